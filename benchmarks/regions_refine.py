"""The plane partitions of ``regions.py`` with each relaxed interface refined by the prototype
of ``curve_refinement.py`` (a study: the library does not refine).

For each seed, the Voronoi partition of [-1, 1]^2 by 7 random sites (``regions.py``'s
``plane-*`` cases), then the three-region Y of curved arcs (``y-*``, seed ``Y``), is
relaxed on Voronoi polygons (``voronoi_polygons(80)``) and on a jittered triangle grid
(``kuhn_grid(80, 2)``). Each interface of ``result.interfaces()``
is cut into its polylines (between junctions and the domain's border, or closed), which
are resampled every h / 2 and moved to the smoothest curve that parts the labelled element
centroids of its two regions within 2 h with the largest margins (``--beta``, ``--tau``,
in units of h); the ends, junctions and border points, are held. Distances in h to the
true bisector or arc of each pair, at the relaxed
interfaces' corners and at the refined polylines' vertices: mean, max, and the max
farther than 2 h from a polyline's ends (where the refinement acts). The many-regions
issue's targets: mean <= 0.12 h, max <= 0.5 h. Region areas are not measured: the
refined polylines are not a partition of the domain.

Usage::

    python benchmarks/regions_refine.py [--seeds 0,1,2] [--beta 3000] [--tau 0.1]

Prints a table, then one JSON line.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from curve_refinement import polylines, refine, resample
from regions_truths import VoronoiTruth, YTruth
from scipy.spatial import cKDTree

from ndboundary import relax
from ndboundary.datasets import kuhn_grid, voronoi_polygons

MESHES = {
    "voronoi 80^2": lambda: voronoi_polygons(80, random_state=0),
    "tri 80^2": lambda: kuhn_grid(80, 2, jitter=0.25, random_state=0),
}


def refined_distances(mesh, truth, distance, beta, tau):
    """``(relaxed, refined, refined_inner)``: distances (h) to the truth,
    ``distance(x, a, b)`` for the interface of labels ``a`` and ``b``, of the relaxed
    interfaces' corners, of the refined polylines' vertices, and of those farther than 2 h
    from their polyline's ends."""
    h = mesh.mean_edge_length()
    centroids = mesh.element_centroids()
    labels = truth.labels(centroids)
    result = relax(mesh, labels, on="elements")
    faces = result.interfaces()
    relaxed, refined, inner = [], [], []
    for pair in np.unique(faces.pairs, axis=0):
        a, b = (int(result.classes[k]) for k in pair)
        mine = faces.simplices[np.all(faces.pairs == pair, axis=1)]
        relaxed.append(distance(faces.points[mine].reshape(-1, 2), a, b) / h)
        for curve, closed in polylines(faces.points, mine):
            points, step = resample(curve / h, 0.5, closed)
            near = (cKDTree(points).query(centroids / h)[0] < 2.0) & ((labels == a) | (labels == b))
            if near.sum() >= 3 and points.shape[0] >= 4:
                side = np.where(labels[near] == a, 1.0, -1.0)
                points = refine(points, step, centroids[near] / h, side, beta, tau, closed)
            d = distance(points * h, a, b) / h
            refined.append(d)
            if closed:
                inner.append(d)
            else:
                ends = np.linalg.norm(points[:, None, :] - points[[0, -1]][None], axis=2).min(axis=1)
                inner.append(d[ends > 2.0])
    return tuple(np.concatenate(x) for x in (relaxed, refined, inner))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--beta", type=float, default=3000.0)
    parser.add_argument("--tau", type=float, default=0.1)
    args = parser.parse_args()
    rows = []
    head = ("relaxed mean", "max", "refined mean", "max", "inner max")
    print(f"{'mesh':14s} {'seed':>4s} " + " ".join(f"{c:>13s}" for c in head))
    y = YTruth()
    plane = [(f"{seed}", VoronoiTruth(np.random.default_rng(seed).uniform(-0.8, 0.8, (7, 2))))
             for seed in [int(s) for s in args.seeds.split(",")]]  # fmt: skip
    for seed, truth in plane + [("Y", y)]:
        distance = truth.interface_distance if seed != "Y" else lambda x, a, b: y.arc_distance(x, y.arc_of(a, b))
        for name, make in MESHES.items():
            relaxed, refined, inner = refined_distances(make(), truth, distance, args.beta, args.tau)
            row = {"mesh": name, "seed": seed, "relaxed_mean_h": relaxed.mean(), "relaxed_max_h": relaxed.max(),
                   "refined_mean_h": refined.mean(), "refined_max_h": refined.max(),
                   "refined_inner_max_h": inner.max(initial=0.0)}  # fmt: skip
            row = {k: v if isinstance(v, (str, int)) else float(v) for k, v in row.items()}
            rows.append(row)
            cells = [row[k] for k in ("relaxed_mean_h", "relaxed_max_h", "refined_mean_h", "refined_max_h",
                                      "refined_inner_max_h")]  # fmt: skip
            print(f"{name:14s} {seed:>4s} " + " ".join(f"{c:13.3f}" for c in cells), flush=True)
    print(json.dumps({"bench": "regions_refine", "beta": args.beta, "tau": args.tau, "rows": rows}))


if __name__ == "__main__":
    main()
