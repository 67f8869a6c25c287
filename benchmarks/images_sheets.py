"""Thin folded sheets: how far each method's enclosed volume strays from the truth as a
sheet thins below a voxel (a study of a limit, not a test).

An atlas's cortical parcels are sheets a few voxels thick, folded. Here a sheet lies
between the surfaces ``z = s(x, y)`` and ``z = s(x, y) + t`` of ``s = n / 2 + A sin(2 pi x
/ lam) sin(1.4 pi y / lam)`` on ``n^3`` voxels: every column of voxels holds exactly ``t``
of its voxels (``t`` an integer), so its voxel count is its true volume, ``t n^2``. Across
the sheet it is thinner where it is steep: at most slope ``A 2 pi / lam`` it is ``t /
sqrt(1 + slope^2)`` thick, under a voxel in the last case below. Every method sees the
mask padded by one background voxel (the sheet meets the image's sides) and is measured
by the volume its closed surface encloses: ``relax_image`` (the region's measure) and the
peers of ``images.py`` (``images_truths.PEERS``: scikit-image's marching cubes on the mask
and on the mask smoothed by a Gaussian of one voxel, VTK's SurfaceNets3D, 3D Slicer's
recipe).

Usage::

    python benchmarks/images_sheets.py

Prints one line per sheet: its slope, least thickness, and each method's volume error.
Needs scikit-image and vtk.
"""

from __future__ import annotations

import argparse

import numpy as np
from images_truths import run_peer

from ndboundary import relax_image

#: (lam, A, t): wavelength and amplitude of the folds, thickness along z (voxels).
SHEETS = ((32, 4, 2), (32, 4, 3), (32, 4, 5), (20, 6, 3), (15, 10, 5), (15, 10, 3))


def sheet(n, lam, A, t):
    z, y, x = np.indices((n, n, n)).astype(np.float64)
    s = n / 2 + A * np.sin(2 * np.pi * x / lam) * np.sin(2 * np.pi * y / lam * 0.7)
    return (z >= s) & (z < s + t)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=64, help="voxels along each axis")
    args = parser.parse_args()
    peers = ["vtk surfacenets", "slicer recipe", "skimage mask", "skimage gauss1"]
    print(f"{'lam':>4s} {'A':>3s} {'t':>2s} {'slope':>6s} {'thinnest':>8s} {'ours %':>8s} "
          + " ".join(f"{p + ' %':>17s}" for p in peers))  # fmt: skip
    for lam, A, t in SHEETS:
        mask = sheet(args.n, lam, A, t)
        true = float(t * args.n**2)
        assert mask.sum() == true
        slope = A * 2 * np.pi / lam
        ours = relax_image(np.pad(mask, 1).astype(np.int8)).region_measures()[1]
        errors = [100 * (ours / true - 1)]
        errors += [100 * (run_peer(p, mask, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))[1] / true - 1) for p in peers]
        print(f"{lam:4d} {A:3d} {t:2d} {slope:6.2f} {t / np.sqrt(1 + slope**2):8.2f} "
              + " ".join(f"{e:+8.2f}" if i == 0 else f"{e:+17.2f}" for i, e in enumerate(errors)), flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
