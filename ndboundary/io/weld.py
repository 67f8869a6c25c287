"""Welding: merging the coincident vertices of triangle soups (STL files, OBJ exports).

Many tools export a surface with every face's own copy of its vertices, so that no two
faces share a vertex and the mesh falls apart into as many components as it has faces.
:func:`weld_blocks` merges the vertices that lie within a tolerance of each other;
:func:`~ndboundary.io.read_mesh` calls it (``weld=``) and reports it in a
:class:`WeldReport`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .._arrays import first_of_groups, group_rows, sort_rows, unique_values
from .._kernels import kernel
from . import common
from .common import flat_rows

__all__ = ["OPEN_EDGE_FRACTION", "WeldReport", "open_edge_fraction", "weld_blocks", "weld_map"]

#: ``weld="auto"`` welds a surface when more than this fraction of its edges bound one face only.
OPEN_EDGE_FRACTION = 0.1


@dataclass(frozen=True)
class WeldReport:
    """What welding did to the vertices of a mesh file (``domain.weld`` after :func:`~ndboundary.io.read_mesh`).

    Attributes
    ----------
    n_vertices_before : int
        The vertices of the file (as its reader gives them: meshio already merges the
        exactly equal corners of STL triangles).
    n_vertices_after : int
        The vertices left once those within ``tolerance`` of each other are one; vertices
        no cell uses are dropped afterwards (``drop_unused``), not counted here.
    n_cells_dropped : int
        The cells that became degenerate (two of their vertices merged) and were dropped.
    tolerance : float
        The distance used: ``weld_tolerance`` times the diagonal of the points' bounding box.

    Examples
    --------
    >>> report = WeldReport(n_vertices_before=6, n_vertices_after=4, n_cells_dropped=0, tolerance=1e-9)
    >>> report.n_merged
    2
    """

    n_vertices_before: int
    n_vertices_after: int
    n_cells_dropped: int
    tolerance: float

    @property
    def n_merged(self) -> int:
        """How many vertices merging removed."""
        return self.n_vertices_before - self.n_vertices_after


def weld_map(points, tolerance):
    """The new index of every point once points within ``tolerance`` of each other are one.

    Exactly equal points are merged by sorting; then the points sharing a cell of a grid
    of spacing ``tolerance / sqrt(d)`` (so within ``tolerance`` of each other); then the
    cells whose first points a k-d tree finds within ``tolerance``. The cost stays
    linear-ish however dense a cluster is. Merging is transitive (a chain of close points
    becomes one vertex). Every merged vertex keeps the position of its first point, and
    the vertices keep the order of their first points.

    Parameters
    ----------
    points : ndarray of shape (n, d)
        Finite coordinates.
    tolerance : float
        An absolute distance (0 merges exactly equal points only).

    Returns
    -------
    new_index : ndarray of int of shape (n,)
    first : ndarray of int of shape (n_after,)
        The point each merged vertex keeps.

    Examples
    --------
    >>> import numpy as np
    >>> new, first = weld_map(np.array([[0.0, 0], [1, 0], [1e-12, 0], [1, 0]]), 1e-9)
    >>> new.tolist(), first.tolist()
    ([0, 1, 0, 1], [0, 1])
    """
    points = np.asarray(points, dtype=np.float64) + 0.0  # -0.0 and 0.0 sort alike
    n = points.shape[0]
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    _, rep, inverse = np.unique(points, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    scale = float(np.max(np.abs(points))) or 1.0  # distances of huge coordinates would overflow
    points, tolerance = points / scale, tolerance / scale
    lo = points.min(axis=0)
    with np.errstate(over="ignore"):
        span = float(np.max(points.max(axis=0) - lo))
    cell = tolerance / np.sqrt(points.shape[1])
    if tolerance > 0 and np.isfinite(span) and span < 2.0**52 * cell:  # cells in the float range
        _, in_cell, cell_of = np.unique(
            np.floor((points[rep] - lo) / cell), axis=0, return_index=True, return_inverse=True
        )
        rep, inverse = rep[in_cell], cell_of.reshape(-1)[inverse]
    m = rep.size
    pairs = np.zeros((0, 2), dtype=np.int64)
    if tolerance > 0 and m > 1:
        pairs = cKDTree(points[rep]).query_pairs(tolerance, output_type="ndarray")
    graph = coo_matrix((np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    n_groups, group = connected_components(graph, directed=False)
    group = group[inverse]
    first = np.full(n_groups, n, dtype=np.int64)
    np.minimum.at(first, group, np.arange(n))
    order = np.argsort(first, kind="stable")
    rank = np.empty(n_groups, dtype=np.int64)
    rank[order] = np.arange(n_groups)
    return rank[group], first[order]


def _n_distinct(flat, sizes):
    """The number of distinct entries of every row of flat rows."""
    owner = np.repeat(np.arange(sizes.size), sizes)
    order = np.lexsort((flat, owner))
    owner, flat = owner[order], flat[order]
    new = np.ones(flat.size, dtype=bool)
    new[1:] = (owner[1:] != owner[:-1]) | (flat[1:] != flat[:-1])
    return np.bincount(owner[new], minlength=sizes.size)


def _kept(new, flat, sizes):
    """Which rows keep all their distinct vertices once renumbered by ``new``."""
    return _n_distinct(new[flat], sizes) == _n_distinct(flat, sizes)


def weld_blocks(points, blocks, tolerance, *, mapping=None):
    """Merge the points of cell blocks within ``tolerance``, dropping the cells that become degenerate.

    Parameters
    ----------
    points : ndarray of shape (n, d)
    blocks : list of (kind, data)
        See :mod:`ndboundary.io.cell_blocks`.
    tolerance : float
        An absolute distance (see :func:`weld_map`).
    mapping : tuple of ndarray, optional
        What ``weld_map(points, tolerance)`` returns, when already computed.

    Returns
    -------
    points : ndarray of shape (n_after, d)
    blocks : list of (kind, data)
        Renumbered; a cell is dropped when it has fewer distinct vertices than before.
    n_dropped : int
        The cells dropped.

    Examples
    --------
    >>> import numpy as np
    >>> soup = np.array([[0.0, 0], [1, 0], [0, 1], [1, 0], [1, 1], [0, 1]])
    >>> points, blocks, dropped = weld_blocks(soup, [("triangle", np.array([[0, 1, 2], [3, 4, 5]]))], 1e-9)
    >>> points.shape, blocks[0][1].tolist(), dropped
    ((4, 2), [[0, 1, 2], [1, 3, 2]], 0)
    """
    new, first = weld_map(points, tolerance) if mapping is None else mapping
    out, dropped = [], 0
    for kind, data in blocks:
        if kind == "hedra":
            out.append((kind, _weld_hedra(new, *data)))
            dropped += len(data[1]) - len(out[-1][1][1])
            continue
        if kind == "polyhedron":
            faces = [f for cell in data for f in cell]
            n_faces = np.fromiter(map(len, data), dtype=np.int64, count=len(data))
            keep = _solids_kept(new, *flat_rows(faces), np.arange(len(faces)), n_faces)
            out.append(
                (kind, [[new[np.asarray(f, dtype=np.int64)] for f in c] for c, k in zip(data, keep, strict=True) if k])
            )
        else:
            flat, sizes = flat_rows(data)
            keep = _kept(new, flat, sizes)
            if isinstance(data, np.ndarray):
                out.append((kind, new[np.asarray(data, dtype=np.int64)][keep]))
            else:
                rows = np.split(new[flat], np.cumsum(sizes)[:-1])
                out.append((kind, [r.tolist() for r, k in zip(rows, keep, strict=True) if k]))
        dropped += int(np.count_nonzero(~keep))
    return np.asarray(points)[first], out, dropped


def _solids_kept(new, f_flat, f_sizes, c_flat, c_sizes):
    """Which polyhedra stay whole once their vertices are renumbered by ``new``.

    A cell is degenerate when one of its faces repeats a vertex, or when it has fewer
    distinct vertices than a closed polyhedron of its faces and edges must have
    (Euler: ``V = 2 + E - F``, ``E`` half the sum of the face sizes): a pinched cell.
    Cells whose faces had their own copies of shared vertices (polyhedron soups) are
    kept, as merging closes them.
    """
    f_start = np.r_[0, np.cumsum(f_sizes)]
    face_ok = _n_distinct(new[f_flat], f_sizes) == f_sizes
    owner_face = np.repeat(np.arange(c_sizes.size), c_sizes)
    lens = f_sizes[c_flat]
    offsets = np.concatenate([[0], np.cumsum(lens)[:-1]]).astype(np.int64)
    pos = np.repeat(f_start[c_flat] - offsets, lens) + np.arange(int(lens.sum()))  # the cells' face vertices
    n_vertices = _n_distinct(new[f_flat[pos]], np.bincount(np.repeat(owner_face, lens), minlength=c_sizes.size))
    euler = 2 + np.bincount(owner_face, weights=lens, minlength=c_sizes.size) / 2 - c_sizes
    whole = np.bincount(owner_face, weights=~face_ok[c_flat], minlength=c_sizes.size) == 0
    return whole & (n_vertices >= euler)


def _weld_hedra(new, faces, cells):
    """HEDRA faces and cells renumbered by ``new``: degenerate cells dropped, faces that became equal merged."""
    f_flat, f_sizes = flat_rows(faces)
    c_flat, c_sizes = flat_rows(cells)
    f_start = np.r_[0, np.cumsum(f_sizes)]
    keep = _solids_kept(new, f_flat, f_sizes, c_flat, c_sizes)
    cells = [c for c, k in zip(cells, keep, strict=True) if k]
    faces = [new[r] for r in np.split(f_flat, f_start[1:-1])]
    used = unique_values(flat_rows(cells)[0])
    faces = [faces[f] for f in used]
    renumber = np.full(len(f_sizes), -1, dtype=np.int64)
    if faces:  # faces that became the same vertex set are one face
        width = max(len(f) for f in faces)
        pad = np.full((len(faces), width), -1, dtype=np.int64)
        for i, f in enumerate(faces):
            pad[i, : len(f)] = np.sort(f)
        ids, n_ids = group_rows(pad)
        firsts = first_of_groups(ids, n_ids)
        order = np.argsort(firsts)  # the merged faces in the order of their first copies
        rank = np.empty(n_ids, dtype=np.int64)
        rank[order] = np.arange(n_ids)
        faces = [faces[i].tolist() for i in firsts[order]]
        renumber[used] = rank[ids]
    return faces, [renumber[np.asarray(c, dtype=np.int64)].tolist() for c in cells]


def open_edge_fraction(blocks):
    """The fraction of the edges of surface blocks that bound one face only (0 for other blocks).

    Parameters
    ----------
    blocks : list of (kind, data)
        ``"triangle"``, ``"quad"`` and ``"polygon"`` blocks count; others are ignored.

    Examples
    --------
    >>> import numpy as np
    >>> open_edge_fraction([("triangle", np.array([[0, 1, 2], [1, 3, 2]]))])  # 4 of 5 edges on the border
    0.8
    """
    flats, sizes = [], []
    for kind, data in blocks:
        if kind in ("triangle", "quad", "polygon"):
            flat, size = flat_rows(data)
            flats.append(flat)
            sizes.append(size)
    if not flats:
        return 0.0
    flat, sizes = (flats[0], sizes[0]) if len(flats) == 1 else (np.concatenate(flats), np.concatenate(sizes))
    sizes = sizes[sizes > 0]
    if flat.size == 0:
        return 0.0
    lowest, highest = int(flat.min()), int(flat.max())
    if flat.size >= common.FAST_MIN_VALUES and lowest >= 0 and highest < 4 * flat.size + 1024:
        distinct, once = _edge_counts(flat, sizes, highest + 1)
        return float(once / distinct)
    nxt = np.arange(flat.size) + 1
    ends = np.cumsum(sizes) - 1
    nxt[ends] = ends - sizes + 1
    edges = np.stack([np.minimum(flat, flat[nxt]), np.maximum(flat, flat[nxt])], axis=1)
    _, new = sort_rows(edges)
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, edges.shape[0]))
    return float(np.count_nonzero(counts == 1) / counts.size)


@kernel("UniTuple(i8, 2)(i8[::1], i8[::1], i8)")
@numba.njit(cache=True, nogil=True)
def _edge_counts(flat, sizes, n):  # pragma: no cover - compiled
    """The number of distinct edges of polygons (flat rows of indices in ``0..n - 1``) and of those met once.

    The edges are bucketed by their lower vertex (a counting sort); the few upper
    vertices of every bucket are then sorted and their runs counted.
    """
    start = np.zeros(n + 1, dtype=np.int64)
    k = 0
    for r in range(sizes.size):
        for j in range(sizes[r]):
            b = k + j + 1 if j + 1 < sizes[r] else k  # the next corner, cyclically
            start[min(flat[k + j], flat[b]) + 1] += 1
        k += sizes[r]
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    upper = np.empty(flat.size, dtype=np.int64)
    k = 0
    for r in range(sizes.size):
        for j in range(sizes[r]):
            a, b = flat[k + j], flat[k + j + 1 if j + 1 < sizes[r] else k]
            upper[fill[min(a, b)]] = max(a, b)
            fill[min(a, b)] += 1
        k += sizes[r]
    distinct, once = 0, 0
    for v in range(n):
        lo, hi = start[v], start[v + 1]
        if hi - lo > 32:
            upper[lo:hi] = np.sort(upper[lo:hi])
        else:  # insertion sort: buckets hold a vertex's few neighbours
            for i in range(lo + 1, hi):
                x, j = upper[i], i - 1
                while j >= lo and upper[j] > x:
                    upper[j + 1] = upper[j]
                    j -= 1
                upper[j + 1] = x
        i = lo
        while i < hi:
            j = i + 1
            while j < hi and upper[j] == upper[i]:
                j += 1
            distinct += 1
            once += j - i == 1
            i = j
    return distinct, once
