"""What limits the fidelity of 2-D label images: the relaxation with one of its inputs
replaced by the truth, and a refinement of the relaxed curve (a study, not a test).

``relax_image`` reaches about 0.054 pixel on average on the 128^2 flower of
``images.py``, against a target of 0.05 (0.083 as relaxed, before its curve is fitted to
the pixels). The relaxation takes two things from the labels:
the field (the heat's gradient, smoothed) and the pins (phi = 1/2 at the centre of each
facet between the labels, weighted towards the staircase's risers,
``ndboundary.pipeline.boundary.facet_pins``). Each mode below replaces one of them by the
truth, inside the relaxation, and measures the relaxed curve against the truth:

* ``labels``: ``relax_image``'s defaults: the relaxed curve fitted to the pixels
  (``ndboundary.pipeline.result.fit_two_regions``): resampled every half pixel and moved
  to the smoothest curve (least change of curvature; circles and lines cost nothing) that
  parts the pixel centres within 2 pixels with the largest margins;
* ``relaxed``: the relaxation alone, not fitted (as every mode below);
* ``exact field``: the smoothed field replaced, on every pixel, by the truth's unit
  normal (the gradient of its implicit function), oriented as the field is;
* ``exact pins``: each facet's pin moved from the facet's centre to where the true
  boundary crosses the segment between the centres of the facet's two pixels (bilinear
  weights in the pixel holding that point), its weight kept;
* ``both``: the exact field and the exact pins.

Cases: the flower of ``images.py`` (5 lobes, amplitude 0.2, radius 0.3 n), discs of
radius 0.3 n and 12.3 pixels, and flowers of 3 and 7 lobes, on 128^2 pixels, each off the
grid's symmetry. Distances in pixels, at ``ndboundary.metrics.sample_points`` of each
curve.

What it shows: with the exact pins, the same relaxation is within a few hundredths of a
pixel on average; with the exact field and the labels' pins it is where it was. The
error lies in where the staircase puts the pins: each pixel pair says only that the
boundary crosses the segment between their centres. The fit of ``labels`` reads more of
the labels than one pair.

``--volume NAME`` runs the modes on a volume of ``images.py`` instead (``labels``: its
surface fitted, ``ndboundary.pipeline.surface_fit``): ``aniso`` (its ball of 64 x 64 x 22
voxels of spacing (1, 1, 3); distances in units of the smallest spacing), ``ball128`` or
``blob64``.

Usage::

    python benchmarks/images_limits.py
    python benchmarks/images_limits.py --modes labels,relaxed
    python benchmarks/images_limits.py --volume aniso

Prints a table (mean / max distance per case and mode), then one JSON line.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import scipy.sparse as sp
from images_truths import Ball, StarShape, blob_terms

import ndboundary.pipeline.padding as padding
import ndboundary.pipeline.relaxer as relaxer
from ndboundary import relax_image
from ndboundary.metrics import sample_points
from ndboundary.pipeline import interface_fit, surface_fit

N = 128
MODES = ("labels", "relaxed", "exact field", "exact pins", "both")


def shapes():
    c = np.array([0.17, -0.23]) * N / 64
    return {
        "flower": StarShape(c, 0.3 * N),
        "disc 0.3n": StarShape(c, 0.3 * N, amplitude=0.0),
        "disc 12.3": StarShape(c, 12.3, amplitude=0.0),
        "flower 3": StarShape(0.7 * c, 0.3 * N, lobes=3, amplitude=0.15, phase=1.1),
        "flower 7": StarShape(c, 0.3 * N, lobes=7, amplitude=0.12, phase=0.7),
    }


def unit_normals(truth, x, eps=1e-4):
    g = np.stack([(truth.F(x + eps * e) - truth.F(x - eps * e)) / (2 * eps) for e in np.eye(x.shape[1])], axis=1)
    return g / np.linalg.norm(g, axis=1)[:, None]


class Oracle:
    """Replaces the field and/or the pins of the relaxations run inside it by the truth's,
    and fits (``fit``) the two-region boundaries of images to the pixels or not."""

    def __init__(self, truth, field, pins, fit):
        self.truth, self.field, self.pins, self.fit = truth, field, pins, fit

    def __enter__(self):
        self._smooth, self._pins = relaxer.smooth, padding.facet_pins
        self._fit = interface_fit.INTERFACE_FIT, surface_fit.SURFACE_FIT
        interface_fit.INTERFACE_FIT = surface_fit.SURFACE_FIT = self.fit
        if self.field:
            relaxer.smooth = self._exact_field
        if self.pins:
            padding.facet_pins = self._exact_pins
        return self

    def __exit__(self, *exc):
        relaxer.smooth, padding.facet_pins = self._smooth, self._pins
        interface_fit.INTERFACE_FIT, surface_fit.SURFACE_FIT = self._fit

    def _exact_field(self, work, X, passes, groups=None):
        smoothed = self._smooth(work, X, passes, groups)
        n = unit_normals(self.truth, work.element_centroids())
        return np.sign((n * smoothed).sum()) * n

    def _exact_pins(self, grid, region1, sources):
        S, targets, slabs = self._pins(grid, region1, sources)
        inside, outside, _ = slabs
        pts = grid.points
        a, b = pts[inside].mean(axis=1), pts[outside].mean(axis=1)  # the two pixels' centres
        lo, hi = np.zeros(a.shape[0]), np.ones(a.shape[0])
        for _ in range(50):  # bisection for the crossing of the segment a -> b
            mid = 0.5 * (lo + hi)
            inner = self.truth.F(a + mid[:, None] * (b - a)) < 0
            lo, hi = np.where(inner, mid, lo), np.where(inner, hi, mid)
        s = 0.5 * (lo + hi)
        x = a + s[:, None] * (b - a)
        corners = np.where((s <= 0.5)[:, None], inside, outside)  # the pixel holding x
        cp = pts[corners]
        low, high = cp.min(axis=1), cp.max(axis=1)
        f = (x - low) / (high - low)
        w = np.ones(corners.shape)
        for axis in range(pts.shape[1]):
            upper = cp[:, :, axis] > (low[:, axis] + high[:, axis])[:, None] / 2
            w *= np.where(upper, f[:, None, axis], 1.0 - f[:, None, axis])
        root = 2.0 * targets
        rows = np.repeat(np.arange(x.shape[0]), corners.shape[1])
        return sp.csr_matrix(((w * root[:, None]).ravel(), (rows, corners.ravel())), shape=S.shape), targets, slabs


VOLUMES = ("aniso", "ball128", "blob64")


def volume(name, modes):
    """The modes on the volume ``name`` of ``images.py``: ``{mode: {mean, max}}``."""
    n = 128 if name == "ball128" else 64
    off = np.array([0.17, -0.23, 0.31]) * n / 64  # images.py's centre, off the grid's symmetry
    shape, spacing = ((64, 64, 22), (1.0, 1.0, 3.0)) if name == "aniso" else ((n,) * 3, (1.0,) * 3)
    origin = np.full(3, -31.5) if name == "aniso" else np.full(3, -(n - 1) / 2)
    truth = StarShape(off, 0.29 * n, blob_terms()) if name == "blob64" else Ball(off, 0.32 * n)
    centres = np.indices(shape).reshape(3, -1).T * spacing + origin
    labels = truth.inside(centres).reshape(shape)
    out = {}
    for mode in modes:
        oracle = Oracle(truth, mode in ("exact field", "both"), mode in ("exact pins", "both"), mode == "labels")
        with oracle:
            result = relax_image(labels, spacing=spacing, origin=origin)
        d = truth.distance(sample_points(result.level_set()))
        out[mode] = {"mean": float(d.mean()), "max": float(d.max())}
    return out


# --------------------------------------------------------------------------- main


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--modes", default=",".join(MODES), help="comma separated, of: " + ", ".join(MODES))
    parser.add_argument("--volume", choices=VOLUMES, help="a volume of images.py instead of the 2-D shapes")
    args = parser.parse_args()
    modes = args.modes.split(",")
    unknown = sorted(set(modes) - set(MODES))
    if unknown:
        parser.error(f"unknown modes {unknown}; choose from {', '.join(MODES)}")
    if args.volume:
        row = volume(args.volume, modes)
        print(f"{'case':12s}" + "".join(f"{m:>20s}" for m in modes))
        print(f"{args.volume:12s}" + "".join(f"{row[m]['mean']:>12.3f} / {row[m]['max']:.3f}" for m in modes))
        print(json.dumps({"bench": "images_limits", "case": args.volume, "modes": row}))
        return
    origin = -(N - 1) / 2
    centres = np.indices((N, N)).reshape(2, -1).T + origin
    rows = {}
    print(f"{'case':12s}" + "".join(f"{m:>20s}" for m in modes))
    for name, truth in shapes().items():
        labels = truth.inside(centres).reshape(N, N).astype(np.int8)
        rows[name] = {}
        for mode in modes:
            oracle = Oracle(truth, mode in ("exact field", "both"), mode in ("exact pins", "both"), mode == "labels")
            with oracle:
                result = relax_image(labels, origin=(origin, origin))
            d = truth.distance(sample_points(result.level_set()))
            rows[name][mode] = {"mean": float(d.mean()), "max": float(d.max())}
        print(f"{name:12s}" + "".join(f"{rows[name][m]['mean']:>12.3f} / {rows[name][m]['max']:.3f}" for m in modes))
    print(json.dumps({"bench": "images_limits", "n": N, "cases": rows}))


if __name__ == "__main__":
    main()
