"""Many regions: every fidelity target of the many-regions issue, with relax's defaults,
distances in units of h = ``mesh.mean_edge_length()``. Regions are labelled by element
centroid from an exact truth (``regions_truths.py``).

Cases (``--cases``, comma separated; default every case but ``speed``):

- ``plane-tri80``, ``plane-tri160``, ``plane-poly80``: a Voronoi partition of [-1, 1]^2 by
  7 random sites on ``kuhn_grid(n, 2, jitter=0.25)`` and ``voronoi_polygons(80)``.
  Interfaces: distance of each interface point to the true Voronoi edge of its pair (the
  bisector *segment*; the JSON's ``bisector_line_max_h`` is the max to the infinite
  line, which is blind to an interface running past a junction), mean <= 0.12 h, max
  <= 0.5 h. Junctions: every true Voronoi vertex inside the square
  (``scipy.spatial.Voronoi``, three nearest sites equidistant; where a bisector meets
  the border is no triple junction) found within 0.5 h by a junction of the same
  regions, and every junction found within 1 h of a true one. Areas within 0.5 %.
- ``y-tri80``, ``y-tri160``, ``y-poly80``: three regions bounded by circular arcs
  (curvatures 0.5, -0.4, 1/3) leaving the point (0.07, -0.04) at 90, 210 and 330 degrees.
  Interfaces: mean distance to their arc <= 0.12 h; the junction within 0.5 h, and no
  other. Angles between the interfaces at the found junction, each interface's direction
  the principal axis of its points 2-6 h from the junction, within 10 degrees of 120;
  the same fit on the true arcs is printed beside (``true arcs``): the arcs' curvature
  alone moves it by up to 6 degrees at 80^2.
- ``sphere-planes``: ``icosphere(5)`` cut by three tilted, offset planes into 8 patches.
  Interfaces: ``|n . x - d|`` of their pair's plane (the points lie on the polyhedral
  surface, within O(h^2) of the sphere), mean <= 0.12 h. Junctions: the crossings of
  two circles (plane-plane-sphere points, where four patches meet: an X, which the
  relaxation may split into two triple junctions) each found within 0.5 h, and every
  junction found within 1 h of one. Patch areas against the exact ones on the mesh
  (``meas%``, information only).
- ``volume-tet24``, ``volume-hex24``: a Voronoi partition of [-1, 1]^3 by 6 sites on
  ``kuhn_grid(24, 3, jitter=0.25)`` and ``hex_grid(24, jitter=0.25)``. Interfaces (to the
  true Voronoi facet polygon of their pair) mean <= 0.12 h; junction curves
  (``jcurve``: each junction point's distance to the true Voronoi edge of its three
  regions, the line equidistant from their sites clipped by the other sites and the
  cube; to the nearest true edge when its regions have none) mean <= 0.5 h; volumes
  within 1 %. ``junc t/f`` is true edges / junction segments; the JSON adds the share of
  the true edges (sampled every h/4) within 1 h of a junction point (``edge_cover_pct``)
  and the junction segments whose regions have no true edge.
- Against the naive approach, in every case: each region relaxed against the rest on its
  own (``res.regions[r]``) and thresholded at 1/2 on its own. ``gap%`` / ``over%``: the
  measure covered by no ``{phi_r > 1/2}`` / by two or more, in % of the domain, exact:
  the simplicial refinement (``domain.level_set_complex``) is cut by every
  ``phi_r = 1/2`` in turn (``partition`` of ``[phi_r - 1/2, 0]``, the other functions
  carried along as columns that never win), after which every cell is wholly in or out
  of every region. ``seam``: the largest distance from a point of one region's
  separately extracted level set (``res.regions[r].level_set()``) to the others'.
  ``argmax``: ``|sum(region_measures()) / domain - 1|`` of the argmax partition, which
  by construction has neither gap nor overlap (zero up to rounding).
- ``image-y`` (not by default): 12 random Y's of three regions on 64 x 64 label images,
  and a Voronoi partition by 24 random sites on 600 x 600 pixels: the distance (pixels)
  from each true junction to the nearest found one, fitted to the labels (the default)
  and relaxed (``JUNCTION_FIT = False``); and the Voronoi image's ``relax_image`` and
  first ``interfaces()`` seconds, each way, medians of 3 cold processes, alternated.
- ``image-many`` (not by default): the Voronoi partition of 200 random sites on 800 x 800
  pixels, ``relax_image`` and the first ``interfaces()`` with the interfaces' fit, with it
  and the softest prior alone (``--soft-interfaces``), and without it
  (``--no-interface-fit``), medians of 3 cold processes, in turn: the fit's cost with many
  regions.
- ``image-arcs`` (not by default): curved interfaces of label images, with the fit, with
  its softer prior alone and as relaxed: two nested circles, a disc cut by a line (and its
  two T-junctions), and a five-lobed flower cut by a line; distances in pixels.
- ``speed`` (or ``--speed``): ``kuhn_grid(500, 2, jitter=0.25)`` (251 001 vertices), 8
  Voronoi regions against 2 (the first two of the 8 sites), relax alone and relax plus
  ``interfaces().junctions()``, medians of 3 cold runs: each the first ``relax`` of a
  fresh process on a fresh domain (the mesh's construction not timed). Target: the
  ratio <= 3. ``--speed-warm PAIRS`` times the same relaxations warm instead, in PAIRS
  pairs in one process (2 then 8 regions and 8 then 2 in turn, a fresh mesh each time):
  the ratio without the first call's costs, each pair adjacent in time.

``--draws N`` measures the plane Voronoi cases (``--cases``, default all three) for N
draws of the sites, seeds ``--seed`` to ``--seed + N - 1``: each target's median, worst and
passes over the draws, with the oracle's area error (``mid%`` below) beside. One draw's
area on Voronoi polygons is as much the draw's as the method's: the oracle itself misses
0.5 % on some draws.

``--wide-margins``, ``--no-straight`` and ``--raw-start`` undo, one each, three parts of the
interfaces' fit in the plane (``interface_fit.TAUS``, ``STRAIGHT`` and ``START_PASSES``):
the margins' soft minimum narrowed to a nearly hard one, the straight first rung, and the
smoothing of the relaxed polylines the fit is linearised about.

``--independent`` relaxes every region against the rest on its own, its field smoothed
as one (``ndboundary.pipeline.sectors.SECTOR_SMOOTHING = False``): the baseline that
smoothing within sectors is measured against. ``--no-junction-fit`` keeps the point
junctions (in the plane, on the sphere), and the junction curves and their corners (in
volumes), where the relaxed functions put them
(``ndboundary.pipeline.junctions.JUNCTION_FIT = False``): the baseline that fitting them
to the labels is measured against; the junctions that lie alone are still fitted with
their interfaces then, unless ``--no-interface-fit`` too, which keeps the interfaces of
plane partitions as relaxed, and their junctions where the junctions' fit put them
(``ndboundary.pipeline.interface_fit.INTERFACE_FIT = False``). ``--soft-interfaces`` fits
every interface that a straight line does not part with the softest curvature-change prior
alone, not the stiffest that parts its sites (``interface_fit.STIFFNESS =
(interface_fit.BETA,)``). ``--vertex-pins`` holds phi
at the jagged boundary's vertices on triangles and tetrahedra, as the paper does, instead
of at its facets' centres (``ndboundary.pipeline.boundary.FACET_CENTRE_PINS = False``).

Columns: ``mean/h``, ``max/h`` over the interface points; ``away``, ``away max`` over
those farther than 2 h from every true junction and from the border (where the largest
errors are not); ``t>f`` the largest distance from a true junction to the found ones,
``f>t`` from a found junction to the true ones; ``jag t>f`` the same ``t>f`` for the
jagged labels' junctions (the vertices where three labels meet); ``meas%`` the largest relative error of
a region's measure; ``jag%`` the same for the labelled regions (their elements' measures
summed: the relaxation keeps them, so that they bound what it can reach); ``mid%`` (plane
Voronoi cases) the same for an oracle that is given the true interfaces' lines and ends and
moves each along its normal to the middle of the gap its labelled sites leave (those within
2 h): the best estimate of an interface's place from the labels under a flat prior, which
no fit to the same labels beats on average (``VoronoiTruth.gap_midpoint_measures``); and ``cell/h``
the square root of the mean element's measure, in h (plane cases); ``s`` the seconds of
the relax call.

Usage::

    python benchmarks/regions.py                     # every fidelity case, ~25 s
    python benchmarks/regions.py --speed             # and the speed case, ~10 s more
    python benchmarks/regions.py --cases plane-tri80,speed
    python benchmarks/regions.py --speed-warm 8
    python benchmarks/regions.py --draws 16          # the plane cases over 16 draws, ~2 min

Prints a table of measures, a table of targets (value, bound, PASS/FAIL), then one JSON
line per case.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np
import scipy.sparse as sp
from regions_truths import PlaneCuts, VoronoiTruth, YTruth, angles_between, direction_angle, match
from scipy.spatial import cKDTree
from verdicts import print_verdicts

from ndboundary import LevelSet, relax
from ndboundary.datasets import hex_grid, icosphere, kuhn_grid, voronoi_polygons
from ndboundary.metrics import level_set_distance
from ndboundary.partition import partition

# (header, width, format, row key) of the table
COLUMNS = [("L", 3, "d", "n_regions"), ("h", 7, ".4f", "h"), ("mean/h", 7, ".3f", "mean_h"),
           ("max/h", 7, ".3f", "max_h"), ("away", 6, ".3f", "away_mean_h"), ("away max", 8, ".3f", "away_max_h"),
           ("junc t/f", 9, "s", "junctions"), ("t>f/h", 7, ".3f", "true_to_found_h"),
           ("f>t/h", 7, ".3f", "found_to_true_h"), ("jag t>f", 7, ".3f", "jagged_true_to_found_h"),
           ("jcurve/h", 8, ".3f", "junction_curve_mean_h"),
           ("meas%", 7, ".3f", "measure_err_pct"), ("jag%", 6, ".3f", "jagged_measure_err_pct"),
           ("mid%", 6, ".3f", "gap_midpoint_measure_err_pct"),
           ("cell/h", 6, ".2f", "cell_h"), ("gap%", 6, ".3f", "naive_gap_pct"),
           ("over%", 6, ".3f", "naive_overlap_pct"), ("seam/h", 6, ".2f", "naive_seam_max_h"),
           ("argmax", 8, ".1e", "argmax_gap_rel"), ("s", 6, ".2f", "seconds")]  # fmt: skip


def relaxed(mesh, labels):
    """The relaxation and its seconds, with its partition (interfaces, junctions) built
    right after (timed apart), before anything reads ``phi`` or ``regions``."""
    t0 = time.perf_counter()
    res = relax(mesh, labels, on="elements")
    seconds = time.perf_counter() - t0
    res.interfaces().junctions()
    res.params["partition_seconds"] = time.perf_counter() - t0 - seconds
    return res, seconds


def interfaces(res, h, distance, junction_distance, touching, border=None):
    """Distances (h) of the interface corners to their pair's truth, ``distance(x, a, b)``
    with ``a``, ``b`` the pair's labels: mean, max, and the same away from the junctions
    and the border (farther than 2 h from every true junction, ``junction_distance(x)``,
    and from the border, ``border(x)``); the % of the interface measure on pairs the truth
    does not let touch (``touching(a, b)`` false)."""
    faces = res.interfaces()
    d, away, off = [], [], 0.0
    measures = faces.simplex_measures()
    for p in np.unique(faces.pairs, axis=0):
        mine = np.all(faces.pairs == p, axis=1)
        x = faces.points[faces.simplices[mine]].reshape(-1, faces.points.shape[1])
        a, b = int(res.classes[p[0]]), int(res.classes[p[1]])
        d.append(distance(x, a, b) / h)
        far = junction_distance(x) > 2 * h
        away.append(far if border is None else far & (border(x) > 2 * h))
        off += 0.0 if touching(a, b) else float(measures[mine].sum())
    d, away = np.concatenate(d), np.concatenate(away)
    return {"mean_h": d.mean(), "max_h": d.max(), "away_mean_h": d[away].mean() if away.any() else np.nan,
            "away_max_h": d[away].max(initial=0.0), "off_pair_interface_pct": 100 * off / measures.sum()}  # fmt: skip


def box_border(x):
    return np.min(1.0 - np.abs(x), axis=1)


def found_junctions(res):
    """Junction points (k = 2) with the set of labels meeting at each."""
    j = res.interfaces().junctions()
    sets = [set(res.classes[r[r >= 0]].tolist()) for r in j.regions]
    return j.points[j.simplices[:, 0]], sets


def jagged_junctions(mesh, labels):
    """The vertices where three or more labels meet, with the set of labels at each: the
    jagged partition's junctions, which the relaxed ones are compared with."""
    classes, codes = np.unique(labels, return_inverse=True)
    onehot = sp.csr_matrix((np.ones(codes.size), (np.arange(codes.size), codes)), shape=(codes.size, classes.size))
    touch = (mesh.incidence @ onehot).tocsr()
    at = np.flatnonzero(np.diff(touch.indptr) >= 3)
    sets = [set(classes[touch.indices[touch.indptr[v] : touch.indptr[v + 1]]].tolist()) for v in at]
    return mesh.points[at], sets


