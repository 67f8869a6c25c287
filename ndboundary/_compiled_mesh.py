"""Compiled loops (numba) over the vertex-simplex incidence of large complexes: the edge
graph and the mean edge length, the simplices across each facet, the stiffness summed
row by row.

Each pass walks the simplices at every vertex with a few scalars of state, where the
vectorised versions sort tables of every vertex pair or facet, many times the mesh's
size: on a tetrahedral mesh of a million vertices those tables, not the arithmetic, set
the time.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

from ._compiled import insert_sorted

__all__ = ["edge_length_graph", "facet_adjacency", "facet_neighbours", "stiffness_matrix"]


@numba.njit(cache=True, nogil=True)
def _across(indptr, elements, srt, across):  # pragma: no cover - compiled
    E, k1 = srt.shape
    across[:] = -2  # not sought yet
    for e in range(E):
        for i in range(k1):
            if across[e, i] != -2:
                continue  # found from the other side
            # facet i leaves out vertex i; its lowest vertex holds every simplex sharing it
            a = srt[e, 1] if i == 0 else srt[e, 0]
            found = -1
            for q in range(indptr[a], indptr[a + 1]):
                f = elements[q]
                if f == e:
                    continue
                # f holds the facet if it holds all its vertices (both rows sorted); the
                # vertex of f it does not hold names the facet on f's side
                p = 0
                held = 0
                for t in range(k1):
                    if t == i:
                        continue
                    v = srt[e, t]
                    while p < k1 and srt[f, p] < v:
                        p += 1
                    if p < k1 and srt[f, p] == v:
                        held += 1
                if held == k1 - 1:
                    if found >= 0:
                        return False  # a facet of three or more simplices
                    found = f
            across[e, i] = found
            if found >= 0:
                # the same facet seen from found: it leaves out found's vertex outside it
                for j in range(k1):
                    v = srt[found, j]
                    inside = False
                    for t in range(k1):
                        if t != i and srt[e, t] == v:
                            inside = True
                    if not inside:
                        if across[found, j] == -2:
                            across[found, j] = e
                        break
    return True


@numba.njit(cache=True, nogil=True)
def _adjacency_rows(across, indptr, indices):  # pragma: no cover - compiled
    E, k1 = across.shape
    row = np.empty(k1, dtype=np.int64)
    n = 0
    for e in range(E):
        count = 0
        for i in range(k1):
            f = across[e, i]
            if f < 0:
                continue
            p = count
            while p > 0 and row[p - 1] > f:
                row[p] = row[p - 1]
                p -= 1
            if p > 0 and row[p - 1] == f:
                return False  # a repeated simplex: two facets across to the same one
            row[p] = f
            count += 1
        for p in range(count):
            indices[n + p] = row[p]
        n += count
        indptr[e + 1] = n
    return True


def facet_adjacency(across):
    """The element adjacency (CSR structure, rows sorted) from :func:`facet_neighbours`'s
    table, or None when two facets of a simplex lie across from the same simplex.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import facet_adjacency
    >>> indptr, indices = facet_adjacency(np.array([[1, -1, -1, -1], [-1, -1, -1, 0]]))
    >>> indptr.tolist(), indices.tolist()
    ([0, 1, 2], [1, 0])
    """
    E = across.shape[0]
    inner = int(np.count_nonzero(across >= 0))
    idx = np.int32 if max(inner, E) < np.iinfo(np.int32).max else np.int64
    indptr = np.zeros(E + 1, dtype=idx)
    indices = np.empty(inner, dtype=idx)
    return (indptr, indices) if _adjacency_rows(np.ascontiguousarray(across), indptr, indices) else None


def facet_neighbours(incidence, sorted_simplices):
    """The simplex across each facet of every simplex (-1 on the border), found among the
    simplices holding the facet's lowest vertex; None when a facet is shared by three
    simplices or more.

    Returns an array of shape (n_simplices, k + 1): entry ``[e, i]`` is the simplex
    sharing the facet of ``e`` that leaves out its ``i``-th lowest vertex.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_mesh import facet_neighbours
    >>> srt = np.array([[0, 1, 2, 3], [1, 2, 3, 4]])  # two tetrahedra sharing (1, 2, 3)
    >>> inc = sp.csr_matrix((np.ones(8), (srt.ravel(), [0, 0, 0, 0, 1, 1, 1, 1])), shape=(5, 2))
    >>> facet_neighbours(inc, srt).tolist()
    [[1, -1, -1, -1], [-1, -1, -1, 0]]
    """
    inc = incidence.tocsr()
    srt = np.ascontiguousarray(sorted_simplices)
    across = np.empty(srt.shape, dtype=np.int64)
    manifold = _across(inc.indptr, inc.indices, srt, across)
    return across if manifold else None


@numba.njit(cache=True, nogil=True)
def _neighbours(a, indptr, elements, simplices, mark, nbr):  # pragma: no cover - compiled
    """Vertex ``a``'s distinct neighbours into ``nbr``, in increasing order; their count."""
    count = 0
    for q in range(indptr[a], indptr[a + 1]):
        s = elements[q]
        for t in range(simplices.shape[1]):
            b = simplices[s, t]
            if b != a and mark[b] != a:
                mark[b] = a
                insert_sorted(nbr, count, b)
                count += 1
    return count


