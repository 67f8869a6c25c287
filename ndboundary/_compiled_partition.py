"""Compiled passes of the partition by the largest region function: the sparse sweep of
:func:`ndboundary.partition_clip.sweep_sparse`, and the facets between its regions.

The sweep resolves the regions one at a time against the envelope of those before them,
on the cells that descend from the input simplices where each region is stored. A
vectorised sweep sorts and concatenates tables of every cell a region touches, several
times per region, and copies the growing complex at every step; here each region is one
pass over its cells with a few scalars of state per cell: the cells of an input simplex
are a chain, a cut cell's first piece takes its slot, crossings are found again through a
table keyed by their edge, and the arrays grow by doubling.

The facets between regions are matched within groups by their lowest vertex, where a sort
of every facet's vertices would read the cells many times.
"""

from __future__ import annotations

import numba
import numpy as np

from ._kernels import kernel

__all__ = ["beaten_simplices", "oriented_region_facets", "point_simplices", "sweep_sparse_compiled"]


@numba.njit(cache=True, nogil=True)
def _grown(a, n):  # pragma: no cover - compiled
    """``a`` with room for at least ``n`` rows (twice as many rows when it must grow)."""
    if a.shape[0] >= n:
        return a
    out = np.empty((max(n, 2 * a.shape[0]),) + a.shape[1:], dtype=a.dtype)
    out[: a.shape[0]] = a
    return out


@numba.njit(cache=True, nogil=True)
def _permute(a, p0, order):  # pragma: no cover - compiled
    """Rows ``p0 + order`` of ``a`` moved to ``p0, p0 + 1, ...``."""
    b = a[p0 : p0 + order.size].copy()
    for i in range(order.size):
        a[p0 + i] = b[order[i]]


@numba.njit(cache=True, nogil=True)
def _renumber(X, M, value, parents, t, S, p0, p1, c0, c1, cut, n_cut):  # pragma: no cover - compiled
    """Number the points ``p0:p1`` a pass made in the order of their edges' ids, as every
    sweep does (the staircase rule of later cuts reads it), in the cells ``c0:c1`` and
    the cells ``cut`` (whose slots hold a piece each).
    """
    m = p1 - p0
    keys = np.empty(m, dtype=np.int64)
    for i in range(m):
        keys[i] = np.int64(parents[p0 + i, 0]) * 2147483648 + parents[p0 + i, 1]
    order = np.argsort(keys)
    rank = np.empty(m, dtype=np.int64)
    for i in range(m):
        rank[order[i]] = i
    _permute(X, p0, order)
    _permute(parents, p0, order)
    _permute(M, p0, order)
    _permute(value, p0, order)
    _permute(t, p0, order)
    for s in range(n_cut):
        _renumber_cell(S, cut[s], p0, rank)
    for c in range(c0, c1):
        _renumber_cell(S, c, p0, rank)


@numba.njit(cache=True, nogil=True, inline="always")
def _renumber_cell(S, c, p0, rank):  # pragma: no cover - compiled
    for i in range(S.shape[1]):
        if S[c, i] >= p0:
            S[c, i] = p0 + rank[S[c, i] - p0]


@numba.njit(cache=True, nogil=True, inline="always")
def _sign(x):  # pragma: no cover - compiled
    return 1 if x > 0 else (-1 if x < 0 else 0)


@numba.njit(cache=True, nogil=True)
def _incidence(simplices, V):  # pragma: no cover - compiled
    """The input simplices at every point, as CSR ``(indptr, simplex ids)``."""
    N, k1 = simplices.shape
    indptr = np.zeros(V + 1, dtype=np.int64)
    for f in range(N):
        for i in range(k1):
            indptr[simplices[f, i] + 1] += 1
    for p in range(V):
        indptr[p + 1] += indptr[p]
    fill = indptr[:-1].copy()
    ids = np.empty(N * k1, dtype=np.int32)
    for f in range(N):
        for i in range(k1):
            p = simplices[f, i]
            ids[fill[p]] = f
            fill[p] += 1
    return indptr, ids


