"""Label images and volumes: ``relax_image``'s defaults against exact truths and peers.

The peers run in the same process on the same voxels. Every truth is voxelised by voxel
centre (``origin + index * spacing``); shapes, truths and peers are in
``images_truths.py``. Distances are in voxels (units of the smallest
spacing), measured at the vertices and simplex centroids of each surface
(``ndboundary.metrics.sample_points``) against the exact distance to the true boundary.

Cases (``--cases``, comma separated; default ``ball64,torus64,flower2d,y2d``, about a
minute; ``--all`` for every case):

- ``ball64``, ``ball128``: a ball of radius 0.32 n, its centre off the grid's symmetry (at
  128^3 its +y pole lies on a plane of voxel centres: the mask leaves it a voxel's play).
- ``torus64``, ``torus128``: a tilted torus of radii 0.25 n and 0.11 n.
- ``blob64``, ``blob128``: a sphere of radius 0.29 n whose radius is perturbed by five
  spherical harmonics of degrees 2 and 3 (radius 0.61 to 1.41 times 0.29 n).
- ``flower2d``: a 5-lobed flower ``r = 0.3 n (1 + 0.2 cos 5 theta)`` on 128^2 pixels.
- ``y2d``: three regions bounded by circular arcs meeting at 120 degrees
  (``regions_truths.YTruth``) on 128^2 pixels covering [-1, 1]^2.
- ``voronoi64``: the Voronoi partition of 6 random sites of [-0.8, 0.8]^3 on 64^3
  voxels covering [-1, 1]^3; per-region volumes against the exact ones (the partition of
  the grid's simplicial refinement by the sites' linear functions, exact). The sites are
  drawn with seed 0; ``--seeds K`` adds the draws of seeds 1 to K - 1, each case of its own.
- ``aniso``: the ball of ``ball64`` on 64 x 64 x 22 voxels of spacing (1, 1, 3).
- ``--prostate``: ``../shared/data/volumes/prostate_mask_00.nii`` (320 x 320 x 15
  voxels, labels 0, 1, 2, spacing 0.6 x 0.6 x 4 mm; ~2.5 min) end to end: each region's
  volume change against its voxel count, whether its boundary is closed, its smoothness
  beside the staircase's and the peers', and how far it strays from the staircase (mm).
  Skipped when the file is absent.

Measures: ``mean``, 99th percentile, ``max`` distance; ``vol%`` = |relaxed measure /
true - 1| (a partition: the largest over its regions); ``area%`` = |surface measure /
true area - 1| (a partition: of the total interface measure, ours only; the JSON adds
each interface's signed error, large on small facets, between which the junctions shift
area); in 2-D "volume" is area and "area" length. ``|H|h``, smoothness (3-D): the
discrete mean curvature ``sum(dihedral angle * edge length) / (2 area)`` in units of 1 / h
(a ball's truth: h / R; it hardly depends on the triangles' size, unlike the mean
dihedral angle, which the prostate's table adds). ``s``: seconds; ours = ``relax_image``,
the surface and the region measures. Partitions: every method is measured on each
region's boundary against the region's true boundary, at the points farther than one
voxel from the image border (along which the peers' closed surfaces run).

Peers (on the mask padded by one background voxel, so that every surface closes; volume
= the measure it encloses; a partition's peers run once per region): scikit-image
``marching_cubes`` (2-D ``find_contours``) at 0.5 on the mask and on the mask smoothed by
a Gaussian of sigma 1 voxel; VTK ``vtkSurfaceNets3D`` (2-D ``vtkSurfaceNets2D``) with its
default smoothing; 3-D only, 3D Slicer's recipe (``vtkDiscreteFlyingEdges3D``, then
``vtkWindowedSincPolyDataFilter``, 20 iterations, pass band 10^(-4 x 0.5) = 0.01 for the
default smoothing factor 0.5, as Slicer's ``vtkBinaryLabelmapToClosedSurfaceConversionRule``
does). ``staircase``: the voxel faces (information, not a peer).

Targets: mean <= 0.05, max <= 0.25, vol% <= 0.3, area% <= 0.5 (``aniso``: 0.15, 0.6,
0.5, 1.0; the prostate: each labelled region's volume change <= 1 %), and ours below
every peer in both mean distance and vol%.

Usage::

    .venv/bin/python benchmarks/images.py                    # default cases
    .venv/bin/python benchmarks/images.py --cases ball128,torus128,blob128
    .venv/bin/python benchmarks/images.py --all --prostate   # everything, ~15 min
    .venv/bin/python benchmarks/images.py --all --no-fit         # two-region boundaries as relaxed
    .venv/bin/python benchmarks/images.py --cases voronoi64 --seeds 8   # 8 draws of the sites

Needs scikit-image and vtk (and, without ``ndboundary.read_image``, nibabel). Prints a
table, the targets (PASS / FAIL), then one JSON line per case.
"""