@numba.njit(cache=True, nogil=True)
def _length(points, a, b):  # pragma: no cover - compiled
    sq = 0.0
    for d in range(points.shape[1]):
        diff = points[a, d] - points[b, d]
        sq += diff * diff
    return np.sqrt(sq)


@numba.njit(cache=True, nogil=True)
def _edge_counts(indptr, elements, simplices, points, nbr):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=np.int64)
    rows = np.zeros(V + 1, dtype=np.int64)
    # how many neighbours each vertex has, and the lengths of the edges (a, b > a) summed
    # in the lexicographic order of the edges
    total = 0.0
    n_edges = 0
    for a in range(V):
        count = _neighbours(a, indptr, elements, simplices, mark, nbr)
        rows[a + 1] = rows[a] + count
        for p in range(count):
            if nbr[p] > a:
                total += _length(points, a, nbr[p])
                n_edges += 1
    return rows, total, n_edges


@numba.njit(cache=True, nogil=True)
def _edge_rows(indptr, elements, simplices, points, nbr, rows, cols, lengths, unit):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=np.int64)
    for a in range(V):
        count = _neighbours(a, indptr, elements, simplices, mark, nbr)
        start = rows[a]
        for p in range(count):
            cols[start + p] = nbr[p]
            lengths[start + p] = _length(points, a, nbr[p]) / unit


@numba.njit(cache=True, nogil=True)
def _stiffness_counts(indptr, elements, srt, nbr, rows):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=np.int64)
    for a in range(V):
        count = _neighbours(a, indptr, elements, srt, mark, nbr)
        rows[a + 1] = rows[a] + count + (1 if indptr[a + 1] > indptr[a] else 0)


@numba.njit(cache=True, nogil=True)
def _stiffness_fill(indptr, elements, srt, grads, vol, nbr, rows, cols, data):  # pragma: no cover - compiled
    V = indptr.size - 1
    k1 = srt.shape[1]
    dim = grads.shape[1]
    mark = np.full(V, -1, dtype=np.int64)
    local = np.zeros(V, dtype=np.int64)
    for a in range(V):
        if indptr[a + 1] == indptr[a]:
            continue  # a vertex in no simplex: an empty row
        count = _neighbours(a, indptr, elements, srt, mark, nbr)
        start = rows[a]
        # the row's columns in order, the diagonal among them
        q = start
        placed = False
        for t in range(count):
            if not placed and nbr[t] > a:
                cols[q] = a
                q += 1
                placed = True
            cols[q] = nbr[t]
            q += 1
        if not placed:
            cols[q] = a
        for q in range(start, rows[a + 1]):
            local[cols[q]] = q - start
            data[q] = 0.0
        # every simplex at a adds its terms vol g_a . g_b, in increasing order of the
        # simplices: the order in which a sum over the vertex pairs of every simplex adds them
        for r in range(indptr[a], indptr[a + 1]):
            e = elements[r]
            ia = 0
            while srt[e, ia] != a:
                ia += 1
            for ib in range(k1):
                i, j = min(ia, ib), max(ia, ib)
                t = 0.0
                for d in range(dim):
                    t += grads[e, d, i] * grads[e, d, j]
                data[start + local[srt[e, ib]]] += t * vol[e]


