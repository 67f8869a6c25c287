"""Interfaces fitted to the labels: each interface of a partition in the plane moved to the
smoothest curve that parts its two regions' labelled sites.

The relaxation averages the staircase along an interface, but what it averages is where
the labels put the boundary: between the sites (element centroids, or vertices for vertex
labels) of the two regions. Where the sites are sparse next to the edges (Voronoi
polygons: a cell is 1.5 mean edges across), that average wavers by a tenth of an edge or
more. The sites themselves say more: the true interface parts the two regions' sites, and
is smooth. So each interface of the relaxed partition (after its junctions are fitted,
:mod:`~ndboundary.pipeline.junctions`) is cut into its polylines between junctions and the
domain's border (or closed), resampled every h / 2, smoothed if open (:data:`START_PASSES`:
the priors below are linearised about it, and the relaxed polyline kinks at every element
it crosses), and moved along its normals to the curve that minimises

    BETA * sum(kappa'^2) step + sum(exp(-margin / tau))

over the sites of its two regions within :data:`SITE_REACH` h: ``kappa'`` the change of
its curvature from vertex to vertex (circles and lines cost nothing), ``margin`` a site's
signed distance to the curve, positive on its region's side, lengths in h. The width
``tau`` of the margins' soft minimum narrows through :data:`TAUS`: where sites crowd the
line, the nearest ones then part it by their middle, unswayed by how many lie about as
near.

``BETA`` is chosen per line, from :data:`STIFFNESS`: the largest that leaves none of its
sites more than :data:`SLACK` h on the wrong side. With a soft prior, the margins bend a
line into the local gaps between its sites, which are as wide as the sites are far apart;
where an arc parts the sites, the stiffest prior reads the arc from all of them instead
(two nested circles on pixels, ``tests/test_images.py``, come out at least twice as near
the truth as with the softest prior alone). Where no arc parts them (the curvature
changes along the line), the line bends again. Before the ladder, an open interface of a
partition is tried straight (:data:`STRAIGHT`): of the curves that part its sites, the
straight one is kept, as a circle would bow between them at no cost of its prior.

A point junction that lies alone (no other junction or border end within
``junctions.MIN_SPACING`` h) moves with its three interfaces (:func:`fit_network`): its
move ``u`` moves each one's end by ``n . u``, and the sites within :data:`JUNCTION_SITES`
h of it part all three, beyond their ends too. Where the interfaces meet is then read
along their whole length, not from the sites around the point alone, which the largest
margin of a Y of straight rays misplaces (its rays turn to widen the margins: the truth
runs nearer some sites than the widest parting does).
An interface's end on the domain's border slides along it, and where the junctions' fits
placed it (a crossing fitted to the sites around it) this fit, read along the whole
interface, places it anew; the ends at pairs of junctions are held. An end or a junction the
fit would move farther than :data:`LOOSE_MAX` or :data:`JUNCTION_MAX` h is held, and the
lines fitted again. A moved junction is imposed as the junctions' fits impose theirs:
three linear functions whose ties run from it towards its fitted interfaces, blended into
the values with those interfaces' fit imposed.

The displacement of each interface is then imposed on its two regions' functions: their
difference, which the partition's interface is the zero of, is shifted by the
displacement times its slope, fully within :data:`CORE` h of the curve and blended out by
:data:`BLEND` h, so that every output of the partition (interfaces, region boundaries and
measures) follows.

Against the interfaces as relaxed (``benchmarks/regions.py --no-interface-fit``), on the
Voronoi partitions of that benchmark, this takes the interface mean on Voronoi polygons
from 0.16 h to 0.09 h, on triangles from 0.05 h to 0.03 h, and the junctions of 2-D label
images nearer to the truth (``--cases image-y``). Surfaces and volumes are not fitted; of
the two-region results, 2-D images' are (:func:`~ndboundary.pipeline.result.fit_two_regions`,
with their own :data:`CURVE_STIFFNESS`, :data:`CURVE_TAUS` and :data:`CURVE_CORNER`).
"""

from __future__ import annotations

import warnings
from collections import defaultdict

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import LinAlgError
from scipy.spatial import cKDTree

from ..solvers.cholesky import factorize_spd
from . import junctions
from .junctions import stored_values

__all__ = ["INTERFACE_FIT", "fit_network", "interface_corrections", "margin_newton", "polylines", "refine", "resample"]

#: Whether a relaxation of three or more regions in the plane fits its interfaces to the
#: labels (read when the partition is first built).
INTERFACE_FIT = True

