"""Generic array helpers: linear-time sorts and groupings of integer rows, ragged arrays.

Every domain builds its incidences from these: meshes hold millions of small integer
rows (edges, facets, corners) whose values are bounded by the number of vertices or
elements, so counting sorts (scipy's CSR-to-CSC conversion) group them in linear time
where ``np.unique(axis=0)`` would sort them in ``n log n``.

One tolerance decides degeneracy everywhere (:data:`DEGENERATE_RTOL`) and one rule
gives unused vertices their mass (:func:`fill_unused_mass`).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = [
    "DEGENERATE_RTOL",
    "counting_sort",
    "expand_ranges",
    "fill_unused_mass",
    "first_of_groups",
    "group_rows",
    "held_bytes",
    "index_dtype",
    "kept_then",
    "mixed_facets",
    "pair_groups",
    "ragged_next",
    "ragged_rows",
    "row_groups",
    "shared_facet_adjacency",
    "sort_rows",
    "unique_values",
    "used_vertices",
]

#: An element is degenerate when its measure is below this fraction of the measure of a
#: regular element of its mean squared edge length (simplices, polygons, faces, cells).
DEGENERATE_RTOL = 1e-10
#: Relative mass given to a vertex that no element holds (see :func:`fill_unused_mass`).
UNUSED_MASS = 1e-12


def index_dtype(n):
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
    idx = index_dtype(max(n, n_keys))
    one_per_row = sp.csr_matrix(
        (np.ones(n, dtype=np.int8), np.asarray(keys).astype(idx, copy=False), np.arange(n + 1, dtype=idx)),
        shape=(n, n_keys),
    )
    by_key = one_per_row.tocsc()
    return by_key.indices, by_key.indptr


def pair_groups(first, second, n):
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


def sort_rows(rows):
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
        idx = index_dtype(max(n, span))
        cols = [(rows[:, c] - lo).astype(idx, copy=False) for c in range(width)]
        if width == 2:
            return pair_groups(cols[0], cols[1], span)
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


def row_groups(rows):
    """Equal rows of an integer array: ``(ids, first)``.

    ``ids`` numbers the distinct rows in lexicographic order; ``first`` is the index of
    one row of every group, in that order.
    """
    rows = np.asarray(rows)
    if rows.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    order, new = sort_rows(rows)
    ids = np.empty(rows.shape[0], dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids, order[new]


def group_rows(rows):
    """Label equal rows of an integer array with the same id.

    Returns ``(ids, n_groups)``; ids follow the lexicographic order of the rows.
    """
    ids, first = row_groups(rows)
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
    idx = index_dtype(max(n_elements, 2 * facet_ids.size))
    n_groups = int(facet_ids.max()) + 1
    if np.all(owner[1:] >= owner[:-1]):
        # owners already in order: a stable sort by facet keeps them so within a facet
        order, starts = counting_sort(facet_ids, n_groups)
        same = np.ones(facet_ids.size, dtype=bool)
        same[starts[:-1][starts[:-1] < facet_ids.size]] = False  # the first of each facet
        same = same[1:]
    else:
        order, _ = sort_rows(np.stack([facet_ids, owner], axis=1))
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


def kept_then(a, keep, tail):
    """``concatenate([a[keep], tail])``, copying ``a`` once."""
    n_keep = int(np.count_nonzero(keep))
    out = np.empty((n_keep + tail.shape[0],) + a.shape[1:], dtype=a.dtype)
    np.compress(keep, a, axis=0, out=out[:n_keep])
    out[n_keep:] = tail
    return out


def expand_ranges(starts, lengths):
    """Concatenation of ``arange(s, s + l)`` for every pair ``(s, l)``."""
    lengths = np.asarray(lengths)
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.zeros(lengths.size, dtype=np.int64)
    np.cumsum(lengths[:-1], out=first[1:])
    return np.repeat(starts - first, lengths) + np.arange(total)


def unique_values(a):
    """The distinct values of ``a`` (any shape), increasing: ``np.unique(a)`` by one sort.

    numpy 2.3 and later find the distinct integers of ``np.unique`` through a hash table
    and then sort them; on mostly distinct keys (the edges of a graph, say) that took 16
    to 18 times a sort on this project's machines (0.9 s against 0.05 s for 800 000
    keys).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._arrays import unique_values
    >>> unique_values(np.array([[5, 1], [1, 3]])).tolist()
    [1, 3, 5]
    """
    s = np.sort(np.asarray(a).ravel())
    if s.size == 0:
        return s
    keep = np.empty(s.size, dtype=bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def used_vertices(cells, n_vertices):
    """The vertices that ``cells`` (an index array of any shape) use, increasing, and the
    renumbering of all ``n_vertices`` onto them (-1 for the unused ones).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._arrays import used_vertices
    >>> used, remap = used_vertices(np.array([[4, 1], [1, 2]]), 6)
    >>> used.tolist(), remap.tolist()
    ([1, 2, 4], [-1, 0, 1, -1, 2, -1])
    """
    used = np.zeros(n_vertices, dtype=bool)
    used[np.asarray(cells).ravel()] = True
    vertices = np.flatnonzero(used)
    remap = np.full(n_vertices, -1, dtype=np.int64)
    remap[vertices] = np.arange(vertices.size)
    return vertices, remap


def fill_unused_mass(mass, shares, unused=None):
    """Give the vertices that no element holds a tiny mass, so that ``M`` stays invertible.

    Parameters
    ----------
    mass : ndarray of shape (n_vertices,)
        Lumped masses, modified in place.
    shares : ndarray
        Every element's measure divided by its number of vertices: an unused vertex gets
        :data:`UNUSED_MASS` times their mean.
    unused : ndarray of bool, optional
        The unused vertices; by default those of non-positive mass.

    Returns
    -------
    mass : ndarray
    """
    unused = mass <= 0 if unused is None else unused
    if unused.any():
        mass[unused] = np.mean(shares) * UNUSED_MASS
    return mass


def ragged_next(offsets):
    """For every corner of a ragged array, its row, and the flat index of the next and
    previous corner in that row (cyclic).

    Rows of one size (the quads of a voxel grid's faces) take a shortcut that indexes no
    array by the rows.

    Examples
    --------
    >>> import numpy as np
    >>> [a.tolist() for a in ragged_next(np.array([0, 3, 5]))]  # a triangle, then an edge
    [[0, 0, 0, 1, 1], [1, 2, 0, 4, 3], [2, 0, 1, 4, 3]]
    >>> [a.tolist() for a in ragged_next(np.array([0, 2, 4]))]
    [[0, 0, 1, 1], [1, 0, 3, 2], [1, 0, 3, 2]]
    """
    sizes = np.diff(offsets)
    if sizes.size and sizes.min() == sizes.max():
        m = int(sizes[0])
        nxt = np.arange(1, offsets[-1] + 1).reshape(-1, m)
        nxt[:, -1] -= m
        prv = np.arange(-1, offsets[-1] - 1).reshape(-1, m)
        prv[:, 0] += m
        return np.arange(sizes.size).repeat(m), nxt.ravel(), prv.ravel()
    owner = np.repeat(np.arange(sizes.size), sizes)
    pos = np.arange(offsets[-1]) - offsets[owner]
    nxt = offsets[owner] + (pos + 1) % sizes[owner]
    prv = offsets[owner] + (pos - 1) % sizes[owner]
    return owner, nxt, prv


def ragged_rows(indices, offsets):
    """The rows of a ragged array as a list of arrays."""
    return np.split(indices, offsets[1:-1])


def held_bytes(value, skip):
    """Bytes held by the arrays and sparse matrices in ``value`` (a dict, list or object),
    not counting the objects in ``skip`` (the domain's own operators).
    """
    if value is None or id(value) in skip:
        return 0
    if isinstance(value, np.ndarray):
        return value.nbytes
    if sp.issparse(value):
        return sum(getattr(value, a).nbytes for a in ("data", "indices", "indptr", "offsets") if hasattr(value, a))
    if isinstance(value, (list, tuple)):
        return sum(held_bytes(v, skip) for v in value)
    if isinstance(value, dict):
        return sum(held_bytes(v, skip) for v in value.values())
    if hasattr(value, "__dict__") and not isinstance(value, type):
        skip.add(id(value))  # count every object once
        return held_bytes(vars(value), skip)
    return 0
