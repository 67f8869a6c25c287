"""Many regions: a threshold-dynamics coupling (multiphase MBO) against relax's own.

In the spirit of multiphase MBO (Merriman, Bence and Osher), the relaxed partition is
turned back into element labels (each element goes to the region whose function is
largest at its centroid) and relaxed again, ``--steps`` times; the figures are those of
``benchmarks/regions.py`` (distances of the interfaces to the true bisectors and of the
junctions to their three sites' circumcentre, in units of h) on the Voronoi cases.

Usage::

    python benchmarks/regions_coupling.py [--steps 2]
"""

from __future__ import annotations

import argparse

import numpy as np

from ndboundary import relax
from ndboundary.datasets import kuhn_grid, voronoi_polygons


def score(mesh, res, sites):
    """Interface mean/max to the bisector lines and junction mean/max, in units of h."""
    h = mesh.mean_edge_length()
    faces = res.interfaces()
    a, b = sites[faces.pairs[:, 0]], sites[faces.pairs[:, 1]]
    n = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    d = np.abs(((faces.points[faces.simplices] - 0.5 * (a + b)[:, None]) * n[:, None]).sum(axis=2)) / h
    dj = []
    junctions = faces.junctions()
    for pts, regions in zip(junctions.points[junctions.simplices], junctions.regions, strict=True):
        tri = sites[regions[regions >= 0][:3]]
        dist = np.linalg.norm(pts[:, None] - tri[None], axis=2)
        dj.extend((dist.max(axis=1) - dist.min(axis=1)) / 2 / h)
    return f"interfaces {d.mean():.3f} / {d.max():.3f} h, junctions {np.mean(dj):.3f} / {np.max(dj):.3f} h"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2, help="relabel-and-relax steps after the first relaxation")
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    s2, s3 = rng.uniform(-0.8, 0.8, (7, 2)), rng.uniform(-0.8, 0.8, (6, 3))
    cases = [
        ("triangles 80^2", kuhn_grid(80, 2, jitter=0.25, random_state=0), s2),
        ("triangles 160^2", kuhn_grid(160, 2, jitter=0.25, random_state=0), s2),
        ("voronoi polygons 80^2", voronoi_polygons(80, random_state=0), s2),
        ("tetrahedra 24^3", kuhn_grid(24, 3, jitter=0.25, random_state=0), s3),
    ]
    for name, mesh, sites in cases:
        c = mesh.element_centroids()
        labels = np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)
        res = relax(mesh, labels, on="elements")
        print(f"{name:22s} relax         {score(mesh, res, sites)}", flush=True)
        inc = mesh.incidence
        count = np.asarray(inc.sum(axis=0)).ravel()
        for step in range(args.steps):
            at_centroids = (inc.T @ res.phi) / count[:, None]
            relabelled = res.classes[np.argmax(at_centroids, axis=1)]
            res = relax(mesh, relabelled, on="elements")
            changed = int((relabelled != labels).sum())
            print(f"{'':22s} MBO step {step + 1}    {score(mesh, res, sites)} ({changed} elements relabelled)", flush=True)


if __name__ == "__main__":
    main()