def stiffness_matrix(incidence, sorted_simplices, grads, vol):
    """``G^T diag(vol) G`` of simplices with barycentric gradients ``grads`` (over the
    vertices of ``sorted_simplices``), summed row by row over the simplices at each vertex
    (``incidence``, its simplices in increasing order), in canonical CSR form.

    Each entry is the sum of the terms ``vol g_i . g_j`` in the order a scatter of every
    simplex's terms in simplex order makes (that of
    :func:`~ndboundary.domains.simplex_geometry.stiffness_terms`), without the table of
    every vertex pair and without storing the terms.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_mesh import stiffness_matrix
    >>> srt = np.array([[0, 1, 2]])
    >>> grads = np.array([[[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]]])  # the right triangle's
    >>> inc = sp.csr_matrix((np.ones(3), ([0, 1, 2], [0, 0, 0])), shape=(3, 1))
    >>> K = stiffness_matrix(inc, srt, grads, np.array([0.5]))
    >>> K.toarray().tolist(), bool(K.has_canonical_format)
    ([[1.0, -0.5, -0.5], [-0.5, 0.5, 0.0], [-0.5, 0.0, 0.5]], True)
    """
    inc = incidence.tocsr()
    V = inc.shape[0]
    srt = np.ascontiguousarray(sorted_simplices)
    k1 = srt.shape[1]
    nbr = np.empty(int(np.diff(inc.indptr).max(initial=0)) * k1 + 1, dtype=np.int64)
    rows = np.zeros(V + 1, dtype=np.int64)
    _stiffness_counts(inc.indptr, inc.indices, srt, nbr, rows)
    idx = np.int32 if max(int(rows[-1]), V) < np.iinfo(np.int32).max else np.int64
    cols, data = np.empty(int(rows[-1]), dtype=idx), np.empty(int(rows[-1]))
    grads, vol = np.ascontiguousarray(grads), np.ascontiguousarray(vol, dtype=np.float64)
    _stiffness_fill(inc.indptr, inc.indices, srt, grads, vol, nbr, rows, cols, data)
    return sp.csr_matrix((data, cols, rows.astype(idx)), shape=(V, V))


def edge_length_graph(incidence, simplices, points, *, unit=1.0, with_graph=True):
    """The edges of a complex as a symmetric sparse matrix of their lengths (in units of
    ``unit``), read off the vertex-simplex ``incidence`` (CSR, one row per vertex) in two
    counting passes, and the mean edge length.

    Returns ``(graph, mean)``: ``graph`` of shape (n_vertices, n_vertices), both ways,
    each row's columns increasing (None unless ``with_graph``); ``mean`` the mean length
    of the distinct edges, summed in their lexicographic order.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_mesh import edge_length_graph
    >>> points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> simplices = np.array([[0, 1, 2], [1, 3, 2]])
    >>> inc = sp.csr_matrix((np.ones(6), (simplices.ravel(), [0, 0, 0, 1, 1, 1])), shape=(4, 2))
    >>> graph, mean = edge_length_graph(inc, simplices, points)
    >>> graph.nnz, round(float(graph[1, 2]), 6), round(mean, 6)  # 5 edges, both ways; one diagonal
    (10, 1.414214, 1.082843)
    """
    inc = incidence.tocsr()
    V = inc.shape[0]
    simplices = np.ascontiguousarray(simplices)
    points = np.ascontiguousarray(points, dtype=np.float64)
    indptr, elements = inc.indptr, inc.indices
    # room for a vertex's neighbours: at most the vertices of the simplices holding it
    nbr = np.empty(int(np.diff(indptr).max(initial=0)) * simplices.shape[1], dtype=np.int64)
    rows, total, n_edges = _edge_counts(indptr, elements, simplices, points, nbr)
    mean = float(total / n_edges) if n_edges else float("nan")
    if not with_graph:
        return None, mean
    idx = np.int32 if max(int(rows[-1]), V) < np.iinfo(np.int32).max else np.int64
    cols, lengths = np.empty(int(rows[-1]), dtype=idx), np.empty(int(rows[-1]))
    _edge_rows(indptr, elements, simplices, points, nbr, rows, cols, lengths, float(unit))
    graph = sp.csr_matrix((lengths, cols, rows.astype(idx)), shape=(V, V))
    return graph, mean
