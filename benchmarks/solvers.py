"""Benchmark the solvers of the integration system ``(K M^-1 K + mu K + lam S^T S) phi = r``.

Captures the integration system that ``relax`` solves (jittered Kuhn grids labelled by
a circle / ball, an icosphere or the geodesic sphere of ``table1.py`` cut by a plane),
then times each available candidate in a fresh subprocess (so that packages that clash,
like cholespy and sksparse-minimal, and the memory of one run do not affect another),
``--repeats`` times.

Prints one JSON line per run, then a table of medians: size, method, setup s (assembly
and factorisation), solve s, total s, its ratio to ``superlu-direct`` measured in the
same run (``x superlu``: 6.0 means six times faster), the peak memory the solve added
to the process, iterations, residual, and the relative difference to the first direct
solve.

    python benchmarks/solvers.py                       # default sizes, < 10 minutes
    python benchmarks/solvers.py --sizes 2d:640,3d:48  # bigger
    python benchmarks/solvers.py --sizes sphere:77,sphere:158,sphere:317 \
        --methods pardiso-direct,cvxopt-direct,cholmod-direct,superlu-direct
    python benchmarks/solvers.py --factor-threads 1    # MKL / OpenBLAS threads of a factor

Sizes: ``2d:n`` / ``3d:n`` (Kuhn grid of n cells a side), ``ico:k`` (icosphere of
subdivision k), ``sphere:f`` (geodesic sphere of frequency f, 10 f^2 + 2 vertices:
77 -> 59K, 158 -> 250K, 317 -> 1.0M).

Candidates (each skipped when its package is missing; the first eight are the default
``--methods``, the others on request):

- ``auto``: ``solve_integration``'s default;
- ``pardiso-direct`` / ``pardiso-pcg``: MKL PARDISO from pypardiso (direct on the whole
  matrix / factor of the ``K + D`` preconditioner);
- ``cvxopt-direct`` / ``cvxopt-pcg``: cvxopt's supernodal CHOLMOD;
- ``cholmod-direct`` / ``cholmod-pcg``: CHOLMOD from sksparse-minimal;
- ``superlu-direct`` / ``superlu-pcg``: scipy SuperLU, the pure-scipy paths;
- ``superlu-rcm-direct``: SuperLU on the reverse Cuthill-McKee permuted matrix;
- ``amg-pcg``: pyamg smoothed aggregation V-cycle for ``(K + D)^{-1}``;
- ``cholespy-direct`` / ``cholespy-pcg``: cholespy's CHOLMOD;
- ``sksparse-direct`` / ``sksparse-pcg``: scikit-sparse's CHOLMOD (built against the
  system SuiteSparse);
- ``auto-blasthreads``: ``auto`` without limiting BLAS to one thread;
- ``auto-repeat`` / ``pardiso-direct-repeat``: the second solve on one mesh (after an
  untimed one with another ``lam``: same sparsity pattern, other values), where PARDISO
  reuses its ordering (kept by a ``FactorCache`` the two solves share; every other run
  passes ``cache=None`` and starts cold).

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
    "pardiso-direct",
    "pardiso-pcg",
    "cvxopt-direct",
    "cvxopt-pcg",
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
    "auto-repeat",
    "pardiso-direct-repeat",
]
DEFAULT_SIZES = "2d:160,2d:320,3d:16,3d:24,3d:32,ico:6,sphere:77,sphere:158"
DEFAULT_METHODS = (
    "auto,pardiso-direct,cvxopt-direct,cholmod-direct,amg-pcg,superlu-direct,superlu-pcg"
)
NEEDS = {
    "pardiso": "pypardiso",
    "cvxopt": "cvxopt",
    "cholmod": "sksparse_minimal",
    "amg": "pyamg",
    "cholespy": "cholespy",
    "sksparse": "sksparse.cholmod",
}


class _Captured(Exception):
    """Raised to stop ``relax`` once its integration system is captured."""


def _domain(spec):
    from ndboundary.datasets import ball, circle, icosphere, kuhn_grid, label_by

    kind, n = spec.split(":")
    n = int(n)
    if kind == "sphere":
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from table1 import geodesic_sphere

        from ndboundary import SimplicialComplex

        dom = SimplicialComplex(*geodesic_sphere(n))
        return dom, (dom.element_centroids()[:, 2] > 0.3).astype(int)
    if kind == "ico":
        dom = icosphere(n)
        return dom, label_by(dom, lambda x: x[:, 2] - 0.3)
    dim = int(kind[0])
    dom = kuhn_grid(n, dim, jitter=0.25, random_state=0)
    return dom, label_by(dom, ball if dim == 3 else circle)


def build(spec, outdir):
    """Capture the integration system of ``relax`` on ``spec``, save it, return its path.

    ``spec`` is "2d:160", "3d:24", "ico:6" or "sphere:158"; ``relax`` runs with its
    defaults up to the integration solve, whose arguments are saved.
    """
    import ndboundary.pipeline.integration as step
    from ndboundary import relax

    dom, lab = _domain(spec)
    captured = {}

    def capture(K, mass, S, lam, rhs, *, mu=0.0, **_kw):
        captured.update(K=sp.csr_matrix(K), S=sp.csr_matrix(S), mass=mass, lam=lam, rhs=rhs, mu=mu)
        raise _Captured

    real = step.solve_integration  # the solver the integration step calls
    step.solve_integration = capture
    try:
        relax(dom, lab, on="elements")
    except _Captured:
        pass
    finally:
        step.solve_integration = real
    K, S = captured["K"], captured["S"]
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
        mass=captured["mass"],
        rhs=captured["rhs"],
        mu=captured["mu"],
        lam=captured["lam"],
    )
    return path


def _load_system(path):
    z = np.load(path)
    K = sp.csr_matrix((z["K_data"], z["K_indices"], z["K_indptr"]), shape=tuple(z["K_shape"]))
    S = sp.csr_matrix((z["S_data"], z["S_indices"], z["S_indptr"]), shape=tuple(z["S_shape"]))
    return K, z["mass"], S, z["rhs"], float(z["mu"]), float(z["lam"])


def _patch_cholmod(which):
    """Make backend="cholmod" use cholespy's or scikit-sparse's CHOLMOD instead."""
    from ndboundary.solvers import cholesky as backends

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

    # the backend's module: the package actually used, in place of sksparse_minimal
    backends.BACKENDS["cholmod"] = NEEDS[which]
    backends.FACTORISERS["cholmod"] = factor


def _status_mb(field):
    """A memory field of /proc/self/status ("VmRSS", "VmHWM") in MB; NaN off Linux."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


