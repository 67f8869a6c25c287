"""Measures of a relaxed boundary against a known smooth truth (fidelity, smoothness)."""

from __future__ import annotations

import numpy as np

from .levelset import LevelSet

__all__ = ["as_complex", "closed_curve_length", "curve_distance", "fidelity", "sample_points"]


def as_complex(points, simplices) -> LevelSet:
    """Wrap a subset complex (e.g. the jagged boundary's facets) as a compact :class:`LevelSet`.

    Only the vertices the simplices use are kept, renumbered in increasing order.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.metrics import as_complex
    >>> mesh = kuhn_grid(10, 2)
    >>> jagged = as_complex(mesh.points, mesh.interface_facets(label_by(mesh, circle) == 1))
    >>> jagged.n_points, jagged.n_simplices, round(jagged.measure(), 6)
    (20, 20, 4.331371)
    """
    simplices = np.asarray(simplices, dtype=np.int64)
    used, inv = np.unique(simplices, return_inverse=True)
    return LevelSet(
        np.asarray(points)[used], inv.reshape(simplices.shape), np.zeros((used.size, 2), dtype=np.int64), 0.0
    )


def sample_points(complex_) -> np.ndarray:
    """The vertices and simplex centroids of a complex: where distances are measured.

    Examples
    --------
    >>> from ndboundary import marching_simplices
    >>> from ndboundary.metrics import sample_points
    >>> seg = marching_simplices([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [0.0, 1.0, 1.0])
    >>> sample_points(seg).tolist()
    [[0.5, 0.0], [0.0, 0.5], [0.25, 0.25]]
    """
    if complex_.n_simplices == 0:
        return np.zeros((0, complex_.points.shape[1]))
    return np.concatenate([complex_.points, complex_.points[complex_.simplices].mean(axis=1)])


def fidelity(complex_, distance, h=1.0):
    """Mean and max of ``distance(x)`` over a complex's vertices and centroids, in units of ``h``.

    Parameters
    ----------
    complex_ : LevelSet
    distance : callable
        Unsigned distance to the true boundary, ``(n, dim) -> (n,)``.
    h : float, default=1.0

    Returns
    -------
    dict with keys ``mean``, ``max``.

    Examples
    --------
    The relaxed boundary of a labelled disc lies within a small fraction of a cell of the
    true circle:

    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.metrics import fidelity
    >>> mesh = kuhn_grid(10, 2)
    >>> result = relax(mesh, label_by(mesh, circle), on="elements")
    >>> fit = fidelity(result.level_set(), circle, h=mesh.mean_edge_length())
    >>> sorted(fit), bool(fit["max"] < 0.5)
    (['max', 'mean'], True)
    """
    x = sample_points(complex_)
    if x.shape[0] == 0:
        return {"mean": float("nan"), "max": float("nan")}
    d = np.abs(distance(x)) / h
    return {"mean": float(d.mean()), "max": float(d.max())}


def closed_curve_length(points):
    """Length of the closed polyline through ``points`` (n, dim), in order.

    Examples
    --------
    >>> from ndboundary.metrics import closed_curve_length
    >>> closed_curve_length([[0, 0], [1, 0], [1, 1], [0, 1]])
    4.0
    """
    points = np.asarray(points, dtype=np.float64)
    return float(np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1).sum())


def curve_distance(curve_points):
    """Distance function to a densely sampled curve or surface, by a k-d tree.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import flower_curve
    >>> from ndboundary.metrics import curve_distance
    >>> distance = curve_distance(flower_curve(2000))
    >>> distance(np.array([[0.0, 0.0], [0.66, 0.0]])).round(6).tolist()
    [0.44, 0.0]
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(np.asarray(curve_points))

    def distance(x):
        return tree.query(x)[0]

    return distance
