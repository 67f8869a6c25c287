"""Interfaces fitted to the labels: each interface of a partition in the plane moved to the
smoothest curve that parts its two regions' labelled sites.

The relaxation averages the staircase along an interface, but what it averages is where
the labels put the boundary: between the sites (element centroids, or vertices for vertex
labels) of the two regions. Where the sites are sparse next to the edges (Voronoi
polygons: a cell is 1.5 mean edges across), that average wavers by a tenth of an edge or
more. The sites themselves say more: the true interface parts the two regions' sites, and
is smooth. So each interface of the relaxed partition (after its junctions are fitted,
:mod:`~ndboundary.pipeline.junctions`) is cut into its polylines between junctions and the
domain's border (or closed), resampled every h / 2, and moved along its normals to the
curve that minimises

    BETA * sum(kappa'^2) step + sum(exp(-margin / TAU))

over the sites of its two regions within :data:`SITE_REACH` h: ``kappa'`` the change of
its curvature from vertex to vertex (circles and lines cost nothing), ``margin`` a site's
signed distance to the curve, positive on its region's side, lengths in h. Its ends, the
fitted junctions and border crossings, are held. The displacement is then imposed on the
two regions' functions: their difference, which the partition's interface is the zero
of, is shifted by the displacement times its slope, fully within :data:`CORE` h of the
curve and blended out by :data:`BLEND` h, so that every output of the partition
(interfaces, region boundaries and measures) follows.

On the Voronoi partition of ``benchmarks/regions.py`` (``--no-interface-fit`` for the
interfaces as relaxed) this took the interface mean on Voronoi polygons from 0.16 h to
0.11 h, and on triangles from 0.05 h to 0.036 h. Surfaces, volumes and two-region results
are not fitted.
"""

from __future__ import annotations

import warnings
from collections import defaultdict

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import LinAlgError, solveh_banded
from scipy.spatial import cKDTree

from .junctions import stored_values

__all__ = ["INTERFACE_FIT", "interface_corrections", "polylines", "refine", "resample"]

#: Whether a relaxation of three or more regions in the plane fits its interfaces to the
#: labels (read when the partition is first built).
INTERFACE_FIT = True

#: Weight of the curvature-change prior against the margins (lengths in units of h).
BETA = 3000.0
#: Width of the margins' soft minimum, in h.
TAU = 0.1
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
    vertex, is found when not given.

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
    n = points.shape[0]
    tangent = (np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)) if closed else np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    if nearest is None:  # each site's nearest vertex, unless the caller found them
        nearest = cKDTree(points).query(sites)[1]
    signed = ((sites - points[nearest]) * normal[nearest]).sum(axis=1)
    if np.mean(np.sign(signed) == -side) < 0.5:
        normal, signed = -normal, -signed
    along = np.clip(((sites - points[nearest]) * tangent[nearest]).sum(axis=1) / step, -0.999, 0.999)
    j0 = np.where(along >= 0, nearest, nearest - 1)
    w = np.where(along >= 0, along, 1.0 + along)
    if closed:
        j0 %= n
    else:  # sites beyond an open polyline's ends have no foot on it
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
    first, last = (0, n) if closed else (0 if loose[0] else 1, n if loose[1] else n - 1)
    free = np.arange(first, last)
    H0_free = (H0.tocsr()[free][:, free] + 1e-9 * sp.identity(free.size)).tocsr()
    # on a chain the Hessian is banded (the prior couples 3 vertices on either side, a
    # site's foot 2): LAPACK's banded Cholesky solves each step in a pass over it
    banded = not closed and free.size > 3
    bands = np.stack([np.r_[np.zeros(k), H0_free.diagonal(k)] for k in (3, 2, 1, 0)]) if banded else None
    lo, hi = j0 - first, j0 + 1 - first  # the foot's two vertices among the free ones
    delta = np.zeros(n)
    for _ in range(iterations):
        e = np.exp(np.clip(-side * (foot @ delta - signed) / tau, -50.0, 50.0))
        grad = H0 @ delta + g0 - foot.T @ (side * e / tau)
        weight = e / tau**2
        if bands is None:
            hess = H0_free + (foot.T @ sp.diags(weight) @ foot).tocsr()[free][:, free]
            move = spla.spsolve(hess.tocsc(), -grad[free])
        else:
            hess, size = bands.copy(), free.size
            for at, value in ((lo, weight * (1.0 - w) ** 2), (hi, weight * w**2)):
                keep = (at >= 0) & (at < size)  # not a held end
                hess[3] += np.bincount(at[keep], value[keep], minlength=size)
            keep = (lo >= 0) & (hi < size)
            hess[2, 1:] += np.bincount(lo[keep], (weight * w * (1.0 - w))[keep], minlength=size)[:-1]
            move = solveh_banded(hess, -grad[free], check_finite=False)
        delta[free] += move
        if np.abs(move).max() < 1e-6:
            break
    return delta, normal


