"""Reuse of the integration factorisation: four relaxations on one geodesic sphere.

The first relax factorises the integration system; the second changes only the number
of smoothing passes (same matrix: the cached factor is reused); the third changes lam
and the fourth the labelling (new matrices: new factorisations).

Usage::

    python benchmarks/reuse.py [--freq 158]      # 158: 250K vertices

Prints one line per run and the speed-up of each over the first.
"""

from __future__ import annotations

import argparse
import time

from table1 import geodesic_sphere

import ndboundary as nb


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--freq", type=int, default=158, help="geodesic frequency (158: 250K vertices)")
    args = ap.parse_args(argv)
    pts, T = geodesic_sphere(args.freq)
    dom = nb.SimplicialComplex(pts, T)
    c = dom.element_centroids()
    runs = [
        ("z > 0.3", c[:, 2] > 0.3, {}),
        ("z > 0.3, 20 passes", c[:, 2] > 0.3, {"smoothing": 20}),
        ("z > 0.3, lam 4", c[:, 2] > 0.3, {"lam": 4.0}),
        ("x > 0.1", c[:, 0] > 0.1, {}),
    ]
    print(f"{dom.n_vertices} vertices")
    first = None
    for name, labels, kwargs in runs:
        t0 = time.perf_counter()
        res = nb.relax(dom, labels.astype(int), on="elements", **kwargs)
        total = time.perf_counter() - t0
        first = first or total
        print(f"{name:<20s} total {total:6.2f} s  integration {res.timings['integration']:6.2f} s  "
              f"speed-up over the first {first / total:4.1f}x")


if __name__ == "__main__":
    main()