def naive(res, h):
    """Gap and overlap (% of the domain) of the regions relaxed and thresholded one by one,
    their largest seam (h), and the argmax partition's relative gap."""
    domain = res.domain
    points, simplices, F = domain.level_set_complex(np.stack([r.phi for r in res.regions], axis=1))
    C = 10.0 + np.abs(F).max()
    F = F - C  # carried along, never the largest
    for r in range(F.shape[1]):
        cells = partition(points, simplices, np.column_stack([F[:, r] + C - 0.5, np.zeros(len(points)), F])).cells
        points, simplices, F = cells.points, cells.simplices, cells.values[:, 2:]
    count = ((F[simplices].mean(axis=1) + C) > 0.5).sum(axis=1)
    m = cells.measures()
    total = m.sum()
    sets = [r.level_set() for r in res.regions]
    seam = 0.0
    for i, a in enumerate(sets):
        rest = [b for j, b in enumerate(sets) if j != i and b.n_points]
        offsets = np.cumsum([0] + [b.n_points for b in rest])
        union = LevelSet(np.concatenate([b.points for b in rest]),
                         np.concatenate([b.simplices + o for b, o in zip(rest, offsets, strict=False)]),
                         np.concatenate([b.edges for b in rest]), 0.5)  # fmt: skip
        if a.n_points:
            seam = max(seam, float(level_set_distance(a, union).max() / h))
    argmax = abs(res.region_measures().sum() / total - 1)
    return 100 * m[count == 0].sum() / total, 100 * m[count >= 2].sum() / total, seam, float(argmax)


