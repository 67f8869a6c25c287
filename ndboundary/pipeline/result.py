"""What a relaxation returns."""

from __future__ import annotations

import numbers
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .._arrays import expand_ranges, unique_values, used_vertices
from .._compiled import unique_pairs
from .._compiled_partition import beaten_simplices, point_simplices
from .._threads import available_threads
from ..domains.image import GridBand
from ..domains.pointcloud_operators import StencilDomain
from ..levelset import LevelSet, marching_simplices, simplex_measures
from ..partition import Cells, Interfaces, Partition, _sparse_partition, partition
from ..partition_clip import sweep_sparse
from . import interface_fit, junction_curves, junctions
from .band import can_cut, extend_outside
from .boundary import Boundary

__all__ = [
    "PARTITION_BY_REGION_SIMPLICES",
    "BandValues",
    "DeferredFill",
    "RegionsResult",
    "RelaxResult",
    "fit_two_regions",
    "keep_band",
    "summed_timings",
]


class DeferredFill:
    """A region's phi on its band, filled outside it (:func:`~ndboundary.pipeline.band.extend_outside`)
    only when it is read.

    The partition of many regions needs no fill (see :meth:`RegionsResult.region_values`),
    and the fill is a pass over the whole domain per region: deferring it makes the cost
    of a many-region relaxation follow its bands.
    """

    def __init__(self, elements, vertices, phi_band, side, distances, rate):
        self.elements, self.vertices, self.phi_band = elements, vertices, phi_band
        self._side, self.distances, self.rate = side, distances, rate

    @property
    def side(self):
        """Whether each vertex is on the region's side (given, or computed when read)."""
        return self._side() if callable(self._side) else self._side

    def filled(self, domain):
        """Phi on every vertex of ``domain``."""
        return extend_outside(domain, self.elements, self.vertices, self.phi_band, self.side, self.distances, self.rate)

    def stored(self):
        """The vertices and values this region stores in a sparse partition
        (:func:`~ndboundary.partition.partition`): phi on the band, and beyond it, on the
        region's side, ``1/2 + c`` with ``c`` one more than the largest ``|phi - 1/2|`` on
        the band.

        Outside its band a region is either the only one whose function exceeds 1/2 (the
        vertex is inside it, farther from its boundary than the band reaches, so no other
        band reaches it either) or below every function that competes there, and the band
        reaches more than a ring of elements past where it can win: the vertices left out
        change no largest function, and the partition is the filled functions' one.
        """
        c = float(np.abs(self.phi_band - 0.5).max()) + 1.0
        beyond = self.side if callable(self._side) else self._side.copy()
        beyond[self.vertices] = False
        deep = np.flatnonzero(beyond)
        return np.concatenate([self.vertices, deep]), np.concatenate([self.phi_band, np.full(deep.size, 0.5 + c)])


class BandValues:
    """Values on a band's vertices, zero beyond it, spread over the domain when read: the
    heat of a region among many, which is zero far from its zeta.
    """

    def __init__(self, vertices, values):
        self.vertices, self.values = vertices, values

    def filled(self, domain):
        """The values on every vertex of ``domain``."""
        out = np.zeros(domain.n_vertices)
        out[self.vertices] = self.values
        return out


def keep_band(res, elements, vertices, side, distances, rate):
    """Make ``res``, a region among many relaxed on the band of ``elements`` and
    ``vertices``, keep its phi and heat on the band only (filled over the domain when
    read: :class:`DeferredFill`, :class:`BandValues`) and none of its fields, so that
    hundreds of regions of a large domain do not each hold arrays of its size.
    """
    res.phi = DeferredFill(elements, vertices, res.phi, side, distances, rate)
    res.u = BandValues(vertices, res.u)
    res.field = res.smoothed_field = None


def summed_timings(results):
    """Seconds per step, summed over the relaxations ``results`` (of many regions)."""
    timings = {}
    for res in results:
        for step, seconds in res.timings.items():
            timings[step] = timings.get(step, 0.0) + seconds
    return timings