from __future__ import annotations

import argparse
import functools
import os
import time

import numpy as np
from images_truths import PEERS, Ball, StarShape, Torus, YAreas, blob_terms, run_peer, staircase
from regions_truths import VoronoiTruth, YTruth
from verdicts import print_verdicts

from ndboundary import ImageGrid, relax_image
from ndboundary.metrics import as_complex, level_set_distance, sample_points

PROSTATE = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data", "volumes", "prostate_mask_00.nii")


def centres(shape, spacing, origin):
    axes = [o + s * np.arange(n) for n, s, o in zip(shape, spacing, origin, strict=True)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(shape))


def smoothness(points, tris):
    """``angle_deg``, ``H``: the mean angle (degrees) between the normals of
    triangles sharing an edge, over the edges shared by exactly two non-degenerate
    triangles (orientation ignored), and ``sum(angle * edge length) / (2 * area)``, the
    discrete mean curvature |H| averaged over the surface, which depends far less on the
    triangles' size (a sphere's is 1 / R; a staircase's is pi / 4 times its edge length
    per area)."""
    p = points[tris]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    norm = np.linalg.norm(n, axis=1)
    good = norm > 1e-12 * max(1.0, float(norm.max(initial=0)))
    n = n[good] / norm[good, None]
    t = tris[good]
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(len(t)), 3)
    uniq, inv, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    two = counts[inv] == 2
    order = np.argsort(inv[two], kind="stable")
    pairs = owner[two][order].reshape(-1, 2)
    length = np.linalg.norm(np.diff(points[uniq[np.sort(inv[two])[::2]]], axis=1)[:, 0], axis=1)
    angle = np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", n[pairs[:, 0]], n[pairs[:, 1]])), 0.0, 1.0))
    return {"angle_deg": float(np.degrees(angle).mean()), "H": float((angle * length).sum() / norm.sum())}


def stats(d):
    if not d.size:
        return {"mean": np.nan, "p99": np.nan, "max": np.nan}
    return {"mean": float(d.mean()), "p99": float(np.percentile(d, 99)), "max": float(d.max())}


# --------------------------------------------------------------------------- two labels


