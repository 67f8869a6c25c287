"""How wide the band must be: the level set of ``relax(..., band=w)`` against the whole-domain solve.

For each case and width (in units of the mean edge length h), the mean and max distance
between the two level sets in units of h, both ways, the share of the vertices the band
holds and the two times. Targets of the band: mean <= 0.01 h, max <= 0.05 h, the same
number of components. Distances are from points to the other curve or surface
(:func:`ndboundary.metrics.level_set_distance`).

Usage::

    python benchmarks/band.py [--widths 8,12,16,21,24,auto] [--params "dict(smoothing=3)"]
    python benchmarks/band.py --suite        # every relax of quality.py and meshes.py
    python benchmarks/band.py --cases voxels-96 --widths auto [--integrate-whole-band]

``--suite`` runs ``benchmarks/quality.py`` (defaults and the paper's settings) and
``benchmarks/meshes.py`` (Fig. 6 and the shared meshes) with every call of ``relax``
made three times: ``band="auto"`` (the default, whose result the script then checks),
``band=None``, and the band at the width auto chooses (forced, although auto relaxes
meshes under ``AUTO_BAND_MIN_VERTICES`` vertices whole); it prints the gaps to the
whole-domain level set per call, then the scripts' own tables.

The cases ``voxels-96``, ``voxels-128`` (a ball in a cube of voxels) and ``voxels-torus-96``
(a torus of radii 0.5 and 0.22 in [-1, 1]^3, its tube of radius 10.6 voxels) are relaxed by
``relax_image``, whose band is cut from the label array, against ``relax_image(...,
band=None)``. ``--integrate-whole-band`` makes image grids integrate their whole band, as
meshes do, instead of the inner band within their ``integration_reach`` of zeta: the
level set and the time it buys. Their truths are exact signed distances, so for them the
table adds each level set's mean distance to the truth (``band>t``, ``whole>t``, in h): where
the band strays from the whole grid's level set, whether it strays towards the truth.

Prints a table, then one JSON line per case and width.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import ndboundary
from ndboundary import ImageGrid, relax, relax_image
from ndboundary.domains.image import GridBand
from ndboundary.metrics import level_set_distance, sample_points
from ndboundary.pipeline.band import band_width, can_cut
from ndboundary.datasets import (
    ball,
    circle,
    flower,
    hex_grid,
    icosphere,
    kuhn_grid,
    label_by,
    quad_grid,
    torus,
    voronoi_polygons,
)

CASES = {
    "flower-160": lambda: (kuhn_grid(160, 2, jitter=0.25, random_state=0), flower),
    "flower-400": lambda: (kuhn_grid(400, 2, jitter=0.25, random_state=0), flower),
    "quads-80": lambda: (quad_grid(80, jitter=0.25, random_state=0), circle),
    "voronoi-80": lambda: (voronoi_polygons(80, random_state=0), circle),
    "ico5-plane": lambda: (icosphere(5), lambda x: x[:, 2] - 0.3),
    "ball-24": lambda: (kuhn_grid(24, 3, jitter=0.25, random_state=0), ball),
    "ball-44": lambda: (kuhn_grid(44, 3, jitter=0.25, random_state=0), ball),
    "hex-24": lambda: (hex_grid(24, jitter=0.25, random_state=0), ball),
    "hex-40": lambda: (hex_grid(40, jitter=0.25, random_state=0), ball),
    "ball-64-r0.3": lambda: (kuhn_grid(64, 3, jitter=0.25, random_state=0), lambda x: ball(x, 0.3)),
    "hex-56-r0.3": lambda: (hex_grid(56, jitter=0.25, random_state=0), lambda x: ball(x, 0.3)),
    "4d-ball-12": lambda: (kuhn_grid(12, 4, jitter=0.1, random_state=0), ball),
    "voxels-96": lambda: (voxel_cube(96), ball),
    "voxels-128": lambda: (voxel_cube(128), ball),
    "voxels-torus-96": lambda: (voxel_cube(96), lambda x: torus(x - 0.01, 0.5, 0.22)),
}
DEFAULT_CASES = (
    "flower-160,flower-400,quads-80,voronoi-80,ico5-plane,ball-44,hex-40,ball-64-r0.3,hex-56-r0.3,4d-ball-12"
)


def image_relax(grid, labels, on, **params):
    """``relax_image`` on the labels of an image grid's voxels (its own band: the width
    ``auto`` chooses for label images, cut from the label array)."""
    return relax_image(labels.reshape(grid.shape), spacing=grid.spacing, origin=grid.origin, **params)


#: The cases whose truth is the exact signed distance to the true boundary.
EXACT_DISTANCE = ("voxels-96", "voxels-128", "voxels-torus-96")


def voxel_cube(n):
    """The voxels of [-1, 1]^3, ``n`` a side."""
    return ImageGrid((n, n, n), spacing=2 / n, origin=-1 + 1 / n)


def gap(a, b, h):
    """Mean distance from ``a``'s level set to ``b``'s, and the max both ways, in units of ``h``
    (point to curve or surface: :func:`ndboundary.metrics.level_set_distance`).
    """
    la, lb = a.level_set(), b.level_set()
    there = level_set_distance(la, lb) / h
    back = level_set_distance(lb, la) / h
    return float(there.mean()), float(max(there.max(), back.max()))


def run_suite():
    """quality.py and meshes.py with every relax done with and without the band."""
    import meshes
    import quality

    rows = []

    def both(domain, labels, **kw):
        kw.pop("band", None)
        t0 = time.perf_counter()
        res = relax(domain, labels, band="auto", **kw)
        t_band = time.perf_counter() - t0
        t0 = time.perf_counter()
        whole = relax(domain, labels, band=None, **kw)
        t_whole = time.perf_counter() - t0
        h = domain.mean_edge_length()
        mean, worst = gap(res, whole, h)
        # the band at auto's width, without auto's rules that small meshes relax whole
        p = {
            "mu": kw.get("mu", ndboundary.DEFAULT_MU),
            "lam": kw.get("lam", ndboundary.DEFAULT_LAM),
            "smoothing": kw.get("smoothing", ndboundary.DEFAULT_SMOOTHING),
        }
        width = band_width(p, domain, whole.params["lam_scale"]) if can_cut(domain) else None
        forced = whole if width is None else relax(domain, labels, band=width, **kw)
        f_mean, f_worst = gap(forced, whole, h)
        share = forced.params.get("band_vertices", domain.n_vertices) / domain.n_vertices
        row = {
            "bench": "band-suite", "case": len(rows), "domain": repr(domain), "params": repr(kw),
            "auto_band": res.params.get("band"), "mean_h": mean, "max_h": worst,
            "components": res.level_set().n_components(), "whole_components": whole.level_set().n_components(),
            "band_s": t_band, "whole_s": t_whole, "forced_width": width, "forced_share": share,
            "forced_mean_h": f_mean, "forced_max_h": f_worst, "forced_components": forced.level_set().n_components(),
        }  # fmt: skip
        row["pass"] = mean <= 0.01 and worst <= 0.05 and row["components"] == row["whole_components"]
        row["forced_pass"] = (
            f_mean <= 0.01 and f_worst <= 0.05 and row["forced_components"] == row["whole_components"]
        )
        rows.append(row)
        auto_w = "whole" if res.params.get("band") is None else f"{res.params['band']:.0f}"
        print(
            f"{len(rows) - 1:3d} {repr(domain)[:58]:58s} {auto_w:>5s} {mean:7.4f} {worst:7.4f} "
            f"{row['components']}/{row['whole_components']} {t_band:6.2f} {t_whole:6.2f} "
            f"{'PASS' if row['pass'] else 'FAIL'} | {width or 0:5.1f} {share:5.2f} {f_mean:7.4f} {f_worst:7.4f} "
            f"{'PASS' if row['forced_pass'] else 'FAIL'}",
            flush=True,
        )
        return res

    ndboundary.relax = meshes.relax = both  # quality.py imports relax from the package in each case
    print(
        f"{'#':>3s} {'domain':58s} {'auto':>5s} {'mean':>7s} {'max':>7s} comp {'auto s':>6s} {'whole':>6s} "
        f"     | the band at auto's width: {'width':>5s} {'verts':>5s} {'mean':>7s} {'max':>7s}"
    )
    quality.main([])
    meshes.main([])
    n_pass = sum(r["pass"] for r in rows)
    n_forced = sum(r["forced_pass"] for r in rows)
    print(
        f"\nband suite: band='auto' {n_pass}/{len(rows)}, the band at auto's width {n_forced}/{len(rows)} "
        "relaxations within mean 0.01 h, max 0.05 h of band=None, with its number of components"
    )
    for row in rows:
        print(json.dumps(row))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--widths", default="8,12,16,21,24,auto")
    parser.add_argument("--params", default="{}", help="relax parameters, a Python dict literal")
    parser.add_argument("--cases", default=DEFAULT_CASES, help=f"any of {', '.join(CASES)}")
    parser.add_argument("--suite", action="store_true", help="every relax of quality.py and meshes.py instead")
    parser.add_argument(
        "--integrate-whole-band",
        action="store_true",
        help="image grids integrate their whole band, as meshes do, instead of their inner band",
    )
    args = parser.parse_args()
    if args.integrate_whole_band:
        ImageGrid.integration_reach = GridBand.integration_reach = None
    if args.suite:
        return run_suite()
    params = eval(args.params, {"dict": dict})  # noqa: S307 - a command-line convenience
    widths = [w if w == "auto" else float(w) for w in args.widths.split(",")]
    print(f"# band: relax parameters {params}; distances in h; verts = share of the vertices in the band")
    print(
        f"{'case':12s} {'width':>6s} {'verts':>6s} {'mean':>7s} {'max':>7s} {'comp':>5s} {'band s':>7s} {'whole s':>8s}"
        f" {'band>t':>7s} {'whole>t':>7s}"
    )
    lines = []
    for name in args.cases.split(","):
        mesh, truth = CASES[name]()
        labels = label_by(mesh, truth)
        h = mesh.mean_edge_length()
        t0 = time.perf_counter()
        run = relax if not isinstance(mesh, ImageGrid) else image_relax
        whole = run(mesh, labels, on="elements", band=None, **params)
        t_whole = time.perf_counter() - t0
        ref = whole.level_set()
        exact = name in EXACT_DISTANCE
        whole_truth = float(np.abs(truth(sample_points(ref))).mean() / h) if exact else np.nan
        for w in widths:
            t0 = time.perf_counter()
            res = run(mesh, labels, on="elements", band=w, **params)
            t_band = time.perf_counter() - t0
            ls = res.level_set()
            there = level_set_distance(ls, ref) / h
            back = level_set_distance(ref, ls) / h
            share = res.params.get("band_vertices", mesh.n_vertices) / mesh.n_vertices
            row = {
                "bench": "band", "case": name, "width": w, "band_share": share, "mean_h": float(there.mean()),
                "max_h": float(max(there.max(), back.max())), "components": ls.n_components(),
                "whole_components": ref.n_components(), "band_s": t_band, "whole_s": t_whole, "params": repr(params),
                "band_to_truth_h": float(np.abs(truth(sample_points(ls))).mean() / h) if exact else None,
                "whole_to_truth_h": whole_truth if exact else None,
            }  # fmt: skip
            lines.append(row)
            print(
                f"{name:12s} {w!s:>6s} {share:6.2f} {row['mean_h']:7.4f} {row['max_h']:7.4f} "
                f"{row['components']}/{row['whole_components']:<3d} {t_band:7.2f} {t_whole:8.2f}"
                + (f" {row['band_to_truth_h']:7.4f} {whole_truth:7.4f}" if exact else ""),
                flush=True,
            )
    for row in lines:
        print(json.dumps(row))


if __name__ == "__main__":
    main()