def filled_check(res):
    """The largest change of a region measure (relative to the domain) when the partition is
    built from the filled ``phi`` instead of what ``region_values`` hands it."""
    filled = partition(*res.domain.level_set_complex(res.phi)).region_measures()
    return float(np.abs(filled - res.region_measures()).max() / filled.sum())


def base_row(name, mesh, res, seconds):
    """The row's common part; the naive measures (which read ``regions``) are added by
    :func:`finish`, after the partition's."""
    row = {"bench": "regions", "case": name, "n_regions": int(res.classes.size), "h": mesh.mean_edge_length()}
    row.update(seconds=seconds, partition_seconds=res.params["partition_seconds"])
    return row, row["h"]


def targets(row, res, *items):
    """The naive approach's measures (unless ``res`` is None), then the targets
    ``(name, value, bound)``: each passes if value <= bound."""
    if res is not None:
        gap, over, seam, argmax = naive(res, row["h"])
        row.update(naive_gap_pct=gap, naive_overlap_pct=over, naive_seam_max_h=seam, argmax_gap_rel=argmax)
        row["filled_vs_default_measure_diff_rel"] = filled_check(res)
    row["targets"] = [{"target": t, "value": float(v), "bound": b, "pass": bool(v <= b)} for t, v, b in items]
    return row


def measure_plane(name, mesh, sites):
    truth = VoronoiTruth(sites)
    labels = truth.labels(mesh.element_centroids())
    res, seconds = relaxed(mesh, labels)
    row, h = base_row(name, mesh, res, seconds)
    true, triples = truth.vertices_scipy()
    s = truth.sites
    to_true = lambda x: np.min(np.linalg.norm(x[:, None, :] - true[None], axis=2), axis=1)  # noqa: E731
    row.update(interfaces(res, h, truth.interface_distance, to_true, lambda a, b: truth.face((a, b)) is not None,
                          box_border))  # fmt: skip
    to_line = lambda x, a, b: np.abs((x - (s[a] + s[b]) / 2) @ (s[b] - s[a])) / np.linalg.norm(s[b] - s[a])  # noqa: E731
    line = interfaces(res, h, to_line, to_true, lambda a, b: True)
    found, sets = found_junctions(res)
    t2f, f2t = match(found, sets, true, [set(t.tolist()) for t in triples])
    t2f, f2t = t2f.max(initial=0) / h, f2t.max(initial=0) / h
    jagged = match(*jagged_junctions(mesh, truth.labels(mesh.element_centroids())), true,
                   [set(t.tolist()) for t in triples])[0].max(initial=0) / h  # fmt: skip
    exact = truth.exact_measures(mesh)[res.classes]
    err = 100 * np.abs(res.region_measures() / exact - 1)
    labelled = np.bincount(np.searchsorted(res.classes, labels), weights=mesh.A, minlength=res.classes.size)
    midpoint = truth.gap_midpoint_measures(mesh.element_centroids(), labels, 2 * h)[res.classes] / exact
    row["gap_midpoint_measure_err_pct"] = float(100 * np.abs(midpoint).max())
    row.update(jagged_measure_err_pct=float(100 * np.abs(labelled / exact - 1).max()),
               cell_h=float(np.sqrt(mesh.A.mean()) / h))  # fmt: skip
    row.update(junctions=f"{len(true)}/{len(found)}", true_to_found_h=t2f, found_to_true_h=f2t,
               jagged_true_to_found_h=jagged, measure_err_pct=err.max(), bisector_line_max_h=line["max_h"])  # fmt: skip
    return targets(row, res, ("interface mean / h", row["mean_h"], 0.12), ("interface max / h", row["max_h"], 0.5),
                   ("every true junction found (max / h)", t2f, 0.5), ("no spurious junction (max / h)", f2t, 1.0),
                   ("area error %", err.max(), 0.5))  # fmt: skip


