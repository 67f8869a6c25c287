"""Reading and writing a 1 M-vertex triangle mesh: OBJ, OFF, binary and ASCII PLY, the phi writer (VTU),
and the surface writers: binary STL, VTP and the STL of named solids.

The mesh is a jittered Kuhn grid of ``--n`` cells a side (999: 1,000,000 vertices and
1,996,002 triangles) lifted onto the surface ``z = 0.1 sin(3x) cos(2y)``, so that every
coordinate is written with 17 significant digits. Each format is written to a temporary
folder and read back; medians of ``--repeats`` runs, wall clock and CPU time (the
machine may be shared: CPU time is the steadier figure).

- write: ``write_mesh`` (OBJ, OFF; binary PLY through meshio), ``write_ascii_ply`` (the
  ASCII PLY of ``write_level_set``), and ``write_mesh`` to ``.vtu`` with the point data
  ``phi`` and ``u`` and three cell arrays, what ``write_phi`` writes. Written only: the
  binary STL and the VTP of ``write_level_set``, a VTP with a pair of regions per
  triangle and the ASCII STL of one named solid per pair, what ``write_interfaces``
  writes (the triangles dealt into four pairs), beside meshio's ASCII STL of one unnamed
  solid, the peer.
- read: ``read_mesh`` (parsing and building the domain) and, on its own, the format's
  reader (``parse``). The peer, timed once in the same run: the line-by-line reader the
  compiled scans fall back on (OBJ, OFF), meshio (PLY), and the ratio to ``parse``.

Run::

    python benchmarks/io_speed.py                  # 1 M vertices, about three minutes
    python benchmarks/io_speed.py --n 300 --repeats 5
    python benchmarks/io_speed.py --first-run      # also each format's first read after an install

``--first-run`` also reads each file in ``--repeats`` fresh processes whose numba cache is
an empty folder, as the first read after a new install does (``first_read_s``, their median:
``read_mesh`` alone, imports excluded, compilation included).

Prints a table, then one JSON line per format (``{"bench": "io_speed", ...}``).
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

import numpy as np

from ndboundary import SimplicialComplex, read_mesh, write_mesh
from ndboundary.datasets import kuhn_grid
from ndboundary.io.meshio_formats import read_with_meshio
from ndboundary.io.obj import read_obj, read_obj_lines
from ndboundary.io.off import read_off, read_off_lines
from ndboundary.io.ply import read_ply, write_ascii_ply
from ndboundary.io.stl import write_ascii_stl_solids, write_binary_stl
from ndboundary.io.vtu import write_vtp


def surface(n):
    """The benchmark mesh: a jittered Kuhn grid of ``n`` cells a side, lifted to 3-D."""
    grid = kuhn_grid(n, 2, jitter=0.25, random_state=0)
    x, y = grid.points.T
    return SimplicialComplex(np.c_[x, y, 0.1 * np.sin(3 * x) * np.cos(2 * y)], grid.simplices)


def timed(fn, repeats):
    """Median wall and CPU seconds of ``repeats`` calls, and the last result."""
    walls, cpus, out = [], [], None
    for _ in range(repeats):
        out = None  # free the last result (a domain of a million vertices) before the next run
        wall, cpu = time.perf_counter(), time.process_time()
        out = fn()
        cpus.append(time.process_time() - cpu)
        walls.append(time.perf_counter() - wall)
    return statistics.median(walls), statistics.median(cpus), out


def formats(mesh, folder):
    """Per format: (name, path, writer, reader, peer reader)."""
    phi = {"phi": mesh.points[:, 0], "u": mesh.points[:, 2]}
    ascii_ply = lambda p: write_ascii_ply(p, mesh.points, mesh.simplices)  # noqa: E731

    def ascii_stl_meshio(path):  # the peer of the named solids: one unnamed solid
        import meshio

        meshio.write(path, meshio.Mesh(mesh.points, [("triangle", mesh.simplices)]), file_format="stl", binary=False)

    cells = {"labels": np.arange(mesh.n_elements) % 2, "field": np.ones((mesh.n_elements, 3))}
    cells["smoothed_field"] = cells["field"]
    group = np.arange(mesh.n_elements) % 4
    kinds = np.array([[0, 1], [0, 2], [1, 2], [1, 3]])
    pairs = kinds[group]
    pair_data = {"region_a": pairs[:, 0], "region_b": pairs[:, 1]}
    names = {g: f"{a}|{b}" for g, (a, b) in enumerate(kinds.tolist())}
    return [
        ("obj", folder / "m.obj", lambda p: write_mesh(p, mesh), read_obj, read_obj_lines),
        ("off", folder / "m.off", lambda p: write_mesh(p, mesh), read_off, read_off_lines),
        ("ply-binary", folder / "b.ply", lambda p: write_mesh(p, mesh), read_ply, read_with_meshio),
        ("ply-ascii", folder / "a.ply", ascii_ply, read_ply, read_with_meshio),
        ("vtu-phi", folder / "phi.vtu", lambda p: write_mesh(p, mesh, point_data=phi, cell_data=cells), None, None),
        ("stl-binary", folder / "s.stl", lambda p: write_binary_stl(p, mesh.points, mesh.simplices), None, None),
        ("vtp", folder / "s.vtp", lambda p: write_vtp(p, mesh.points, "triangle", mesh.simplices), None, None),
        ("vtp-pairs", folder / "i.vtp", lambda p: write_vtp(p, mesh.points, "triangle", mesh.simplices,
                                                            cell_data=pair_data), None, None),
        ("stl-solids", folder / "i.stl", lambda p: write_ascii_stl_solids(p, mesh.points, mesh.simplices, group, names),
         None, None),
        ("stl-ascii-meshio", folder / "m.stl", ascii_stl_meshio, None, None),
    ]


FIRST_READ = """
import sys, time
from ndboundary import read_mesh
t = time.perf_counter()
read_mesh(sys.argv[1])
print(time.perf_counter() - t)
"""


def first_read(path, repeats):
    """Median seconds of ``read_mesh(path)``, each in a fresh process with an empty numba cache."""
    seconds = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            done = subprocess.run([sys.executable, "-c", FIRST_READ, str(path)], env=env, capture_output=True,
                                  text=True, check=True)  # fmt: skip
        seconds.append(float(done.stdout.split()[-1]))
    return statistics.median(seconds)


def run(n, repeats, peer, first=False):
    mesh = surface(n)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, write, parse, reference in formats(mesh, Path(tmp)):
            row = {"bench": "io_speed", "format": name, "n_vertices": mesh.n_vertices, "n_triangles": mesh.n_elements}
            row["write_s"], row["write_cpu_s"], _ = timed(lambda: write(path), repeats)  # noqa: B023
            row["mb"] = os.path.getsize(path) / 1e6
            if parse is not None:
                row["read_s"], row["read_cpu_s"], domain = timed(lambda: read_mesh(path), repeats)  # noqa: B023
                assert domain.n_vertices == mesh.n_vertices and domain.n_elements == mesh.n_elements
                del domain
                row["parse_s"], row["parse_cpu_s"], _ = timed(lambda: parse(path), repeats)  # noqa: B023
                if first:
                    row["first_read_s"] = first_read(path, repeats)
            if peer and reference is not None:
                row["peer"] = reference.__name__
                row["peer_parse_s"], _, _ = timed(lambda: reference(path), 1)  # noqa: B023
                row["peer_ratio"] = row["peer_parse_s"] / row["parse_s"]
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def table(rows):
    def cell(row, key):
        return f"{row[key]:.2f}" if key in row else "-"

    head = ["format", "MB", "write s", "write cpu", "read s", "read cpu", "parse s", "first read s", "peer", "peer s",
            "x peer"]  # fmt: skip
    print("\n" + " | ".join(head))
    print(" | ".join("-" * len(h) for h in head))
    for r in rows:
        keys = ["mb", "write_s", "write_cpu_s", "read_s", "read_cpu_s", "parse_s", "first_read_s"]
        print(" | ".join([r["format"], *(cell(r, k) for k in keys), r.get("peer", "-"), cell(r, "peer_parse_s"),
                          cell(r, "peer_ratio")]))  # fmt: skip


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=999, help="cells a side of the Kuhn grid (999: 1 M vertices)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-peer", action="store_true", help="skip the line readers and meshio")
    parser.add_argument("--first-run", action="store_true", help="also time each first read after an install")
    args = parser.parse_args()
    read_mesh_warmup()
    rows = run(args.n, args.repeats, not args.no_peer, args.first_run)
    table(rows)
    print()
    for row in rows:
        print(json.dumps(row))


def read_mesh_warmup():
    """Load (or compile, once per installation) the compiled scans and writers, so that no timing holds it."""
    mesh = surface(250)  # files and arrays above the sizes that use the compiled code
    with tempfile.TemporaryDirectory() as tmp:
        for ext in (".obj", ".off", ".ply"):
            write_mesh(Path(tmp) / f"w{ext}", mesh)
            read_mesh(Path(tmp) / f"w{ext}")
        write_ascii_ply(Path(tmp) / "a.ply", mesh.points, mesh.simplices)
        read_mesh(Path(tmp) / "a.ply")


if __name__ == "__main__":
    main()