@kernel("Tuple((i8[::1], i4[::1]))(i8[:, ::1], i8)")
@numba.njit(cache=True, nogil=True)
def _point_simplices(simplices, V):  # pragma: no cover - compiled
    return _incidence(simplices, V)


def point_simplices(simplices, n_points):
    """The simplices at every point, as CSR ``(indptr, simplex ids)`` (int64, int32), built
    by counting, without the tables of every (point, simplex) pair a sparse matrix's
    construction sorts.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_partition import point_simplices
    >>> indptr, ids = point_simplices(np.array([[0, 1, 2], [1, 3, 2]]), 4)
    >>> indptr.tolist(), ids.tolist()
    ([0, 1, 3, 5, 6], [0, 0, 1, 0, 1, 1])
    """
    if simplices.shape[0] >= 1 << 31:
        raise ValueError(f"{simplices.shape[0]} simplices are too many to index with 32-bit ids")
    return _point_simplices(np.ascontiguousarray(simplices, dtype=np.int64), int(n_points))


@numba.njit(cache=True, nogil=True)
def _region_cells(r, stored, inc_ptr, inc, visited, head, chain, cells):  # pragma: no cover - compiled
    """The cells of the input simplices with a point in ``stored`` (each input simplex's
    cells are a chain) into ``cells``, grown as needed: ``(cells, count)``.
    """
    n = 0
    for p in stored:
        for e in range(inc_ptr[p], inc_ptr[p + 1]):
            f = inc[e]
            if visited[f] == r:
                continue
            visited[f] = r
            c = head[f]
            while c >= 0:
                if n == cells.size:
                    cells = _grown(cells, n + 1)
                cells[n] = c
                n += 1
                c = chain[c]
    return cells, n


@numba.njit(cache=True, nogil=True)
def _evaluate(r, cells, n_sel, S, V, parents, t, value, M, stamp, d, stack):  # pragma: no cover - compiled
    """Region ``r``'s value at the points of the cells, and ``d``, its excess over the
    envelope: 0 at an input point that does not store it, and interpolated along the
    parent edge at a point a cut made, its parents first. Returns the scratch ``stack``
    (grown as needed).
    """
    for s in range(n_sel):
        for i in range(S.shape[1]):
            p = S[cells[s], i]
            if stamp[p] == r:
                continue
            if p < V:
                value[p] = 0.0
                stamp[p] = r
                d[p] = -M[p]
                continue
            stack[0] = p
            top = 1
            while top > 0:
                x = stack[top - 1]
                if stamp[x] == r:  # reached through another child first
                    top -= 1
                    continue
                a, b = parents[x, 0], parents[x, 1]
                ready = True
                for y in (a, b):
                    if stamp[y] == r:
                        continue
                    if y < V:
                        value[y] = 0.0
                        stamp[y] = r
                        d[y] = -M[y]
                    else:
                        if top == stack.size:
                            stack = _grown(stack, top + 1)
                        stack[top] = y
                        top += 1
                        ready = False
                if ready:
                    value[x] = value[a] + t[x] * (value[b] - value[a])
                    stamp[x] = r
                    d[x] = value[x] - M[x]
                    top -= 1
    return stack


@numba.njit(cache=True, nogil=True)
def _classify(r, cells, n_sel, S, d, value, M, region, cut):  # pragma: no cover - compiled
    """Cells wholly above the envelope (somewhere strictly) go to ``r``; those ``r``
    crosses are listed in ``cut`` (grown as needed): ``(cut, count)``. A cell where ``r``
    ties the envelope throughout keeps its earlier region. The envelope takes ``r``'s
    value where it is above (``d``, read by the cuts, keeps the excess over the old one).
    """
    n_cut = 0
    for s in range(n_sel):
        c = cells[s]
        pos = False
        neg = False
        for i in range(S.shape[1]):
            p = S[c, i]
            pos = pos or d[p] > 0
            neg = neg or d[p] < 0
            if value[p] > M[p]:
                M[p] = value[p]
        if pos and neg:
            if n_cut == cut.size:
                cut = _grown(cut, n_cut + 1)
            cut[n_cut] = c
            n_cut += 1
        elif pos:
            region[c] = r
    return cut, n_cut


