"""Measures of a relaxed boundary against a known smooth truth (fidelity, smoothness)."""

from __future__ import annotations

import numpy as np

from .levelset import LevelSet

__all__ = ["as_complex", "closed_curve_length", "curve_distance", "fidelity", "sample_points"]


def as_complex(points, simplices) -> LevelSet:
    """Wrap a subset complex (e.g. the jagged boundary's facets) as a compact :class:`LevelSet`."""
    simplices = np.asarray(simplices, dtype=np.int64)
    used, inv = np.unique(simplices, return_inverse=True)
    return LevelSet(
        np.asarray(points)[used], inv.reshape(simplices.shape), np.zeros((used.size, 2), dtype=np.int64), 0.0
    )


def sample_points(complex_) -> np.ndarray:
    """The vertices and simplex centroids of a complex: where distances are measured."""
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
    """Distance function to a densely sampled curve or surface, by a k-d tree."""
    from scipy.spatial import cKDTree

    tree = cKDTree(np.asarray(curve_points))

    def distance(x):
        return tree.query(x)[0]

    return distance