#: Weight of the curvature-change prior against the margins (lengths in units of h): the
#: softest a line of a partition is fitted with, and :func:`refine`'s default.
BETA = 3000.0
#: The weights of the curvature-change prior (as :data:`BETA`) tried on each line,
#: stiffest first: a line is fitted with the stiffest that leaves none of its sites more
#: than :data:`SLACK` h on the wrong side of it. A stiffer first weight (1e8) makes the fit
#: carry differences of 1e-7 in the relaxed values into the measures at 1e-8.
STIFFNESS = (1e7, BETA)
#: How far (h) a site may lie on the wrong side of its fitted interface: the margins' soft
#: minimum leaves a few hundredths.
SLACK = 0.02
#: An interface fitted with the softest curvature-change prior that still holds a site
#: farther than this (h) on its wrong side is left as relaxed.
CROSS_MAX = 0.5
#: Width of the margins' soft minimum, in h.
TAU = 0.1
#: The widths of the soft minimum a partition's interfaces narrow through, each fit
#: starting from the one before. The soft minimum of a line's margins on each side is its
#: nearest site's margin less the width times the log of how many sites lie about as
#: near, so a wide one moves the line away from the side whose nearest sites come in a
#: cluster (half the width times the log of the ratio: between two rows of sites 0.2 h
#: apart, one twice as dense, 0.035 h at 0.1 and 0.0035 h at 0.01). Where sites lie within
#: a few widths of the line, narrowed, the nearest of them part it by their middle; where
#: none does, the narrow minimum has no pull and the line stays where the wider width and
#: its prior put it. After the first width, an end on the domain's border is held where
#: that width put it: with fewer sites than a junction's three interfaces, a short
#: interface would swing about its other end to widen its margins.
TAUS = (TAU, 0.03, 0.01)
#: Weight of the curvature prior (lengths in h) that holds an open interface of a
#: partition straight on its first rung: a line that a straight one parts (within
#: :data:`SLACK`) is fitted straight, and only the others bend (:data:`STIFFNESS`). A
#: circle of curvature-change prior zero would otherwise bow between sites that a
#: straight line parts as well, and a bow of a third of h along a Voronoi edge of 40 h
#: changes its regions' areas by a tenth of a percent.
STRAIGHT = 1e6
#: Passes of the (1, 2, 1) / 4 filter over an open interface's polyline (steps of h / 2)
#: before its fit: a Gaussian of 1.4 h. The relaxed polyline kinks wherever it crosses an
#: element, with curvatures near 1 / h, and the curvature priors are linearised about it:
#: their neglected second-order terms then exceed the curvature of the arcs being fitted
#: (1 / (100 h)), and a line held straight by them came out bowed. A closed one is fitted
#: as relaxed: the filter shrinks a small circle (by 8 % at a radius of 3.5 h), and islands
#: of that size came out 2 % smaller.
START_PASSES = 16
#: The two-region curves' fit (:func:`~ndboundary.pipeline.result.fit_two_regions`): its
#: curvature-change weights, stiffest first (as :data:`STIFFNESS`), and the widths of the
#: margins' soft minimum it narrows through, each fit starting from the one before. With
#: no junction to place, the narrower minimum reads the sites nearest the curve, and the
#: softer prior follows a curvature that changes along it (a flower's petals).
CURVE_STIFFNESS = (1e7, 1000.0)
CURVE_TAUS = (TAU, 0.03)
#: A two-region curve that turns sharper than this (1 / h, its curvature as relaxed,
#: averaged over 2 h) somewhere has a corner, which a curve of slowly changing curvature
#: cannot follow: it is left as relaxed (a rectangle's sides, pulled by its rounded
#: corners, would bow by a third of h). Smooth shapes relax to at most about 0.25.
CURVE_CORNER = 1.0 / 3.0
#: The sites within this many h of an interface are the ones it parts.
SITE_REACH = 2.0
#: The displacement is imposed fully within ``CORE`` h of the interface and blended out by
#: ``BLEND`` h; along an open polyline it grows from its held ends over ``END_RAMP`` h.
CORE = 1.5
BLEND = 3.0
END_RAMP = 2.0
#: An end on the domain's border slides with the fit, unless it would move farther than
#: this (in h): then it is held.
LOOSE_MAX = 1.0
#: A junction fitted with its interfaces is held where it would move farther (in h). The
#: junctions' fit to the sites around it can leave a junction nearly an h off, which the
#: network, reading the whole interfaces, moves back: 0.78-0.91 h on 4 of 16 draws of
#: Voronoi polygons (``benchmarks/regions.py --draws 16``), then 0.22-0.30 h, and 0.48
#: pixel on one of the 12 Y's of ``--cases image-y``, then 0.03.
JUNCTION_MAX = 1.5
#: The sites within this many h of such a junction constrain all its interfaces between
#: their region and another, beyond their ends too (each sector is convex).
JUNCTION_SITES = 3.0


def polylines(points, segments):
    """The polylines a set of segments forms: ``(vertex ids, closed)`` for each chain
    between vertices of another degree than 2 (junctions, ends) and each closed loop.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.interface_fit import polylines
    >>> [(ids.tolist(), closed) for ids, closed in polylines(np.zeros((5, 2)), np.array([[0, 1], [1, 2], [3, 4]]))]
    [([0, 1, 2], False), ([3, 4], False)]
    """
    around = defaultdict(list)
    for a, b in np.asarray(segments).tolist():
        around[a].append(b)
        around[b].append(a)
    used = set()

    def walk(start):
        path, previous, v = [start], None, start
        while True:
            ahead = [w for w in around[v] if w != previous and (min(v, w), max(v, w)) not in used]
            if not ahead:
                return path
            w = ahead[0]
            used.add((min(v, w), max(v, w)))
            path.append(w)
            previous, v = v, w
            if len(around[v]) != 2:
                return path

    out = []
    for v in [v for v in around if len(around[v]) != 2]:
        while any((min(v, w), max(v, w)) not in used for w in around[v]):
            out.append((np.array(walk(v)), False))
    for v in list(around):
        if any((min(v, w), max(v, w)) not in used for w in around[v]):
            path = walk(v)
            out.append((np.array(path[:-1]), True) if path[0] == path[-1] else (np.array(path), False))
    return out


def resample(points, spacing, closed):
    """The polyline at equal arclength steps of about ``spacing``: ``(vertices, step)``; a
    closed one gives each vertex once, an open one keeps both ends.
    """
    chain = np.vstack([points, points[:1]]) if closed else points
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(chain, axis=0), axis=1))])
    m = max(8 if closed else 2, int(round(s[-1] / spacing)))
    t = np.linspace(0.0, s[-1], m + 1)
    out = np.stack([np.interp(t, s, chain[:, k]) for k in range(points.shape[1])], axis=1)
    return (out[:-1] if closed else out), s[-1] / m


def _smoothed(points, closed, passes):
    """The polyline ``points`` after ``passes`` of the (1, 2, 1) / 4 filter: an open one
    keeps its ends.
    """
    points = np.array(points, dtype=np.float64)
    if points.shape[0] < 3:
        return points
    for _ in range(passes):
        if closed:
            points = 0.5 * points + 0.25 * (np.roll(points, 1, axis=0) + np.roll(points, -1, axis=0))
        else:
            points[1:-1] = 0.5 * points[1:-1] + 0.25 * (points[:-2] + points[2:])
    return points