class _RegionMethods:
    """The partition of the domain by the largest of the region functions, and what it gives."""

    def region_values(self):
        """One function per region, shape (n_vertices, n_regions); the largest wins."""
        raise NotImplementedError

    def partition(self):
        """The exact partition (:func:`ndboundary.partition.partition`) of the domain's
        simplicial refinement by the largest region function, built once.
        """
        cached = self.__dict__.get("_partition")
        if cached is None:
            cached = self.__dict__["_partition"] = partition(*_complex(self.domain, self.region_values()))
        return cached

    def _mixed(self):
        """``(points, simplices, values)`` of the simplicial refinement of the elements where
        the largest function changes between their vertices (None when there is none to cut
        apart from the whole domain), and each region's measure of the other elements
        (built once).

        Where every vertex of an element has the same largest function, it is the largest
        over the whole element (the functions are linear on each simplex of the
        refinement, whose points are averages of the element's vertices): the element
        lies in that region, whole, and no interface crosses it. Cutting only the others
        makes the cost follow the interfaces, not the domain.
        """
        values = self.region_values()  # may leave the cut of its junctions' fit here
        cached = self.__dict__.get("_mixed_cache")
        if cached is None:
            beside = self.__dict__.pop("_cut_beside", None)
            lead = _argmax_rows(values)
            if beside is not None:
                far, far_part, shift = beside
                if _still_mixed(self.domain, values, lead, far, shift):
                    # the elements cut beside the fit are left out, and joined to the rest's cut
                    cached = _mixed_of(self.domain, values, lead, skip=far, shift=shift)
                    self.__dict__["_far_part"] = far_part, shift
            if cached is None:
                cached = _mixed_of(self.domain, values, lead)
            self.__dict__["_mixed_cache"] = cached
        return cached

    def _cut(self):
        """The partition of the mixed elements (:meth:`_mixed`; of the whole domain when
        there are none) and each region's measure of the others (built once).
        """
        cached = self.__dict__.get("_cut_cache")
        if cached is None:
            complex_, whole = self._mixed()
            far = self.__dict__.pop("_far_part", None)
            if far is not None:
                far_part, shift = far
                cut = far_part if complex_ is None else _JoinedCut(far_part, _shifted_cut(*complex_, shift))
            else:
                cut = self.partition() if complex_ is None else partition(*complex_)
            cached = self.__dict__["_cut_cache"] = (cut, whole)
            self.__dict__.pop("_region_cuts", None)  # the whole partition serves every region now
        return cached

    def _by_region(self):
        """A :class:`_RegionCuts` when the mixed elements' refinement holds more than
        :data:`PARTITION_BY_REGION_SIMPLICES` simplices with sparse values, else None.
        """
        if "_cut_cache" in self.__dict__:
            return None
        complex_ = self._mixed()[0]
        if "_far_part" in self.__dict__:  # the rest of the mixed elements, cut beside the fit
            return None
        if complex_ is None or not sp.issparse(complex_[2]) or complex_[1].shape[0] <= PARTITION_BY_REGION_SIMPLICES:
            return None
        cached = self.__dict__.get("_region_cuts")
        if cached is None:
            cached = self.__dict__["_region_cuts"] = _RegionCuts(*complex_)
        return cached

    def interfaces(self):
        """The interfaces between the relaxed regions (``pairs`` index ``classes``), with
        their junctions (:class:`~ndboundary.partition.Interfaces`). Built from the
        partition of every mixed element at once, whose memory follows all the interfaces
        together, about a kilobyte per simplex of their elements' refinement; beyond
        :data:`PARTITION_BY_REGION_SIMPLICES`, from each region's own cut
        (:meth:`_RegionCuts.interfaces`), whose memory follows one region: the same
        simplices, without ``cells`` and ``point_ids`` (None), which name the cells of a
        partition of them all.
        """
        cuts = self._by_region()
        if cuts is None:
            return self._cut()[0].interfaces()
        return cuts.interfaces()

    def region_boundary(self, r):
        """Region ``r``'s boundary, oriented outward, as a :class:`~ndboundary.LevelSet`.

        Where the mixed elements are many (:data:`PARTITION_BY_REGION_SIMPLICES`), it is
        cut from the partition of the simplices near region ``r`` only
        (:class:`_RegionCuts`), which gives the same surface, simplex for simplex, in
        memory that follows the region.
        """
        r = self._region_index(r)
        cuts = self._by_region()
        if cuts is None:
            return self._cut()[0].region_boundary(r)
        return cuts.boundary(r)

    def region_boundaries(self, regions=None):
        """The boundaries of ``regions`` (indices into ``classes``; every region by
        default), in their order: :meth:`region_boundary` of each.

        Where each region is cut on its own (:data:`PARTITION_BY_REGION_SIMPLICES`), the
        regions are cut on several threads at once (:func:`~ndboundary._threads.available_threads`),
        since the cuts' compiled passes hold no GIL; the surfaces are the same, simplex for
        simplex. ``ndboundary relax MESH LABELS --region-surfaces DIR`` goes through here;
        for a label image, which may hold hundreds of regions, see
        :meth:`each_region_boundary`.

        Raises
        ------
        TypeError, ValueError
            If a region is not an integer index into ``classes``.
        """
        regions = self._region_indices(regions)
        done = dict(self._each_boundary(sorted(set(regions)), None))
        return [done[r] for r in regions]

    def each_region_boundary(self, regions=None):
        """Yield ``(r, region_boundary(r))`` for each of ``regions`` (indices into
        ``classes``; every region by default), a few at a time: a caller that writes each
        boundary and lets it go holds a few at once, where :meth:`region_boundaries`
        holds them all. In the order given, but where each region is cut on its own
        (:data:`PARTITION_BY_REGION_SIMPLICES`) the region stored at the most points comes
        last, its boundary assembled from the pieces its neighbours' cuts keep for it.
        ``ndboundary relax IMAGE --surfaces DIR`` writes the surfaces this way.

        Raises
        ------
        TypeError, ValueError
            If a region is not an integer index into ``classes``.
        """
        return self._each_boundary(self._region_indices(regions), BOUNDARIES_AT_ONCE * available_threads())

    def _each_boundary(self, regions, batch):
        """``(r, boundary)`` for each of ``regions`` (checked indices): from the partition of
        every mixed element, or from the regions' own cuts, ``batch`` at a time (all at
        once when None).
        """
        cuts = self._by_region()
        if cuts is None:
            whole = self._cut()[0]
            return ((r, whole.region_boundary(r)) for r in regions)
        return cuts.each_boundary(regions, batch or max(len(regions), 1))

    def _region_indices(self, regions):
        """``regions`` (every region when None) checked as indices into ``classes``."""
        return [self._region_index(r) for r in (range(self.classes.size) if regions is None else regions)]

    def _region_index(self, r):
        """``r`` checked as an index into ``classes``."""
        n = self.classes.size
        if isinstance(r, bool) or not isinstance(r, numbers.Integral):
            raise TypeError(f"a region is an integer index into classes (0 to {n - 1}), got {r!r}")
        if not 0 <= r < n:
            raise ValueError(f"region {r} is out of range: there are {n} regions (0 to {n - 1})")
        return int(r)

    def region_measures(self):
        """Area / volume of every relaxed region, shape (n_regions,): they sum to the domain's
        (on the band of an image, :class:`~ndboundary.domains.image.GridBand`, to the whole
        image's: the pixels outside the band count whole).
        """
        cuts = self._by_region()
        whole = self._mixed()[1]
        if cuts is None:
            measures = self._cut()[0].region_measures() + whole
        else:
            measures = cuts.measures() + whole
        if isinstance(self.domain, GridBand):
            measures = measures + self.domain.measures_outside(self.classes)
        return measures


def _merged(pieces):
    """Interface pieces ``(points, simplices, pairs, parents)`` from several regions' cuts
    (a list, not empty, emptied) as one: a point two cuts share has the same coordinates
    in both, computed from the same values in the same order, and is merged by them (its
    parents, where the pieces have them, are the first cut's).
    """
    points = np.concatenate([p for p, _, _, _ in pieces])
    offsets = np.cumsum([0] + [p.shape[0] for p, _, _, _ in pieces])[:-1]
    simplices = np.concatenate([t + o for (_, t, _, _), o in zip(pieces, offsets, strict=True)])
    pairs = np.concatenate([q for _, _, q, _ in pieces])
    parents = None if pieces[0][3] is None else np.concatenate([e for _, _, _, e in pieces])
    pieces.clear()  # let the pieces go before the merge
    _, first, merged = np.unique(
        np.ascontiguousarray(points).view([("", points.dtype)] * points.shape[1]).ravel(),
        return_index=True, return_inverse=True,
    )  # fmt: skip
    return points[first], merged.ravel()[simplices], pairs, None if parents is None else parents[first]


def _on_threads(fn, items):
    """``[fn(item) for item in items]``, computed on :func:`~ndboundary._threads.available_threads`
    threads at once: for the regions' own cuts, whose compiled passes hold no GIL.
    """
    items = list(items)
    threads = min(available_threads(), len(items))
    if threads < 2:
        return [fn(item) for item in items]
    with ThreadPoolExecutor(threads, thread_name_prefix="ndboundary-regions") as pool:
        return list(pool.map(fn, items))


#: Beyond this many simplices in the refinement of the elements that interfaces cross,
#: :meth:`RegionsResult.region_boundary`, :meth:`~RegionsResult.region_measures` and
#: :meth:`~RegionsResult.interfaces` cut each region's neighbourhood on its own
#: (:class:`_RegionCuts`) instead of partitioning them all at once, whose memory grows
#: by about 180 bytes per simplex (1.0 GB for the
#: 5.7 M simplices of 46 regions on 138 x 174 x 122 voxels, in 7.2 s): the regions together
#: cost about twice the time (16 s there; each simplex is cut once for every region stored
#: at its points), in memory that follows one region.
PARTITION_BY_REGION_SIMPLICES = 10_000_000

