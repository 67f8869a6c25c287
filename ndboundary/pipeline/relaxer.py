"""The relaxation written once for every domain: :class:`Relaxer`.

A :class:`Relaxer` runs the paper's four steps over one domain and keeps what a next
relaxation of that domain can share: the jagged boundary and padded domain of the last
labelling, its heat and field, and the last factorisation of the integration system.
:func:`~ndboundary.pipeline.oneshot.relax` is its one-shot wrapper, which keeps nothing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._arrays import held_bytes
from .._threads import Beside, available_threads
from .._validation import check_labels
from ..domains.base import Domain
from ..solvers import FactorCache
from ..solvers.cache import digest
from ..solvers.common import blas_threads
from .band import (
    AUTO_BAND_MAX_SHARE,
    AUTO_BAND_MIN_VERTICES,
    FILL_BESIDE_MIN_SHARE,
    OutsideFill,
    band_elements,
    band_width,
    growth_rate,
    inner_band,
    inner_phi,
    integration_reach,
)
from .boundary import Boundary, element_boundary, vertex_boundary
from .checks import check_element_shapes
from .field import initial_field
from .heat import diffuse
from .integration import (
    boundary_weight_scale,
    grid_scale_hint,
    integrate,
    integration_terms,
    prepare,
    with_rhs,
    within_slabs,
)
from .padding import pad as pad_domain
from .params import DEFAULT_LAM, DEFAULT_MU, DEFAULT_RTOL, DEFAULT_SMOOTHING, check_params, integration_rtol
from .result import RegionsResult, RelaxResult, keep_band, summed_timings
from . import sectors
from .sectors import region_sectors
from .smoothing import smooth

__all__ = ["Relaxer"]

#: A band of more vertices than this, relaxed by a relaxer that keeps nothing (an image's
#: regions), builds its integration terms after its field, once its own stiffness and
#: adjacency are let go, instead of beside the field: built beside, both were held at
#: once, 13.9 GB for the background of a brain-like atlas (a band of 9.3 M voxels,
#: ``python benchmarks/many_labels.py --layout brain``). Smaller bands gain the overlap.
BESIDE_MAX_VERTICES = 4_000_000


#: A band of more vertices than this relaxes alone when an image's regions relax several at
#: once (:func:`relax_at_once`): the background of a brain-like atlas (a band of 9.3 M
#: voxels) peaks at 10.1 GB on its own, and a second region beside it would add its own.
ALONE_MIN_VERTICES = BESIDE_MAX_VERTICES


class _Lines:
    """Where a relaxation's progress lines go: to stderr, or held until :meth:`release`
    (those of a region whose steps run while the region before it finishes), so that
    every region's lines come out together and in order.
    """

    def __init__(self, held=False):
        self._held = [] if held else None
        self._lock = threading.Lock()  # written on a region's thread, released on another

    def write(self, line):
        with self._lock:
            if self._held is not None:
                self._held.append(line)
                return
        print(line, file=sys.stderr, flush=True)

    def release(self):
        """Print the lines held, and the next ones as they come."""
        with self._lock:
            held, self._held = self._held or [], None
            for line in held:
                print(line, file=sys.stderr, flush=True)


def _say(verbose, name, seconds):
    """A step's progress line, when ``verbose`` (True: to stderr; or a :class:`_Lines`)."""
    if not verbose:
        return
    line = f"[ndboundary] {name:<12s} {seconds:8.3f} s"
    if isinstance(verbose, _Lines):
        verbose.write(line)
    else:
        print(line, file=sys.stderr, flush=True)


class _Progress:
    """Per-step wall times, printed to stderr as each step ends when ``verbose`` (True,
    or a :class:`_Lines`).
    """

    def __init__(self, verbose):
        self.verbose = verbose
        self.times = {}
        self.tick = time.perf_counter()

    def resume(self, paused):
        """Count none of the ``paused`` seconds just spent outside the relaxation."""
        self.tick += paused

    def step(self, name):
        now = time.perf_counter()
        self.times[name] = now - self.tick
        _say(self.verbose, name, self.times[name])
        self.tick = time.perf_counter()


