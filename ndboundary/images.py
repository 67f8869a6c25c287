"""Relax a label image or volume directly: :func:`relax_image`."""

from __future__ import annotations

import contextlib
import functools
import sys
import threading
import time

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from ._validation import check_labels
from .domains.image import GridBand, ImageGrid, grid_direction, grid_geometry, grid_usual_degree
from .pipeline import relax, sectors
from .pipeline.band import AUTO_BAND_MAX_SHARE, AUTO_BAND_MIN_VERTICES, band_width, growth_rate
from .pipeline.boundary import Boundary, element_boundary, zeta_facets
from .pipeline.grid_band import corners_of, grid_mean_edge_length, image_band, region_band
from .pipeline.integration import grid_scale_hint
from .pipeline.params import DEFAULT_LAM, DEFAULT_MU, DEFAULT_RTOL, DEFAULT_SMOOTHING, check_params
from .pipeline.relaxer import Relaxer, relax_at_once, relax_in_turn
from .pipeline.result import RegionsResult, fit_two_regions, keep_band, summed_timings
from .pipeline import surface_fit
from .solvers import FactorCache

__all__ = ["REACH_SCALE", "relax_image"]

#: The boundary weight's scale (:func:`~ndboundary.pipeline.integration.boundary_weight_scale`)
#: of the meshes on which the quads' and hexahedra's ``band_reach`` was measured, by number
#: of axes (``quads-80`` and ``hex-40`` of ``benchmarks/band.py``, the width forced): an
#: image's band (of the grid's reach, :data:`~ndboundary.domains.image.GRID_BAND_REACH`)
#: widens only for a scale below the one its reach already holds. The grid's own scale
#: (0.43 on isotropic voxels) would widen it to 19 h, as ``relax`` widens the band of an
#: :class:`~ndboundary.ImageGrid`, at about twice the cost.
REACH_SCALE = {2: 0.94, 3: 0.48}