def _stencil(rows, cols, weights, step, cyclic=False):
    """The ``rows`` x ``cols`` matrix whose row ``i`` holds ``weights[k] / step`` at column
    ``i + k`` (modulo ``cols`` when ``cyclic``).
    """
    i = np.arange(rows)
    columns = np.concatenate([(i + k) % cols if cyclic else i + k for k in range(len(weights))])
    values = np.concatenate([np.full(rows, w / step) for w in weights])
    return sp.csr_matrix((values, (np.tile(i, len(weights)), columns)), shape=(rows, cols))


def refine(
    points, step, sites, side, beta=BETA, tau=TAU, closed=True, iterations=30, nearest=None, loose=(False, False)
):
    """The polyline ``points`` (equal steps ``step``, in the units of ``beta`` and ``tau``)
    moved along its normals to the smoothest curve parting the ``sites`` (``side`` +1 on
    one side, -1 on the other) with the largest margins: ``(delta, normal)``, each
    vertex's move along its ``normal``, which points away from the +1 sites. An open
    polyline keeps its ends, but for its first and last where ``loose`` says so (an end
    on the domain's border, which slides along it). ``nearest``, each site's nearest
    vertex, is found when not given. ``tau`` may be a sequence of widths of the margins'
    soft minimum to narrow through (:data:`TAUS`), each fit starting from the one before.

    Examples
    --------
    A circle between two rings of sites moves to the middle of the gap:

    >>> import numpy as np
    >>> from ndboundary.pipeline.interface_fit import refine
    >>> t = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    >>> ring = lambda r: np.stack([r * np.cos(t), r * np.sin(t)], axis=1)
    >>> sites, side = np.concatenate([ring(4.5), ring(5.5)]), np.r_[np.ones(64), -np.ones(64)]
    >>> curve = ring(5.3)
    >>> delta, normal = refine(curve, float(np.linalg.norm(curve[1] - curve[0])), sites, side)
    >>> radius = np.linalg.norm(curve + delta[:, None] * normal, axis=1)
    >>> bool(np.abs(radius - 5.0).max() < 0.05)
    True
    """
    terms = _line_terms(points, step, sites, side, beta, closed, nearest)
    ends = ("loose", "loose") if closed else tuple("loose" if free else "held" for free in loose)
    taus = tuple(float(t) for t in np.atleast_1d(tau))
    return _solve_network([(terms, ends)], 0, taus, iterations)[0][0], terms[0]


def _line_terms(points, step, sites, side, beta, closed, nearest, extend=(False, False), alpha=0.0):
    """The parts of :func:`refine`'s loss on the polyline ``points``: ``(normal, foot,
    signed, side, H0, g0, Hb, gb)``, each vertex's normal (away from the +1 sites), the (sites,
    vertices) matrix interpolating the vertices' moves at each site's foot, the sites'
    signed distances and sides (those with a foot), and the Hessians and gradients at no
    move of the curvature-change prior and of the curvature prior.

    A site beyond an open polyline's end has no foot, unless ``extend`` says so for that
    end: its foot then lies on the end segment's line, and moves with it. ``alpha``
    weighs a curvature prior ``alpha * sum(kappa^2) step`` beside the curvature-change one.
    """
    n = points.shape[0]
    tangent = (np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)) if closed else np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    if nearest is None:  # each site's nearest vertex, unless the caller found them
        nearest = cKDTree(points).query(sites)[1]
    signed = ((sites - points[nearest]) * normal[nearest]).sum(axis=1)
    if np.mean(np.sign(signed) == -side) < 0.5:
        normal, signed = -normal, -signed
    raw = ((sites - points[nearest]) * tangent[nearest]).sum(axis=1) / step
    along = np.clip(raw, -0.999, 0.999)
    j0 = np.where(along >= 0, nearest, nearest - 1)
    w = np.where(along >= 0, along, 1.0 + along)
    if closed:
        j0 %= n
    else:  # sites beyond an open polyline's ends have no foot on it, unless it is extended
        if extend[0]:
            beyond = j0 < 0
            j0[beyond], w[beyond] = 0, raw[beyond]
        if extend[1]:
            beyond = j0 >= n - 1
            j0[beyond], w[beyond] = n - 2, 1.0 + raw[beyond]
        on = (j0 >= 0) & (j0 < n - 1)
        j0, w, signed, side = j0[on], w[on], signed[on], side[on]
    m = j0.size
    ends = (np.tile(np.arange(m), 2), np.r_[j0, (j0 + 1) % n])
    foot = sp.csr_matrix((np.r_[1.0 - w, w], ends), shape=(m, n))
    if closed:
        D = _stencil(n, n, (-1.0, 1.0), step, cyclic=True)
        D2 = (-(D.T @ D)).tocsr()
        inner_normal = normal
    else:
        D2 = _stencil(n - 2, n, (1.0, -2.0, 1.0), step**2)
        inner_normal = normal[1:-1]
    kappa = (D2 @ points * -inner_normal).sum(axis=1)
    rows = np.arange(kappa.size)
    dkappa = -D2 - sp.csr_matrix((kappa**2, (rows, rows if closed else rows + 1)), shape=(kappa.size, n))
    if not closed:
        D = _stencil(kappa.size - 1, kappa.size, (-1.0, 1.0), step)
    A = D @ dkappa
    H0, g0 = beta * step * (A.T @ A), beta * step * (A.T @ (D @ kappa))
    Hb, gb = alpha * step * (dkappa.T @ dkappa), alpha * step * (dkappa.T @ kappa)
    return normal, foot, signed, side, H0.tocsr(), g0, Hb.tocsr(), gb


