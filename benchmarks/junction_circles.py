"""Curved junction curves of label volumes: two overlapping balls (a study, not a test of
the issue's targets, whose Voronoi junctions are straight).

Three regions on ``n^3`` voxels: two balls of radii ``R`` and ``0.8 R`` whose centres lie
``R`` apart, parted by their radical plane (each point of their union goes to the ball
of least power ``|x - c|^2 - r^2``), and the space outside both. Where the three meet is
the circle where the two spheres cross, of radius ``0.73 R``, with sectors of about 133
degrees (the larger ball's) and 114 degrees (the smaller one's and the outside's) about
it. Each placement draws the pair's middle (within a voxel of the grid's) and its axis
(about ``(0.3, 0.2, 0.93)``). Measured, with ``relax_image``'s defaults (the junction
curves fitted to the labels, ``ndboundary.pipeline.junction_curves``) and, with
``--relaxed``, the curves as relaxed (``junctions.JUNCTION_FIT = False``): the distance
(voxels) from each point of ``interfaces().junctions()`` to the true circle, and the
errors of the two balls' parts' volumes (``region_measures()`` against the exact ones:
each ball less its cap beyond the radical plane). A cross-section of a curve reads the
sites of a slab ``2 SLAB`` h thick; ``--slabs`` compares half-thicknesses.

Usage::

    python benchmarks/junction_circles.py
    python benchmarks/junction_circles.py --radii 8,14,20 --placements 3 --relaxed --slabs 1.5,3

Prints one line per radius and setting (mean, 90th percentile and max over the
placements' junction points, the worst placement's mean, and the range of the volumes'
errors), then one JSON line.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import ndboundary.pipeline.junction_curves as junction_curves
import ndboundary.pipeline.junctions as junctions
from ndboundary import relax_image

N = 64


def case(radius, placement, n=N):
    """The labels and the true circle ``(centre, normal, radius)`` of one placement."""
    rng = np.random.default_rng(placement)
    middle = np.full(3, (n - 1) / 2) + rng.uniform(-1.0, 1.0, 3)
    axis = np.array([0.3, 0.2, 0.93]) + rng.normal(0.0, 0.3, 3)
    axis /= np.linalg.norm(axis)
    radii = np.array([radius, 0.8 * radius])
    centres = middle + np.outer([-0.5 * radius, 0.5 * radius], axis)
    x = np.indices((n, n, n)).reshape(3, -1).T.astype(np.float64)
    power = ((x[:, None, :] - centres[None]) ** 2).sum(axis=2) - radii**2
    labels = np.where(power.min(axis=1) < 0, power.argmin(axis=1), 2).reshape(n, n, n)
    along = (radius**2 + radii[0] ** 2 - radii[1] ** 2) / (2 * radius)  # from the first centre
    return labels, (centres[0] + along * axis, axis, np.sqrt(radii[0] ** 2 - along**2))


def exact_volumes(radius):
    """The exact volumes of the two balls' parts (each less its cap beyond the radical plane)."""
    radii = np.array([radius, 0.8 * radius])
    along = (radius**2 + radii[0] ** 2 - radii[1] ** 2) / (2 * radius)
    caps = radii - np.array([along, radius - along])  # the caps' heights
    return 4 / 3 * np.pi * radii**3 - np.pi * caps**2 * (3 * radii - caps) / 3


def circle_distance(points, circle):
    centre, normal, radius = circle
    v = points - centre
    along = v @ normal
    return np.hypot(along, np.linalg.norm(v - along[:, None] * normal, axis=1) - radius)


def measure(radius, placements, fit, slab):
    junctions.JUNCTION_FIT = fit
    junction_curves.SLAB = slab
    d, means, volumes = [], [], []
    for p in range(placements):
        labels, circle = case(radius, p)
        result = relax_image(labels)
        d.append(circle_distance(result.interfaces().junctions().points, circle))
        means.append(float(d[-1].mean()))
        volumes.append(100 * (result.region_measures()[:2] / exact_volumes(radius) - 1))
    d, volumes = np.concatenate(d), np.concatenate(volumes)
    return {"radius": radius, "fit": fit, "slab": slab, "mean": float(d.mean()), "p90": float(np.percentile(d, 90)),
            "max": float(d.max()), "worst_mean": max(means),
            "volume_pct": [float(volumes.min()), float(volumes.max())]}  # fmt: skip


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--radii", default="8,14,20", help="ball radii (voxels), comma separated")
    parser.add_argument("--placements", type=int, default=3, help="placements of the ball and plane per radius")
    parser.add_argument("--relaxed", action="store_true", help="also measure the curves as relaxed")
    parser.add_argument("--slabs", default=None, help="half-thicknesses of the fit's slab (h), comma separated")
    args = parser.parse_args()
    slabs = [float(s) for s in args.slabs.split(",")] if args.slabs else [junction_curves.SLAB]
    settings = ([(False, slabs[0])] if args.relaxed else []) + [(True, s) for s in slabs]
    print(f"{'R':>4s} {'junctions':>18s} {'mean':>7s} {'p90':>7s} {'max':>7s} {'worst mean':>10s} {'volume %':>15s}",
          flush=True)  # fmt: skip
    rows = []
    for radius in (float(r) for r in args.radii.split(",")):
        for fit, slab in settings:
            row = measure(radius, args.placements, fit, slab)
            rows.append(row)
            name = f"fitted, slab {slab:g}" if fit else "as relaxed"
            lo, hi = row["volume_pct"]
            print(f"{radius:4.0f} {name:>18s} {row['mean']:7.3f} {row['p90']:7.3f} {row['max']:7.3f} "
                  f"{row['worst_mean']:10.3f} {lo:+7.2f}..{hi:+.2f}", flush=True)  # fmt: skip
    print(json.dumps({"bench": "junction_circles", "n": N, "placements": args.placements, "rows": rows}))


if __name__ == "__main__":
    main()
