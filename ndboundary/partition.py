"""The exact partition of a simplicial complex by the largest of L piecewise-linear functions.

The region of a point is the index of the largest of ``values[:, 0], ..., values[:, L-1]``
interpolated there (linearly on every simplex); equal values go to the smaller region
index. The complex is refined, one function at a time, by the hyperplanes
``f_r = f_s`` of the pairs that meet on it (see :mod:`ndboundary.partition_clip`), into
a conforming complex on which the region is constant per simplex; the interfaces are
the facets between cells of different regions, the junctions the faces of the
interfaces where three or more regions meet. Any dimension, any k <= dim.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ._arrays import unique_values, used_vertices
from .levelset import LevelSet, row_codes, simplex_measures
from .partition_clip import interface_facets, sweep, sweep_sparse

__all__ = ["Cells", "Interfaces", "Junctions", "Partition", "partition"]


def _y_example():
    d = np.array([[1.0, 0.0], [-0.5, 0.75**0.5], [-0.5, -(0.75**0.5)]])
    pts = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [0.1, 0.05]])
    tri = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    return pts, tri, pts @ d.T


class Cells:
    """A conforming complex of k-simplices, each wholly inside one region.

    Attributes
    ----------
    points : ndarray of shape (n_points, dim)
        The input vertices first, in their order, then the new points.
    simplices : ndarray of int of shape (n_cells, k + 1)
        Oriented like the input simplex each cell lies in.
    regions : ndarray of int of shape (n_cells,)
    values : ndarray of shape (n_points, L) or None
        The functions interpolated at the points (None for a partition of sparse values).
    parents : ndarray of int of shape (n_points, 2)
        The two points (earlier ids) each point was created between; an input vertex
        has its own id twice. This pair is the point's global key.

    Examples
    --------
    >>> from ndboundary.partition import partition
    >>> cells = partition([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [[1, 0], [0, 1], [0, 1]]).cells
    >>> cells
    Cells(n_points=5, n_cells=3)
    >>> cells.regions.tolist(), cells.measures().round(4).tolist()
    ([0, 1, 1], [0.125, 0.25, 0.125])
    """

    def __init__(self, points, simplices, regions, values, parents):
        self.points = points
        self.simplices = simplices
        self.regions = regions
        self.values = values
        self.parents = parents

    def measures(self) -> np.ndarray:
        """Length / area / volume of each cell."""
        return simplex_measures(self.points, self.simplices)

    def __len__(self):
        return int(self.simplices.shape[0])

    def __repr__(self):
        return f"Cells(n_points={self.points.shape[0]}, n_cells={len(self)})"


class Junctions:
    """The (k-2)-faces of the interfaces where three or more regions meet.

    Attributes
    ----------
    points : ndarray of shape (n_points, dim)
    simplices : ndarray of int of shape (n, k - 1)
        Points (shape (n, 1)) for k = 2, segments for k = 3, triangles for k = 4.
    regions : ndarray of int of shape (n, max_regions)
        The regions meeting at each junction simplex, ascending, padded with -1.
    point_ids : ndarray of int of shape (n_points,)
        Index of each point in the interfaces' point array.

    Examples
    --------
    >>> from ndboundary.partition import partition, _y_example
    >>> j = partition(*_y_example()).interfaces().junctions()
    >>> j
    Junctions(n_points=1, n_simplices=1)
    >>> abs(j.points).round(12).tolist(), j.regions.tolist()
    ([[0.0, 0.0]], [[0, 1, 2]])
    """

    def __init__(self, points, simplices, regions, point_ids):
        self.points = points
        self.simplices = simplices
        self.regions = regions
        self.point_ids = point_ids

    def __len__(self):
        return int(self.simplices.shape[0])

    def __repr__(self):
        return f"Junctions(n_points={self.points.shape[0]}, n_simplices={len(self)})"


#: :meth:`Interfaces.junctions` sorts the keys of at most about this many faces of the
#: interface simplices at once (each face keyed twice, once per region of its piece):
#: the 107 M faces of an atlas's 35.6 M interface triangles, sorted at once, held some
#: 9 GB of keys and their copies.
JUNCTION_KEYS_AT_ONCE = 1 << 24


def _widened(rows, width):
    """``rows`` padded on the right with -1 to ``width`` columns."""
    return np.pad(rows, ((0, 0), (0, width - rows.shape[1])), constant_values=-1)


def _padded_runs(values, start, counts):
    """The runs ``values[start[i]:start[i] + counts[i]]`` as the rows of an array padded
    with -1.
    """
    width = int(counts.max()) if counts.size else 0
    out = np.full((counts.size, width), -1, dtype=np.int64)
    for w in range(width):
        has = counts > w
        out[has, w] = values[start[has] + w]
    return out


class Interfaces:
    """The (k-1)-simplices between cells of different regions, on one shared point array.

    Attributes
    ----------
    points : ndarray of shape (n_points, dim)
    simplices : ndarray of int of shape (n, k)
        Each oriented with its normal from region ``pairs[:, 0]`` towards ``pairs[:, 1]``
        (the convention of :func:`ndboundary.levelset.marching_simplices`: the normal
        points where the difference ``f_pairs[:, 1] - f_pairs[:, 0]`` increases).
    pairs : ndarray of int of shape (n, 2)
        The two regions, smaller first.
    cells : ndarray of int of shape (n, 2) or None
        The cell on the side of ``pairs[:, 0]`` and of ``pairs[:, 1]``.
    point_ids : ndarray of int of shape (n_points,) or None
        Index of each point in the partition's cell points. Both None where the pieces
        come from each region's own cut, not from one partition
        (:meth:`~ndboundary.pipeline.result.RegionsResult.interfaces` of many mixed
        elements).

    Examples
    --------
    >>> from ndboundary.partition import partition, _y_example
    >>> faces = partition(*_y_example()).interfaces()
    >>> faces
    Interfaces(n_points=8, n_simplices=7)
    >>> sorted(set(map(tuple, faces.pairs.tolist()))), round(faces.measure(), 6)
    ([(0, 1), (0, 2), (1, 2)], 3.309401)
    """

    def __init__(self, points, simplices, pairs, cells, point_ids):
        self.points = points
        self.simplices = simplices
        self.pairs = pairs
        self.cells = cells
        self.point_ids = point_ids
        self._by_region = None

    def __len__(self):
        return int(self.simplices.shape[0])

    def of_region(self, r) -> np.ndarray:
        """The indices of the simplices bounding region ``r``, increasing."""
        if self._by_region is None:
            flat = self.pairs.ravel()
            n = int(flat.max()) + 1 if flat.size else 0
            start = np.concatenate([[0], np.cumsum(np.bincount(flat, minlength=n))])
            self._by_region = (np.argsort(flat, kind="stable") // 2, start)
        order, start = self._by_region
        if not 0 <= r < start.size - 1:
            return order[:0]
        return order[start[r] : start[r + 1]]

    def bounding(self, r):
        """The simplices bounding region ``r``, oriented outward from it, over the points
        they use: ``(used, simplices)``, ``used`` the indices of those points in
        :attr:`points`, increasing, and ``simplices`` numbering them.

        Examples
        --------
        >>> from ndboundary.partition import partition, _y_example
        >>> used, simplices = partition(*_y_example()).interfaces().bounding(0)
        >>> simplices.shape, bool(simplices.max() < used.size)
        ((5, 2), True)
        """
        mine = self.of_region(r)
        T = self.simplices[mine]
        flip = self.pairs[mine, 1] == r
        if T.shape[1] >= 2:
            T[flip, 0], T[flip, 1] = T[flip, 1].copy(), T[flip, 0].copy()
        used, remap = used_vertices(T, self.points.shape[0])
        return used, remap[T]

    def simplex_measures(self) -> np.ndarray:
        """Length / area / volume of each interface simplex (ones for k = 1)."""
        if self.simplices.shape[1] == 1:
            return np.ones(len(self))
        return simplex_measures(self.points, self.simplices)

    def measure(self) -> float:
        """Total length / area / volume of the interfaces."""
        return float(self.simplex_measures().sum())

    def junctions(self) -> Junctions:
        """The (k-2)-faces shared by interface pieces of three or more regions."""
        T, k = self.simplices, self.simplices.shape[1]
        D = self.points.shape[1]
        if k < 2 or len(self) == 0:
            return Junctions(np.zeros((0, D)), np.zeros((0, max(k - 1, 0)), dtype=np.int64), np.zeros((0, 0), int), [])
        n, r = max(self.points.shape[0], 1), int(self.pairs.max(initial=0)) + 1
        if float(n) ** (k - 1) * r >= 2.0**62:  # no integer key: rows of (face, region)
            faces = np.concatenate([np.sort(np.delete(T, i, axis=1), axis=1) for i in range(k)])
            regs = np.tile(self.pairs, (k, 1))
            rows = np.concatenate([np.column_stack([faces, regs[:, 0]]), np.column_stack([faces, regs[:, 1]])])
            rows = np.unique(rows, axis=0)
            uf, start, counts = np.unique(rows[:, :-1], axis=0, return_index=True, return_counts=True)
            j = np.flatnonzero(counts >= 3)
            regions = _padded_runs(rows[:, -1], start[j], counts[j])
            uf = uf[j]
        else:  # each (face, region) as one integer, sorted a share of the faces at a time
            code = np.concatenate([row_codes(np.sort(np.delete(T, i, axis=1), axis=1), n) for i in range(k)])
            shares = max(1, -(-code.size // JUNCTION_KEYS_AT_ONCE))
            share = (code % shares).astype(np.min_scalar_type(shares)) if shares > 1 else None
            found, regions = [], []
            for b in range(shares):
                rows = np.arange(code.size) if share is None else np.flatnonzero(share == b)
                pairs = self.pairs[rows % len(self)]
                keys = unique_values(np.concatenate([code[rows] * r + pairs[:, 0], code[rows] * r + pairs[:, 1]]))
                del rows, pairs
                face_keys = keys // r
                start = np.flatnonzero(np.r_[True, face_keys[1:] != face_keys[:-1]])
                counts = np.diff(np.r_[start, face_keys.size])
                j = np.flatnonzero(counts >= 3)
                found.append(face_keys[start[j]])
                regions.append(_padded_runs(keys % r, start[j], counts[j]))
            del code, share
            found = np.concatenate(found)
            order = np.argsort(found, kind="stable")  # as one sort of every key would list them
            width = max((a.shape[1] for a in regions), default=0)
            regions = np.concatenate([_widened(a, width) for a in regions])
            found, regions = found[order], regions[order]
            uf = np.empty((found.size, k - 1), dtype=np.int64)
            for c in range(k - 2, -1, -1):
                uf[:, c], found = found % n, found // n
        used, simp = np.unique(uf, return_inverse=True)
        return Junctions(self.points[used], simp.reshape(uf.shape[0], k - 1), regions, used)

    def __repr__(self):
        return f"Interfaces(n_points={self.points.shape[0]}, n_simplices={len(self)})"


class Partition:
    """The partition of a simplicial complex by the argmax of L piecewise-linear functions.

    Built by :func:`partition`.

    Attributes
    ----------
    cells : Cells
    n_regions : int
    input_measure : float
        Total measure of the input complex (computed when first read: a check, which the
        partition itself does not need).

    Examples
    --------
    >>> from ndboundary.partition import partition, _y_example
    >>> part = partition(*_y_example())
    >>> part
    Partition(n_regions=3, n_cells=20)
    >>> part.region_measures().round(6).tolist(), round(part.input_measure, 12)
    ([1.42265, 1.288675, 1.288675], 4.0)
    """

    def __init__(self, cells, n_regions, input_measure):
        self.cells = cells
        self.n_regions = int(n_regions)
        self._input_measure = input_measure  # a float, or a function that computes it
        self._interfaces = None

    @property
    def input_measure(self) -> float:
        """Total measure of the input complex."""
        if callable(self._input_measure):
            self._input_measure = self._input_measure()
        return float(self._input_measure)

    def __getstate__(self):
        # the input's measure is computed before pickling: its function holds the input
        state = dict(self.__dict__)
        state["_input_measure"] = self.input_measure
        return state

    def region_measures(self) -> np.ndarray:
        """Length / area / volume of each region, shape (L,): the cell measures summed."""
        return np.bincount(self.cells.regions, weights=self.cells.measures(), minlength=self.n_regions)

    def interfaces(self) -> Interfaces:
        """The interfaces between the regions (computed once)."""
        if self._interfaces is None:
            c = self.cells
            facets, pairs, cells = interface_facets(c.points, c.simplices, c.regions)
            used, remap = used_vertices(facets, c.points.shape[0])
            simp = remap[facets]
            self._interfaces = Interfaces(c.points[used], simp, pairs, cells, used)
        return self._interfaces

    def region_boundary(self, r) -> LevelSet:
        """The interface pieces bounding region ``r``, oriented outward from it.

        Closed where the region does not touch the border of the domain. ``edges`` of the
        returned level set holds each point's parent pair (see :attr:`Cells.parents`).

        Examples
        --------
        >>> from ndboundary.partition import partition, _y_example
        >>> b = partition(*_y_example()).region_boundary(0)
        >>> b, b.is_closed()
        (LevelSet(value=0.0, n_points=6, n_simplices=5), False)
        """
        f = self.interfaces()
        used, simp = f.bounding(r)
        return LevelSet(f.points[used], simp, self.cells.parents[f.point_ids[used]], 0.0)

    def __repr__(self):
        return f"Partition(n_regions={self.n_regions}, n_cells={len(self.cells)})"


def partition(points, simplices, values) -> Partition:
    """Partition a simplicial complex exactly by the largest of L piecewise-linear functions.

    Parameters
    ----------
    points : array_like of shape (n_vertices, dim)
    simplices : array_like of int of shape (n_simplices, k + 1), 1 <= k <= dim
    values : array_like or sparse matrix of shape (n_vertices, L), L >= 2
        Column r is the function of region r, linear on every simplex. Finite. A sparse
        matrix lists at each vertex only the regions that may win near it (its stored
        entries, at least one per vertex): a region not stored at a vertex counts as
        lower there than every stored value of the matrix, and the work of each region
        follows the vertices that store it instead of the whole complex. With many
        regions, each competing in a small part of the domain, that is what keeps the
        partition's cost and memory proportional to the interfaces.

    Returns
    -------
    Partition
        Region of a point: the smallest r with the largest value there.

    Notes
    -----
    The functions are added one at a time: against the envelope of the earlier ones
    (linear per cell) the new one changes sign only on the cells the interface of that
    pair crosses, and only those are split, into the two pieces of the hyperplane cut,
    each triangulated by the staircase rule in the global vertex order (so it agrees on
    shared faces). A cut point is keyed by its edge's two (global) point ids. The work
    follows the interfaces of the partial partitions: vectorised per sign pattern for
    dense values, one compiled pass per region for sparse ones.

    Examples
    --------
    Three linear functions on a square meet at a Y whose junction is the origin:

    >>> from ndboundary.partition import partition, _y_example
    >>> part = partition(*_y_example())
    >>> faces = part.interfaces()
    >>> float(abs(faces.junctions().points).max()) < 1e-12
    True
    >>> round(float(part.region_measures().sum()), 12)
    4.0
    """
    points = np.asarray(points, dtype=np.float64)
    simplices = np.asarray(simplices, dtype=np.int64)
    sparse = sp.issparse(values)
    values = sp.csr_matrix(values, dtype=np.float64) if sparse else np.asarray(values, dtype=np.float64)
    if points.ndim != 2 or simplices.ndim != 2 or values.ndim != 2:
        raise ValueError("points, simplices and values must be 2-D arrays")
    V, D = points.shape
    k = simplices.shape[1] - 1
    if not 1 <= k <= D:
        raise ValueError(f"simplices must have between 2 and dim + 1 = {D + 1} vertices, got {k + 1}")
    if values.shape[0] != V or values.shape[1] < 2:
        raise ValueError(f"values must have shape ({V}, L) with L >= 2, got {values.shape}")
    if not np.all(np.isfinite(values.data if sparse else values)):
        raise ValueError("values contain NaN or infinite entries")
    if simplices.size and (simplices.min() < 0 or simplices.max() >= V):
        raise ValueError("simplices refer to vertices that do not exist")
    measure = lambda: float(simplex_measures(points, simplices).sum())  # noqa: E731
    if not sparse:
        X, S, regions, F, parents = sweep(points, simplices, values)
        return Partition(Cells(X, S, regions, F, parents), values.shape[1], measure)
    values.sum_duplicates()
    empty = np.flatnonzero(np.diff(values.indptr) == 0)
    if empty.size:
        raise ValueError(f"values store no region at vertex {int(empty[0])}: every vertex needs one")
    return _sparse_partition(points, simplices, values, 1.0 - values.data.min() if values.nnz else 0.0)


def _sparse_partition(points, simplices, values, shift):
    """:func:`partition` of checked sparse ``values`` (CSR, summed), shifted by ``shift``
    first: every stored value above 0 once shifted, so that 0 is below each (the default
    shift makes the lowest 1). Two complexes cut with the same shift compute the same
    points where they meet, to the bit, as one complex holding both does.
    """
    shifted = values.copy()
    shifted.data = shifted.data + shift
    X, S, regions, parents = sweep_sparse(points, simplices, shifted)
    measure = lambda: float(simplex_measures(points, simplices).sum())  # noqa: E731
    return Partition(Cells(X, S, regions, None, parents), values.shape[1], measure)