def fit_network(lines, n_junctions, tau=TAU, iterations=30, stiffness=None, bends=None):
    """:func:`refine` of several polylines at once, some of whose ends are one point that
    moves with them (a junction): each line's ``(terms, ends)``, its :func:`_line_terms`
    and how each end moves (``"held"``, ``"loose"``, or a junction's number), and the
    number of junctions; ``stiffness`` and ``bends``, each line's factors on its
    curvature-change and curvature priors (1 when not given). Returns each line's moves
    along its normals and each junction's move, shape (n_junctions, 2).

    A junction's three interfaces are fitted with it: where they meet is where they part
    their sites best, read along their whole length rather than from the sites around the
    point alone. Its move ``u`` moves each of its lines' end by ``n . u``, ``n`` that end's
    normal (the end's move along its interface changes none of the losses to first order).
    """
    return _solve_network(lines, n_junctions, (tau,), iterations, stiffness, bends)[:2]


def _solve_network(lines, n_junctions, taus=(TAU,), iterations=30, stiffness=None, bends=None, start=None, hold=None):
    """:func:`fit_network`, its Newton steps from the unknowns ``start`` (none moved when
    not given), which it returns too; the margins' soft minimum narrows through the widths
    ``taus``, each solve starting from the one before, and the border ends of the lines
    that ``hold`` (a boolean per line, none when not given) says are held after the first
    width where it put them.
    """
    blocks, width = [], 2 * n_junctions  # the junctions' moves come first
    border = []  # the unknowns of the ends on the border that are held after the first width
    for line, (terms, ends) in enumerate(lines):
        normal = terms[0]
        n = normal.shape[0]
        rows, cols, vals = [np.arange(1, n - 1)], [width + np.arange(n - 2)], [np.ones(n - 2)]
        width += n - 2
        for i, end in ((0, ends[0]), (n - 1, ends[1])):
            if end == "loose":
                if hold is not None and hold[line]:
                    border.append(width)
                rows.append([i]), cols.append([width]), vals.append([1.0])
                width += 1
            elif end != "held":
                rows.append([i, i]), cols.append([2 * end, 2 * end + 1]), vals.append(normal[i])
        blocks.append((np.concatenate(rows), np.concatenate(cols), np.concatenate(vals), n))
    # every line's vertices stacked: their moves are ``place @ z``, z the unknowns
    offsets = np.cumsum([0] + [n for _, _, _, n in blocks])
    place = sp.csr_matrix(
        (
            np.concatenate([v for _, _, v, _ in blocks]),
            (np.concatenate([r + o for (r, _, _, _), o in zip(blocks, offsets, strict=False)]),
             np.concatenate([c for _, c, _, _ in blocks])),
        ),
        shape=(offsets[-1], width),
    )  # fmt: skip
    F = (sp.block_diag([terms[1] for terms, _ in lines], format="csr") @ place).tocsr()
    scale = np.ones(len(lines)) if stiffness is None else stiffness
    bend = np.ones(len(lines)) if bends is None else bends
    parts = list(zip(scale, bend, [terms for terms, _ in lines], strict=True))
    H0 = (place.T @ sp.block_diag([c * t[4] + b * t[6] for c, b, t in parts], format="csr") @ place).tocsr()
    g0 = place.T @ np.concatenate([c * t[5] + b * t[7] for c, b, t in parts])
    signed = np.concatenate([line[0][2] for line in lines])
    side = np.concatenate([line[0][3] for line in lines])
    z = np.zeros(width) if start is None else start.copy()
    if border and len(taus) > 1:
        z = margin_newton(H0, g0, F, signed, side, taus[:1], z, iterations, 1e-6, _spd_solve, PROXIMAL)[0]
        # the other unknowns, with those of the border ends fixed at z: margins of
        # F @ (P @ y + fixed) and a prior of (P @ y + fixed)
        free = np.setdiff1d(np.arange(width), border)
        P = sp.csr_matrix((np.ones(free.size), (free, np.arange(free.size))), shape=(width, free.size))
        fixed = np.zeros(width)
        fixed[border] = z[border]
        y = margin_newton(
            (P.T @ H0 @ P).tocsr(), P.T @ (g0 + H0 @ fixed), (F @ P).tocsr(), signed - F @ fixed, side, taus[1:],
            z[free], iterations, 1e-6, _spd_solve, PROXIMAL, 0,
        )[0]  # fmt: skip
        z = P @ y + fixed
    else:
        z = margin_newton(H0, g0, F, signed, side, taus, z, iterations, 1e-6, _spd_solve, PROXIMAL)[0]
    moves = place @ z
    lines_moves = [moves[a:b] for a, b in zip(offsets[:-1], offsets[1:], strict=True)]
    return lines_moves, z[: 2 * n_junctions].reshape(n_junctions, 2), z


#: Weight (per h^2) of the proximal term that holds each narrower width of a partition's
#: fit where the one before left the unknowns, but for what its sites move.
PROXIMAL = 1e-2
#: Newton stops when the step's predicted fall of the loss (its Newton decrement) is below
#: this, relative to the margins' part of the loss.
DECREMENT = 1e-10


def _spd_solve(A, b):
    """``A x = b`` for the symmetric positive definite Newton systems of a network's fit,
    by the fastest sparse Cholesky installed (:func:`~ndboundary.solvers.cholesky.factorize_spd`:
    supernodal CHOLMOD with the ``[fast]`` extra; SuperLU, as ``spsolve``, without it).
    """
    return factorize_spd(A)(b)


