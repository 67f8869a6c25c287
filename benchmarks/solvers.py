"""Benchmark the solvers of the integration system ``(K M^-1 K + mu K + lam S^T S) phi = r``.

Captures the integration system that ``relax`` solves (jittered Kuhn grids labelled by
a circle / ball, an icosphere or the geodesic sphere of ``table1.py`` cut by a plane;
with ``relax``'s default ``band="auto"`` that is the band's system, ``--band none`` the
whole domain's), then times each available candidate in a fresh subprocess (so that
packages that clash, like cholespy and sksparse-minimal, and the memory of one run do
not affect another), ``--repeats`` times.

Prints the size of each system (unknowns, their share of the domain's vertices, entries
of ``K`` and ``Q``), one JSON line per run, then a table of medians: size, unknowns,
entries of ``Q``, method, setup s (assembly and factorisation / AMG hierarchy), solve s,
total s, its ratio to ``superlu-direct`` and to ``auto`` measured in the same run (``x
superlu``: 6.0 means six times faster), the peak memory the solve added to the
process, iterations, residual, and the relative difference to the first direct solve.

    python benchmarks/solvers.py                       # default sizes, < 10 minutes
    python benchmarks/solvers.py --sizes 2d:640,3d:48  # bigger
    python benchmarks/solvers.py --sizes sphere:77,sphere:158,sphere:317 \
        --methods pardiso-direct,cvxopt-direct,cholmod-direct,superlu-direct
    python benchmarks/solvers.py --factor-threads 1    # MKL / OpenBLAS threads of a factor

Sizes: ``2d:n`` / ``3d:n`` (Kuhn grid of n cells a side, a circle / ball of radius
0.6), ``3dsmall:n`` (the same grid, a ball of radius 0.3: a band thin against the
domain), ``ico:k`` (icosphere of subdivision k), ``sphere:f`` (geodesic sphere of
frequency f, 10 f^2 + 2 vertices: 77 -> 59K, 158 -> 250K, 316 -> 1.0M), ``voxels:n`` (the
ball of ``images_speed.py`` on n^3 voxels, relaxed by ``relax_image``: the system of its
inner band).

Choice for the band systems ``relax`` solved by default when it was 12 h wide, medians of 3 (2
cores shared with another user's work: single runs of one method spread by up to 50 %
while it was busy, and the medians of ``auto`` and ``amg-pcg``, the same solver, differ
by up to 17 %)::

    python benchmarks/solvers.py --sizes sphere:316,2d:999 --slow 40 --timeout 120 \
        --methods auto,pardiso-direct,cvxopt-direct,cholmod-direct,superlu-direct,amg-pcg
    python benchmarks/solvers.py --sizes 3dsmall:99,3d:62,3d:99 --slow 30 --timeout 45 \
      --methods auto,auto-nolight,amg-pcg,pardiso-pcg,cvxopt-pcg,cholmod-pcg,pardiso-direct,cvxopt-direct,cholmod-direct

On curves and surfaces the band's squared operator is cheap to factor: on the bands of
the 1 M-vertex sphere and triangle grid (62 K / 55 K unknowns) ``auto`` (cvxopt)
factorises and solves in 0.32 / 0.18 s, sksparse-minimal's CHOLMOD in 0.32 / 0.23 s,
SuperLU in 0.40 / 0.34 s, PARDISO in 0.96 / 0.58 s (loading MKL), AMG-PCG in 0.80 /
0.92 s. On tetrahedra ``auto`` keeps AMG-PCG: 2.1 s at 123 K unknowns (``3dsmall:99``),
3.1 s at 169 K (``3d:62``) and 9.4 s at 402 K (``3d:99``); PCG with a factored ``K + D``
takes 8.2 s and 13.8 s on the first two (PARDISO; 40-45 iterations, where AMG's need
45-51; cvxopt 26 s and 43 s), a factorisation of ``Q`` 35 s at 123 K (PARDISO; cvxopt and
sksparse-minimal more than 45 s). The band's ragged edge and the vertices padding adds
are light (a small lumped mass against their neighbours'): the AMG V-cycle alone
(``auto-nolight``) needed 76 and 104 iterations (3.0 s, 5.6 s) and more than 45 s on
``3d:99``, the Jacobi step on those vertices around it
(``ndboundary.solvers.amg.light_vertex_jacobi``) 45, 51 and 61. On the wider bands of
16 h (``3d:99``: 540 K unknowns), the V-cycle alone needed 463 iterations (94 s), with
the step 59 (16.8 s).

Those figures predate the V-cycle of forward sweeps before the coarse correction and
backward ones after, with two energy-minimisation iterations (``ndboundary.solvers.amg``),
and the 8 h band on simplices. With both, ``python benchmarks/solvers.py --sizes
3d:99,3d:62 --methods auto --slow 60`` gives 7.1 s (2.3 + 4.8, 72 iterations) at 277 K
unknowns on ``3d:99`` and 2.5 s (0.8 + 1.7, 59) at 115 K on ``3d:62``, at this script's rtol
of 1e-10; ``relax`` solves to its default 1e-7 (51 iterations on ``3d:99``).

Candidates (each skipped when its package is missing; by default ``--methods`` runs
``auto``, ``amg-pcg``, ``superlu-pcg`` and the ``-direct`` ones of PARDISO, cvxopt,
sksparse-minimal and SuperLU, the others on request):

- ``auto``: ``solve_integration``'s default;
- ``pardiso-direct`` / ``pardiso-pcg``: MKL PARDISO from pypardiso (direct on the whole
  matrix / factor of the ``K + D`` preconditioner);
- ``pardiso-md-direct`` / ``pardiso-metis-direct``: ``pardiso-direct`` ordered by
  minimum degree / by METIS whatever the size (``pardiso.MINIMUM_DEGREE_MAX`` chooses
  between them by the number of unknowns);
- ``cvxopt-direct`` / ``cvxopt-pcg``: cvxopt's supernodal CHOLMOD;
- ``cholmod-direct`` / ``cholmod-pcg``: CHOLMOD from sksparse-minimal;
- ``superlu-direct`` / ``superlu-pcg``: scipy SuperLU, the pure-scipy paths;
- ``superlu-rcm-direct``: SuperLU on the reverse Cuthill-McKee permuted matrix;
- ``amg-pcg``: pyamg smoothed aggregation V-cycle for ``(K + D)^{-1}``;
- ``amg-pcg-sweeps1`` / ``amg-pcg-sweeps2``: the same V-cycle with one / two Gauss-Seidel
  sweeps each way, solved to the ``rtol`` that ``relax`` solved the captured system to
  (``multigrid_sweeps``: one on cubic voxels, two elsewhere);
- ``cholespy-direct`` / ``cholespy-pcg``: cholespy's CHOLMOD;
- ``sksparse-direct`` / ``sksparse-pcg``: scikit-sparse's CHOLMOD (built against the
  system SuiteSparse);
- ``auto-blasthreads``: ``auto`` without limiting BLAS to one thread;
- ``auto-nolight``: ``auto`` without the Jacobi step on light vertices around the AMG
  V-cycle (``LIGHT_VERTEX_SHARE = 0``: the V-cycle alone, as before that step);
- ``auto-repeat`` / ``pardiso-direct-repeat``: the second solve on one mesh (after an
  untimed one with another ``lam``: same sparsity pattern, other values), where PARDISO
  reuses its ordering (kept by a ``FactorCache`` the two solves share; every other run
  passes ``cache=None`` and starts cold).

A method whose first run takes longer than ``--slow`` seconds is run once and not
tried on systems as large or larger of the same kind of mesh (``3dsmall`` counts as
``3d``); ``--timeout`` stops a run. ``--band none`` captures the whole domain's system
instead of the band's; ``--systems DIR`` keeps the captured systems for the next run.
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
    "auto-nolight",
    "auto-repeat",
    "pardiso-direct-repeat",
    "pardiso-md-direct",
    "pardiso-metis-direct",
    "amg-pcg-sweeps1",
    "amg-pcg-sweeps2",
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
    if kind == "voxels":  # the ball of images_speed.py, relaxed by relax_image
        from ndboundary import ImageGrid

        centre = (n - 1) / 2 + np.array([0.17, -0.23, 0.31]) * n / 64
        x = np.indices((n, n, n)).reshape(3, -1).T - centre
        return ImageGrid((n, n, n)), (np.linalg.norm(x, axis=1) < 0.32 * n).reshape(n, n, n)
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
    if kind == "3dsmall":  # a ball of radius 0.3: a band thin against the domain
        return dom, label_by(dom, lambda x: ball(x, r=0.3))
    return dom, label_by(dom, ball if dim == 3 else circle)


def build(spec, outdir, band="auto"):
    """Capture the integration system of ``relax`` on ``spec``, save it, return its path.

    ``spec`` is "2d:160", "3d:24", "3dsmall:99", "ico:6" or "sphere:158"; ``relax`` runs
    with its defaults and ``band`` ("auto": the band's system, "none": the whole
    domain's) up to the integration solve, whose arguments are saved with the domain's
    vertex count and the number of entries of ``Q``. A saved system is reused.
    """
    import ndboundary.pipeline.integration as step
    from ndboundary import relax

    path = os.path.join(outdir, spec.replace(":", "_") + ("" if band == "auto" else "-whole") + ".npz")
    if os.path.exists(path):
        return path
    dom, lab = _domain(spec)
    captured = {}

    def capture(K, mass, S, lam, rhs, *, mu=0.0, rtol=1e-10, **_kw):
        captured.update(K=sp.csr_matrix(K), S=sp.csr_matrix(S), mass=mass, lam=lam, rhs=rhs, mu=mu, rtol=rtol)
        raise _Captured

    real = step.solve_integration  # the solver the integration step calls
    step.solve_integration = capture
    try:
        if spec.startswith("voxels"):
            from ndboundary import relax_image

            relax_image(lab, band=None if band == "none" else band)
        else:
            relax(dom, lab, on="elements", band=None if band == "none" else band)
    except _Captured:
        pass
    finally:
        step.solve_integration = real
    K, S = captured["K"], captured["S"]
    Q = K @ sp.diags(1.0 / captured["mass"]) @ K + captured["lam"] * (S.T @ S)
    arrays = {f"{name}_{a}": getattr(M, a) for name, M in (("K", K), ("S", S)) for a in ("data", "indices", "indptr")}
    np.savez(
        path, **arrays, K_shape=K.shape, S_shape=S.shape, mass=captured["mass"], rhs=captured["rhs"],
        mu=captured["mu"], lam=captured["lam"], n_domain=dom.n_vertices, Q_nnz=Q.nnz, rtol=captured["rtol"],
    )  # fmt: skip
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
        if "-sweeps" in method:  # the V-cycle's sweeps each way, to the rtol relax solved to
            z = np.load(path)
            kw.update(sweeps=int(method.rsplit("sweeps", 1)[1]), rtol=float(z["rtol"]) if "rtol" in z else 1e-10)
    elif method.endswith(("-direct", "-direct-repeat")):
        kw = {"method": "direct", "backend": base}
    else:
        kw = {"method": "pcg", "preconditioner": "cholesky", "backend": base}
    if method in ("pardiso-md-direct", "pardiso-metis-direct"):
        from ndboundary.solvers import pardiso

        pardiso.MINIMUM_DEGREE_MAX = sys.maxsize if "-md-" in method else 0
    if method == "auto-nolight":
        solvers.amg.LIGHT_VERTEX_SHARE = 0.0
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
            "nnz": int(np.load(path)["Q_nnz"]),
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
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", default=DEFAULT_SIZES, help=f"comma-separated kind:n (default {DEFAULT_SIZES})")
    p.add_argument("--methods", default=DEFAULT_METHODS, help=f"comma-separated, from {','.join(ALL_METHODS)}")
    p.add_argument("--band", choices=("auto", "none"), default="auto", help="the band or whole domain")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--factor-threads", type=int, default=None, help="factorisation threads (default FACTOR_THREADS)")
    p.add_argument("--slow", type=float, default=20.0, help="seconds above which a method is not repeated nor grown")
    p.add_argument("--timeout", type=float, default=None, help="seconds after which a run is stopped (counts as slow)")
    p.add_argument("--systems", default=None, help="directory keeping the captured systems for later runs")
    p.add_argument("--worker", nargs=3, metavar=("PATH", "METHOD", "REPEATS"), help=argparse.SUPPRESS)
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
    too_slow = {}  # (kind of mesh, method): the fewest unknowns it was too slow on
    with tempfile.TemporaryDirectory() as tmp:
        outdir = args.systems or tmp
        os.makedirs(outdir, exist_ok=True)
        for spec in args.sizes.split(","):
            t = time.perf_counter()
            path = build(spec, outdir, args.band)
            z = np.load(path)
            n, share = int(z["K_shape"][0]), int(z["K_shape"][0]) / int(z["n_domain"])
            print(
                f"# {spec} band={args.band}: n {n} ({share:.0%} of {int(z['n_domain'])} vertices), nnz K "
                f"{z['K_data'].size}, nnz Q {int(z['Q_nnz'])}; built in {time.perf_counter() - t:.1f} s",
                file=sys.stderr, flush=True,
            )  # fmt: skip
            kind = spec.split(":")[0].replace("small", "")  # 3dsmall grows into 3d
            ref = [None, []]  # the first direct solve's phi, the runs waiting for it
            for m in methods:
                if too_slow.get((kind, m), np.inf) <= n:
                    continue
                cmd = [sys.executable, os.path.abspath(__file__), "--worker", path, m, "1"]
                if args.factor_threads is not None:
                    cmd += ["--factor-threads", str(args.factor_threads)]
                runs = _runs(cmd, spec, m, path, ref, args)
                if runs and runs[-1]["wall"] > args.slow:
                    too_slow[kind, m] = min(n, too_slow.get((kind, m), n))
                if runs:
                    rows.append(runs)
    print()
    print(table(rows))


def _runs(cmd, spec, m, path, ref, args):
    """Up to ``--repeats`` runs of ``cmd``, each compared with the first direct solve
    (``ref``); a run past ``--slow`` seconds ends them, one past ``--timeout`` is recorded
    with that many seconds and no solution.
    """
    runs = []
    for rep in range(args.repeats):
        try:
            out = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=args.timeout)
        except subprocess.TimeoutExpired:
            print(f"# {spec} {m} stopped after {args.timeout:.0f} s", file=sys.stderr, flush=True)
            nan = float("nan")
            z = np.load(path)
            row = {"size": os.path.basename(path)[:-4], "n": int(z["K_shape"][0]), "nnz": int(z["Q_nnz"]),
                   "method": m, "rep": rep, "solver": "timeout", "setup": nan, "solve": nan,
                   "wall": args.timeout, "cpu": nan, "iterations": 0, "residual": nan, "memory": nan,
                   "diff_vs_direct": None}  # fmt: skip
            print(json.dumps(row), flush=True)
            return [*runs, row]
        if out.returncode != 0:
            print(f"# {spec} {m} failed: {out.stderr.strip().splitlines()[-1:]}", file=sys.stderr)
            break
        row = json.loads(out.stdout.strip().splitlines()[-1])
        row["rep"] = rep
        phi = np.load(path[:-4] + f"__{m}.npy")
        if ref[0] is None and m.endswith("direct"):
            ref[0] = phi
            for r in ref[1]:  # runs before the first direct one
                r["diff_vs_direct"] = float(np.linalg.norm(r.pop("_phi") - phi) / np.linalg.norm(phi))
            ref[1].clear()
        row["diff_vs_direct"] = None
        if ref[0] is not None:
            row["diff_vs_direct"] = float(np.linalg.norm(phi - ref[0]) / np.linalg.norm(ref[0]))
        print(json.dumps(row), flush=True)
        if ref[0] is None:
            row["_phi"] = phi
            ref[1].append(row)
        runs.append(row)
        if row["wall"] > args.slow:
            break
    return runs


def table(rows):
    """The table of medians of ``rows`` (one list of runs per size and method), with the
    speed-ups over ``superlu-direct`` and ``auto`` of the same size in the same run.
    """
    med = []
    for runs in rows:
        keys = ("setup", "solve", "wall", "cpu", "iterations", "residual", "memory")
        m = {k: float(np.median([r[k] for r in runs])) for k in keys}
        m["runs"] = len(runs)
        m["diff"] = max((r["diff_vs_direct"] for r in runs if r["diff_vs_direct"] is not None), default=None)
        med.append((runs[0], m))
    peer = {(r0["size"], r0["method"]): m["wall"] for r0, m in med if r0["method"] in ("superlu-direct", "auto")}
    head = (
        f"{'size':14s} {'n':>8s} {'nnz Q':>10s} {'method':18s} {'solver':18s} {'setup s':>8s} {'solve s':>8s} "
        f"{'total s':>8s} {'x superlu':>9s} {'x auto':>6s} {'mem MB':>7s} {'cpu s':>7s} {'iters':>5s} "
        f"{'residual':>9s} {'vs direct':>9s} runs"
    )
    lines = [head, "-" * len(head)]
    for r0, m in med:
        ratios = []
        for name, width in (("superlu-direct", 9), ("auto", 6)):
            ref = peer.get((r0["size"], name))
            ratios.append(f"{ref / m['wall']:{width}.2f}" if ref else f"{'-':>{width}s}")
        diff = f"{m['diff']:9.1e}" if m["diff"] is not None else f"{'-':>9s}"
        total = f"{m['wall']:8.2f}" if r0["solver"] != "timeout" else f"{'>' + format(m['wall'], 'g'):>8s}"
        lines.append(
            f"{r0['size']:14s} {r0['n']:8d} {r0.get('nnz', 0):10d} {r0['method']:18s} {r0['solver']:18s} "
            f"{m['setup']:8.2f} {m['solve']:8.3f} {total} {' '.join(ratios)} {m['memory']:7.0f} "
            f"{m['cpu']:7.2f} {int(m['iterations']):5d} {m['residual']:9.1e} {diff} {m['runs']}"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    main()
