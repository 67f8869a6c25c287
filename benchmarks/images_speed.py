"""Voxel volumes: the time and peak memory of ``relax_image`` on a ball, end to end.

Each run is a fresh process: the label volume (a ball of radius 0.32 n, its centre off the
grid's symmetry, as ``images.py``'s ``ball64``; with ``--regions K`` the Voronoi partition
of K random sites instead, and ``--shape`` for a volume that is not a cube), one ``relax_image`` with the defaults and its ``level_set()``
(for a partition, every region's boundary); then, in the same process on the same volume, VTK's
``vtkSurfaceNets3D`` (when the ``[bench]`` extra is installed; on a partition, with every
label at once), the peer whose ratio is printed. Prints every run, then the medians.

``--against DIR`` sets another source tree beside this one (a ``git worktree`` of an
earlier release, say): each repeat runs it, then this tree, each in a fresh process, so
that the machine's drifting speed weighs on both alike, and the ratios of the medians are
printed. The other tree is imported from ``DIR`` ahead of the installed package (an
editable install's import hook would otherwise win over ``PYTHONPATH``); its kernels are
compiled by numba, so the first of its runs pays for that.

Usage::

    python benchmarks/images_speed.py 64            # three runs at 64^3
    python benchmarks/images_speed.py 96 --repeats 1
    python benchmarks/images_speed.py 64 --against ../release
    python benchmarks/images_speed.py 128 --regions 16 --repeats 1
    python benchmarks/images_speed.py --shape 275,347,245 --regions 365 --repeats 1  # an atlas's size
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

#: Imports ndboundary from the folder ``{source}`` instead of the installed package.
FROM_SOURCE = """
import sys
sys.meta_path = [f for f in sys.meta_path if "editable" not in getattr(f, "__module__", "").lower()]
sys.path.insert(0, {source!r})
"""

ONE_RUN = """
import json, resource, time
import numpy as np
from ndboundary import relax_image
from scipy.spatial import cKDTree
shape, regions = {shape}, {regions}
n = shape[0]
centre = (np.array(shape) - 1) / 2 + np.array([0.17, -0.23, 0.31]) * n / 64
x = np.indices(shape).reshape(3, -1).T - centre
if regions:  # the Voronoi partition of random sites, by voxel centre
    sites = np.random.default_rng(0).uniform(-0.5, 0.5, (regions, 3)) * shape
    mask = cKDTree(sites).query(x, workers=2)[1].astype(np.int32).reshape(shape)
else:
    mask = (np.linalg.norm(x, axis=1) < 0.32 * n).reshape(shape)
del x
t0 = time.perf_counter()
result = relax_image(mask)
t1 = time.perf_counter()
if regions:
    surfaces = [result.region_boundary(r) for r in range(regions)]
else:
    surfaces = [result.level_set()]
t2 = time.perf_counter()
area = sum(s.measure() for s in surfaces)
# regions meet the image's border: their boundaries are open there
closed = None if regions else bool(surfaces[0].is_closed())
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
try:  # the peer, on the same volume in the same process (the [bench] extra)
    import sys
    sys.path.insert(0, {bench!r})
    from images_truths import surface_nets, surface_nets_partition
    import vtk  # imported before the clock, as ndboundary is
    t3 = time.perf_counter()
    (surface_nets_partition if regions else surface_nets)(mask, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    peer_s = time.perf_counter() - t3
except ImportError:
    peer_s = float("nan")
print(json.dumps({{"relax_s": t1 - t0, "level_set_s": t2 - t1, "total_s": t2 - t0, "peak_gb": peak,
                   "closed": closed, "area": area, "surface_nets_s": peer_s}}))
"""


def one_run(shape, regions=0, source=None):
    """One fresh process's figures, with ndboundary from ``source`` if given."""
    code = (FROM_SOURCE.format(source=str(source)) if source else "") + ONE_RUN.format(
        shape=tuple(shape), regions=regions, bench=str(HERE)
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


#: This folder: ``images_truths.py`` holds the peer.
HERE = Path(__file__).resolve().parent
MEDIANS = ("relax_s", "level_set_s", "total_s", "peak_gb", "surface_nets_s")


def medians(runs):
    return {k: sorted(r[k] for r in runs)[len(runs) // 2] for k in MEDIANS}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int, nargs="?", default=64, help="voxels a side (default 64)")
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes (default 3)")
    parser.add_argument("--against", type=Path, help="another source tree, run alternately with this one")
    parser.add_argument("--regions", type=int, default=0, help="a Voronoi partition of this many regions instead")
    parser.add_argument("--shape", help="a volume of these voxels instead of n^3 (e.g. 275,347,245; with --regions)")
    args = parser.parse_args()
    shape = tuple(int(v) for v in args.shape.split(",")) if args.shape else (args.n,) * 3
    if len(shape) != 3 or (args.shape and not args.regions):
        parser.error("--shape takes three sizes, for a Voronoi partition (--regions)")
    case = f"voronoi of {args.regions}" if args.regions else "ball"
    size = "x".join(map(str, shape))
    trees = ([("against", args.against.resolve())] if args.against else []) + [("this", None)]
    runs = {name: [] for name, _ in trees}
    for _ in range(args.repeats):
        for name, source in trees:
            runs[name].append(one_run(shape, args.regions, source))
            fields = (f"{k} {v:.6g}" if isinstance(v, float) else f"{k} {v}" for k, v in runs[name][-1].items())
            print(f"{name} tree, {case} {size}: " + ", ".join(fields), flush=True)
    med = {name: medians(r) for name, r in runs.items()}
    peer = med["this"]["surface_nets_s"]
    print(f"this tree: {med['this']['total_s']:.2f} s, vtkSurfaceNets3D {peer:.3f} s in the same processes "
          f"(ratio {med['this']['total_s'] / peer:.1f}x)")
    if args.against:
        ratio = {k: med["this"][k] / med["against"][k] for k in ("relax_s", "total_s", "peak_gb")}
        print("this tree / the other: " + ", ".join(f"{k} {v:.2f}" for k, v in ratio.items()))
        print(json.dumps({"bench": "images_speed", "shape": shape, "repeats": args.repeats, **med, "ratio": ratio}))
    else:
        print(json.dumps({"bench": "images_speed", "shape": shape, "repeats": args.repeats, **med["this"]}))


if __name__ == "__main__":
    main()
