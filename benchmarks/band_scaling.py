"""Cost follows the boundary, not the domain: relax time against the domain's size and zeta's length.

(a) A boundary of fixed length in cells on growing domains: ``kuhn_grid(n, 2,
    jitter=0.25)`` of [-1, 1]^2 with n = 499, 999 and 1999 (250K, 1M and 4M vertices),
    labelled by a circle of radius 100 cells about the centre. Target: the relaxation
    beyond the linear passes (locate: zeta and the band; fill: phi outside the band)
    grows by at most 1.5x from 250K to 4M.
(b) A fixed domain (n = 999, 1M vertices) and a boundary of growing length: the curve
    r = 0.5 (1 + 0.25 cos(k theta)) with k = 2, 4, 8 and 16 lobes. The time per
    boundary vertex stays about constant.

Every figure is the median of ``--repeats`` runs of a one-shot ``relax`` (nothing
kept) on a domain whose operators are not assembled, with the default ``band="auto"``;
beside it, for (a), the same relax with ``band=None`` on the smallest domain (the
whole-domain design the band replaces, measured in the same run).

Run::

    python benchmarks/band_scaling.py [--repeats 3] [--sizes 499,999,1999]

Prints two tables, then one JSON line per row.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from ndboundary import SimplicialComplex, relax
from ndboundary.datasets import kuhn_grid, label_by

BEYOND = ("pad", "heat", "field", "smoothing", "integration")


def lobes(k):
    """The curve r = 0.5 (1 + 0.25 cos(k theta)), as a sign function (negative inside)."""

    def truth(x):
        return np.hypot(x[:, 0], x[:, 1]) - 0.5 * (1 + 0.25 * np.cos(k * np.arctan2(x[:, 1], x[:, 0])))

    return truth


def timed(points, simplices, labels, repeats, band="auto"):
    """Median step times of ``repeats`` cold relaxations, and the last result's sizes."""
    runs = []
    for _ in range(repeats):
        domain = SimplicialComplex(points, simplices)  # fresh: nothing assembled or cached
        t0 = time.perf_counter()
        res = relax(domain, labels, on="elements", band=band)
        wall = time.perf_counter() - t0
        t = dict(res.timings)
        t["beyond"] = sum(t.get(s, 0.0) for s in BEYOND)
        t["wall"] = wall
        runs.append(t)
        n_sources, n_band = int(res.boundary.sources.size), int(res.params.get("band_vertices", domain.n_vertices))
        del res, domain
    med = {k: float(np.median([r.get(k, 0.0) for r in runs])) for k in runs[0]}
    return med, n_sources, n_band


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", default="499,999,1999", help="grid sizes n of (a)")
    ap.add_argument("--lobes", default="2,4,8,16", help="lobe counts k of (b)")
    ap.add_argument("--lobes-size", type=int, default=999, help="grid size n of (b)")
    args = ap.parse_args(argv)
    warm = kuhn_grid(40, 2)
    relax(warm, label_by(warm, lobes(3)), on="elements")  # compiled kernels loaded before timing
    rows = []
    print("(a) a circle of radius 100 cells on growing domains; seconds, medians of", args.repeats)
    print(f"{'verts':>9s} {'zeta':>6s} {'band':>8s} {'locate':>7s} {'beyond':>7s} {'fill':>7s} {'wall':>7s}")
    for n in (int(v) for v in args.sizes.split(",")):
        mesh = kuhn_grid(n, 2, jitter=0.25, random_state=0)
        r = 100 * 2.0 / n
        labels = label_by(mesh, lambda x, r=r: np.hypot(x[:, 0], x[:, 1]) - r)
        med, n_sources, n_band = timed(mesh.points, mesh.simplices, labels, args.repeats)
        row = {"bench": "band_scaling", "part": "fixed zeta", "n": n, "n_vertices": mesh.n_vertices,
               "zeta_vertices": n_sources, "band_vertices": n_band, **med}  # fmt: skip
        rows.append(row)
        print(f"{mesh.n_vertices:>9d} {n_sources:>6d} {n_band:>8d} {med['locate']:>7.3f} {med['beyond']:>7.3f} "
              f"{med['fill']:>7.3f} {med['wall']:>7.3f}", flush=True)
        if len(rows) == 1:
            whole, _, _ = timed(mesh.points, mesh.simplices, labels, args.repeats, band=None)
            row["whole_domain_wall"] = whole["wall"]
            print(f"{'':>9s} band=None on this domain: {whole['wall']:.3f} s "
                  f"({whole['wall'] / med['wall']:.1f}x the band)", flush=True)
        del mesh
    first, last = rows[0], rows[-1]
    growth = last["beyond"] / first["beyond"]
    print(f"  beyond the linear passes: x{growth:.2f} from {first['n_vertices']} to {last['n_vertices']} vertices "
          f"(target <= 1.5) {'PASS' if growth <= 1.5 else 'FAIL'}; the whole relax: x{last['wall'] / first['wall']:.2f}")

    print(f"\n(b) r = 0.5 (1 + 0.25 cos(k theta)) on kuhn_grid({args.lobes_size}, 2); seconds, medians of", args.repeats)
    print(f"{'k':>3s} {'zeta':>6s} {'band':>8s} {'locate':>7s} {'beyond':>7s} {'fill':>7s} {'wall':>7s} {'us/zeta':>8s}")
    mesh = kuhn_grid(args.lobes_size, 2, jitter=0.25, random_state=0)
    for k in (int(v) for v in args.lobes.split(",")):
        labels = label_by(mesh, lobes(k))
        med, n_sources, n_band = timed(mesh.points, mesh.simplices, labels, args.repeats)
        per = 1e6 * med["beyond"] / n_sources
        rows.append({"bench": "band_scaling", "part": "growing zeta", "n": args.lobes_size, "lobes": k,
                     "n_vertices": mesh.n_vertices, "zeta_vertices": n_sources, "band_vertices": n_band,
                     "beyond_us_per_zeta_vertex": per, **med})  # fmt: skip
        print(f"{k:>3d} {n_sources:>6d} {n_band:>8d} {med['locate']:>7.3f} {med['beyond']:>7.3f} {med['fill']:>7.3f} "
              f"{med['wall']:>7.3f} {per:>8.1f}", flush=True)
    print()
    for row in rows:
        print(json.dumps(row))


if __name__ == "__main__":
    main()
