"""Shortest distances along the edges of a simplicial complex, walked over its vertex-simplex
incidence, or along a graph (numba): Dijkstra with a binary heap and decrease-key, the
edge lengths of the complex computed as the walk reaches them.

The band search and the fill outside the band need distances along the edges. A graph of
the edges costs a pass over the whole complex and, on a tetrahedral mesh of a million
vertices, a few hundred megabytes written once and read once; the walk needs the
incidence, which the complex holds anyway, and a distance per vertex. A search stopped
at a distance touches the vertices within it only.
"""

from __future__ import annotations

import numba
import numpy as np
import scipy.sparse as sp

from ._kernels import kernel

__all__ = ["graph_distances", "incidence_distances", "kept_edge_graph"]


@numba.njit(cache=True, nogil=True, inline="always")
def _up(keys, items, where, i):  # pragma: no cover - compiled
    """Move the heap's entry ``i`` up to its place."""
    key, item = keys[i], items[i]
    while i > 0:
        parent = (i - 1) >> 1
        if keys[parent] <= key:
            break
        keys[i] = keys[parent]
        items[i] = items[parent]
        where[items[i]] = i
        i = parent
    keys[i] = key
    items[i] = item
    where[item] = i


@numba.njit(cache=True, nogil=True, inline="always")
def _down(keys, items, where, n, i):  # pragma: no cover - compiled
    """Move the heap's entry ``i`` (of ``n``) down to its place."""
    key, item = keys[i], items[i]
    while True:
        child = 2 * i + 1
        if child >= n:
            break
        if child + 1 < n and keys[child + 1] < keys[child]:
            child += 1
        if keys[child] >= key:
            break
        keys[i] = keys[child]
        items[i] = items[child]
        where[items[i]] = i
        i = child
    keys[i] = key
    items[i] = item
    where[item] = i


@numba.njit(cache=True, nogil=True, inline="always")
def _improve(keys, items, where, n, b, key):  # pragma: no cover - compiled
    """Vertex ``b`` enters the heap at ``key``, or moves up to it; the heap's new size."""
    if where[b] < 0:
        keys[n] = key
        items[n] = b
        _up(keys, items, where, n)
        return n + 1
    keys[where[b]] = key
    _up(keys, items, where, where[b])
    return n


@numba.njit(cache=True, nogil=True, inline="always")
def _pop(keys, items, where, n):  # pragma: no cover - compiled
    """The heap's smallest vertex, removed (``n > 0`` entries before)."""
    a = items[0]
    where[a] = -1
    n -= 1
    if n > 0:
        keys[0] = keys[n]
        items[0] = items[n]
        where[items[0]] = 0
        _down(keys, items, where, n, 0)
    return a


@numba.njit(cache=True, nogil=True)
def _seed(sources, offsets, limit, dist):  # pragma: no cover - compiled
    """The heap (``keys``, ``items``, each vertex's place ``where`` or -1) holding the
    sources at their offsets (within ``limit``), and its size. Each vertex is in it at
    most once: an improvement moves it up (Dijkstra with decrease-key).
    """
    V = dist.size
    keys = np.empty(V, dtype=np.float64)
    items = np.empty(V, dtype=np.int64)
    where = np.full(V, -1, dtype=np.int64)
    n = 0
    for i in range(sources.size):
        s, d0 = sources[i], offsets[i]
        if d0 < dist[s] and d0 <= limit:
            dist[s] = d0
            n = _improve(keys, items, where, n, s, d0)
    return keys, items, where, n


