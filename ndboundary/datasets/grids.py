"""Example domains: jittered simplicial, quad and hexahedral grids, an icosphere, Voronoi polygons."""

from __future__ import annotations

from itertools import permutations

import numpy as np

from ..domains import PolygonMesh, PolyhedralMesh, SimplicialComplex

__all__ = ["hex_grid", "icosphere", "kuhn_grid", "quad_grid", "voronoi_polygons"]


def kuhn_grid(n, dim=2, *, jitter=0.0, lo=-1.0, hi=1.0, random_state=None):
    """Kuhn (Freudenthal) triangulation of the cube ``[lo, hi]^dim`` with ``n`` cells a side.

    Each cube is split into ``dim!`` simplices sharing its main diagonal (2 triangles,
    6 tetrahedra, 24 4-simplices). Interior vertices are moved by up to
    ``jitter * (hi - lo) / n`` along each axis, uniformly at random.

    Parameters
    ----------
    n : int
    dim : int, default=2
    jitter : float, default=0.0
        Fraction of the cell size; below 0.5 keeps every simplex positive.
    lo, hi : float
    random_state : int, Generator or None

    Returns
    -------
    SimplicialComplex

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> kuhn_grid(10, 2)
    SimplicialComplex(n_vertices=121, n_elements=200, simplex_dim=2, dim=2)
    >>> kuhn_grid(3, 3).n_elements  # 6 tetrahedra per cube
    162
    >>> bool(kuhn_grid(4, 2, jitter=0.3, random_state=0).volumes.min() > 0)
    True
    """
    if n < 1 or dim < 1:
        raise ValueError(f"n and dim must be positive, got n={n}, dim={dim}")
    if not 0 <= jitter < 0.5:
        raise ValueError(f"jitter must be in [0, 0.5), got {jitter}")
    s = (hi - lo) / n
    axes = np.meshgrid(*([np.arange(n + 1)] * dim), indexing="ij")
    grid = np.stack([a.ravel() for a in axes], axis=1)
    points = lo + s * grid.astype(np.float64)
    strides = (n + 1) ** np.arange(dim - 1, -1, -1)
    cells = np.stack(np.meshgrid(*([np.arange(n)] * dim), indexing="ij"), axis=-1).reshape(-1, dim)
    origin = cells @ strides
    simplices = []
    for perm in permutations(range(dim)):
        steps = np.cumsum([0] + [strides[p] for p in perm])
        simplices.append(origin[:, None] + steps[None, :])
    simplices = np.concatenate(simplices)
    # orient every simplex positively
    neg = _signed_volumes(points, simplices) < 0
    simplices[neg, 0], simplices[neg, 1] = simplices[neg, 1].copy(), simplices[neg, 0].copy()
    if jitter > 0:
        rng = np.random.default_rng(random_state)
        interior = np.all((grid > 0) & (grid < n), axis=1)
        shift = np.zeros_like(points)
        shift[interior] = rng.uniform(-jitter * s, jitter * s, size=(interior.sum(), dim))
        # halve the shift of the vertices of any simplex the jitter would flatten or invert
        floor = 0.1 * s**dim / np.prod(np.arange(1, dim + 1))
        for _ in range(30):
            bad = _signed_volumes(points + shift, simplices) < floor
            if not bad.any():
                break
            shift[np.unique(simplices[bad])] *= 0.5
        points = points + shift
    return SimplicialComplex(points, simplices)


def _signed_volumes(points, simplices):
    X = points[simplices]
    return np.linalg.det(X[:, 1:, :] - X[:, :1, :])


def icosphere(subdivisions=5, radius=1.0):
    """Triangulated sphere by repeated midpoint subdivision of an icosahedron.

    ``subdivisions=5`` gives 10 242 vertices and 20 480 triangles, outward oriented.

    Examples
    --------
    >>> from ndboundary.datasets import icosphere
    >>> icosphere(1)
    SimplicialComplex(n_vertices=42, n_elements=80, simplex_dim=2, dim=3)
    >>> round(float(icosphere(3).A.sum()), 4)  # close to 4 pi = 12.5664
    12.5065
    """
    p = (1 + 5**0.5) / 2
    v = np.array(
        [
            [-1, p, 0],
            [1, p, 0],
            [-1, -p, 0],
            [1, -p, 0],
            [0, -1, p],
            [0, 1, p],
            [0, -1, -p],
            [0, 1, -p],
            [p, 0, -1],
            [p, 0, 1],
            [-p, 0, -1],
            [-p, 0, 1],
        ],
        dtype=np.float64,
    )
    f = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
        key = np.sort(e, axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        mid = v[uniq].mean(axis=1)
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        nf = f.shape[0]
        m = v.shape[0] + inv.reshape(3, nf).T  # midpoints of edges 01, 12, 20
        v = np.concatenate([v, mid])
        f = np.concatenate(
            [
                np.stack([f[:, 0], m[:, 0], m[:, 2]], 1),
                np.stack([f[:, 1], m[:, 1], m[:, 0]], 1),
                np.stack([f[:, 2], m[:, 2], m[:, 1]], 1),
                m,
            ]
        )
    return SimplicialComplex(radius * v, f)


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

    Examples
    --------
    >>> from ndboundary.datasets import quad_grid
    >>> mesh = quad_grid(4)
    >>> mesh.n_vertices, mesh.n_elements, float(mesh.A.sum())
    (25, 16, 4.0)
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

    Examples
    --------
    >>> from ndboundary.datasets import hex_grid
    >>> mesh = hex_grid(2)
    >>> mesh.n_vertices, mesh.n_faces, mesh.n_elements, round(float(mesh.A.sum()), 6)
    (27, 36, 8, 8.0)
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

    Examples
    --------
    >>> from ndboundary.datasets import voronoi_polygons
    >>> mesh = voronoi_polygons(3, random_state=0)
    >>> mesh.n_elements, round(float(mesh.A.sum()), 6)  # the cells tile [-1, 1]^2
    (9, 4.0)
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
    for reg, site in zip(regions, sites, strict=True):
        ids = remap[k : k + len(reg)]
        k += len(reg)
        ids = ids[np.r_[True, ids[1:] != ids[:-1]]]
        if ids.size > 1 and ids[0] == ids[-1]:
            ids = ids[:-1]
        p = points[ids] - site
        polys.append(ids[np.argsort(np.arctan2(p[:, 1], p[:, 0]))])
    return PolygonMesh(points, polys, **kwargs)