#: How many of the mixed elements of a volume are refined to estimate the size of the
#: refinement of them all (:func:`_near_junction_elements`), before any is cut.
REFINEMENT_SAMPLE = 512
#: The mixed elements of a volume farther than this (h, and twice the elements' spread)
#: from every element whose vertices lead with three regions are cut while the junctions
#: are fitted (:func:`_far_cut`), on a thread of their own: no fit moves a vertex of them
#: (the fits move vertices within 4.6 h of such elements in a partition of 16 regions on
#: 192^3 voxels; one that moves another leaves every mixed element to the partition after
#: the fit).
BESIDE_FIT_REACH = 8.0
#: :meth:`RegionsResult.each_region_boundary` cuts this many regions per thread at a time.
BOUNDARIES_AT_ONCE = 4


class _RegionCuts:
    """Each region's partition, cut from the simplices where it is stored.

    A region can win only in simplices with a point storing it (sparse values, see
    :func:`~ndboundary.partition.partition`), and the partition of a simplex depends on
    the regions stored at its points alone: the partition of those simplices, with every
    region stored there, holds each of the region's cells exactly as the partition of
    the whole complex does (point ids keep their order, so every cut is triangulated
    alike), and so its boundary, which only cells of other regions next to them border.
    Of those simplices, the ones where another region beats it at every point
    (:func:`~ndboundary._compiled_partition.beaten_simplices`) hold none of its cells, nor
    a face they share, and are left out before the cut.

    The region stored at the most points (an atlas's background, whose cut alone would be
    larger than any other by tens of times) is never cut: each interface piece comes from
    the cut of the smaller of its two regions, the largest region's boundary is its
    pieces, and its measure is the simplices' measure less the others' (the partition is
    exact). The ``edges`` of a boundary cut region by region hold each point's parent
    pair in the cut it comes from (:attr:`~ndboundary.partition.Cells.parents`).
    """

    def __init__(self, points, simplices, values):
        self.points, self.simplices = points, simplices
        # shifted as partition() shifts the whole complex's values, so that every cut is
        # computed with the same rounding as there
        self.values = sp.csr_matrix(values, dtype=np.float64)
        self.values.sum_duplicates()
        self.values.data = self.values.data - self.values.data.min() + 1.0
        self.columns = self.values.tocsc()
        self._at_point = point_simplices(simplices, points.shape[0])
        self._scratch = threading.local()  # tables of the points per thread
        self._measures = {}
        self._interfaces = None
        self._kept = {}  # pieces with the largest region, kept from cuts made for boundaries
        # each region's rank by the points storing it (ties by index): an interface piece
        # is taken from the cut of its lower-ranked region, so the last is never cut for one
        sizes = np.diff(self.columns.indptr)
        order = np.lexsort((np.arange(sizes.size), sizes))
        self._rank = np.empty(sizes.size, dtype=np.int64)
        self._rank[order] = np.arange(sizes.size)
        self._largest = int(order[-1])

    def _partition(self, r):
        """``(partition, j, present)``: the partition of the simplices storing region
        ``r``, whose regions are those stored there (``present``, increasing), ``r`` being
        its region ``j``; it keeps only the cells with a facet's worth of points of region
        ``j``'s cells, all that its boundary needs. Region ``r``'s measure is kept for :meth:`measure`.
        """
        c = self.columns
        stored = c.indices[c.indptr[r] : c.indptr[r + 1]]
        indptr, ids = self._at_point  # the simplices at the points storing r
        chosen = unique_values(ids[expand_ranges(indptr[stored], indptr[stored + 1] - indptr[stored])])
        simplices = self.simplices[chosen]
        # less those where another region beats r at every point: none of r's cells, nor a
        # face they share with a cell beside them, lies there
        own = getattr(self._scratch, "own", None)  # r's values at every point, 0 elsewhere
        if own is None:
            own = self._scratch.own = np.zeros(self.points.shape[0])
        own[stored] = c.data[c.indptr[r] : c.indptr[r + 1]]
        try:
            kept = ~beaten_simplices(simplices, self.values, r, own)
        finally:
            own[stored] = 0.0
        chosen, simplices = chosen[kept], simplices[kept]
        if chosen.size == 0:  # the region wins in none of these simplices
            self._measures[r] = 0.0
            empty = partition(np.zeros((0, self.points.shape[1])), self.simplices[:0], np.zeros((0, 2)))
            return empty, 0, np.array([r])
        used = unique_values(simplices)
        slot = getattr(self._scratch, "slot", None)
        if slot is None:
            slot = self._scratch.slot = np.empty(self.points.shape[0], dtype=np.int64)
        slot[used] = np.arange(used.size)  # a scratch table of the points, read at these only
        values = self.values[used]
        present = unique_values(values.indices)
        values = sp.csr_matrix(
            (values.data, np.searchsorted(present, values.indices), values.indptr), shape=(used.size, present.size)
        )
        X, S, regions, parents = sweep_sparse(self.points[used], slot[simplices], values)
        del simplices, values  # the cut's own copies are let go before its boundary is found
        j = int(np.searchsorted(present, r))
        mine = regions == j
        self._measures[r] = float(simplex_measures(X, S[mine]).sum())
        # region j's boundary lies between its cells and cells with a facet in common, whose
        # points are all points of j's cells: only those are kept, so that the interfaces
        # of the other regions are not sought
        touched = np.zeros(X.shape[0], dtype=bool)
        touched[S[mine]] = True
        near = np.count_nonzero(touched[S], axis=1) >= S.shape[1] - 1
        part = Partition(
            Cells(X, S[near], regions[near], None, parents), present.size,
            lambda: float(simplex_measures(self.points, self.simplices[chosen]).sum()),
        )  # fmt: skip
        return part, j, present

    def boundary(self, r, keep=False):
        """Region ``r``'s boundary, oriented outward (a :class:`~ndboundary.LevelSet`):
        from its cut, or, for the largest region, from its neighbours' pieces with it.
        ``keep`` keeps the cut's piece with the largest region for that.
        """
        if r == self._largest:
            return self._largest_boundary()
        cut = self._partition(r)
        if keep:
            self._kept[r] = self._pieces(r, cut, only=self._largest)
        part, j, _ = cut
        return part.region_boundary(j)

    def each_boundary(self, regions, batch):
        """``(r, boundary)`` for each of ``regions`` in turn, ``batch`` regions cut at a
        time on several threads; the largest region's last, from the pieces its
        neighbours' cuts kept.
        """
        rest = [r for r in regions if r != self._largest]
        keep = self._largest in regions
        for start in range(0, len(rest), batch):
            some = rest[start : start + batch]
            yield from zip(some, _on_threads(lambda r: self.boundary(r, keep), some), strict=True)
        if self._largest in regions:
            yield self._largest, self._largest_boundary()

    def _largest_boundary(self):
        """The largest region's boundary, from the cuts of the regions stored beside it
        (or the pieces they kept).
        """
        r = self._largest
        c, v = self.columns, self.values
        rows = c.indices[c.indptr[r] : c.indptr[r + 1]]
        beside = unique_values(v.indices[expand_ranges(v.indptr[rows], v.indptr[rows + 1] - v.indptr[rows])])
        beside = beside[beside != r].tolist()
        if not beside:  # stored alone: no other region to take its pieces from
            part, j, _ = self._partition(r)
            return part.region_boundary(j)
        pieces = _on_threads(lambda k: self._kept.pop(k, None) or self._pieces(k, only=r), beside)
        self._kept.clear()
        points, T, pairs, parents = _merged(pieces)
        flip = pairs[:, 1] == r  # outward: as the partition orients them
        if T.shape[1] >= 2:
            T[flip, 0], T[flip, 1] = T[flip, 1].copy(), T[flip, 0].copy()
        used, remap = used_vertices(T, points.shape[0])
        return LevelSet(points[used], remap[T], parents[used], 0.0)

    def _pieces(self, r, cut=None, only=None):
        """The interface simplices between region ``r`` and the regions ranked above it
        (or region ``only`` alone), from ``r``'s cut (``cut``, made when not given):
        ``(points, simplices, pairs, parents)``, the pairs in the regions' numbering (each
        region's cut numbers the regions stored in it in the same order, and a pair lists
        its lower region first, whichever cut it comes from), the parents the cut's (with
        ``only``; else None).
        """
        part, j, present = self._partition(r) if cut is None else cut
        faces = part.interfaces()
        mine = faces.of_region(j)
        pairs = faces.pairs[mine]
        other = present[np.where(pairs[:, 0] == j, pairs[:, 1], pairs[:, 0])]
        mine = mine[self._rank[other] > self._rank[r] if only is None else other == only]  # one cut of each pair
        used, remap = used_vertices(faces.simplices[mine], faces.points.shape[0])
        parents = None if only is None else part.cells.parents[faces.point_ids[used]]
        return faces.points[used], remap[faces.simplices[mine]], present[faces.pairs[mine]], parents

    def interfaces(self):
        """Every interface, each piece taken from the cut of the lower-ranked of its two
        regions (the one stored at fewer points), on several threads (as
        :meth:`RegionsResult.region_boundaries`): the same simplices as the partition of
        them all. A point two cuts share has the same coordinates in both, computed from
        the same values in the same order, and is merged by them. Built once.
        """
        if self._interfaces is not None:
            return self._interfaces
        others = [r for r in range(self.values.shape[1]) if r != self._largest]
        points, simplices, pairs, _ = _merged(_on_threads(self._pieces, others))
        self._interfaces = Interfaces(points, simplices, pairs, None, None)
        return self._interfaces

    def measure(self, r):
        """Region ``r``'s measure within the simplices."""
        if r not in self._measures:
            self._partition(r)
        return self._measures[r]

    def measures(self):
        """Every region's measure within the simplices: the others' from their cuts, on
        several threads (as :meth:`interfaces`), the largest region's what they leave.
        """
        others = [r for r in range(self.values.shape[1]) if r != self._largest]
        measures = np.zeros(self.values.shape[1])
        measures[others] = _on_threads(self.measure, others)
        measures[self._largest] = self.total - measures[others].sum()
        return measures

    @cached_property
    def total(self):
        """The measure of all the simplices, summed a block at a time."""
        step = 1 << 22
        return float(
            sum(
                simplex_measures(self.points, self.simplices[i : i + step].astype(np.int64)).sum()
                for i in range(0, self.simplices.shape[0], step)
            )
        )