def _reset_peak():
    """Reset the peak resident memory of this process to its current value (Linux)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def _peak_mb():
    """Peak resident memory of this process since the last :func:`_reset_peak`, in MB."""
    peak = _status_mb("VmHWM")
    if not np.isnan(peak):
        return peak
    import resource

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024


def worker(path, method, repeats, factor_threads=None):
    """Run ``method`` on the system in ``path`` ``repeats`` times; print one JSON line each."""
    from ndboundary import solvers
    from ndboundary.solvers import cholesky, common

    if factor_threads is not None:
        solvers.FACTOR_THREADS = factor_threads
    factor_threads = solvers.FACTOR_THREADS
    K, mass, S, rhs, mu, lam = _load_system(path)
    base = method.split("-")[0]
    kw = {}
    if base in ("cholespy", "sksparse"):
        _patch_cholmod(base)
        base = "cholmod"
    if method.startswith("auto"):
        pass
    elif base == "amg":
        kw = {"method": "pcg", "preconditioner": "amg"}
    elif method.endswith(("-direct", "-direct-repeat")):
        kw = {"method": "direct", "backend": base}
    else:
        kw = {"method": "pcg", "preconditioner": "cholesky", "backend": base}
    if method == "auto-blasthreads":
        common.SOLVE_THREADS = None  # BLAS's own number of threads during the solves
    perm = None
    if method == "superlu-rcm-direct":
        from scipy.sparse.csgraph import reverse_cuthill_mckee

        Q = (K @ sp.diags(1.0 / mass) @ K + mu * K + lam * (S.T @ S)).tocsr()
        perm = reverse_cuthill_mckee(Q, symmetric_mode=True)

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

        cholesky.FACTORISERS["superlu"] = rcm_superlu
    for rep in range(repeats):
        cache = None  # a cold solve: nothing kept from an earlier one
        if method.endswith("-repeat"):
            # an untimed solve of another lam (the same pattern) leaves PARDISO's ordering
            # in the cache, not its factor: the timed solve reuses the ordering only
            cache = solvers.FactorCache()
            solvers.solve_integration(K, mass, S, 2 * lam, rhs, mu=mu, cache=cache, **kw)
            cache.clear(orderings=False)
        rss0 = _status_mb("VmRSS")
        _reset_peak()
        t = time.perf_counter()
        c = time.process_time()
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, cache=cache, **kw)
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
            "memory": _peak_mb() - rss0,
            "factor_threads": factor_threads,
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
        "--factor-threads",
        type=int,
        default=None,
        help="threads of a sparse factorisation (default: ndboundary.solvers.FACTOR_THREADS)",
    )
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
        worker(args.worker[0], args.worker[1], int(args.worker[2]), args.factor_threads)
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
                cmd = [
                    sys.executable,
                    os.path.abspath(__file__),
                    "--worker",
                    path,
                    m,
                    "1",
                ]
                if args.factor_threads is not None:
                    cmd += ["--factor-threads", str(args.factor_threads)]
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
    print(table(rows))


def table(rows):
    """The table of medians of ``rows`` (one list of runs per size and method)."""
    med = []
    for runs in rows:
        m = {
            k: float(np.median([r[k] for r in runs]))
            for k in ("setup", "solve", "wall", "cpu", "iterations", "residual", "memory")
        }
        m["runs"] = len(runs)
        m["diff"] = max(
            (r["diff_vs_direct"] for r in runs if r["diff_vs_direct"] is not None), default=None
        )
        med.append((runs[0], m))
    superlu = {r0["size"]: m["wall"] for r0, m in med if r0["method"] == "superlu-direct"}
    head = (
        f"{'size':11s} {'n':>8s} {'method':18s} {'solver':13s} {'setup s':>8s} {'solve s':>8s} "
        f"{'total s':>8s} {'x superlu':>9s} {'mem MB':>7s} {'cpu s':>7s} {'iters':>5s} "
        f"{'residual':>9s} {'vs direct':>9s} runs"
    )
    lines = [head, "-" * len(head)]
    for r0, m in med:
        ref = superlu.get(r0["size"])
        ratio = f"{ref / m['wall']:9.2f}" if ref else f"{'-':>9s}"
        diff = f"{m['diff']:9.1e}" if m["diff"] is not None else f"{'-':>9s}"
        lines.append(
            f"{r0['size']:11s} {r0['n']:8d} {r0['method']:18s} {r0['solver']:13s} "
            f"{m['setup']:8.2f} {m['solve']:8.3f} {m['wall']:8.2f} {ratio} {m['memory']:7.0f} "
            f"{m['cpu']:7.2f} {int(m['iterations']):5d} {m['residual']:9.1e} {diff} {m['runs']}"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
