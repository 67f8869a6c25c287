"""Hundreds of labels at an atlas's size: ``relax_image`` and every region's boundary, phase
by phase, with the resident memory of each.

The volume is the Voronoi partition of ``--sites`` random sites (by voxel centre, a k-d
tree) on 275 x 347 x 245 voxels, a brain atlas's size, times ``--scale`` along each axis.
One fresh run (an atlas takes half an hour on two cores): the relaxation; the region
values the partition reads; the refinement of the voxels that interfaces cross; every
region's boundary (``region_boundaries``, region by region on every core beyond
``PARTITION_BY_REGION_SIMPLICES``); the region measures and how closely they sum to the
image's volume. A thread polls ``/proc/self/statm`` every 50 ms: ``rss`` is the memory
after each phase, ``peak`` the most within it. The run stops itself beyond ``--limit``
GB.

``--layout brain`` draws a brain-like atlas instead: background (label 0) outside and
inside, a folded cortical ribbon 5 voxels thick cut into ``--sites`` - 35 parcels by
direction from the centre, and 35 deep nuclei (balls of radius 5 to 12 voxels). Most of
the volume is then one region, the background, whose boundary is every other region's:
its own band holds millions of voxels, where the Voronoi partition's largest holds a few
hundred thousand.

Usage::

    python benchmarks/many_labels.py                       # 365 sites, 275 x 347 x 245
    python benchmarks/many_labels.py --sites 46 --scale 0.5
    python benchmarks/many_labels.py --layout brain
    python benchmarks/many_labels.py --interfaces        # and every interface, with its junctions
    python benchmarks/many_labels.py --layout brain --background 0   # as the command line's --background 0
    python benchmarks/many_labels.py --image atlas.nii.gz --background 0   # a real atlas

``--background LABEL`` does what ``ndboundary relax IMAGE --surfaces DIR --background
LABEL`` does: the labels framed by one layer of that label, relaxed with it as the
background, and every boundary but the background's.
"""

from __future__ import annotations

import argparse
import os
import threading
import time

import numpy as np
from scipy.spatial import cKDTree

ATLAS_SHAPE = (275, 347, 245)


class Memory:
    """The resident memory, polled on a thread: the current value, and the most since reset."""

    def __init__(self, limit):
        self.now = self.peak = self.top = 0.0
        self.limit = limit
        threading.Thread(target=self._poll, daemon=True).start()

    def _poll(self):
        while True:
            with open("/proc/self/statm") as f:
                rss = int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e9
            self.now, self.peak, self.top = rss, max(self.peak, rss), max(self.top, rss)
            if rss > self.limit:
                print(f"resident memory {rss:.1f} GB above --limit, stopping", flush=True)
                os._exit(3)
            time.sleep(0.05)


def voronoi_labels(shape, sites):
    """The Voronoi partition of ``sites`` random sites by voxel centre."""
    points = np.random.default_rng(0).uniform(0, 1, (sites, 3)) * shape
    centres = np.indices(shape, dtype=np.float32).reshape(3, -1).T
    return cKDTree(points).query(centres, workers=2)[1].astype(np.int32).reshape(shape)


