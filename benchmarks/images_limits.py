"""What limits the fidelity of 2-D label images: the relaxation with one of its inputs
replaced by the truth, and a refinement of the relaxed curve (a study, not a test).

``relax_image`` reaches about 0.08 pixel on average on the 128^2 flower of
``images.py``, against a target of 0.05. The relaxation takes two things from the labels:
the field (the heat's gradient, smoothed) and the pins (phi = 1/2 at the centre of each
facet between the labels, weighted towards the staircase's risers,
``ndboundary.pipeline.boundary.facet_pins``). Each mode below replaces one of them by the
truth, inside the relaxation, and measures the relaxed curve against the truth:

* ``labels``: ``relax_image``'s defaults;
* ``exact field``: the smoothed field replaced, on every pixel, by the truth's unit
  normal (the gradient of its implicit function), oriented as the field is;
* ``exact pins``: each facet's pin moved from the facet's centre to where the true
  boundary crosses the segment between the centres of the facet's two pixels (bilinear
  weights in the pixel holding that point), its weight kept;
* ``both``: the exact field and the exact pins;
* ``refined``: no truth at all, the relaxed curve of ``labels`` refined by a prototype
  estimator: each closed curve resampled every half pixel and moved along its normals by
  the one Newton-solved ``delta`` that minimises ``beta * sum(kappa'^2) h +
  sum(exp(-margin / tau))`` over the pixel centres within 2 pixels (``margin``: a
  centre's signed distance to the moved curve, positive on its label's side; the
  curvature ``kappa`` linearised about the relaxed curve). It keeps the smoothest curve
  that parts the centres with the largest margins: a curvature-variation prior (circles
  and lines cost nothing) against the labels' corridor. ``--beta`` (1000) and ``--tau``
  (0.1 pixel) trade the two.

Cases: the flower of ``images.py`` (5 lobes, amplitude 0.2, radius 0.3 n), discs of
radius 0.3 n and 12.3 pixels, and flowers of 3 and 7 lobes, on 128^2 pixels, each off the
grid's symmetry. Distances in pixels, at ``ndboundary.metrics.sample_points`` of each
curve (the refined curve at its resampled vertices).

What it shows: with the exact pins, the same relaxation is within a few hundredths of a
pixel on average; with the exact field and the labels' pins it is where it was. The
error lies in where the staircase puts the pins: each pixel pair says only that the
boundary crosses the segment between their centres. An estimator of those crossings
that reads more of the labels than one pair is what the target needs; ``refined`` is a
first one.

Usage::

    python benchmarks/images_limits.py
    python benchmarks/images_limits.py --modes labels,refined --beta 3000

Prints a table (mean / max distance per case and mode), then one JSON line.
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from images_truths import StarShape
from scipy.spatial import cKDTree

import ndboundary.pipeline.padding as padding
import ndboundary.pipeline.relaxer as relaxer
from ndboundary import relax_image
from ndboundary.metrics import sample_points

N = 128
MODES = ("labels", "exact field", "exact pins", "both", "refined")


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
    """Replaces the field and/or the pins of the relaxations run inside it by the truth's."""

    def __init__(self, truth, field, pins):
        self.truth, self.field, self.pins = truth, field, pins

    def __enter__(self):
        self._smooth, self._pins = relaxer.smooth, padding.facet_pins
        if self.field:
            relaxer.smooth = self._exact_field
        if self.pins:
            padding.facet_pins = self._exact_pins
        return self

    def __exit__(self, *exc):
        relaxer.smooth, padding.facet_pins = self._smooth, self._pins

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


# --------------------------------------------------------------------------- refinement


def closed_curves(level_set):
    """The closed polylines of a 2-D level set, each as its points in order."""
    following = dict(level_set.simplices.tolist())
    seen, curves = set(), []
    for start in following:
        if start in seen:
            continue
        loop, v = [start], following[start]
        seen.add(start)
        while v != start:
            if v not in following:
                raise ValueError("the level set holds an open curve")
            loop.append(v)
            seen.add(v)
            v = following[v]
        curves.append(level_set.points[loop])
    return curves


def resample(points, spacing):
    """The closed polyline ``points`` at equal arclength steps of about ``spacing``."""
    ring = np.vstack([points, points[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ring, axis=0), axis=1))])
    m = max(8, int(round(s[-1] / spacing)))
    t = np.arange(m) * s[-1] / m
    return np.stack([np.interp(t, s, ring[:, k]) for k in range(2)], axis=1), s[-1] / m


