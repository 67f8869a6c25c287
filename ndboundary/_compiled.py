"""Compiled loops (numba) for the hot spots: the field smoothing, and the edges and incidence
of simplicial complexes.
"""

from __future__ import annotations

from functools import partial

import numba
import numpy as np
import scipy.sparse as sp

from ._kernels import kernel
from ._threads import available_threads, shared_pool


@numba.njit(cache=True, nogil=True, inline="always")
def _unit_row(B, i, x, y, z):  # pragma: no cover - compiled
    """Row ``i`` of ``B`` set to ``(x, y, z)`` scaled to unit length (zero stays zero)."""
    s = x * x + y * y + z * z
    if s > 0.0:
        s = 1.0 / np.sqrt(s)
    B[i, 0] = x * s
    B[i, 1] = y * s
    B[i, 2] = z * s


@numba.njit(cache=True, nogil=True, inline="always")
def sort_short(values, start, stop):  # pragma: no cover - compiled
    """Sort ``values[start:stop]`` in place by insertion: a few dozen entries, where numba's
    sort of a short slice costs ten times more.
    """
    for a in range(start + 1, stop):
        value = values[a]
        b = a - 1
        while b >= start and values[b] > value:
            values[b + 1] = values[b]
            b -= 1
        values[b + 1] = value


@numba.njit(cache=True, nogil=True, inline="always")
def _accumulate(i, j, value, mark, acc, columns, count):  # pragma: no cover - compiled
    """Add ``value`` to column ``j`` of row ``i`` summed in the dense ``acc``, the column
    appended to ``columns`` at ``count`` when first met (``mark[j] == i`` then); returns
    the columns' new count.
    """
    if mark[j] != i:
        mark[j] = i
        acc[j] = 0.0
        columns[count] = j
        count += 1
    acc[j] += value
    return count


@numba.njit(cache=True, nogil=True, inline="always")
def insert_sorted(values, count, b):  # pragma: no cover - compiled
    """Insert ``b`` into the increasing ``values[:count]``; a few dozen entries at most."""
    t = count
    while t > 0 and values[t - 1] > b:
        values[t] = values[t - 1]
        t -= 1
    values[t] = b


@kernel("void(i4[::1], i4[::1], f8[::1], f8[:, ::1], f8[:, ::1], i8, i8)")
@numba.njit(cache=True, nogil=True)
def _sweep3(indptr, indices, data, A, B, start, stop):  # pragma: no cover - compiled
    for i in range(start, stop):
        x = 0.0
        y = 0.0
        z = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            w = data[p]
            x += w * A[j, 0]
            y += w * A[j, 1]
            z += w * A[j, 2]
        _unit_row(B, i, x, y, z)


@kernel("void(i4[::1], i4[::1], f8[:, ::1], f8[:, ::1], b1, i8, i8)")
@numba.njit(cache=True, nogil=True)
def _sweep3_unit(indptr, indices, A, B, with_self, start, stop):  # pragma: no cover - compiled
    for i in range(start, stop):
        x = 0.0
        y = 0.0
        z = 0.0
        pending = with_self  # the row's own vector, added where its column would sort
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if pending and j > i:
                x += A[i, 0]
                y += A[i, 1]
                z += A[i, 2]
                pending = False
            x += A[j, 0]
            y += A[j, 1]
            z += A[j, 2]
        if pending:
            x += A[i, 0]
            y += A[i, 1]
            z += A[i, 2]
        _unit_row(B, i, x, y, z)


@kernel("void(i4[::1], i4[::1], f8[::1], f8[:, ::1], f8[:, ::1], i8, i8)")
@numba.njit(cache=True, nogil=True)
def _sweep(indptr, indices, data, A, B, start, stop):  # pragma: no cover - compiled
    d = A.shape[1]
    for i in range(start, stop):
        for c in range(d):
            B[i, c] = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            w = data[p]
            for c in range(d):
                B[i, c] += w * A[j, c]
        s = 0.0
        for c in range(d):
            s += B[i, c] * B[i, c]
        if s > 0.0:
            s = 1.0 / np.sqrt(s)
        for c in range(d):
            B[i, c] *= s


# the sweeps' dispatchers, which compiled callers call
_sweep3_rows, _sweep3_unit_rows, _sweep_rows = _sweep3.jit, _sweep3_unit.jit, _sweep.jit


#: the row sweeps :func:`_sweep_passes` runs, by ``kind``
SWEEP, SWEEP3, SWEEP3_UNIT = 0, 1, 2


