"""Level sets of piecewise-linear functions on simplices ("marching simplices"), any dimension.

On every edge whose end values lie on both sides of ``c`` (a value exactly ``c``
counts as above) a vertex is placed at the linear crossing; it is shared by every
simplex around that edge. Inside a k-simplex with ``a`` vertices below and ``b``
above, the crossing is the product of simplices ``Delta^{a-1} x Delta^{b-1}``; it is
cut into ``C(k-1, a-1)`` (k-1)-simplices by the staircase triangulation taken in
the global vertex order, which agrees on shared faces, so the result is a
conforming complex: a closed polyline or a watertight surface where the boundary
is closed. Every output simplex is oriented so that the function increases along
its normal (for k = dim, by the sign of a determinant in space; for k < dim, in
the oriented frame of the input simplex).
"""

from __future__ import annotations

from functools import cache
from itertools import combinations
from math import factorial

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._compiled import unique_pairs
from ._compiled_geometry import crossing_orientations, crossing_pattern, full_simplex_volumes

__all__ = ["LevelSet", "marching_simplices"]


def simplex_measures(points, simplices):
    """Unsigned length / area / volume of each simplex (any k <= dim, k >= 1).

    Full-dimensional simplices up to 3-D are measured by one compiled pass, triangles in
    space by their edges' cross product and segments by their length; the others by the
    Gram determinant of their edges, in blocks.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.levelset import simplex_measures
    >>> simplex_measures(np.array([[0.0, 0, 0], [1, 0, 0], [0, 2, 0]]), np.array([[0, 1, 2], [1, 0, 2]])).tolist()
    [1.0, 1.0]
    """
    k = simplices.shape[1] - 1
    if k == points.shape[1] <= 3:
        return full_simplex_volumes(points, simplices)
    out = np.empty(simplices.shape[0])
    for lo in range(0, simplices.shape[0], 1 << 18):
        X = points[simplices[lo : lo + (1 << 18)]]
        E = X[:, 1:, :] - X[:, :1, :]
        part = out[lo : lo + E.shape[0]]
        if k == 1:
            part[:] = np.sqrt(np.einsum("ij,ij->i", E[:, 0], E[:, 0]))
        elif k == 2 and points.shape[1] == 3:
            c = np.cross(E[:, 0], E[:, 1])
            part[:] = np.sqrt(np.einsum("ij,ij->i", c, c))
        elif k == points.shape[1]:
            part[:] = np.abs(np.linalg.det(E))
        else:
            part[:] = np.sqrt(np.clip(np.linalg.det(E @ E.transpose(0, 2, 1)), 0, None))
    return out / factorial(k)


