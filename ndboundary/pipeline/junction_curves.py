"""Junction curves and their corners fitted to the labels: where three or four regions meet
in a volume.

The largest of the region functions puts a junction curve within about half an element
of where the labels' three regions meet: the interfaces either side are averaged along
their whole extent by the relaxation, but the curve has only its own length. Near the
curve, though, its three interfaces are nearly planes, and a cross-section of them is a
Y of three rays, as at a point junction in the plane
(:mod:`~ndboundary.pipeline.junctions`).

So each junction curve of three regions is sampled every :data:`STEP` h along its
length, and at each sample the labelled sites (element centroids, or vertices for vertex
labels) of its three regions within :data:`RADIUS` h of the curve and :data:`SLAB` h of
the sample's normal plane are projected onto that plane and fitted by a Y
(:func:`~ndboundary.pipeline.junctions.fit_ys`, all samples at once). Along a straight
curve the projection is exact and the slab's sites all pin the same Y. The fitted
centres and rays are averaged along the curve over :data:`PASSES` passes of the (1, 2,
1) / 4 filter, or, where the curve is straight, over up to :data:`WIDE` samples either
side (the fits waver with where each slab meets the voxels, over tens of samples), then
imposed on the three regions' functions as at a point junction, in the plane normal to
the curve: within :data:`CORE` h of the fitted curve the three
functions differ by linear functions of the cross-section whose ties are the fitted
rays (:func:`~ndboundary.pipeline.junctions.y_gradients`), the leading one keeping its
value, so that the ties with any other region stay where they were; between :data:`CORE`
and :data:`BLEND` h they are blended back into the relaxed functions. Each vertex near a
curve takes the Y of the sample nearest it, and only a vertex that one of the three
leads.

Where junction curves meet, four regions meet at a point (a corner), and near it the
four interfaces' six pieces are nearly planes through it: the argmax of four affine
functions. Each corner with four regions about it is fitted so (:func:`fit_corner`, the
functions first fitted to the relaxed ones around it) to the sites within
:data:`CORNER_RADIUS` h, and imposed as a Y is, within :data:`CORNER_CORE` h of it,
blended out by :data:`CORNER_BLEND`; the curves' samples within :data:`END_GAP` h of a
point where curves meet are not fitted, and the corner's vertices are its own. Two
corners nearer than :data:`CORNER_PAIR` h are fitted together, as five affine functions
about both.

A fit is left out (the curve or corner as relaxed) when it moves the junction farther
than :data:`~ndboundary.pipeline.junctions.MAX_MOVE` sites' spacings, when it puts fewer of
its sites in their regions than :data:`ACCURACY` or than the relaxed functions do, or
when a sector is not convex; so is a T (:data:`MAX_SECTOR`).
:data:`~ndboundary.pipeline.junctions.JUNCTION_FIT` switches these fits off with those of
point junctions.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._arrays import counting_sort, row_groups, unique_values
from .._threads import available_threads
from .interface_fit import _smoothed, polylines, resample
from .junctions import MARGIN, MAX_MOVE, _imposed_linear, _separating, fit_ys, stored_values, y_gradients

__all__ = ["curve_corrections", "fit_corner"]

#: Spacing (h) of the samples along a junction curve.
STEP = 1.0
#: Radius (h) about the curve of the sites each sample is fitted to.
RADIUS = 5.0
#: Half-thickness (h) of the slab about each sample's normal plane whose sites it reads.
#: A thin slab's cross-section of the sites shifts with where the curve crosses the grid,
#: and its fits waver along the curve, by half a voxel on a straight curve at a slant to
#: the voxels, beyond what the averaging after smooths; a thicker slab reads more of the
#: labels at once, while a curve within it is near enough straight that its projection
#: stays sharp (junction circles of 6 to 15 voxels, ``benchmarks/junction_circles.py``:
#: both 1.5 h and 4 h left them farther from the truth than 3 h).
SLAB = 3.0
#: Passes of the (1, 2, 1) / 4 filter over the curve before it is sampled, and over the
#: fitted centres and rays after.
PASSES = 4
#: Where a curve is straight, its fits are averaged over longer stretches: each sample's
#: fitted centre and rays become the mean of the fits within ``W`` samples either side
#: (a line fitted to them, read at the sample), ``W`` up to ``WIDE`` and no more than the
#: samples to the run's nearer end, and such that a circle of the curvature the relaxed
#: curve has there would lie at most ``WIDE_BIAS`` h from that line on average
#: (``W (W + 1) kappa / 6``); not where that leaves ``W`` below ``WIDE_MIN``. The fits
#: of a cross-section waver with where the slab meets the voxels, by up to half a voxel
#: along a thin sector over about 25 samples (a straight curve of a 6-region Voronoi
#: partition, whose fits averaged over its length lay 0.08 voxel from the truth), far
#: longer than the filter above smooths. A looser bias (0.1 h) moved the fitted
#: junction circles of 29 voxels from 0.06 to 0.08 voxel from the truth on average.
WIDE = 12
WIDE_BIAS = 0.03
WIDE_MIN = 4
#: The curvature that bounds ``W`` is read from a quadratic fitted to the relaxed curve's
#: samples within this many either side (no more than to the run's nearer end). The
#: relaxed curve of a straight junction at a slant to the voxels waves about its line, by
#: a quarter of a voxel over about 25 samples: read over ``WIDE`` samples, that wave
#: passed for a curvature and narrowed the windows to 4-7 samples (the straight curve of
#: draw 5 of a 6-region Voronoi partition, 0.40 voxel from the truth at worst; 0.37 read
#: over 24). Junction circles of 6 to 29 voxels came out the same.
CURVATURE_REACH = 24
#: Within ``CORE`` h of a fitted curve the region functions are the fitted ones, blended
#: back into the relaxed ones by ``BLEND`` h. The fitted rays are straight: imposed
#: farther, they flatten curved faces near the curve (two overlapping balls of 8 and 6.4
#: voxels lost up to 1.9 % of their volume with 1.5 and 3 h, 1.4 % with 1.25 and 2.5 h,
#: 0.9 % with 1 and 2 h); nearer, they leave more of the relaxation's rounding where flat
#: faces meet (four regions about a corner kept their voxels' volumes within 0.26 % with
#: 1.25 and 2.5 h, 0.30 % with 1 and 2 h).
CORE = 1.25
BLEND = 2.5
#: Samples within this many h of a point where junction curves meet are not fitted.
END_GAP = 2.0
#: A point where four regions meet (a corner) is fitted to the sites within this many h
#: of it, and imposed fully within ``CORNER_CORE`` h, blended out by ``CORNER_BLEND``.
CORNER_RADIUS = 4.0
CORNER_CORE = 1.25
CORNER_BLEND = 2.5
#: Two corners nearer than this many h to each other are fitted together.
CORNER_PAIR = 8.0
#: A sample's fit is kept only where its Y puts at least this share of its sites in their
#: regions' sectors (and no fewer than the relaxed Y does).
ACCURACY = 0.95
#: A sample whose slab holds fewer sites of its three regions than this share of a whole
#: slab's (the domain's border cuts it, or a fourth region fills part of it) is not fitted.
FULL = 0.5
#: A sample whose fitted Y has a sector wider than this (radians) is left as relaxed: a
#: T, where a region meets a flat face of another. No three linear functions part a T: as
#: a sector nears half a turn, their rise across the opposite ray vanishes
#: (:func:`~ndboundary.pipeline.junctions.y_gradients`), and imposed there they moved the
#: regions of a test partition framed by a layer one voxel thick by up to 3 %.
MAX_SECTOR = np.radians(170.0)


def curve_corrections(domain, codes, on, values, faces, h, lead):
    """New values of the region functions near every junction curve of three regions
    that fits, as the module describes.

    Parameters
    ----------
    domain : Domain
        Of elements of dimension 3.
    codes : ndarray of int
        The labels' region of each element (``on="elements"``) or vertex.
    on : {"elements", "vertices"}
    values : ndarray or sparse matrix of shape (n_vertices, n_regions)
        The region functions (:meth:`RegionsResult.region_values`).
    faces : Interfaces or None
        The partition's interfaces near its junctions, with their junction curves.
    h : float
    lead : ndarray of int of shape (n_vertices,)
        Each vertex's largest function: a sample's Y is imposed only where one of its
        three regions leads, never over a fourth region near the curve.

    Returns
    -------
    list of (vertices, regions, new)
        For each fitted sample: the vertices that take its Y, its three regions, and their
        new values, shape (n_vertices_near, 3). No two share a vertex.
    """
    junctions = None if faces is None else faces.junctions()
    if junctions is None or len(junctions) == 0 or junctions.simplices.shape[1] != 2:
        return []
    n_sites = domain.n_vertices if on == "vertices" else domain.n_elements
    unit = float(np.cbrt(np.asarray(domain.A).sum() / n_sites))  # the sites' spacing
    corners, samples = _corners(junctions, h), _samples(junctions, h)
    if not corners and not samples:
        return []
    # the vertices and sites about every corner and sample, found at once
    corner_reach = CORNER_RADIUS * h + max((half for _, _, half in corners), default=0.0)
    reach = np.r_[np.full(len(corners), corner_reach), np.full(len(samples), float(np.hypot(RADIUS, SLAB)) * h)]
    centres = np.array([c for c, _, _ in corners] + [s[0] for s in samples])
    near, sites, site_codes, site_near = _sites_near(domain, codes, on, centres, reach)
    if not near:
        return []
    k = len(corners)
    found = (near[:k], sites, site_codes, site_near[:k])
    fixes = _corner_fixes(domain, values, corners, found, h, lead, unit) if corners else []
    taken = np.zeros(domain.n_vertices, dtype=bool)
    for vertices, _, _ in fixes:
        taken[vertices] = True
    if not samples:
        return fixes
    found = (near[k:], sites, site_codes, site_near[k:])
    return fixes + _curve_fixes(domain, values, faces, samples, found, h, lead, unit, taken)


def _curve_fixes(domain, values, faces, samples, found, h, lead, unit, taken):
    """The junction curves' ``samples`` (:func:`_samples`) fitted and imposed, as the
    module describes, on the vertices that no corner's fit took (``taken``); ``found``:
    :func:`_sites_near` of the samples.
    """
    near, sites, site_codes, site_near = found
    pieces = _pair_points(faces)
    expected = np.pi * RADIUS**2 * 2.0 * SLAB * (h / unit) ** 3  # the sites of a whole slab
    problems = []
    for k, ((centre, tangent, frame, trio, curve), around) in enumerate(zip(samples, site_near, strict=True)):
        rel = sites[around] - centre
        along = rel @ tangent
        planar = rel @ frame.T
        keep = (np.abs(along) <= SLAB * h) & (np.linalg.norm(planar, axis=1) <= RADIUS * h)
        guess = _ray_angles(pieces, trio, centre, tangent, frame, h)
        if guess is None:
            continue
        angles, owners = guess
        if _widest(angles) > MAX_SECTOR:
            continue  # a T as relaxed (below)
        mine = keep & np.isin(site_codes[around], owners)
        order = np.argsort(owners)
        sector = order[np.searchsorted(owners, site_codes[around][mine], sorter=order)]
        if np.bincount(sector, minlength=3).min() < 3 or mine.sum() < FULL * expected:
            continue  # too few sites, or a slab the domain's border cuts short
        problems.append((k, curve, owners, (planar[mine] / unit, sector, angles)))
    if not problems:
        return []
    fits = fit_ys([p[3] for p in problems], MARGIN)
    fitted = {}  # sample -> (centre, angles, owners)
    for (k, _, owners, (planar, sector, angles)), fit in zip(problems, fits, strict=True):
        if fit is None or np.linalg.norm(fit[0]) > MAX_MOVE:
            continue
        # kept only where it parts the sites at least as well as the relaxed Y, and nearly all
        right = np.mean(_sectors(planar - fit[0], fit[1]) == sector)
        if _widest(fit[1]) <= MAX_SECTOR and right >= max(ACCURACY, np.mean(_sectors(planar, angles) == sector)):
            centre, _, frame, _, _ = samples[k]
            fitted[k] = (centre + (fit[0] * unit) @ frame, fit[1], owners)
    fitted = _averaged(fitted, samples, h)
    if not fitted:
        return []
    keys = list(fitted)
    moved = np.array([fitted[k][0] for k in keys])
    candidates = unique_values(np.concatenate([near[k] for k in keys]))
    d, nearest = cKDTree(moved).query(domain.points[candidates], distance_upper_bound=BLEND * h)
    candidates, nearest = candidates[np.isfinite(d)], nearest[np.isfinite(d)]
    order, bounds = counting_sort(nearest, len(keys))  # each sample's vertices, increasing
    fixes = []
    for i, k in enumerate(keys):
        centre, angles, owners = fitted[k]
        vertices = candidates[order[bounds[i] : bounds[i + 1]]]
        vertices = vertices[np.isin(lead[vertices], owners) & ~taken[vertices]]
        if vertices.size < 3:
            continue
        tangent, frame = samples[k][1], samples[k][2]
        # a vertex beyond the end of a curve (towards a point where curves meet, or past the
        # last sample fitted) takes the Y's weight only within half a step of it
        taper = np.clip(1.5 - np.abs((domain.points[vertices] - centre) @ tangent) / (STEP * h), 0.0, 1.0)
        grads = y_gradients(angles)
        if grads is None:
            continue
        linear = np.column_stack([grads, np.zeros(3)])
        fix = _imposed_linear(domain, centre, frame, owners, linear, vertices, CORE * h, BLEND * h, values, h, unit,
                              angles, taper, level=True)  # fmt: skip
        if fix is not None:
            fixes.append(fix)
    return fixes


def fit_corner(sites, region, linear, margin=MARGIN, iterations=100):
    """The affine functions, one per region, whose largest parts labelled sites with the
    largest margins, fitted from a first guess: where four regions meet in a volume, four
    functions part space into the four cones about the point where they tie.

    Each site of region ``r`` should lie on r's side of the plane where its function ties
    with each other's; the loss ``sum(exp(-d / margin))`` over the sites' signed distances
    ``d`` to those planes is minimised by damped Gauss-Newton steps, region 0's function
    held at zero (adding one affine function to all of them parts space alike).

    Parameters
    ----------
    sites : ndarray of shape (n, dim)
        Site coordinates, in the unit of ``margin``.
    region : ndarray of int of shape (n,)
        Each site's region, 0 to m - 1.
    linear : ndarray of shape (m, dim + 1)
        First guess: each region's gradient and value at the origin.
    margin : float, default=MARGIN

    Returns
    -------
    ndarray of shape (m, dim + 1) or None
        The fitted functions, region 0's zero; None when more than a twentieth of the
        sites stay on a wrong side, or the fit is not finite.

    Examples
    --------
    >>> import numpy as np
    >>> sites = np.random.default_rng(0).uniform(-4, 4, (600, 3))
    >>> truth = np.array([[0, 0, 0, 0], [1, 0, 0, 0.2], [0, 1, 0, 0.2], [0, 0, 1, 0.2]], float)
    >>> region = np.argmax(sites @ truth[:, :3].T + truth[:, 3], axis=1)
    >>> fit = fit_corner(sites, region, truth + [[0, 0, 0, 0], [0.2, 0.1, 0, 0.3], [0, 0.9, 0.1, 0], [0, 0, 1.2, 0]])
    >>> corner = np.linalg.solve(fit[1:, :3], -fit[1:, 3])  # where the four tie
    >>> bool(np.linalg.norm(corner - [-0.2, -0.2, -0.2]) < 0.2)
    True
    """
    sites = np.asarray(sites, dtype=np.float64)
    region = np.asarray(region, dtype=np.intp)
    m, dim = linear.shape[0], sites.shape[1]
    start = np.asarray(linear, dtype=np.float64) - linear[0]
    # one constraint per site and other region: (site, own region, other region)
    other = np.array([[s for s in range(m) if s != r] for r in range(m)])[region]
    site = np.repeat(np.arange(sites.shape[0]), m - 1)
    own, other = np.repeat(region, m - 1), other.ravel()
    x = sites[site]
    width = dim + 1

    def signed(p):
        rows = np.vstack([np.zeros(width), p.reshape(m - 1, width)])
        D = rows[own, :dim] - rows[other, :dim]
        norm = np.maximum(np.linalg.norm(D, axis=1), 1e-300)
        dist = (np.einsum("ij,ij->i", D, x) + rows[own, dim] - rows[other, dim]) / norm
        # the distance's derivatives by D and by the offset, then by each region's parameters
        dD = x / norm[:, None] - (dist / norm)[:, None] * (D / norm[:, None])
        dA = 1.0 / norm
        d = np.zeros((dist.size, (m - 1) * width))
        k = np.arange(dist.size)
        for r, sign in ((own, 1.0), (other, -1.0)):
            has = r > 0
            cols = (r[has] - 1) * width
            for j in range(dim):
                d[k[has], cols + j] += sign * dD[has, j]
            d[k[has], cols + dim] += sign * dA[has]
        return dist, d

    p = _separating(signed, start[1:].ravel(), margin, iterations)
    if p is None:
        return None
    return np.vstack([np.zeros(width), p.reshape(m - 1, width)])


def _corner_fixes(domain, values, corners, found, h, lead, unit):
    """The ``corners`` of the junction curves (:func:`_corners`: points where four regions
    meet) fitted (:func:`fit_corner`) and imposed on the four regions' functions: a list of
    ``(vertices, regions, new)``, no two sharing a vertex; ``found``: :func:`_sites_near`
    of the corners.
    """
    near, sites, site_codes, site_near = found
    fixes, taken = [], np.zeros(domain.n_vertices, dtype=bool)
    for (centre, owners, half), vertices, around in zip(corners, near, site_near, strict=True):
        vertices = vertices[np.linalg.norm(domain.points[vertices] - centre, axis=1) <= CORNER_RADIUS * h + half]
        around = around[np.linalg.norm(sites[around] - centre, axis=1) <= CORNER_RADIUS * h + half]
        stored = stored_values(values, vertices, owners)
        rel = (domain.points[vertices] - centre) / unit
        use = ~np.isnan(stored).any(axis=1) & (np.linalg.norm(rel, axis=1) <= (2.0 * h + half) / unit)
        mine = np.isin(site_codes[around], owners)
        if use.sum() < 8 or mine.sum() < 20:
            continue
        # the first guess: each region's relaxed function, affine over the vertices near
        design = np.column_stack([rel[use], np.ones(use.sum())])
        guess = np.linalg.lstsq(design, stored[use], rcond=None)[0].T
        region = np.searchsorted(owners, site_codes[around][mine])
        points = (sites[around][mine] - centre) / unit
        fit = fit_corner(points, region, guess, MARGIN)
        if fit is None:
            continue
        right = np.mean(np.argmax(points @ fit[:, :3].T + fit[:, 3], axis=1) == region)
        before = np.mean(np.argmax(points @ guess[:, :3].T + guess[:, 3], axis=1) == region)
        moved = np.zeros(3)
        if owners.size == 4:
            try:
                moved = np.linalg.solve(fit[1:, :3], -fit[1:, 3])  # where the four functions tie
            except np.linalg.LinAlgError:
                continue
        if not (right >= max(ACCURACY, before) and np.linalg.norm(moved) <= MAX_MOVE):
            continue
        linear = np.column_stack([fit[:, :3], fit[:, :3] @ moved + fit[:, 3]])  # about the moved point
        place = centre + moved * unit
        within = vertices[np.isin(lead[vertices], owners) & ~taken[vertices]]
        fix = _imposed_linear(domain, place, np.eye(3), owners, linear, within, CORNER_CORE * h + half,
                              CORNER_BLEND * h + half, values, h, unit, level=True)  # fmt: skip
        if fix is not None:
            taken[fix[0]] = True
            fixes.append(fix)
    return fixes


def _corners(junctions, h):
    """The points where junction curves meet with four regions about them: ``(point,
    regions, 0)``, the points of one corner (within h of each other) merged; two corners
    nearer than :data:`CORNER_PAIR` h to each other, and to no third, as one ``(midpoint,
    their five regions, half their distance)``: four affine functions about each would
    not see the other's fifth region, which the fit of all five about both does.
    """
    points, simplices, regions = junctions.points, junctions.simplices, junctions.regions
    degree = np.bincount(simplices.ravel(), minlength=points.shape[0])
    meeting = np.flatnonzero(degree >= 3)
    if meeting.size == 0:
        return []
    groups = cKDTree(points[meeting]).query_ball_point(points[meeting], h)
    out, seen = [], set()
    for i, group in enumerate(groups):
        if i in seen:
            continue
        seen.update(group)
        ids = meeting[group]
        touching = np.isin(simplices, ids).any(axis=1)
        owners = np.unique(regions[touching])
        owners = owners[owners >= 0]
        if owners.size == 4:
            out.append((points[ids].mean(axis=0), owners, 0.0))
    if len(out) < 2:
        return out
    at = np.array([c for c, _, _ in out])
    dist, other = cKDTree(at).query(at, k=min(3, len(out)))
    dist = np.column_stack([dist, np.full((len(out), 3 - dist.shape[1]), np.inf)])
    paired, merged = set(), []
    for i, (d, j) in enumerate(zip(dist, other[:, 1], strict=True)):
        if i in paired or not d[1] < CORNER_PAIR * h or d[2] < CORNER_PAIR * h or dist[j, 2] < CORNER_PAIR * h:
            continue
        regions_ij = np.union1d(out[i][1], out[j][1])
        if regions_ij.size == 5:
            paired |= {i, int(j)}
            merged.append((0.5 * (at[i] + at[j]), regions_ij, 0.5 * float(d[1])))
    return [c for k, c in enumerate(out) if k not in paired] + merged


def _widest(angles):
    """The widest sector (radians) of the Y of rays at ``angles`` (counter-clockwise)."""
    return float(np.diff(np.r_[angles, angles[0] + 2 * np.pi]).max())


def _sectors(sites, angles):
    """The sector of each site (n, 2) of the Y of rays at ``angles`` from the origin
    (counter-clockwise; sector ``q`` from ray ``q`` to ray ``q + 1``).
    """
    theta = np.arctan2(sites[:, 1], sites[:, 0])
    return (np.searchsorted(np.sort(np.mod(angles - angles[0], 2 * np.pi)), np.mod(theta - angles[0], 2 * np.pi),
                            side="right") - 1) % 3  # fmt: skip


def _samples(junctions, h):
    """The samples of the junction curves of three regions: ``(point, tangent, frame,
    regions, curve)`` every :data:`STEP` h along each, the frame (2, 3) an orthonormal
    basis of the normal plane turning with the curve (each curve's frames are projected
    from one direction, so that the rays' angles compare along it), ``curve`` numbering
    the polylines. Samples within :data:`END_GAP` h of a point where curves meet are left
    out.
    """
    points, simplices, regions = junctions.points, junctions.simplices, junctions.regions
    if regions.shape[1] < 3:
        return []
    three = regions[:, 2] >= 0
    if regions.shape[1] > 3:
        three &= regions[:, 3] < 0
    if not three.any():
        return []
    degree = np.bincount(simplices.ravel(), minlength=points.shape[0])
    meeting = points[degree >= 3]
    meeting_tree = cKDTree(meeting) if len(meeting) else None
    trios = regions[three, :3]
    key = (trios[:, 0] * (trios.max() + 1) + trios[:, 1]) * (trios.max() + 1) + trios[:, 2]
    out, curve = [], 0
    for value in np.unique(key):
        same = key == value
        mine = np.flatnonzero(three)[same]
        trio = trios[np.argmax(same)]
        for ids, closed in polylines(points, simplices[mine]):
            if ids.size < 2:
                continue
            chain = _smoothed(points[ids] / h, closed, PASSES)
            if not closed and chain.shape[0] >= 2 and np.linalg.norm(chain[-1] - chain[0]) < STEP:
                continue
            line, _ = resample(chain, STEP, closed)
            if closed:
                tangent = np.roll(line, -1, axis=0) - np.roll(line, 1, axis=0)
            else:
                tangent = np.gradient(line, axis=0)
            tangent /= np.maximum(np.linalg.norm(tangent, axis=1), 1e-300)[:, None]
            if not np.isfinite(tangent).all():
                continue
            reference = np.eye(3)[np.argmin(np.abs(tangent.mean(axis=0)))]
            first = reference - (tangent @ reference)[:, None] * tangent
            length = np.linalg.norm(first, axis=1)
            first /= np.maximum(length, 1e-300)[:, None]
            second = np.cross(tangent, first)
            line = line * h
            far = length > 0.1  # a loop's tangent may turn onto the reference direction
            if meeting_tree is not None:
                far &= meeting_tree.query(line)[0] > END_GAP * h
            for p, t, a, b in zip(line[far], tangent[far], first[far], second[far], strict=True):
                out.append((p, t, np.stack([a, b]), trio, curve))
            curve += 1
    return out


def _sites_near(domain, codes, on, centres, reach):
    """For each sample at ``centres``: the domain's vertices within ``reach`` (one for
    each, or one for all) of it, and the labelled sites there (element centroids, or
    vertices): ``(near, sites, site_codes, site_near)``, ``site_near`` indexing ``sites``;
    empty lists when no vertex is that near. Only the vertices of a tube about the curves
    are searched again, and only the elements at them read.
    """
    workers = available_threads()
    d = cKDTree(centres).query(domain.points, distance_upper_bound=float(np.max(reach)), workers=workers)[0]
    close = np.flatnonzero(np.isfinite(d))
    if close.size == 0:
        return [], None, None, []
    tree = cKDTree(domain.points[close])
    near = [close[np.asarray(ids, dtype=np.intp)] for ids in tree.query_ball_point(centres, reach, workers=workers)]
    if on == "vertices":
        return near, domain.points, np.asarray(codes), near
    mask = np.zeros(domain.n_vertices, dtype=bool)
    mask[close] = True
    elements = np.flatnonzero(domain.elements_at(mask))
    sites = domain.centroids_of(elements)
    found = cKDTree(sites).query_ball_point(centres, reach, workers=workers)
    site_near = [np.asarray(ids, dtype=np.intp) for ids in found]
    return near, sites, np.asarray(codes)[elements], site_near


def _pair_points(faces):
    """For each pair of regions of the interfaces ``faces``, the points of its pieces, and
    a tree over each.
    """
    out = {}
    pairs = np.sort(faces.pairs, axis=1)
    ids, first = row_groups(pairs)
    order, bounds = counting_sort(ids, first.size)
    for g, f in enumerate(first):
        at = unique_values(faces.simplices[order[bounds[g] : bounds[g + 1]]])
        out[(int(pairs[f, 0]), int(pairs[f, 1]))] = cKDTree(faces.points[at]), faces.points[at]
    return out


def _ray_angles(pieces, trio, centre, tangent, frame, h):
    """First guesses of the rays between the three regions ``trio`` in the normal plane
    of a junction curve at ``centre``: the direction of each pair's interface points 1-4 h
    from the curve within the sample's slab, and the sector of each region
    (counter-clockwise order); None when a pair has no such points.
    """
    rays = []
    for a, b in ((0, 1), (0, 2), (1, 2)):
        pair = (int(min(trio[a], trio[b])), int(max(trio[a], trio[b])))
        if pair not in pieces:
            return None
        tree, points = pieces[pair]
        ids = tree.query_ball_point(centre, float(np.hypot(4.0, SLAB)) * h)
        rel = points[ids] - centre
        planar = rel @ frame.T
        d = np.linalg.norm(planar, axis=1)
        use = (np.abs(rel @ tangent) <= SLAB * h) & (d >= h) & (d <= 4 * h)
        if not use.any():
            return None
        direction = planar[use].mean(axis=0)
        rays.append(((a, b), np.arctan2(direction[1], direction[0]) % (2 * np.pi)))
    rays.sort(key=lambda ray: ray[1])
    owners = [(set(rays[q][0]) & set(rays[(q + 1) % 3][0])).pop() for q in range(3)]
    if sorted(owners) != [0, 1, 2]:
        return None
    return np.array([angle for _, angle in rays]), np.asarray(trio)[owners]


def _averaged(fitted, samples, h):
    """The fitted centres and rays averaged along their curves (:data:`PASSES` passes of
    the (1, 2, 1) / 4 filter over each run of consecutive fitted samples of one curve with
    the same sectors, or the mean of up to :data:`WIDE` samples either side where the
    curve is straight), each centre kept in its own sample's normal plane.
    """
    out = {}
    keys = sorted(fitted)
    runs, run = [], []
    for k in keys:
        if run and (
            k != run[-1] + 1
            or samples[k][4] != samples[run[-1]][4]
            or not np.array_equal(fitted[k][2], fitted[run[-1]][2])
        ):
            runs.append(run)
            run = []
        run.append(k)
    if run:
        runs.append(run)
    for run in runs:
        raw_centres = np.array([fitted[k][0] for k in run])
        raw_angles = np.unwrap(np.array([fitted[k][1] for k in run]), axis=0)
        centres = _smoothed(raw_centres, False, PASSES)  # a copy, left as it is below 3 samples
        angles = _smoothed(raw_angles, False, PASSES)
        widths = _straight_widths(np.array([samples[k][0] for k in run]) / h)
        for i in np.flatnonzero(widths):
            window = slice(i - widths[i], i + widths[i] + 1)
            centres[i], angles[i] = raw_centres[window].mean(axis=0), raw_angles[window].mean(axis=0)
        for k, c, a in zip(run, centres, angles, strict=True):
            point, tangent = samples[k][0], samples[k][1]
            c = c - ((c - point) @ tangent) * tangent
            out[k] = (c, a, fitted[k][2])
    return out


def _straight_widths(points):
    """For each of a run of consecutive samples ``points`` (n, 3) of a curve, in units of
    h, the half-width ``W`` of the window its fits are averaged over (:data:`WIDE`), 0
    where they are not.

    The curvature at a sample is read from the quadratic fitted to the samples within
    :data:`CURVATURE_REACH` of it (no more than to the run's nearer end), so that the
    relaxed curve's own wavering, a few tenths of h over tens of samples, hardly counts.

    Examples
    --------
    >>> import numpy as np
    >>> line = np.outer(np.arange(30.0), [0.6, 0.8, 0.0])
    >>> _straight_widths(line).tolist()[:14]
    [0, 0, 0, 0, 4, 5, 6, 7, 8, 9, 10, 11, 12, 12]
    >>> t = np.arange(30.0) / 8.0  # a circle of 8 h: no window is flat enough
    >>> int(_straight_widths(np.column_stack([8 * np.cos(t), 8 * np.sin(t), 0 * t])).max())
    0
    """
    n = points.shape[0]
    widths = np.zeros(n, dtype=np.intp)
    for i in range(WIDE_MIN, n - WIDE_MIN):
        reach = min(CURVATURE_REACH, i, n - 1 - i)
        d = np.arange(-reach, reach + 1, dtype=np.float64)
        window = points[i - reach : i + reach + 1]
        slope = d @ window / (d @ d)
        bend = d**2 - (d**2).mean()
        a2 = bend @ window / (bend @ bend)
        across = a2 - (a2 @ slope) / (slope @ slope) * slope
        kappa = 2.0 * np.linalg.norm(across) / (slope @ slope)
        # a line's mean distance from a circle of curvature kappa over +-W samples
        w = min(WIDE, i, n - 1 - i)
        while w >= WIDE_MIN and w * (w + 1) * STEP**2 * kappa / 6.0 > WIDE_BIAS:
            w -= 1
        widths[i] = w if w >= WIDE_MIN else 0
    return widths