def measure_y(name, mesh, truth=None):
    truth = truth or YTruth()
    res, seconds = relaxed(mesh, truth.labels(mesh.element_centroids()))
    row, h = base_row(name, mesh, res, seconds)
    faces = res.interfaces()
    to_arc = lambda x, a, b: truth.arc_distance(x, truth.arc_of(a, b))  # noqa: E731
    to_centre = lambda x: np.linalg.norm(x - truth.centre, axis=1)  # noqa: E731
    row.update(interfaces(res, h, to_arc, to_centre, lambda a, b: True, box_border))
    found, _ = found_junctions(res)
    dj = np.linalg.norm(found - truth.centre, axis=1) / h
    angles, true_angles = np.full(3, np.nan), np.full(3, np.nan)
    if len(found):
        j = found[np.argmin(dj)]
        dirs = []
        for p in np.unique(faces.pairs, axis=0):
            mine = np.unique(faces.simplices[np.all(faces.pairs == p, axis=1)])
            dirs.append(direction_angle(faces.points[mine], j, 2 * h, 6 * h))
        if len(dirs) == 3 and all(u is not None for u in dirs):
            angles = angles_between(dirs)
        rho = np.linspace(2 * h, 6 * h, 200)
        true_angles = angles_between([direction_angle(truth.arc_points(k, rho), truth.centre, 0, 1) for k in range(3)])
    dev = np.abs(angles - 120)
    row.update(junctions=f"1/{len(found)}", true_to_found_h=dj.min(initial=np.inf), found_to_true_h=dj.max(initial=0),
               angles_deg=angles.tolist(), true_arcs_same_fit_deg=true_angles.tolist())  # fmt: skip
    items = [("interface mean / h", row["mean_h"], 0.12), ("junction found (/ h)", dj.min(initial=np.inf), 0.5),
             ("no spurious junction (max / h)", dj.max(initial=0), 1.0)]  # fmt: skip
    items += [(f"angle {k}: |{angles[k]:.1f} - 120| deg (true arcs {true_angles[k]:.1f})", dev[k], 10.0)
              for k in range(3)]  # fmt: skip
    return targets(row, res, *[(t, np.inf if np.isnan(v) else v, b) for t, v, b in items])


SPHERE_PLANES = PlaneCuts([[1.0, 0.2, 0.1], [-0.15, 1.0, 0.25], [0.2, -0.1, 1.0]], [0.1, -0.12, 0.15])


def measure_sphere(name, mesh, truth=SPHERE_PLANES):
    res, seconds = relaxed(mesh, truth.labels(mesh.element_centroids()))
    row, h = base_row(name, mesh, res, seconds)
    true, codes = truth.crossings
    to_true = lambda x: np.min(np.linalg.norm(x[:, None, :] - true[None], axis=2), axis=1)  # noqa: E731
    row.update(interfaces(res, h, truth.interface_distance, to_true, lambda a, b: bin(a ^ b).count("1") == 1))
    found, sets = found_junctions(res)
    t2f, f2t = match(found, sets, true, codes)
    t2f, f2t = t2f.max(initial=0) / h, f2t.max(initial=0) / h
    # exact patch areas on the polyhedral surface: code c maximises sum_i (+-1)(n_i . x - d_i)
    points, simplices, _ = mesh.level_set_complex(np.zeros(mesh.n_vertices))
    g = points @ truth.normals.T - truth.offsets
    signs = 2.0 * ((res.classes[:, None] >> np.arange(len(truth.offsets))) & 1) - 1
    exact = partition(points, simplices, g @ signs.T).region_measures()
    err = 100 * np.abs(res.region_measures() / exact - 1)
    row.update(junctions=f"{len(true)}/{len(found)}", true_to_found_h=t2f, found_to_true_h=f2t,
               measure_err_pct=err.max())  # fmt: skip
    return targets(row, res, ("interface mean / h", row["mean_h"], 0.12), ("every crossing found (max / h)", t2f, 0.5),
                   ("no spurious junction (max / h)", f2t, 1.0))  # fmt: skip


def measure_volume(name, mesh, sites):
    truth = VoronoiTruth(sites)
    res, seconds = relaxed(mesh, truth.labels(mesh.element_centroids()))
    row, h = base_row(name, mesh, res, seconds)
    to_edges = lambda x: np.min([truth.face_distance(x, S) for S in truth.triples], axis=0)  # noqa: E731
    row.update(interfaces(res, h, truth.interface_distance, to_edges, lambda a, b: truth.face((a, b)) is not None,
                          box_border))  # fmt: skip
    j = res.interfaces().junctions()
    dj, off = [], 0
    for regions in np.unique(j.regions, axis=0):
        mine = np.all(j.regions == regions, axis=1)
        x = j.points[j.simplices[mine]].reshape(-1, 3)
        dist = truth.junction_distance(x, res.classes[regions[regions >= 0]].tolist())
        if dist is None:  # no true edge for these regions: the nearest true edge at all
            off += int(mine.sum())
            dist = to_edges(x)
        dj.append(dist / h)
    dj = np.concatenate(dj) if dj else np.full(1, np.inf)
    edges = [truth.face_points(S) for S in truth.triples]
    samples = np.concatenate([e[0] + np.linspace(0, 1, max(2, int(np.linalg.norm(e[1] - e[0]) / (h / 4))))[:, None] *
                              (e[1] - e[0]) for e in edges])  # fmt: skip
    cover = 100 * float(np.mean(cKDTree(j.points).query(samples)[0] <= h)) if len(j.points) else 0.0
    err = 100 * np.abs(res.region_measures() / truth.exact_measures(mesh)[res.classes] - 1)
    row.update(junctions=f"{len(edges)}/{len(j)}", junction_curve_mean_h=dj.mean(), junction_curve_max_h=dj.max(),
               junction_simplices_off_triple=off, edge_cover_pct=cover, measure_err_pct=err.max())  # fmt: skip
    return targets(row, res, ("interface mean / h", row["mean_h"], 0.12), ("junction curve mean / h", dj.mean(), 0.5),
                   ("volume error %", err.max(), 1.0))  # fmt: skip


