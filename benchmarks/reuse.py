"""Reuse between relaxations of one domain: ``Relaxer(domain).relax`` twice on a geodesic sphere.

The first call computes everything: the jagged boundary, the band and its padded
domain, the heat and the field, and the factorisation of the integration system. The
second call raises the number of smoothing passes (more passes keep the band's width:
fewer widen it, and then the band is built again): the relaxer reuses the band, its
padded operators, the heat and field, and (the integration matrix being the same) the
factor, so that it costs the smoothing and a back-substitution. ``ndboundary.relax``
keeps nothing between calls: every one of its calls costs as much as the first here.

Usage::

    python benchmarks/reuse.py [--freq 158]      # 158: 250K vertices

Prints one line per call (total and integration time, the integration solver's method)
and the speed-up of the second over the first; then a third call with another labelling
(z > 0.2) against a one-shot ``relax`` of it on the same domain.
"""

from __future__ import annotations

import argparse
import time

from table1 import geodesic_sphere

import ndboundary as nb


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--freq", type=int, default=158, help="geodesic frequency (158: 250K vertices)")
    ap.add_argument("--smoothing", type=int, default=100, help="smoothing passes of the second call (default 100)")
    args = ap.parse_args(argv)
    pts, T = geodesic_sphere(args.freq)
    dom = nb.SimplicialComplex(pts, T)
    labels = (dom.element_centroids()[:, 2] > 0.3).astype(int)
    print(f"{dom.n_vertices} vertices")
    relaxer = nb.Relaxer(dom)
    totals = []
    for name, kwargs in [("first call", {}), (f"{args.smoothing} passes", {"smoothing": args.smoothing})]:
        t0 = time.perf_counter()
        res = relaxer.relax(labels, on="elements", **kwargs)
        totals.append(time.perf_counter() - t0)
        info = res.solver["integration"]
        print(f"{name:<14s} total {totals[-1]:6.2f} s  integration {res.timings['integration']:6.2f} s "
              f"({info.method})")
    print(f"second call / first call: {totals[1] / totals[0]:.3f} (speed-up {totals[0] / totals[1]:.1f}x); "
          f"kept {relaxer.nbytes / 2**20:.0f} MB")
    # another labelling: the relaxer against a one-shot relax on a domain whose own
    # operators (edges, incidence) are already built
    other = (dom.element_centroids()[:, 2] > 0.2).astype(int)
    t0 = time.perf_counter()
    relaxer.relax(other, on="elements")
    kept = time.perf_counter() - t0
    t0 = time.perf_counter()
    nb.relax(dom, other, on="elements")
    one_shot = time.perf_counter() - t0
    print(f"another labelling (z > 0.2): {kept:.2f} s with the relaxer, {one_shot:.2f} s one-shot "
          f"({one_shot / kept:.2f}x)")


if __name__ == "__main__":
    main()
