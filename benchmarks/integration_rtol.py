"""How far the integration's tolerance moves the level set, on every kind of mesh.

``relax`` solves the heat to ``rtol`` (default 1e-7) and the squared-Laplacian
integration to ``ndboundary.pipeline.params.integration_rtol(rtol)`` (default 1e-5).
For each case this relaxes the same labels three times, the integration solved to that
default, to the heat's ``rtol`` and to 1e-10 (the heat unchanged), and prints the largest
and mean change of phi near the level set (``|phi - 1/2| < 1``, in units of ``h``: phi
grows by about one per ``h`` there, so this is how far the level set moves), with the
integration's iterations and seconds (after a first run, which pays for the memory it
touches first).

Cases: triangles (``kuhn_grid(200, 2)``, a circle: a direct solve), a sphere
(``icosphere(6)`` cut by a plane), Voronoi polygons (``voronoi_polygons(120)``, a
circle), tetrahedra (``kuhn_grid(40, 3)``, a ball), hexahedra (``hex_grid(40)``, a
ball), a voxel ball (``relax_image`` on 96^3 voxels, the ball of ``images_speed.py``) and a
ball on thick slices (40 x 40 x 10 voxels of 0.6 x 0.6 x 4 mm, as a prostate scan's).

Usage::

    python benchmarks/integration_rtol.py
    python benchmarks/integration_rtol.py --cases voxels96 --also 1e-4,1e-3
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import ndboundary.pipeline.params as params
import ndboundary.pipeline.relaxer as relaxer
from ndboundary import relax, relax_image
from ndboundary.datasets import ball, circle, hex_grid, icosphere, kuhn_grid, label_by, voronoi_polygons


def _voxel_ball(n):
    x = np.indices((n, n, n)).reshape(3, -1).T - (n - 1) / 2 - np.array([0.17, -0.23, 0.31]) * n / 64
    return (np.linalg.norm(x, axis=1) < 0.32 * n).reshape(n, n, n)


def cases():
    def mesh_case(domain, labels):
        return lambda: relax(domain, labels, on="elements")

    tri = kuhn_grid(200, 2, jitter=0.25, random_state=0)
    sphere = icosphere(6)
    poly = voronoi_polygons(120, random_state=0)
    tet = kuhn_grid(40, 3, jitter=0.25, random_state=0)
    hexa = hex_grid(40, jitter=0.2, random_state=0)
    cut = (sphere.element_centroids() @ np.array([0.3, 0.5, 0.81]) > 0.2).astype(int)
    voxels = _voxel_ball(96)
    i, j, k = np.indices((40, 40, 10))
    slices = np.linalg.norm(np.stack([(i - 19.3) * 0.6, (j - 19.6) * 0.6, (k - 4.4) * 4.0], axis=-1), axis=-1) < 9.0
    return {
        "triangles": mesh_case(tri, label_by(tri, circle)),
        "sphere": mesh_case(sphere, cut),
        "polygons": mesh_case(poly, label_by(poly, circle)),
        "tetrahedra": mesh_case(tet, label_by(tet, ball)),
        "hexahedra": mesh_case(hexa, label_by(hexa, ball)),
        "voxels96": lambda: relax_image(voxels),
        "slices": lambda: relax_image(slices, spacing=(0.6, 0.6, 4.0)),
    }


def run(case, tolerance):
    """``(phi, integration SolveInfo, seconds)`` with the integration solved to
    ``tolerance(rtol)`` instead of ``integration_rtol(rtol)``."""
    saved = relaxer.integration_rtol
    relaxer.integration_rtol = tolerance
    try:
        result = case()
    finally:
        relaxer.integration_rtol = saved
    return np.asarray(result.phi), result.solver["integration"], result.timings["integration"]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default=None, help="comma separated (default: all)")
    parser.add_argument("--also", default="", help="more tolerances to compare, comma separated (e.g. 1e-4,1e-3)")
    args = parser.parse_args(argv)
    table = cases()
    names = args.cases.split(",") if args.cases else list(table)
    settings = {"default": params.integration_rtol, "heat's rtol": lambda rtol: rtol, "1e-10": lambda rtol: 1e-10}
    for text in filter(None, args.also.split(",")):
        settings[text] = lambda rtol, value=float(text): value
    print(f"{'case':<11} {'integration':<12} {'rtol':>7} {'iters':>5} {'seconds':>7} {'max dphi/h':>10} {'mean':>9}")
    for name in names:
        run(table[name], params.integration_rtol)  # a first run pays for first-touched memory
        runs = {label: run(table[name], tolerance) for label, tolerance in settings.items()}
        ref = runs["1e-10"][0]
        near = np.abs(ref - 0.5) < 1.0
        for label, (phi, info, seconds) in runs.items():
            d = np.abs(phi - ref)[near]
            rtol = settings[label](params.DEFAULT_RTOL)
            print(
                f"{name:<11} {label:<12} {rtol:7.0e} {info.iterations:5d} {seconds:7.2f} {d.max():10.1e} {d.mean():9.1e}",
                flush=True,
            )


if __name__ == "__main__":
    start = time.perf_counter()
    main()
    print(f"{time.perf_counter() - start:.0f} s in all")
