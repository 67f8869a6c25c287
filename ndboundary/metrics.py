"""Measures of a relaxed boundary against a known smooth truth (fidelity, smoothness)."""

from __future__ import annotations

import numpy as np

from .levelset import LevelSet

__all__ = ["as_complex", "closed_curve_length", "curve_distance", "fidelity", "level_set_distance", "sample_points"]


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


def level_set_distance(a, b) -> np.ndarray:
    """For every point of the level set ``a``, its distance to the level set ``b``.

    Exact for curves (``b`` made of segments) and surfaces (triangles): every simplex
    that can hold a point nearer than ``b``'s nearest vertex is measured (those whose
    centroid lies within that distance plus the largest centroid-to-corner distance).
    For level sets of higher dimension, the distance to ``b``'s nearest point, an upper
    bound. Distances between vertex sets alone overstate how far two nearby level sets
    lie apart by up to half the spacing of their points, wherever a point slides along
    the curve.

    Examples
    --------
    >>> from ndboundary import marching_simplices
    >>> from ndboundary.datasets import kuhn_grid, circle
    >>> from ndboundary.metrics import level_set_distance
    >>> mesh = kuhn_grid(16, 2)
    >>> a = marching_simplices(mesh.points, mesh.simplices, circle(mesh.points), 0.0)
    >>> b = marching_simplices(mesh.points, mesh.simplices, circle(mesh.points) - 1e-3, 0.0)
    >>> d = level_set_distance(a, b)  # circles of radius 0.6 and 0.601, as polygons
    >>> bool(0.0009 < d.min() and d.max() < 0.0011), float(level_set_distance(a, a).max())
    (True, 0.0)
    """
    from scipy.spatial import cKDTree

    if b.n_points == 0:
        return np.full(a.n_points, np.inf)
    best = cKDTree(b.points).query(a.points)[0]
    m = b.simplices.shape[1] if b.n_simplices else 0
    if m not in (2, 3) or a.n_points == 0:
        return best
    corners = b.points[b.simplices]
    centroids = corners.mean(axis=1)
    reach = float(np.linalg.norm(corners - centroids[:, None], axis=2).max())
    found = cKDTree(centroids).query_ball_point(a.points, best + reach)
    counts = np.fromiter((len(f) for f in found), dtype=np.int64, count=a.n_points)
    rows = np.repeat(np.arange(a.n_points), counts)
    cand = np.fromiter((c for f in found for c in f), dtype=np.int64, count=int(counts.sum()))
    dist = _point_simplex_distance(a.points[rows], corners[cand])
    np.minimum.at(best, rows, dist)
    return best


def _point_simplex_distance(p, corners):
    """Distance from each point ``p[i]`` to the segment or triangle ``corners[i]``."""

    def to_segment(p, s0, s1):
        e = s1 - s0
        t = np.clip(np.einsum("ij,ij->i", p - s0, e) / np.maximum(np.einsum("ij,ij->i", e, e), 1e-300), 0.0, 1.0)
        return np.linalg.norm(p - s0 - t[:, None] * e, axis=1)

    if corners.shape[1] == 2:
        return to_segment(p, corners[:, 0], corners[:, 1])
    v0, v1, v2 = corners[:, 0], corners[:, 1], corners[:, 2]
    e1, e2, w = v1 - v0, v2 - v0, p - v0
    # the projection onto the triangle's plane, in barycentric coordinates
    d11, d12, d22 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    w1, w2 = np.einsum("ij,ij->i", w, e1), np.einsum("ij,ij->i", w, e2)
    det = np.maximum(d11 * d22 - d12 * d12, 1e-300)
    s, t = (d22 * w1 - d12 * w2) / det, (d11 * w2 - d12 * w1) / det
    inside = (s >= 0) & (t >= 0) & (s + t <= 1)
    plane = np.linalg.norm(w - s[:, None] * e1 - t[:, None] * e2, axis=1)
    edges = np.minimum(np.minimum(to_segment(p, v0, v1), to_segment(p, v1, v2)), to_segment(p, v2, v0))
    return np.where(inside, plane, edges)


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