@dataclass
class RelaxResult(_RegionMethods):
    """What :func:`~ndboundary.relax` returns.

    Attributes
    ----------
    phi : ndarray of shape (n_vertices,)
        The relaxed function; ``phi > 1/2`` in region 1 (``classes[1]``).
    u : ndarray of shape (n_vertices,)
        The heat (step 1), on the original vertices.
    field : ndarray of shape (n_padded_elements, dim) or None
        The unit field of step 2 on the padded domain (None for a region among many
        relaxed on its band, see :attr:`RegionsResult.regions`).
    smoothed_field : ndarray of shape (n_padded_elements, dim) or None
        The field after step 3.
    boundary : Boundary
        The jagged boundary zeta.
    classes : ndarray of shape (2,)
        The label values of region 0 and region 1.
    domain : Domain
        The domain relaxed on.
    timings : dict
        Seconds per step: ``pad`` (finding zeta, padding, and assembling the stiffness and
        mass of the padded domain when they are not cached yet), ``heat``, ``field``,
        ``smoothing``, ``integration``, ``total``. The integration's matrix and
        preconditioner are built on a second thread during heat, field and smoothing, so
        the steps share that time; ``solver["integration"].setup_time`` is its
        preconditioner's.
    solver : dict of SolveInfo
        Per linear solve, its method, iterations and relative residual.
    params : dict
        The parameters used; ``lam_scale`` is the factor applied to ``lam`` (see
        :mod:`ndboundary.pipeline.integration`); ``lifted_pins`` the facet pins of an
        image whose weight was lifted where the level set crossed a pixel centre (see
        :func:`~ndboundary.pipeline.integration.within_slabs`; 0 elsewhere).

    Examples
    --------
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> mesh = kuhn_grid(20, 2)
    >>> result = relax(mesh, label_by(mesh, circle), on="elements")
    >>> result.level_set().n_components()
    1
    """

    phi: np.ndarray
    u: np.ndarray
    field: np.ndarray
    smoothed_field: np.ndarray
    boundary: Boundary
    classes: np.ndarray
    domain: object
    timings: dict = field(default_factory=dict)
    solver: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)

    def region_values(self):
        """``(1 - phi, phi)``: region 0 where ``phi < 1/2``, region 1 where ``phi > 1/2``."""
        return np.stack([1.0 - self.phi, self.phi], axis=1)

    def level_set(self, value=0.5) -> LevelSet:
        """The level set ``phi == value`` (default 1/2, the relaxed boundary) by marching simplices."""
        value = float(value)
        if not np.isfinite(value):
            raise ValueError(f"value must be finite, got {value!r}")
        points, simplices, values = self.domain.level_set_complex(self.phi, value)
        return marching_simplices(points, simplices, values, value)