def refine(points, step, sites, side, beta, tau):
    """The closed curve ``points`` (equal steps ``step``) moved along its normals to
    part the ``sites`` (``side`` +1 inside, -1 outside) with the largest margins at the
    least curvature variation: one Newton solve of the energy in the module docstring.
    """
    n = points.shape[0]
    ahead, behind = np.roll(points, -1, axis=0), np.roll(points, 1, axis=0)
    tangent = ahead - behind
    tangent /= np.linalg.norm(tangent, axis=1)[:, None]
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)
    nearest = cKDTree(points).query(sites)[1]
    signed = ((sites - points[nearest]) * normal[nearest]).sum(axis=1)
    if np.mean(np.sign(signed) == -side) < 0.5:  # the normals point out of the inside
        normal, signed = -normal, -signed
    along = np.clip(((sites - points[nearest]) * tangent[nearest]).sum(axis=1) / step, -0.999, 0.999)
    j0 = np.where(along >= 0, nearest, (nearest - 1) % n)
    w = np.where(along >= 0, along, 1.0 + along)
    foot = sp.csr_matrix(
        (np.concatenate([1.0 - w, w]), (np.tile(np.arange(sites.shape[0]), 2), np.concatenate([j0, (j0 + 1) % n]))),
        shape=(sites.shape[0], n),
    )
    cycle = np.arange(n)
    ends = (np.tile(cycle, 2), np.concatenate([cycle, (cycle + 1) % n]))
    D = sp.csr_matrix((np.concatenate([-np.ones(n), np.ones(n)]) / step, ends), shape=(n, n))  # d/ds on the cycle
    kappa = ((ahead - 2.0 * points + behind) / step**2 * -normal).sum(axis=1)  # positive where convex
    dkappa = -(D @ D) - sp.diags(kappa**2)  # kappa of the curve moved by delta, to first order
    A = D @ dkappa
    H0, g0 = beta * step * (A.T @ A), beta * step * (A.T @ (D @ kappa))
    delta = np.zeros(n)
    for _ in range(30):
        e = np.exp(np.clip(-side * (foot @ delta - signed) / tau, -50.0, 50.0))
        grad = H0 @ delta + g0 - foot.T @ (side * e / tau)
        hess = H0 + foot.T @ sp.diags(e / tau**2) @ foot + 1e-9 * sp.identity(n)
        move = spla.spsolve(hess.tocsc(), -grad)
        delta += move
        if np.abs(move).max() < 1e-7:
            break
    return points + delta[:, None] * normal


def refined_points(result, centres, inside, beta, tau, reach=2.0):
    out = []
    for curve in closed_curves(result.level_set()):
        points, step = resample(curve, 0.5)
        near = cKDTree(points).query(centres)[0] < reach
        out.append(refine(points, step, centres[near], np.where(inside[near], 1.0, -1.0), beta, tau))
    return np.concatenate(out)


# --------------------------------------------------------------------------- main


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--modes", default=",".join(MODES), help="comma separated, of: " + ", ".join(MODES))
    parser.add_argument("--beta", type=float, default=1000.0)
    parser.add_argument("--tau", type=float, default=0.1)
    args = parser.parse_args()
    modes = args.modes.split(",")
    unknown = sorted(set(modes) - set(MODES))
    if unknown:
        parser.error(f"unknown modes {unknown}; choose from {', '.join(MODES)}")
    origin = -(N - 1) / 2
    centres = np.indices((N, N)).reshape(2, -1).T + origin
    rows = {}
    print(f"{'case':12s}" + "".join(f"{m:>20s}" for m in modes))
    for name, truth in shapes().items():
        inside = truth.inside(centres)
        labels = inside.reshape(N, N).astype(np.int8)
        rows[name] = {}
        for mode in modes:
            with Oracle(truth, field=mode in ("exact field", "both"), pins=mode in ("exact pins", "both")):
                result = relax_image(labels, origin=(origin, origin))
            if mode == "refined":
                d = truth.distance(refined_points(result, centres, inside, args.beta, args.tau))
            else:
                d = truth.distance(sample_points(result.level_set()))
            rows[name][mode] = {"mean": float(d.mean()), "max": float(d.max())}
        print(f"{name:12s}" + "".join(f"{rows[name][m]['mean']:>12.3f} / {rows[name][m]['max']:.3f}" for m in modes))
    print(json.dumps({"bench": "images_limits", "n": N, "beta": args.beta, "tau": args.tau, "cases": rows}))


if __name__ == "__main__":
    main()
