"""Simplicial complexes of any dimension: segments, triangles, tetrahedra, n-simplices.

Operators (sign convention of :mod:`ndboundary.domain`: ``K`` is positive
semidefinite, ``Delta = -M^{-1} K``):

* gradient of the linear interpolant, per simplex: with ``E = [x1-x0, ..., xk-x0]``
  (dim x k) the barycentric gradients are the columns of ``E (E^T E)^{-1}``, exact for
  linear functions and intrinsic to the simplex (valid for surfaces in 3-D);
* ``A`` = simplex volume ``sqrt(det(E^T E)) / k!``;
* ``K = G^T diag(A) G`` -- the cotangent Laplacian on triangles, the cotangent
  Laplacian of tetrahedral meshes on tetrahedra;
* ``mass`` = each simplex's volume shared equally among its k+1 vertices.
"""

from __future__ import annotations

from functools import cached_property
from math import factorial

import numpy as np
import scipy.sparse as sp

from ._validation import check_cells, check_points
from .domain import Domain

__all__ = ["SimplicialComplex"]

_DEGENERATE_RTOL = 1e-10
# Entries of the per-block temporaries of the geometry (simplices x vertices x dim).
_BLOCK = 1 << 16


def _index_dtype(n):
    """int32 when it holds ``0..n``, else int64 (scipy's choice for sparse indices)."""
    return np.int32 if n <= np.iinfo(np.int32).max else np.int64


def counting_sort(keys, n_keys):
    """Stable argsort of integers ``keys`` in ``0..n_keys-1``, in linear time.

    A sparse matrix with one entry per row, row ``i`` holding column ``keys[i]``, lists
    the rows of every column in increasing order once converted to compressed columns:
    scipy's CSR to CSC conversion is a counting sort.

    Returns
    -------
    order : ndarray of int
        ``keys[order]`` is sorted; equal keys keep their order.
    starts : ndarray of int of shape (n_keys + 1,)
        ``order[starts[k]:starts[k + 1]]`` are the positions of the key ``k``.
    """
    n = keys.size
    idx = _index_dtype(max(n, n_keys))
    one_per_row = sp.csr_matrix(
        (np.ones(n, dtype=np.int8), np.asarray(keys).astype(idx, copy=False), np.arange(n + 1, dtype=idx)),
        shape=(n, n_keys),
    )
    by_key = one_per_row.tocsc()
    return by_key.indices, by_key.indptr


def _pair_groups(first, second, n):
    """Sort integer pairs ``(first[i], second[i])``, both in ``0..n-1``, in linear time.

    A counting sort on ``first``, then a sort of ``second`` within each value of
    ``first`` (short runs, sorted in place by scipy).

    Returns
    -------
    order : ndarray of int
        The pairs ``order`` in lexicographic order (equal pairs in no particular order).
    new : ndarray of bool
        ``new[i]`` tells whether pair ``order[i]`` differs from the one before it.
    """
    m = first.size
    order, starts = counting_sort(first, n)
    within = sp.csr_matrix((order, second[order].astype(starts.dtype, copy=False), starts), shape=(n, n))
    within.sort_indices()
    order, second = within.data, within.indices
    new = np.empty(m, dtype=bool)
    new[:1] = True
    np.not_equal(second[1:], second[:-1], out=new[1:])
    first_change = starts[1:-1]
    new[first_change[first_change < m]] = True
    return order, new


def _sort_rows(rows):
    """Sort the rows of an integer array lexicographically.

    Returns ``(order, new)``: ``rows[order]`` is sorted (equal rows in no particular
    order) and ``new[i]`` tells whether ``rows[order[i]]`` differs from the row before
    it. Rows with a small range of values (vertex or element indices) are sorted in
    linear time: a counting sort per column, from the last to the first, or for two
    columns a counting sort on the first and a sort of the second within each value of
    the first.
    """
    n, width = rows.shape
    lo, hi = int(rows.min()), int(rows.max())
    span = hi - lo + 1
    new = np.empty(n, dtype=bool)
    new[:1] = True
    if span <= 4 * n + 1024:
        idx = _index_dtype(max(n, span))
        cols = [(rows[:, c] - lo).astype(idx, copy=False) for c in range(width)]
        if width == 2:
            return _pair_groups(cols[0], cols[1], span)
        order = None
        for c in range(width - 1, -1, -1):
            col = cols[c] if order is None else cols[c][order]
            step, _ = counting_sort(col, span)
            order = step if order is None else order[step]
    else:
        order = np.lexsort(rows.T[::-1])
    new[1:] = False
    for c in range(width):
        col = rows[order, c]
        new[1:] |= col[1:] != col[:-1]
    return order, new