class Relaxer:
    """Relax labellings of one domain, sharing what the relaxations have in common.

    Factor once, solve many: a relaxer keeps the padded domain and its operators, the
    heat and the field of the last labelling, and the last factorisation of the
    integration system (with PARDISO's ordering, which serves every labelling of the
    domain). Another smoothing of the same labels then costs the smoothing and a
    back-substitution; another ``lam`` reuses everything but the factorisation. On the
    band (:mod:`ndboundary.pipeline.band`) it keeps the edge distances the band is found by,
    which serves every labelling of the domain, and the band's own relaxer, which serves
    every labelling with the same band. Memory is bounded to one labelling and one
    factor: :attr:`nbytes` reports it and :meth:`clear` frees it.

    Parameters
    ----------
    domain : Domain
        Any domain (:class:`~ndboundary.SimplicialComplex`, :class:`~ndboundary.PolygonMesh`,
        :class:`~ndboundary.PolyhedralMesh`, :class:`~ndboundary.PointCloud`, or your own
        :class:`~ndboundary.Domain`).

    Examples
    --------
    >>> from ndboundary import Relaxer
    >>> from ndboundary.datasets import kuhn_grid, label_by, flower
    >>> mesh = kuhn_grid(30, 2, jitter=0.25, random_state=0)
    >>> labels = label_by(mesh, flower)
    >>> relaxer = Relaxer(mesh)
    >>> smooth = relaxer.relax(labels, on="elements")
    >>> smoother = relaxer.relax(labels, on="elements", smoothing=200)
    >>> relaxer.nbytes > 0
    True
    >>> relaxer.clear(); relaxer.nbytes
    0
    """

    def __init__(self, domain, *, _keep=True, _h=None, _private=False):
        if not isinstance(domain, Domain):
            raise TypeError(
                f"domain must be an ndboundary domain (e.g. SimplicialComplex), got {type(domain).__name__}"
            )
        self.domain = domain
        self._keep = _keep
        self._factors = FactorCache()
        self._labelling = None  # (key, boundary, padded)
        self._heat = None  # (key, u, heat_info, X)
        self._band = None  # (key, boundary, lam_scale or None, (width, mask, distance from zeta))
        self._band_relaxer = None  # (digest of the band's mask, relaxer of the band, its vertices)
        self._distances = None  # the band's searches along the edges: the same for every labelling
        self._h = _h  # the mesh size of the domain this one is a band of
        self._fill = True  # False: phi outside the band is filled when first read (many regions)
        self._shared = None  # a FactorCache that relaxations of other labellings share (many regions)
        self._sectors = None  # (every element's region, this region): smooth within sectors
        self._vertex_pins = False  # True: zeta's vertices pinned on image grids too (many regions)
        self._zeta = None  # zeta's vertices, found with every other region's (many regions)
        self._element_ids = None  # a band's elements' indices in the domain it was cut from
        self._all_reached = False  # True: zeta reaches every connected part of the domain (a band)
        # on the band of an image grid: (its vertices' graph distance from zeta, inf beyond
        # the band's width, and the integration's reach), both in units of h: the far
        # field's direction (field.initial_field) and the integration's inner band
        # (band.inner_band). Meshes and graphs search the far field's distances again
        # (along the band's edges) and integrate their whole band.
        self._reach = None
        # the domain is this relaxation's own (a band it cut): what the result does not read
        # is dropped from it once used, so that the integration and the level set, the
        # largest steps, run beside less memory (read again, it is built again)
        self._private = _private

    @property
    def nbytes(self) -> int:
        """Memory held for the next relaxation: padded operators, heat, field and factor (bytes)."""
        held = held_bytes([self._labelling, self._heat, self._distances], {id(self.domain)}) + self._factors.nbytes
        if self._band is not None:
            held += held_bytes([self._band[1], self._band[3]], set())
        if self._band_relaxer is not None:
            sub = self._band_relaxer[1]
            held += sub.nbytes + held_bytes(sub.domain, set())
        return int(held)

    def clear(self):
        """Free everything kept for the next relaxation (the domain's own operators stay)."""
        self._labelling = self._heat = self._band = self._band_relaxer = self._distances = None
        self._factors.clear()

    def relax(
        self,
        labels,
        *,
        on,
        lam=DEFAULT_LAM,
        smoothing=DEFAULT_SMOOTHING,
        mu=DEFAULT_MU,
        t=None,
        form="mass",
        pad=True,
        rtol=DEFAULT_RTOL,
        solver="auto",
        band="auto",
        verbose=False,
    ):
        """Relax the jagged boundary of ``labels`` into the level set ``phi = 1/2``.

        Takes the parameters of :func:`relax` (without ``domain``) and returns the same
        :class:`~ndboundary.RelaxResult`.
        """
        return _run(
            self._relax_steps(
                labels, on=on, lam=lam, smoothing=smoothing, mu=mu, t=t, form=form, pad=pad, rtol=rtol,
                solver=solver, band=band, verbose=verbose,
            )
        )  # fmt: skip

    def _relax_steps(self, labels, *, on, lam, smoothing, mu, t, form, pad, rtol, solver, band, verbose, clock=None):
        """:meth:`relax` as a generator whose value is the result. It pauses (yields) once,
        when the integration waits only for its factor, built beside: a relaxation of many
        regions goes on meanwhile with the next region's steps (:meth:`_relax_regions`).
        The seconds it stays paused are added to ``clock[0]`` and counted in no timing.
        """
        clock = [0.0] if clock is None else clock
        paused = clock[0]
        p = check_params(
            on=on, lam=lam, smoothing=smoothing, mu=mu, t=t, form=form, rtol=rtol, solver=solver, band=band
        )
        domain = self.domain
        n_expected = domain.n_elements if on == "elements" else domain.n_vertices
        classes, region1 = check_labels(labels, n_expected, what=on[:-1], many=True)
        if classes.size > 2:
            return self._relax_regions(classes, region1, p, pad, verbose)
        prog = _Progress(verbose)
        t0 = prog.tick
        h = domain.mean_edge_length() if self._h is None else self._h  # a linear pass over the edges

        # what is kept for the next call is found again by the labels' digest (a pass over
        # the domain, which a relaxer that keeps nothing does not need)
        kept = self._keep or self._labelling is not None or self._band is not None
        key = _labels_key(region1, on, bool(pad)) if kept else None
        auto = p["band"] == "auto"
        zeta = None
        if p["band"] is not None and not (
            auto and (band_width(p, domain) is None or domain.n_vertices < AUTO_BAND_MIN_VERTICES)
        ):
            result = yield from self._relax_band(key, region1, classes, h, p, pad, verbose, t0, clock)
            if not isinstance(result, Boundary):
                result.timings["total"] = time.perf_counter() - t0 - (clock[0] - paused)
                return result
            zeta = result  # the band would hold (nearly) everything: the whole domain, with its zeta
        boundary, padded = self._padded(key, region1, on, bool(pad), zeta)
        prog.step("pad")
        # step 4's matrix and preconditioner do not depend on the field: built meanwhile,
        # with BLAS limited to one thread on this thread around both (the solves and the
        # preconditioner's build limit it too, and OpenBLAS lifts a limit only on the
        # thread that set it: the limit opened first must close last, here)
        # a large band's terms, on the inner band, come after its field (BESIDE_MAX_VERTICES)
        later = not self._keep and self._reach is not None and padded.work.n_vertices > BESIDE_MAX_VERTICES
        with blas_threads(1), Beside(self._integration_terms, padded, boundary.sources, h, p, defer=later) as terms:
            u, heat_info, X = self._field(key, boundary, padded, region1, p["t"] * h * h, p["rtol"], prog)
            groups = None
            if self._sectors is not None:
                # on the padded domain, whose adjacency the smoothing reads: one a region
                codes, region = self._sectors
                groups = region_sectors(padded.work, codes[padded.parent], region)
            Xs = smooth(padded.work, X, p["smoothing"], groups)
            groups = None
            if later:
                _forget(padded.work, ("K", "adjacency"))
            prog.step("smoothing")
            start = time.perf_counter()
            yield  # the factor may still be built beside: the caller can go on meanwhile
            prog.resume(time.perf_counter() - start)
            clock[0] += time.perf_counter() - start
            system, preconditioner, on_band, inner, kept, constraints = terms.result()
        work = padded.work
        system = with_rhs(system, on_band, Xs if inner is None else Xs[inner], h, constraints)
        rows = (constraints.S, constraints.targets, constraints.slabs)  # the pins, for within_slabs
        terms = on_band = constraints = None
        if not self._keep:
            # the padded operators are not needed by the solve: free them before it
            self.clear()
            padded = None
            if self._private:
                _forget(domain, ("adjacency", "edges", "edge_lengths", "_faces", "_face_ids"))
        # the first-order form (the classifier's) solves to the heat's rtol
        rtol = p["rtol"] if p["form"] == "gradient" else integration_rtol(p["rtol"])
        phi, int_info = integrate(
            system, rtol=rtol, solver=p["solver"], cache=self._cache, preconditioner=preconditioner
        )
        phi, again, lifted = within_slabs(
            system, *rows, phi, rtol=rtol, solver=p["solver"], cache=self._cache, preconditioner=preconditioner
        )
        if again is not None:  # the second solve's time and iterations added to the first's
            int_info = dataclasses.replace(
                int_info,
                iterations=int_info.iterations + again.iterations,
                residual=int_info.residual if np.isnan(again.residual) else again.residual,
                solve_time=int_info.solve_time + again.setup_time + again.solve_time,
            )
        lam_scale, system, rows = system.lam_scale, None, None
        if inner is not None:
            side = region1 if p["on"] == "vertices" else domain.vertices_of(region1)
            phi = inner_phi(work, phi, kept, self._reach[0], side, self._reach[1])
        prog.step("integration")
        if self._private and not self._keep:
            _forget(domain, ("K",))

        timings = dict(prog.times)
        timings["total"] = time.perf_counter() - t0 - (clock[0] - paused)
        _say(verbose, "total", timings["total"])
        V = domain.n_vertices
        params = {k: p[k] for k in ("lam", "smoothing", "mu", "t", "form", "on")}
        params.update(lam_scale=lam_scale, pad=bool(pad), h=h, lifted_pins=lifted)
        return RelaxResult(
            phi=phi[:V].copy(),
            u=u[:V].copy(),
            field=X,
            smoothed_field=Xs,
            boundary=boundary,
            classes=classes,
            domain=domain,
            timings=timings,
            solver={"heat": heat_info, "integration": int_info},
            params=params,
        )

    def _relax_regions(self, classes, codes, p, pad, verbose):
        """Every region relaxed against the rest, on the operators the domain caches."""
        t0 = time.perf_counter()
        h = self.domain.mean_edge_length() if self._h is None else self._h
        params = {k: p[k] for k in ("on", "lam", "smoothing", "mu", "t", "form", "rtol", "solver", "band")}
        # the squared operator and PARDISO's ordering serve every region; each factor its own
        shared = self._factors if self._keep else FactorCache(keep_factor=False)
        # every region's zeta in one pass over the domain, where each alone would take one
        zetas = self.domain.code_boundaries(codes, classes.size) if p["on"] == "elements" else None
        previous = self  # the last region's relaxer, whose band searches serve the next one

        def region(r, lines):
            nonlocal previous
            relaxer = Relaxer(self.domain, _keep=False, _h=h)
            relaxer._distances = previous._distances  # the band's searches serve every region
            relaxer._fill = False  # the partition needs no fill: RegionsResult fills phi when read
            relaxer._shared = shared
            relaxer._vertex_pins = True
            relaxer._zeta = None if zetas is None else zetas[r]
            if p["on"] == "elements" and sectors.SECTOR_SMOOTHING:
                relaxer._sectors = (codes, r)
            previous = relaxer
            return relaxer._relax_steps(codes == r, pad=pad, verbose=lines, **params)

        results = relax_in_turn(classes.size, region, verbose)
        if self._keep:
            self._distances = previous._distances
        timings = summed_timings(results)
        timings["total"] = time.perf_counter() - t0
        params.update(pad=bool(pad), h=h)
        return RegionsResult(classes, self.domain, results, timings, params, codes=codes)

    def _relax_band(self, key, region1, classes, h, p, pad, verbose, start, clock):
        """Relax on the elements near zeta and extend phi outside them; zeta alone (a
        :class:`~ndboundary.pipeline.boundary.Boundary`, for the whole-domain relaxation)
        when the band holds every element (the whole-domain relaxation is then the same)
        or, for ``band="auto"``, most of them (the whole domain then costs no more).

        The edge distances serve every labelling, the band's relaxer (operators, orderings,
        factor) every labelling with the same band. "locate" counts from ``start``. A generator,
        as :meth:`_relax_steps`: it pauses where the band's relaxation does.
        """
        domain, on = self.domain, p["on"]
        tick = start  # locating zeta and the band includes the mesh size h
        padding = 0.0
        if self._distances is None or self._distances[0] != h:
            self._distances = (h, domain.edge_distances(h))
        distances = self._distances[1]
        if self._band is not None and self._band[0] == key:
            boundary, scale, cached = self._band[1:]
        else:
            self._band = None
            boundary = self._boundary(region1, on)
            if boundary.sources.size == 0:
                raise ValueError("the two regions never meet: labels form no boundary on this domain")
            scale = cached = None

        def band_of(width):
            if cached is not None and cached[0] == width:
                return cached[1:]
            return band_elements(domain, boundary.sources, width, distances)

        def relaxer_of(mask):
            """``(digest of mask, the band's relaxer, its vertices)``, the last one's if the same."""
            mask_key = digest("band", mask) if self._keep or self._band_relaxer is not None else None
            if self._band_relaxer is not None and self._band_relaxer[0] == mask_key:
                return self._band_relaxer
            sub, vertices = domain.subdomain(mask)
            relaxer = Relaxer(sub, _keep=self._keep, _h=h, _private=not self._keep)
            relaxer._element_ids = np.flatnonzero(mask)  # what its warnings name
            # every element of a band lies within its width of zeta along edges of the band
            relaxer._all_reached = True
            return mask_key, relaxer, vertices

        def labels_of(mask, vertices):
            return region1[mask] if on == "elements" else region1[vertices]

        width = p["band"]
        if width == "auto":
            # the narrowest band auto can choose first: when it already holds most of the
            # domain, the whole domain costs no more
            width = band_width(p, domain)
            if boundary.sources.size * 2 * width > AUTO_BAND_MAX_SHARE * domain.n_vertices:
                # zeta's vertices times the band's thickness in layers (at least one layer
                # per h) already exceed the share: no need to search the band
                return boundary
            mask, dist = band_of(width)
            if _share(mask) > AUTO_BAND_MAX_SHARE:
                return boundary
            hint = grid_scale_hint(domain, h) if scale is None else None
            likely = width if hint is None else band_width(p, domain, hint)
            # an image grid's scale is known closely without a padding: when the band it
            # widens to holds most of the domain, relax the whole domain (the exact solve
            # the band stands for) instead of padding a band only to read its scale
            if likely > width and _share(band_of(likely)[0]) > AUTO_BAND_MAX_SHARE:
                return boundary
            band = relaxer_of(mask)
            if scale is None:
                # read on the band's padding, which its relaxation then uses: the band holds
                # the two rings of elements around zeta that the scale depends on
                padding = time.perf_counter()  # timed as the band's padding, not as locating it
                scale = band[1]._lam_scale(labels_of(mask, band[2]), on, pad, h)
                padding = time.perf_counter() - padding
                tick += padding
            wider = band_width(p, domain, scale)
            if wider > width:
                width = wider
                mask, dist = band_of(width)
                if _share(mask) > AUTO_BAND_MAX_SHARE:
                    return boundary
                band = relaxer_of(mask)
        else:
            mask, dist = band_of(width)
            if mask.all():
                return boundary
            band = relaxer_of(mask)
        _, relaxer, vertices = band
        relaxer._band_of_width(domain, width, dist[vertices])
        self._band_relaxer = band if self._keep else None
        self._band = (key, boundary, scale, (width, mask, dist)) if self._keep else None
        locate = time.perf_counter() - tick
        _say(verbose, "locate", locate)
        sub_labels = labels_of(mask, vertices)
        relaxer._sectors = None if self._sectors is None else (self._sectors[0][mask], self._sectors[1])
        relaxer._vertex_pins = self._vertex_pins
        # every element at a vertex of zeta lies in the band: its zeta is the parent's, renumbered
        relaxer._zeta = np.searchsorted(vertices, boundary.sources) if on == "elements" else None
        elements = relaxer._element_ids
        params = {k: p[k] for k in ("lam", "smoothing", "mu", "t", "form", "rtol", "solver")}

        def outside():
            """The fill's walk and every vertex's side: they depend on the band alone. A
            deferred fill is handed the side as a function of the region's members, so
            that many regions do not each hold a mask over the whole domain.
            """
            if not self._fill:
                return None, functools.partial(_vertex_side, domain, on, np.flatnonzero(region1))
            side = region1 if on == "vertices" else domain.vertices_of(region1)
            return OutsideFill(domain, elements, vertices, distances).prepare(), side

        with ThreadPoolExecutor(1) as pool:
            # on the second core while the band is relaxed, if the band is large enough to hide it
            beside = vertices.size >= FILL_BESIDE_MIN_SHARE * domain.n_vertices
            prepared = pool.submit(outside) if beside else None
            res = yield from relaxer._relax_steps(
                sub_labels, on=on, pad=pad, verbose=verbose, band=None, clock=clock, **params
            )
            tick = time.perf_counter()
            fill, side = prepared.result() if beside else outside()
        rate = growth_rate(res.phi, dist[vertices], width)
        if fill is not None:
            res.phi = fill(res.phi, side, rate)
            u = np.zeros(domain.n_vertices)
            u[vertices] = res.u
            res.u = u
        else:
            # one region among many: what covers the whole domain is built when read, and
            # the fields on its band are not kept (see RegionsResult.regions)
            keep_band(res, elements, vertices, side, distances, rate)
        res.boundary, res.classes, res.domain = boundary, classes, domain
        fill = time.perf_counter() - tick
        _say(verbose, "fill", fill)
        res.timings = {"locate": locate, **res.timings, "fill": fill}
        res.timings["pad"] += padding
        res.params.update(band=width, band_vertices=int(vertices.size))
        return res

    def _band_of_width(self, parent, width, distance):
        """Relax as the band of ``width`` around zeta, cut from ``parent``, that this
        relaxer's domain is, its vertices ``distance`` from zeta (units of ``h``, ``inf``
        beyond the width): set ``_reach`` where ``parent`` integrates an inner band only
        (:func:`~ndboundary.pipeline.band.integration_reach`).
        """
        reach = integration_reach(parent, width)
        self._reach = None if reach is None else (distance, reach)

    @property
    def _cache(self):
        """Where the integration keeps its factor or hierarchy for the next solve."""
        return self._factors if self._keep else self._shared

    def _integration_terms(self, padded, sources, h, p):
        """Step 4's terms (:func:`~ndboundary.pipeline.integration.integration_terms`) and
        preconditioner, neither of which the field enters: on the padded domain, or on the
        inner band of an image's band (``_reach``). Returns ``(system, preconditioner,
        domain, inner, kept, constraints)``: ``system`` lives on ``domain``, the inner
        band's ``kept`` vertices of the padded domain (``inner`` its mask; both None for
        the whole padded domain), with zeta's rows ``constraints``.
        """
        work = padded.work
        kept = None
        inner = None if self._reach is None else inner_band(work, *self._reach)
        if inner is None:
            on, constraints = work, padded
        else:
            on, kept = work.subdomain(inner)
            constraints, sources = _cut_rows(padded, sources, kept, work.n_vertices)
        system = integration_terms(on, h, constraints, sources, lam=p["lam"], mu=p["mu"], form=p["form"])
        # on a thread of its own beside the field's steps (Beside), when there are two
        pre = prepare(system, solver=p["solver"], cache=self._cache, concurrent=available_threads() > 1)
        return system, pre, on, inner, kept, constraints

    def _lam_scale(self, region1, on, pad, h):
        """``lam_scale`` of the labelling (:func:`boundary_weight_scale`) on this domain (a
        band), from its padding, which is kept for the relaxation that follows.
        """
        boundary, padded = self._padded(_labels_key(region1, on, bool(pad)), region1, on, bool(pad), keep=True)
        return boundary_weight_scale(padded.work, h, boundary.sources)

    def _padded(self, key, region1, on, pad, boundary=None, keep=False):
        """Zeta (``boundary`` when already found) and the padded domain of a labelling, kept
        for the next call (by a relaxer that keeps what it computes, or when ``keep``).
        """
        if self._labelling is not None and self._labelling[0] == key:
            return self._labelling[1:]
        self._labelling = self._heat = None
        domain = self.domain
        if boundary is None:
            boundary = self._boundary(region1, on)
        if boundary.sources.size == 0:
            raise ValueError("the two regions never meet: labels form no boundary on this domain")
        check_element_shapes(domain, element_ids=self._element_ids)
        padded = pad_domain(
            domain, region1, boundary, on, pad, vertex_pins=self._vertex_pins, all_reached=self._all_reached
        )
        _ = padded.work.K, padded.work.mass  # assembled (and timed) with the padding
        if self._keep or keep:
            self._labelling = (key, boundary, padded)
        return boundary, padded

    def _boundary(self, region1, on):
        """Zeta of the labelling ``region1`` on this relaxer's domain (its vertices found
        already when ``_zeta`` holds them).
        """
        if on == "elements":
            return element_boundary(self.domain, region1, self._zeta)
        return vertex_boundary(self.domain, region1)

    def _field(self, key, boundary, padded, region1, t, rtol, prog):
        """Steps 1 and 2 (heat and field), kept for the next call with the same labels."""
        if self._heat is not None and self._heat[0] == (key, t, rtol):
            prog.step("heat")
            prog.step("field")
            return self._heat[1:]
        u, heat_info = diffuse(padded.work, boundary.sources, t, rtol)
        prog.step("heat")
        distance = None if self._reach is None else self._reach[0]
        X = initial_field(self.domain, padded, region1, boundary.sources, u, rtol, distance)
        prog.step("field")
        if self._keep:
            self._heat = ((key, t, rtol), u, heat_info, X)
        return u, heat_info, X