class RegionsResult(_RegionMethods):
    """What :func:`~ndboundary.relax` returns for three or more labels.

    Attributes
    ----------
    phi : ndarray of shape (n_vertices, n_regions)
        One relaxed function per region, columns in ``classes`` order: region ``r``'s
        function is above 1/2 in region ``r``. A point belongs to the region whose
        function is largest there. Outside a region's band it is filled when first read.
        Near the point junctions of a mesh or image in the plane or on a surface, the functions
        are those of the junctions fitted to the labels
        (:mod:`~ndboundary.pipeline.junctions`), and in the plane near every interface
        those of the interface fitted to them (:mod:`~ndboundary.pipeline.interface_fit`):
        their largest meets and parts there, while their values need not cross 1/2 on the
        region's boundary.
    classes : ndarray of shape (n_regions,)
    domain : Domain
    regions : list of RelaxResult
        Region ``r`` relaxed against the rest (each filled when the list is first read),
        its own relaxation, without the fitted junctions and interfaces.
    timings : dict
        Seconds per step, summed over the regions, and ``total``.
    params : dict

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> mesh = kuhn_grid(30, 2, jitter=0.2, random_state=0)
    >>> c = mesh.element_centroids()
    >>> labels = np.where(c[:, 0] < 0, 0, np.where(c[:, 1] < 0, 1, 2))  # a T of three regions
    >>> result = relax(mesh, labels, on="elements")
    >>> result.phi.shape, round(float(result.region_measures().sum()), 9)
    ((961, 3), 4.0)
    >>> len(result.interfaces().junctions())
    1
    """

    def __init__(self, classes, domain, regions, timings=None, params=None, codes=None):
        self.classes = classes
        self.domain = domain
        self._regions = regions
        self.timings = {} if timings is None else timings
        self.params = {} if params is None else params
        # the labels' region per element (or vertex), kept where junctions are fitted: on
        # meshes and images in the plane, on surfaces and in volumes, not on a graph
        fitted = getattr(domain, "element_dim", None) in (2, 3) and can_cut(domain)
        fitted = fitted and not isinstance(domain, StencilDomain)
        self._codes = codes if fitted else None
        self._junction_values = []  # (vertices, regions, values) near each fitted junction
        self._interface_values = []  # the same near each fitted interface

    def __repr__(self):
        return f"RegionsResult(n_regions={self.classes.size}, n_vertices={self.domain.n_vertices})"

    @property
    def regions(self):
        """Every region relaxed against the rest, as a list of :class:`RelaxResult`.

        Relaxed on their bands, the regions do not keep their fields (``field`` and
        ``smoothed_field`` are None): hundreds of regions of a large image would hold
        gigabytes of them. ``phi`` and ``u`` cover the domain once this is read.
        """
        for res in self._regions:
            if isinstance(res.phi, DeferredFill):
                res.phi = res.phi.filled(self.domain)
            if isinstance(res.u, BandValues):
                res.u = res.u.filled(self.domain)
        return self._regions

    @property
    def phi(self):
        """The region functions, shape (n_vertices, n_regions) (built once): each region's
        relaxation, and near each junction fitted to the labels the fitted values
        (:meth:`region_values`).
        """
        cached = self.__dict__.get("_phi")
        if cached is None:
            cached = self.region_values()  # the junctions fitted
            if sp.issparse(cached):  # the regions' bands only: filled now
                cached = np.stack([res.phi for res in self.regions], axis=1)
                cached = _written(_written(cached, self._junction_values), self._interface_values)
            self.__dict__["_phi"] = cached
            self.__dict__.pop("_values", None)
        return cached

    def region_values(self):
        """The region functions as the partition needs them: ``phi`` where it is filled;
        while the regions hold it on their bands only, a sparse matrix (n_vertices,
        n_regions) that stores each region on its band and beyond it on its own side
        (:meth:`DeferredFill.stored`), which the partition reads as the same largest
        function with work and memory that follow the bands, not ``L`` times the domain.

        In the plane and on surfaces, the values near each point junction are those of
        the junction fitted to the labels (:mod:`~ndboundary.pipeline.junctions`), in
        volumes those near each junction curve and its corners
        (:mod:`~ndboundary.pipeline.junction_curves`), so that the partition's junctions
        are the fitted ones, and in the plane the values
        near each interface those of the interface fitted to them
        (:mod:`~ndboundary.pipeline.interface_fit`); ``regions`` keeps every region's own
        relaxation.
        """
        if "_phi" in self.__dict__:
            return self.__dict__["_phi"]
        cached = self.__dict__.get("_values")
        if cached is None:
            cached = self._relaxed_values()
            if self._fit_junctions(cached):
                cached = _written(cached, self._junction_values)
            if self._fit_interfaces(cached):
                cached = _written(cached, self._interface_values)
                self.__dict__.pop("_mixed_cache", None)  # cut from the values before the fit
            self.__dict__["_values"] = cached
        return cached

    def _relaxed_values(self):
        """:meth:`region_values` of the regions' own relaxations (no junction fitted)."""
        if not any(isinstance(r.phi, DeferredFill) for r in self._regions):
            return np.stack([res.phi for res in self._regions], axis=1)
        # column by column (each region's vertices are distinct): no triplets, whose
        # row and column arrays would cost more than the matrix at hundreds of regions
        V, L = self.domain.n_vertices, len(self._regions)
        index = np.int32 if V < np.iinfo(np.int32).max else np.int64
        rows, data = [], []
        for res in self._regions:
            if isinstance(res.phi, DeferredFill):
                vertices, values = res.phi.stored()
            else:
                vertices, values = np.arange(res.phi.size), res.phi
            rows.append(vertices.astype(index, copy=False))
            data.append(values)
        indptr = np.concatenate([[0], np.cumsum([r.size for r in rows])])
        columns = sp.csc_matrix((np.concatenate(data), np.concatenate(rows), indptr), shape=(V, L))
        del rows, data
        out = columns.tocsr()
        out.sort_indices()
        return out

    def _fit_junctions(self, values):
        """Fit the junctions of the partition of the relaxed functions ``values`` to the
        labels, once: points in the plane and on surfaces
        (:mod:`~ndboundary.pipeline.junctions`), curves and their corners in volumes
        (:mod:`~ndboundary.pipeline.junction_curves`); whether any was fitted.

        The junctions are found by cutting the complex near them only
        (:func:`_near_junctions`). In the plane and on surfaces that complex is cut from
        the refinement of every mixed element, which is kept for the partition when no
        junction was fitted; in volumes only the mixed elements near the junctions are
        refined (:func:`_near_junction_elements`), and the partition refines the mixed
        elements of the fitted functions.
        """
        self._junction_values = []
        if self._codes is None or not junctions.JUNCTION_FIT or self.classes.size < 3:
            return False
        tick = time.perf_counter()
        lead = _argmax_rows(values)
        h = self.params.get("h") or self.domain.mean_edge_length()
        on = self.params.get("on", "elements")
        mixed, pool = None, None
        if self.domain.element_dim == 3 and can_cut(self.domain):  # only the mixed elements near junctions refined
            near, cut_size, far = _near_junction_elements(
                self.domain, values, lead, 5.0 * h, PARTITION_BY_REGION_SIMPLICES, BESIDE_FIT_REACH * h
            )
            if cut_size > PARTITION_BY_REGION_SIMPLICES:
                return False  # the whole cut would not fit in memory: see _RegionCuts
            crossings = np.zeros((0, 3)), np.zeros((0, 2), dtype=np.int64)
            if near is not None and far is not None and sp.issparse(values):
                # the mixed elements far from every junction, which no fit reaches, are cut
                # while the junctions are fitted: their compiled passes hold no GIL
                shift = 1.0 - float(values.data.min())
                pool = ThreadPoolExecutor(1, thread_name_prefix="ndboundary-beside")
                far_cut = pool.submit(_far_cut, self.domain, values, far, shift)
        else:
            mixed = _mixed_of(self.domain, values, lead)
            if mixed[0] is not None and mixed[0][1].shape[0] > PARTITION_BY_REGION_SIMPLICES:
                self.__dict__["_mixed_cache"] = mixed  # the partition's, not built twice
                return False  # the whole cut would not fit in memory: see _RegionCuts
            complex_ = _complex(self.domain, values) if mixed[0] is None else mixed[0]
            complex_lead = _argmax_rows(complex_[2])
            near = _near_junctions(*complex_, complex_lead, 5.0 * h)
            crossings = _border_crossings(*complex_, complex_lead)
        try:
            faces = None if near is None else partition(*near).interfaces()
            if faces is not None and faces.simplices.shape[1] == 3:  # surfaces in a volume
                self._junction_values = junction_curves.curve_corrections(
                    self.domain, self._codes, on, values, faces, h, lead
                )
            elif faces is not None or len(crossings[0]):
                crossings = (*crossings, lead)
                self._junction_values = junctions.junction_corrections(
                    self.domain, self._codes, on, values, faces, h, crossings
                )
        finally:
            if pool is not None:
                pool.shutdown(wait=True)
        if pool is not None:
            far_part, far_vertices = far_cut.result()
            moved = np.zeros(self.domain.n_vertices, dtype=bool)
            for vertices, _, _ in self._junction_values:
                moved[vertices] = True
            if not moved[far_vertices].any():  # else the partition cuts every mixed element
                self.__dict__["_cut_beside"] = far, far_part, shift
        self.params["fitted_junctions"] = len(self._junction_values)
        self.timings["junctions"] = time.perf_counter() - tick
        if not self._junction_values:
            if mixed is not None:
                self.__dict__["_mixed_cache"] = mixed
            return False
        return True

    def _fit_interfaces(self, values):
        """Fit the interfaces of the partition of ``values`` (the junctions' fits written)
        to the labels (:mod:`~ndboundary.pipeline.interface_fit`), once, on domains in the
        plane; whether any was fitted.
        """
        self._interface_values = []
        if self._codes is None or not interface_fit.INTERFACE_FIT or self.classes.size < 3 or self.domain.dim != 2:
            return False
        tick = time.perf_counter()
        complex_ = _mixed_of(self.domain, values)[0]
        if complex_ is None or complex_[1].shape[0] > PARTITION_BY_REGION_SIMPLICES:
            return False
        h = self.params.get("h") or self.domain.mean_edge_length()
        faces = partition(*complex_).interfaces()
        # the junctions' fits hold their points; a crossing of the border the interface's
        # fit places anew, from its whole length
        skip = [v for v, r, _ in self._junction_values if len(r) >= 3]
        on = self.params.get("on", "elements")
        self._interface_values, moved = interface_fit.interface_corrections(
            self.domain, self._codes, on, values, faces, h, skip
        )
        self.params["fitted_interfaces"] = len(self._interface_values) - moved
        self.params["refitted_junctions"] = moved
        self.timings["interfaces"] = time.perf_counter() - tick
        return bool(self._interface_values)