def relax_image(labels, *, spacing=None, origin=None, direction=None, background=None, pad=False, fit="auto", **params):
    """Relax the staircase boundaries of a 2-D label image or 3-D label volume.

    Parameters
    ----------
    labels : array_like of shape (n0, n1) or (n0, n1, n2)
        One label per pixel or voxel, any number of distinct labels (integers, booleans
        or strings). Not modified.
    spacing : float or sequence of float, optional
        The distance between pixel centres along each axis (default 1).
    origin : float or sequence of float, optional
        The centre of the first pixel (default 0): pixel ``index`` is centred at
        ``origin + index * spacing``, the NIfTI / ITK and scikit-image convention.
    direction : array_like of shape (dim, dim), optional
        The axes of an oblique scan (see :class:`~ndboundary.ImageGrid`): the outputs are
        then in its world coordinates.
    background : label, optional
        A label that is one more region of the partition (every pixel belongs to a
        region) but whose own boundary is not wanted: recorded as
        ``result.params["background"]`` (its index among ``result.classes``) for the
        writers and the command line, which then leave it out.
    pad : bool, default=False
        Whether to split the pixels all of whose corners lie on the staircase into
        pyramids (:func:`~ndboundary.relax`'s padding). By default they keep their shape
        and take their neighbours' field
        (:func:`~ndboundary.pipeline.field.fill_flat`): on a grid they are few and
        scattered, the relaxed boundaries are the same to within a hundredth of a pixel
        (``benchmarks/images.py``), and splitting them would turn the grid's uniform
        voxels into a general polyhedral mesh that is rebuilt whole.
    fit : {"auto", True, False}, default="auto"
        Whether the relaxed boundary of two labels is moved to the smoothest one that
        parts the pixel centres with the largest margins (least change of curvature;
        :func:`~ndboundary.pipeline.result.fit_two_regions` in 2-D,
        :func:`~ndboundary.pipeline.surface_fit.fit_surface` in 3-D, keeping the
        relaxed volume): nearer the truth where the staircase leaves the boundary a gap
        to stray in. The fit is written into ``phi`` within a few pixels of the boundary,
        so that its other level sets there are no longer the relaxation's. ``"auto"``
        fits every curve, and a surface of up to
        :data:`~ndboundary.pipeline.surface_fit.AUTO_MAX_VERTICES` vertices (its
        Cholesky factors grow faster than it, and on a large surface the fit takes longer
        than the relaxation). A boundary with a corner (a box's) is left as relaxed.
        Three labels or more: see :func:`~ndboundary.relax` (interfaces in the plane
        are fitted, volumes' are not).
    **params
        Passed to :func:`~ndboundary.relax` (``lam``, ``smoothing``, ``band``, ...).

    Returns
    -------
    RelaxResult or RegionsResult
        Its ``level_set()``, ``interfaces()``, ``region_boundary(r)`` and
        ``region_measures()`` are in physical coordinates. ``result.domain`` (which
        ``phi`` lives on) is the image's :class:`~ndboundary.ImageGrid`, or, when the
        band of ``band`` holds a small part of a large image, that band
        (:class:`~ndboundary.domains.image.GridBand`; ``result.domain.pixels`` names its
        pixels): the whole grid is then never built, and the cost follows the boundaries.
        The band is found on the image's index grid, as the whole grid's would be
        (:mod:`ndboundary.pipeline.grid_band`; ``result.timings["image band"]``: finding
        it and building its mesh); with ``band="auto"`` it is the domain's
        ``band_reach`` (12 h), widened for a weaker boundary term, fewer smoothing
        passes, or a grid whose boundary weight
        (:func:`~ndboundary.pipeline.integration.grid_scale_hint`) is below that of the
        meshes the reach was measured on (:data:`REACH_SCALE`). The regions' measures
        count the pixels outside the band whole. With three labels or more, each region
        relaxes on its own band of that width, cut from a box around it (no region reads
        the whole image, so that hundreds of labels cost what their bands cost), as
        :func:`~ndboundary.relax` would relax it on the grid with ``band=width``; in 3-D
        the regions relax several at a time, one on each core
        (:func:`~ndboundary.pipeline.relaxer.relax_at_once`), to the same functions.

    Raises
    ------
    ValueError
        On an image that is not 2-D or 3-D, a bad spacing or origin, a background that is
        not one of the labels, or labels ``relax`` refuses (one class, NaN).

    Examples
    --------
    A disc of radius 6 pixels on a 24 x 24 image, with pixels 0.5 mm apart:

    >>> import numpy as np
    >>> from ndboundary import relax_image
    >>> i, j = np.indices((24, 24))
    >>> disc = (i - 11.5) ** 2 + (j - 11.5) ** 2 < 36
    >>> result = relax_image(disc, spacing=0.5)
    >>> curve = result.level_set()
    >>> curve.n_components(), round(curve.measure() / (2 * np.pi * 3.0), 2)
    (1, 0.98)
    """
    labels = np.asarray(labels)
    if labels.ndim not in (2, 3):
        raise ValueError(f"labels must be a 2-D image or a 3-D volume, got shape {labels.shape}")
    fit = bool(fit) if isinstance(fit, np.bool_) else fit
    if not (isinstance(fit, bool) or (isinstance(fit, str) and fit == "auto")):
        raise ValueError(f"fit must be 'auto', True or False, got {fit!r}")
    geometry = grid_geometry(labels.shape, 1.0 if spacing is None else spacing, 0.0 if origin is None else origin)
    direction = grid_direction(direction, labels.ndim)
    flat = labels.reshape(-1)
    start = time.perf_counter()
    classes, codes = check_labels(flat, flat.size, what="pixel", many=True)
    pixels, h, width, distance = _band_pixels(codes.reshape(labels.shape), geometry, direction, params)
    if width is not None and classes.size > 2:
        locate = time.perf_counter() - start
        if params.get("verbose"):
            print(f"[ndboundary] {'image band':<12s} {locate:8.3f} s", file=sys.stderr, flush=True)
        result = _relax_regions(
            codes.reshape(labels.shape), classes, geometry, direction, pixels, h, width, pad, params
        )
        result.timings = {"image band": locate, **result.timings, "total": time.perf_counter() - start}
    elif pixels is None:
        grid = ImageGrid(labels.shape, spacing=geometry[1], origin=geometry[2], direction=direction)
        result = relax(grid, flat, on="elements", pad=pad, **params)
    else:
        domain = _image_band(labels.shape, geometry, direction, pixels, codes, classes)
        locate = time.perf_counter() - start
        if params.get("verbose"):
            print(f"[ndboundary] {'image band':<12s} {locate:8.3f} s", file=sys.stderr, flush=True)
        relaxer = Relaxer(domain, _keep=False, _h=h, _private=True)
        relaxer._band_of_width(domain, width, distance)
        result = relaxer.relax(flat[pixels], on="elements", pad=pad, **{**params, "band": None})
        result.params.update(band=width, band_vertices=int(domain.n_vertices))
        result.timings = {"image band": locate, **result.timings, "total": result.timings["total"] + locate}
    if classes.size == 2 and fit is not False:
        _fit_boundary(result, codes if pixels is None else codes[pixels], labels.ndim, fit, params.get("verbose"))
    if background is not None:
        where = np.flatnonzero(result.classes == background)
        if where.size != 1:
            raise ValueError(f"background {background!r} is not one of the labels {result.classes.tolist()}")
        result.params["background"] = int(where[0])
    return result