def relax_in_turn(count, start, verbose, overlap=True):
    """The results of ``count`` relaxations, in order: ``start(i, lines)`` returns the
    steps of the i-th (a generator, as :meth:`Relaxer._relax_steps`, given ``lines`` as
    its ``verbose``). With ``overlap``, each runs up to its pause, while the factor of the
    one before it is still built beside; then that one is finished, its factor built
    meanwhile. The progress lines of each are held until the one before it has printed its
    own. When one raises, the one paused is closed, which stops its factor's thread.
    Without ``overlap``, each runs to its end before the next starts.
    """
    if not overlap:
        return [_run(start(i, verbose)) for i in range(count)]
    results, waiting = [], None
    try:
        for i in range(count):
            lines = _Lines(held=waiting is not None) if verbose else False
            steps = start(i, lines)
            ready = _advance(steps)
            last, waiting = waiting, (steps if ready is steps else None)
            if last is not None:
                results.append(_run(last))
            if lines:
                lines.release()
            if waiting is None:
                results.append(ready)
        if waiting is not None:
            last, waiting = waiting, None
            results.append(_run(last))
    finally:
        if waiting is not None:
            waiting.close()
    return results


def relax_at_once(count, start, verbose, threads=None, order=None):
    """The results of ``count`` relaxations, in order, run ``threads`` at a time
    (:func:`~ndboundary._threads.available_threads` by default), each on a thread of its
    own: ``start(i, lines, gate)`` returns the steps of the i-th (a generator, as
    :meth:`Relaxer._relax_steps`), which run within ``gate.held(n_vertices)`` once their
    band is known (:class:`_Gate`: a band of more than :data:`ALONE_MIN_VERTICES`
    vertices relaxes alone). They start in ``order`` (by index by default): the largest
    first, the threads end together. The progress lines of each are held until the one
    before it has printed its own.

    The relaxations share nothing they write, and each gives the same functions, to the
    bit, as relaxed one after another. Their solves spend most of their time in sparse
    products, sweeps and compiled passes that hold no GIL, on one core each: two at once
    relaxed the 16 regions of a 192^3 Voronoi partition in three quarters of the time
    (``benchmarks/images_speed.py 192 --regions 16``).
    """
    threads = available_threads() if threads is None else threads
    gate = _Gate(threads)
    if threads < 2 or count < 2:
        return [_run(start(i, verbose, gate)) for i in range(count)]
    lines = [_Lines(held=i > 0) if verbose else False for i in range(count)]
    pool = ThreadPoolExecutor(min(threads, count), thread_name_prefix="ndboundary-relax")
    # every thread's BLAS limited from this one, which waits for them all (blas_threads)
    with blas_threads(1):
        futures = [None] * count
        for i in range(count) if order is None else order:
            futures[i] = pool.submit(lambda i: _run(start(i, lines[i], gate)), i)
        try:
            results = []
            for i, future in enumerate(futures):
                results.append(future.result())
                if verbose and i + 1 < count:
                    lines[i + 1].release()
        finally:  # after an error, the regions not started are dropped and those under way end
            pool.shutdown(cancel_futures=True)
    return results