def fit_two_regions(result, codes):
    """Fit the relaxed boundary of ``result``, a relaxation of two regions in the plane, to
    its labelled sites (``codes``: each element's region, 0 or 1), as the interfaces of a
    partition in the plane are fitted (:mod:`~ndboundary.pipeline.interface_fit`, with
    :data:`~ndboundary.pipeline.interface_fit.CURVE_STIFFNESS` and ``CURVE_TAUS``), and
    write the fit into ``result.phi`` (a new array) near the boundary; whether any part of
    it was fitted. Only the elements the boundary crosses are cut.

    Each pair of pixels across the staircase says only that the boundary crosses the
    segment between their centres, and the relaxation pins it at the segment's middle
    (weighted towards the staircase's risers). The fit reads the whole curve instead: the
    smoothest curve that parts the sites with the largest margins.
    """
    domain = result.domain
    if not interface_fit.INTERFACE_FIT or domain.points.shape[1] != 2 or not can_cut(domain):
        return False
    values = result.region_values()
    complex_ = _mixed_of(domain, values)[0]
    if complex_ is None:
        return False
    h = result.params.get("h") or domain.mean_edge_length()
    faces = partition(*complex_).interfaces()
    fixes, _ = interface_fit.interface_corrections(
        domain, codes, "elements", values, faces, h, [], interface_fit.CURVE_STIFFNESS, interface_fit.CURVE_TAUS,
        interface_fit.CURVE_CORNER, straight=0.0, start_passes=0, hold_border=False,
    )  # fmt: skip
    phi = np.array(result.phi, dtype=np.float64)
    for vertices, regions, new in fixes:
        ones = new[:, 1] if regions[1] == 1 else new[:, 0]  # phi - 1/2 = (v1 - v0) / 2
        zeros = new[:, 0] if regions[1] == 1 else new[:, 1]
        phi[vertices] = 0.5 * (ones - zeros + 1.0)
    result.phi = phi
    result.params["fitted_interfaces"] = len(fixes)
    return bool(fixes)


def _near_junctions(points, simplices, values, lead, radius):
    """The part of the complex ``(points, simplices, values)`` within ``radius`` of its
    simplices whose vertices lead (``lead``, each point's largest function) with three or
    more regions, where point junctions may be, as a complex of its own; None when there
    is none. Cutting it alone finds the junctions and the interfaces near them at a cost
    that follows the junctions.
    """
    lead = np.sort(lead[simplices], axis=1)
    seeds = np.flatnonzero((np.diff(lead, axis=1) != 0).sum(axis=1) >= 2)
    if seeds.size == 0:
        return None
    tree = cKDTree(points[unique_values(simplices[seeds])])
    near = tree.query(points, distance_upper_bound=radius, workers=available_threads())[0] < np.inf
    kept = simplices[near[simplices].all(axis=1)]
    used = unique_values(kept)
    return points[used], np.searchsorted(used, kept), values[used]