def _row_groups(rows):
    """Equal rows of an integer array: ``(ids, first)``.

    ``ids`` numbers the distinct rows in lexicographic order; ``first`` is the index of
    one row of every group, in that order.
    """
    rows = np.asarray(rows)
    if rows.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order, new = _sort_rows(rows)
    ids = np.empty(rows.shape[0], dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


def group_rows(rows):
    """Label equal rows of an integer array with the same id.

    Returns ``(ids, n_groups)``; ids follow the lexicographic order of the rows.
    """
    ids, first = _row_groups(rows)
    return ids, int(first.size)


def first_of_groups(ids, n_groups):
    """Index of the first occurrence of every id ``0..n_groups-1`` in ``ids``, in linear time.

    Every id must occur; the result is ``np.unique(ids, return_index=True)[1]``.
    """
    order, starts = counting_sort(ids, n_groups)
    return order[starts[:-1]].astype(np.intp)


def shared_facet_adjacency(facet_ids, owner, n_elements):
    """Element adjacency: elements sharing a facet id (more than two sharing one are chained).

    ``facet_ids[i]`` is the id of a facet of element ``owner[i]``.
    """
    if facet_ids.size == 0:
        return sp.csr_matrix((n_elements, n_elements))
    idx = _index_dtype(max(n_elements, 2 * facet_ids.size))
    n_groups = int(facet_ids.max()) + 1
    if np.all(owner[1:] >= owner[:-1]):
        # owners already in order: a stable sort by facet keeps them so within a facet
        order, starts = counting_sort(facet_ids, n_groups)
        same = np.ones(facet_ids.size, dtype=bool)
        same[starts[:-1][starts[:-1] < facet_ids.size]] = False  # the first of each facet
        same = same[1:]
    else:
        order, _ = _sort_rows(np.stack([facet_ids, owner], axis=1))
        f = facet_ids[order]
        same = f[1:] == f[:-1]
    o = owner[order].astype(idx)
    same &= o[1:] != o[:-1]
    i, j = o[:-1][same], o[1:][same]
    adj = sp.csr_matrix(
        (np.ones(2 * i.size), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n_elements, n_elements)
    )
    adj.data[:] = 1.0
    return adj


def mixed_facets(facet_ids, owner, region1):
    """Indices (into ``facet_ids``) of one occurrence of every facet shared by both labels."""
    n_groups = int(facet_ids.max()) + 1
    lab = np.asarray(region1, dtype=np.float64)[owner]
    cnt = np.bincount(facet_ids, minlength=n_groups)
    ones = np.bincount(facet_ids, weights=lab, minlength=n_groups)
    mixed = (cnt >= 2) & (ones > 0) & (ones < cnt)
    where = np.flatnonzero(mixed[facet_ids])
    order, starts = counting_sort(facet_ids[where], n_groups)
    return where[order[starts[:-1][mixed]]]


def _symmetric_inverse(gram, k):
    """Determinants and cofactors of symmetric k x k matrices, k <= 3.

    ``gram[i][j]`` holds entry (i, j) of every matrix, as arrays of one shape; returns
    ``(det, cof)`` with ``cof[i, j]`` (``i <= j``) likewise: the inverse is ``cof / det``.
    """
    g = gram
    if k == 1:
        det = g[0][0]
        cof = {(0, 0): np.ones_like(det)}
    elif k == 2:
        det = g[0][0] * g[1][1] - g[0][1] * g[0][1]
        cof = {(0, 0): g[1][1], (0, 1): -g[0][1], (1, 1): g[0][0]}
    else:
        cof = {
            (0, 0): g[1][1] * g[2][2] - g[1][2] * g[1][2],
            (0, 1): g[0][2] * g[1][2] - g[0][1] * g[2][2],
            (0, 2): g[0][1] * g[1][2] - g[0][2] * g[1][1],
            (1, 1): g[0][0] * g[2][2] - g[0][2] * g[0][2],
            (1, 2): g[0][1] * g[0][2] - g[0][0] * g[1][2],
            (2, 2): g[0][0] * g[1][1] - g[0][1] * g[0][1],
        }
        det = g[0][0] * cof[0, 0] + g[0][1] * cof[0, 1] + g[0][2] * cof[0, 2]
    return det, cof


def _simplex_geometry(points, simplices):
    """Barycentric gradients and volumes of simplices.

    Returns ``(grads, vol)``: ``grads[e, :, a]`` (shape (E, dim, k+1), the layout of the
    rows of the gradient operator) is the gradient of the barycentric coordinate of
    vertex ``simplices[e, a]`` over simplex ``e``, ``vol`` the volumes (E,). Degenerate
    simplices (volume below a relative tolerance) get volume NaN and zero gradients, for
    the caller to report. Simplices are taken in blocks small enough for the
    temporaries to stay in cache.
    """
    E, k1 = simplices.shape
    dim = points.shape[1]
    grads = np.empty((E, dim, k1))
    vol = np.empty(E)
    block = max(64, _BLOCK // (k1 * dim))
    if k1 <= 4:
        coords = np.ascontiguousarray(points.T)
        for start in range(0, E, block):
            b = slice(start, start + block)
            vol[b] = _small_simplex_geometry(coords, simplices[b], grads[b])
    else:
        for start in range(0, E, block):
            b = slice(start, start + block)
            vol[b] = _large_simplex_geometry(points, simplices[b], grads[b])
    return grads, vol


def _small_simplex_geometry(coords, simplices, grads):
    """:func:`_simplex_geometry` of simplices of at most 3 dimensions, by cofactors.

    ``coords`` is the (dim, n_vertices) array of coordinates; the gradients are written
    to ``grads`` (n, dim, k+1) and the volumes returned.
    """
    k = simplices.shape[1] - 1
    x0 = coords[:, simplices[:, 0]]
    e = [coords[:, simplices[:, i + 1]] - x0 for i in range(k)]  # edge vectors from x0, (dim, n)
    gram = [[None] * k for _ in range(k)]
    for i in range(k):
        for j in range(i, k):
            gram[i][j] = gram[j][i] = np.einsum("dn,dn->n", e[i], e[j])
    scale = sum(gram[i][i] for i in range(k)) / k  # mean squared edge length from x0
    det, cof = _symmetric_inverse(gram, k)
    bad = ~(det > (_DEGENERATE_RTOL * scale) ** k)
    inv_det = 1.0 / np.where(bad, 1.0, det)
    total = 0.0
    for i in range(k):
        # gradient of the barycentric coordinate i + 1: row i of gram^{-1} times the edges
        row = sum(e[j] * (cof[min(i, j), max(i, j)] * inv_det) for j in range(k))
        grads[:, :, i + 1] = row.T
        total = total + row
    grads[:, :, 0] = -total.T
    grads[bad] = 0.0
    vol = np.sqrt(np.where(bad, 1.0, det)) / factorial(k)
    vol[bad] = np.nan
    return vol


def _large_simplex_geometry(points, simplices, grads):
    """:func:`_simplex_geometry` by LU factorisations of the Gram matrices; the
    gradients are written to ``grads`` (n, dim, k+1) and the volumes returned."""
    X = points[simplices]
    Ed = X[:, 1:, :] - X[:, :1, :]  # (n, k, dim)
    gram = Ed @ Ed.transpose(0, 2, 1)  # (n, k, k)
    k = Ed.shape[1]
    det = np.linalg.det(gram)
    scale = np.einsum("eij,eij->e", Ed, Ed) / k  # mean squared edge length from x0
    bad = ~(det > (_DEGENERATE_RTOL * scale) ** k)
    gram[bad] = np.eye(k)
    vol = np.sqrt(np.where(bad, 1.0, det)) / factorial(k)
    vol[bad] = np.nan
    rest = np.linalg.inv(gram) @ Ed  # (n, k, dim): row i is grad of barycentric coordinate i+1
    rest[bad] = 0.0
    grads[:, :, 1:] = rest.transpose(0, 2, 1)
    grads[:, :, 0] = -rest.sum(axis=1)
    return vol


def _stiffness_terms(grads, vol):
    """Per simplex, the entries ``vol g_i . g_j`` of ``G^T diag(A) G`` over its vertices.

    Parameters
    ----------
    grads : ndarray of shape (n, dim, k + 1)
        Barycentric gradients, as :func:`_simplex_geometry` returns them.
    vol : ndarray of shape (n,)

    Returns
    -------
    off : ndarray of shape (n, k (k + 1) / 2)
        The vertex pairs ``i < j`` in ``triu_indices`` order.
    diag : ndarray of shape (n, k + 1)
    """
    n, _, k1 = grads.shape
    iu, ju = np.triu_indices(k1, 1)
    off = np.empty((n, iu.size))
    for p, (i, j) in enumerate(zip(iu, ju)):
        off[:, p] = np.einsum("ed,ed->e", grads[:, :, i], grads[:, :, j]) * vol
    diag = np.empty((n, k1))
    for i in range(k1):
        diag[:, i] = np.einsum("ed,ed->e", grads[:, :, i], grads[:, :, i]) * vol
    return off, diag


def _symmetric_csr(edges, off, diag, has_diag):
    """The symmetric sparse matrix with entries ``off`` at the ``edges`` and at their
    transposes and ``diag`` on the diagonal where ``has_diag``, in canonical CSR form.

    ``edges`` are distinct pairs ``i < j`` in lexicographic order (the row-major order of
    the upper triangle); the lower triangle is their counting sort by ``j``.
    """
    n = diag.size
    i, j = edges[:, 0], edges[:, 1]
    n_edges = i.size
    idx = _index_dtype(2 * n_edges + n)
    lower, lower_start = counting_sort(j, n)  # (j, i) in row-major order
    n_lower = np.diff(lower_start)
    n_upper = np.bincount(i, minlength=n)
    indptr = np.zeros(n + 1, dtype=idx)
    np.cumsum(n_lower + has_diag + n_upper, out=indptr[1:])
    indices = np.empty(int(indptr[-1]), dtype=idx)
    data = np.empty(int(indptr[-1]))
    rank = np.arange(n_edges)
    # per row: the lower triangle, the diagonal, the upper triangle
    pos = rank + (indptr[:-1] - lower_start[:-1])[j[lower]]
    indices[pos] = i[lower]
    data[pos] = off[lower]
    rows = np.flatnonzero(has_diag)
    pos = indptr[rows] + n_lower[rows]
    indices[pos] = rows
    data[pos] = diag[rows]
    upper_start = np.cumsum(n_upper) - n_upper
    pos = rank + (indptr[:-1] + n_lower + has_diag - upper_start)[i]
    indices[pos] = j
    data[pos] = off
    return sp.csr_matrix((data, indices, indptr), shape=(n, n))


def _kept_then(a, keep, tail):
    """``concatenate([a[keep], tail])``, copying ``a`` once."""
    n_keep = int(np.count_nonzero(keep))
    out = np.empty((n_keep + tail.shape[0],) + a.shape[1:], dtype=a.dtype)
    np.compress(keep, a, axis=0, out=out[:n_keep])
    out[n_keep:] = tail
    return out


class _ElementSplit:
    """The operators of a complex made by :meth:`SimplicialComplex._split_elements`,
    derived from those of its parent.

    Only the split simplices change: the sums over the edges and vertices they hold
    are recomputed from every simplex holding them, in the order a fresh build adds
    them; the parent's sums are kept everywhere else. The results are those of a
    fresh build of the split complex.

    Parameters
    ----------
    parent : SimplicialComplex
    split : ndarray of int of shape (m,)
        The split simplices, increasing.
    keep : ndarray of bool of shape (n_elements,)
        The simplices of the parent that are not split.

    Notes
    -----
    The split complex holds the kept simplices in order, then its children in ``k + 1``
    blocks of ``m``: child ``i * m + j`` replaces vertex ``i`` (in the order of
    ``parent.simplices``) of simplex ``split[j]`` by its centre, vertex ``V + j``.
    """

    def __init__(self, parent, split, keep):
        self.parent = parent
        self.split = split
        self.keep = keep
        self.n_keep = int(np.count_nonzero(keep))
        # sorted position of every vertex of the split simplices
        self.rank = np.argsort(np.argsort(parent.simplices[split], axis=1), axis=1)

    @cached_property
    def _split_vertices(self):
        """The vertices of the split simplices, as a mask over the parent's vertices."""
        mask = np.zeros(self.parent.n_vertices, dtype=bool)
        mask[self.parent.simplices[self.split].ravel()] = True
        return mask

    @cached_property
    def _star(self):
        """The kept simplices sharing a vertex with a split simplex, increasing."""
        P = self.parent
        near = self._split_vertices
        if "incidence" in P.__dict__:
            inc = P.incidence
            rows = np.flatnonzero(near)
            held = np.zeros(P.n_elements, dtype=bool)
            held[inc.indices[_expand(inc.indptr[rows], inc.indptr[rows + 1])]] = True
        else:
            held = near[P._sorted_simplices].any(axis=1)
        return np.flatnonzero(held & self.keep)

    @cached_property
    def edge_map(self):
        """``(edges, old, new)``: the edges of the split complex (as ``edges``), the new id
        of every edge of the parent (-1 for an edge no simplex keeps) and, shape (m, k+1),
        the id of the edge from vertex ``srt[j, r]`` to the centre of ``split[j]``
        (``srt`` the sorted simplices)."""
        P = self.parent
        V = P.n_vertices
        edges_p, pair_edge_p = P._edge_index
        srt = P._sorted_simplices[self.split]
        if srt.shape[1] == 2:
            # a split segment drops its edge unless a kept segment holds it too
            survive = np.bincount(pair_edge_p[self.keep], minlength=edges_p.shape[0]) > 0
            kept_edges = edges_p[survive]
        else:
            survive = None  # every edge of a split simplex is an edge of its children
            kept_edges = edges_p
        # the centre joins the vertices of its simplex, after every parent edge of each row
        by_row, new_before = counting_sort(srt.ravel(), V)
        row = srt.ravel()[by_row]
        new_pos = np.arange(row.size) + np.searchsorted(kept_edges[:, 0], row, side="right")
        old_pos = np.arange(kept_edges.shape[0]) + new_before[kept_edges[:, 0]]
        edges = np.empty((kept_edges.shape[0] + row.size, 2), dtype=edges_p.dtype)
        edges[old_pos] = kept_edges
        edges[new_pos, 0] = row
        edges[new_pos, 1] = V + by_row // srt.shape[1]
        if survive is None:
            old = old_pos
        else:
            old = np.full(edges_p.shape[0], -1, dtype=old_pos.dtype)
            old[survive] = old_pos
        new = np.empty(row.size, dtype=new_pos.dtype)
        new[by_row] = new_pos
        return edges, old, new.reshape(srt.shape)

    @cached_property
    def children_pair_edge(self):
        """The edge of every vertex pair of the children, (n_children, k (k + 1) / 2), in
        the order of ``_edge_index``."""
        P = self.parent
        _, old, new = self.edge_map
        m, k1 = new.shape
        k = k1 - 1
        iu, ju = np.triu_indices(k1, 1)
        pair_of = np.zeros((k1, k1), dtype=np.intp)
        pair_of[iu, ju] = np.arange(iu.size)
        # position in the parent of child position r, for a child without parent position a
        pos = np.arange(k)[None, :] + (np.arange(k)[None, :] >= np.arange(k1)[:, None])
        to_centre = ju == k
        a = self.rank.T.ravel()
        j = np.tile(np.arange(m), k1)[:, None]
        first = pos[a][:, iu]
        second = pos[a][:, np.minimum(ju, k - 1)]
        pair_edge_p = P._edge_index[1].reshape(P.n_elements, -1)[self.split]
        inner = old[pair_edge_p[j, pair_of[first, second]]]
        return np.where(to_centre[None, :], new[j, first], inner)

    def edge_index(self):
        """``_edge_index`` of the split complex."""
        P = self.parent
        edges, old, _ = self.edge_map
        pair_edge_p = P._edge_index[1].reshape(P.n_elements, -1)
        kept = old[pair_edge_p[self.keep]]
        return edges, np.concatenate([kept.ravel(), self.children_pair_edge.ravel()])

    def _recomputed(self, sums, targets, star_ids, star_terms, child_ids, child_terms):
        """Set ``sums[targets]`` to the sums of the terms of the star simplices whose ids
        are in ``targets`` (increasing), then of every term of the children."""
        star_ids = star_ids.ravel()
        sel = np.zeros(sums.size, dtype=bool)
        sel[targets] = True
        sel = sel[star_ids]
        ids = np.concatenate([star_ids[sel], child_ids.ravel()])
        terms = np.concatenate([star_terms.ravel()[sel], child_terms.ravel()])
        sums[targets] = np.bincount(np.searchsorted(targets, ids), weights=terms, minlength=targets.size)

    def stiffness_sums(self, child):
        """``_stiffness_sums`` of the split complex ``child``."""
        P = self.parent
        off_p, diag_p, used_p = P._stiffness_sums
        edges, old, new = self.edge_map
        m = self.split.size
        n = self.n_keep
        star = self._star
        star_off, star_diag = _stiffness_terms(P._bary_grads[star], P._volumes[star])
        child_off, child_diag = _stiffness_terms(child._bary_grads[n:], child._volumes[n:])
        off = np.empty(edges.shape[0])
        if old.size == off_p.size and (old >= 0).all():
            off[old] = off_p
        else:
            off[old[old >= 0]] = off_p[old >= 0]
        pair_edge_p = P._edge_index[1].reshape(P.n_elements, -1)
        held = old[pair_edge_p[self.split]]
        targets = np.union1d(held[held >= 0], new.ravel())
        self._recomputed(off, targets, old[pair_edge_p[star]], star_off, self.children_pair_edge, child_off)
        diag = np.concatenate([diag_p, np.zeros(m)])
        targets = np.concatenate([np.flatnonzero(self._split_vertices), P.n_vertices + np.arange(m)])
        self._recomputed(diag, targets, P._sorted_simplices[star], star_diag, child._sorted_simplices[n:], child_diag)
        return off, diag, np.concatenate([used_p, np.ones(m, dtype=bool)])

    def mass(self, child):
        """The lumped mass of the split complex ``child`` from its parent's, or None when
        the parent's is not built."""
        P = self.parent
        if "mass" not in P.__dict__:
            return None
        k1 = P.simplices.shape[1]
        m = self.split.size
        n = self.n_keep
        star = self._star
        mass = np.concatenate([P.mass, np.zeros(m)])
        unused = ~P._vertex_used
        targets = np.concatenate([np.flatnonzero(self._split_vertices), P.n_vertices + np.arange(m)])
        self._recomputed(
            mass,
            targets,
            P.simplices[star],
            np.repeat(P._volumes[star] / k1, k1),
            child.simplices[n:],
            np.repeat(child._volumes[n:] / k1, k1),
        )
        if unused.any():
            mass[: P.n_vertices][unused] = child._volumes.mean() / k1 * 1e-12
        return mass


def _expand(starts, stops):
    """Concatenation of ``arange(s, t)`` for every pair."""
    lengths = stops - starts
    total = int(lengths.sum())
    first = np.zeros(lengths.size, dtype=np.int64)
    np.cumsum(lengths[:-1], out=first[1:])
    return np.repeat(starts - first, lengths) + np.arange(total)


class SimplicialComplex(Domain):
    """A pure simplicial complex of k-simplices with vertices in R^dim, 1 <= k <= dim.

    Parameters
    ----------
    points : array-like of shape (n_vertices, dim)
        Vertex coordinates. Copied.
    simplices : array-like of int of shape (n_elements, k + 1)
        Vertex indices of each simplex. Copied.

    Raises
    ------
    ValueError
        On NaN or infinite coordinates, out-of-range indices, a simplex with a
        repeated vertex or with zero volume, or more simplex vertices than
        ``dim + 1``.
    TypeError
        On non-numeric points or non-integer indices.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import SimplicialComplex
    >>> tri = SimplicialComplex([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> float(tri.A[0])
    0.5
    >>> tri.gradient([0.0, 1.0, 0.0]).tolist()
    [[1.0, 0.0]]
    """

    # set on the complexes made by _split_elements: their operators derive from the parent's
    _split_of = None

    def __init__(self, points, simplices):
        self.points = check_points(points)
        self.simplices = check_cells(simplices, self.points.shape[0], name="simplices")
        k1 = self.simplices.shape[1]
        if k1 < 2:
            raise ValueError(
                f"simplices has shape {self.simplices.shape}; a simplex needs at least 2 vertices"
            )
        if k1 > self.dim + 1:
            raise ValueError(
                f"simplices has shape {self.simplices.shape} but points are {self.dim}-dimensional; "
                f"expected at most {self.dim + 1} vertices per simplex"
            )
        self._sorted_simplices = np.sort(self.simplices, axis=1)
        self._bary_grads, self._volumes = self._geometry()

    @classmethod
    def from_delaunay(cls, points):
        """The Delaunay triangulation of data points (scipy's Qhull), flat slivers dropped.

        Practical up to about 6 dimensions; beyond, use :class:`~ndboundary.PointCloud`.
        See :func:`ndboundary.delaunay_complex`.
        """
        from .pointcloud import delaunay_complex

        return delaunay_complex(points)

    # -- sizes -------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return int(self.simplices.shape[0])

    @property
    def simplex_dim(self) -> int:
        """The dimension k of the simplices (2 for triangles, 3 for tetrahedra)."""
        return int(self.simplices.shape[1] - 1)

    @property
    def element_dim(self) -> int:
        return self.simplex_dim

    # -- geometry ------------------------------------------------------------------
    def _geometry(self):
        """Barycentric gradients and volumes (see :func:`_simplex_geometry`) over the
        vertices of every simplex in increasing order (``_sorted_simplices``, the column
        order of the operators), refusing degenerate simplices."""
        grads, vol = _simplex_geometry(self.points, self._sorted_simplices)
        bad = ~np.isfinite(vol)
        if bad.any():
            e = int(np.flatnonzero(bad)[0])
            k = self.simplex_dim
            raise ValueError(
                f"simplex {e} (vertices {self.simplices[e].tolist()}) is degenerate: zero "
                f"{'length' if k == 1 else 'area' if k == 2 else 'volume'}"
                f"{'' if bad.sum() == 1 else f' ({int(bad.sum())} degenerate simplices in all)'}"
            )
        return grads, vol

    def element_centroids(self) -> np.ndarray:
        return self.points[self.simplices].mean(axis=1)

    # -- operators ------------------------------------------------------------------
    def _build_gradient(self):
        # one row per element and component, its k+1 entries in increasing column order;
        # the data are the barycentric gradients themselves, not a copy
        E, k1 = self.simplices.shape
        D = self.dim
        idx = _index_dtype(max(E * D * k1, self.n_vertices))
        indices = np.broadcast_to(self._sorted_simplices.astype(idx)[:, None, :], (E, D, k1))
        return sp.csr_matrix(
            (self._bary_grads.reshape(-1), indices.reshape(-1), np.arange(E * D + 1, dtype=idx) * k1),
            shape=(E * D, self.n_vertices),
        )

    def _build_measures(self):
        return self._volumes.copy()

    @cached_property
    def _vertex_used(self):
        """Whether each vertex lies in some simplex."""
        return np.bincount(self.simplices.ravel(), minlength=self.n_vertices) > 0

    @cached_property
    def _stiffness_sums(self):
        """``(off, diag, used)``: the entries of ``K = G^T diag(A) G`` at the edges (in the
        order of :attr:`edges`), its diagonal, and :attr:`_vertex_used` (the rows with a
        diagonal entry). Each entry is one sum over the simplices holding the edge or vertex."""
        if self._split_of is not None:
            return self._split_of.stiffness_sums(self)
        off, diag = _stiffness_terms(self._bary_grads, self._volumes)
        edges, pair_edge = self._edge_index
        off = np.bincount(pair_edge, weights=off.ravel(), minlength=edges.shape[0])
        diag = np.bincount(self._sorted_simplices.ravel(), weights=diag.ravel(), minlength=self.n_vertices)
        return off, diag, self._vertex_used

    def _build_stiffness(self):
        off, diag, used = self._stiffness_sums
        K = _symmetric_csr(self.edges, off, diag, used)
        K.eliminate_zeros()  # an edge whose angles cancel exactly (right angles on both sides)
        return K

    def _build_mass(self):
        if self._split_of is not None:
            m = self._split_of.mass(self)
            if m is not None:
                return m
        k1 = self.simplices.shape[1]
        m = np.bincount(
            self.simplices.ravel(), weights=np.repeat(self._volumes / k1, k1), minlength=self.n_vertices
        )
        unused = m <= 0
        if unused.any():
            # Vertices in no simplex carry no measure; give them a tiny one so M stays invertible.
            m[unused] = self._volumes.mean() / k1 * 1e-12
        return m

    def _build_incidence(self):
        # the element-vertex matrix, one row per simplex, transposed
        E, k1 = self.simplices.shape
        idx = _index_dtype(max(E * k1, self.n_vertices))
        by_element = sp.csr_matrix(
            (np.ones(E * k1), self._sorted_simplices.astype(idx).ravel(), np.arange(E + 1, dtype=idx) * k1),
            shape=(E, self.n_vertices),
        )
        return by_element.T.tocsr()

    def _element_max(self, f):
        f = np.asarray(f)
        out = f[self.simplices[:, 0]]
        for i in range(1, self.simplices.shape[1]):
            np.maximum(out, f[self.simplices[:, i]], out=out)
        return out

    @cached_property
    def _edge_index(self):
        """The unique edges, sorted (as :attr:`edges`), and the edge of every vertex pair
        ``(srt[e, i], srt[e, j])``, ``i < j`` in ``triu_indices`` order, element-major
        (``srt = _sorted_simplices``)."""
        if self._split_of is not None:
            return self._split_of.edge_index()
        srt = self._sorted_simplices
        E, k1 = srt.shape
        iu, ju = np.triu_indices(k1, 1)
        V = self.n_vertices
        idx = _index_dtype(max(V, E * iu.size))
        s = srt.astype(idx, copy=False)
        first, second = np.take(s, iu, axis=1).ravel(), np.take(s, ju, axis=1).ravel()
        order, new = _pair_groups(first, second, V)
        pair_edge = np.empty(first.size, dtype=np.intp)
        pair_edge[order] = np.cumsum(new, dtype=np.intp) - 1
        head = order[new]
        edges = np.empty((head.size, 2), dtype=srt.dtype)
        edges[:, 0] = first[head]
        edges[:, 1] = second[head]
        return edges, pair_edge

    @cached_property
    def _facets(self):
        """Sorted facets of every simplex, element-major, (E*(k+1), k): facet i leaves
        out vertex i."""
        E, k1 = self.simplices.shape
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self._sorted_simplices[:, leave_out].reshape(E * k1, k1 - 1)

    @cached_property
    def _facet_ids(self):
        """Group id of every row of :attr:`_facets` (equal facets, equal ids), the ids in
        the lexicographic order of the facets."""
        if self.simplices.shape[1] == 3:
            # the facets of triangles are their edges, in the reverse order of the pairs
            # of _edge_index
            return self._edge_index[1].reshape(-1, 3)[:, ::-1].ravel()
        return self._facet_groups[0]

    @cached_property
    def _facet_groups(self):
        """``(ids, order, starts)``: :attr:`_facet_ids`, and the rows of :attr:`_facets`
        grouped by facet, ``order[starts[f]:starts[f + 1]]`` holding those of facet ``f``.

        A facet of more than two vertices is known by the edge of its first two vertices
        and its other vertices: for tetrahedra, a pair sorted in linear time. The edges
        are numbered in lexicographic order, so the ids are those of the facets.
        """
        E, k1 = self.simplices.shape
        if k1 == 3:
            ids = self._facet_ids
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        if k1 == 2:
            ids = group_rows(self._facets)[0]
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        edges, pair_edge = self._edge_index
        iu, ju = np.triu_indices(k1, 1)
        pair_of = np.zeros((k1, k1), dtype=np.intp)
        pair_of[iu, ju] = np.arange(iu.size)
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        lead = np.take(pair_edge.reshape(E, iu.size), pair_of[leave_out[:, 0], leave_out[:, 1]], axis=1).ravel()
        rest = np.take(self._sorted_simplices, leave_out[:, 2:], axis=1).reshape(E * k1, k1 - 3)
        if k1 == 4:
            n = max(edges.shape[0], self.n_vertices)
            idx = _index_dtype(max(n, lead.size))
            order, new = _pair_groups(lead.astype(idx), rest[:, 0].astype(idx), n)
        else:
            order, new = _sort_rows(np.column_stack([lead, rest]))
        ids = np.empty(lead.size, dtype=order.dtype)
        ids[order] = np.cumsum(new, dtype=order.dtype) - 1
        starts = np.append(np.flatnonzero(new), lead.size).astype(order.dtype)
        return ids, order, starts

    def _build_adjacency(self):
        E, k1 = self.simplices.shape
        ids, order, starts = self._facet_groups
        size = np.diff(starts)
        if size.max() > 2:
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)
        # every facet in at most two simplices: each simplex's neighbours, one per
        # facet (-1 on the boundary), sorted
        first = starts[:-1][size == 2]
        a, b = order[first], order[first + 1]
        across = np.full(E * k1, -1, dtype=order.dtype)
        across[a] = b // k1
        across[b] = a // k1
        across = np.sort(across.reshape(E, k1), axis=1)
        if (across[:, 1:] == across[:, :-1])[across[:, 1:] >= 0].any():
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)  # repeated simplices
        inner = across >= 0
        indptr = np.zeros(E + 1, dtype=order.dtype)
        np.cumsum(inner.sum(axis=1), out=indptr[1:])
        return sp.csr_matrix((np.ones(int(indptr[-1])), across[inner], indptr), shape=(E, E))

    def _build_edges(self):
        if self._split_of is not None:
            return self._split_of.edge_map[0]
        return self._edge_index[0]

    def _interface_facets(self, region1):
        """Facets shared by a region-0 and a region-1 simplex: the jagged boundary, (n, k)."""
        k1 = self.simplices.shape[1]
        owner = np.repeat(np.arange(self.n_elements), k1)
        which = mixed_facets(self._facet_ids, owner, region1)
        if "_facets" in self.__dict__:
            return self._facets[which]
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self._sorted_simplices[which // k1][np.arange(which.size)[:, None], leave_out[which % k1]]

    def _split_elements(self, mask):
        mask = np.asarray(mask, dtype=bool)
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return self, np.arange(self.n_elements)
        k1 = self.simplices.shape[1]
        V = self.n_vertices
        centres = self.points[self.simplices[idx]].mean(axis=1)
        new_ids = V + np.arange(idx.size)
        parts = []
        for i in range(k1):
            s = self.simplices[idx].copy()
            s[:, i] = new_ids
            parts.append(s)
        new = np.concatenate(parts)
        parent = np.concatenate([np.flatnonzero(~mask)] + [idx] * k1)
        # children of valid simplices are valid: skip validation, and compute the geometry
        # of the new simplices only
        keep = ~mask
        out = SimplicialComplex.__new__(SimplicialComplex)
        out.points = np.concatenate([self.points, centres])
        new_sorted = np.sort(new, axis=1)
        grads, vols = _simplex_geometry(out.points, new_sorted)
        out.simplices = _kept_then(self.simplices, keep, new)
        out._sorted_simplices = _kept_then(self._sorted_simplices, keep, new_sorted)
        out._bary_grads = _kept_then(self._bary_grads, keep, grads)
        out._volumes = _kept_then(self._volumes, keep, vols)
        out._split_of = _ElementSplit(self, idx, keep)
        return out, parent

    def _level_set_simplices(self):
        return self.simplices

    def __repr__(self):
        return (
            f"SimplicialComplex(n_vertices={self.n_vertices}, n_elements={self.n_elements}, "
            f"simplex_dim={self.simplex_dim}, dim={self.dim})"
        )