def _fit_boundary(result, codes, dim, fit, verbose):
    """Fit the relaxed boundary of a two-region image to its pixels (``codes``, each
    pixel's region): a curve (:func:`~ndboundary.pipeline.result.fit_two_regions`) or a
    surface (:func:`~ndboundary.pipeline.surface_fit.fit_surface`, of any size with
    ``fit=True``).
    """
    start = time.perf_counter()
    if dim == 2:
        fitted = fit_two_regions(result, codes)
    else:
        fitted = surface_fit.fit_surface(result, codes, None if fit is True else surface_fit.AUTO_MAX_VERTICES)
    if fitted:
        seconds = time.perf_counter() - start
        result.timings["fit"] = seconds
        result.timings["total"] += seconds
        if verbose:
            print(f"[ndboundary] {'fit':<12s} {seconds:8.3f} s", file=sys.stderr, flush=True)


def _image_band(shape, geometry, direction, pixels, codes, classes):
    """The :class:`GridBand` of ``pixels``, with the measure of each class among the pixels
    it leaves out (``codes``: every pixel's class, flat).
    """
    domain = GridBand(shape, pixels, spacing=geometry[1], origin=geometry[2], direction=direction)
    domain.usual_degree = grid_usual_degree(shape)
    rest = np.ones(codes.size, dtype=bool)
    rest[pixels] = False
    counts = np.bincount(codes[rest].astype(np.intp), minlength=classes.size)
    domain.outside = dict(zip(classes.tolist(), (counts * float(np.prod(geometry[1]))).tolist(), strict=True))
    return domain


#: The relaxation's parameters that :func:`relax_image` reads, with their defaults.
_SOLVE_DEFAULTS = {
    "lam": DEFAULT_LAM,
    "smoothing": DEFAULT_SMOOTHING,
    "mu": DEFAULT_MU,
    "form": "mass",
    "rtol": DEFAULT_RTOL,
    "solver": "auto",
}


def _checked(params, band):
    """The relaxation's parameters in ``params`` (the defaults for those not given),
    checked (:func:`~ndboundary.pipeline.params.check_params`), with ``band``.
    """
    return check_params(
        on="elements", t=params.get("t"), band=band, **{k: params.get(k, d) for k, d in _SOLVE_DEFAULTS.items()}
    )


