"""The integration's factor built beside the heat, field and smoothing, against the factor
built in the solve, after them: ``relax`` wall times, alternated fresh processes.

Where the integration factorises its matrix (triangle meshes and surfaces), the factor
does not depend on the field, so the relaxation builds it on a second thread while the
heat, the field and the smoothing run (``IntegrationFactor``, returned by
``ndboundary.solvers.integration.integration_preconditioner``). The other way is the one
the solve takes without it: this benchmark makes ``integration_preconditioner`` return
None for the direct path in the processes that measure it. Each repeat runs every case
both ways, each in a fresh process whose first ``relax`` it times, cold as a user's first
call (the imports and the mesh's construction not timed), so that the drifts of a shared
machine hit both alike. Beside, the factor is PARDISO's where installed (its calls
release the GIL), of the upper triangle a compiled call assembles; in the solve it is
the fastest backend's (cvxopt's CHOLMOD): the two phi agree to the rounding of the two
factorisations (``tests``). For many regions, each region goes on while the previous
one's factor is built. This prints times only.

Cases:

- ``regions2``, ``regions8``: the speed case of ``regions.py`` (``kuhn_grid(500, 2,
  jitter=0.25)``, 251 001 vertices, 2 and 8 Voronoi regions, each relaxed on its band);
- ``flower``: ``kuhn_grid(250, 2, jitter=0.2)`` (63 001 vertices), a flower, ``band=None``;
- ``sphere``: ``icosphere(7)`` (163 842 vertices) cut by the plane z = 0.3, ``band=None``;
- ``image24``: ``relax_image`` of the Voronoi partition of 24 random sites on 600 x 600
  pixels, each region on its own band.

Usage::

    python benchmarks/factor_beside.py [--repeats 3] [--cases regions2,regions8,flower,sphere,image24]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np

CASES = ("regions2", "regions8", "flower", "sphere", "image24")


def one(case, beside):
    """Seconds of one ``relax`` of ``case`` in this process, the factor built beside or not."""
    from regions import speed_case

    from ndboundary import relax
    from ndboundary.datasets import flower, icosphere, kuhn_grid, label_by

    if not beside:
        import ndboundary.pipeline.integration as pipeline_integration
        from ndboundary.solvers.integration import IntegrationFactor, integration_preconditioner

        def in_the_solve(*args, **kwargs):
            built = integration_preconditioner(*args, **kwargs)
            return None if isinstance(built, IntegrationFactor) else built

        pipeline_integration.integration_preconditioner = in_the_solve
    if case == "image24":  # 24 Voronoi regions of a 600 x 600 label image, each on its band
        from scipy.spatial import cKDTree

        from ndboundary import relax_image

        pixels = np.indices((600, 600)).reshape(2, -1).T
        sites = np.random.default_rng(0).uniform(0, 600, (24, 2))
        image = cKDTree(sites).query(pixels)[1].reshape(600, 600)
        t0 = time.perf_counter()
        relax_image(image)
        return time.perf_counter() - t0
    band = "auto"
    if case.startswith("regions"):
        mesh, labels = speed_case(0, int(case[len("regions") :]))
    elif case == "flower":
        mesh = kuhn_grid(250, 2, jitter=0.2, random_state=0)
        labels, band = label_by(mesh, flower), None
    else:
        mesh = icosphere(7)
        labels, band = (mesh.element_centroids()[:, 2] > 0.3).astype(int), None
    t0 = time.perf_counter()
    relax(mesh, labels, on="elements", band=band)
    return time.perf_counter() - t0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--one", nargs=2, help=argparse.SUPPRESS)  # CASE beside|solve: one run, in this process
    args = ap.parse_args(argv)
    if args.one:
        print(one(args.one[0], args.one[1] == "beside"))
        return
    cases = args.cases.split(",")
    unknown = set(cases) - set(CASES)
    if unknown:
        ap.error(f"unknown cases {sorted(unknown)}; choose among {', '.join(CASES)}")
    times = {(c, w): [] for c in cases for w in ("beside", "solve")}
    for _ in range(args.repeats):
        for case in cases:
            for way in ("beside", "solve"):
                out = subprocess.run(
                    [sys.executable, __file__, "--one", case, way], check=True, capture_output=True, text=True
                )
                times[case, way].append(float(out.stdout.split()[-1]))
    row = {"bench": "factor_beside", "repeats": args.repeats}
    for case in cases:
        beside, solve = np.median(times[case, "beside"]), np.median(times[case, "solve"])
        print(
            f"{case:9s} factor beside {beside:6.3f} s ({min(times[case, 'beside']):.3f}-"
            f"{max(times[case, 'beside']):.3f}), in the solve {solve:6.3f} s ({min(times[case, 'solve']):.3f}-"
            f"{max(times[case, 'solve']):.3f}), ratio {beside / solve:.2f}",
            flush=True,
        )
        row[case] = {"beside_s": float(beside), "solve_s": float(solve), "ratio": float(beside / solve)}
    print(json.dumps(row))


if __name__ == "__main__":
    main()
