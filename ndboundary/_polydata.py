"""Example polygon and polyhedral domains: jittered quad and hexahedral grids, clipped Voronoi polygons.

Companions of :func:`ndboundary.datasets.kuhn_grid`; nothing is downloaded.
"""

from __future__ import annotations

import numpy as np

from .polygon import PolygonMesh
from .polyhedral import PolyhedralMesh

__all__ = ["quad_grid", "hex_grid", "voronoi_polygons"]


def _grid_points(n, dim, jitter, lo, hi, random_state):
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    if not 0 <= jitter < 0.5:
        raise ValueError(f"jitter must be in [0, 0.5), got {jitter}")
    n = int(n)
    s = (hi - lo) / n
    axes = np.meshgrid(*([np.arange(n + 1)] * dim), indexing="ij")
    grid = np.stack([a.ravel() for a in axes], axis=1)
    points = lo + s * grid.astype(np.float64)
    if jitter > 0:
        rng = np.random.default_rng(random_state)
        interior = np.all((grid > 0) & (grid < n), axis=1)
        points[interior] += rng.uniform(-jitter * s, jitter * s, size=(int(interior.sum()), dim))
    strides = (n + 1) ** np.arange(dim - 1, -1, -1)
    cells = np.stack(np.meshgrid(*([np.arange(n)] * dim), indexing="ij"), axis=-1).reshape(-1, dim)
    return points, cells @ strides, strides


def quad_grid(n, *, jitter=0.0, lo=-1.0, hi=1.0, random_state=None, **kwargs):
    """Quadrilateral grid of the square ``[lo, hi]^2`` with ``n`` cells a side.

    Interior vertices are moved by up to ``jitter * (hi - lo) / n`` along each axis,
    uniformly at random; below 0.5 every quad stays simple and counter-clockwise (it
    may become non-convex, which the Green-Gauss gradient handles).

    Parameters
    ----------
    n : int
    jitter : float, default=0.0
        Fraction of the cell size, in [0, 0.5).
    lo, hi : float, default=-1.0, 1.0
    random_state : int, Generator or None
    **kwargs
        Passed to :class:`~ndboundary.PolygonMesh` (``laplacian``, ``stabilization``).

    Returns
    -------
    PolygonMesh
        ``(n + 1)^2`` vertices, ``n^2`` counter-clockwise quads.
    """
    points, origin, (sx, sy) = _grid_points(n, 2, jitter, lo, hi, random_state)
    quads = np.stack([origin, origin + sx, origin + sx + sy, origin + sy], axis=1)
    return PolygonMesh(points, quads, **kwargs)


def hex_grid(n, *, jitter=0.0, lo=-1.0, hi=1.0, random_state=None, **kwargs):
    """Hexahedral grid of the cube ``[lo, hi]^3`` with ``n`` cells a side.

    Parameters
    ----------
    n : int
    jitter : float, default=0.0
        Fraction of the cell size by which interior vertices move along each axis, in [0, 0.5).
        The faces of jittered hexahedra are not planar; the Green-Gauss gradient on the
        fan of each face stays exact on linear functions.
    lo, hi : float, default=-1.0, 1.0
    random_state : int, Generator or None
    **kwargs
        Passed to :class:`~ndboundary.PolyhedralMesh`.

    Returns
    -------
    PolyhedralMesh
        ``(n + 1)^3`` vertices, ``n^3`` hexahedra.
    """
    points, o, (sx, sy, sz) = _grid_points(n, 3, jitter, lo, hi, random_state)
    bottom = [o, o + sx, o + sx + sy, o + sy]
    hexes = np.stack(bottom + [b + sz for b in bottom], axis=1)
    return PolyhedralMesh.from_hexahedra(points, hexes, **kwargs)


def voronoi_polygons(n, *, jitter=0.25, lo=-1.0, hi=1.0, random_state=None, **kwargs):
    """Voronoi cells of ``n x n`` jittered grid sites, clipped to the square ``[lo, hi]^2``.

    The sites are the cell centres of an ``n x n`` grid moved by up to ``jitter`` of the
    cell size. Mirroring the sites across the four sides makes the Voronoi cells of the
    original sites exactly the clipped cells; vertices closer than ``1e-9`` of the cell
    size are merged.

    Parameters
    ----------
    n : int
    jitter : float, default=0.25
        In [0, 0.5). With 0, four cells meet at each vertex.
    lo, hi : float, default=-1.0, 1.0
    random_state : int, Generator or None
    **kwargs
        Passed to :class:`~ndboundary.PolygonMesh`.

    Returns
    -------
    PolygonMesh
        ``n^2`` convex polygons, counter-clockwise.
    """
    from scipy.spatial import Voronoi

    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    if not 0 <= jitter < 0.5:
        raise ValueError(f"jitter must be in [0, 0.5), got {jitter}")
    n = int(n)
    s = (hi - lo) / n
    c = lo + s * (np.arange(n) + 0.5)
    sites = np.stack(np.meshgrid(c, c, indexing="ij"), axis=-1).reshape(-1, 2)
    rng = np.random.default_rng(random_state)
    sites = sites + rng.uniform(-jitter * s, jitter * s, size=sites.shape)
    mirrors = [sites]
    for axis in range(2):
        for wall in (lo, hi):
            m = sites.copy()
            m[:, axis] = 2 * wall - m[:, axis]
            mirrors.append(m)
    vor = Voronoi(np.concatenate(mirrors))
    regions = [vor.regions[vor.point_region[i]] for i in range(sites.shape[0])]
    verts = np.clip(vor.vertices, lo, hi)
    # merge coincident vertices (cocircular sites give repeated Voronoi vertices)
    key = np.round((verts - lo) / (s * 1e-9)).astype(np.int64)
    _, merge = np.unique(key, axis=0, return_inverse=True)
    merge = merge.reshape(-1)
    used, remap = np.unique(merge[np.concatenate(regions)], return_inverse=True)
    points = np.zeros((used.size, 2))
    points[remap] = verts[np.concatenate(regions)]
    polys, k = [], 0
    for reg, site in zip(regions, sites):
        ids = remap[k:k + len(reg)]
        k += len(reg)
        ids = ids[np.r_[True, ids[1:] != ids[:-1]]]
        if ids.size > 1 and ids[0] == ids[-1]:
            ids = ids[:-1]
        p = points[ids] - site
        polys.append(ids[np.argsort(np.arctan2(p[:, 1], p[:, 0]))])
    return PolygonMesh(points, polys, **kwargs)