def interface_corrections(domain, codes, on, values, faces, h, skip):
    """New values of the two region functions near every interface of ``faces`` (an
    :class:`~ndboundary.partition.Interfaces` of a partition of the plane), fitted as the
    module describes: a list of ``(vertices, regions, new)``, none at the vertices of
    ``skip`` (those the junctions' fits wrote) and none sharing a vertex.
    """
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
    lines = []  # (a, b, points, step, closed, loose ends), lengths in h
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
                points, step = resample(faces.points[ids] / h, 0.5, closed)
                if points.shape[0] >= 4:
                    loose = (False, False) if closed else (bool(degree[ids[0]] == 1), bool(degree[ids[-1]] == 1))
                    lines.append((int(pair[0]), int(pair[1]), points, step, closed, loose))
    if not lines:
        return []
    # one search for all the polylines: each site and vertex goes with the nearest
    starts = np.cumsum([0] + [line[2].shape[0] for line in lines])
    tree = cKDTree(np.concatenate([line[2] for line in lines]))
    site_line, site_at = _nearest_line(tree, starts, sites / h, SITE_REACH)
    vertex_line, vertex_at = _nearest_line(tree, starts, points_near / h, BLEND)
    skipped = np.zeros(domain.n_vertices, dtype=bool)
    skipped[skip] = True
    out = []
    for k, (a, b, points, step, closed, loose) in enumerate(lines):
        near = np.flatnonzero(site_line == k)
        near = near[(site_codes[near] == a) | (site_codes[near] == b)]
        if near.size < 3:
            continue
        side = np.where(site_codes[near] == a, 1.0, -1.0)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", spla.MatrixRankWarning)
                delta, normal = refine(
                    points, step, sites[near] / h, side, closed=closed, nearest=site_at[near], loose=loose
                )
                if any(loose) and np.abs(delta[[0, -1]]).max() > LOOSE_MAX:
                    # the sites near the border hold that end too loosely (a short
                    # interface swings about its held end): it stays where it was
                    loose = (False, False)
                    delta, normal = refine(points, step, sites[near] / h, side, closed=closed, nearest=site_at[near])
        except LinAlgError:
            continue
        if not (np.isfinite(delta).all() and np.isfinite(normal).all()):
            continue  # a degenerate polyline (a singular system) stays as relaxed
        if not closed:  # the move grows from a held end
            j = np.arange(points.shape[0], dtype=np.float64)
            ramp = np.minimum(np.inf if loose[0] else j, np.inf if loose[1] else j[::-1])
            delta = delta * np.clip(ramp * step / END_RAMP, 0.0, 1.0)
        mine = np.flatnonzero((vertex_line == k) & ~skipped[vertices_near])
        if mine.size == 0:
            continue
        at = vertex_at[mine]
        offset = points_near[mine] / h - points[at]
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
        out.append((vertices, regions, now + np.stack([shift, -shift], axis=1)))
    return out


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