def _relax_regions(codes, classes, geometry, direction, pixels, h, width, pad, params):
    """Relax every region of a label image against the rest, each on its own band.

    Region ``r``'s band is the pixels within ``width`` of its zeta, found in a box around
    the region (:func:`~ndboundary.pipeline.grid_band.region_band`) and built as a
    :class:`GridBand` of its own: no region reads the whole image, so that hundreds of
    regions cost what their bands cost. The bands and their relaxations are those that
    :func:`~ndboundary.relax` cuts from the whole grid with ``band=width``, and the result
    lives on the whole grid (``pixels`` None) or on the band of every region (``pixels``),
    as :func:`~ndboundary.relax` returns it there.

    Parameters
    ----------
    codes : ndarray of int, the image's shape
        Every pixel's region (an index into ``classes``).
    pixels : ndarray of int64 or None
    """
    shape, spacing, origin = geometry
    t0 = time.perf_counter()
    unknown = set(params) - set(_SOLVE_DEFAULTS) - {"t", "band", "verbose", "on"}
    if unknown:
        raise TypeError(f"relax_image got unexpected keyword arguments {sorted(unknown)}")
    if params.get("on", "elements") != "elements":
        raise ValueError(f"relax_image labels pixels: on must be 'elements', got {params['on']!r}")
    verbose = params.get("verbose", False)
    p = _checked(params, width)
    if pixels is None:
        domain = ImageGrid(shape, spacing=spacing, origin=origin, direction=direction)
    else:
        domain = _image_band(shape, geometry, direction, pixels, codes.reshape(-1), classes)
    reach = [int(np.ceil(width * h / s)) + 1 for s in spacing]  # the band's reach in pixels, per axis
    boxes = ndimage.find_objects(codes + 1)
    distances = _OnFirstCall(functools.partial(domain.edge_distances, h))
    shared = FactorCache(keep_factor=False)
    solve = {k: p[k] for k in ("lam", "smoothing", "mu", "t", "form", "rtol", "solver")}
    index = np.int32 if domain.n_vertices < np.iinfo(np.int32).max else np.int64

    def region(r, lines, gate=None):
        """Region ``r``'s relaxation on its own band: steps, as ``Relaxer._relax_steps``
        (within ``gate.held``, :func:`~ndboundary.pipeline.relaxer.relax_at_once`, once
        its band is found).
        """
        tick = time.perf_counter()
        box = tuple(
            slice(max(b.start - m, 0), min(b.stop + m, n)) for b, m, n in zip(boxes[r], reach, shape, strict=True)
        )
        band_pixels, dist, labels, band_codes = region_band(codes, r, box, spacing, h, width)
        band = GridBand(shape, band_pixels, spacing=spacing, origin=origin, direction=direction)
        band.usual_degree = domain.usual_degree
        locate = time.perf_counter() - tick
        relaxer = Relaxer(band, _keep=False, _h=h, _private=True)
        relaxer._shared = shared
        relaxer._band_of_width(domain, width, dist)
        relaxer._vertex_pins = True
        if sectors.SECTOR_SMOOTHING:
            relaxer._sectors = (band_codes, r)
        waited = time.perf_counter()
        with contextlib.nullcontext() if gate is None else gate.held(band.n_vertices):
            # the seconds it waits for its turn, and for the next region's first steps
            clock = [time.perf_counter() - waited]
            res = yield from relaxer._relax_steps(
                labels, on="elements", pad=pad, verbose=lines, band=None, clock=clock, **solve
            )
        if pixels is None:
            vertices, elements = band.corners, band_pixels
        else:
            vertices, elements = np.searchsorted(domain.corners, band.corners), np.searchsorted(pixels, band_pixels)
        # kept by every region until the partition: hundreds of bands of a large image
        vertices, elements = vertices.astype(index), elements.astype(index)
        side = functools.partial(_region_side, domain, codes, r, box)
        keep_band(res, elements, vertices, side, distances, growth_rate(res.phi, dist, width))
        if pad:  # zeta over the band's own vertices, not over its padding's
            res.boundary = element_boundary(band, labels)
        res.boundary = _moved(res.boundary, vertices, domain, codes, r)
        res.domain = domain
        res.timings = {"locate": locate, **res.timings, "total": time.perf_counter() - tick - clock[0]}
        res.params.update(band=width, band_vertices=int(band.n_vertices))
        return res

    # in 2-D each region goes on while the last one's factor is still built beside
    # (benchmarks/factor_beside.py --cases image24); in 3-D the regions' conjugate
    # gradients hold no GIL, and several regions relax at once, one on each core
    if len(shape) == 2:
        results = relax_in_turn(classes.size, region, verbose)
    else:
        results = relax_at_once(classes.size, region, verbose, order=np.argsort(-_facet_counts(codes, classes.size)))
    timings = summed_timings(results)
    timings["total"] = time.perf_counter() - t0
    params = {k: p[k] for k in ("on", "lam", "smoothing", "mu", "t", "form", "rtol", "solver", "band")}
    params.update(pad=bool(pad), h=h, band_vertices=int(domain.n_vertices))
    flat = codes.reshape(-1)
    return RegionsResult(classes, domain, results, timings, params, codes=flat if pixels is None else flat[pixels])


class _OnFirstCall:
    """A callable built when first called: the whole domain's edge distances, which a
    region's phi needs only when it is filled beyond its band.
    """

    def __init__(self, build):
        self._build, self._built = build, None
        self._lock = threading.Lock()  # regions relaxed at once may call it together

    def __getstate__(self):
        return {"_build": self._build, "_built": self._built}

    def __setstate__(self, state):
        self.__dict__.update(state, _lock=threading.Lock())

    def __call__(self, *args, **kwargs):
        with self._lock:
            if self._built is None:
                self._built = self._build()
        return self._built(*args, **kwargs)