def margin_newton(H, g, F, signed, side, taus, z, iterations, tolerance, solve, proximal=0.0, proximal_from=1):
    """Newton steps on ``z @ H @ z / 2 + g @ z + sum(exp(-margin / tau))``, ``margin = side *
    (F @ z - signed)``, from ``z`` (a new array is returned), for each width ``tau`` of
    ``taus`` in turn, until no entry moves farther than ``tolerance`` or the loss can fall
    by no more than :data:`DECREMENT`; ``solve(A, b)`` solves the Newton systems (symmetric
    positive definite). Each width from the ``proximal_from``-th on adds ``proximal / 2 *
    |z - z0|^2``, z0 where z was when it began: a narrow soft minimum leaves directions of almost no
    curvature (where no site is near), along which z would otherwise wander by the
    systems' rounding. Returns ``(z, finite)``, ``finite`` False when a step was not (the
    last finite ``z`` is returned).
    """
    z = np.array(z, dtype=np.float64)
    identity = sp.identity(z.size, format="csr")

    def exps(z, tau):
        return np.exp(np.clip(-side * (F @ z - signed) / tau, -50.0, 50.0))

    for k, tau in enumerate(taus):
        anchor, rho = z.copy(), proximal if k >= proximal_from else 0.0
        for _ in range(iterations):
            e = exps(z, tau)
            prior = H @ z + g
            grad = prior - F.T @ (side * e / tau) + rho * (z - anchor)
            move = solve((H + F.T @ sp.diags(e / tau**2) @ F + (1e-9 + rho) * identity).tocsc(), -grad)
            if not np.isfinite(move).all():
                return z, False
            # the margins' exponentials are far from quadratic: a backtracking search on the
            # loss's change, summed term by term (the loss itself is large beside it: the
            # priors' weights reach 1e7)
            slope = float(grad @ move)
            lin = float((prior + rho * (z - anchor)) @ move)
            curve = float(move @ (H @ move) + rho * (move @ move))
            if -slope <= DECREMENT * (1.0 + e.sum()):
                # the loss can fall by no more than DECREMENT: converged. The narrowest
                # widths leave directions of almost no curvature (where no site is near), along
                # which further steps would only wander
                break
            step = 1.0
            while step > 1e-4:
                change = step * lin + 0.5 * step**2 * curve + float((exps(z + step * move, tau) - e).sum())
                if change <= 1e-4 * step * slope:
                    break
                step *= 0.5
            z += step * move
            if np.abs(step * move).max() < tolerance:
                break
    return z, True