def binary_case(name, truth, shape, spacing, origin, bounds):
    h = min(spacing)
    mask = truth.inside(centres(shape, spacing, origin)).reshape(shape)
    t0 = time.perf_counter()
    res = relax_image(mask, spacing=spacing, origin=origin, fit=FIT)
    relax_s = time.perf_counter() - t0
    surf = res.level_set()
    inside = int(np.flatnonzero(res.classes == True)[0])  # noqa: E712
    volume = float(res.region_measures()[inside])
    seconds = time.perf_counter() - t0
    methods = {"ours": {**stats(truth.distance(sample_points(surf)) / h), "s": seconds, "relax_s": relax_s,
                        "vol_pct": 100 * abs(volume / truth.volume - 1),
                        "area_pct": 100 * abs(surf.measure() / truth.area - 1),
                        "closed": surf.is_closed(), "components": surf.n_components()}}  # fmt: skip
    sets = {"ours": surf}
    for peer in PEERS if len(shape) == 3 else [p for p in PEERS if p != "slicer recipe"]:
        ls, vol, s = run_peer(peer, mask, spacing, origin)
        sets[peer] = ls
        methods[peer] = {**stats(truth.distance(sample_points(ls)) / h), "vol_pct": 100 * abs(vol / truth.volume - 1),
                         "area_pct": 100 * abs(ls.measure() / truth.area - 1), "s": s,
                         "closed": ls.is_closed()}  # fmt: skip
    sets["staircase"] = stair = as_complex(*staircase(mask, spacing, origin))
    methods["staircase"] = {**stats(truth.distance(sample_points(stair)) / h),
                            "vol_pct": 100 * abs(mask.sum() * np.prod(spacing) / truth.volume - 1),
                            "area_pct": 100 * abs(stair.measure() / truth.area - 1), "s": np.nan}  # fmt: skip
    for m, ls in sets.items():  # 3-D: the discrete mean curvature, in units of 1 / h
        methods[m]["H_h"] = smoothness(ls.points, ls.simplices)["H"] * h if len(shape) == 3 else None
    row = {"bench": "images", "case": name, "shape": list(shape), "spacing": list(spacing),
           "true_volume": truth.volume, "true_area": truth.area, "methods": methods}  # fmt: skip
    return with_targets(row, bounds)


def with_targets(row, bounds):
    mean_b, max_b, vol_b, area_b = bounds
    ours, items = row["methods"]["ours"], []
    items += [("mean distance", ours["mean"], mean_b), ("max distance", ours["max"], max_b),
              ("|volume error| %", ours["vol_pct"], vol_b)]  # fmt: skip
    if ours.get("area_pct") is not None:
        items.append(("|area error| %", ours["area_pct"], area_b))
    for peer, m in row["methods"].items():
        if peer in PEERS:
            items.append((f"mean below {peer} ({m['mean']:.3f})", ours["mean"], m["mean"]))
            items.append((f"vol% below {peer} ({m['vol_pct']:.3f})", ours["vol_pct"], m["vol_pct"]))
    row["targets"] = [{"target": t, "value": float(v), "bound": float(b), "pass": bool(v <= b)} for t, v, b in items]
    return row


# --------------------------------------------------------------------------- partitions


def partition_case(name, labels_of, boundary_distance, exact_volumes, exact_interfaces, n, dim, bounds):
    """A partition of ``[-1, 1]^dim`` on ``n^dim`` voxels."""
    h = 2.0 / n
    shape, spacing, origin = (n,) * dim, (h,) * dim, (-1 + h / 2,) * dim
    labels = labels_of(centres(shape, spacing, origin)).reshape(shape)
    t0 = time.perf_counter()
    res = relax_image(labels, spacing=spacing, origin=origin)
    relax_s = time.perf_counter() - t0
    measures = res.region_measures()
    bounds_r = [res.region_boundary(r) for r in range(res.classes.size)]
    seconds = time.perf_counter() - t0
    exact = exact_volumes(res, ImageGrid(shape, spacing=spacing, origin=origin))  # res.domain may be a band
    faces = res.interfaces()
    fm = faces.simplex_measures()
    pair_area = {p: float(fm[np.all(np.sort(faces.pairs, axis=1) == p, axis=1)].sum()) for p in exact_interfaces}
    total_true = sum(exact_interfaces.values())

    def far(x):
        return np.min(1.0 - np.abs(x), axis=1) > h

    def dist(ls_of_region):
        d = []
        for r, ls in ls_of_region:
            x = sample_points(ls)
            x = x[far(x)]
            d.append(boundary_distance(x, int(res.classes[r])) / h)
        return np.concatenate(d)

    methods = {"ours": {**stats(dist(enumerate(bounds_r))), "s": seconds, "relax_s": relax_s,
                        "vol_pct": float(np.max(100 * np.abs(measures / exact - 1))),
                        "area_pct": 100 * abs(sum(pair_area.values()) / total_true - 1),
                        "interface_area_pct": {f"{a}-{b}": 100 * (pair_area[a, b] / t - 1)
                                               for (a, b), t in exact_interfaces.items()},
                        "closed": [b.is_closed() for b in bounds_r]}}  # fmt: skip
    for peer in PEERS if dim == 3 else [p for p in PEERS if p != "slicer recipe"]:
        out = [run_peer(peer, labels == c, spacing, origin) for c in res.classes]
        vols = np.array([o[1] for o in out])
        methods[peer] = {**stats(dist([(r, o[0]) for r, o in enumerate(out)])), "s": sum(o[2] for o in out),
                         "vol_pct": float(np.max(100 * np.abs(vols / exact - 1))), "area_pct": None}  # fmt: skip
    counts = np.array([(labels == c).sum() for c in res.classes]) * h**dim
    methods["staircase"] = {"mean": np.nan, "p99": np.nan, "max": np.nan, "s": np.nan, "area_pct": None,
                            "vol_pct": float(np.max(100 * np.abs(counts / exact - 1)))}  # fmt: skip
    row = {"bench": "images", "case": name, "shape": list(shape), "spacing": list(spacing),
           "n_regions": int(res.classes.size), "exact_volumes": exact.tolist(), "methods": methods}  # fmt: skip
    return with_targets(row, bounds)