@kernel("i8(i4[::1], i4[::1], f8[::1], f8[:, ::1], f8[:, ::1], i8, b1, i8)")
@numba.njit(cache=True, nogil=True)
def _sweep_passes(indptr, indices, data, A, B, kind, with_self, passes):  # pragma: no cover - compiled
    """``passes`` sweeps over every row of :func:`_sweep`, :func:`_sweep3` or
    :func:`_sweep3_unit` (``kind``: :data:`SWEEP`, :data:`SWEEP3`, :data:`SWEEP3_UNIT`,
    which reads no ``data``), ``A`` and ``B`` swapped after each; returns 0 when the last
    sweep's rows are in ``A``, 1 when in ``B``.
    """
    n = indptr.size - 1
    for k in range(passes):
        src, dst = (A, B) if k % 2 == 0 else (B, A)
        if kind == SWEEP3_UNIT:
            _sweep3_unit_rows(indptr, indices, src, dst, with_self, 0, n)
        elif kind == SWEEP3:
            _sweep3_rows(indptr, indices, data, src, dst, 0, n)
        else:
            _sweep_rows(indptr, indices, data, src, dst, 0, n)
    return passes % 2


def smooth_rows_compiled(W, X, passes, plus_identity=False):
    """``passes`` sweeps of ``X <- normalize_rows(W @ X)``, each row in one go (``W + I``
    for ``plus_identity``, never formed when ``W``'s weights are ones).

    ``W`` is a CSR matrix with sorted indices, ``X`` an (n, d) array (not modified). Every sweep reads the
    previous sweep's rows only (Jacobi order), so the result does not depend on the row
    order, and blocks of rows are swept on several threads (:func:`row_blocks`) with the
    same result; zero rows stay zero. Summing and renormalising a row in one loop reads the
    field once per sweep instead of the four passes of a sparse product and a
    renormalisation.
    """
    d = X.shape[1]
    unit = d in (2, 3) and (W.data == 1.0).all()
    if plus_identity and not unit:
        W = (W + sp.identity(W.shape[0], format="csr")).tocsr()
    # planar fields run through the 3-column loop with a zero third component
    sweep = _sweep3 if d in (2, 3) else _sweep
    # the structure as it comes (int32 or int64): a copy would double the bytes each
    # sweep reads
    indptr, indices = W.indptr, W.indices
    data = W.data.astype(np.float64, copy=False)
    A = np.zeros((X.shape[0], 3 if d == 2 else d))
    A[:, :d] = X
    B = np.empty_like(A)
    if unit:  # uniform weights (the usual case): no weights to read

        def one(A, B, rows):
            _sweep3_unit(indptr, indices, A, B, bool(plus_identity), *rows)
    else:

        def one(A, B, rows):
            sweep(indptr, indices, data, A, B, *rows)

    bounds = row_blocks(indptr)
    if len(bounds) == 2:  # one block: every sweep in one call, without a thread per sweep
        kind = SWEEP3_UNIT if unit else SWEEP3 if d in (2, 3) else SWEEP
        A = B if _sweep_passes(indptr, indices, data, A, B, kind, bool(plus_identity), passes) else A
        return A[:, :d].copy() if d == 2 else A
    blocks = list(zip(bounds[:-1], bounds[1:], strict=True))
    for _ in range(passes):
        # every row reads the previous sweep's rows only: the blocks are independent
        list(shared_pool().map(partial(one, A, B), blocks))
        A, B = B, A
    return A[:, :d].copy() if d == 2 else A


#: rows below which one thread sweeps them all
MIN_ROWS_PER_THREAD = 20_000


