"""What a fit of the relaxed surface to the voxels would give in 3-D (a study, not a test).

In the plane, ``relax_image`` of two labels fits its relaxed curve to the pixels: the
smoothest curve (least change of curvature) that parts the pixel centres with the largest
margins (``ndboundary.pipeline.result.fit_two_regions``). Volumes are not fitted, and
their largest distances to the truth miss the imaging issue's 0.25 voxel where the
voxels leave the boundary a gap to stray in (a ball's surface at 45 degrees between two
axes, where the planes of voxel centres lie 0.71 voxel apart). This script measures the
same fit on surfaces, on a mesh built for it, to tell whether building it is worth it.

The mesh: surface nets on the relaxed phi (:func:`relaxed_mesh`), whose quads are nearly
squares, which the cotangent operators below need (on the marching simplices' own
triangles, thin near the voxel corners, the discrete mean curvature came out four times
too large on average).

The fit: each vertex moves by ``z`` along its normal to minimise

    beta * integral |grad H|^2  +  sum over voxel centres within 2 voxels of exp(-margin / tau)

``H`` the mean curvature (``H0 + B z``, linearised: ``B = (M^-1 K - |A|^2) / 2``, ``K``
the cotangent stiffness, ``M`` the lumped mass, ``|A|^2 = 4 H^2 - 2 K_gauss``, so that
moving a sphere or a plane along its normals, translating or scaling it, costs nothing),
``margin`` a voxel centre's signed distance to the surface at its nearest vertex,
positive on its label's side. Newton steps with a backtracking search, the soft minimum's
width narrowing through ``--taus``, as the curves' fit does.

Distances are measured at the mesh's vertices (in units of the smallest spacing), as
projected (the relaxation) and as fitted.

Usage::

    python benchmarks/images_surface_fit.py                       # ball64, torus64, blob64, aniso
    python benchmarks/images_surface_fit.py --cases ball128,torus128,blob128
    python benchmarks/images_surface_fit.py --cases aniso --betas 100,1000,10000

Prints one row per case and weight, then one JSON line.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from images_truths import Ball, StarShape, Torus, blob_terms
from scipy import ndimage
from scipy.spatial import cKDTree

from ndboundary import SimplicialComplex, relax_image
from ndboundary.solvers.cholesky import factorize_spd


def case(name):
    """``(truth, shape, spacing, origin)`` of the case ``name`` of ``images.py``."""
    n = 128 if name.endswith("128") else 64
    off = np.array([0.17, -0.23, 0.31]) * n / 64
    if name == "aniso":
        return Ball(off, 0.32 * n), (64, 64, 22), np.array([1.0, 1.0, 3.0]), np.full(3, -31.5)
    if name.startswith("torus"):
        return Torus(off, 0.25 * n, 0.11 * n), (n,) * 3, np.ones(3), np.full(3, -(n - 1) / 2)
    truth = StarShape(off, 0.29 * n, blob_terms()) if name.startswith("blob") else Ball(off, 0.32 * n)
    return truth, (n,) * 3, np.ones(3), np.full(3, -(n - 1) / 2)


def relaxed_mesh(result, labels, spacing, origin):
    """A quad mesh (split into triangles) of the relaxed level set phi = 1/2, one vertex in
    each voxel whose corners phi crosses (the mean of the crossings on its edges, then moved
    onto phi = 1/2 by Newton steps on the trilinear phi), one quad about each voxel edge
    phi crosses (surface nets on phi): its quads are nearly squares of a voxel's side, where
    the marching simplices' triangles are thin near the voxel corners. Only the voxels
    within 3 of the labels' boundary are meshed (phi, filled beyond the band, may cross 1/2
    again far from it).
    """
    shape = np.array(labels.shape)
    f = np.zeros(tuple(shape + 1))  # phi - 1/2 on the voxel corners
    corner0 = origin - spacing / 2
    idx = np.rint((result.domain.points - corner0) / spacing).astype(int)
    f[tuple(idx.T)] = np.asarray(result.phi) - 0.5
    near = ndimage.binary_dilation(labels, iterations=3) & ~ndimage.binary_erosion(labels, iterations=3)
    corners = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    signs = [f[i : i + shape[0], j : j + shape[1], k : k + shape[2]] > 0 for i, j, k in corners]
    active = np.logical_or.reduce(signs) & ~np.logical_and.reduce(signs) & near
    cells = np.argwhere(active)
    vertex = np.full(tuple(shape), -1)
    vertex[tuple(cells.T)] = np.arange(len(cells))
    total, count = np.zeros((len(cells), 3)), np.zeros(len(cells))
    for a in range(3):  # the crossings on each voxel's 12 edges
        e = np.eye(3, dtype=int)[a]
        for o in (o for o in corners if o[a] == 0):
            f0, f1 = f[tuple((cells + o).T)], f[tuple((cells + o + e).T)]
            cross = (f0 > 0) != (f1 > 0)
            t = np.where(cross, f0 / np.where(cross, f0 - f1, 1.0), 0.0)
            total += np.where(cross[:, None], cells + o + t[:, None] * e, 0.0)
            count += cross
    points = corner0 + total / count[:, None] * spacing
    quads = []
    for a in range(3):  # a quad about each crossed voxel edge, of its four voxels
        b, c = (a + 1) % 3, (a + 2) % 3
        eb, ec = np.eye(3, dtype=int)[b], np.eye(3, dtype=int)[c]
        lo, hi = [slice(None)] * 3, [slice(None)] * 3
        lo[a], hi[a] = slice(0, -1), slice(1, None)
        p = np.argwhere((f[tuple(lo)] > 0) != (f[tuple(hi)] > 0))
        p = p[(p[:, b] >= 1) & (p[:, b] < shape[b]) & (p[:, c] >= 1) & (p[:, c] < shape[c])]
        q = np.stack([vertex[tuple((p - eb - ec).T)], vertex[tuple((p - ec).T)], vertex[tuple(p.T)],
                      vertex[tuple((p - eb).T)]], axis=1)  # fmt: skip
        outward = f[tuple(p.T)] > 0  # inside at the edge's start: the quad faces along +a
        q[~outward] = q[~outward][:, ::-1]
        quads.append(q[(q >= 0).all(axis=1)])
    q = np.concatenate(quads)

    def phi_at(x):
        return ndimage.map_coordinates(f, ((x - corner0) / spacing).T, order=1)

    for _ in range(10):  # onto phi = 1/2
        g = np.stack([(phi_at(points + 1e-4 * s * e) - phi_at(points - 1e-4 * s * e)) / (2e-4 * s)
                      for s, e in zip(spacing, np.eye(3), strict=True)], axis=1)  # fmt: skip
        points = points - (phi_at(points) / np.maximum((g * g).sum(axis=1), 1e-12))[:, None] * g
    short = np.linalg.norm(points[q[:, 0]] - points[q[:, 2]], axis=1) <= np.linalg.norm(
        points[q[:, 1]] - points[q[:, 3]], axis=1
    )  # each quad split along its shorter diagonal
    faces = np.where(short[:, None], q[:, [0, 1, 2, 0, 2, 3]], q[:, [0, 1, 3, 1, 2, 3]]).reshape(-1, 3)
    return points, faces


def curvature_terms(points, faces):
    """Vertex normals, the cotangent stiffness ``K``, the lumped mass, ``H0`` and ``|A|^2``."""
    mesh = SimplicialComplex(points, faces)
    K, mass = mesh.K.tocsr(), np.asarray(mesh.mass).ravel()
    area = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    normal = np.zeros_like(points)
    angle = np.zeros(len(points))
    for k in range(3):
        np.add.at(normal, faces[:, k], area)
        a = points[faces[:, (k + 1) % 3]] - points[faces[:, k]]
        b = points[faces[:, (k + 2) % 3]] - points[faces[:, k]]
        cos = (a * b).sum(axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        np.add.at(angle, faces[:, k], np.arccos(np.clip(cos, -1.0, 1.0)))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    H0 = 0.5 * ((K @ points) / mass[:, None] * normal).sum(axis=1)  # -Delta x = 2 H n
    gauss = (2 * np.pi - angle) / mass
    return normal, K, mass, H0, np.maximum(4 * H0**2 - 2 * gauss, 0.0)


def fit(points, faces, centres, inside, beta, taus, reach=2.0):
    """Each vertex's move along its normal (see the module), and the Newton steps taken."""
    normal, K, mass, H0, A2 = curvature_terms(points, faces)
    B = 0.5 * (sp.diags(1.0 / mass) @ K) - 0.5 * sp.diags(A2)
    prior, prior0 = beta * (B.T @ K @ B).tocsr(), beta * (B.T @ (K @ H0))
    dist, near = cKDTree(points).query(centres, distance_upper_bound=reach)
    on = np.isfinite(dist)
    near, side = near[on], np.where(inside[on], -1.0, 1.0)  # the normals point outwards
    signed = ((centres[on] - points[near]) * normal[near]).sum(axis=1)
    F = sp.csr_matrix((np.ones(near.size), (np.arange(near.size), near)), shape=(near.size, len(points)))
    z, steps = np.zeros(len(points)), 0

    def loss(z, tau):
        return 0.5 * z @ (prior @ z) + prior0 @ z + np.exp(np.clip(-side * (signed - F @ z) / tau, -50, 50)).sum()

    for tau in taus:
        for _ in range(40):
            e = np.exp(np.clip(-side * (signed - F @ z) / tau, -50, 50))
            grad = prior @ z + prior0 + F.T @ (side * e / tau)
            hess = (prior + F.T @ sp.diags(e / tau**2) @ F + 1e-9 * sp.identity(len(z))).tocsc()
            move = factorize_spd(hess)(-grad)
            steps += 1
            step, now, slope = 1.0, loss(z, tau), grad @ move
            while -slope > 1e-12 * abs(now) and step > 1e-4 and loss(z + step * move, tau) > now + 1e-4 * step * slope:
                step *= 0.5
            z += step * move
            if np.abs(step * move).max() < 1e-6:
                break
    return z, normal, steps


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default="ball64,torus64,blob64,aniso", help="of ball, torus, blob 64 or 128, aniso")
    parser.add_argument("--betas", default="1000", help="weights of the prior, comma separated")
    parser.add_argument("--taus", default="0.1,0.03", help="widths of the margins' soft minimum, in turn")
    args = parser.parse_args()
    taus = [float(t) for t in args.taus.split(",")]
    warnings.simplefilter("ignore", spla.MatrixRankWarning)
    rows = []
    print(f"{'case':10s} {'beta':>8s} {'relaxed mean / max':>20s} {'fitted mean / max':>20s} {'steps':>6s} {'s':>6s}")
    for name in args.cases.split(","):
        truth, shape, spacing, origin = case(name)
        centres = np.indices(shape).reshape(3, -1).T * spacing + origin
        inside = truth.inside(centres)
        result = relax_image(inside.reshape(shape), spacing=spacing, origin=origin)
        points, faces = relaxed_mesh(result, inside.reshape(shape), spacing, origin)
        unit = spacing.min()
        d0 = truth.distance(points) / unit
        for beta in [float(b) for b in args.betas.split(",")]:
            start = time.perf_counter()
            z, normal, steps = fit(points, faces, centres, inside, beta, taus)
            seconds = time.perf_counter() - start
            d = truth.distance(points + z[:, None] * normal) / unit
            rows.append({"case": name, "beta": beta, "vertices": len(points), "relaxed": [d0.mean(), d0.max()],
                         "fitted": [d.mean(), d.max()], "steps": steps, "seconds": seconds})  # fmt: skip
            print(f"{name:10s} {beta:8g} {d0.mean():11.4f} / {d0.max():.4f} {d.mean():11.4f} / {d.max():.4f}"
                  f" {steps:6d} {seconds:6.1f}", flush=True)  # fmt: skip
    print(json.dumps({"bench": "images_surface_fit", "taus": taus, "rows": rows}))


if __name__ == "__main__":
    main()