def _near_junction_elements(domain, values, lead, radius, limit, beside=np.inf):
    """:func:`_near_junctions` of the refinement of the mixed elements near those whose
    vertices lead (``lead``) with three or more regions, without refining the others:
    the complex (None when there is none), and the number of simplices the refinement of
    every mixed element would hold, estimated from a sample of them
    (:data:`REFINEMENT_SAMPLE` elements spread over them; exact where the elements are
    alike). Beyond ``limit`` simplices, the complex is not built. Third, the mixed
    elements farther than ``beside`` (and twice the spread below) from every element whose
    vertices lead with three regions, which :func:`_far_cut` cuts beside the junctions'
    fit (None when there is none, or no complex).

    The elements refined are the mixed ones whose centroids lie within ``radius`` and
    twice the farthest vertex from a mixed element's centroid of one whose vertices lead
    with three regions: every simplex within ``radius`` of a simplex whose points lead with
    three regions lies in one of them, as long as three regions lead at the vertices of
    the element that simplex lies in, or of another within that reach. The junctions of a
    volume's partition lie where three interfaces meet, among a small share of the
    elements the interfaces cross (a fifth of them for a partition of 16 regions on 192^3
    voxels).
    """
    mixed = domain.mixed_elements(lead)[0]
    ids = np.flatnonzero(mixed)
    if ids.size == 0:
        return None, 0, None
    sample = np.zeros(domain.n_elements, dtype=bool)
    sample[ids[:: max(1, ids.size // REFINEMENT_SAMPLE)]] = True
    part = domain.subdomain(sample)[0]
    estimate = ids.size * part._refinement[1].shape[0] / part.n_elements
    if estimate > limit:
        return None, estimate, None
    sub, vertices = domain.subdomain(mixed)
    by_element = sub.incidence.T.tocsr()
    owner = np.repeat(np.arange(ids.size), np.diff(by_element.indptr))
    L = values.shape[1]
    keys = unique_values(owner * L + lead[vertices][by_element.indices])
    three = np.bincount(keys // L, minlength=ids.size) >= 3
    if not three.any():
        return None, estimate, None
    centroids = sub.centroids_of(np.arange(ids.size))
    spread = float(np.linalg.norm(sub.points[by_element.indices] - centroids[owner], axis=1).max())
    reach = radius + 2.0 * spread
    d = cKDTree(centroids[three]).query(
        centroids, distance_upper_bound=max(reach, beside + 2.0 * spread), workers=available_threads()
    )[0]
    del sub, by_element, owner, keys, centroids
    keep = np.zeros(domain.n_elements, dtype=bool)
    keep[ids[d <= reach]] = True
    far = None
    beyond = ~(d <= beside + 2.0 * spread)
    if beyond.any():
        far = np.zeros(domain.n_elements, dtype=bool)
        far[ids[beyond]] = True
    part, vertices = domain.subdomain(keep)
    local = values[vertices]
    if sp.issparse(local):
        local = _within_reach(part, local)
    points, simplices, local = _complex(part, local)
    near = _near_junctions(points, simplices, local, _argmax_rows(local), radius)
    return near, estimate, None if near is None else far


def _border_crossings(points, simplices, values, lead):
    """Where the interfaces meet the border of the 2-D complex ``(points, simplices,
    values)``, each point's largest function ``lead``: the points, and the two regions
    leading at the ends of each border edge that the interfaces cross. The complex is the
    domain's, or its mixed elements' (whose border elsewhere no interface crosses: the
    elements beyond lie in one region, and both ends of an edge they share lead with it).
    """
    if simplices.shape[1] != 3:
        return np.zeros((0, points.shape[1])), np.zeros((0, 2), dtype=np.int64)
    edges = np.sort(np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]], simplices[:, [0, 2]]]), axis=1)
    edges = edges.astype(np.int32)  # the complex is cut whole only below PARTITION_BY_REGION_SIMPLICES
    distinct, which = unique_pairs(edges[:, 0], edges[:, 1], points.shape[0])
    edges = distinct[np.bincount(which, minlength=len(distinct)) == 1]  # in one simplex: on the border
    edges = edges[lead[edges[:, 0]] != lead[edges[:, 1]]]
    pairs = lead[edges]
    if len(edges) == 0:
        return np.zeros((0, points.shape[1])), np.zeros((0, 2), dtype=np.int64)
    rows = values[edges.ravel()]
    rows = rows.toarray() if sp.issparse(rows) else np.asarray(rows)
    rows = rows.reshape(len(edges), 2, -1)
    k = np.arange(len(edges))
    # the difference of the two leading functions at each end, zero where the edge is cut
    gap = rows[k, :, pairs[:, 0]] - rows[k, :, pairs[:, 1]]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = gap[:, 0] / (gap[:, 0] - gap[:, 1])
    cut = np.isfinite(t)  # a tie at both ends crosses nowhere in particular
    edges, pairs, t = edges[cut], pairs[cut], t[cut]
    crossing = points[edges[:, 0]] + t[:, None] * (points[edges[:, 1]] - points[edges[:, 0]])
    return crossing, pairs


def _written(values, fitted):
    """The region functions ``values`` (an array, or a CSR matrix with sorted indices)
    with each fitted ``(vertices, regions, new)`` written over them, on a copy; a sparse
    ``values`` stores every fitted entry.
    """
    if not fitted:
        return values
    out = values.copy()
    if not sp.issparse(out):
        for vertices, regions, new in fitted:
            out[np.ix_(vertices, regions)] = new
        return out
    keys = _entry_keys(out)[1]
    L = out.shape[1]
    for vertices, regions, new in fitted:
        at, found = _lookup(keys, (vertices[:, None] * L + regions[None, :]).ravel())
        if not found.all():
            raise RuntimeError("a fitted junction's value is not stored")  # checked when fitted
        out.data[at] = new.ravel()
    return out


def _mixed_of(domain, values, lead=None, skip=None, shift=None):
    """:meth:`_RegionMethods._mixed` of the region functions ``values`` on ``domain``
    (``lead``: each vertex's largest function, when known).

    ``skip``: mixed elements left out of the complex (cut beside the junctions' fit,
    :func:`_far_cut`), and None for it when they are all the mixed ones; ``shift``: the
    shift of the sparse values while averaged (:func:`_complex`).
    """
    mixed, lowest = domain.mixed_elements(_argmax_rows(values) if lead is None else lead)
    if not can_cut(domain) or mixed.all() or not mixed.any():
        return None, np.zeros(values.shape[1])
    whole = np.bincount(lowest[~mixed], weights=np.asarray(domain.A)[~mixed], minlength=values.shape[1])
    if skip is not None:
        mixed = mixed & ~skip
        if not mixed.any():
            return None, whole
    sub, vertices = domain.subdomain(mixed)
    local = values[vertices]
    if sp.issparse(local):
        local = _within_reach(sub, local)
    points, simplices, local = _complex(sub, local, shift)
    if points.shape[0] < np.iinfo(np.int32).max:  # held until the partition: half the bytes
        simplices = simplices.astype(np.int32)
    return (points, simplices, local), whole


def _far_cut(domain, values, far, shift):
    """The partition of the mixed elements ``far`` (:func:`_near_junction_elements`) by
    the sparse region functions ``values``, its interfaces found, and the vertices of those
    elements: the part of the partition that the junctions' fit, which moves no vertex of
    them, leaves as it is. Made beside the fit (:meth:`RegionsResult._fit_junctions`),
    ``values`` shifted by ``shift`` as the rest will be (:func:`_shifted_cut`).
    """
    sub, vertices = domain.subdomain(far)
    local = _within_reach(sub, values[vertices])
    part = _shifted_cut(*_complex(sub, local, shift), shift)
    part.interfaces()
    return part, vertices


def _shifted_cut(points, simplices, values, shift):
    """The partition of a complex of sparse ``values`` (as :func:`_complex` gives them),
    shifted by ``shift`` (:func:`~ndboundary.partition._sparse_partition`).
    """
    values = sp.csr_matrix(values, dtype=np.float64)
    values.sum_duplicates()
    return _sparse_partition(np.asarray(points, dtype=np.float64), np.asarray(simplices, dtype=np.int64), values, shift)


def _still_mixed(domain, values, lead, far, shift):
    """Whether the elements ``far`` cut beside the junctions' fit are still all mixed by
    the fitted ``values`` (sparse; ``lead``, each vertex's largest), and ``shift`` keeps
    every value above 0: then the cut of the others joins theirs.
    """
    if not sp.issparse(values) or not float(values.data.min()) + shift > 0.0:
        return False
    return not (far & ~domain.mixed_elements(lead)[0]).any()


