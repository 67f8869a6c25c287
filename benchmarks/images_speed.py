"""Voxel volumes: the time and peak memory of ``relax_image`` on a ball, end to end.

Each run is a fresh process: the label volume (a ball of radius 0.32 n, its centre off the
grid's symmetry, as ``images.py``'s ``ball64``), one ``relax_image`` with the defaults and
its ``level_set()``. Prints every run, then the medians.

To set this release beside another, run the same command with the other's source tree
first on ``PYTHONPATH`` (alternating the two, as the machine's speed drifts).

Usage::

    python benchmarks/images_speed.py 64            # three runs at 64^3
    python benchmarks/images_speed.py 96 --repeats 1
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

ONE_RUN = """
import json, resource, time
import numpy as np
from ndboundary import relax_image
n = {n}
x = np.indices((n, n, n)).reshape(3, -1).T - (n - 1) / 2 - np.array([0.17, -0.23, 0.31]) * n / 64
mask = (np.linalg.norm(x, axis=1) < 0.32 * n).reshape(n, n, n)
t0 = time.perf_counter()
result = relax_image(mask)
t1 = time.perf_counter()
surface = result.level_set()
t2 = time.perf_counter()
print(json.dumps({{"relax_s": t1 - t0, "level_set_s": t2 - t1, "total_s": t2 - t0,
                   "peak_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6,
                   "closed": bool(surface.is_closed())}}))
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int, nargs="?", default=64, help="voxels a side (default 64)")
    parser.add_argument("--repeats", type=int, default=3, help="fresh processes (default 3)")
    args = parser.parse_args()
    runs = []
    for _ in range(args.repeats):
        out = subprocess.run(
            [sys.executable, "-c", ONE_RUN.format(n=args.n)], capture_output=True, text=True, check=True
        )
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
        fields = (f"{k} {v:.2f}" if isinstance(v, float) else f"{k} {v}" for k, v in runs[-1].items())
        print(f"ball {args.n}^3: " + ", ".join(fields), flush=True)
    med = {k: sorted(r[k] for r in runs)[len(runs) // 2] for k in ("relax_s", "level_set_s", "total_s", "peak_gb")}
    print(json.dumps({"bench": "images_speed", "n": args.n, "repeats": args.repeats, **med}))


if __name__ == "__main__":
    main()