def interface_corrections(
    domain,
    codes,
    on,
    values,
    faces,
    h,
    skip,
    ladder=None,
    taus=None,
    corner=np.inf,
    straight=None,
    start_passes=None,
    hold_border=True,
):
    """New values of the region functions near every interface of ``faces`` (an
    :class:`~ndboundary.partition.Interfaces` of a partition of the plane), and near the
    junctions fitted with them, as the module describes: a list of ``(vertices, regions,
    new)`` and the number of junctions moved, none at the vertices of ``skip`` (those the
    junctions' fits hold) but those a moved junction writes anew, and none sharing a
    vertex. ``ladder`` and ``taus``: the curvature-change weights tried (:data:`STIFFNESS`
    when not given) and the widths of the margins' soft minimum (:data:`TAUS`); a line
    whose curvature exceeds ``corner`` (1 / h) is not fitted; ``straight``: the curvature
    prior's weight on a first rung that holds open lines straight (:data:`STRAIGHT`; 0: no
    such rung); ``start_passes``: the smoothing of each open polyline before its fit
    (:data:`START_PASSES`); ``hold_border``: whether the ends on the domain's border are
    held after the first width.
    """
    ladder = STIFFNESS if ladder is None else ladder
    taus = TAUS if taus is None else taus
    straight = STRAIGHT if straight is None else straight
    start_passes = START_PASSES if start_passes is None else start_passes
    # only the vertices whose two largest functions are within reach of each other can lie
    # near an interface (the functions grow by about one per h from it), and only the sites
    # there: the searches follow the interfaces, not the domain
    vertices_near = np.flatnonzero(_top_gap(values) < 2.0 * BLEND + 2.0)
    if on == "vertices":
        site_ids = vertices_near
        sites = domain.points[site_ids]
    else:
        mask = np.zeros(domain.n_vertices, dtype=bool)
        mask[vertices_near] = True
        site_ids = np.flatnonzero(domain.elements_at(mask))
        sites = domain.element_centroids()[site_ids]
    site_codes, points_near = codes[site_ids], domain.points[vertices_near]
    lines = []  # (a, b, points, step, closed, end vertices, points as relaxed), lengths in h
    key = faces.pairs[:, 0].astype(np.int64) * (int(faces.pairs.max(initial=0)) + 1) + faces.pairs[:, 1]
    # an interface ends at a junction (three or more pieces meet there) or on the border,
    # where it is the only piece: that end slides along the border with the fit
    degree = np.bincount(faces.simplices.ravel(), minlength=faces.points.shape[0])
    order = np.argsort(key, kind="stable")
    bounds = np.flatnonzero(np.r_[True, np.diff(key[order]) != 0, True])
    for first, last in zip(bounds[:-1], bounds[1:], strict=True):
        pair = faces.pairs[order[first]]
        mine = faces.simplices[order[first:last]]
        for ids, closed in polylines(faces.points, mine):
            if ids.size >= 3:
                ids = _canonical(faces.points, ids, closed)
                raw, step = resample(faces.points[ids] / h, 0.5, closed)
                points = raw if closed else _smoothed(raw, False, start_passes)
                if points.shape[0] >= 4 and (corner == np.inf or _sharpest(points, step, closed) <= corner):
                    lines.append((int(pair[0]), int(pair[1]), points, step, closed, (ids[0], ids[-1]), raw))
    if not lines:
        return [], 0
    # one search for all the polylines: each site and vertex goes with the nearest
    starts = np.cumsum([0] + [line[2].shape[0] for line in lines])
    tree = cKDTree(np.concatenate([line[2] for line in lines]))
    site_line, site_at = _nearest_line(tree, starts, sites / h, SITE_REACH)
    vertex_line, vertex_at = _nearest_line(tree, starts, points_near / h, BLEND)
    junction_of, special, spacing = _single_junctions(faces, degree, lines, h)
    site_tree = cKDTree(sites / h)
    fitted = {}  # line -> (terms, ends)
    for k, (a, b, points, step, closed, end_ids, _) in enumerate(lines):
        near = np.flatnonzero(site_line == k)
        near = near[(site_codes[near] == a) | (site_codes[near] == b)]
        if near.size < 3:
            continue
        ends = ("loose", "loose") if closed else tuple(
            junction_of.get(v, "loose" if degree[v] == 1 else "held") for v in end_ids
        )  # fmt: skip
        at = site_at[near]
        extend = tuple(not isinstance(e, str) for e in ends)
        for v, e in zip(end_ids, ends, strict=True):
            if not isinstance(e, str):  # a junction's sites part its three interfaces
                around = np.asarray(site_tree.query_ball_point(faces.points[v] / h, JUNCTION_SITES), dtype=np.intp)
                extra = np.setdiff1d(around, near)
                extra = extra[(site_codes[extra] == a) | (site_codes[extra] == b)]
                near = np.r_[near, extra]
                at = np.r_[at, cKDTree(points).query(sites[extra] / h)[1]]
        side = np.where(site_codes[near] == a, 1.0, -1.0)
        # the curvature prior at unit weight: the straight rung's, weighed by _fit_all
        terms = _line_terms(points, step, sites[near] / h, side, BETA, closed, at, extend, 1.0)
        if not (np.isfinite(terms[0]).all() and terms[2].size >= 3):
            continue
        fitted[k] = (terms, ends)
    closed_lines = {k for k in fitted if lines[k][4]}
    moves, ends_of, shifts = _fit_all(fitted, closed_lines, len(special), ladder, taus, straight, hold_border)
    placed, kept = _moved_junctions(
        domain, values, faces, special, spacing, shifts, lines, moves, ends_of, fitted, vertices_near, h
    )  # fmt: skip
    # the junctions' fits' neighbourhoods stay, but for those of the junctions moved here,
    # whose new ones blend into the interfaces' fit (below)
    skipped = np.zeros(domain.n_vertices, dtype=bool)
    replaced = _replaced(domain, skip, [centre for _, centre, _, _ in placed], h)
    for k, zone in enumerate(skip):
        skipped[zone] = k not in replaced
    zone_of = np.full(domain.n_vertices, -1)
    for z, ((vertices, _, _), _, _, _) in enumerate(placed):
        zone_of[vertices] = z
    out, moved = [], len(placed)
    for k, delta in moves.items():
        a, b, points, step, closed, _, raw = lines[k]
        normal = fitted[k][0][0]
        # the fit moved the smoothed polyline; the tie to move runs along the relaxed one
        delta = delta - ((raw - points) * normal).sum(axis=1)
        # a junction left where it was holds its ends, as the junctions' fits do
        ends = tuple("held" if e in kept else e for e in ends_of[k])
        if not closed:  # the move grows from a held end
            j = np.arange(points.shape[0], dtype=np.float64)
            ramp = np.minimum(j if ends[0] == "held" else np.inf, j[::-1] if ends[1] == "held" else np.inf)
            delta = delta * np.clip(ramp * step / END_RAMP, 0.0, 1.0)
        mine = np.flatnonzero((vertex_line == k) & ~skipped[vertices_near])
        if mine.size == 0:
            continue
        at = vertex_at[mine]
        offset = points_near[mine] / h - raw[at]
        d, s = np.linalg.norm(offset, axis=1), (offset * normal[at]).sum(axis=1)
        regions = np.array([a, b])
        stored = _stored(values, vertices_near[mine], regions)
        if stored is None:
            continue
        now, rows = stored
        vertices, d, s, move = vertices_near[mine][rows], d[rows], s[rows], delta[at][rows]
        diff = now[:, 0] - now[:, 1]  # positive on a's side, which the normals point away from
        core = d <= CORE
        if core.sum() < 3 or not (s[core] ** 2).sum() > 0:
            continue
        slope = -float((diff[core] * s[core]).sum() / (s[core] ** 2).sum())  # diff ~ -slope * s
        if not np.isfinite(slope) or slope <= 0.0:
            continue
        weight = np.clip((BLEND - d) / (BLEND - CORE), 0.0, 1.0)
        shift = 0.5 * slope * weight * move  # the tie moves by move (in h) along the normal
        inside = zone_of[vertices] >= 0
        out.append((vertices[~inside], regions, (now + np.stack([shift, -shift], axis=1))[~inside]))
        for z in np.unique(zone_of[vertices[inside]]):
            _blend_into(placed[z], vertices[inside], zone_of[vertices[inside]] == z, regions, shift[inside], domain, h)
    return [fix for fix, _, _, _ in placed] + [fix for fix in out if fix[0].size], moved


def _replaced(domain, zones, centres, h):
    """The indices of the ``zones`` (vertex arrays) that hold a vertex within ``h`` of one
    of the ``centres``: the neighbourhoods of the junctions moved there. Only the zones'
    vertices are searched.
    """
    if not len(zones) or not len(centres):
        return set()
    owner = np.repeat(np.arange(len(zones)), [len(zone) for zone in zones])
    d, at = cKDTree(domain.points[np.concatenate(zones)]).query(np.asarray(centres), distance_upper_bound=h)
    return {int(owner[i]) for i in at[np.isfinite(d)]}


def _blend_into(placed, vertices, mine, regions, shift, domain, h):
    """Add an interface's fitted shift (``+shift`` to ``regions[0]``, ``-shift`` to
    ``regions[1]`` at ``vertices[mine]``) to a moved junction's values, weighted by what
    its imposition keeps of the values it blends into: the junction's functions then blend
    into the fitted interfaces, not the relaxed ones. A junction with less than ``h`` to
    blend over (one near another, or near the border) keeps its own values: over so short
    a step the two would kink the interface.
    """
    (zone, owners, new), centre, core, blend = placed
    columns = [np.flatnonzero(owners == r) for r in regions]
    if any(c.size == 0 for c in columns) or blend - core < h:
        return
    rows = np.searchsorted(zone, vertices[mine], sorter=np.argsort(zone))
    rows = np.argsort(zone)[rows]
    # only where the interface's two regions lead: a vertex nearer to it than to the tie
    # of its own two leading regions (next to the junction) keeps the junction's values
    top = np.argsort(new[rows], axis=1)[:, -2:]
    leads = np.sort(top, axis=1) == np.sort([columns[0][0], columns[1][0]])
    rows, mine = rows[leads.all(axis=1)], np.flatnonzero(mine)[leads.all(axis=1)]
    keep = 1.0 - np.clip(
        (blend - np.linalg.norm(domain.points[vertices[mine]] - centre, axis=1)) / (blend - core), 0.0, 1.0
    )
    new[rows, columns[0][0]] += keep * shift[mine]
    new[rows, columns[1][0]] -= keep * shift[mine]