class _Gate:
    """Admits up to ``threads`` relaxations at once, one whose band holds more than
    :data:`ALONE_MIN_VERTICES` vertices alone.
    """

    def __init__(self, threads):
        self._threads = max(1, threads)
        self._running = 0
        self._turn = threading.Condition()

    @contextlib.contextmanager
    def held(self, n_vertices):
        """Wait until a band of ``n_vertices`` may relax beside those running, and count it
        among them until the block ends.
        """
        weight = self._threads if n_vertices > ALONE_MIN_VERTICES else 1
        with self._turn:
            self._turn.wait_for(lambda: self._running + weight <= self._threads)
            self._running += weight
        try:
            yield
        finally:
            with self._turn:
                self._running -= weight
                self._turn.notify_all()


def _advance(steps):
    """Run a relaxation's steps (:meth:`Relaxer._relax_steps`) to their pause: ``steps``
    when they paused, their result when they ended without one. Steps that raise are closed.
    """
    try:
        next(steps)
    except StopIteration as done:
        return done.value
    except BaseException:
        steps.close()
        raise
    return steps


def _run(steps):
    """Run a relaxation's steps (:meth:`Relaxer._relax_steps`) to their end: their result."""
    while True:
        out = _advance(steps)
        if out is not steps:
            return out