def brain_labels(shape, parcels, nuclei=35, thickness=5.0, seed=0):
    """A brain-like atlas (see the module's docstring), a slab of the first axis at a time."""
    rng = np.random.default_rng(seed)
    centre, semi = (np.asarray(shape) - 1) / 2, 0.42 * np.asarray(shape)
    directions = rng.normal(size=(parcels, 3))
    directions /= np.linalg.norm(directions, axis=1)[:, None]
    waves = rng.normal(size=(12, 3))
    waves /= np.linalg.norm(waves, axis=1)[:, None]
    phases, frequencies = rng.uniform(0, 2 * np.pi, 12), 2 * np.pi * rng.uniform(5, 8, 12)
    nucleus_centres, nucleus_radii = rng.uniform(-0.3, 0.3, (nuclei, 3)) * semi, rng.uniform(5, 12, nuclei)
    by_direction = cKDTree(directions)
    out = np.zeros(shape, dtype=np.int32)
    j, k = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
    for i in range(shape[0]):
        x = np.stack([np.full(j.size, i), j.ravel(), k.ravel()], axis=1) - centre
        q = x / semi
        rho = np.linalg.norm(q, axis=1)
        u = q / np.maximum(rho, 1e-12)[:, None]
        folded = 1.0 + 0.1 * np.sin((u @ waves.T) * frequencies + phases).sum(axis=1) / np.sqrt(12)
        depth = (folded - rho) * semi.min()  # voxels beneath the folded surface
        label = np.zeros(j.size, dtype=np.int32)
        ribbon = (depth >= 0) & (depth < thickness)
        label[ribbon] = 1 + by_direction.query(u[ribbon])[1]
        inner = np.flatnonzero(depth >= thickness)
        d = np.linalg.norm((x[inner, None, :] - nucleus_centres) / nucleus_radii[:, None], axis=2)
        nearest = np.argmin(d, axis=1)
        hit = d[np.arange(inner.size), nearest] < 1
        label[inner[hit]] = 1 + parcels + nearest[hit]
        out[i] = label.reshape(j.shape)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sites", type=int, default=365, help="regions (default 365)")
    parser.add_argument("--scale", type=float, default=1.0, help="times the atlas's size along each axis")
    parser.add_argument("--limit", type=float, default=21.0, help="stop beyond this resident memory, GB")
    parser.add_argument("--layout", choices=("voronoi", "brain"), default="voronoi", help="the labels' layout")
    parser.add_argument(
        "--interfaces", action="store_true", help="the interfaces too, as `ndboundary relax --boundary` writes them"
    )
    parser.add_argument(
        "--background", type=int, help="this label's boundary left out, the image framed by it (as the command line)"
    )
    parser.add_argument("--image", help="a label image file instead (a real atlas: NIfTI, NRRD, TIFF or .npy)")
    args = parser.parse_args()
    spacing = origin = None
    if args.image:
        from ndboundary import read_image

        image = read_image(args.image)
        labels, spacing, origin = image.labels, image.spacing, image.origin
        if image.direction is not None:
            raise SystemExit(f"{args.image}: an oblique image; relax it with `ndboundary relax`")
        shape, name = labels.shape, args.image
    else:
        shape = tuple(int(round(n * args.scale)) for n in ATLAS_SHAPE)
        if args.layout == "brain":
            labels = brain_labels(shape, args.sites - 35, thickness=5.0 * args.scale)
        else:
            labels = voronoi_labels(shape, args.sites)
        name = f"{args.layout} layout"
    share = "" if args.background is None else f", background {np.mean(labels == args.background):.1%} of the voxels"
    print(f"{name}: {np.unique(labels).size} labels{share}")
    if args.background is not None:
        if not (labels == args.background).any():
            raise SystemExit(f"--background {args.background}: not one of the labels")
        labels = np.pad(labels, 1, constant_values=args.background)
        if origin is not None:  # the frame's voxels lie one step before the image's first
            origin = np.asarray(origin, dtype=np.float64) - np.asarray(spacing, dtype=np.float64)
    memory = Memory(args.limit)
    from ndboundary import relax_image

    def phase(name, start):
        print(f"{name:44s} {time.perf_counter() - start:8.2f} s  rss {memory.now:6.2f} GB  peak {memory.peak:6.2f} GB",
              flush=True)  # fmt: skip
        memory.peak = memory.now
        return time.perf_counter()

    begin = tick = time.perf_counter()
    result = relax_image(labels, spacing=spacing, origin=origin, background=args.background)
    tick = phase(f"relax {'x'.join(map(str, shape))}, {result.classes.size} labels", tick)
    values = result.region_values()
    tick = phase(f"region values ({values.nnz} stored)", tick)
    del values
    complex_, _ = result._mixed()
    tick = phase(f"refinement of the mixed voxels ({0 if complex_ is None else complex_[1].shape[0]} simplices)", tick)
    by_region = result._by_region() is not None
    regions = [r for r in range(result.classes.size) if result.classes[r] != args.background]
    area = sum(boundary.measure() for boundary in result.region_boundaries(regions))
    which = "every region's boundary" if len(regions) == result.classes.size else "every boundary but the background's"
    tick = phase(f"{which} ({'region by region' if by_region else 'all at once'}), area {area:.6g}", tick)
    if args.interfaces:
        faces = result.interfaces()
        tick = phase(f"interfaces ({len(faces)} simplices)", tick)
        tick = phase(f"their junctions ({len(faces.junctions())} segments)", tick)
        del faces
    measures = result.region_measures()
    volume = labels.size * float(np.prod(1.0 if spacing is None else spacing))
    phase(f"region measures (sum off the volume by {abs(measures.sum() / volume - 1):.1e})", tick)
    print(f"end to end {time.perf_counter() - begin:.1f} s, most resident memory {memory.top:.2f} GB")


if __name__ == "__main__":
    main()