def row_blocks(indptr, min_rows=None):
    """Row bounds of one block per thread (one block for fewer than ``2 min_rows`` rows,
    :data:`MIN_ROWS_PER_THREAD` by default), with about equal numbers of entries.
    """
    n = indptr.size - 1
    blocks = max(1, min(available_threads(), n // (min_rows or MIN_ROWS_PER_THREAD)))
    cuts = np.searchsorted(indptr, np.arange(1, blocks) * (int(indptr[-1]) / blocks))
    return [0, *(int(c) for c in np.minimum(cuts, n)), n]


@kernel("Tuple((i4[:, ::1], i8[::1]))(i4[::1], i4[::1], i8)")
@numba.njit(cache=True, nogil=True)
def _unique_pairs(first, second, n):  # pragma: no cover - compiled
    m = first.size
    starts = np.zeros(n + 1, dtype=np.int64)
    for p in range(m):
        starts[first[p] + 1] += 1
    for a in range(n):
        starts[a + 1] += starts[a]
    fill = starts[:-1].copy()
    bucket = np.empty(m, dtype=np.int64)  # pair ids grouped by their first vertex
    for p in range(m):
        a = first[p]
        bucket[fill[a]] = p
        fill[a] += 1
    mark = np.full(n, -1, dtype=np.int64)
    local = np.zeros(n, dtype=np.int64)
    unique = np.empty(n, dtype=np.int64)
    edges = np.empty((m, 2), dtype=first.dtype)
    pair_edge = np.empty(m, dtype=np.intp)
    n_edges = 0
    for a in range(n):
        count = 0
        for q in range(starts[a], starts[a + 1]):
            b = second[bucket[q]]
            if mark[b] != a:
                mark[b] = a
                insert_sorted(unique, count, b)
                count += 1
        for t in range(count):
            local[unique[t]] = n_edges + t
            edges[n_edges + t, 0] = a
            edges[n_edges + t, 1] = unique[t]
        for q in range(starts[a], starts[a + 1]):
            p = bucket[q]
            pair_edge[p] = local[second[p]]
        n_edges += count
    return edges[:n_edges].copy(), pair_edge


def unique_pairs(first, second, n):
    """The distinct pairs ``(first[i], second[i])`` (values in ``0..n-1``), sorted
    lexicographically, and the index of each input pair among them, in linear time.

    A counting sort by ``first``, then within each value of ``first`` its distinct
    ``second`` values kept in order as they are met (a vertex has a few neighbours).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled import unique_pairs
    >>> edges, which = unique_pairs(np.array([2, 0, 0, 2, 0]), np.array([3, 2, 1, 3, 2]), 4)
    >>> edges.tolist(), which.tolist()
    ([[0, 1], [0, 2], [2, 3]], [2, 1, 0, 2, 1])
    """
    return _unique_pairs(np.ascontiguousarray(first), np.ascontiguousarray(second), int(n))


@kernel("void(i8[:, ::1], i8, i4[::1], i4[::1])")
@numba.njit(cache=True, nogil=True)
def _rows_by_value(rows, n, indptr, indices):  # pragma: no cover - compiled
    m, width = rows.shape
    for r in range(m):
        for c in range(width):
            indptr[rows[r, c] + 1] += 1
    for v in range(n):
        indptr[v + 1] += indptr[v]
    fill = indptr[:-1].copy()
    for r in range(m):
        for c in range(width):
            v = rows[r, c]
            indices[fill[v]] = r
            fill[v] += 1


def rows_by_value(rows, n, dtype):
    """The transpose of a fixed-width integer array as CSR structure: for every value
    ``v`` in ``0..n-1``, the rows holding it, in increasing order (``indptr``, ``indices``
    of ``dtype``), in one counting pass.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled import rows_by_value
    >>> indptr, indices = rows_by_value(np.array([[0, 1], [1, 2]]), 3, np.int32)
    >>> indptr.tolist(), indices.tolist()
    ([0, 1, 3, 4], [0, 0, 1, 1])
    """
    rows = np.ascontiguousarray(rows)
    indptr = np.zeros(int(n) + 1, dtype=dtype)
    indices = np.empty(rows.size, dtype=dtype)
    _rows_by_value(rows, int(n), indptr, indices)
    return indptr, indices


@numba.njit(cache=True, nogil=True)
def _root(parent, v):  # pragma: no cover - compiled
    while parent[v] != v:
        parent[v] = parent[parent[v]]  # path halving
        v = parent[v]
    return v


@kernel("i8(i8[:, ::1], i4[::1])")
@numba.njit(cache=True, nogil=True)
def _components(rows, labels):  # pragma: no cover - compiled
    n = labels.size
    parent = np.arange(n)
    for r in range(rows.shape[0]):
        a = _root(parent, rows[r, 0])
        for c in range(1, rows.shape[1]):
            b = _root(parent, rows[r, c])
            # the lower vertex stays the root: every root is its component's lowest vertex
            if b < a:
                parent[a] = b
                a = b
            elif b > a:
                parent[b] = a
    count = 0
    for v in range(n):
        a = _root(parent, v)
        if a == v:
            labels[v] = count
            count += 1
        else:
            labels[v] = labels[a]  # a < v: labelled already
    return count


def row_components(rows, n):
    """The connected components of the values ``0..n-1`` joined by the rows of an integer
    array (the vertices of simplices): ``(n_components, labels)``, numbered in the order
    of their lowest value, as :func:`scipy.sparse.csgraph.connected_components` numbers
    the components of the graph of the rows' edges. One union-find pass, without the graph.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled import row_components
    >>> n, labels = row_components(np.array([[0, 3], [4, 1], [3, 5]]), 6)
    >>> n, labels.tolist()  # 2 is in no row: a component of its own
    (3, [0, 1, 2, 0, 1, 0])
    """
    labels = np.empty(int(n), dtype=np.int32)
    count = _components(np.ascontiguousarray(rows), labels)
    return int(count), labels


@kernel("void(i8[:, ::1], f8[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _row_sums(rows, weights, out):  # pragma: no cover - compiled
    for r in range(rows.shape[0]):
        for c in range(rows.shape[1]):
            out[rows[r, c]] += weights[r]


def row_sums(rows, weights, n):
    """For every value ``0..n-1``, the sum of ``weights[r]`` over the rows ``r`` holding it:
    ``np.bincount(rows.ravel(), weights=np.repeat(weights, rows.shape[1]), minlength=n)``,
    the same sums in the same order, without the repeated weights.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled import row_sums
    >>> row_sums(np.array([[0, 1], [1, 2]]), np.array([1.0, 10.0]), 4).tolist()
    [1.0, 11.0, 10.0, 0.0]
    """
    out = np.zeros(int(n))
    _row_sums(np.ascontiguousarray(rows), np.ascontiguousarray(weights, dtype=np.float64), out)
    return out


@kernel("void(i4[::1], i4[::1], f8[::1], f8[::1], f8[::1], i8, i8)")
@numba.njit(cache=True, nogil=True)
def _csr_rows(indptr, indices, data, x, y, start, stop):  # pragma: no cover - compiled
    for i in range(start, stop):
        s = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            s += data[p] * x[indices[p]]
        y[i] = s


#: entries below which one thread multiplies a matrix by a vector
MIN_ENTRIES_PER_THREAD = 1_000_000
#: mean entries a row below which one thread multiplies a matrix by a vector: on the short
#: rows of a mesh's stiffness scipy's loop is the faster (a voxel band's 14.5 M entries, 26 a
#: row: 9.3 ms on one thread, 12.9 ms on two), on a neighbour graph's long rows the threads
#: (11.3 M entries, 564 a row: 15.6 ms on one, 10.0 ms on two)
MIN_ENTRIES_PER_ROW = 100


class ThreadedMatvec:
    """``K @ x`` for a CSR matrix on several threads, each a block of rows
    (:func:`row_blocks`); the same bits as scipy's product, whose row sums run in the
    same order.

    Conjugate gradients on a neighbour graph's stiffness (hundreds of entries a row) spend
    most of their time in this product, which scipy computes on one thread. One block
    (scipy itself) for matrices under :data:`MIN_ENTRIES_PER_THREAD` entries a thread or
    :data:`MIN_ENTRIES_PER_ROW` entries a row, or without 32-bit indices.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled import ThreadedMatvec, available_threads
    >>> K = sp.random(400, 400, density=0.5, format="csr", random_state=0)  # 200 entries a row
    >>> x = np.arange(400.0)
    >>> product = ThreadedMatvec(K, min_entries=1000)
    >>> len(product.blocks) > 1 or available_threads() == 1, bool(np.array_equal(product(x), K @ x))
    (True, True)
    """

    def __init__(self, K, min_entries=None):
        self.K = sp.csr_matrix(K)
        nnz, n = self.K.nnz, self.K.shape[0]
        per_thread = MIN_ENTRIES_PER_THREAD if min_entries is None else min_entries
        bounds = row_blocks(self.K.indptr, min_rows=max(1, int(per_thread * n / max(nnz, 1))))
        fits = self.K.indptr.dtype == np.int32 and self.K.indices.dtype == np.int32
        long_rows = nnz >= MIN_ENTRIES_PER_ROW * n
        self.blocks = list(zip(bounds[:-1], bounds[1:], strict=True)) if fits and long_rows else [(0, n)]
        self.data = self.K.data.astype(np.float64, copy=False)

    def __call__(self, x):
        if len(self.blocks) == 1:
            return self.K @ x
        x = np.ascontiguousarray(x, dtype=np.float64)
        y = np.empty(self.K.shape[0])
        rows = partial(_csr_rows, self.K.indptr, self.K.indices, self.data, x, y)
        list(shared_pool().map(lambda block: rows(*block), self.blocks))
        return y


@kernel("void(i4[::1], i4[::1], i8[::1])", "void(i8[::1], i8[::1], i8[::1])")
@numba.njit(cache=True, nogil=True)
def diagonal_slots(indptr, indices, out):  # pragma: no cover - compiled
    """``out[i]``: the position of row ``i``'s diagonal entry in the CSR arrays, -1 if none."""
    for i in range(out.size):
        out[i] = -1
        for p in range(indptr[i], indptr[i + 1]):
            if indices[p] == i:
                out[i] = p
                break


def _index_arrays(A):
    """The CSR matrix ``A``'s index arrays as the kernels' signatures take them: both
    32-bit or both 64-bit.
    """
    if A.indptr.dtype != A.indices.dtype or A.indices.dtype not in (np.int32, np.int64):
        return A.indptr.astype(np.int64), A.indices.astype(np.int64)
    return A.indptr, A.indices


def plus_diagonal(K, d):
    """``K + diag(d)`` for a square CSR matrix that stores its whole diagonal, sharing
    ``K``'s index arrays (``K`` + ``diags(d)`` otherwise): on a large system the sum's own
    copy of the pattern costs time and memory (40 M entries for the band of a 256^3 voxel
    ball: 0.5 GB and over a second). ``K`` is not modified.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled import plus_diagonal
    >>> K = sp.csr_matrix(np.array([[2.0, -1.0], [-1.0, 2.0]]))
    >>> A = plus_diagonal(K, np.array([1.0, 3.0]))
    >>> A.toarray().tolist(), np.shares_memory(A.indices, K.indices), K.toarray().tolist()
    ([[3.0, -1.0], [-1.0, 5.0]], True, [[2.0, -1.0], [-1.0, 2.0]])
    """
    K = sp.csr_matrix(K)
    n = K.shape[0]
    slots = np.full(n, -1, dtype=np.int64)
    if K.shape[1] == n:
        diagonal_slots(*_index_arrays(K), slots)
    if (slots < 0).any():
        return (K + sp.diags(d)).tocsr()
    data = K.data.astype(np.float64, copy=True)
    data[slots] += d
    return sp.csr_matrix((data, K.indices, K.indptr), shape=K.shape)


@kernel("void(i4[::1], i4[::1], f8[::1], f8[::1])", "void(i8[::1], i8[::1], f8[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _pattern_sums(indptr, indices, x, out):  # pragma: no cover - compiled
    for i in range(out.size):
        s = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            s += x[indices[p]]
        out[i] = s


def pattern_sums(A, x):
    """``ones(A) @ x``: every row's sum of ``x`` over its stored columns, without a matrix
    of ones of ``A``'s size.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled import pattern_sums
    >>> A = sp.csr_matrix(np.array([[2.0, -1.0, 0.0], [0.0, 0.0, 5.0]]))
    >>> pattern_sums(A, np.array([1.0, 10.0, 100.0])).tolist()
    [11.0, 100.0]
    """
    A = sp.csr_matrix(A)
    x = np.ascontiguousarray(x, dtype=np.float64)
    out = np.empty(A.shape[0])
    _pattern_sums(*_index_arrays(A), x, out)
    return out


_SQUARED_UPPER = (
    "Tuple((i8[::1], i4[::1], f8[::1]))({i}[::1], {i}[::1], f8[::1], f8[::1], f8, {i}[::1], {i}[::1], f8[::1], f8)"
)


@kernel(_SQUARED_UPPER.format(i="i4"), _SQUARED_UPPER.format(i="i8"))
@numba.njit(cache=True, nogil=True)
def _squared_upper(indptr, indices, data, dinv, mu, tptr, tind, tdat, lam):  # pragma: no cover - compiled
    """The upper triangle of ``K diag(dinv) K + mu K + lam T`` (``K`` and ``T`` symmetric,
    in CSR form), in CSR form with sorted columns: two passes over the rows, the columns
    of each marked in a table, the values summed in a dense row (:func:`_accumulate`) and
    the columns sorted by :func:`sort_short`.
    """
    n = indptr.size - 1
    mark = np.full(n, -1, dtype=np.int64)
    out_ptr = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        count = 0
        for p in range(indptr[i], indptr[i + 1]):
            k = indices[p]
            for q in range(indptr[k], indptr[k + 1]):
                j = indices[q]
                if j >= i and mark[j] != i:
                    mark[j] = i
                    count += 1
            if k >= i and mark[k] != i:
                mark[k] = i
                count += 1
        for p in range(tptr[i], tptr[i + 1]):
            j = tind[p]
            if j >= i and mark[j] != i:
                mark[j] = i
                count += 1
        out_ptr[i + 1] = out_ptr[i] + count
    out_ind = np.empty(out_ptr[n], dtype=np.int32)
    out_dat = np.empty(out_ptr[n], dtype=np.float64)
    acc = np.zeros(n)
    mark[:] = -1
    for i in range(n):
        start = count = out_ptr[i]
        for p in range(indptr[i], indptr[i + 1]):
            k = indices[p]
            a = data[p] * dinv[k]
            for q in range(indptr[k], indptr[k + 1]):
                if indices[q] >= i:
                    count = _accumulate(i, indices[q], a * data[q], mark, acc, out_ind, count)
        for p in range(indptr[i], indptr[i + 1]):
            if indices[p] >= i:
                count = _accumulate(i, indices[p], mu * data[p], mark, acc, out_ind, count)
        for p in range(tptr[i], tptr[i + 1]):
            if tind[p] >= i:
                count = _accumulate(i, tind[p], lam * tdat[p], mark, acc, out_ind, count)
        sort_short(out_ind, start, count)
        for t in range(start, count):
            out_dat[t] = acc[out_ind[t]]
    return out_ptr, out_ind, out_dat


def squared_upper(K, mass, mu, T, lam):
    """The upper triangle of ``K M^{-1} K + mu K + lam T`` as a CSR matrix with sorted
    columns (the integration's matrix, for a factorisation that reads one triangle), ``K``
    and ``T`` symmetric, ``M = diag(mass)``: summed in one compiled call that releases
    the GIL, where the sparse products, their symmetrisation and the triangle's
    extraction each hold it.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled import squared_upper
    >>> K = sp.csr_matrix(np.array([[1.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]]))
    >>> T = sp.csr_matrix(([1.0], ([0], [0])), shape=(3, 3))
    >>> U = squared_upper(K, np.array([1.0, 2.0, 1.0]), 0.5, T, 3.0)
    >>> Q = (K @ sp.diags([1.0, 0.5, 1.0]) @ K + 0.5 * K + 3.0 * T).toarray()
    >>> bool(np.allclose(U.toarray(), np.triu(Q)))
    True
    """
    K, T = sp.csr_matrix(K), sp.csr_matrix(T)
    index = np.int32 if max(K.nnz, T.nnz, K.shape[0]) < 2**31 - 1 else np.int64
    arrays = [np.ascontiguousarray(a, dtype=index) for a in (K.indptr, K.indices)]
    t_arrays = [np.ascontiguousarray(a, dtype=index) for a in (T.indptr, T.indices)]
    dinv = 1.0 / np.asarray(mass, dtype=np.float64)
    indptr, indices, data = _squared_upper(
        arrays[0], arrays[1], np.ascontiguousarray(K.data, dtype=np.float64), dinv, float(mu),
        t_arrays[0], t_arrays[1], np.ascontiguousarray(T.data, dtype=np.float64), float(lam),
    )  # fmt: skip
    U = sp.csr_matrix((data, indices, indptr), shape=K.shape)
    U.has_sorted_indices = True
    return U


@kernel("void(f8[:, ::1], f8[:, :, ::1], i8[:, :], f8[:, :], f8[:, ::1], f8[:, ::1], f8[:, :, ::1])")
@numba.njit(cache=True, nogil=True)
def ambient_values(c, g, ind, X, lo, hi, out):  # pragma: no cover - compiled
    """``out[b, q, r] = c[u, r] + g[u, r] . X[b]`` for ``u = ind[b, q]``, clipped to
    ``[lo[u, r], hi[u, r]]``: first-order extensions of functions from the neighbours
    ``ind`` of the points ``X``, with gradients ``g`` in ambient coordinates, summed
    without gathering a (b, q, r, D) array of them.
    """
    n_functions, dim = c.shape[1], X.shape[1]
    for b in range(ind.shape[0]):
        for q in range(ind.shape[1]):
            u = ind[b, q]
            for r in range(n_functions):
                s = 0.0
                for d in range(dim):
                    s += g[u, r, d] * X[b, d]
                out[b, q, r] = min(max(c[u, r] + s, lo[u, r]), hi[u, r])


@kernel(
    "void(i8[:, ::1], f4[:, ::1], f8[:], f8[:, ::1], f8[:, :, ::1], f8[:, :],"
    " f8[:, ::1], f8[:, ::1], f8, i8, i8, f8[:, ::1])"
)
@numba.njit(cache=True, nogil=True)
def neighbour_means(ind, sq, scale, c, g, X, lo, hi, power, k, nxt, out):  # pragma: no cover - compiled
    """``out[b]``: the weighted mean over the ``k`` nearest neighbours ``ind[b]`` of the
    points ``X`` of their clipped first-order extensions (:func:`ambient_values`), from the
    neighbours' squared distances ``sq`` as an HNSW search returns them, with ``nxt`` a
    next neighbour to fade against. Weight ``q`` is ``taper_q (d_1 / d_q)^power``: with
    ``e_q`` the distances and ``d_q`` those in units of each neighbour's ``scale``,
    ``taper_q = 1 - (e_q / e_{k+1})^2`` clipped to ``[0, 1]`` (plus ``1e-12``, so that ``k``
    neighbours all tied with the next weigh alike), 1 without a next one. The same sums
    as ``NeighborExtension``'s arrays of every row's terms, with no array per block of
    rows: a process that hands freed memory back to the system at once (a Dask worker's
    ``MALLOC_TRIM_THRESHOLD_``) would fault such arrays in again on every block.
    """
    tiny = np.finfo(np.float64).tiny
    n_functions, dim = c.shape[1], X.shape[1]
    acc = np.empty(n_functions)
    e = np.empty(k)  # a row's distances, and in units of each neighbour's scale
    d = np.empty(k)
    for b in range(ind.shape[0]):
        far = max(np.sqrt(max(np.float64(sq[b, ind.shape[1] - 1]), 0.0)), tiny)
        near = np.inf
        widest = -np.inf
        for q in range(k):
            e[q] = np.sqrt(max(np.float64(sq[b, q]), 0.0))
            d[q] = e[q] / max(scale[ind[b, q]], tiny)
            near = min(near, d[q])
            widest = max(widest, d[q])
        guard = 1e-12 * max(widest, tiny)
        near = max(near, guard)
        acc[:] = 0.0
        total = 0.0
        for q in range(k):
            u = ind[b, q]
            taper = 1.0
            if nxt:
                t = e[q] / far
                taper = min(max(1.0 - t * t, 0.0), 1.0) + 1e-12
            w = taper * np.exp(-power * np.log(max(d[q], guard) / near))
            total += w
            for r in range(n_functions):
                s = 0.0
                for a in range(dim):
                    s += g[u, r, a] * X[b, a]
                acc[r] += w * min(max(c[u, r] + s, lo[u, r]), hi[u, r])
        for r in range(n_functions):
            out[b, r] = acc[r] / total


@kernel("void(f8[:, :], f8[:, ::1], f8[:, :, :], i8[:, :], f8[:, :, ::1])")
@numba.njit(cache=True, nogil=True)
def tangent_coordinates(X, points, frames, ind, out):  # pragma: no cover - compiled
    """``out[b, q] = frames[u]^T (X[b] - points[u])`` for ``u = ind[b, q]``: the tangent
    coordinates of the points ``X`` seen from their neighbours ``ind``, without gathering
    a (b, q, D, m) array of the neighbours' frames.
    """
    dim, m = frames.shape[1], frames.shape[2]
    offset = np.empty(dim)
    for b in range(ind.shape[0]):
        for q in range(ind.shape[1]):
            u = ind[b, q]
            for d in range(dim):
                offset[d] = X[b, d] - points[u, d]
            for j in range(m):
                s = 0.0
                for d in range(dim):
                    s += offset[d] * frames[u, d, j]
                out[b, q, j] = s


@kernel("void(f8[:, ::1], f8[:, ::1], f8[:, ::1])")
@numba.njit(cache=True, nogil=True)
def squared_distances(X, landmarks_t, out):  # pragma: no cover - compiled
    """``out[b, l] = |X[b] - landmarks[l]|^2``, from the transposed landmarks
    ``landmarks_t`` (n_features, n_landmarks). Each row is summed in the same order
    whatever rows come with it (predictions made block by block equal those made at
    once, to the bit), and the inner loop runs over the landmarks, which the compiler
    vectorises, into a row of its own that it knows no other array shares.
    """
    dim, m = landmarks_t.shape
    acc = np.empty(m)
    for b in range(X.shape[0]):
        acc[:] = 0.0
        for d in range(dim):
            x = X[b, d]
            row = landmarks_t[d]
            for j in range(m):
                t = x - row[j]
                acc[j] += t * t
        out[b] = acc


@numba.njit(cache=True, nogil=True, inline="always")
def _heap_push(keys, nodes, size, key, node):  # pragma: no cover - compiled
    """Push ``(key, node)`` on the max-heap ``keys[:size]``, ``nodes[:size]``; the new size."""
    t = size
    while t > 0 and keys[(t - 1) // 2] < key:
        keys[t] = keys[(t - 1) // 2]
        nodes[t] = nodes[(t - 1) // 2]
        t = (t - 1) // 2
    keys[t] = key
    nodes[t] = node
    return size + 1


@kernel("void(i8[::1], i8[::1], f8[::1], i8[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def widest_paths(indptr, indices, phi, sources, out):  # pragma: no cover - compiled
    """``out[v]``: the largest, over the paths of the graph (CSR ``indptr``, ``indices``,
    both directions of every edge) from a vertex of ``sources`` to ``v``, of the least
    ``phi`` on the path, both ends included; ``phi[v]`` where no path reaches ``v``.

    A priority flood (Dijkstra's order, the widest path first) from the sources: each
    vertex is settled once, at its final value, with a binary heap of lazy entries.
    """
    n = phi.shape[0]
    best = np.full(n, -np.inf)
    done = np.zeros(n, dtype=np.bool_)
    cap = indices.shape[0] + sources.shape[0] + 1
    keys = np.empty(cap)
    nodes = np.empty(cap, dtype=np.int64)
    size = 0
    for s in sources:
        if phi[s] > best[s]:
            best[s] = phi[s]
            size = _heap_push(keys, nodes, size, phi[s], s)
    while size > 0:
        value = keys[0]
        u = nodes[0]
        # pop the top: the last entry sifts down from the root
        size -= 1
        last_key = keys[size]
        last_node = nodes[size]
        t = 0
        while True:
            c = 2 * t + 1
            if c >= size:
                break
            if c + 1 < size and keys[c + 1] > keys[c]:
                c += 1
            if keys[c] <= last_key:
                break
            keys[t] = keys[c]
            nodes[t] = nodes[c]
            t = c
        keys[t] = last_key
        nodes[t] = last_node
        if done[u]:
            continue
        done[u] = True
        for p in range(indptr[u], indptr[u + 1]):
            w = indices[p]
            if not done[w] and min(value, phi[w]) > best[w]:
                best[w] = min(value, phi[w])
                size = _heap_push(keys, nodes, size, best[w], w)
    for v in range(n):
        out[v] = best[v] if done[v] else phi[v]


@kernel("void(i4[::1], i4[::1], i8[::1], b1[::1])", "void(i8[::1], i8[::1], i8[::1], b1[::1])")
@numba.njit(cache=True, nogil=True)
def _mark_neighbours(indptr, indices, rows, mark):  # pragma: no cover - compiled
    for i in rows:
        for p in range(indptr[i], indptr[i + 1]):
            mark[indices[p]] = True


_WALK_GRAPH = "Tuple((i8[::1], i8[::1], f8[::1]))({i}[::1], {i}[::1], i8[::1], i8[::1], b1[::1], f8[:, ::1])"


@kernel(_WALK_GRAPH.format(i="i4"), _WALK_GRAPH.format(i="i8"))
@numba.njit(cache=True, nogil=True)
def _walk_graph(indptr, indices, nodes, local, inside, centroids):  # pragma: no cover - compiled
    m, dim = centroids.shape
    out_ptr = np.zeros(m + 1, dtype=np.int64)
    for a in range(m):
        i = nodes[a]
        count = 0
        if inside[i]:
            for p in range(indptr[i], indptr[i + 1]):
                if indices[p] != i:
                    count += 1
        out_ptr[a + 1] = out_ptr[a] + count
    cols = np.empty(out_ptr[m], dtype=np.int64)
    lengths = np.empty(out_ptr[m])
    for a in range(m):
        i = nodes[a]
        q = out_ptr[a]
        if not inside[i]:
            continue
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if j != i:
                cols[q] = local[j]
                q += 1
        sort_short(cols, out_ptr[a], q)
        for q in range(out_ptr[a], out_ptr[a + 1]):
            b = cols[q]
            s = 0.0
            for c in range(dim):
                d = centroids[a, c] - centroids[b, c]
                s += d * d
            lengths[q] = np.sqrt(s) + 1e-300  # an explicit zero would drop the edge
    return out_ptr, cols, lengths


def region_walk_graph(adjacency, inside, centroids_of):
    """The graph a region's shortest paths from outside walk on: the region's elements and
    the ring of elements outside next to them, joined along the element adjacency from
    each element inside, weighted by the distance between centroids.

    Parameters
    ----------
    adjacency : scipy.sparse.csr_matrix of shape (n_elements, n_elements)
        The elements' adjacency (a domain's :attr:`~ndboundary.Domain.adjacency`).
    inside : ndarray of bool of shape (n_elements,)
    centroids_of : callable
        ``centroids_of(elements)``: the centroids of those elements, shape
        (len(elements), dim) (:meth:`~ndboundary.Domain.centroids_of`).

    Returns
    -------
    nodes : ndarray of int64
        The graph's elements, increasing.
    graph : scipy.sparse.csr_matrix of shape (n_nodes, n_nodes)
        Row ``a`` holds the edges from ``nodes[a]`` when it is inside (none from the ring),
        columns sorted, each length positive.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary._compiled import region_walk_graph
    >>> grid = kuhn_grid(4, 2)
    >>> inside = grid.element_centroids()[:, 0] < -0.5
    >>> nodes, graph = region_walk_graph(grid.adjacency, inside, grid.centroids_of)
    >>> bool(inside[nodes].sum() == inside.sum()), graph[~inside[nodes]].nnz, bool((graph.data > 0).all())
    (True, 0, True)
    """
    indptr, indices = _index_arrays(adjacency)
    inside = np.ascontiguousarray(inside, dtype=bool)
    mark = inside.copy()
    _mark_neighbours(indptr, indices, np.flatnonzero(inside), mark)
    nodes = np.flatnonzero(mark)
    local = np.full(inside.size, -1, dtype=np.int64)
    local[nodes] = np.arange(nodes.size)
    centroids = np.ascontiguousarray(centroids_of(nodes), dtype=np.float64)
    graph = sp.csr_matrix(_walk_graph(indptr, indices, nodes, local, inside, centroids)[::-1], shape=(nodes.size,) * 2)
    graph.has_sorted_indices = True
    return nodes, graph


_WITHIN_GROUPS = "Tuple(({i}[::1], {i}[::1], f8[::1]))({i}[::1], {i}[::1], f8[::1], i8[::1])"


@kernel(_WITHIN_GROUPS.format(i="i4"), _WITHIN_GROUPS.format(i="i8"))
@numba.njit(cache=True, nogil=True)
def _within_groups(indptr, indices, data, groups):  # pragma: no cover - compiled
    n = indptr.size - 1
    out_ptr = np.zeros(n + 1, dtype=indptr.dtype)
    out_idx = np.empty(indices.size, dtype=indices.dtype)
    out_dat = np.empty(indices.size)
    q = 0
    for i in range(n):
        a = groups[i]
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            b = groups[j]
            if a == b or a < 0 or b < 0:
                out_idx[q] = j
                out_dat[q] = data[p]
                q += 1
        out_ptr[i + 1] = q
    return out_ptr, out_idx[:q].copy(), out_dat[:q].copy()


def within_groups(W, groups):
    """The entries ``(i, j)`` of the CSR matrix ``W`` whose row and column are in one
    group (``groups[i] == groups[j]``), or where either is in none (a negative group); the
    others dropped, not zeroed.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled import within_groups
    >>> W = sp.csr_matrix(np.ones((3, 3)))
    >>> within_groups(W, np.array([0, 1, -1])).toarray().tolist()
    [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]]
    """
    indptr, indices = _index_arrays(W)
    data = np.ascontiguousarray(W.data, dtype=np.float64)
    kept = _within_groups(indptr, indices, data, np.ascontiguousarray(groups, dtype=np.int64))
    out = sp.csr_matrix(kept[::-1], shape=W.shape)
    out.has_sorted_indices = W.has_sorted_indices
    return out