def _cut_rows(padded, sources, kept, n):
    """The padding's constraint rows and zeta's sources over the vertices ``kept`` (of
    ``n``) of the inner band: ``(padded, sources)`` for its integration. Rows that reach
    beyond it (the pins of parts of the band that zeta does not reach) are dropped.
    """
    local = np.full(n, -1, dtype=np.int64)
    local[kept] = np.arange(kept.size)
    S = padded.S.tocsr()
    cut = S[:, kept].tocsr()
    whole = np.diff(cut.indptr) == np.diff(S.indptr)
    sources = local[sources]
    slabs = None
    if padded.slabs is not None:  # the pixels' corners in the inner band's numbering, -1 where it has none
        inside, outside, lift = (a[whole] for a in padded.slabs)
        slabs = (np.where(inside < 0, -1, local[inside]), np.where(outside < 0, -1, local[outside]), lift)
    return dataclasses.replace(padded, S=cut[whole], targets=padded.targets[whole], slabs=slabs), sources[sources >= 0]


def _forget(domain, names):
    """Drop the cached properties ``names`` of ``domain`` (built again when read)."""
    for name in names:
        domain.__dict__.pop(name, None)


def _labels_key(region1, on, pad):
    h = hashlib.blake2b(digest_size=16)
    h.update(repr((on, pad, region1.shape)).encode())
    h.update(np.ascontiguousarray(region1, dtype=bool).view(np.uint8))
    return h.hexdigest()


def _vertex_side(domain, on, members):
    """The vertices on a region's side, from its elements (or vertices) ``members``."""
    mask = np.zeros(domain.n_elements if on == "elements" else domain.n_vertices, dtype=bool)
    mask[members] = True
    return domain.vertices_of(mask) if on == "elements" else mask


def _share(mask):
    """The share of ``mask`` that is set (a count, where ``mask.mean()`` converts every
    entry of a mask over the whole domain to a float).
    """
    return np.count_nonzero(mask) / max(mask.size, 1)