def speed_case(seed, n_regions):
    """The speed case's mesh (251 001 vertices) and its labels: the first ``n_regions`` of
    8 Voronoi sites."""
    mesh = kuhn_grid(500, 2, jitter=0.25, random_state=0)
    sites = np.random.default_rng(seed).uniform(-0.8, 0.8, (8, 2))
    return mesh, VoronoiTruth(sites[:n_regions]).labels(mesh.element_centroids())


def speed_one(seed, n_regions):
    """One cold relaxation (this process's first, on a fresh domain): relax seconds, and
    with ``interfaces().junctions()``; the mesh's construction is not timed."""
    mesh, labels = speed_case(seed, n_regions)
    t0 = time.perf_counter()
    res = relax(mesh, labels, on="elements")
    seconds = time.perf_counter() - t0
    res.interfaces().junctions()
    print(seconds, time.perf_counter() - t0)


def speed_warm(seed, pairs):
    """``pairs`` pairs of relaxations in this process, 2 regions then 8 and 8 then 2 in
    turn, each on a fresh mesh (no operators cached from the last), after one of each to
    warm up: the median of each side and its ratio, and each pair's ratio. The cold runs of
    :func:`speed` pay what a user's first call pays; these show the ratio without it, and,
    adjacent in time, less of the host's drift.
    """
    for L in (2, 8):
        relax(*speed_case(seed, L), on="elements")
    times = {2: [], 8: []}
    for k in range(pairs):
        for L in (2, 8) if k % 2 == 0 else (8, 2):
            mesh, labels = speed_case(seed, L)
            t0 = time.perf_counter()
            relax(mesh, labels, on="elements")
            times[L].append(time.perf_counter() - t0)
    each = np.array(times[8]) / np.array(times[2])
    med = {L: float(np.median(v)) for L, v in times.items()}
    print(f"speed, {pairs} warm pairs in one process: relax 2 regions {med[2]:.2f} s ({min(times[2]):.2f}-"
          f"{max(times[2]):.2f}), 8 regions {med[8]:.2f} s ({min(times[8]):.2f}-{max(times[8]):.2f}), ratio of the "
          f"medians {med[8] / med[2]:.2f}; pairs {np.round(each, 2).tolist()}", flush=True)  # fmt: skip
    row = {"bench": "regions", "case": "speed-warm", "pairs": pairs, "relax_2_s": times[2], "relax_8_s": times[8],
           "ratio": med[8] / med[2]}  # fmt: skip
    return targets(row, None, ("relax 8 regions / 2 regions, warm", row["ratio"], 3.0))


def _interface_fit_flag():
    """The command-line flags that fit a subprocess's interfaces as this process's are
    (``--no-interface-fit``, ``--soft-interfaces``)."""
    from ndboundary.pipeline import interface_fit

    flags = [] if interface_fit.INTERFACE_FIT else ["--no-interface-fit"]
    return flags + ([] if len(interface_fit.STIFFNESS) > 1 else ["--soft-interfaces"])


def speed(seed, repeats=3, fit=True, vertex_pins=False):
    print("speed: kuhn_grid(500, 2) (251 001 vertices); every timed relax is the first of a fresh process on a "
          "fresh domain: it pays the assembly and the loading of the compiled kernels, as a user's first call "
          "does (the imports and the mesh's construction are not timed)", flush=True)  # fmt: skip
    times = {(L, w): [] for L in (2, 8) for w in ("relax", "with_junctions")}
    for _ in range(repeats):
        for L in (2, 8):
            flags = ([] if fit else ["--no-junction-fit"]) + (["--vertex-pins"] if vertex_pins else [])
            flags += _interface_fit_flag()
            out = subprocess.run([sys.executable, __file__, "--speed-one", str(L), "--seed", str(seed), *flags],
                                 check=True, capture_output=True, text=True).stdout.split()  # fmt: skip
            times[L, "relax"].append(float(out[0]))
            times[L, "with_junctions"].append(float(out[1]))
    med = {f"{w}_{L}_s": float(np.median(v)) for (L, w), v in times.items()}
    ratio = med["relax_8_s"] / med["relax_2_s"]
    ratio_j = med["with_junctions_8_s"] / med["with_junctions_2_s"]
    print(f"speed: relax 2 regions {med['relax_2_s']:.2f} s, 8 regions {med['relax_8_s']:.2f} s, ratio {ratio:.2f} "
          f"(target <= 3); with interfaces().junctions() {med['with_junctions_2_s']:.2f} s / "
          f"{med['with_junctions_8_s']:.2f} s, ratio {ratio_j:.2f}", flush=True)  # fmt: skip
    row = {"bench": "regions", "case": "speed", "n_vertices": 251001, "repeats": repeats,
           **med, "ratio": ratio, "ratio_with_junctions": ratio_j}  # fmt: skip
    return targets(row, None, ("relax 8 regions / 2 regions", ratio, 3.0))