@kernel("void(i4[::1], i4[::1], i8[:, ::1], f8[:, ::1], f8, i8[::1], f8[::1], f8, b1[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _walk_simplices(
    indptr, elements, simplices, points, unit, sources, offsets, limit, done, dist
):  # pragma: no cover - compiled
    dim = points.shape[1]
    mark = np.full(dist.size, -1, dtype=np.int64)  # the neighbours of the vertex being settled
    keys, items, where, n = _seed(sources, offsets, limit, dist)
    while n > 0:
        a = _pop(keys, items, where, n)
        n -= 1
        if done[a]:
            continue  # a blocked source: its offset stands, no path leaves it
        done[a] = True
        d = dist[a]
        for q in range(indptr[a], indptr[a + 1]):
            e = elements[q]
            for t in range(simplices.shape[1]):
                b = simplices[e, t]
                if done[b] or mark[b] == a:
                    continue  # a itself, settled, or an edge already seen from a
                mark[b] = a
                sq = 0.0
                for c in range(dim):
                    diff = points[a, c] - points[b, c]
                    sq += diff * diff
                nd = d + np.sqrt(sq) / unit
                if nd < dist[b] and nd <= limit:
                    dist[b] = nd
                    n = _improve(keys, items, where, n, b, nd)


@kernel("void(i4[::1], i4[::1], f8[::1], i8[::1], f8[::1], f8, b1[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _walk_graph(indptr, indices, lengths, sources, offsets, limit, done, dist):  # pragma: no cover - compiled
    keys, items, where, n = _seed(sources, offsets, limit, dist)
    while n > 0:
        a = _pop(keys, items, where, n)
        n -= 1
        if done[a]:
            continue  # a blocked source: its offset stands, no path leaves it
        done[a] = True
        d = dist[a]
        for q in range(indptr[a], indptr[a + 1]):
            b = indices[q]
            if done[b]:
                continue
            nd = d + lengths[q]
            if nd < dist[b] and nd <= limit:
                dist[b] = nd
                n = _improve(keys, items, where, n, b, nd)


@kernel("void(i4[::1], i4[::1], i8[:, ::1], f8[:, ::1], f8, b1[::1], i8[::1], i4[::1], f8[::1])")
@numba.njit(cache=True, nogil=True)
def _kept_edges(indptr, elements, simplices, points, unit, keep, rows, cols, lengths):  # pragma: no cover - compiled
    # with rows[-1] == 0, count each kept vertex's kept neighbours into rows; else write
    # them, and the edges' lengths as the walk computes them, into cols and lengths
    dim = points.shape[1]
    count = rows[-1] == 0
    mark = np.full(keep.size, -1, dtype=np.int64)
    for a in range(keep.size):
        q0 = rows[a]
        n = 0
        if keep[a]:
            for q in range(indptr[a], indptr[a + 1]):
                e = elements[q]
                for t in range(simplices.shape[1]):
                    b = simplices[e, t]
                    if b == a or not keep[b] or mark[b] == a:
                        continue
                    mark[b] = a
                    if not count:
                        sq = 0.0
                        for c in range(dim):
                            diff = points[a, c] - points[b, c]
                            sq += diff * diff
                        cols[q0 + n] = b
                        lengths[q0 + n] = np.sqrt(sq) / unit
                    n += 1
        if count:
            rows[a + 1] = q0 + n


def kept_edge_graph(incidence, simplices, points, keep, *, unit=1.0):
    """The graph of the edges of a complex between the vertices that the boolean mask
    ``keep`` selects, with their lengths in units of ``unit`` (CSR, shape (V, V), both
    ways), read off the vertex-simplex ``incidence`` in two passes.

    Dijkstra along it gives :func:`incidence_distances` with the other vertices
    ``blocked``, bit for bit (each length is computed as that walk computes it), and
    walks it several times faster: each vertex's edges lie side by side.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_walk import kept_edge_graph
    >>> points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> simplices = np.array([[0, 1, 2], [1, 3, 2]])
    >>> inc = sp.csr_matrix((np.ones(6), (simplices.ravel(), [0, 0, 0, 1, 1, 1])), shape=(4, 2))
    >>> g = kept_edge_graph(inc, simplices, points, np.array([True, True, True, False]))
    >>> g.nnz, round(float(g[1, 2]), 6), float(g[1, 3])  # three edges both ways; none to vertex 3
    (6, 1.414214, 0.0)
    """
    inc = incidence.tocsr()
    keep = np.ascontiguousarray(keep, dtype=bool)
    simplices, points = np.ascontiguousarray(simplices), np.ascontiguousarray(points, dtype=np.float64)
    V = keep.size
    rows = np.zeros(V + 1, dtype=np.int64)
    none_i, none_f = np.empty(0, dtype=np.int32), np.empty(0)
    _kept_edges(inc.indptr, inc.indices, simplices, points, float(unit), keep, rows, none_i, none_f)
    idx = np.int32 if max(int(rows[-1]), V) < np.iinfo(np.int32).max else np.int64
    cols, lengths = np.empty(int(rows[-1]), dtype=idx), np.empty(int(rows[-1]))
    if rows[-1]:
        _kept_edges(inc.indptr, inc.indices, simplices, points, float(unit), keep, rows, cols, lengths)
    return sp.csr_matrix((lengths, cols, rows.astype(idx)), shape=(V, V))


def _start(n_vertices, sources, offsets, blocked):
    sources = np.ascontiguousarray(sources, dtype=np.int64).reshape(-1)
    offsets = np.zeros(sources.size) if offsets is None else np.ascontiguousarray(offsets, dtype=np.float64)
    done = np.zeros(n_vertices, dtype=bool) if blocked is None else np.array(blocked, dtype=bool)
    return sources, offsets.reshape(-1), done, np.full(n_vertices, np.inf)


def incidence_distances(incidence, simplices, points, sources, *, unit=1.0, offsets=None, limit=np.inf, blocked=None):
    """Shortest distances along the edges of a complex (in units of ``unit``) from the
    nearest of the ``sources``, each starting at its offset (0 without ``offsets``),
    walking the simplices at each vertex (``incidence``: CSR, one row per vertex).

    The same distances as Dijkstra on the graph of the edges' lengths
    (:func:`graph_distances`): each is a sum of the same lengths, added along the same
    shortest path. Vertices farther than ``limit``, or that no path reaches, get ``inf``;
    the walk stops there, so a search within a distance costs what lies within it. Paths
    do not pass through the vertices selected by the boolean mask ``blocked``, which get
    ``inf`` unless they are sources.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_walk import incidence_distances
    >>> points = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    >>> simplices = np.array([[0, 1, 2], [1, 3, 2], [1, 4, 3]])
    >>> inc = sp.csr_matrix((np.ones(9), (simplices.ravel(), np.repeat([0, 1, 2], 3))), shape=(5, 3))
    >>> incidence_distances(inc, simplices, points, [0]).round(6).tolist()
    [0.0, 1.0, 1.0, 2.0, 2.414214]
    >>> incidence_distances(inc, simplices, points, [0, 4], offsets=[0.0, 0.5], limit=1.6).round(6).tolist()
    [0.0, 1.0, 1.0, 1.5, 0.5]
    >>> incidence_distances(inc, simplices, points, [0], blocked=[False, True, False, False, False]).tolist()
    [0.0, inf, 1.0, 2.0, 3.0]
    """
    inc = incidence.tocsr()
    sources, offsets, done, dist = _start(inc.shape[0], sources, offsets, blocked)
    simplices, points = np.ascontiguousarray(simplices), np.ascontiguousarray(points, dtype=np.float64)
    _walk_simplices(inc.indptr, inc.indices, simplices, points, float(unit), sources, offsets, float(limit), done, dist)
    return dist


def graph_distances(graph, sources, *, offsets=None, limit=np.inf, blocked=None):
    """Shortest distances along the edges of ``graph`` (CSR, lengths, both ways) from the
    nearest of the ``sources``, each starting at its offset: Dijkstra, as
    :func:`incidence_distances` walks it.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary._compiled_walk import graph_distances
    >>> path = sp.diags([np.ones(4), np.ones(4)], [-1, 1]).tocsr()  # 5 vertices, unit edges
    >>> graph_distances(path, [0, 4], offsets=[2.0, 0.0]).tolist()
    [2.0, 3.0, 2.0, 1.0, 0.0]
    """
    graph = graph.tocsr()
    sources, offsets, done, dist = _start(graph.shape[0], sources, offsets, blocked)
    lengths = np.ascontiguousarray(graph.data, dtype=np.float64)
    _walk_graph(graph.indptr, graph.indices, lengths, sources, offsets, float(limit), done, dist)
    return dist
