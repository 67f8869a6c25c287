"""Benchmark the solvers of the integration system ``(K M^-1 K + mu K + lam S^T S) phi = r``.

Builds the systems with the library itself (jittered Kuhn grids labelled by a circle /
ball, an icosphere cut by a plane), then times each available candidate in a fresh
subprocess (so that packages that clash, like cholespy and sksparse-minimal, and the
memory of one run do not affect another), ``--repeats`` times.

Prints one JSON line per run, then a table of medians: size, method, setup s, solve s,
iterations, residual, and the relative difference to the first direct solve.

    python benchmarks/solvers.py                       # default sizes, < 10 minutes
    python benchmarks/solvers.py --sizes 2d:640,3d:48  # bigger
    python benchmarks/solvers.py --methods auto,cholmod-direct

Candidates (each skipped when its package is missing; the first six are the default
``--methods``, the others on request):

- ``auto``: ``solve_integration``'s default;
- ``cholmod-direct`` / ``cholmod-pcg``: CHOLMOD from sksparse-minimal (direct on the
  whole matrix / factor of the ``K + D`` preconditioner);
- ``superlu-direct`` / ``superlu-pcg``: scipy SuperLU, the pure-scipy paths;
- ``superlu-rcm-direct``: SuperLU on the reverse Cuthill-McKee permuted matrix;
- ``amg-pcg``: pyamg smoothed aggregation V-cycle for ``(K + D)^{-1}``;
- ``cholespy-direct`` / ``cholespy-pcg``: cholespy's CHOLMOD;
- ``sksparse-direct`` / ``sksparse-pcg``: scikit-sparse's CHOLMOD (built against the
  system SuiteSparse);
- ``auto-blasthreads``: ``auto`` without limiting BLAS to one thread.

A method whose first run takes longer than ``--slow`` seconds is run once and not
tried on bigger sizes of the same kind of mesh.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy.sparse as sp

ALL_METHODS = [
    "auto",
    "cholmod-direct",
    "cholmod-pcg",
    "amg-pcg",
    "superlu-direct",
    "superlu-pcg",
    "superlu-rcm-direct",
    "cholespy-direct",
    "cholespy-pcg",
    "sksparse-direct",
    "sksparse-pcg",
    "auto-blasthreads",
]
DEFAULT_SIZES = "2d:160,2d:320,3d:16,3d:24,3d:32,ico:6"
DEFAULT_METHODS = "auto,cholmod-direct,cholmod-pcg,amg-pcg,superlu-direct,superlu-pcg"
NEEDS = {
    "cholmod": "sksparse_minimal",
    "amg": "pyamg",
    "cholespy": "cholespy",
    "sksparse": "sksparse.cholmod",
}


def build(spec, outdir):
    """Build the system ``spec`` ("2d:160", "3d:24", "ico:6") and save it; return its path."""
    from ndboundary import relax
    from ndboundary.datasets import ball, circle, icosphere, kuhn_grid, label_by

    try:
        from ndboundary.pipeline import DEFAULT_MU as mu
    except ImportError:
        mu = 0.0
    kind, n = spec.split(":")
    n = int(n)
    if kind == "ico":
        dom = icosphere(n)
        lab = label_by(dom, lambda x: x[:, 2] - 0.3)
        k = 2
    else:
        dim = int(kind[0])
        dom = kuhn_grid(n, dim, jitter=0.25, random_state=0)
        lab = label_by(dom, ball if dim == 3 else circle)
        k = dim
    r = relax(dom, lab, on="elements", rtol=1e-6)
    h = dom.mean_edge_length()
    K = (dom.K * h ** (2 - k)).tocsr()
    mass = dom.mass / h**k
    S = r.boundary.S.tocsr()
    path = os.path.join(outdir, spec.replace(":", "_") + ".npz")
    np.savez(
        path,
        K_data=K.data,
        K_indices=K.indices,
        K_indptr=K.indptr,
        K_shape=K.shape,
        S_data=S.data,
        S_indices=S.indices,
        S_indptr=S.indptr,
        S_shape=S.shape,
        mass=mass,
        phi=r.phi,
        mu=mu,
        lam=2.0,
    )
    return path


def _load_system(path):
    z = np.load(path)
    K = sp.csr_matrix((z["K_data"], z["K_indices"], z["K_indptr"]), shape=tuple(z["K_shape"]))
    S = sp.csr_matrix((z["S_data"], z["S_indices"], z["S_indptr"]), shape=tuple(z["S_shape"]))
    return K, z["mass"], S, z["phi"], float(z["mu"]), float(z["lam"])


def _patch_cholmod(solvers, which):
    """Make backend="cholmod" use cholespy's or scikit-sparse's CHOLMOD instead."""
    if which == "cholespy":
        import cholespy

        def factor(A):
            A = sp.csc_matrix(A)
            s = cholespy.CholeskySolverD(
                A.shape[0],
                A.indptr.astype(np.int32),
                A.indices.astype(np.int32),
                A.data.astype(np.float64),
                cholespy.MatrixType.CSC,
            )

            def solve(b):
                x = np.zeros_like(b)
                s.solve(np.ascontiguousarray(b, dtype=np.float64), x)
                return x

            return solve
    else:
        from sksparse.cholmod import cholesky

        def factor(A):
            return cholesky(sp.csc_matrix(A))

    real_load = solvers._load
    solvers._cholmod = factor
    solvers._load = lambda name: object() if name == "sksparse_minimal" else real_load(name)


def worker(path, method, repeats):
    """Run ``method`` on the system in ``path`` ``repeats`` times; print one JSON line each."""
    from ndboundary import solvers

    K, mass, S, phi_ref, mu, lam = _load_system(path)
    Q = (K @ sp.diags(1.0 / mass) @ K + mu * K + lam * (S.T @ S)).tocsr()
    rhs = Q @ phi_ref
    base = method.split("-")[0]
    kw = {}
    if base in ("cholespy", "sksparse"):
        _patch_cholmod(solvers, base)
        base = "cholmod"
    if method.startswith("auto"):
        pass
    elif base == "amg":
        kw = {"method": "pcg", "preconditioner": "amg"}
    elif method.endswith("-direct"):
        kw = {"method": "direct", "backend": "superlu" if base == "superlu" else "cholmod"}
    else:
        kw = {
            "method": "pcg",
            "preconditioner": "cholesky",
            "backend": "superlu" if base == "superlu" else "cholmod",
        }
    if method == "auto-blasthreads":
        import contextlib

        solvers._one_blas_thread = contextlib.nullcontext
    perm = None
    if method == "superlu-rcm-direct":
        from scipy.sparse.csgraph import reverse_cuthill_mckee

        perm = reverse_cuthill_mckee(Q, symmetric_mode=True)
        real = solvers._superlu

        def rcm_superlu(A):
            A = sp.csc_matrix(A)
            lu = sp.linalg.splu(
                A[perm][:, perm].tocsc(),
                permc_spec="NATURAL",
                diag_pivot_thresh=0.0,
                options={"SymmetricMode": True},
            )
            inv = np.empty_like(perm)
            inv[perm] = np.arange(perm.size)

            def solve(b):
                return lu.solve(b[perm])[inv]

            return solve

        solvers._superlu = rcm_superlu
        assert real is not None
    for rep in range(repeats):
        solvers.clear_cache()
        t = time.perf_counter()
        c = time.process_time()
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, cache=False, **kw)
        wall = time.perf_counter() - t
        cpu = time.process_time() - c
        row = {
            "size": os.path.basename(path)[:-4],
            "n": int(K.shape[0]),
            "method": method,
            "rep": rep,
            "solver": info.method,
            "setup": info.setup_time,
            "solve": info.solve_time,
            "wall": wall,
            "cpu": cpu,
            "iterations": int(info.iterations),
            "residual": info.residual,
        }
        np.save(path[:-4] + f"__{method}.npy", phi)
        print(json.dumps(row), flush=True)


def _available(method):
    import importlib.util

    base = method.split("-")[0]
    mod = NEEDS.get(base)
    if mod is None:
        return True
    try:  # find, not import: cholespy and sksparse-minimal clash in one process
        return importlib.util.find_spec(mod.split(".")[0]) is not None
    except Exception:  # noqa: BLE001
        return False


def main(argv=None):
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument(
        "--sizes", default=DEFAULT_SIZES, help=f"comma-separated kind:n (default {DEFAULT_SIZES})"
    )
    p.add_argument(
        "--methods", default=DEFAULT_METHODS, help=f"comma-separated, from {','.join(ALL_METHODS)}"
    )
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument(
        "--slow",
        type=float,
        default=20.0,
        help="seconds above which a method is not repeated nor grown",
    )
    p.add_argument(
        "--worker", nargs=3, metavar=("PATH", "METHOD", "REPEATS"), help=argparse.SUPPRESS
    )
    args = p.parse_args(argv)
    if args.worker:
        worker(args.worker[0], args.worker[1], int(args.worker[2]))
        return
    methods = [m for m in args.methods.split(",") if m]
    for m in methods:
        if m not in ALL_METHODS:
            p.error(f"unknown method {m!r}")
    methods = [m for m in methods if _available(m)]
    rows = []
    too_slow = set()
    with tempfile.TemporaryDirectory() as tmp:
        for spec in args.sizes.split(","):
            t = time.perf_counter()
            path = build(spec, tmp)
            print(f"# built {spec} in {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)
            kind = spec.split(":")[0]
            ref = None
            pending = []
            for m in methods:
                if (kind, m) in too_slow:
                    continue
                cmd = [sys.executable, os.path.abspath(__file__), "--worker", path, m, "1"]
                runs = []
                for rep in range(args.repeats):
                    out = subprocess.run(cmd, check=False, capture_output=True, text=True)
                    if out.returncode != 0:
                        print(
                            f"# {spec} {m} failed: {out.stderr.strip().splitlines()[-1:]}",
                            file=sys.stderr,
                        )
                        break
                    row = json.loads(out.stdout.strip().splitlines()[-1])
                    row["rep"] = rep
                    phi = np.load(path[:-4] + f"__{m}.npy")
                    if ref is None and m.endswith("direct"):
                        ref = phi
                        for r in pending:  # runs before the first direct one
                            r["diff_vs_direct"] = float(
                                np.linalg.norm(r.pop("_phi") - ref) / np.linalg.norm(ref)
                            )
                        pending = []
                    if ref is not None:
                        row["diff_vs_direct"] = float(
                            np.linalg.norm(phi - ref) / np.linalg.norm(ref)
                        )
                    else:
                        row["diff_vs_direct"] = None
                    row.pop("phi_sha", None)
                    print(json.dumps(row), flush=True)
                    if ref is None:
                        row["_phi"] = phi
                        pending.append(row)
                    runs.append(row)
                    if row["wall"] > args.slow:
                        too_slow.add((kind, m))
                        break
                if runs:
                    rows.append(runs)
    print()
    head = f"{'size':8s} {'n':>7s} {'method':18s} {'solver':13s} {'setup s':>8s} {'solve s':>8s} {'total s':>8s} {'cpu s':>7s} {'iters':>5s} {'residual':>9s} {'vs direct':>9s} runs"
    print(head)
    print("-" * len(head))
    for runs in rows:
        med = {
            k: float(np.median([r[k] for r in runs]))
            for k in ("setup", "solve", "wall", "cpu", "iterations", "residual")
        }
        r0 = runs[0]
        dv = max(
            (r["diff_vs_direct"] for r in runs if r["diff_vs_direct"] is not None), default=None
        )
        print(
            f"{r0['size']:8s} {r0['n']:7d} {r0['method']:18s} {r0['solver']:13s} {med['setup']:8.2f} {med['solve']:8.2f} "
            f"{med['wall']:8.2f} {med['cpu']:7.2f} {int(med['iterations']):5d} {med['residual']:9.1e} "
            f"{(f'{dv:9.1e}' if dv is not None else '        -')} {len(runs)}"
        )


if __name__ == "__main__":
    main()