def image_y(seed, n=64, count=12):
    """Junctions of label images, relaxed and fitted to the labels: ``count`` Y's of three
    regions on ``n x n`` pixels, each centred within half a pixel of the image's centre and
    turned at random, its sectors 120 degrees give or take 15, and the Voronoi partition of
    24 random sites on 600 x 600 pixels; the distance (pixels) from each true junction to
    the nearest found one, with ``JUNCTION_FIT`` on (the default) and off."""
    from scipy.spatial import Voronoi, cKDTree

    from ndboundary import relax_image
    from ndboundary.pipeline import junctions

    rng = np.random.default_rng(seed)
    images = []
    for _ in range(count):
        centre = (n - 1) / 2 + rng.uniform(-0.5, 0.5, 2)
        spans = np.radians(120.0) + rng.uniform(-0.26, 0.26, 3)
        spans *= 2 * np.pi / spans.sum()
        turns = rng.uniform(0, 2 * np.pi) + np.concatenate([[0.0], np.cumsum(spans[:2])])
        x, y = np.meshgrid(np.arange(n) - centre[0], np.arange(n) - centre[1], indexing="ij")
        angle = (np.arctan2(y, x) - turns[0]) % (2 * np.pi)
        images.append((np.searchsorted((turns - turns[0]) % (2 * np.pi), angle, side="right") - 1, centre[None]))
    sites = rng.uniform(0, 600, (24, 2))
    voronoi = cKDTree(sites).query(np.indices((600, 600)).reshape(2, -1).T)[1].reshape(600, 600)
    true = Voronoi(sites).vertices
    voronoi_case = (voronoi, true[((true > 5) & (true < 594)).all(axis=1)])
    row = {"bench": "regions", "case": f"image Y {n}^2 x{count}, Voronoi 600^2 x24"}
    for fit in (True, False):
        junctions.JUNCTION_FIT = fit
        try:
            errors = []
            for labels, truth in [*images, voronoi_case]:
                j = relax_image(labels).interfaces().junctions()
                found = j.points[j.simplices[:, 0]]
                errors.append(np.linalg.norm(truth[:, None] - found[None], axis=2).min(axis=1))
        finally:
            junctions.JUNCTION_FIT = True
        y, v = np.concatenate(errors[:-1]), errors[-1]
        name = "fitted" if fit else "relaxed"
        row.update({f"y_{name}_mean_px": y.mean(), f"y_{name}_max_px": y.max(), f"voronoi_{name}_mean_px": v.mean(),
                    f"voronoi_{name}_max_px": v.max()})  # fmt: skip
        print(f"image junctions, {name}: Y {n}^2 x{count} mean {y.mean():.3f} max {y.max():.3f} px; Voronoi 600^2 "
              f"({v.size} junctions) mean {v.mean():.3f} max {v.max():.3f} px", flush=True)  # fmt: skip
    # the seconds of the Voronoi image's relax_image, then of its first interfaces(): each
    # the first of a fresh process, the fit on and off alternated, medians of 3
    times = {True: [], False: []}
    for _ in range(3):
        for fit in (True, False):
            flags = ([] if fit else ["--no-junction-fit"]) + _interface_fit_flag()
            out = subprocess.run([sys.executable, __file__, "--image-one", "--seed", str(seed), *flags],
                                 check=True, capture_output=True, text=True).stdout.split()  # fmt: skip
            times[fit].append([float(t) for t in out])
    for fit, name in ((True, "fitted"), (False, "relaxed")):
        relax_s, partition_s = np.median(times[fit], axis=0)
        row.update({f"voronoi_{name}_relax_s": relax_s, f"voronoi_{name}_partition_s": partition_s})
        print(f"image Voronoi 600^2, {name}: relax_image {relax_s:.2f} s, then interfaces() {partition_s:.2f} s "
              "(medians of 3 fresh processes)", flush=True)  # fmt: skip
    return targets(row, None)


def image_one(seed):
    """One cold relax_image of :func:`image_y`'s Voronoi image and its first interfaces():
    prints both seconds."""
    from scipy.spatial import cKDTree

    from ndboundary import relax_image

    rng = np.random.default_rng(seed)
    for _ in range(12):  # the Y's draws come first
        rng.uniform(-0.5, 0.5, 2), rng.uniform(-0.26, 0.26, 3), rng.uniform(0, 2 * np.pi)
    sites = rng.uniform(0, 600, (24, 2))
    image = cKDTree(sites).query(np.indices((600, 600)).reshape(2, -1).T)[1].reshape(600, 600)
    t0 = time.perf_counter()
    res = relax_image(image)
    t1 = time.perf_counter()
    res.interfaces()
    print(t1 - t0, time.perf_counter() - t1)

def image_many(seed, n=800, count=200, repeats=3):
    """The cost of the interfaces' fit on a label image of many regions: the Voronoi
    partition of ``count`` random sites on ``n x n`` pixels, its ``relax_image`` and first
    ``interfaces()`` each the first of a fresh process, with the interfaces' fit, with it
    and the softest prior alone (``--soft-interfaces``), and without it
    (``--no-interface-fit``), in turn, medians of ``repeats``."""
    variants = {"fitted": [], "fitted softest": ["--soft-interfaces"], "as relaxed": ["--no-interface-fit"]}
    times = {name: [] for name in variants}
    for _ in range(repeats):
        for name, flags in variants.items():
            out = subprocess.run([sys.executable, __file__, "--image-many-one", "--seed", str(seed), *flags],
                                 check=True, capture_output=True, text=True).stdout.split()  # fmt: skip
            times[name].append([float(t) for t in out])
    row = {"bench": "regions", "case": f"image Voronoi {n}^2 x{count}"}
    for name in variants:
        relax_s, partition_s = np.median(times[name], axis=0)
        row.update({f"{name.replace(' ', '_')}_relax_s": relax_s, f"{name.replace(' ', '_')}_partition_s": partition_s})
        print(f"image Voronoi {n}^2 x{count}, interfaces {name}: relax_image {relax_s:.2f} s, then interfaces() "
              f"{partition_s:.2f} s (medians of {repeats} fresh processes)", flush=True)  # fmt: skip
    return targets(row, None)


