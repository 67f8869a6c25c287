"""Point junctions fitted to the labels: where three regions meet in the plane or on a surface.

The relaxation puts each interface ten times nearer to the truth than the jagged labels
do, by averaging the staircase along it, but a point where three regions meet has no
such stretch to average over: the largest of the region functions puts it within an
element of the vertex where the labels' three regions meet, whose error it keeps (about
half an element). Near a junction, though, the three interfaces are nearly straight, and
the labelled sites of a disk around it (element centroids, or vertices for vertex
labels) pin down where three straight rays from one point may run between them far more
tightly than the nearest vertex does.

So each point junction of the relaxed partition (three regions, no other junction within
:data:`MIN_SPACING` h; two such junctions nearer to each other are fitted as a pair,
:func:`fit_pair`) is fitted: a centre and three ray angles, the sites within
:data:`SITE_RADIUS` site spacings of it (the spacing is the square root of the domain's
measure per site) each on its own region's side of both rays bounding that region's
sector, by the largest margin (the smooth loss :func:`fit_y` minimises). The fit is then
imposed on the region functions: within :data:`CORE` h of the fitted centre the three
regions' functions become their common largest value plus a linear function each, whose
pairwise ties are the fitted rays (:func:`y_gradients`); being linear on every simplex
of the refinement, their partition meets exactly at the fitted centre. Between
:data:`CORE` and :data:`BLEND` h they are blended back into the relaxed functions. A
junction is left as relaxed when its fit moves it more than :data:`MAX_MOVE` site
spacings, or when a sector is not convex (three linear functions cannot part the plane
that way).

Where an interface meets the domain's border, the relaxation has one side to average
over: such a crossing, with no junction among its sites, is fitted as a line between the
two regions' sites (:func:`fit_line`) and imposed the same way.

Meshes of triangles, quads and polygons and 2-D label images are fitted this way, in the
plane and on surfaces (each junction in the best plane through the vertices near it).
Junction curves in volumes are not fitted: there the interfaces' own averaging already
places them (``benchmarks/regions.py``).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .._arrays import expand_ranges
from .._threads import available_threads, shared_pool

__all__ = [
    "JUNCTION_FIT",
    "PAIR_LINES",
    "fit_line",
    "fit_pair",
    "fit_y",
    "fit_ys",
    "junction_corrections",
    "y_gradients",
]

#: Whether a relaxation of three or more regions in the plane or on a surface fits its
#: point junctions to the labels (read when the partition is first built; False keeps the
#: junctions where the relaxed functions put them, which ``benchmarks/regions.py
#: --no-junction-fit`` measures against).
JUNCTION_FIT = True

#: Radius of the disk of labelled sites a junction is fitted to, in units of the sites'
#: spacing (the square root of the domain's measure per site): about 300 sites.
SITE_RADIUS = 10.0

#: Margin scale of the fit's loss, in units of the sites' spacing: a site nearer than this
#: to a ray that bounds its region's sector weighs about as much as one on the wrong side.
MARGIN = 0.1

#: A fit that moves the junction farther than this (units of the sites' spacing) is not kept.
MAX_MOVE = 2.5

#: Within this distance (units of h) of a fitted junction the region functions are the
#: fitted ones; blended back into the relaxed ones by :data:`BLEND`.
CORE = 2.0
BLEND = 4.0

#: Two junctions nearer than this (units of h) to each other, and to no other, are fitted
#: as a pair (:func:`fit_pair`): a Y each would not model them (four regions meeting near
#: a point). A junction nearer than this to two others is left as relaxed.
MIN_SPACING = 3.0


def fit_y(sites, sector, angles, margin=MARGIN):
    """The Y of three rays that best separates labelled sites, fitted from a first guess.

    Sector ``q`` lies counter-clockwise from ray ``q`` to ray ``q + 1`` (modulo 3). Each
    site of sector ``q`` should lie left of ray ``q`` and right of ray ``q + 1``; the loss
    ``sum(exp(-s0 / margin) + exp(-s1 / margin))`` over the sites' signed distances
    ``s0``, ``s1`` to the two lines is a smooth stand-in for the smallest margin, and is
    minimised from the centre at the origin and ``angles``.

    Parameters
    ----------
    sites : ndarray of shape (n, 2)
        Site coordinates, relative to the first guess of the centre, in the unit of
        ``margin`` (the sites' spacing, in the relaxation).
    sector : ndarray of int of shape (n,)
        Each site's sector, 0, 1 or 2.
    angles : ndarray of shape (3,)
        First guess of the rays' angles, counter-clockwise in that order.
    margin : float, default=MARGIN

    Returns
    -------
    (centre, angles) or None
        ``centre`` of shape (2,) in the sites' coordinates and the fitted angles; None
        when the fitted sectors are not all convex and in the same order.

    Examples
    --------
    >>> import numpy as np
    >>> sites = np.random.default_rng(0).uniform(-5, 5, (300, 2))  # three sites per unit square
    >>> a = np.arctan2(sites[:, 1] - 0.3, sites[:, 0] + 0.2) % (2 * np.pi)  # a Y centred at (-0.2, 0.3)
    >>> sector = np.searchsorted(np.radians([0.0, 120.0, 240.0]), a, side="right") - 1
    >>> centre, angles = fit_y(sites, sector, np.radians([10.0, 110.0, 250.0]))
    >>> bool(np.linalg.norm(centre - [-0.2, 0.3]) < 0.2), np.degrees(angles).round(-1).tolist()
    (True, [-0.0, 120.0, 240.0])
    """
    return fit_ys([(sites, sector, angles)], margin)[0]


#: Junctions of more sites than this in all are fitted in :func:`fit_ys` on every core, a
#: share of them on each thread (each junction's fit is its own, the same to the bit): the
#: 2 848 cross-sections of a 192^3 Voronoi partition's junction curves, 1.3 M sites, took
#: 1.5 s on two threads against 2.8 s on one.
SPLIT_MIN_SITES = 100_000


def fit_ys(problems, margin=MARGIN, iterations=100):
    """:func:`fit_y` of several junctions ``(sites, sector, angles)`` at once.

    Their losses are independent: each step takes a damped Gauss-Newton step
    (Levenberg-Marquardt) of every junction's five parameters from one pass over the
    sites, and keeps it for the junctions whose loss it lowers (raising their damping for
    the others), so that a few array passes serve every junction. A junction whose step
    falls below 1e-7, or whose damping passes 1e12, is done: the passes after read only
    the sites of the others. Beyond :data:`SPLIT_MIN_SITES` sites, the junctions are
    split into runs of about as many sites, one per thread.
    """
    sizes = np.cumsum([len(p[0]) for p in problems])
    threads = min(available_threads(), len(problems))
    if threads < 2 or sizes[-1] < SPLIT_MIN_SITES:
        return _fit_ys(problems, margin, iterations)
    cuts = np.searchsorted(sizes, sizes[-1] * np.arange(1, threads) / threads)
    runs = [problems[a:b] for a, b in zip([0, *cuts], [*cuts, len(problems)], strict=True) if b > a]
    return [fit for fits in shared_pool().map(lambda run: _fit_ys(run, margin, iterations), runs) for fit in fits]


def _fit_ys(problems, margin, iterations):
    """:func:`fit_ys` on this thread."""
    n = len(problems)
    sites = np.concatenate([np.asarray(p[0], dtype=np.float64) for p in problems])
    owner = np.repeat(np.arange(n), [len(p[0]) for p in problems])
    sector = np.concatenate([np.asarray(p[1], dtype=np.intp) for p in problems])
    following = (sector + 1) % 3
    ray_slots = np.arange(2, 5)

    def terms(x, active):
        """The loss, gradient and Gauss-Newton matrix of each junction of ``active`` at its
        parameters ``x`` (one row each).

        A site's distance to a ray depends on the centre and on that ray's angle only, so
        each site adds to 6 of the matrix's 15 distinct entries: they are summed per
        junction (and per ray, for the angles') by counting, not formed per site.
        """
        slot = np.full(n, -1)
        slot[active] = np.arange(active.size)
        mine = np.flatnonzero(slot[owner] >= 0)
        at, first, second = slot[owner[mine]], sector[mine], following[mine]
        k = active.size
        centre, angle = x[:, :2], x[:, 2:]
        rel = sites[mine] - centre[at]
        loss, grad, hess = np.zeros(k), np.zeros((k, 5)), np.zeros((k, 5, 5))

        def summed(weights, bins=at, size=k):
            return np.bincount(bins, weights, minlength=size)

        for ray, sign in ((first, 1.0), (second, -1.0)):
            a = angle[at, ray]
            # the left normal of each site's first ray, the right normal of its second
            normal = sign * np.stack([-np.sin(a), np.cos(a)], axis=1)
            dist = np.einsum("ij,ij->i", rel, normal)
            e, slope = _soft_exp(-dist / margin)
            # the distance's derivatives: -normal by the centre, turn by the ray's angle
            turn = rel[:, 1] * normal[:, 0] - rel[:, 0] * normal[:, 1]
            pull, weight = slope / margin, slope / margin**2
            by_ray = at * 3 + ray
            loss += summed(e)
            grad[:, 0] += summed(pull * normal[:, 0])
            grad[:, 1] += summed(pull * normal[:, 1])
            grad[:, 2:] -= summed(pull * turn, by_ray, 3 * k).reshape(k, 3)
            w0, w1 = weight * normal[:, 0], weight * normal[:, 1]
            hess[:, 0, 0] += summed(w0 * normal[:, 0])
            hess[:, 0, 1] += summed(w0 * normal[:, 1])
            hess[:, 1, 1] += summed(w1 * normal[:, 1])
            hess[:, 0, 2:] -= summed(w0 * turn, by_ray, 3 * k).reshape(k, 3)
            hess[:, 1, 2:] -= summed(w1 * turn, by_ray, 3 * k).reshape(k, 3)
            hess[:, ray_slots, ray_slots] += summed(weight * turn * turn, by_ray, 3 * k).reshape(k, 3)
        hess[:, 1, 0] = hess[:, 0, 1]
        hess[:, 2:, :2] = hess[:, :2, 2:].transpose(0, 2, 1)
        return loss, grad, hess

    x = np.column_stack([np.zeros((n, 2)), np.array([np.asarray(p[2], dtype=np.float64) for p in problems])])
    active = np.arange(n)
    loss, grad, hess = terms(x, active)
    damping = np.full(n, 1e-3)
    for _ in range(iterations):
        if active.size == 0:
            break
        h, g, mu = hess[active], grad[active], damping[active]
        scaled = h + mu[:, None, None] * (np.eye(5) * (np.einsum("jii->ji", h)[:, :, None] + 1e-12))
        step = -np.linalg.solve(scaled, g[:, :, None])[:, :, 0]
        trial = terms(x[active] + step, active)
        better = trial[0] < loss[active]
        moved = active[better]
        x[moved] += step[better]
        loss[moved], grad[moved], hess[moved] = trial[0][better], trial[1][better], trial[2][better]
        damping[active] = np.where(better, mu / 3.0, mu * 4.0)
        active = active[~((np.abs(step).max(axis=1) < 1e-7) | (damping[active] > 1e12))]
    out = []
    for centre, fitted in zip(x[:, :2], x[:, 2:], strict=True):
        spans = np.diff(np.concatenate([fitted, fitted[:1] + 2 * np.pi]))
        ok = np.isfinite(centre).all() and np.isfinite(fitted).all() and np.all((spans > 0) & (spans < np.pi))
        out.append((centre, fitted) if ok else None)
    return out


def y_gradients(angles):
    """Gradients of three linear functions, one per sector, whose pairwise ties are the
    rays at ``angles`` (counter-clockwise; sector ``q`` from ray ``q`` to ray ``q + 1``),
    each largest in its sector; None when a sector is not convex.

    Across ray ``q`` the function of sector ``q`` rises over that of sector ``q - 1`` at
    rate ``alpha_q`` along the ray's left normal ``n_q``. The three rises close up around
    the centre when ``sum(alpha_q n_q) = 0``, which positive rates satisfy exactly when
    no sector reaches half a turn. The rates are scaled to a mean of 1.

    Examples
    --------
    >>> import numpy as np
    >>> g = y_gradients(np.radians([90.0, 210.0, 330.0]))
    >>> x = np.array([[0.0, 1.0], [0.1, -1.0]])  # on ray 0, and inside sector 1
    >>> f = x @ g.T
    >>> bool(np.isclose(f[0, 0], f[0, 2])), int(np.argmax(f[1]))
    (True, 1)
    """
    c, s = np.cos(angles), np.sin(angles)
    normals = np.stack([-s, c], axis=1)
    alpha = np.linalg.svd(normals.T)[2][-1]  # the null vector of the 2 x 3 normals
    alpha = alpha if alpha.sum() > 0 else -alpha
    if not np.all(alpha > 1e-9 * np.abs(alpha).max()):
        return None
    alpha = alpha * (3.0 / alpha.sum())
    grads = np.zeros((3, 2))
    grads[1] = alpha[1] * normals[1]
    grads[2] = grads[1] + alpha[2] * normals[2]
    return grads


#: The lines bounding each region of a pair of junctions joined by a short interface
#: (:func:`fit_pair`): regions ``p``, ``q`` (either side of the short interface), ``x`` (at
#: the first junction only), ``y`` (at the second); lines 0-3 the rays ``x|p``, ``x|q`` from
#: the first junction and ``y|p``, ``y|q`` from the second, line 4 the short interface.
PAIR_LINES = ((0, 4, 2), (1, 4, 3), (0, 1), (2, 3))


def fit_pair(sites, region, ends, angles, margin=MARGIN, iterations=100):
    """Two junctions joined by a short interface, fitted to labelled sites as
    :func:`fit_y` fits one: each site on its own region's side of every line bounding that
    region (:data:`PAIR_LINES`; each region convex), by the largest margin.

    Parameters
    ----------
    sites : ndarray of shape (n, 2)
        In units of the sites' spacing.
    region : ndarray of int of shape (n,)
        Each site's region: 0 ``p``, 1 ``q``, 2 ``x``, 3 ``y``.
    ends : ndarray of shape (2, 2)
        First guesses of the two junctions (``x`` meets ``p`` and ``q`` at the first).
    angles : ndarray of shape (4,)
        First guesses of the rays ``x|p``, ``x|q``, ``y|p``, ``y|q``.
    margin : float, default=MARGIN
    iterations : int, default=100

    Returns
    -------
    (ends, angles) or None
        None when a region's sites do not lie on one side of a line bounding it.

    Examples
    --------
    >>> import numpy as np
    >>> sites = np.random.default_rng(0).uniform(-6, 6, (500, 2))
    >>> x, y = sites.T
    >>> # junctions at (-1, 0) and (1, 0): p above the short interface, q below
    >>> region = np.where(x < -1 - np.abs(y), 2, np.where(x > 1 + np.abs(y), 3, np.where(y > 0, 0, 1)))
    >>> ends, angles = fit_pair(sites, region, np.array([[-1.3, 0.2], [0.8, -0.1]]),
    ...                         np.radians([130.0, 230.0, 50.0, 310.0]))
    >>> bool(np.abs(ends - [[-1.0, 0.0], [1.0, 0.0]]).max() < 0.25)
    True
    """
    sites = np.asarray(sites, dtype=np.float64)
    region = np.asarray(region, dtype=np.intp)
    rows, lines = [], []
    for r, bounding in enumerate(PAIR_LINES):
        at = np.flatnonzero(region == r)
        for line in bounding:
            rows.append(at)
            lines.append(np.full(at.size, line))
    rows, lines = np.concatenate(rows), np.concatenate(lines)
    x = sites[rows]

    def distances(p):
        """Each (site, line) row's signed distance to its line (left of a ray, and of the
        short interface from the first junction to the second) and its derivatives.
        """
        J = p[:4].reshape(2, 2)
        theta = p[4:]
        dist, d = np.zeros(rows.size), np.zeros((rows.size, 8))
        ray = lines < 4
        k = lines[ray]
        origin = J[k // 2]
        rel = x[ray] - origin
        c, s = np.cos(theta[k]), np.sin(theta[k])
        dist[ray] = -rel[:, 0] * s + rel[:, 1] * c
        where = np.flatnonzero(ray)
        for j in (0, 1):
            at = where[k // 2 == j]
            d[at, 2 * j] = s[k // 2 == j]
            d[at, 2 * j + 1] = -c[k // 2 == j]
        d[where, 4 + k] = -(rel[:, 0] * c + rel[:, 1] * s)
        edge = np.flatnonzero(~ray)
        v = J[1] - J[0]
        length = np.linalg.norm(v)
        u = v / length
        n = np.array([-u[1], u[0]])
        rel = x[edge] - J[0]
        dist[edge] = rel @ n
        # d dist / d v = (I - u u^T) R^T rel / |v|, with R the quarter turn taking u to n
        dv = (np.column_stack([rel[:, 1], -rel[:, 0]]) - np.outer(rel @ n, u)) / length
        d[edge, 2:4] = dv
        d[edge, 0:2] = -n - dv
        return dist, d

    p = np.concatenate([np.asarray(ends, dtype=np.float64).ravel(), np.asarray(angles, dtype=np.float64)])
    dist, _ = distances(p)
    # each region's side of each line bounding it, from the first guess
    sign = np.ones(rows.size)
    for r, bounding in enumerate(PAIR_LINES):
        for line in bounding:
            mine = (region[rows] == r) & (lines == line)
            side = np.sign(np.median(dist[mine])) if mine.any() else 1.0
            sign[mine] = side if side != 0 else 1.0

    def signed(p):
        dist, d = distances(p)
        return sign * dist, d * sign[:, None]

    p = _separating(signed, p, margin, iterations)
    return None if p is None else (p[:4].reshape(2, 2), p[4:])


def _separating(signed, p, margin, iterations):
    """The parameters from ``p`` that minimise :func:`fit_y`'s loss over the signed
    distances ``signed(p) -> (distances, their derivatives)`` (positive on the right
    side), by damped Gauss-Newton steps; None when more than a twentieth of the
    distances stay negative, or the parameters are not finite.
    """

    def terms(p):
        dist, d = signed(p)
        e, slope = _soft_exp(-dist / margin)
        return e.sum(), (-slope / margin) @ d, (d * (slope / margin**2)[:, None]).T @ d

    loss, grad, hess = terms(p)
    damping = 1e-3
    for _ in range(iterations):
        step = -np.linalg.solve(hess + damping * np.diag(np.diag(hess) + 1e-12), grad)
        trial = terms(p + step)
        if trial[0] < loss:
            p = p + step
            loss, grad, hess = trial
            damping /= 3.0
        else:
            damping *= 4.0
        if np.abs(step).max() < 1e-7 or damping > 1e12:
            break
    if not (np.isfinite(p).all() and np.mean(signed(p)[0] > 0) > 0.95):
        return None
    return p


def _soft_exp(z, top=30.0):
    """``exp(z)`` and its derivative, continued linearly beyond ``top``: the fit's loss
    stays finite, and its gradient true, for sites far on the wrong side of a guess.
    """
    e = np.exp(np.minimum(z, top))
    return np.where(z > top, e * (1.0 + z - top), e), e


def _frame(points):
    """An orthonormal basis (2, dim) of the best plane through ``points``."""
    if points.shape[1] == 2:
        return np.eye(2)
    return np.linalg.svd(points - points.mean(axis=0), full_matrices=False)[2][:2]


def junction_corrections(domain, codes, on, values, faces, h, crossings=None):
    """New values of the region functions near every point junction, pair of junctions
    and crossing of the border that fits.

    Parameters
    ----------
    domain : Domain
        Of elements of dimension 2 (in the plane or on a surface).
    codes : ndarray of int
        The labels' region of each element (``on="elements"``) or vertex.
    on : {"elements", "vertices"}
    values : ndarray or sparse matrix of shape (n_vertices, n_regions)
        The region functions (:meth:`RegionsResult.region_values`).
    faces : Interfaces or None
        The partition's interfaces near its junctions, with their junctions.
    h : float
    crossings : (points, pairs, lead) or None
        Where interfaces meet the domain's border (:func:`fit_line`): the points, shape
        (m, dim), the two regions of each, shape (m, 2), and the leading region at every
        vertex of the domain.

    Returns
    -------
    list of (vertices, regions, new)
        For each fitted junction, pair or crossing: the vertices near it, its three, four
        or two regions, and their new values, shape (n_vertices_near, n_regions_there).
        No two share a vertex.
    """
    junctions = None if faces is None else faces.junctions()
    if junctions is None or len(junctions) == 0 or junctions.simplices.shape[1] != 1:
        centres, regions = np.zeros((0, domain.points.shape[1])), np.full((0, 3), -1)
    else:
        centres, regions = junctions.points[junctions.simplices[:, 0]], junctions.regions
    if regions.shape[1] < 3:
        regions = np.column_stack([regions, np.full((len(regions), 3 - regions.shape[1]), -1)])
    if crossings is None:
        crossings = (np.zeros((0, domain.points.shape[1])), np.zeros((0, 2), int), None)
    n_sites = domain.n_vertices if on == "vertices" else domain.n_elements
    unit = float(np.sqrt(np.asarray(domain.A).sum() / n_sites))  # the sites' spacing
    # a crossing is fitted as a line where no junction lies within its disk of sites
    alone = [_nearest(centres, point) > SITE_RADIUS * unit for point in crossings[0]]
    crossings = (crossings[0][alone], crossings[1][alone], crossings[2])
    singles, pairs, dist = _clusters(centres, regions, MIN_SPACING * h)
    if singles.size == 0 and not pairs and len(crossings[0]) == 0:
        return []
    middles = np.array([0.5 * (centres[i] + centres[j]) for i, j in pairs]).reshape(-1, centres.shape[1])
    where = np.concatenate([centres[singles], middles, crossings[0]])
    near, sites, site_codes, site_near = _sites_near(domain, codes, on, where, SITE_RADIUS * unit)
    n = len(centres)
    problems = []
    for j, vertices, around in zip(singles, near, site_near, strict=False):
        problem = _problem(
            domain, centres[j], regions[j, :3], faces, vertices, sites[around], site_codes[around], h, unit
        )
        if problem is not None:
            problems.append((j, vertices, problem))
    fixes = []
    if problems:
        fits = fit_ys([problem[:3] for _, _, problem in problems], MARGIN)
        for (j, vertices, problem), fit in zip(problems, fits, strict=True):
            blend = min(BLEND * h, 0.5 * dist[j, 1], 0.5 * _nearest(crossings[0], centres[j]))
            fix = (
                None
                if fit is None
                else _imposed(domain, centres[j], problem[3:], fit, vertices, blend, values, h, unit)
            )
            if fix is not None:
                fixes.append(fix)
    for (i, j), middle, vertices, around in zip(
        pairs, middles, near[singles.size : singles.size + len(pairs)],
        site_near[singles.size : singles.size + len(pairs)], strict=True
    ):  # fmt: skip
        ends, trios = centres[[i, j]], (regions[i, :3], regions[j, :3])
        others = min(dist[i, 2], dist[j, 2], _nearest(crossings[0], centres[i]), _nearest(crossings[0], centres[j]))
        fix = _pair(
            domain, ends, trios, middle, faces, vertices, sites[around], site_codes[around], values, h, unit, others
        )
        if fix is not None:
            fixes.append(fix)
    if len(crossings[0]):
        lead = crossings[2]
        first = singles.size + len(pairs)
        others = np.concatenate([centres, crossings[0]])
        for m, (point, pair) in enumerate(zip(crossings[0], crossings[1], strict=True)):
            blend = min(BLEND * h, 0.5 * _nearest(np.delete(others, n + m, axis=0), point))
            fix = _crossing(domain, point, pair, near[first + m], sites[site_near[first + m]],
                            site_codes[site_near[first + m]], values, lead, blend, h, unit)  # fmt: skip
            if fix is not None:
                fixes.append(fix)
    # a fitted centre may move towards another: a fix that reaches one kept is dropped
    taken = np.zeros(domain.n_vertices, dtype=bool)
    kept = []
    for fix in fixes:
        if not taken[fix[0]].any():
            taken[fix[0]] = True
            kept.append(fix)
    return kept


def _clusters(centres, regions, apart):
    """The junctions at ``centres`` (between ``regions``) to fit alone, nearer than
    ``apart`` to no other, and the pairs to fit together, nearer than ``apart`` to each
    other and to no third; with each junction's distances to itself and its two nearest
    others (inf where there are fewer), shape (n, 3).
    """
    triple = regions[:, 2] >= 0
    if regions.shape[1] > 3:
        triple &= regions[:, 3] < 0
    n = len(centres)
    k = min(3, n)
    if n:
        dist, nearest = cKDTree(centres).query(centres, k=k)
    else:
        dist, nearest = np.zeros((0, 0)), np.zeros((0, 0), int)
    dist = np.column_stack([dist.reshape(n, k), np.full((n, 3 - k), np.inf)])
    nearest = np.column_stack([nearest.reshape(n, k), np.full((n, 3 - k), n)])
    singles = np.flatnonzero(triple & (dist[:, 1] >= apart))
    pairs = []
    for i in np.flatnonzero(triple & (dist[:, 1] < apart) & (dist[:, 2] >= apart)):
        j = nearest[i, 1]
        if i < j and triple[j] and nearest[j, 1] == i and dist[j, 2] >= apart:
            if np.union1d(regions[i, :3], regions[j, :3]).size == 4:
                pairs.append((i, j))
    return singles, pairs, dist


def _sites_near(domain, codes, on, where, radius):
    """For each point of ``where``: the domain's vertices within ``radius``, and the
    labelled sites there (element centroids, or vertices): ``(near, sites, site_codes,
    site_near)``, ``site_near`` indexing ``sites``. Only the elements at those vertices
    are read.
    """
    near = _within(domain.points, where, radius)
    if on == "vertices":
        return near, domain.points, codes, near
    mask = np.zeros(domain.n_vertices, dtype=bool)
    for vertices in near:
        mask[vertices] = True
    elements = np.flatnonzero(domain.elements_at(mask))
    sites = domain.centroids_of(elements)
    return near, sites, codes[elements], _within(sites, where, radius)


def _nearest(points, point):
    """The distance from ``point`` to the nearest of ``points`` (inf for none)."""
    return float(np.linalg.norm(points - point, axis=1).min(initial=np.inf))


def _within(points, centres, radius):
    """For each centre, the indices of ``points`` within ``radius`` of it: a window of the
    points sorted along their first axis, so that each centre reads the points near it.
    """
    order = np.argsort(points[:, 0], kind="stable")
    first = points[order, 0]
    lo = np.searchsorted(first, centres[:, 0] - radius, side="left")
    hi = np.searchsorted(first, centres[:, 0] + radius, side="right")
    out = []
    for c, a, b in zip(centres, lo, hi, strict=True):
        window = order[a:b]
        out.append(window[np.linalg.norm(points[window] - c, axis=1) <= radius])
    return out


def _ray_angles(faces, centre, trio, frame, h):
    """First guesses of the rays between the three regions ``trio`` at ``centre``: the
    direction of each pair's interface points 1-4 h away, and the sector of each region
    (counter-clockwise order); None when a pair has no such points.
    """
    rays = []
    for a, b in ((0, 1), (0, 2), (1, 2)):
        angle = _interface_angle(faces, (trio[a], trio[b]), centre, frame, h)
        if angle is None:
            return None
        rays.append(((a, b), angle % (2 * np.pi)))
    rays.sort(key=lambda ray: ray[1])
    # the sector from one ray to the next belongs to the region both rays border
    owners = [(set(rays[q][0]) & set(rays[(q + 1) % 3][0])).pop() for q in range(3)]
    if sorted(owners) != [0, 1, 2]:
        return None
    return np.array([angle for _, angle in rays]), trio[owners]


def _interface_angle(faces, pair, centre, frame, h):
    """The direction from ``centre``, in the frame's plane, of the interface points of
    the two regions ``pair`` 1-4 h away (an angle), or None when there is none.
    """
    mine = (faces.pairs[:, 0] == min(pair)) & (faces.pairs[:, 1] == max(pair))
    points = faces.points[np.unique(faces.simplices[mine])]
    d = np.linalg.norm(points - centre, axis=1)
    points = points[(d >= h) & (d <= 4 * h)]
    if len(points) == 0:
        return None
    direction = frame @ (points.mean(axis=0) - centre)
    return np.arctan2(direction[1], direction[0])


def _problem(domain, centre, trio, faces, near, sites, site_codes, h, unit):
    """One junction's fit :func:`fit_y` as ``(sites, sector, angles, frame, owners)``, or
    None: ``near`` are the vertices within :data:`SITE_RADIUS` sites' spacings ``unit`` of
    it, ``sites`` and ``site_codes`` the labelled sites there (their coordinates in the
    fit in units of ``unit``).
    """
    if near.size < 3:
        return None
    frame = _frame(domain.points[near])
    guess = _ray_angles(faces, centre, trio, frame, h)
    if guess is None:
        return None
    angles, owners = guess
    mine = np.isin(site_codes, owners)
    order = np.argsort(owners)
    sector = order[np.searchsorted(owners, site_codes[mine], sorter=order)]
    return (sites[mine] - centre) @ frame.T / unit, sector, angles, frame, owners


def _imposed(domain, centre, geometry, fit, near, blend, values, h, unit):
    """The fitted junction ``fit`` imposed on the region functions near it:
    ``(vertices, regions, new values)``, or None when it moved too far or its sectors
    cannot be parted by linear functions.
    """
    frame, owners = geometry
    offset, angles = fit
    if np.linalg.norm(offset) > MAX_MOVE:
        return None
    grads = y_gradients(angles)
    if grads is None:
        return None
    centre = centre + (offset * unit) @ frame
    linear = np.column_stack([grads, np.zeros(3)])
    core = min(CORE * h, 0.6 * blend)
    return _imposed_linear(domain, centre, frame, owners, linear, near, core, blend, values, h, unit, angles)


def _pair(domain, ends, trios, middle, faces, near, sites, site_codes, values, h, unit, others):
    """Two junctions ``ends`` nearer than :data:`MIN_SPACING` h to each other, between the
    regions ``trios``, fitted as a pair (:func:`fit_pair`) to the sites near them and
    imposed on the region functions: ``(vertices, regions, new values)``, or None when
    the fit fails, moves a junction more than :data:`MAX_MOVE` site spacings, or gives a
    sector that linear functions cannot part. ``others`` is the distance from the pair to
    the nearest other junction.
    """
    if near.size < 3:
        return None
    p, q = np.intersect1d(trios[0], trios[1])
    x, y = np.setdiff1d(trios[0], [p, q])[0], np.setdiff1d(trios[1], [p, q])[0]
    four = np.array([p, q, x, y])
    frame = _frame(domain.points[near])
    angles = []
    for end, pair in ((0, (x, p)), (0, (x, q)), (1, (y, p)), (1, (y, q))):
        angle = _interface_angle(faces, pair, ends[end], frame, h)
        if angle is None:
            return None
        angles.append(angle)
    mine = np.isin(site_codes, four)
    region = np.argsort(four)[np.searchsorted(np.sort(four), site_codes[mine])]
    local_ends = (ends - middle) @ frame.T / unit
    fit = fit_pair((sites[mine] - middle) @ frame.T / unit, region, local_ends, np.array(angles))
    if fit is None or np.linalg.norm(fit[0] - local_ends, axis=1).max() > MAX_MOVE:
        return None
    linear = _pair_functions(*fit)
    if linear is None:
        return None
    half = 0.5 * float(np.linalg.norm(ends[1] - ends[0]))
    blend = min(BLEND * h + half, 0.5 * others - half)  # no nearer another junction's blend
    if blend < half + h:
        return None
    return _imposed_linear(domain, middle, frame, four, linear, near, min(CORE * h + half, 0.6 * blend), blend,
                           values, h, unit)  # fmt: skip


def _pair_functions(ends, angles):
    """Linear functions of the regions ``p``, ``q``, ``x``, ``y`` of :func:`fit_pair`
    (rows: gradient and offset) whose largest parts the plane as the fitted pair does, or
    None when a sector is not convex: a Y's functions at each junction
    (:func:`y_gradients`), those of the second scaled to rise across the short interface
    as the first's do.
    """
    edge = ends[1] - ends[0]
    at_ends = []
    for end, rays in ((0, ((0, 2), (1, 2), (0, 1))), (1, ((0, 3), (1, 3), (0, 1)))):
        heading = np.arctan2(*(edge if end == 0 else -edge)[::-1])
        ray_angles = np.array([angles[2 * end], angles[2 * end + 1], heading]) % (2 * np.pi)
        order = np.argsort(ray_angles)
        labels = [set(rays[o]) for o in order]
        owners = [(labels[r] & labels[(r + 1) % 3]).pop() for r in range(3)]
        grads = y_gradients(ray_angles[order])
        if grads is None or sorted(owners) != sorted(set(rays[0]) | set(rays[1])):
            return None
        at_ends.append({owner: grad for owner, grad in zip(owners, grads, strict=True)})
    first, second = at_ends
    normal = np.array([-edge[1], edge[0]])
    scale = float((first[0] - first[1]) @ normal) / float((second[0] - second[1]) @ normal)
    if not scale > 0:
        return None
    linear = np.zeros((4, 3))
    for r in (0, 1, 2):
        linear[r] = [*first[r], -first[r] @ ends[0]]
    rise = scale * (second[3] - second[0])
    linear[3] = [*(first[0] + rise), -first[0] @ ends[0] - rise @ ends[1]]
    return linear


def _imposed_linear(
    domain, centre, frame, owners, linear, near, core, blend, values, h, unit, rays=None, taper=None, level=False
):
    """The linear functions ``linear`` (rows: gradient and offset, in the frame's
    coordinates about ``centre`` in units of ``unit``; the frame is (2, dim) in the plane
    and on surfaces, any orthonormal rows in a volume) of the regions ``owners``, imposed
    on their functions within ``core`` of ``centre`` and blended back by ``blend``:
    ``(vertices, regions, new values)``, or None.

    They are scaled to the relaxed functions' rise across their ties, read at the vertices
    within 2 h of the tie of their two largest, or, for a Y with ``rays`` (the angles of
    :func:`y_gradients`, from ``centre``), within 2 h of each ray (not of its line's far
    half, beyond the centre), between the two sectors it parts. ``taper`` (one per vertex
    of ``near``, 1 when not given) scales the imposed part's weight. ``level``: each
    vertex's leading linear function's region keeps the largest value there (the others
    fall below it by the linear functions' gaps) instead of rising by its linear function,
    so that the ties with regions beyond ``owners`` stay where they were; the differences
    between ``owners`` are the same linear functions either way.
    """
    within = np.linalg.norm(domain.points[near] - centre, axis=1) < blend
    vertices = near[within]
    stored = _values_at(values, vertices, owners)
    if stored is None:
        return None
    rel = (domain.points[vertices] - centre) @ frame.T
    g = rel @ linear[:, :-1].T / unit + linear[:, -1]
    rows = np.arange(vertices.size)
    if rays is None:
        top = np.argsort(g, axis=1)[:, -2:]
        first, second = top[:, 1], top[:, 0]
        slope = np.linalg.norm(linear[first, :-1] - linear[second, :-1], axis=1) / unit
        across = g[rows, first] - g[rows, second] < 2 * h * slope
        parted = [(first, second, across)]
    else:
        along = rel @ np.stack([np.cos(rays), np.sin(rays)], axis=1).T
        near_ray = (np.abs(rel @ np.stack([-np.sin(rays), np.cos(rays)], axis=1).T) < 2 * h) & (along > 0)
        parted = [(np.full(rows.size, q), np.full(rows.size, q - 1), near_ray[:, q]) for q in range(3)]
    rise = np.concatenate([(stored[rows, a] - stored[rows, b])[m] for a, b, m in parted])
    rise_linear = np.concatenate([(g[rows, a] - g[rows, b])[m] for a, b, m in parted])
    scale = float(rise @ rise_linear) / float(rise_linear @ rise_linear) if rise_linear.any() else 0.0
    if not scale > 0:
        return None
    weight = np.clip((blend - np.linalg.norm(rel, axis=1)) / (blend - core), 0.0, 1.0)[:, None]
    if taper is not None:
        weight = weight * np.asarray(taper)[within][:, None]
    if level:
        g = g - g.max(axis=1, keepdims=True)
    return vertices, owners, (1.0 - weight) * stored + weight * (stored.max(axis=1, keepdims=True) + scale * g)


def fit_line(sites, side, angle, offset=0.0, margin=MARGIN, iterations=100):
    """The line that best separates labelled sites of two regions: its normal at ``angle``
    points into the sites of ``side`` +1, away from those of -1, and it passes at
    ``offset`` from the origin along it. The loss is :func:`fit_y`'s over the sites' signed
    distances to the line, minimised by damped Gauss-Newton steps from the guess.

    Returns
    -------
    (angle, offset) or None
        None when the fitted line leaves more than a twentieth of the sites on the wrong
        side.

    Examples
    --------
    >>> import numpy as np
    >>> sites = np.random.default_rng(0).uniform(-5, 5, (300, 2))
    >>> side = np.where(sites @ [np.cos(0.3), np.sin(0.3)] > 0.4, 1, -1)
    >>> angle, offset = fit_line(sites, side, 0.0)
    >>> round(float(angle), 1), bool(abs(offset - 0.4) < 0.2)
    (0.3, True)
    """
    sites = np.asarray(sites, dtype=np.float64)
    side = np.asarray(side, dtype=np.float64)

    def signed(p):
        c, s = np.cos(p[0]), np.sin(p[0])
        d = side[:, None] * np.column_stack([sites @ [-s, c], -np.ones(len(sites))])
        return side * (sites @ [c, s] - p[1]), d

    p = _separating(signed, np.array([angle, offset], dtype=np.float64), margin, iterations)
    return None if p is None else (p[0], p[1])


def _crossing(domain, point, pair, near, sites, site_codes, values, lead, blend, h, unit):
    """Where the interface of the regions ``pair`` meets the domain's border at ``point``,
    fitted as a line to the two regions' sites near it (:func:`fit_line`) and imposed as
    two linear functions: ``(vertices, regions, new values)``, or None when another region
    leads near it, the fit fails or moves the crossing more than :data:`MAX_MOVE` site
    spacings.
    """
    if near.size < 3 or blend <= 1.5 * h:
        return None
    if not np.isin(lead[near[np.linalg.norm(domain.points[near] - point, axis=1) < blend]], pair).all():
        return None
    frame = _frame(domain.points[near])
    mine = np.isin(site_codes, pair)
    local = (sites[mine] - point) @ frame.T / unit
    side = np.where(site_codes[mine] == pair[0], 1.0, -1.0)
    # the least-squares discriminant of the two regions to start from
    w = np.linalg.lstsq(np.column_stack([local, np.ones(len(local))]), side, rcond=None)[0]
    if not np.linalg.norm(w[:2]) > 0:
        return None
    fit = fit_line(local, side, np.arctan2(w[1], w[0]), -w[2] / np.linalg.norm(w[:2]))
    if fit is None or abs(fit[1]) > MAX_MOVE:
        return None
    angle, offset = fit
    linear = np.array([[np.cos(angle), np.sin(angle), -offset], [0.0, 0.0, 0.0]])
    return _imposed_linear(domain, point, frame, np.asarray(pair), linear, near, min(CORE * h, 0.6 * blend), blend,
                           values, h, unit)  # fmt: skip


def stored_values(values, vertices, regions):
    """``values[vertices][:, regions]`` as an array, NaN where a sparse ``values`` does not
    store the entry.
    """
    if not hasattr(values, "tocsr"):
        return np.asarray(values)[np.ix_(vertices, regions)]
    values = values.tocsr()  # the same matrix when it is one: its rows are read in place
    vertices, regions = np.asarray(vertices), np.asarray(regions)
    starts = values.indptr[vertices]
    lengths = values.indptr[vertices + 1] - starts
    at = expand_ranges(starts, lengths)  # every entry stored in the vertices' rows
    column = np.full(values.shape[1], -1)
    column[regions] = np.arange(regions.size)
    row = np.repeat(np.arange(vertices.size), lengths)
    wanted = column[values.indices[at]]
    kept = wanted >= 0
    out = np.full((vertices.size, regions.size), np.nan)
    out[row[kept], wanted[kept]] = values.data[at[kept]]
    return out


def _values_at(values, vertices, regions):
    """``values[vertices][:, regions]`` as an array, or None when a sparse ``values``
    does not store one of them.
    """
    out = stored_values(values, vertices, regions)
    return None if np.isnan(out).any() else out