def y_case(n, bounds):
    y = YTruth()
    ya = YAreas(y)
    interfaces = {tuple(sorted(p)): ya.lengths[YTruth.arc_of(*p)] for p in ((0, 1), (1, 2), (0, 2))}
    return partition_case(f"Y 2-D {n}^2", y.labels, ya.boundary_distance, lambda res, grid: ya.areas[res.classes],
                          interfaces, n, 2, bounds)  # fmt: skip


def voronoi_case(n, bounds, seed=0):
    truth = VoronoiTruth(np.random.default_rng(seed).uniform(-0.8, 0.8, (6, 3)))
    interfaces = {}
    for a in range(6):
        for b in range(a + 1, 6):
            f = truth.face((a, b))
            if f is not None:  # the facet's polygon in its plane's orthonormal coordinates
                x, y = f[2][:, 0], f[2][:, 1]
                interfaces[(a, b)] = abs(float((x * np.roll(y, -1) - np.roll(x, -1) * y).sum()) / 2)
    exact = lambda res, grid: truth.exact_measures(grid)[res.classes]  # noqa: E731
    name = f"voronoi 6 sites {n}^3" + (f" #{seed}" if seed else "")
    return partition_case(name, truth.labels, truth.boundary_distance, exact, interfaces, n, 3,
                          bounds)  # fmt: skip


# --------------------------------------------------------------------------- cases

ISO, ANISO = (0.05, 0.25, 0.3, 0.5), (0.15, 0.6, 0.5, 1.0)
FIT = "auto"  # relax_image's fit of two-region boundaries (--no-fit: False)


def iso(n, dim=3):
    return (n,) * dim, (1.0,) * dim, (-(n - 1) / 2,) * dim


def off(n, dim=3):
    return np.array([0.17, -0.23, 0.31][:dim]) * n / 64


def cases():
    ball = lambda n: binary_case(f"ball {n}^3", Ball(off(n), 0.32 * n), *iso(n), ISO)  # noqa: E731
    torus = lambda n: binary_case(f"torus {n}^3", Torus(off(n), 0.25 * n, 0.11 * n), *iso(n), ISO)  # noqa: E731
    blob = lambda n: binary_case(f"blob {n}^3", StarShape(off(n), 0.29 * n, blob_terms()), *iso(n), ISO)  # noqa: E731
    return {
        "ball64": lambda: ball(64), "torus64": lambda: torus(64), "blob64": lambda: blob(64),
        "ball128": lambda: ball(128), "torus128": lambda: torus(128), "blob128": lambda: blob(128),
        "flower2d": lambda: binary_case("flower 2-D 128^2", StarShape(off(128, 2), 0.3 * 128), *iso(128, 2), ISO),
        "y2d": lambda: y_case(128, ISO),
        "voronoi64": lambda: voronoi_case(64, ISO),
        "aniso": lambda: binary_case("ball 64x64x22 (1,1,3)", Ball(off(64), 0.32 * 64), (64, 64, 22), (1.0, 1.0, 3.0),
                                     (-31.5, -31.5, -31.5), ANISO),
    }  # fmt: skip