def image_arcs():
    """Curved interfaces of label images, fitted (the default), fitted with the softer
    curvature-change prior alone (``STIFFNESS = (BETA,)``) and as relaxed: two nested
    circles parting three regions on 96^2 pixels; a disc cut by a line through it (two
    T-junctions joined by arcs), and the distance of its junctions to the truth; a
    five-lobed flower cut by a line on 128^2 pixels (curved interfaces between junctions).
    Distances in pixels, mean / max."""
    from scipy.spatial import cKDTree

    from ndboundary import relax_image
    from ndboundary.pipeline import interface_fit

    def grid(n):
        return np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)

    centre, radii, g96 = np.array([47.3, 44.8]), (14.3, 31.6), grid(96)
    nested = np.searchsorted(radii, np.linalg.norm(g96 - centre, axis=1)).reshape(96, 96)
    u = np.array([np.cos(np.radians(70.0)), np.sin(np.radians(70.0))])
    normal, radius = np.array([-u[1], u[0]]), 27.6
    cut = np.where(np.linalg.norm(g96 - centre, axis=1) > radius, 1 + ((g96 - centre) @ normal > 0), 0)
    tees = np.array([centre + radius * u, centre - radius * u])
    flower_centre, g128 = np.array([63.3, 62.8]), grid(128)
    v = g128 - flower_centre
    petals = lambda t: 30.0 * (1.0 + 0.2 * np.cos(5.0 * t))  # noqa: E731
    inside = np.linalg.norm(v, axis=1) < petals(np.arctan2(v[:, 1], v[:, 0]))
    flower = np.where(inside, 0, np.where(v[:, 0] > 0.3 * v[:, 1], 1, 2)).reshape(128, 128)
    t = np.linspace(0.0, 2.0 * np.pi, 20000)
    outline = cKDTree(flower_centre + petals(t)[:, None] * np.stack([np.cos(t), np.sin(t)], axis=1))

    def faces_of(labels):
        faces = relax_image(labels).interfaces()
        return faces, faces.points[faces.simplices].mean(axis=1)

    def measure():
        faces, x = faces_of(nested)
        d_nested = np.abs(np.linalg.norm(x - centre, axis=1) - np.take(radii, faces.pairs.min(axis=1)))
        faces, x = faces_of(cut.reshape(96, 96))
        to_circle = np.abs(np.linalg.norm(x - centre, axis=1) - radius)
        d_cut = np.where(faces.pairs.min(axis=1) == 0, to_circle, np.abs((x - centre) @ normal))
        d_cut = d_cut[np.abs(x - 48).max(axis=1) < 46]  # away from the image's border
        j = faces.junctions()
        tee = np.linalg.norm(tees[:, None] - j.points[j.simplices[:, 0]][None], axis=2).min(axis=1)
        faces, x = faces_of(flower)
        d_flower = outline.query(x[faces.pairs.min(axis=1) == 0])[0]
        return {"nested": d_nested, "cut": d_cut, "tees": tee, "flower": d_flower}

    stiffness, fitting, rows = interface_fit.STIFFNESS, interface_fit.INTERFACE_FIT, {}
    try:
        for name, fit, stiff in (("fitted", True, stiffness), ("softer prior", True, (interface_fit.BETA,)),
                                 ("as relaxed", False, stiffness)):  # fmt: skip
            interface_fit.INTERFACE_FIT, interface_fit.STIFFNESS = fit, stiff
            m = measure()
            rows[name] = {k: [float(d.mean()), float(d.max())] for k, d in m.items()}
            print(f"image arcs, {name}: nested circles {m['nested'].mean():.3f} / {m['nested'].max():.3f} px; disc "
                  f"cut by a line {m['cut'].mean():.3f} / {m['cut'].max():.3f}, its junctions "
                  f"{np.round(m['tees'], 3).tolist()}; flower cut by a line {m['flower'].mean():.3f} / "
                  f"{m['flower'].max():.3f}", flush=True)  # fmt: skip
    finally:
        interface_fit.INTERFACE_FIT, interface_fit.STIFFNESS = fitting, stiffness
    return targets({"bench": "regions", "case": "image arcs", **rows}, None)


def image_many_one(seed, n=800, count=200):
    """One cold relax_image of :func:`image_many`'s image and its first interfaces():
    prints both seconds."""
    from scipy.spatial import cKDTree

    from ndboundary import relax_image

    sites = np.random.default_rng(seed).uniform(0, n, (count, 2))
    image = cKDTree(sites).query(np.indices((n, n)).reshape(2, -1).T)[1].reshape(n, n)
    t0 = time.perf_counter()
    res = relax_image(image)
    t1 = time.perf_counter()
    res.interfaces()
    print(t1 - t0, time.perf_counter() - t1)


def cases(args):
    rng = np.random.default_rng(args.seed)
    sites2, sites3 = rng.uniform(-0.8, 0.8, (args.sites, 2)), rng.uniform(-0.8, 0.8, (6, 3))
    tri = lambda n: kuhn_grid(n, 2, jitter=0.25, random_state=0)  # noqa: E731
    return {
        "plane-tri80": lambda: measure_plane("plane tri 80^2", tri(80), sites2),
        "plane-tri160": lambda: measure_plane("plane tri 160^2", tri(160), sites2),
        "plane-poly80": lambda: measure_plane("plane voronoi 80^2", voronoi_polygons(80, random_state=0), sites2),
        "y-tri80": lambda: measure_y("Y tri 80^2", tri(80)),
        "y-tri160": lambda: measure_y("Y tri 160^2", tri(160)),
        "y-poly80": lambda: measure_y("Y voronoi 80^2", voronoi_polygons(80, random_state=0)),
        "sphere-planes": lambda: measure_sphere("sphere 3 planes ico5", icosphere(5)),
        "volume-tet24": lambda: measure_volume(
            "volume tet 24^3", kuhn_grid(24, 3, jitter=0.25, random_state=0), sites3
        ),  # fmt: skip
        "volume-hex24": lambda: measure_volume("volume hex 24^3", hex_grid(24, jitter=0.25, random_state=0), sites3),
        "speed": lambda: speed(args.seed, fit=not args.no_junction_fit, vertex_pins=args.vertex_pins),
        "image-y": lambda: image_y(args.seed),
        "image-many": lambda: image_many(args.seed),
        "image-arcs": image_arcs,
    }


