"""The splitting kernel of :mod:`ndboundary.partition`.

The upper envelope ``M_r = max(f_0, ..., f_r)`` is built one function at a time. On
the current complex ``M_{r-1}`` is linear on every cell (the cell's region is
constant), so ``d = f_r - M_{r-1}`` is a continuous piecewise-linear function given
by its vertex values, and a cell that ``d`` changes sign on is cut by the hyperplane
``f_r = f_{region}`` of its pair. A k-simplex whose vertices split into ``a``
negative, ``b`` positive and some zero ones is cut into two pieces: the negative one
is the product ``Delta^{a-1} x Delta^b`` (the negative vertices times the crossings
plus the vertex itself), the positive one ``Delta^{b-1} x Delta^a``, each coned over
the zero vertices; both are cut by the staircase triangulation in the global order
of vertex ids (the crossings' order, as in :func:`ndboundary.levelset.marching_simplices`),
which restricts to the same triangulation on every shared face. Every crossing is a
new point keyed by the pair of (global) ids of its edge, so neighbouring cells create
the same point and the complex stays conforming.
"""

from __future__ import annotations

from functools import cache

import numpy as np

from ._compiled_partition import oriented_region_facets, sweep_sparse_compiled
from .levelset import sorting_parity, staircase_paths


@cache
def _templates(code, k1):
    """The two pieces of a cut simplex with sign pattern ``code`` (base 3 over its k1
    sorted vertices: 0 negative, 1 zero, 2 positive): a pair of arrays (m, k1, 2) of
    slots, ``(i, i)`` a vertex, ``(i, j)`` the crossing on the edge from negative i to
    positive j, each sub-simplex oriented like the parent (in sorted order).
    """
    sign = [(code // 3**i) % 3 for i in range(k1)]
    neg = [i for i in range(k1) if sign[i] == 0]
    zero = [i for i in range(k1) if sign[i] == 1]
    pos = [i for i in range(k1) if sign[i] == 2]
    out = []
    for own, other, flip_edge in ((neg, pos, False), (pos, neg, True)):
        simp = []
        for path in staircase_paths(len(own), len(other) + 1):
            slots = []
            for p, q in path:
                if q == 0:
                    slots.append((own[p], own[p]))
                else:
                    e = (own[p], other[q - 1])
                    slots.append(e[::-1] if flip_edge else e)
            simp.append(slots + [(z, z) for z in zero])
        T = np.array(simp, dtype=np.int64)
        # orientation with every crossing at its midpoint: the sign does not depend on
        # where the crossings are (the cut is a projective image of the product)
        m = T.shape[0]
        xi = np.zeros((m, k1, k1))
        rows, cols = np.arange(m)[:, None], np.arange(k1)[None, :]
        np.add.at(xi, (rows, cols, T[..., 0]), 0.5)
        np.add.at(xi, (rows, cols, T[..., 1]), 0.5)
        det = np.linalg.det(xi[:, 1:, 1:] - xi[:, :1, 1:])
        neg_det = det < 0
        T[neg_det, 0], T[neg_det, 1] = T[neg_det, 1].copy(), T[neg_det, 0].copy()
        out.append(T)
    return tuple(out)


@cache
def template_tables(k1):
    """The pieces of every sign pattern of a cut ``(k1 - 1)``-simplex, as flat tables.

    Returns ``(ptr, slots, side)``: the pieces of pattern ``code`` (base 3 over the sorted
    vertices: 0 negative, 1 zero, 2 positive; see
    :func:`_templates`) are rows ``ptr[code]:ptr[code + 1]`` of
    ``slots`` (n, k1, 2) and ``side`` (n,): 0 on the negative side, 1 on the positive one.
    """
    ptr, slots, side = [0], [], []
    for code in range(3**k1):
        digits = [(code // 3**i) % 3 for i in range(k1)]
        pieces = _templates(code, k1) if 0 in digits and 2 in digits else ()
        for s, T in enumerate(pieces):
            slots.append(T)
            side.append(np.full(T.shape[0], s, dtype=np.int64))
        ptr.append(ptr[-1] + sum(T.shape[0] for T in pieces))
    return (
        np.array(ptr, dtype=np.int64),
        np.ascontiguousarray(np.concatenate(slots), dtype=np.int64),
        np.concatenate(side),
    )


class _Complex:
    """Mutable state of the sweep: points, their values, the envelope, cells and regions."""

    def __init__(self, points, simplices, values):
        V = points.shape[0]
        self.X = points
        self.F = values
        self.M = values[:, 0].copy()
        self.S = simplices
        self.region = np.zeros(simplices.shape[0], dtype=np.int64)
        self.parents = np.stack([np.arange(V), np.arange(V)], axis=1)

    def add(self, r):
        """Resolve ``f_r`` against the envelope of the functions before it."""
        d = self.F[:, r] - self.M
        sg = np.sign(d).astype(np.int64)
        s = sg[self.S]
        pos, neg = (s > 0).any(axis=1), (s < 0).any(axis=1)
        cut = pos & neg
        # ties (d == 0 on the whole cell) keep the smaller, earlier region
        self.region[pos & ~neg] = r
        self.M = np.maximum(self.M, self.F[:, r])
        if not cut.any():
            return
        new, regions, _, ea, eb, t = _pieces(self.S[cut], sg, d, self.region[cut], r, self.X.shape[0])
        Xn = self.X[ea] + t[:, None] * (self.X[eb] - self.X[ea])
        Fn = self.F[ea] + t[:, None] * (self.F[eb] - self.F[ea])
        self.S = np.concatenate([self.S[~cut], new])
        self.region = np.concatenate([self.region[~cut], regions])
        self.X = np.concatenate([self.X, Xn])
        self.F = np.concatenate([self.F, Fn])
        self.M = np.concatenate([self.M, Fn[:, r]])  # the crossing is on the cut: d == 0 there
        self.parents = np.concatenate([self.parents, np.stack([ea, eb], axis=1)])


def _pieces(C, sg, d, old, r, n):
    """Cut the cells ``C`` (global point ids) where ``d = f_r - M`` (signs ``sg``, both
    indexed by point id) changes sign: the pieces as point ids, the new points numbered
    from ``n`` on; each piece's region (``old`` on the negative side, ``r`` on the
    positive one); the row of ``C`` it comes from; and the new points' parent edges
    ``(ea, eb)`` with the crossing's parameter ``t`` (``x = x_ea + t (x_eb - x_ea)``).
    """
    k1 = C.shape[1]
    parity = sorting_parity(C)
    Cs = np.sort(C, axis=1)
    code = ((sg[Cs] + 1) * 3 ** np.arange(k1)).sum(axis=1)
    slots, regions, sources = [], [], []
    for c in np.unique(code):
        sel = np.flatnonzero(code == c)
        for side, T in enumerate(_templates(int(c), k1)):
            ids = Cs[sel][:, T]  # (n, m, k1, 2)
            odd = parity[sel] < 0
            ids[odd, :, 0], ids[odd, :, 1] = ids[odd, :, 1].copy(), ids[odd, :, 0].copy()
            slots.append(ids.reshape(-1, k1, 2))
            regions.append(np.repeat(old[sel] if side == 0 else np.full(sel.size, r), T.shape[0]))
            sources.append(np.repeat(sel, T.shape[0]))
    A = np.concatenate(slots)
    a, b = A[..., 0], A[..., 1]
    edge = a != b
    ukeys, inv = np.unique(a[edge] * n + b[edge], return_inverse=True)
    ea, eb = ukeys // n, ukeys % n
    t = d[ea] / (d[ea] - d[eb])  # d[ea] < 0 < d[eb]
    new = a.copy()
    new[edge] = n + inv.ravel()
    return new, np.concatenate(regions), np.concatenate(sources), ea, eb, t


def sweep(points, simplices, values):
    """Refine a complex until the argmax of the columns of ``values`` is constant per simplex.

    Returns points, simplices, regions, point values and each point's parent edge (the
    two ids it was created between; a point of the input has itself twice).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.partition_clip import sweep
    >>> X, S, regions, F, parents = sweep(np.eye(2), np.array([[0, 1]]), np.array([[1.0, 0.0], [0.0, 1.0]]))
    >>> X.tolist(), S.tolist(), regions.tolist(), parents.tolist()
    ([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]], [[0, 2], [2, 1]], [0, 1], [[0, 0], [1, 1], [0, 1]])
    """
    c = _Complex(points, simplices, values)
    for r in range(1, values.shape[1]):
        c.add(r)
    return c.X, c.S, c.region, c.F, c.parents


def interface_facets(points, simplices, regions):
    """Facets shared by two cells of different regions, oriented away from the smaller region.

    Returns the facets (n, k) as vertex ids, the region pairs (n, 2) smaller first, and
    the cell of each facet on each side (n, 2).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.partition_clip import interface_facets
    >>> pts = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1]])
    >>> facets, pairs, cells = interface_facets(pts, np.array([[0, 1, 2], [0, 2, 3]]), np.array([1, 0]))
    >>> facets.tolist(), pairs.tolist(), cells.tolist()
    ([[2, 0]], [[0, 1]], [[1, 0]])
    """
    k1 = simplices.shape[1]
    k = k1 - 1
    if simplices.shape[0] == 0 or k1 < 2:
        return np.zeros((0, k), dtype=np.int64), np.zeros((0, 2), dtype=np.int64), np.zeros((0, 2), dtype=np.int64)
    return oriented_region_facets(points, simplices, regions)


def sweep_sparse(points, simplices, values):
    """:func:`sweep` for a sparse ``values`` (CSR, every value at least 1; a region not
    stored at a point is 0 there). Returns points, simplices, regions and parents.

    Each region is stored at some points only, where it may win: a region not stored at
    an input point is 0 there, below every stored value, so it can win only near the
    points that store it. Region ``r`` is resolved on the cells that descend from an
    input simplex with a point storing it, so the work of a region follows where it is
    stored, not the size of the complex. Its values at new points are interpolated from
    their parent edges, as the dense sweep does, so that every cell sharing an edge
    computes the same crossing there and the complex stays conforming; the points a
    region's cuts make are numbered in the order of their edges, as :func:`sweep`
    numbers them, and the same input gives both sweeps the same points and cells
    (:mod:`ndboundary._compiled_partition`).

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary.partition_clip import sweep_sparse
    >>> values = sp.csr_matrix(np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0]]))
    >>> X, S, regions, parents = sweep_sparse(np.eye(2), np.array([[0, 1]]), values)
    >>> X.tolist(), S.tolist(), regions.tolist()
    ([[1.0, 0.0], [0.0, 1.0], [0.5, 0.5]], [[0, 2], [2, 1]], [0, 1])
    """
    X, S, regions, parents = sweep_sparse_compiled(points, simplices, values, template_tables(simplices.shape[1]))
    if (regions < 0).any():  # pragma: no cover - every input simplex stores a region at a point
        raise AssertionError("a cell was left without a region")
    return X, S, regions, parents