DEFAULT = ["ball64", "torus64", "flower2d", "y2d"]


# --------------------------------------------------------------------------- prostate


def read_labels(path):
    """``(labels, spacing, origin)``: ``ndboundary.read_image(oblique=True)`` when it exists,
    else nibabel (the header's zooms, the affine's translation); an oblique file's rotation
    is left out: volumes, closedness and angles do not depend on it."""
    try:
        from ndboundary import read_image
    except ImportError:
        import nibabel

        img = nibabel.load(path)
        zooms = tuple(float(z) for z in img.header.get_zooms()[:3])
        return np.asarray(img.dataobj), zooms, tuple(float(v) for v in img.affine[:3, 3])
    img = read_image(path, oblique=True)
    return np.asarray(img.labels), tuple(img.spacing), tuple(img.origin)


def prostate(path=PROSTATE):
    if not os.path.exists(path):
        print(f"prostate: {path} is absent, skipped", flush=True)
        return None
    t0 = time.perf_counter()
    labels, spacing, origin = read_labels(path)
    read_s = time.perf_counter() - t0
    voxel = float(np.prod(spacing))
    print(f"prostate: {labels.shape} voxels, spacing {tuple(round(s, 4) for s in spacing)}, labels "
          f"{np.unique(labels).tolist()}; relaxing (about 2 minutes) ...", flush=True)  # fmt: skip
    t0 = time.perf_counter()
    res = relax_image(labels, spacing=spacing, origin=origin)
    relax_s = time.perf_counter() - t0
    measures = res.region_measures()
    measures_s = time.perf_counter() - t0 - relax_s
    boundaries = [res.region_boundary(r) for r in range(res.classes.size)]
    total_s = time.perf_counter() - t0
    regions, items = [], []
    for r, c in enumerate(res.classes):
        mask, b = labels == c, boundaries[r]
        count = float(mask.sum() * voxel)
        touches = any(np.take(mask, i, axis=a).any() for a in range(3) for i in (0, -1))
        reg = {"label": int(c), "voxels": int(mask.sum()), "voxel_volume": count, "touches_border": touches,
               "ours": {"volume": float(measures[r]), "change_pct": 100 * (measures[r] / count - 1),
                        "closed": b.is_closed(), "components": b.n_components(), "area": b.measure(),
                        **smoothness(b.points, b.simplices)}}  # fmt: skip
        if int(c) != 0:  # the background's boundary is the others'
            sp, st = staircase(mask, spacing, origin)
            d = level_set_distance(b, as_complex(sp, st))
            reg["ours"].update(to_staircase_max_mm=float(d.max()), to_staircase_p99_mm=float(np.percentile(d, 99)))
            reg["staircase"] = {"volume": count, "change_pct": 0.0, "area": as_complex(sp, st).measure(),
                                **smoothness(sp, st)}  # fmt: skip
            for peer in PEERS:
                ls, vol, sec = run_peer(peer, mask, spacing, origin)
                reg[peer] = {"volume": vol, "change_pct": 100 * (vol / count - 1), "closed": ls.is_closed(),
                             "components": ls.n_components(), "area": ls.measure(), "s": sec,
                             **smoothness(ls.points, ls.simplices)}  # fmt: skip
            items.append((f"label {int(c)} |volume change| % vs voxel count", abs(reg["ours"]["change_pct"]), 1.0))
        regions.append(reg)
    row = {"bench": "images", "case": "prostate", "shape": list(labels.shape), "spacing": list(spacing),
           "read_s": read_s, "relax_s": relax_s, "region_measures_s": measures_s, "total_s": total_s,
           "regions": regions}  # fmt: skip
    row["targets"] = [{"target": t, "value": float(v), "bound": float(b), "pass": bool(v <= b)} for t, v, b in items]
    return row


