"""Every mesh type: the paper's Fig. 6 claim and the shared meshes, with default parameters.

(a) Fig. 6: one truth (circle r = 0.6 in [-1, 1]^2; ball r = 0.6 in [-1, 1]^3) on jittered
    triangles, jittered quads and Voronoi polygons (80 x 80 cells), and jittered
    hexahedra and tetrahedra (24^3 cells), each with the consistent Laplacian (default)
    and the paper's combinatorial one. Mean / max distance of the level set to the
    truth in units of the cell size s, length / area excess, and the factor
    ``lam_scale`` that :func:`ndboundary.relax` applied to ``lam``. Targets (issue):
    mean <= 0.15 s and |excess| <= 2 %.
(b) Every mesh in ``../shared/data/meshes``, labelled by a tilted plane through its
    centre: mean / max distance of the level set to the plane in units of the mean edge
    length h, the same for the jagged boundary's vertices, and the time of ``relax``.
    Target (issue): mean <= 0.25 h.

``--vertex-pins`` holds phi at the jagged boundary's vertices on triangles and tetrahedra,
as the paper does, instead of at its facets' centres
(``ndboundary.pipeline.boundary.FACET_CENTRE_PINS = False``).

Run::

    python benchmarks/meshes.py            # about a minute
    python benchmarks/meshes.py --no-shared
    python benchmarks/meshes.py --vertex-pins

Prints two tables, then one JSON line per case (``{"bench": "meshes", ...}``).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from ndboundary import PolyhedralMesh, relax
from ndboundary.datasets import ball, circle, hex_grid, kuhn_grid, label_by, quad_grid, voronoi_polygons
from ndboundary import read_mesh
from ndboundary.metrics import fidelity

MESHES = Path(__file__).resolve().parents[2] / "shared" / "data" / "meshes"


def fig6_domain(cells, laplacian, n2=80, n3=24):
    """The jittered mesh of one Fig. 6 case: ``(domain, truth, cell size, true measure)``."""
    if cells == "triangles":
        dom = kuhn_grid(n2, 2, jitter=0.25, random_state=0)
    elif cells == "quads":
        dom = quad_grid(n2, jitter=0.25, random_state=0, laplacian=laplacian)
    elif cells == "voronoi":
        dom = voronoi_polygons(n2, random_state=0, laplacian=laplacian)
    elif cells == "hexahedra":
        dom = hex_grid(n3, jitter=0.25, random_state=0, laplacian=laplacian)
    else:  # tetrahedra: the simplicial complex's cotangent Laplacian, or the paper's
        dom = kuhn_grid(n3, 3, jitter=0.25, random_state=0)
        if laplacian == "combinatorial":
            dom = PolyhedralMesh.from_tetrahedra(dom.points, dom.simplices, laplacian=laplacian)
    if dom.dim == 2:
        return dom, circle, 2 / n2, 2 * np.pi * 0.6
    return dom, ball, 2 / n3, 4 * np.pi * 0.36


FIG6 = [
    ("triangles", "consistent"),
    *((cells, lap) for lap in ("consistent", "combinatorial") for cells in ("quads", "voronoi", "hexahedra", "tetrahedra")),
]


def run_fig6():
    rows = []
    for cells, lap in FIG6:
        dom, truth, s, measure = fig6_domain(cells, lap)
        name = f"{cells} {'80^2' if dom.dim == 2 else '24^3'}"
        t0 = time.perf_counter()
        res = relax(dom, label_by(dom, truth), on="elements")
        seconds = time.perf_counter() - t0
        ls = res.level_set()
        fid = fidelity(ls, truth, s)
        rows.append({
            "bench": "meshes", "part": "fig6", "mesh": name, "laplacian": lap, "n_vertices": dom.n_vertices,
            "mean_s": fid["mean"], "max_s": fid["max"], "excess_pct": 100 * (ls.measure() / measure - 1),
            "components": ls.n_components(), "closed": ls.is_closed(), "lam_scale": res.params["lam_scale"],
            "seconds": seconds,
        })
    print("\n(a) Fig. 6: one truth, every cell type, default parameters (distances in cell sizes s)")
    print(f"{'mesh':<18s} {'laplacian':<14s} {'verts':>7s} {'mean/s':>7s} {'max/s':>7s} {'exc %':>7s} "
          f"{'lam x':>6s} {'closed':>6s} {'s':>6s}  target mean<=0.15 |exc|<=2%")
    for r in rows:
        ok = r["mean_s"] <= 0.15 and abs(r["excess_pct"]) <= 2 and r["closed"] and r["components"] == 1
        print(f"{r['mesh']:<18s} {r['laplacian']:<14s} {r['n_vertices']:>7d} {r['mean_s']:>7.3f} {r['max_s']:>7.3f} "
              f"{r['excess_pct']:>+7.2f} {r['lam_scale']:>6.3f} {str(r['closed']):>6s} {r['seconds']:>6.2f}  "
              f"{'PASS' if ok else 'FAIL'}")
    return rows


def run_shared():
    rows = []
    for path in sorted(MESHES.iterdir()):
        dom = read_mesh(path)
        centre = dom.points.mean(axis=0)
        normal = np.ones(dom.dim)
        normal[0] = 1.3
        normal /= np.linalg.norm(normal)

        def plane(x, centre=centre, normal=normal):
            return (x - centre) @ normal

        labels = (plane(dom.element_centroids()) > 0).astype(int)
        h = dom.mean_edge_length()
        t0 = time.perf_counter()
        res = relax(dom, labels, on="elements")
        seconds = time.perf_counter() - t0
        fid = fidelity(res.level_set(), plane, h)
        jag = np.abs(plane(dom.points[res.boundary.sources])) / h
        rows.append({
            "bench": "meshes", "part": "shared", "mesh": path.name, "kind": type(dom).__name__,
            "n_vertices": dom.n_vertices, "n_elements": dom.n_elements, "mean_h": fid["mean"], "max_h": fid["max"],
            "jagged_vertices_mean_h": float(jag.mean()), "lam_scale": res.params["lam_scale"], "seconds": seconds,
        })
    print("\n(b) shared meshes, tilted plane through the centre (distances in mean edge lengths h)")
    print(f"{'mesh':<24s} {'kind':<18s} {'verts':>7s} {'elems':>7s} {'mean/h':>7s} {'max/h':>7s} {'jag/h':>7s} "
          f"{'lam x':>6s} {'s':>6s}  target mean<=0.25")
    for r in rows:
        print(f"{r['mesh']:<24s} {r['kind']:<18s} {r['n_vertices']:>7d} {r['n_elements']:>7d} {r['mean_h']:>7.3f} "
              f"{r['max_h']:>7.3f} {r['jagged_vertices_mean_h']:>7.3f} {r['lam_scale']:>6.3f} {r['seconds']:>6.2f}  "
              f"{'PASS' if r['mean_h'] <= 0.25 else 'FAIL'}")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--no-shared", action="store_true", help="Fig. 6 cases only")
    ap.add_argument("--vertex-pins", action="store_true", help="pin zeta's vertices on simplices, not its facets' centres")
    args = ap.parse_args(argv)
    if args.vertex_pins:
        from ndboundary.pipeline import boundary

        boundary.FACET_CENTRE_PINS = False
    rows = run_fig6()
    if not args.no_shared:
        if MESHES.is_dir():
            rows += run_shared()
        else:
            print(f"\n(b) skipped: {MESHES} is absent")
    print()
    for r in rows:
        print(json.dumps(r))


if __name__ == "__main__":
    main()