@numba.njit(cache=True, nogil=True)
def _cut(r, cut, n_cut, tpl_ptr, tpl_slots, tpl_side, pts, cells, n_pts, n_cells):  # pragma: no cover - compiled
    """Split the cells ``cut`` into the pieces of their sign patterns' templates: the
    pieces, oriented as their parents, take the cut cell's slot and new ones; their
    crossings are new points, one per edge. Returns the numbers of points and cells.
    """
    X, M, value, stamp, d, parents, t = pts
    S, region, origin, chain, head = cells
    k1, D = S.shape[1], X.shape[1]
    max_edges = (k1 // 2) * ((k1 + 1) // 2)
    size = 1
    while size < 2 * n_cut * max_edges:
        size *= 2
    keys = np.full(size, -1, dtype=np.int64)  # a table of the crossings by their edge
    ids = np.empty(size, dtype=np.int64)
    srt = np.empty(k1, dtype=np.int64)
    for s in range(n_cut):
        c = cut[s]
        for i in range(k1):
            srt[i] = S[c, i]
        odd = False  # insertion sort, counting the swaps' parity
        for i in range(1, k1):
            j = i
            while j > 0 and srt[j - 1] > srt[j]:
                srt[j - 1], srt[j] = srt[j], srt[j - 1]
                odd = not odd
                j -= 1
        code = 0
        base = 1
        for i in range(k1):
            code += (_sign(d[srt[i]]) + 1) * base
            base *= 3
        old, f = region[c], origin[c]
        for piece in range(tpl_ptr[code], tpl_ptr[code + 1]):
            if piece == tpl_ptr[code]:
                n = c
            else:
                n = n_cells
                n_cells += 1
                origin[n] = f
                chain[n] = head[f]
                head[f] = n
            for i in range(k1):
                u, v = tpl_slots[piece, i, 0], tpl_slots[piece, i, 1]
                a = srt[u]
                if u == v:
                    S[n, i] = a
                    continue
                b = srt[v]  # the crossing on the edge from negative a to positive b
                key = a * 2147483648 + b
                h = ((key * 6364136223846793005) >> 32) & (size - 1)
                while keys[h] != -1 and keys[h] != key:
                    h = (h + 1) & (size - 1)
                if keys[h] == -1:
                    keys[h] = key
                    ids[h] = n_pts
                    w = d[a] / (d[a] - d[b])
                    for j in range(D):
                        X[n_pts, j] = X[a, j] + w * (X[b, j] - X[a, j])
                    fa = value[a] + w * (value[b] - value[a])
                    value[n_pts] = fa
                    M[n_pts] = fa  # the crossing is on the cut: d == 0 there
                    d[n_pts] = 0.0
                    stamp[n_pts] = r
                    parents[n_pts, 0] = a
                    parents[n_pts, 1] = b
                    t[n_pts] = w
                    n_pts += 1
                S[n, i] = ids[h]
            if odd:
                S[n, 0], S[n, 1] = S[n, 1], S[n, 0]
            region[n] = old if tpl_side[piece] == 0 else r
    return n_pts, n_cells


@kernel(
    "Tuple((f8[:, ::1], i8[:, ::1], i8[::1], i8[:, ::1]))"
    "(f8[:, ::1], i8[:, ::1], i8[::1], i8[::1], f8[::1], i8[::1], i8[:, :, ::1], i8[::1])"
)
@numba.njit(cache=True, nogil=True)
def _sweep(points, simplices, col_ptr, col_idx, col_val, tpl_ptr, tpl_slots, tpl_side):  # pragma: no cover - compiled
    V, D = points.shape
    N, k1 = simplices.shape
    inc_ptr, inc = _incidence(simplices, V)
    # points: coordinates, envelope, the value of the region being resolved and its
    # excess over the envelope (valid where stamped with it), parent edge and crossing
    # parameter
    X = np.empty((2 * V + 16, D))
    X[:V] = points
    M = np.zeros(X.shape[0])
    value = np.zeros(X.shape[0])
    d = np.zeros(X.shape[0])
    stamp = np.full(X.shape[0], -1, dtype=np.int32)
    parents = np.empty((X.shape[0], 2), dtype=np.int32)
    for p in range(V):
        parents[p, 0] = p
        parents[p, 1] = p
    t = np.zeros(X.shape[0])
    n_pts = V
    # cells: vertices, region, input simplex, the next cell of its chain; and the first
    # cell of every input simplex's chain
    S = np.empty((2 * N + 16, k1), dtype=np.int32)
    S[:N] = simplices
    region = np.full(S.shape[0], -1, dtype=np.int32)
    origin = np.empty(S.shape[0], dtype=np.int32)
    origin[:N] = np.arange(N)
    chain = np.full(S.shape[0], -1, dtype=np.int32)
    head = np.arange(N).astype(np.int32)
    n_cells = N
    visited = np.full(N, -1, dtype=np.int32)
    cells = np.empty(16, dtype=np.int32)
    cut = np.empty(16, dtype=np.int32)
    stack = np.empty(16, dtype=np.int64)
    max_edges = (k1 // 2) * ((k1 + 1) // 2)
    max_pieces = 1
    for c in range(tpl_ptr.size - 1):
        max_pieces = max(max_pieces, tpl_ptr[c + 1] - tpl_ptr[c])
    for r in range(col_ptr.size - 1):
        stored = col_idx[col_ptr[r] : col_ptr[r + 1]]
        if stored.size == 0:
            continue
        for q in range(col_ptr[r], col_ptr[r + 1]):
            p = col_idx[q]
            value[p] = col_val[q]
            stamp[p] = r
            d[p] = value[p] - M[p]
        cells, n_sel = _region_cells(r, stored, inc_ptr, inc, visited, head, chain, cells)
        stack = _evaluate(r, cells, n_sel, S, V, parents, t, value, M, stamp, d, stack)
        cut, n_cut = _classify(r, cells, n_sel, S, d, value, M, region, cut)
        if n_cut == 0:
            continue
        need = n_pts + n_cut * max_edges
        if need > X.shape[0]:
            X, M, value, d = _grown(X, need), _grown(M, need), _grown(value, need), _grown(d, need)
            stamp, parents, t = _grown(stamp, need), _grown(parents, need), _grown(t, need)
        need = n_cells + n_cut * (max_pieces - 1)
        if need > S.shape[0]:
            S, region, origin, chain = _grown(S, need), _grown(region, need), _grown(origin, need), _grown(chain, need)
        n_pts0, n_cells0 = n_pts, n_cells
        n_pts, n_cells = _cut(
            r, cut, n_cut, tpl_ptr, tpl_slots, tpl_side,
            (X, M, value, stamp, d, parents, t), (S, region, origin, chain, head), n_pts, n_cells,
        )  # fmt: skip
        _renumber(X, M, value, parents, t, S, n_pts0, n_pts, n_cells0, n_cells, cut, n_cut)
    regions = region[:n_cells].astype(np.int64)
    return X[:n_pts].copy(), S[:n_cells].astype(np.int64), regions, parents[:n_pts].astype(np.int64)


@numba.njit(cache=True, nogil=True)
def _sorted_facet(simplices, c, o, out):  # pragma: no cover - compiled
    """The vertices of cell ``c`` but its ``o``-th, sorted, into ``out``."""
    q = 0
    for j in range(simplices.shape[1]):
        if j == o:
            continue
        v = simplices[c, j]
        i = q
        while i > 0 and out[i - 1] > v:
            out[i] = out[i - 1]
            i -= 1
        out[i] = v
        q += 1


@numba.njit(cache=True, nogil=True, inline="always")
def _candidate(lo, hi, simplices, c, o, count):  # pragma: no cover - compiled
    """Whether facet ``o`` of cell ``c`` (``count`` of whose vertices lie on cells of two
    regions or more) has all its vertices there: only then can it lie between regions.
    """
    p = simplices[c, o]
    return count == simplices.shape[1] or (count == simplices.shape[1] - 1 and lo[p] == hi[p])


@kernel("i8[:, ::1](i8[:, ::1], i8[::1], i8)")
@numba.njit(cache=True, nogil=True)
def _region_facets(simplices, regions, n_points):  # pragma: no cover - compiled
    """The facets between cells of different regions, as rows ``(cell, its left-out
    column, other cell, its left-out column)``, the first cell the lower.

    A facet between regions has all its vertices on cells of two regions or more: only
    those facets are sought. They are grouped by their lowest vertex (a counting sort)
    and matched within each group, where a sort of every facet would read them all many
    times.
    """
    n_cells, k1 = simplices.shape
    lo = np.full(n_points, n_cells, dtype=np.int64)  # the lowest and highest region at every point
    hi = np.full(n_points, -1, dtype=np.int64)
    for c in range(n_cells):
        for j in range(k1):
            p = simplices[c, j]
            lo[p] = min(lo[p], regions[c])
            hi[p] = max(hi[p], regions[c])
    mixed = np.zeros(n_cells, dtype=np.int8)  # vertices on cells of two regions or more
    start = np.zeros(n_points + 1, dtype=np.int64)
    facet = np.empty(k1 - 1, dtype=np.int64)
    for c in range(n_cells):
        count = 0
        for j in range(k1):
            count += lo[simplices[c, j]] != hi[simplices[c, j]]
        mixed[c] = count
        for o in range(k1):
            if _candidate(lo, hi, simplices, c, o, count):
                _sorted_facet(simplices, c, o, facet)
                start[facet[0] + 1] += 1
    for p in range(n_points):
        start[p + 1] += start[p]
    fill = start[:-1].copy()
    rows = np.empty((start[-1], k1 + 1), dtype=np.int64)  # (cell, column, sorted vertices)
    for c in range(n_cells):
        for o in range(k1):
            if _candidate(lo, hi, simplices, c, o, mixed[c]):
                _sorted_facet(simplices, c, o, facet)
                q = fill[facet[0]]
                fill[facet[0]] += 1
                rows[q, 0] = c
                rows[q, 1] = o
                rows[q, 2:] = facet
    out = np.empty((16, 4), dtype=np.int64)
    n = 0
    done = np.zeros(rows.shape[0], dtype=np.bool_)  # paired with the cell before it already
    for p in range(n_points):
        # each facet is paired with the next cell that holds it, that one with the next (a
        # facet of three cells or more, in a complex that is not a manifold, pairs them in
        # turn); a cell paired already starts no search of its own
        for i in range(start[p], start[p + 1]):
            if done[i]:
                continue
            current = i
            for j in range(i + 1, start[p + 1]):
                same = not done[j]
                for q in range(3, k1 + 1):
                    same = same and rows[current, q] == rows[j, q]
                if not same:
                    continue
                if regions[rows[current, 0]] != regions[rows[j, 0]]:
                    if n == out.shape[0]:
                        out = _grown(out, n + 1)
                    out[n, 0], out[n, 1] = rows[current, 0], rows[current, 1]
                    out[n, 2], out[n, 3] = rows[j, 0], rows[j, 1]
                    n += 1
                done[j] = True
                current = j
    return out[:n].copy()


@numba.njit(cache=True, nogil=True)
def _orientation(points, simplices, c, E):  # pragma: no cover - compiled
    """The sign of the determinant of cell ``c``'s edge vectors (a full-dimensional
    simplex), by elimination with partial pivoting; 0 for a singular one.
    """
    k = E.shape[0]
    for i in range(k):
        for j in range(k):
            E[i, j] = points[simplices[c, i + 1], j] - points[simplices[c, 0], j]
    sign = 1.0
    for col in range(k):
        pivot = col
        for i in range(col + 1, k):
            if abs(E[i, col]) > abs(E[pivot, col]):
                pivot = i
        if E[pivot, col] == 0.0:
            return 0.0
        if pivot != col:
            sign = -sign
            for j in range(k):
                E[col, j], E[pivot, j] = E[pivot, j], E[col, j]
        if E[col, col] < 0:
            sign = -sign
        for i in range(col + 1, k):
            f = E[i, col] / E[col, col]
            for j in range(col, k):
                E[i, j] -= f * E[col, j]
    return sign


@kernel("Tuple((i8[:, ::1], i8[:, ::1], i8[:, ::1]))(f8[:, ::1], i8[:, ::1], i8[::1], i8[:, ::1])")
@numba.njit(cache=True, nogil=True)
def _oriented_facets(points, simplices, regions, rows):  # pragma: no cover - compiled
    """The facets of :func:`_region_facets`'s ``rows``, taken from the cell of the lower
    region and oriented away from it: ``(facets, region pairs, cells)``.
    """
    n, k1 = rows.shape[0], simplices.shape[1]
    k = k1 - 1
    full = k == points.shape[1]
    E = np.empty((k, k))
    facets = np.empty((n, k), dtype=np.int64)
    pairs = np.empty((n, 2), dtype=np.int64)
    cells = np.empty((n, 2), dtype=np.int64)
    for i in range(n):
        first = regions[rows[i, 0]] < regions[rows[i, 2]]
        c, o = (rows[i, 0], rows[i, 1]) if first else (rows[i, 2], rows[i, 3])
        cells[i, 0], cells[i, 1] = (rows[i, 0], rows[i, 2]) if first else (rows[i, 2], rows[i, 0])
        pairs[i, 0], pairs[i, 1] = regions[cells[i, 0]], regions[cells[i, 1]]
        q = 0
        for j in range(k1):
            if j != o:
                facets[i, q] = simplices[c, j]
                q += 1
        # the normal points out of the cell: (-1)^(k-1) (-1)^o times the cell's orientation
        sign = -1.0 if (k - 1 + o) % 2 else 1.0
        if full:
            sign *= _orientation(points, simplices, c, E)
        if k >= 2 and sign < 0:
            facets[i, 0], facets[i, 1] = facets[i, 1], facets[i, 0]
    return facets, pairs, cells


def oriented_region_facets(points, simplices, regions):
    """The facets between cells of different regions, each taken from the cell of the
    lower region and oriented away from it: ``(facets, region pairs, cells)``, the pairs
    and cells lower region first (see :func:`ndboundary.partition_clip.interface_facets`).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._compiled_partition import oriented_region_facets
    >>> points = np.array([[0.0, 0], [1, 0], [1, 1], [0, 1], [2, 1]])
    >>> simplices = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    >>> facets, pairs, cells = oriented_region_facets(points, simplices, np.array([1, 0, 0]))
    >>> facets.tolist(), pairs.tolist(), cells.tolist()
    ([[2, 0], [1, 2]], [[0, 1], [0, 1]], [[1, 0], [2, 0]])
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    simplices = np.ascontiguousarray(simplices, dtype=np.int64)
    regions = np.ascontiguousarray(regions, dtype=np.int64)
    rows = _region_facets(simplices, regions, points.shape[0])
    return _oriented_facets(points, simplices, regions, rows)


def sweep_sparse_compiled(points, simplices, values, tables):
    """:func:`ndboundary.partition_clip.sweep_sparse`, compiled: points, simplices,
    regions and parents, from the CSR ``values`` (points x regions, every value at least 1)
    and the cut templates ``tables`` (:func:`ndboundary.partition_clip.template_tables`).
    """
    if max(points.shape[0], simplices.shape[0]) >= 1 << 29:
        raise ValueError(
            f"a partition of {simplices.shape[0]} simplices on {points.shape[0]} points is too large to cut "
            f"(at most {(1 << 29) - 1} of each)"
        )
    columns = values.tocsc()
    columns.sort_indices()
    ptr, slots, side = tables
    return _sweep(
        np.ascontiguousarray(points, dtype=np.float64),
        np.ascontiguousarray(simplices, dtype=np.int64),
        columns.indptr.astype(np.int64),
        columns.indices.astype(np.int64),
        np.ascontiguousarray(columns.data, dtype=np.float64),
        ptr,
        slots,
        side,
    )


@numba.njit(cache=True, nogil=True)
def _stored(indptr, indices, data, p, c):  # pragma: no cover - compiled
    """Region ``c``'s value at point ``p`` of the CSR (sorted indices), 0 where not stored."""
    lo, hi = indptr[p], indptr[p + 1]
    while lo < hi:
        mid = (lo + hi) // 2
        if indices[mid] < c:
            lo = mid + 1
        else:
            hi = mid
    return data[lo] if lo < indptr[p + 1] and indices[lo] == c else 0.0


@kernel(
    "b1[::1](i8[:, ::1], f8[::1], i4[::1], i4[::1], f8[::1], i8)",
    "b1[::1](i8[:, ::1], f8[::1], i8[::1], i4[::1], f8[::1], i8)",
    "b1[::1](i8[:, ::1], f8[::1], i8[::1], i8[::1], f8[::1], i8)",
)
@numba.njit(cache=True, nogil=True)
def _beaten(simplices, own, indptr, indices, data, r):  # pragma: no cover - compiled
    n, k = simplices.shape
    out = np.zeros(n, dtype=np.bool_)
    for s in range(n):
        top = 0.0  # region r's largest value at the simplex's points (``own``: r's values)
        for a in range(k):
            top = max(top, own[simplices[s, a]])
        bound = top + 1e-9 * (1.0 + top)  # beaten by a margin no rounding of a cut reaches
        # the region leading at the first point, unless r: the one likeliest to beat r throughout
        p = simplices[s, 0]
        c, low = -1, 0.0
        for e in range(indptr[p], indptr[p + 1]):
            if data[e] > low:
                c, low = indices[e], data[e]
        a = 1
        while c != r and low > bound and a < k:
            low = min(low, _stored(indptr, indices, data, simplices[s, a], c))
            a += 1
        out[s] = c != r and low > bound
    return out


def beaten_simplices(simplices, values, r, own=None):
    """Whether region ``r`` loses at every point of each simplex, by a test that needs no
    cut: the region leading at its first point has, at every one of its points, a value
    above r's largest there (``values`` CSR, points x regions, sorted indices, a region
    not stored at a point being 0 there). ``own``: region r's value at every point (0
    where not stored), read from ``values`` when not given.

    Each region's function is linear on a simplex, so that region beats r everywhere in
    it, on its faces too: none of r's cells, nor a face they share with a cell of a
    simplex beside them, lies in a simplex flagged. The test is conservative (r may lose
    everywhere to several regions in turn, and is then not flagged), by a margin far
    beyond a cut's rounding.

    Examples
    --------
    >>> import numpy as np, scipy.sparse as sp
    >>> from ndboundary._compiled_partition import beaten_simplices
    >>> values = sp.csr_matrix(np.array([[3.0, 1.0], [3.0, 2.0], [1.0, 3.0]]))
    >>> beaten_simplices(np.array([[0, 1], [1, 2]]), values, 1).tolist()
    [True, False]
    """
    own = np.asarray(values[:, r].toarray(), dtype=np.float64).ravel() if own is None else own
    return _beaten(np.ascontiguousarray(simplices, dtype=np.int64), own, values.indptr, values.indices,
                   np.ascontiguousarray(values.data, dtype=np.float64), int(r))  # fmt: skip
