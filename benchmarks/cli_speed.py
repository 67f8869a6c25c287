"""``ndboundary relax`` end to end on a 1 M-vertex OBJ: reading, relaxing, writing phi and the boundary.

The mesh is the geodesic sphere of ``benchmarks/table1.py`` (frequency ``--freq``, 316:
998 562 vertices, 1 996 920 triangles), labelled by the plane cut z > 0.3, written as
OBJ with one label per line. Each run is a fresh process (``python -m ndboundary.cli relax
sphere.obj labels.txt -o phi.vtu --boundary boundary.obj``): interpreter start, imports,
reading, relaxing and writing, as a user's command costs. The peer, in the same run:
``meshio.read`` of the same OBJ (the reader the field uses), in a fresh process too.

``--first-run`` also times the command once as a new install runs it: it deletes
ndboundary's numba caches (``*.nbi``, ``*.nbc`` under the package) and gives the run an
empty ``NUMBA_CACHE_DIR``, so that whatever a new install would compile, it compiles.

Run::

    python benchmarks/cli_speed.py [--freq 316] [--repeats 3] [--first-run]

Prints the medians and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from table1 import geodesic_sphere  # noqa: E402

import ndboundary  # noqa: E402
from ndboundary import SimplicialComplex, write_labels, write_mesh  # noqa: E402


def run(cmd, cwd, env=None):
    """Wall time of ``cmd`` in a fresh process, and its output."""
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, check=True)
    return time.perf_counter() - t0, done.stdout


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--freq", type=int, default=316)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--first-run", action="store_true", help="time a run with ndboundary's numba caches deleted")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        points, triangles = geodesic_sphere(args.freq)
        mesh = SimplicialComplex(points, triangles)
        write_mesh(folder / "sphere.obj", mesh)
        write_labels(folder / "labels.txt", (points[triangles].mean(axis=1)[:, 2] > 0.3).astype(int))
        size_mb = (folder / "sphere.obj").stat().st_size / 2**20
        relax_cmd = [sys.executable, "-m", "ndboundary.cli", "relax", "sphere.obj", "labels.txt", "-o", "phi.vtu",
                     "--boundary", "boundary.obj", "--quiet"]  # fmt: skip
        peer_cmd = [sys.executable, "-c", "import meshio; meshio.read('sphere.obj')"]
        first = None
        if args.first_run:
            package = Path(ndboundary.__file__).parent
            for cache in [*package.rglob("*.nbi"), *package.rglob("*.nbc")]:
                cache.unlink()
            with tempfile.TemporaryDirectory() as empty:  # and no numba cache anywhere else
                first = run(relax_cmd, folder, {**os.environ, "NUMBA_CACHE_DIR": empty})[0]
        else:
            run(relax_cmd, folder)  # compiled kernels cached on disk before timing
        ours, peer, report = [], [], ""
        for _ in range(args.repeats):
            seconds, report = run(relax_cmd, folder)
            ours.append(seconds)
            peer.append(run(peer_cmd, folder)[0])
    med, med_peer = statistics.median(ours), statistics.median(peer)
    print(report.strip())
    print(
        f"\nndboundary relax, {mesh.n_vertices} vertices ({size_mb:.0f} MB OBJ), end to end: median {med:.2f} s "
        f"(runs {', '.join(f'{s:.2f}' for s in ours)}); target <= 10 s {'PASS' if med <= 10 else 'FAIL'}\n"
        f"peer, meshio.read of the same OBJ alone: median {med_peer:.2f} s; the whole command takes "
        f"{med / med_peer:.2f}x meshio's read"
        + ("" if first is None else f"\nfirst run after installing (empty numba caches): {first:.2f} s")
    )
    print(json.dumps({"bench": "cli_speed", "n_vertices": int(mesh.n_vertices), "n_triangles": int(len(triangles)),
                      "obj_mb": size_mb, "seconds": ours, "median_s": med, "peer_meshio_read_s": peer,
                      "peer_median_s": med_peer, "ratio_to_peer": med / med_peer, "first_run_s": first}))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
