"""Compiled loops (numba) over the vertex-simplex incidence of large complexes: the edge
graph and the mean edge length, the simplices across each facet, the stiffness; the
assembly of the cells' stiffness blocks of polygon and polyhedral meshes; and the
stiffness of the gradient stencils of point clouds.

Each pass walks the simplices at every vertex (or every simplex once) with a few scalars
of state, where the vectorised versions sort tables of every vertex pair or facet, many
times the mesh's size: on a tetrahedral mesh of a million vertices those tables, not the
arithmetic, set the time.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba
import numpy as np
import scipy.sparse as sp

from ._compiled import insert_sorted, row_blocks
from ._kernels import kernel

__all__ = [
    "assemble_box_stencil",
    "assemble_cell_blocks",
    "edge_length_graph",
    "facet_adjacency",
    "facet_neighbours",
    "stencil_stiffness",
    "stiffness_matrix",
]


@numba.njit(cache=True, nogil=True, inline="always")
def _facet_vertex(srt, f, i, t):  # pragma: no cover - compiled
    """The ``t``-th lowest vertex of the facet of ``f`` that leaves out its ``i``-th."""
    return srt[f, t + 1 if t >= i else t]


@kernel("b1(i4[::1], i4[::1], i8[:, ::1], i8[:, ::1])")
@numba.njit(cache=True, nogil=True)
def _across(indptr, elements, srt, across):  # pragma: no cover - compiled
    """The simplex across each facet into ``across``; False at a facet of three simplices
    or more.

    Every facet is met once, at its lowest vertex ``a``: the simplices at ``a`` with ``a``
    first hold all their facets but the first there, those with ``a`` second their first
    facet. The facets met at ``a`` are paired by their second vertex (a chain of slots per
    vertex, emptied after ``a``) and then the rest, so one pass over the stars finds every
    pair, where a search per facet would test every simplex at its lowest vertex.
    """
    V = indptr.size - 1
    k1 = srt.shape[1]
    width = 1
    for a in range(V):
        width = max(width, (indptr[a + 1] - indptr[a]) * (k1 - 1))
    head = np.full(V, -1, dtype=np.int32)  # per second vertex: its latest slot at a
    lead = np.empty(width, dtype=np.int64)  # a slot's second vertex
    chain = np.empty(width, dtype=np.int64)  # the slot before it with that second vertex
    one = np.empty((width, 2), dtype=np.int64)  # the first (simplex, facet) on the slot
    two = np.empty((width, 2), dtype=np.int64)  # the second, or -1
    for a in range(V):
        n = 0
        for q in range(indptr[a], indptr[a + 1]):
            f = elements[q]
            if srt[f, 0] == a:
                lo, hi = 1, k1
            elif srt[f, 1] == a:
                lo, hi = 0, 1
            else:
                continue
            for i in range(lo, hi):
                b = _facet_vertex(srt, f, i, 1) if k1 > 2 else a
                s = head[b]
                while s >= 0:
                    same = True
                    for t in range(2, k1 - 1):
                        if _facet_vertex(srt, one[s, 0], one[s, 1], t) != _facet_vertex(srt, f, i, t):
                            same = False
                            break
                    if same:
                        break
                    s = chain[s]
                if s < 0:
                    lead[n] = b
                    chain[n] = head[b]
                    head[b] = n
                    one[n, 0] = f
                    one[n, 1] = i
                    two[n, 0] = -1
                    n += 1
                elif two[s, 0] < 0:
                    two[s, 0] = f
                    two[s, 1] = i
                else:
                    return False  # a facet of three or more simplices
        for s in range(n):
            head[lead[s]] = -1
            across[one[s, 0], one[s, 1]] = two[s, 0]
            if two[s, 0] >= 0:
                across[two[s, 0], two[s, 1]] = one[s, 0]
    return True


@kernel("b1(i8[:, ::1], i4[::1], i4[::1])")
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
    if points.shape[1] == 3:
        dx, dy, dz = points[a, 0] - points[b, 0], points[a, 1] - points[b, 1], points[a, 2] - points[b, 2]
        return np.sqrt(0.0 + dx * dx + dy * dy + dz * dz)
    sq = 0.0
    for d in range(points.shape[1]):
        diff = points[a, d] - points[b, d]
        sq += diff * diff
    return np.sqrt(sq)


@kernel("Tuple((f8, i8))(i4[::1], i4[::1], i8[:, ::1], f8[:, ::1], i8[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _edge_counts(indptr, elements, simplices, points, nbr, rows):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=elements.dtype)
    with_rows = rows.size > 0  # the mean alone needs no row sizes
    # how many neighbours each vertex has, and the lengths of the edges (a, b > a) summed
    # in the lexicographic order of the edges: only the higher neighbours kept in order
    total = 0.0
    n_edges = 0
    for a in range(V):
        below = 0
        above = 0
        for q in range(indptr[a], indptr[a + 1]):
            s = elements[q]
            for t in range(simplices.shape[1]):
                b = simplices[s, t]
                if b > a and mark[b] != a:
                    mark[b] = a
                    insert_sorted(nbr, above, b)
                    above += 1
                elif b < a and with_rows and mark[b] != a:
                    mark[b] = a
                    below += 1
        if with_rows:
            rows[a + 1] = rows[a] + below + above
        for p in range(above):
            total += _length(points, a, nbr[p])
        n_edges += above
    return total, n_edges


@kernel("void(i4[::1], i4[::1], i8[:, ::1], f8[:, ::1], i8[::1], i8[::1], i4[::1], f8[::1], f8)")
@numba.njit(cache=True, nogil=True)
def _edge_rows(indptr, elements, simplices, points, nbr, rows, cols, lengths, unit):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=elements.dtype)
    for a in range(V):
        count = _neighbours(a, indptr, elements, simplices, mark, nbr)
        start = rows[a]
        for p in range(count):
            cols[start + p] = nbr[p]
            lengths[start + p] = _length(points, a, nbr[p]) / unit


@kernel("void(i4[::1], i4[::1], i8[:, ::1], i8[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _stiffness_counts(indptr, elements, srt, nbr, rows):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=elements.dtype)
    for a in range(V):
        count = _neighbours(a, indptr, elements, srt, mark, nbr)
        rows[a + 1] = rows[a] + count + (1 if indptr[a + 1] > indptr[a] else 0)


@kernel("void(i4[::1], i4[::1], i8[:, ::1], i8[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _stiffness_columns(indptr, elements, srt, nbr, rows, cols, data):  # pragma: no cover - compiled
    """Each row's columns in order, the diagonal among them, and its entries zeroed."""
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=elements.dtype)
    for a in range(V):
        if indptr[a + 1] == indptr[a]:
            continue  # a vertex in no simplex: an empty row
        count = _neighbours(a, indptr, elements, srt, mark, nbr)
        q = rows[a]
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
        for q in range(rows[a], rows[a + 1]):
            data[q] = 0.0