class _JoinedCut:
    """The partition of the mixed elements as the partitions of two parts of them, the
    elements cut beside the junctions' fit (``first``) and the others (``second``), both
    shifted alike (:func:`_shifted_cut`): the interfaces of both, joined where they meet by
    the points' coordinates, and the regions' measures summed. The ``edges`` of a region's
    boundary hold each point's parent pair in the part it comes from.
    """

    def __init__(self, first, second):
        self.first, self.second = first, second
        self._interfaces = None
        self._parents = None

    def region_measures(self):
        """Every region's measure within the mixed elements."""
        return self.first.region_measures() + self.second.region_measures()

    def interfaces(self):
        """The interfaces of both parts as one (built once): the first part's points, then
        those of the second that the first does not hold.
        """
        if self._interfaces is None:
            first, second = self.first.interfaces(), self.second.interfaces()
            shared = _same_points(first.points, second.points)  # -1 where the first has no such point
            new = shared < 0
            number = shared.copy()
            number[new] = first.points.shape[0] + np.arange(int(new.sum()))
            points = np.concatenate([first.points, second.points[new]])
            simplices = np.concatenate([first.simplices, number[second.simplices]])
            pairs = np.concatenate([first.pairs, second.pairs])
            self._parents = np.concatenate(
                [self.first.cells.parents[first.point_ids], self.second.cells.parents[second.point_ids[new]]]
            )
            self._interfaces = Interfaces(points, simplices, pairs, None, None)
        return self._interfaces

    def region_boundary(self, r):
        """Region ``r``'s boundary, oriented outward (as
        :meth:`~ndboundary.partition.Partition.region_boundary`).
        """
        f = self.interfaces()
        used, simp = f.bounding(r)
        return LevelSet(f.points[used], simp, self._parents[used], 0.0)


def _same_points(a, b):
    """For each point of ``b``, the index of a point of ``a`` with the same coordinates, to
    the bit, or -1: a sort of a hash of the coordinates' bits, each match then checked.
    """

    def keys(points):
        bits = np.ascontiguousarray(points, dtype=np.float64).view(np.uint64)
        out = np.zeros(bits.shape[0], dtype=np.uint64)
        for c in range(bits.shape[1]):
            out = (out ^ bits[:, c]) * np.uint64(0x9E3779B97F4A7C15)  # a multiplicative hash
        return out

    out = np.full(b.shape[0], -1, dtype=np.int64)
    if a.shape[0] == 0 or b.shape[0] == 0:
        return out
    ka = keys(a)
    order = np.argsort(ka)
    sorted_keys = ka[order]
    at = np.minimum(np.searchsorted(sorted_keys, keys(b)), order.size - 1)
    candidate = order[at]
    same = (a[candidate] == b).all(axis=1)
    out[same] = candidate[same]
    return out


def _argmax_rows(values):
    """The column of each row's largest value, the smallest among equals, for a dense
    array or a sparse matrix (its stored entries; every row stores one).
    """
    if not sp.issparse(values):
        return np.argmax(values, axis=1)
    values = sp.csr_matrix(values)
    starts = values.indptr[:-1]
    top = np.maximum.reduceat(values.data, starts)
    counts = np.diff(values.indptr)
    at_top = np.where(values.data == np.repeat(top, counts), values.indices, values.shape[1])
    return np.minimum.reduceat(at_top, starts)


def _complex(domain, values, shift=None):
    """``domain.level_set_complex(values)``, for sparse values too: a point the
    refinement adds stores a region when each vertex it averages stores it (elsewhere the
    region stays below the functions that compete there, as at those vertices). The
    sparse values are averaged shifted by ``shift`` (by default, so that the lowest is 1),
    and two complexes averaged with the same shift give the points they share the same
    values, to the bit.
    """
    if not sp.issparse(values):
        return domain.level_set_complex(values)
    points, simplices, R = domain._refinement
    if R is None:
        return points, simplices, values
    R = sp.csr_matrix(R)
    stored = sp.csr_matrix((np.ones(values.nnz), values.indices, values.indptr), shape=values.shape)
    if shift is None:
        shift = 1.0 - values.data.min()  # every stored value above 0: none cancels in the averages
    shifted = sp.csr_matrix((values.data + shift, values.indices, values.indptr), shape=values.shape)
    mean = (R @ shifted).tocsr()
    count = (abs(R).sign() @ stored).tocsr()
    mean.sort_indices()
    count.sort_indices()
    rows = _entry_keys(count)[0]
    out = _kept(mean, rows, count.data == np.diff(R.indptr)[rows], offset=shift)
    return points, simplices, out


def _within_reach(domain, values):
    """The sparse ``values`` (CSR, vertices x regions) without the entries of regions that
    win in no element around their vertex; the largest function is unchanged.

    A region cannot win anywhere in an element where its largest value at the element's
    vertices is below another region's smallest, ``T(e)`` (the functions are linear on
    each simplex of the refinement, whose points average the element's vertices); ``T``
    is read off the regions that are largest at some vertex of ``e``. A region is kept
    at a vertex when its value at a vertex of the vertex's star reaches the smallest
    ``T`` there: every region that may win in an element is kept at all its vertices,
    and the partition resolves each region near where it competes only.
    """
    values = sp.csr_matrix(values)
    values.sort_indices()
    V, L = values.shape
    by_element = domain.incidence.T.tocsr()
    corners = by_element.indices  # every element's vertices, element by element
    elements = np.repeat(np.arange(by_element.shape[0]), np.diff(by_element.indptr))
    best = _argmax_rows(values)
    rows, keys = _entry_keys(values)
    T = np.full(by_element.shape[0], -np.inf)
    for reduce in (np.minimum, np.maximum):  # the lowest and the highest leading region
        lead = reduce.reduceat(best[corners], by_element.indptr[:-1])
        at, found = _lookup(keys, corners * L + lead[elements])
        low = np.where(found, values.data[at], -np.inf)  # not stored: no bound from it
        T = np.maximum(T, np.minimum.reduceat(low, by_element.indptr[:-1]))
    reach = np.minimum.reduceat(T[domain.incidence.indices], domain.incidence.indptr[:-1])
    hot = values.copy()  # its own index arrays: dropping its zeros must not touch values'
    hot.data = (values.data >= reach[rows]).astype(np.float64)
    hot.eliminate_zeros()
    star = sp.csr_matrix(domain.incidence @ (by_element @ hot))  # > 0 where a vertex of the star is hot
    star.sort_indices()
    return _kept(values, rows, _lookup(_entry_keys(star)[1], keys)[1])


def _entry_keys(matrix):
    """The row of every stored entry of a CSR ``matrix`` with sorted indices, and its key
    ``row * n_columns + column`` (increasing).
    """
    rows = np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))
    return rows, rows * matrix.shape[1] + matrix.indices


def _lookup(keys, want):
    """Where each of ``want`` is in the increasing ``keys``, and whether it is there."""
    if keys.size == 0:
        return np.zeros(want.size, dtype=np.int64), np.zeros(want.size, dtype=bool)
    at = np.minimum(np.searchsorted(keys, want), keys.size - 1)
    return at, keys[at] == want


def _kept(matrix, rows, keep, offset=0.0):
    """The CSR ``matrix`` with only the entries ``keep`` (``rows`` their rows), its values
    less ``offset``.
    """
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows[keep], minlength=matrix.shape[0]))])
    return sp.csr_matrix((matrix.data[keep] - offset, matrix.indices[keep], indptr), shape=matrix.shape)