class LevelSet:
    """A (k-1)-dimensional simplicial complex: the level set of a function on k-simplices.

    Attributes
    ----------
    points : ndarray of shape (n_points, dim)
    simplices : ndarray of int of shape (n_simplices, k)
        Vertex indices; segments for k = 2, triangles for k = 3, tetrahedra for k = 4.
    edges : ndarray of int of shape (n_points, 2)
        The domain edge each point lies on.
    value : float
        The level.

    Examples
    --------
    >>> from ndboundary import marching_simplices
    >>> from ndboundary.datasets import kuhn_grid, circle
    >>> mesh = kuhn_grid(16, 2)
    >>> curve = marching_simplices(mesh.points, mesh.simplices, circle(mesh.points), 0.0)
    >>> curve
    LevelSet(value=0.0, n_points=62, n_simplices=62)
    >>> round(curve.measure(), 6), curve.is_closed(), curve.n_components(), curve.euler_characteristic()
    (3.762175, True, 1, 0)
    """

    def __init__(self, points, simplices, edges, value):
        self.points = points
        self.simplices = simplices
        self.edges = edges
        self.value = float(value)

    @property
    def n_points(self) -> int:
        """Number of points."""
        return int(self.points.shape[0])

    @property
    def n_simplices(self) -> int:
        """Number of simplices."""
        return int(self.simplices.shape[0])

    def __len__(self):
        return self.n_simplices

    def simplex_measures(self) -> np.ndarray:
        """Length / area / volume of every output simplex."""
        if self.simplices.shape[1] == 1:
            return np.ones(self.n_simplices)
        return simplex_measures(self.points, self.simplices)

    def measure(self) -> float:
        """Total length (curves), area (surfaces) or volume."""
        return float(self.simplex_measures().sum())

    def facets(self) -> np.ndarray:
        """All oriented boundary facets of the output simplices (with repetition), shape (m, k-1)."""
        k = self.simplices.shape[1]
        out = []
        for i in range(k):
            f = np.delete(self.simplices, i, axis=1)
            if i % 2 == 1 and f.shape[1] >= 2:
                f = f[:, [1, 0] + list(range(2, f.shape[1]))]
            out.append(f)
        return np.concatenate(out) if out else np.zeros((0, k - 1), dtype=np.int64)

    def is_closed(self) -> bool:
        """True when every facet is shared by exactly two simplices with opposite orientations
        (for curves: every point starts one segment and ends one).
        """
        if self.n_simplices == 0 or self.simplices.shape[1] < 2:
            return False
        if self.simplices.shape[1] == 3 and self.n_points < 3_037_000_499:
            return _closed_triangles(self.simplices, self.n_points)
        f = self.facets()
        if f.shape[1] == 1:
            # curves: every point starts exactly one segment and ends exactly one
            starts = np.bincount(self.simplices[:, 0], minlength=self.n_points)
            ends = np.bincount(self.simplices[:, 1], minlength=self.n_points)
            used = (starts + ends) > 0
            return bool(np.all(starts[used] == 1) and np.all(ends[used] == 1))
        return _closed_facets(f, self.n_points)

    def n_components(self) -> int:
        """Number of connected components."""
        if self.n_simplices == 0:
            return 0
        k = self.simplices.shape[1]
        i = np.repeat(self.simplices[:, :1], k - 1, axis=1).ravel()
        j = self.simplices[:, 1:].ravel()
        g = sp.coo_matrix((np.ones(i.size), (i, j)), shape=(self.n_points, self.n_points))
        n, lab = connected_components(g, directed=False)
        used = np.zeros(self.n_points, dtype=bool)
        used[self.simplices.ravel()] = True
        return int(np.unique(lab[used]).size)

    def euler_characteristic(self) -> int:
        """Alternating sum of the numbers of faces of every dimension."""
        if self.n_simplices == 0:
            return 0
        k = self.simplices.shape[1]
        chi = 0
        for d in range(1, k + 1):
            faces = np.concatenate([np.sort(self.simplices[:, list(c)], axis=1) for c in combinations(range(k), d)])
            chi += (-1) ** (d - 1) * np.unique(faces, axis=0).shape[0]
        return int(chi)

    def __repr__(self):
        return f"LevelSet(value={self.value}, n_points={self.n_points}, n_simplices={self.n_simplices})"


def _closed_facets(f, n):
    """Whether each oriented facet of ``f`` (point ids below ``n``) is there once and its
    reverse once, compared as rows of sorted ids with the parity of their sorting.
    """
    key = _row_keys(_canonical_oriented(f), n)
    axis = 0 if key.ndim == 2 else None
    _, counts = np.unique(key, axis=axis, return_counts=True)
    if np.any(counts != 1):
        return False
    rev = f.copy()
    rev[:, [0, 1]] = rev[:, [1, 0]]
    both = np.concatenate([key, _row_keys(_canonical_oriented(rev), n)])
    _, c2 = np.unique(both, axis=axis, return_counts=True)
    return bool(np.all(c2 == 2))


def _closed_triangles(simplices, n):
    """Whether every oriented edge of the triangles ``simplices`` (point ids below ``n``,
    ``n ** 2`` within 63 bits) is theirs once and its reverse once: each edge as one
    integer, sorted, and the reverses looked up in them. An atlas's background has tens
    of millions of triangles; this holds a few integers per edge, where comparing rows
    of sorted ids held about forty bytes per edge several times over.
    """
    s = np.asarray(simplices, dtype=np.int64)
    key = np.concatenate([row_codes(s[:, edge], n) for edge in ([0, 1], [1, 2], [2, 0])])
    key.sort()
    if (key[1:] == key[:-1]).any():  # an edge twice in one direction
        return False
    reverse = key % n
    reverse *= n
    reverse += key // n
    at = np.searchsorted(key, reverse)
    at[at == key.size] = 0
    return bool((key[at] == reverse).all())