def _single_junctions(faces, degree, lines, h):
    """The junctions fitted with their interfaces: each vertex of ``faces`` where exactly
    three of the ``lines`` end, with no other junction or border end within
    ``junctions.MIN_SPACING`` h (pairs of junctions keep the junctions' fits).
    Returns ``{vertex: number}``, the vertices in that order, and each one's distance to
    the nearest other junction or border end.
    """
    ends = defaultdict(int)
    for line in lines:
        if not line[4]:
            for v in line[5]:
                ends[v] += 1
    marks = np.flatnonzero(degree != 2)
    candidates = [int(v) for v in np.flatnonzero(degree == 3) if ends.get(v, 0) == 3]
    if not candidates:
        return {}, [], np.zeros(0)
    # to the nearest other junction or border end (the nearest mark is the vertex itself)
    spacing = cKDTree(faces.points[marks]).query(faces.points[candidates], k=2)[0][:, 1]
    alone = spacing > junctions.MIN_SPACING * h
    special = [v for v, keep in zip(candidates, alone, strict=True) if keep]
    return {v: i for i, v in enumerate(special)}, special, spacing[alone]


def _canonical(points, ids, closed):
    """The polyline ``ids`` (of ``points``) walked from where a walk along the same curve
    starts whichever way it was found: a closed one counter-clockwise from its point
    farthest from its centroid (which a rotation of the image keeps), an open one from its
    lesser end (by coordinates). Its resampling, and so its fit, is then the same when the
    labels of its two regions are swapped.
    """
    x = points[ids]
    if not closed:
        return ids[::-1] if tuple(x[-1]) < tuple(x[0]) else ids
    area = float((x[:, 0] * np.roll(x[:, 1], -1) - np.roll(x[:, 0], -1) * x[:, 1]).sum())
    if area < 0:
        ids, x = ids[::-1], x[::-1]
    return np.roll(ids, -int(np.argmax(((x - x.mean(axis=0)) ** 2).sum(axis=1))))


def _sharpest(points, step, closed, reach=2.0):
    """The largest curvature of the polyline ``points`` (equal steps ``step``), averaged
    over ``reach`` along it; 0 when it is too short to tell.
    """
    if points.shape[0] < 5:
        return 0.0
    d1 = (points[2:] - points[:-2]) / (2.0 * step)
    d2 = (points[2:] - 2.0 * points[1:-1] + points[:-2]) / step**2
    kappa = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.linalg.norm(d1, axis=1) ** 3
    if closed:
        kappa = np.r_[kappa, kappa[:2]]  # the ends' turns too, wrapped round
    width = max(1, min(kappa.size, int(round(reach / step))))
    return float(np.convolve(kappa, np.ones(width) / width, mode="valid").max())


def _fit_all(fitted, closed, n_junctions, ladder, taus, straight=0.0, hold_border=False):
    """:func:`fit_network` of the ``fitted`` lines (``{line: (terms, ends)}``), each with the
    stiffest prior of ``ladder`` (:data:`STIFFNESS`) that parts its sites (fitted again,
    softer, while one does not), an open line first held straight (a curvature prior of
    weight ``straight``, unless 0); then again with the ends held that it moved too far: a
    border end farther than :data:`LOOSE_MAX` h (a short interface, which its sites hold
    loosely, swinging about its other end) or a junction farther than :data:`JUNCTION_MAX`
    h. Every fit narrows the margins' soft minimum through ``taus``, holding the ends on the
    border after the first width if ``hold_border``: a prior is too stiff for a line if it
    still holds a site more than :data:`SLACK` h on the wrong side at the narrowest.
    Returns each line's moves and ends as fitted, and each junction's move (NaN where
    held); a line whose end still moves too far after a few rounds, or which still holds a
    site farther than :data:`CROSS_MAX` h on its wrong side, is left out, as relaxed.
    """
    keys = list(fitted)
    if straight:
        ladder = (ladder[0], *ladder)
    first = np.array([straight if straight and k not in closed else 0.0 for k in keys])
    hold = [hold_border and k not in closed for k in keys]
    held_junctions, held_ends = set(), set()
    rung = dict.fromkeys(keys, 0)  # each line's place on the ladder
    z, crossed = None, []
    for _ in range(5 + len(ladder)):
        ends = {
            k: tuple("held" if e in held_junctions or (k, i) in held_ends else e for i, e in enumerate(fitted[k][1]))
            for k in keys
        }
        stiffness = np.array([ladder[min(rung[k], len(ladder) - 1)] / BETA for k in keys])
        bends = np.where(np.array([rung[k] for k in keys]) == 0, first, 0.0)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", spla.MatrixRankWarning)
                # after a softening alone the unknowns are the same: Newton goes on from them
                moves, shifts, z = _solve_network(
                    [(fitted[k][0], ends[k]) for k in keys], n_junctions, taus, stiffness=stiffness, bends=bends,
                    start=z if crossed else None, hold=hold,
                )  # fmt: skip
        except (LinAlgError, RuntimeError, ValueError):
            return {}, {}, np.full((n_junctions, 2), np.nan)
        crossed = [
            k
            for k, delta in zip(keys, moves, strict=True)
            if rung[k] < len(ladder) - 1 and _least_margin(fitted[k][0], delta) < -SLACK
        ]
        for k in crossed:  # too stiff to part those lines' sites: bend them more easily
            rung[k] += 1
        far_junctions = {
            j for j in range(n_junctions) if j not in held_junctions and not np.linalg.norm(shifts[j]) <= JUNCTION_MAX
        }
        far_ends = {
            (k, i)
            for k, delta in zip(keys, moves, strict=True)
            for i, e in enumerate(ends[k])
            if e == "loose" and k not in closed and not abs(delta[-i]) <= LOOSE_MAX
        }
        if crossed:  # refitted before any end is held, as the stiffness may be what moved it
            continue
        if not far_junctions and not far_ends:
            break
        held_junctions |= far_junctions
        held_ends |= far_ends
    shifts = shifts.copy()
    shifts[list(held_junctions | far_junctions)] = np.nan
    drop = {k for k, _ in far_ends} | {
        k for k in keys for e in ends[k] if not isinstance(e, str) and e in far_junctions
    }
    drop |= {k for k, delta in zip(keys, moves, strict=True) if _least_margin(fitted[k][0], delta) < -CROSS_MAX}
    good = {k: delta for k, delta in zip(keys, moves, strict=True) if np.isfinite(delta).all() and k not in drop}
    return good, ends, shifts