def _facet_counts(codes, n):
    """The pixel facets on each of the ``n`` regions' boundaries in the label image
    ``codes`` (each region's index), the image's border left out: what its band's size
    follows.
    """
    counts = np.zeros(n, dtype=np.int64)
    for a in range(codes.ndim):  # the faces between pixels i and i + 1 along a
        low, high = codes[(slice(None),) * a + (slice(None, -1),)], codes[(slice(None),) * a + (slice(1, None),)]
        apart = low != high
        counts += np.bincount(low[apart], minlength=n) + np.bincount(high[apart], minlength=n)
    return counts


def _region_side(domain, codes, region, box):
    """The vertices of ``domain`` (the whole grid or a :class:`GridBand`) that hold a pixel
    of ``region``, all of whose pixels lie in ``box``: a mask over its vertices.
    """
    held = np.nonzero(corners_of(codes[box] == region))
    corners = np.ravel_multi_index(
        tuple(i + b.start for i, b in zip(held, box, strict=True)), tuple(n + 1 for n in codes.shape)
    )
    if isinstance(domain, GridBand):  # the corners the band holds, as its vertices
        at = np.minimum(np.searchsorted(domain.corners, corners), domain.corners.size - 1)
        corners = at[domain.corners[at] == corners]
    side = np.zeros(domain.n_vertices, dtype=bool)
    side[corners] = True
    return side


def _moved(boundary, vertices, domain, codes, region):
    """A band's zeta (:class:`~ndboundary.pipeline.boundary.Boundary`) over the vertices of
    the ``domain`` it was cut from, ``vertices[i]`` being the band's vertex ``i``; its
    facets are sought on ``domain`` when first read, so that it holds no reference to the
    band.
    """
    S = sp.csr_matrix(boundary.S)
    sources = vertices[boundary.sources]
    return Boundary(
        sources,
        sp.csr_matrix((S.data, vertices[S.indices], S.indptr), shape=(S.shape[0], domain.n_vertices)),
        boundary.points,
        facets=functools.partial(_region_facets, domain, codes, region, sources),
        targets=boundary.targets,
    )


def _region_facets(domain, codes, region, sources):
    """The facets of ``domain`` between ``region`` and the rest (``codes``: every pixel's
    region, the image's shape) around zeta's vertices ``sources``.
    """
    mine = codes.reshape(-1) == region
    return zeta_facets(domain, mine if domain.n_elements == mine.size else mine[domain.pixels], sources)


def _band_pixels(codes, geometry, direction, params):
    """``(pixels, h, width, distance)`` of the band to relax the image on: ``distance``
    is the graph distance from zeta of its corners (:func:`image_band`). ``pixels`` and
    ``distance`` are None for the whole grid: when the band of ``width`` holds (nearly)
    all of it, or when there is no band (``band=None``, or a small grid: ``width`` None
    too).

    A number ``band`` cuts the band of that width whenever it leaves pixels out. ``"auto"``
    cuts the band of :func:`~ndboundary.pipeline.band.band_width` for the grid's boundary
    weight relative to :data:`REACH_SCALE`, on grids of
    :data:`~ndboundary.pipeline.band.AUTO_BAND_MIN_VERTICES` corners or more, when it holds
    at most :data:`~ndboundary.pipeline.band.AUTO_BAND_MAX_SHARE` of the pixels (the whole
    grid costs no more beyond, and its solve is exact).
    """
    shape, spacing, _ = geometry
    band = params.get("band", "auto")
    p = _checked(params, band)
    h = grid_mean_edge_length(shape, spacing)
    if p["band"] is None:
        return None, h, None, None
    if p["band"] == "auto":
        if np.prod([n + 1 for n in shape]) < AUTO_BAND_MIN_VERTICES:
            return None, h, None, None
        proto = ImageGrid((1,) * len(shape), spacing=spacing, direction=direction)  # a pixel of the grid
        width = band_width(p, proto, grid_scale_hint(proto, h) / REACH_SCALE[len(shape)])
        if width is None:
            return None, h, None, None
    else:
        width = p["band"]
    pixels, distance = image_band(codes, spacing, h, width)
    share = pixels.size / codes.size
    if share == 1.0 or (p["band"] == "auto" and share > AUTO_BAND_MAX_SHARE):
        return None, h, width, None
    return pixels, h, width, distance
