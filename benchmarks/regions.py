"""Many regions: a Voronoi partition of [-1, 1]^2 (or ^3) by random sites, labelled by element
centroid, relaxed into one partition with junctions, against the exact Voronoi diagram.

Per case: the mean and max distance of the interface points to their pair's bisector and
of the junction points to their three sites' circumcentre (in units of h), the number of
junctions found against the true ones, the largest relative error of a region's measure,
and the gap/overlap of the partition (its measures against the domain's). Targets of the
many-regions issue: interfaces <= 0.12 h mean and <= 0.5 h max, junctions within 0.5 h,
areas within 0.5 % (2-D) / 1 % (3-D).

Usage::

    python benchmarks/regions.py [--sites 7] [--seed 0]

Prints a table, then one JSON line per case.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from ndboundary import relax
from ndboundary.datasets import hex_grid, kuhn_grid, voronoi_polygons
from ndboundary.partition import partition


def exact_measures(mesh, sites):
    """Region measures of the exact Voronoi diagram: the partition by the linear functions
    ``2 x . s - |s|^2``, exact on any simplicial refinement."""
    points, simplices, _ = mesh.level_set_complex(np.zeros(mesh.n_vertices))
    return partition(points, simplices, 2 * points @ sites.T - (sites**2).sum(axis=1)).region_measures()


def measure_case(name, mesh, sites):
    h = mesh.mean_edge_length()
    c = mesh.element_centroids()
    labels = np.argmin(((c[:, None, :] - sites[None]) ** 2).sum(axis=2), axis=1)
    present = np.unique(labels)
    t0 = time.perf_counter()
    res = relax(mesh, labels, on="elements")
    seconds = time.perf_counter() - t0
    s = sites[present]
    faces = res.interfaces()
    a, b = s[faces.pairs[:, 0]], s[faces.pairs[:, 1]]
    centre = 0.5 * (a + b)[:, None, :]
    normal = ((b - a) / np.linalg.norm(b - a, axis=1, keepdims=True))[:, None, :]
    corners = faces.points[faces.simplices]  # (n, k, dim)
    d_face = np.abs(((corners - centre) * normal).sum(axis=2)).ravel() / h
    junctions = faces.junctions()
    d_junction = []
    for pts, regions in zip(junctions.points[junctions.simplices], junctions.regions, strict=True):
        tri = s[regions[regions >= 0][:3]]
        dist = np.linalg.norm(pts[:, None, :] - tri[None], axis=2)
        d_junction.extend((dist.max(axis=1) - dist.min(axis=1)) / 2 / h)
    measures = res.region_measures()
    exact = exact_measures(mesh, s)
    row = {
        "bench": "regions", "case": name, "n_regions": int(present.size), "mean_h": float(d_face.mean()),
        "max_h": float(d_face.max()), "junction_points": len(junctions), "junction_mean_h": float(np.mean(d_junction)),
        "junction_max_h": float(np.max(d_junction)), "measure_err_pct": float(100 * np.max(np.abs(measures / exact - 1))),
        "gap_rel": float(abs(measures.sum() / exact.sum() - 1)), "seconds": seconds,
    }  # fmt: skip
    print(
        f"{name:22s} {row['n_regions']:3d} {row['mean_h']:7.3f} {row['max_h']:7.3f} {row['junction_points']:5d} "
        f"{row['junction_mean_h']:7.3f} {row['junction_max_h']:7.3f} {row['measure_err_pct']:7.3f} "
        f"{row['gap_rel']:9.1e} {seconds:7.2f}",
        flush=True,
    )
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=7)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    sites2, sites3 = rng.uniform(-0.8, 0.8, (args.sites, 2)), rng.uniform(-0.8, 0.8, (6, 3))
    print(f"{'case':22s} {'L':>3s} {'mean/h':>7s} {'max/h':>7s} {'junc':>5s} {'j mean':>7s} {'j max':>7s} {'area%':>7s} {'gap':>9s} {'s':>7s}")
    rows = [
        measure_case("triangles 80^2", kuhn_grid(80, 2, jitter=0.25, random_state=0), sites2),
        measure_case("triangles 160^2", kuhn_grid(160, 2, jitter=0.25, random_state=0), sites2),
        measure_case("voronoi polygons 80^2", voronoi_polygons(80, random_state=0), sites2),
        measure_case("tetrahedra 24^3", kuhn_grid(24, 3, jitter=0.25, random_state=0), sites3),
        measure_case("hexahedra 24^3", hex_grid(24, jitter=0.25, random_state=0), sites3),
    ]
    for row in rows:
        print(json.dumps(row))


if __name__ == "__main__":
    main()