def _canonical_oriented(f):
    """Each oriented facet as its sorted vertices plus the parity of the sorting permutation."""
    f = np.asarray(f)
    order = np.argsort(f, axis=1)
    srt = np.take_along_axis(f, order, axis=1)
    parity = _permutation_parity(order)
    return np.concatenate([srt, parity[:, None]], axis=1)


def _row_keys(rows, n):
    """One integer per row of ``rows`` (point ids below ``n``, then a parity bit), equal
    for equal rows, when they fit in 63 bits (a sort of integers, not of rows); else the
    rows themselves.

    Examples
    --------
    >>> import numpy as np
    >>> _row_keys(np.array([[1, 2, 0], [1, 2, 1], [0, 2, 1]]), 3).tolist()
    [10, 11, 5]
    """
    ids = rows.shape[1] - 1
    if ids * np.log2(max(n, 2)) + 1 > 62:
        return rows
    return row_codes(rows[:, :ids], n) * 2 + rows[:, -1]


def row_codes(rows, n):
    """Each row of ``rows`` (ids below ``n``, ``n ** columns`` within 63 bits) as one
    integer, in the rows' lexicographic order.

    Examples
    --------
    >>> import numpy as np
    >>> row_codes(np.array([[1, 2], [0, 2]]), 3).tolist()
    [5, 2]
    """
    code = np.zeros(rows.shape[0], dtype=np.int64)
    for c in range(rows.shape[1]):
        code = code * n + rows[:, c]
    return code


def _permutation_parity(perm):
    """Parity (0 even, 1 odd) of each row permutation, by counting inversions."""
    m = perm.shape[1]
    inv = np.zeros(perm.shape[0], dtype=np.int64)
    for i in range(m):
        for j in range(i + 1, m):
            inv += perm[:, i] > perm[:, j]
    return inv % 2


@cache
def staircase_paths(a, b):
    """Monotone lattice paths from (0, 0) to (a-1, b-1): each is a list of (below, above) positions.

    They index the staircase triangulation of a product of simplices, the one that agrees
    on shared faces when vertices are taken in their global order.

    Examples
    --------
    >>> from ndboundary.levelset import staircase_paths
    >>> staircase_paths(2, 2).tolist()
    [[[0, 0], [1, 0], [1, 1]], [[0, 0], [0, 1], [1, 1]]]
    """
    paths = []

    def walk(p, q, acc):
        acc = acc + [(p, q)]
        if p == a - 1 and q == b - 1:
            paths.append(acc)
            return
        if p < a - 1:
            walk(p + 1, q, acc)
        if q < b - 1:
            walk(p, q + 1, acc)

    walk(0, 0, [])
    return np.array(paths, dtype=np.int64)  # (n_paths, a+b-1, 2)