def _least_margin(terms, delta):
    """The least signed distance (h) of a line's sites to it moved by ``delta``, positive
    on their side.
    """
    _, foot, signed, side = terms[:4]
    return float((side * (foot @ delta - signed)).min(initial=np.inf))


def _moved_junctions(domain, values, faces, special, spacing, shifts, lines, moves, ends, fitted, vertices_near, h):
    """Each junction of ``special`` (vertices of ``faces``, ``spacing`` h from the nearest
    other junction or border end) that its fit moved by
    ``shifts`` (in h) imposed there on the region functions, as
    :mod:`~ndboundary.pipeline.junctions` imposes a fitted one: three linear functions
    whose ties run from the moved point towards its fitted interfaces 1-4 h away, blended
    back by ``junctions.BLEND`` h. Returns the fixes, and the junctions of ``special`` not
    moved.
    """
    out, kept = [], set(range(len(special)))
    if not len(special):
        return out, kept
    rays = defaultdict(list)  # junction -> (pair, its interface's fitted points 1-4 h away)
    for k, delta in moves.items():
        a, b, points, step = lines[k][:4]
        curve = points + delta[:, None] * fitted[k][0][0]
        for i, e in enumerate(ends[k]):
            if not isinstance(e, str):
                along = curve if i == 0 else curve[::-1]
                reach = along[int(round(1.0 / step)) : int(round(4.0 / step)) + 1]
                if len(reach):
                    rays[e].append(((a, b), reach.mean(axis=0) * h))
    tree = cKDTree(domain.points[vertices_near])
    for j, v in enumerate(special):
        if not np.isfinite(shifts[j]).all() or len(rays[j]) != 3:
            continue
        centre = faces.points[v] + shifts[j] * h
        angles = np.array([np.arctan2(*(point - centre)[::-1]) % (2 * np.pi) for _, point in rays[j]])
        order = np.argsort(angles)
        pairs = [set(rays[j][o][0]) for o in order]
        owners = [pairs[q] & pairs[(q + 1) % 3] for q in range(3)]
        if any(len(o) != 1 for o in owners) or len({min(o) for o in owners}) != 3:
            continue
        grads = junctions.y_gradients(angles[order])
        blend = min(junctions.BLEND * h, 0.5 * spacing[j] - np.linalg.norm(shifts[j]) * h)
        if grads is None or blend < 2.0 * h:
            continue
        near = vertices_near[tree.query_ball_point(centre, blend)]
        core = min(junctions.CORE * h, 0.6 * blend)
        fix = junctions._imposed_linear(
            domain, centre, np.eye(2), np.array([min(o) for o in owners]), np.column_stack([grads, np.zeros(3)]),
            near, core, blend, values, h, h, angles[order],
        )  # fmt: skip
        if fix is not None:
            out.append((fix, centre, core, blend))
            kept.discard(j)
    return out, kept


def _nearest_line(tree, starts, x, radius):
    """For each of the points ``x``, the polyline (``starts``: each one's first point in
    ``tree``) whose point is nearest within ``radius``, -1 beyond, and that point's index
    in its polyline.
    """
    d, i = tree.query(x, distance_upper_bound=radius)
    line = np.full(x.shape[0], -1)
    found = np.isfinite(d)
    line[found] = np.searchsorted(starts, i[found], side="right") - 1
    at = np.zeros(x.shape[0], dtype=np.int64)
    at[found] = i[found] - starts[line[found]]
    return line, at


def _top_gap(values):
    """Each row's largest value less its second largest (inf where it holds one value)."""
    if not hasattr(values, "tocsr"):
        values = np.asarray(values)
        top = np.partition(values, values.shape[1] - 2, axis=1)
        return top[:, -1] - top[:, -2]
    values = values.tocsr()
    counts = np.diff(values.indptr)
    gap = np.full(values.shape[0], np.inf)
    rows = np.flatnonzero(counts >= 2)
    if rows.size == 0:
        return gap
    data, starts = values.data, values.indptr[:-1]
    first = np.full(values.shape[0], -np.inf)
    first[counts > 0] = np.maximum.reduceat(data, starts[counts > 0])
    row_of = np.repeat(np.arange(values.shape[0]), counts)
    rest = np.where(data == first[row_of], -np.inf, data)  # ties keep their second below
    tie = np.bincount(row_of[data == first[row_of]], minlength=values.shape[0]) > 1
    second = np.full(values.shape[0], -np.inf)
    second[counts > 0] = np.maximum.reduceat(rest, starts[counts > 0])
    second[tie] = first[tie]
    gap[rows] = first[rows] - second[rows]
    return gap


def _stored(values, vertices, regions):
    """``(values[vertices][:, regions], rows)``: the values at the rows that store both
    regions (a sparse ``values`` may not), or None when none does.
    """
    out = stored_values(values, vertices, regions)
    rows = np.flatnonzero(~np.isnan(out).any(axis=1))
    return (out[rows], rows) if rows.size else None