def draws(args):
    """The plane Voronoi cases (``--cases``, default all three) for ``args.draws`` draws of
    the sites: each target's median and worst value over the draws and how many pass,
    beside the oracle's area error (``mid%``), the labels' best estimate given the true lines.
    """
    meshes = {
        "plane-tri80": ("plane tri 80^2", lambda: kuhn_grid(80, 2, jitter=0.25, random_state=0)),
        "plane-tri160": ("plane tri 160^2", lambda: kuhn_grid(160, 2, jitter=0.25, random_state=0)),
        "plane-poly80": ("plane voronoi 80^2", lambda: voronoi_polygons(80, random_state=0)),
    }
    names = args.cases.split(",") if args.cases else list(meshes)
    unknown = [n for n in names if n not in meshes]
    if unknown:
        raise SystemExit(f"--draws measures {', '.join(meshes)}; not {unknown}")
    seeds = range(args.seed, args.seed + args.draws)
    print(f"{'case':22s} {'target':40s} {'median':>7s} {'worst':>7s} {'bound':>6s} {'passes':>7s}")
    for n in names:
        name, build = meshes[n]
        mesh, values = build(), {}
        for seed in seeds:
            sites = np.random.default_rng(seed).uniform(-0.8, 0.8, (args.sites, 2))
            row = measure_plane(name, mesh, sites)
            for t in row["targets"]:
                values.setdefault(t["target"], ([], t["bound"]))[0].append(t["value"])
            values.setdefault("oracle area error % (mid%)", ([], 0.5))[0].append(row["gap_midpoint_measure_err_pct"])
        for target, (v, bound) in values.items():
            v = np.asarray(v)
            print(f"{name:22s} {target:40s} {np.median(v):7.3f} {v.max():7.3f} {bound:6.2f} "
                  f"{int((v <= bound).sum()):3d}/{v.size}", flush=True)  # fmt: skip


def cell(row, key, width, fmt):
    v = row.get(key)
    if v is None:
        return f"{'-':>{width}s}"
    return f"{v:>{width}s}" if isinstance(v, str) else f"{v:{width}{fmt}}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=7, help="Voronoi sites of the plane cases")
    parser.add_argument("--seed", type=int, default=0, help="random state of the sites")
    parser.add_argument("--speed", action="store_true", help="add the speed case")
    parser.add_argument(
        "--speed-warm", type=int, metavar="PAIRS", help="the speed case's relaxations, warm, in PAIRS pairs in this process"
    )
    parser.add_argument("--speed-one", type=int, help=argparse.SUPPRESS)  # one cold relax of the speed case
    parser.add_argument("--image-one", action="store_true", help=argparse.SUPPRESS)  # one cold image of image-y
    parser.add_argument("--image-many-one", action="store_true", help=argparse.SUPPRESS)  # one of image-many
    parser.add_argument("--cases", default=None, help="comma-separated case names (default: every fidelity case)")
    parser.add_argument(
        "--independent",
        action="store_true",
        help="smooth every region's field as one (the independent one-vs-rest relaxations), not within sectors",
    )
    parser.add_argument(
        "--no-junction-fit",
        action="store_true",
        help="keep the junctions (points, curves and their corners) where the relaxed functions put them (not "
        "fitted to the labels)",
    )
    parser.add_argument(
        "--no-interface-fit",
        action="store_true",
        help="keep the interfaces of plane partitions as relaxed, and their junctions where the junctions' fit put "
        "them (not fitted with the interfaces to the labels' sites)",
    )
    parser.add_argument(
        "--soft-interfaces",
        action="store_true",
        help="fit every interface that a straight line does not part with the softest curvature-change prior alone, "
        "not the stiffest that parts its sites",
    )
    parser.add_argument(
        "--wide-margins",
        action="store_true",
        help="fit the interfaces of plane partitions with the widest soft minimum of their margins alone",
    )
    parser.add_argument(
        "--no-straight", action="store_true", help="no first rung holding the interfaces of plane partitions straight"
    )
    parser.add_argument(
        "--raw-start", action="store_true", help="fit the interfaces of plane partitions from their relaxed polylines"
    )
    parser.add_argument(
        "--draws",
        type=int,
        metavar="N",
        help="the plane Voronoi cases for N draws of the sites (seeds SEED, SEED + 1, ...): each target's median, "
        "worst and passes",
    )
    parser.add_argument(
        "--vertex-pins",
        action="store_true",
        help="hold phi at the jagged boundary's vertices on simplices, not at its facets' centres",
    )
    args = parser.parse_args()
    if args.no_junction_fit:
        from ndboundary.pipeline import junctions

        junctions.JUNCTION_FIT = False
    if args.no_interface_fit:
        from ndboundary.pipeline import interface_fit

        interface_fit.INTERFACE_FIT = False
    if args.soft_interfaces:
        from ndboundary.pipeline import interface_fit

        interface_fit.STIFFNESS = (interface_fit.BETA,)
    if args.wide_margins or args.no_straight or args.raw_start:
        from ndboundary.pipeline import interface_fit

        if args.wide_margins:
            interface_fit.TAUS = (interface_fit.TAU,)
        if args.no_straight:
            interface_fit.STRAIGHT = 0.0
        if args.raw_start:
            interface_fit.START_PASSES = 0
    if args.vertex_pins:
        from ndboundary.pipeline import boundary

        boundary.FACET_CENTRE_PINS = False
    if args.speed_one:
        speed_one(args.seed, args.speed_one)
        return
    if args.image_one:
        image_one(args.seed)
        return
    if args.image_many_one:
        image_many_one(args.seed)
        return
    if args.speed_warm:
        print_verdicts([speed_warm(args.seed, args.speed_warm)], 22, 58, "6.2f")
        return
    if args.independent:
        from ndboundary.pipeline import sectors

        sectors.SECTOR_SMOOTHING = False
    if args.draws:
        draws(args)
        return
    table = cases(args)
    apart = ("speed", "image-y", "image-many", "image-arcs")  # not by default, and not in the table
    names = args.cases.split(",") if args.cases else [n for n in table if n not in apart]
    if args.speed and "speed" not in names:
        names.append("speed")
    unknown = [n for n in names if n not in table]
    if unknown:
        parser.error(f"unknown cases {unknown}; choose from {', '.join(table)}")
    if any(n not in apart for n in names):
        print(f"{'case':22s} " + " ".join(f"{c:>{w}s}" for c, w, _, _ in COLUMNS), flush=True)
    rows = []
    for n in names:
        row = table[n]()
        rows.append(row)
        if n not in apart:
            print(f"{row['case']:22s} " + " ".join(cell(row, k, w, f) for _, w, f, k in COLUMNS), flush=True)
    print_verdicts(rows, 22, 58, "6.2f")


if __name__ == "__main__":
    main()