def marching_simplices(points, simplices, values, value=0.5):
    """Extract the level set ``values == value`` of a piecewise-linear function.

    Parameters
    ----------
    points : ndarray of shape (n_vertices, dim)
    simplices : ndarray of int of shape (n_simplices, k + 1)
    values : ndarray of shape (n_vertices,)
        Must be finite.
    value : float, default=0.5

    Returns
    -------
    LevelSet

    Examples
    --------
    A function rising from 0 at the first vertex to 1 at the others crosses 1/2 at the
    midpoints of the two edges that leave the first vertex:

    >>> from ndboundary import marching_simplices
    >>> seg = marching_simplices([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [0.0, 1.0, 1.0])
    >>> seg.points.tolist(), seg.simplices.tolist(), seg.edges.tolist()
    ([[0.5, 0.0], [0.0, 0.5]], [[1, 0]], [[0, 1], [0, 2]])

    The level set of the distance to a sphere, on a tetrahedral grid, is a closed surface:

    >>> from ndboundary.datasets import kuhn_grid, ball
    >>> grid = kuhn_grid(6, 3)
    >>> sphere = marching_simplices(grid.points, grid.simplices, ball(grid.points), 0.0)
    >>> sphere.simplices.shape, sphere.is_closed(), sphere.euler_characteristic()
    ((360, 3), True, 2)
    """
    points = np.asarray(points, dtype=np.float64)
    simplices = np.asarray(simplices, dtype=np.int64)
    values = np.asarray(values, dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise ValueError("values contain NaN or infinite entries")
    V, D = points.shape
    if simplices.ndim != 2 or values.shape != (V,):
        raise ValueError(
            f"simplices must be 2-D and values one per point ({V}), got shapes {simplices.shape} and {values.shape}"
        )
    if simplices.size and (simplices.min() < 0 or simplices.max() >= V):
        raise ValueError(f"simplices index vertices outside 0..{V - 1}")
    k1 = simplices.shape[1]
    table, n_paths = _crossing_table(k1)
    S, parity, E, owner, local = crossing_pattern(
        np.ascontiguousarray(simplices), np.ascontiguousarray(values >= value), table, n_paths
    )  # the simplices crossed, their vertices sorted (the staircase uses that order)
    if S.shape[0] == 0:
        return LevelSet(
            np.zeros((0, D)), np.zeros((0, k1 - 1), dtype=np.int64), np.zeros((0, 2), dtype=np.int64), value
        )
    m, k = E.shape[:2]
    flat = E.reshape(-1, 2)
    if V < np.iinfo(np.int32).max:  # the distinct edges by a counting sort, sorted as (below, above)
        ue, inv = unique_pairs(flat[:, 0].astype(np.int32), flat[:, 1].astype(np.int32), V)
        ue = ue.astype(np.int64)
    else:
        keys = flat[:, 0] * V + flat[:, 1]
        ukeys, inv = np.unique(keys, return_inverse=True)
        ue = np.stack([ukeys // V, ukeys % V], axis=1)
    f0, f1 = values[ue[:, 0]], values[ue[:, 1]]
    t = (value - f0) / (f1 - f0)  # f1 >= value > f0, so the denominator is positive
    pts = points[ue[:, 0]] + t[:, None] * (points[ue[:, 1]] - points[ue[:, 0]])
    tris = inv.reshape(m, k)
    if k >= 2:
        flip = _orientation(points, values, S, parity, owner, local, t[tris]) < 0
        tris[flip, 0], tris[flip, 1] = tris[flip, 1].copy(), tris[flip, 0].copy()
    at_vertex = f1 == value
    if at_vertex.any():
        pts, tris, ue = _merge_vertex_crossings(pts, tris, ue, at_vertex)
    return LevelSet(pts, tris, ue, value)


@cache
def _crossing_table(k1):
    """For simplices of ``k1`` vertices, the output simplices of each pattern of vertices
    above the level (bit ``i`` of the code: sorted vertex ``i``): ``table[code, p, j]``
    the local positions (below, above) of the edge that vertex ``j`` of output simplex
    ``p`` lies on, along the :func:`staircase_paths` of the pattern, and ``n_paths[code]``
    how many there are (none for the codes with every vertex on one side).
    """
    patterns = {}
    for code in range(1, (1 << k1) - 1):
        bits = np.array([(code >> i) & 1 for i in range(k1)], dtype=bool)
        lo, hi = np.flatnonzero(~bits), np.flatnonzero(bits)
        paths = staircase_paths(lo.size, hi.size)  # (n_paths, k, 2) positions in lo / hi
        patterns[code] = np.stack([lo[paths[..., 0]], hi[paths[..., 1]]], axis=-1)
    most = max((loc.shape[0] for loc in patterns.values()), default=1)
    table = np.zeros((1 << k1, most, k1 - 1, 2), dtype=np.int8)
    n_paths = np.zeros(1 << k1, dtype=np.int64)
    for code, loc in patterns.items():
        table[code, : loc.shape[0]] = loc
        n_paths[code] = loc.shape[0]
    return table, n_paths


def _merge_vertex_crossings(pts, tris, ue, at_vertex):
    """One point for the crossings of all the edges that end at a vertex whose value is
    exactly the level (they all sit on it), and no output simplex that this flattens.
    """
    key = np.where(at_vertex, -1 - ue[:, 1], np.arange(ue.shape[0]))
    _, first, remap = np.unique(key, return_index=True, return_inverse=True)
    tris = remap.reshape(-1)[tris]
    k = tris.shape[1]
    distinct = np.ones(tris.shape[0], dtype=bool)
    for i in range(k):
        for j in range(i + 1, k):
            distinct &= tris[:, i] != tris[:, j]
    tris = tris[distinct]
    used, tris = np.unique(tris, return_inverse=True)
    keep = first[used]
    return pts[keep], tris.reshape(-1, k), ue[keep]


#: Owners of up to this many dimensions (tetrahedra) orient their output simplices by one
#: compiled pass (:func:`~ndboundary._compiled_geometry.crossing_orientations`), larger ones
#: by blocks of arrays (:data:`ORIENTATION_BLOCK`).
COMPILED_ORIENTATION_DIM = 3

#: Output simplices whose orientation is found at once: the temporaries of a block stay
#: small (a few megabytes), where a level set of millions of triangles took gigabytes.
ORIENTATION_BLOCK = 1 << 17


def _orientation(points, values, S, parity, owner, local, t):
    """Sign telling whether each output simplex has the function increasing along its normal.

    Computed in the reference (barycentric) coordinates of the owning simplex, where no
    element is thin, then carried to space by the owner's orientation: the sign of its
    volume for full-dimensional simplices, its winding as given otherwise. Owners of up
    to :data:`COMPILED_ORIENTATION_DIM` dimensions in one compiled pass; larger ones in
    blocks of :data:`ORIENTATION_BLOCK` simplices, one after another.
    """
    m, k1 = t.shape[0], S.shape[1]
    full = k1 - 1 == points.shape[1]
    if k1 - 1 <= COMPILED_ORIENTATION_DIM:  # one pass, no arrays per simplex
        out = np.empty(m)
        crossing_orientations(
            np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(values, dtype=np.float64),
            np.ascontiguousarray(S, dtype=np.int64), np.ascontiguousarray(owner, dtype=np.int64),
            np.ascontiguousarray(local, dtype=np.int8), np.ascontiguousarray(t, dtype=np.float64),
            np.zeros(0) if full else np.ascontiguousarray(parity, dtype=np.float64), full, out,
        )  # fmt: skip
        return out
    if full:
        own = np.empty(S.shape[0])
        for lo in range(0, S.shape[0], ORIENTATION_BLOCK):
            X = points[S[lo : lo + ORIENTATION_BLOCK]]
            own[lo : lo + ORIENTATION_BLOCK] = np.sign(_det(X[:, 1:, :] - X[:, :1, :]))
    else:
        own = parity
    out = np.empty(m)
    for lo in range(0, m, ORIENTATION_BLOCK):
        block = slice(lo, lo + ORIENTATION_BLOCK)
        out[block] = _reference_sign(values, S, owner[block], local[block], t[block]) * own[owner[block]]
    return out


def _reference_sign(values, S, owner, local, t):
    """The sign of each output simplex's orientation against the function's gradient, in
    the reference coordinates of its owner ``S[owner]``.
    """
    m, k = t.shape
    k1 = S.shape[1]
    # output vertex j lies at (1 - t) e_a + t e_b in barycentric coordinates, (a, b) its
    # edge's ends; dropping the first coordinate leaves reference coordinates in R^(k1 - 1)
    xi = np.zeros((m, k, k1 - 1))
    for j in range(k):
        a, b, tj = local[:, j, 0], local[:, j, 1], t[:, j]
        for c in range(1, k1):
            xi[:, j, c - 1] = np.where(a == c, 1.0 - tj, 0.0) + np.where(b == c, tj, 0.0)
    f = values[S[owner]]
    dphi = f[:, 1:] - f[:, :1]  # gradient of the function in reference coordinates
    cols = np.concatenate([xi[:, 1:, :] - xi[:, :1, :], dphi[:, None, :]], axis=1)
    return np.sign(_det(cols))


def _det(M):
    """The determinants of a stack of square matrices, shape ``M.shape[:-2]``: written out
    up to 3 x 3, where numpy's loop over LAPACK costs about a microsecond a matrix (seconds
    for the level set of a large volume).
    """
    n = M.shape[-1]
    if n == 1:
        return M[..., 0, 0].copy()
    if n == 2:
        return M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]
    if n == 3:
        a, b, c = M[..., 0, 0], M[..., 0, 1], M[..., 0, 2]
        d, e, f = M[..., 1, 0], M[..., 1, 1], M[..., 1, 2]
        g, h, i = M[..., 2, 0], M[..., 2, 1], M[..., 2, 2]
        return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return np.linalg.det(M)


def sorting_parity(simplices):
    """+1 where sorting a simplex's vertices is an even permutation, -1 where odd.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.levelset import sorting_parity
    >>> sorting_parity(np.array([[0, 1, 2], [1, 0, 2], [2, 0, 1]])).tolist()
    [1, -1, 1]
    """
    order = np.argsort(simplices, axis=1)
    return 1 - 2 * _permutation_parity(order)