def print_prostate(row):
    print(f"\nprostate: read {row['read_s']:.2f} s, relax_image {row['relax_s']:.1f} s, region_measures "
          f"{row['region_measures_s']:.1f} s, region boundaries and relax: {row['total_s']:.1f} s")  # fmt: skip
    print(f"{'label':>5s} {'method':16s} {'voxels':>8s} {'mm3':>10s} {'chg%':>7s} {'closed':>6s} {'comp':>4s} "
          f"{'angle':>6s} {'|H| mm-1':>8s} {'s':>6s}")  # fmt: skip
    for g in row["regions"]:
        for m, v in g.items():
            if isinstance(v, dict):
                print(f"{g['label']:5d} {m:16s} {g['voxels']:8d} {v['volume']:10.1f} {v['change_pct']:+7.3f} "
                      f"{str(v.get('closed', '-')):>6s} {v.get('components', '-'):>4} {v['angle_deg']:6.2f} "
                      f"{v['H']:8.4f} {fmt(v.get('s'), (6, '.2f'))}")  # fmt: skip
        if "to_staircase_max_mm" in g["ours"]:
            o = g["ours"]
            print(f"{'':5s} ours to the staircase: max {o['to_staircase_max_mm']:.2f} mm, 99th percentile "
                  f"{o['to_staircase_p99_mm']:.2f} mm; touches the image border: {g['touches_border']}")  # fmt: skip


# --------------------------------------------------------------------------- main


def fmt(v, spec):
    return f"{'-':>{spec[0]}s}" if v is None or (isinstance(v, float) and np.isnan(v)) else f"{v:{spec[0]}{spec[1]}}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    table = cases()
    parser.add_argument("--cases", default=None, help=f"comma separated, from {', '.join(table)}")
    parser.add_argument("--all", action="store_true", help="every synthetic case")
    parser.add_argument("--prostate", action="store_true", help="add the prostate label volume")
    parser.add_argument("--no-fit", action="store_true", help="two-region boundaries as relaxed (fit=False)")
    parser.add_argument("--seeds", type=int, default=1, help="run voronoi64 on the sites of seeds 0 to SEEDS - 1")
    args = parser.parse_args()
    global FIT
    FIT = not args.no_fit and "auto"
    names = list(table) if args.all else (args.cases.split(",") if args.cases else ([] if args.prostate else DEFAULT))
    unknown = [n for n in names if n not in table]
    if unknown:
        parser.error(f"unknown cases {unknown}; choose from {', '.join(table)}")
    rows = []
    if names:
        heads = " ".join(f"{c:>7s}" for c in ("mean", "p99", "max", "vol%", "area%"))
        print(f"{'case':24s} {'method':16s} {heads} {'|H|h':>6s} {'s':>7s}", flush=True)
    jobs = [table[n] for n in names]
    if "voronoi64" in names and args.seeds > 1:
        at = names.index("voronoi64") + 1
        jobs[at:at] = [functools.partial(voronoi_case, 64, ISO, seed=s) for s in range(1, args.seeds)]
    for job in jobs:
        row = job()
        rows.append(row)
        for m, v in row["methods"].items():
            cells = [fmt(v[k], (7, ".3f")) for k in ("mean", "p99", "max", "vol_pct", "area_pct")]
            H, sec = fmt(v.get("H_h"), (6, ".3f")), fmt(v["s"], (7, ".2f"))
            print(f"{row['case']:24s} {m:16s} {' '.join(cells)} {H} {sec}", flush=True)
    if args.prostate:
        row = prostate()
        if row is not None:
            rows.append(row)
            print_prostate(row)
    print_verdicts(rows, 24, 44, "8.3f")


if __name__ == "__main__":
    main()