@numba.njit(cache=True, nogil=True, inline="always")
def _term(g, i, j, w):  # pragma: no cover - compiled
    """``w g_i . g_j`` of a tetrahedron's gradients ``g`` (3, 4), in the general loop's order."""
    return (0.0 + g[0, i] * g[0, j] + g[1, i] * g[1, j] + g[2, i] * g[2, j]) * w


@numba.njit(cache=True, nogil=True, inline="always")
def _add_row4(cols, data, q, b, t0, t1, t2, t3):  # pragma: no cover - compiled
    """A tetrahedron's terms added to its vertices ``b`` (increasing) in the row from ``q``."""
    while cols[q] < b[0]:
        q += 1
    data[q] += t0
    while cols[q] < b[1]:
        q += 1
    data[q] += t1
    while cols[q] < b[2]:
        q += 1
    data[q] += t2
    while cols[q] < b[3]:
        q += 1
    data[q] += t3


@kernel("void(i8[:, ::1], f8[:, :, ::1], f8[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _stiffness_fill_tets(srt, grads, vol, rows, cols, data):  # pragma: no cover - compiled
    """:func:`_stiffness_fill` on tetrahedra in space, the same sums unrolled."""
    for e in range(srt.shape[0]):
        g, w = grads[e], vol[e]
        t00, t01, t02, t03 = _term(g, 0, 0, w), _term(g, 0, 1, w), _term(g, 0, 2, w), _term(g, 0, 3, w)
        t11, t12, t13 = _term(g, 1, 1, w), _term(g, 1, 2, w), _term(g, 1, 3, w)
        t22, t23, t33 = _term(g, 2, 2, w), _term(g, 2, 3, w), _term(g, 3, 3, w)
        b = srt[e]
        _add_row4(cols, data, rows[b[0]], b, t00, t01, t02, t03)
        _add_row4(cols, data, rows[b[1]], b, t01, t11, t12, t13)
        _add_row4(cols, data, rows[b[2]], b, t02, t12, t22, t23)
        _add_row4(cols, data, rows[b[3]], b, t03, t13, t23, t33)


@kernel("void(i8[:, ::1], f8[:, :, ::1], f8[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _stiffness_fill(srt, grads, vol, rows, cols, data):  # pragma: no cover - compiled
    # every simplex adds its terms vol g_i . g_j to the rows of its vertices, in increasing
    # order of the simplices: the order in which a sum over the vertex pairs of every
    # simplex adds them; its vertices, increasing, are found by one scan of each row
    E, k1 = srt.shape
    dim = grads.shape[1]
    for e in range(E):
        for i in range(k1):
            q = rows[srt[e, i]]
            for j in range(k1):
                while cols[q] < srt[e, j]:
                    q += 1
                t = 0.0
                for d in range(dim):
                    t += grads[e, d, i] * grads[e, d, j]
                data[q] += t * vol[e]


def stiffness_matrix(incidence, sorted_simplices, grads, vol):
    """``G^T diag(vol) G`` of simplices with barycentric gradients ``grads`` (over the
    vertices of ``sorted_simplices``), in canonical CSR form: the columns of each row read
    off the simplices at its vertex (``incidence``), then every simplex's terms added to
    the rows of its vertices.

    Each entry is the sum of the terms ``vol g_i . g_j`` in the order a scatter of every
    simplex's terms in simplex order makes (that of
    :func:`~ndboundary.domains.simplex_geometry.stiffness_terms`), without the table of
    every vertex pair and without storing the terms: each simplex's terms are computed
    once, its gradients read in one sweep in simplex order.

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
    _stiffness_columns(inc.indptr, inc.indices, srt, nbr, rows, cols, data)
    fill = _stiffness_fill_tets if k1 == 4 and grads.shape[1] == 3 else _stiffness_fill  # each compiles alone
    fill(srt, grads, vol, rows, cols, data)
    return sp.csr_matrix((data, cols, rows.astype(idx)), shape=(V, V))


@numba.njit(cache=True, nogil=True, inline="always")
def _cell_neighbours(a, indptr, cells, cell_ptr, cell_verts, mark, nbr):  # pragma: no cover - compiled
    """The distinct vertices of the cells at vertex ``a``, ``a`` among them, into ``nbr``
    in increasing order; their count.
    """
    count = 0
    for q in range(indptr[a], indptr[a + 1]):
        c = cells[q]
        for p in range(cell_ptr[c], cell_ptr[c + 1]):
            b = cell_verts[p]
            if mark[b] != a:
                mark[b] = a
                insert_sorted(nbr, count, b)
                count += 1
    return count


@kernel("void(i8[::1], i8[::1], i8[::1], i8[::1], i8[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _cell_block_counts(indptr, cells, cell_ptr, cell_verts, nbr, rows):  # pragma: no cover - compiled
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=np.int64)
    for a in range(V):
        rows[a + 1] = rows[a] + _cell_neighbours(a, indptr, cells, cell_ptr, cell_verts, mark, nbr)


@kernel("void(i8[::1], i8[::1], i8[::1], i8[::1], i8[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _cell_block_columns(indptr, cells, cell_ptr, cell_verts, nbr, rows, cols, data):  # pragma: no cover - compiled
    """Each row's columns in increasing order, and its entries zeroed."""
    V = indptr.size - 1
    mark = np.full(V, -1, dtype=np.int64)
    for a in range(V):
        count = _cell_neighbours(a, indptr, cells, cell_ptr, cell_verts, mark, nbr)
        for t in range(count):
            cols[rows[a] + t] = nbr[t]
            data[rows[a] + t] = 0.0


@kernel("void(i8[::1], i8[::1], f8[::1], i8[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _cell_block_fill(cell_ptr, cell_verts, blocks, block_ptr, rows, cols, data):  # pragma: no cover - compiled
    # cell c's block is the m x m matrix blocks[block_ptr[c]:][: m * m] (row-major, m its
    # vertex count); its symmetric part is added to the rows of its vertices in increasing
    # order of the cells, so entries (a, b) and (b, a) are the same sum in the same order
    for c in range(cell_ptr.size - 1):
        start = cell_ptr[c]
        m = cell_ptr[c + 1] - start
        base = block_ptr[c]
        for i in range(m):
            a = cell_verts[start + i]
            lo0 = rows[a]
            hi0 = rows[a + 1]
            for j in range(m):
                b = cell_verts[start + j]
                lo = lo0
                hi = hi0
                while hi - lo > 1:  # the column b in the row's increasing columns
                    mid = (lo + hi) // 2
                    if cols[mid] <= b:
                        lo = mid
                    else:
                        hi = mid
                data[lo] += 0.5 * (blocks[base + i * m + j] + blocks[base + j * m + i])


def assemble_cell_blocks(cell_ptr, cell_verts, blocks, block_ptr, n_vertices):
    """``sum_c P_c^T sym(B_c) P_c``: the symmetric parts of the cells' blocks added into a
    sparse matrix over the vertices, in canonical CSR form, exactly symmetric.

    The columns of each row are read off the cells at its vertex; each cell then adds its
    block to the rows of its vertices. Cells may share one block (cells of one shape, as
    the voxels of an image), so no block need be stored per cell.

    Parameters
    ----------
    cell_ptr : ndarray of int64 of shape (n_cells + 1,)
        Cell ``c``'s vertices are ``cell_verts[cell_ptr[c]:cell_ptr[c + 1]]``.
    cell_verts : ndarray of int64
    blocks : ndarray of float64
        The blocks, each ``m x m`` row-major for a cell of ``m`` vertices, one after another.
    block_ptr : ndarray of int64 of shape (n_cells,)
        Where cell ``c``'s block starts in ``blocks``.
    n_vertices : int

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n_vertices, n_vertices)
        A vertex in no cell has an empty row.

    Examples
    --------
    Two unit segments sharing vertex 1, one block for both:

    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import assemble_cell_blocks
    >>> block = np.array([1.0, -1.0, -1.0, 1.0])
    >>> K = assemble_cell_blocks(np.array([0, 2, 4]), np.array([0, 1, 1, 2]), block, np.array([0, 0]), 3)
    >>> K.toarray().tolist(), bool(K.has_canonical_format)
    ([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]], True)
    """
    cell_ptr = np.ascontiguousarray(cell_ptr, dtype=np.int64)
    cell_verts = np.ascontiguousarray(cell_verts, dtype=np.int64)
    V = int(n_vertices)
    owner = np.repeat(np.arange(cell_ptr.size - 1, dtype=np.int64), np.diff(cell_ptr))
    order, indptr = _entries_by_vertex(cell_verts, V)
    cells = owner[order]
    sizes = np.diff(cell_ptr)
    at_vertex = np.diff(indptr)
    nbr = np.empty(int(at_vertex.max(initial=0)) * int(sizes.max(initial=0)) + 1, dtype=np.int64)
    rows = np.zeros(V + 1, dtype=np.int64)
    _cell_block_counts(indptr, cells, cell_ptr, cell_verts, nbr, rows)
    idx = np.int32 if max(int(rows[-1]), V) < np.iinfo(np.int32).max else np.int64
    cols, data = np.empty(int(rows[-1]), dtype=idx), np.empty(int(rows[-1]))
    _cell_block_columns(indptr, cells, cell_ptr, cell_verts, nbr, rows, cols, data)
    blocks = np.ascontiguousarray(blocks, dtype=np.float64)
    _cell_block_fill(cell_ptr, cell_verts, blocks, np.ascontiguousarray(block_ptr, dtype=np.int64), rows, cols, data)
    return sp.csr_matrix((data, cols, rows.astype(idx)), shape=(V, V))


#: Rows below which one thread assembles the stiffness of stencils: each of its rows adds
#: a few dozen stencils of a few dozen vertices, far more work than a row of a sparse
#: product with a vector.
STENCIL_ROWS_PER_THREAD = 1000


@kernel("void(i8[::1], i8[::1], i8[:, ::1], i8[::1], i8, i8)")
@numba.njit(cache=True, nogil=True)
def _stencil_counts(indptr, cells, stencils, counts, start, stop):  # pragma: no cover - compiled
    """``counts[a + 1]``: the distinct vertices of the stencils at ``a``, for ``a`` in ``[start, stop)``."""
    mark = np.full(indptr.size - 1, -1, dtype=np.int64)
    for a in range(start, stop):
        count = 0
        for q in range(indptr[a], indptr[a + 1]):
            c = cells[q]
            for j in range(stencils.shape[1]):
                b = stencils[c, j]
                if b >= 0 and mark[b] != a:
                    mark[b] = a
                    count += 1
        counts[a + 1] = count


@kernel("void(i8[::1], i8[::1], i8[::1], i8[:, ::1], f8[:, :, ::1], f8[::1], i8[::1], i8[::1], f8[::1], i8, i8)")
@numba.njit(cache=True, nogil=True)
def _stencil_fill(indptr, cells, slots, stencils, coef, weight, rows, cols, data, start, stop):  # pragma: no cover
    # row a, for a in [start, stop): its columns sorted, then every stencil c at a (in
    # increasing order of c, a at its position slots[q]) adds row a of weight[c] D_c^T D_c;
    # entries (a, b) and (b, a) add the same products over the same stencils in the same
    # order, so the matrix is exactly symmetric
    pos = np.full(indptr.size - 1, -1, dtype=np.int64)
    m, width = coef.shape[1], coef.shape[2]
    acc = np.empty(width)
    for a in range(start, stop):
        lo = rows[a]
        count = 0
        for q in range(indptr[a], indptr[a + 1]):
            c = cells[q]
            for j in range(stencils.shape[1]):
                b = stencils[c, j]
                if b >= 0 and pos[b] != -2 - a:
                    pos[b] = -2 - a
                    cols[lo + count] = b
                    count += 1
        cols[lo : lo + count].sort()
        for t in range(count):
            pos[cols[lo + t]] = lo + t
            data[lo + t] = 0.0
        for q in range(indptr[a], indptr[a + 1]):
            c = cells[q]
            i = slots[q]
            acc[:] = 0.0
            for d in range(m):  # the row i of D_c^T D_c, its columns side by side
                g = coef[c, d, i]
                for j in range(width):
                    acc[j] += g * coef[c, d, j]
            w = weight[c]
            for j in range(width):
                b = stencils[c, j]
                if b >= 0:
                    data[pos[b]] += w * acc[j]


def stencil_stiffness(stencils, coef, weight, n_vertices):
    """``sum_c weight[c] P_c^T D_c^T D_c P_c``: the stiffness ``G^T diag(A) G`` of gradient
    stencils, in canonical CSR form, exactly symmetric.

    Stencil ``c`` holds the vertices ``stencils[c]`` (-1: none, its column skipped) and
    the gradient rows ``D_c = coef[c]`` over them. Each row of the matrix is assembled on
    its own (its columns, then every stencil at its vertex), in blocks of rows on several
    threads. The sparse product ``G^T diag(A) G`` of the same rows looks each product of
    two entries up ``m`` times (once per row of ``D_c``), on one thread, and sorts the
    result.

    Parameters
    ----------
    stencils : ndarray of int of shape (n_stencils, s)
    coef : ndarray of shape (n_stencils, m, s)
    weight : ndarray of shape (n_stencils,)
    n_vertices : int

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n_vertices, n_vertices)
        A vertex in no stencil has an empty row.

    Examples
    --------
    Two unit segments sharing vertex 1 (a one-row gradient each), the second of weight 2:

    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import stencil_stiffness
    >>> coef = np.array([[[-1.0, 1.0]], [[-1.0, 1.0]]])
    >>> K = stencil_stiffness(np.array([[0, 1], [1, 2]]), coef, np.array([1.0, 2.0]), 3)
    >>> K.toarray().tolist(), bool(K.has_canonical_format)
    ([[1.0, -1.0, 0.0], [-1.0, 3.0, -2.0], [0.0, -2.0, 2.0]], True)
    """
    stencils = np.ascontiguousarray(stencils, dtype=np.int64)
    coef = np.ascontiguousarray(coef, dtype=np.float64)
    weight = np.ascontiguousarray(weight, dtype=np.float64)
    V = int(n_vertices)
    order, indptr = _entries_by_vertex(stencils.ravel(), V)
    cells, slots = np.divmod(order, stencils.shape[1])
    rows = np.zeros(V + 1, dtype=np.int64)
    bounds = row_blocks(indptr, STENCIL_ROWS_PER_THREAD)
    _threaded(_stencil_counts, bounds, indptr, cells, stencils, rows)
    np.cumsum(rows, out=rows)
    cols, data = np.empty(int(rows[-1]), dtype=np.int64), np.empty(int(rows[-1]))
    _threaded(_stencil_fill, bounds, indptr, cells, slots, stencils, coef, weight, rows, cols, data)
    return sp.csr_matrix((data, cols, rows), shape=(V, V))


def _entries_by_vertex(verts, n_vertices):
    """The entries of ``verts`` grouped by vertex, each group in increasing order (-1
    entries left out), and the groups' bounds: ``(order, indptr)``, vertex ``a``'s entries
    being ``order[indptr[a]:indptr[a + 1]]``.
    """
    order = np.argsort(verts, kind="stable")
    order = order[verts[order] >= 0]
    indptr = np.zeros(n_vertices + 1, dtype=np.int64)
    np.cumsum(np.bincount(verts[order], minlength=n_vertices), out=indptr[1:])
    return order, indptr


def _threaded(kernel, bounds, *args):
    """``kernel(*args, start, stop)`` for each block ``[start, stop)`` of ``bounds``, on threads."""
    blocks = list(zip(bounds[:-1], bounds[1:], strict=True))
    if len(blocks) == 1:
        kernel(*args, *blocks[0])
        return
    with ThreadPoolExecutor(len(blocks)) as pool:
        for f in [pool.submit(kernel, *args, lo, hi) for lo, hi in blocks]:
            f.result()


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
    rows = np.zeros(V + 1 if with_graph else 0, dtype=np.int64)
    total, n_edges = _edge_counts(indptr, elements, simplices, points, nbr, rows)
    mean = float(total / n_edges) if n_edges else float("nan")
    if not with_graph:
        return None, mean
    idx = np.int32 if max(int(rows[-1]), V) < np.iinfo(np.int32).max else np.int64
    cols, lengths = np.empty(int(rows[-1]), dtype=idx), np.empty(int(rows[-1]))
    _edge_rows(indptr, elements, simplices, points, nbr, rows, cols, lengths, float(unit))
    graph = sp.csr_matrix((lengths, cols, rows.astype(idx)), shape=(V, V))
    return graph, mean


#: Rows of the matrix that :func:`assemble_box_stencil` builds at a time, in a buffer of
#: one slot per stencil offset that the block reuses (a few MB, which stays in cache
#: instead of a buffer over every row first touched).
BOX_STENCIL_BLOCK_ROWS = 8192


@kernel("void(i8[:, ::1], i8[::1], i8[::1], i8[::1], f8[::1], i8[:, ::1], i8[::1], i4[::1], f8[::1], b1, i8, i8)")
@numba.njit(cache=True, nogil=True)
def _box_stencil_blocks(
    corners, first, second, slot, value, blocks, rows, cols, out, count, start, stop
):  # pragma: no cover - compiled
    # for each block b of start..stop, rows blocks[b, 0]..blocks[b, 1], whose cells are
    # blocks[b, 2]..blocks[b, 3]: every cell adds value[p] to the entry (corners[c,
    # first[p]], corners[c, second[p]]) of the rows in the block, kept in the row's slot
    # slot[p] (one slot per offset between two corners); then either the rows' entries
    # are counted (rows[a + 1], count) or written from rows[a] on in the slots' order
    n_slots = 0
    for p in range(slot.size):
        n_slots = max(n_slots, slot[p] + 1)
    size = 0
    for b in range(start, stop):
        size = max(size, blocks[b, 1] - blocks[b, 0])
    nbr = np.empty((size, n_slots), dtype=np.int32)
    data = np.empty((size, n_slots))
    for b in range(start, stop):
        lo, hi = blocks[b, 0], blocks[b, 1]
        nbr[: hi - lo] = -1
        data[: hi - lo] = 0.0
        for c in range(blocks[b, 2], blocks[b, 3]):
            for p in range(first.size):
                a = corners[c, first[p]]
                if lo <= a < hi:
                    nbr[a - lo, slot[p]] = corners[c, second[p]]
                    data[a - lo, slot[p]] += value[p]
        for a in range(lo, hi):
            if count:
                k = 0
                for s in range(n_slots):
                    if nbr[a - lo, s] >= 0:
                        k += 1
                rows[a + 1] = k
            else:
                t = rows[a]
                for s in range(n_slots):
                    if nbr[a - lo, s] >= 0:
                        cols[t] = nbr[a - lo, s]
                        out[t] = data[a - lo, s]
                        t += 1


def assemble_box_stencil(corners, block, offsets, n_vertices):
    """``sum_c P_c^T B P_c`` for cells that all share the symmetric block ``B`` (the voxels
    of an image), in canonical CSR form, without a search: each row keeps one slot per
    offset between two corners of a cell, so every entry of a cell goes straight to its
    slot, and the slots, in increasing order of the offset, are the row's columns in
    increasing order when the vertices are numbered in the order of their positions
    (as a grid's corners are). The zero entries of ``B`` are left out of the pattern.

    Parameters
    ----------
    corners : ndarray of int of shape (n_cells, m)
        Every cell's vertices.
    block : ndarray of shape (m, m)
        The block every cell shares, symmetric.
    offsets : ndarray of int of shape (m,)
        Every corner's position in the vertex order, relative to the cell's first corner
        (the grid's corner strides): the offset ``offsets[j] - offsets[i]`` names the slot
        of ``(i, j)``, and its order the columns' order.
    n_vertices : int

    Returns
    -------
    scipy.sparse.csr_matrix of shape (n_vertices, n_vertices)

    Examples
    --------
    Two unit segments sharing vertex 1:

    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import assemble_box_stencil
    >>> block = np.array([[1.0, -1.0], [-1.0, 1.0]])
    >>> K = assemble_box_stencil(np.array([[0, 1], [1, 2]]), block, np.array([0, 1]), 3)
    >>> K.toarray().tolist(), bool(K.has_canonical_format)
    ([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]], True)
    """
    corners = np.ascontiguousarray(corners, dtype=np.int64)
    block = np.asarray(block, dtype=np.float64)
    first, second = np.nonzero(block)
    step = np.asarray(offsets, dtype=np.int64)
    shifts, slot = np.unique(step[second] - step[first], return_inverse=True)
    V = int(n_vertices)
    if V >= np.iinfo(np.int32).max:
        raise ValueError(f"{V} vertices are too many for 32-bit column indices")
    # the cells whose corners reach rows lo..hi: those whose lowest corner is below hi and
    # whose highest is lo or above, a range of cells when both grow with the cell (cells
    # in the order of their positions, as a grid's)
    low, high = corners.min(axis=1), corners.max(axis=1)
    if corners.shape[0] > 1 and not (np.all(low[1:] >= low[:-1]) and np.all(high[1:] >= high[:-1])):
        order = np.argsort(low, kind="stable")
        corners, low = corners[order], low[order]
        high = np.maximum.accumulate(high[order])  # bounds the cells' ranges from above
    lo = np.arange(0, V, BOX_STENCIL_BLOCK_ROWS, dtype=np.int64)
    hi = np.minimum(lo + BOX_STENCIL_BLOCK_ROWS, V)
    blocks = np.stack([lo, hi, np.searchsorted(high, lo, side="left"), np.searchsorted(low, hi, side="left")], axis=1)
    args = (corners, first.astype(np.int64), second.astype(np.int64), slot.astype(np.int64).ravel(),
            np.ascontiguousarray(block[first, second]), np.ascontiguousarray(blocks, dtype=np.int64))  # fmt: skip
    bounds = row_blocks(np.arange(lo.size + 1), 2)  # blocks of rows, as many to each thread
    rows = np.zeros(V + 1, dtype=np.int64)
    _threaded(_box_stencil_blocks, bounds, *args, rows, np.empty(0, np.int32), np.empty(0), True)
    np.cumsum(rows, out=rows)
    cols, out = np.empty(int(rows[-1]), dtype=np.int32), np.empty(int(rows[-1]))
    _threaded(_box_stencil_blocks, bounds, *args, rows, cols, out, False)
    return sp.csr_matrix((out, cols, rows.astype(np.int32)), shape=(V, V))


@kernel("void(f8[:, ::1], i8[:, ::1], i8[::1], f8[:, ::1])")
@numba.njit(cache=True, nogil=True)
def _corner_means(points, corners, rows, out):  # pragma: no cover - compiled
    k = corners.shape[1]
    for a in range(rows.size):
        e = rows[a]
        for d in range(points.shape[1]):
            s = points[corners[e, 0], d]
            for c in range(1, k):
                s += points[corners[e, c], d]
            out[a, d] = s / k


def corner_means(points, corners, rows=None):
    """The means of ``points`` over the rows ``rows`` (all by default) of ``corners``, each
    summed in its order: a cell's centroid, without the (cell, corner, axis) table of
    gathered points.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import corner_means
    >>> points = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    >>> corner_means(points, np.array([[0, 1, 2, 3], [0, 1, 1, 0]]), np.array([1])).tolist()
    [[1.0, 0.0]]
    """
    corners = np.ascontiguousarray(corners, dtype=np.int64)
    rows = np.arange(corners.shape[0]) if rows is None else np.ascontiguousarray(rows, dtype=np.int64)
    out = np.empty((rows.size, points.shape[1]))
    _corner_means(np.ascontiguousarray(points, dtype=np.float64), corners, rows, out)
    return out


@kernel("void(f8[::1], i8[:, ::1], f8[::1])", "void(i8[::1], i8[:, ::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def _corner_max(f, corners, out):  # pragma: no cover - compiled
    for e in range(corners.shape[0]):
        m = f[corners[e, 0]]
        for c in range(1, corners.shape[1]):
            v = f[corners[e, c]]
            if v > m or v != v:  # a NaN wins, as in np.maximum
                m = v
        out[e] = m


def corner_max(f, corners):
    """Per row of ``corners``, the largest of the values ``f`` at its vertices (NaN if any
    is NaN, as ``np.maximum`` gives it), of ``f``'s type: integers (labels) are compared
    as 64-bit integers, other numbers as doubles.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_mesh import corner_max
    >>> corner_max(np.array([0.0, 3.0, 1.0, np.nan]), np.array([[0, 1, 2], [2, 3, 0]])).tolist()
    [3.0, nan]
    >>> corner_max(np.array([4, 1, 2], dtype=np.int32), np.array([[1, 2], [0, 2]]))
    array([2, 4], dtype=int32)
    """
    f = np.asarray(f)
    wide = np.int64 if f.dtype.kind in "biu" else np.float64
    corners = np.ascontiguousarray(corners, dtype=np.int64)
    out = np.empty(corners.shape[0], dtype=wide)
    _corner_max(np.ascontiguousarray(f, dtype=wide), corners, out)
    return out.astype(f.dtype, copy=False)
