"""Reproduce the paper's Table 1: time per step of the relaxation on refined sphere meshes.

Livesu 2018, Table 1, times the four steps (heat, field, smoothing, integration) on a
triangle mesh of ~1K vertices refined up to 1M vertices (single-threaded C++, Eigen
LL^T). This script times ``ndboundary.relax`` on the same sizes and puts the paper's
figures beside ours, with the ratio ours / paper per step.

Meshes
    ``--mesh geodesic`` (default): class-I geodesic spheres, every icosahedron face cut
    into f^2 triangles, 10 f^2 + 2 vertices; f = 10, 20, 39, 77, 158, 316 give
    1 002, 4 002, 15 212, 59 292, 249 642 and 998 562 vertices, the paper's
    1K/4K/15K/60K/250K/1M, and f = 632 gives 3 994 242 (4M, beyond the paper).
    ``--mesh icosphere``: ``datasets.icosphere(s)``, s = 3..8
    (642 ... 655 362 vertices). Labelling: the plane cut z > 0.3 (``--cut wavy``:
    z > 0.3 + 0.1 sin(3 atan2(y, x))).
    ``--tets``: a 3-D series instead, ``kuhn_grid(n, 3, jitter=0.25)`` labelled by the
    ball r = 0.6, n = 10, 16, 25, 39, 62 ((n+1)^3 = 1.3K ... 250K vertices), and 99
    (1M) with ``--max-vertices 1000000``; ``--jitter 0`` for the plain Kuhn grid.

What is measured, per size, each run in its own subprocess (so that peak memory,
``ru_maxrss``, belongs to that run alone):
    * cold runs, ``--repeats`` times, each in a fresh process (imports and the loading
      of compiled kernels included): a fresh ``SimplicialComplex(points, simplices)``
      (nothing assembled) and a one-shot ``relax`` with the default ``band="auto"``;
      the median of each step of ``r.timings`` (locate, pad, heat, field, smoothing,
      integration, fill, total), of the construction, and of the end-to-end time
      (construction + relax). Operators are assembled inside the steps, on the band,
      as a user's first call would.
    * ``--assembly``: the whole domain's operator assembly (``.K``, ``.G``, ``.mass``,
      ``.adjacency``), which ``relax`` no longer needs (it raises the peak memory).
    * ``--vertex-pins``: phi held at the jagged boundary's vertices, as the paper does,
      instead of at its facets' centres (``ndboundary.pipeline.boundary.FACET_CENTRE_PINS``).
    * peak resident memory of the process, and the resident size right after imports.
    * a peer measured in the same run, up to ``--peer-max`` vertices: the whole
      domain's integration system (``band=None``, captured from the pipeline)
      assembled as ``K M^-1 K + mu K + lam S^T S`` and solved by
      ``scipy.sparse.linalg.spsolve`` (plain SuperLU, default options, no UMFPACK);
      ratio ours / peer of the integration step.

Every size has a deadline taken from ``--budget`` (default 540 s for the whole run):
a size that does not finish in time is reported as a timeout with whatever repeats
did finish, and larger sizes of that kind are skipped. The default run therefore
ends in under 10 minutes whatever the speed of the library.

Run::

    python benchmarks/table1.py                      # 1K .. 250K, defaults
    python benchmarks/table1.py --min-vertices 900000 --max-vertices 4000000 --budget 900
    python benchmarks/table1.py --params paper       # lam 0.5, 3 passes, plain form
    python benchmarks/table1.py --tets

Output: a table on stdout, then one JSON line per size (``{"bench": "table1", ...}``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

# verts: heat, field, smoothing, integration, total (seconds), Livesu 2018 Table 1
PAPER_TABLE = {
    1_000: (6e-3, 4e-5, 3e-3, 9e-3, 16e-3),
    4_000: (2e-2, 1e-4, 9e-4, 5e-2, 72e-3),
    15_000: (9e-2, 2e-4, 2e-3, 0.37, 0.46),
    60_000: (0.57, 1e-3, 1e-2, 3.7, 4.3),
    250_000: (3.62, 4e-3, 5e-2, 27.5, 31.2),
    1_000_000: (29.6, 1e-2, 0.19, 295.3, 325.1),
}
STEPS = ("heat", "field", "smoothing", "integration", "total")

GEODESIC_FREQ = (10, 20, 39, 77, 158, 316, 632)
ICOSPHERE_LEVELS = (3, 4, 5, 6, 7, 8)
KUHN_N = (10, 16, 25, 39, 62, 99)


def rss_mb():
    """Peak resident set size of this process so far, in MB (Linux reports KB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# --- meshes ---------------------------------------------------------------------

def geodesic_sphere(freq):
    """Class-I geodesic sphere: each icosahedron face cut into ``freq**2`` triangles.

    Returns ``(points, triangles)`` with ``10 freq^2 + 2`` points on the unit sphere.
    Points shared by faces are merged exactly, by their integer barycentric weights
    over the 12 icosahedron vertices.
    """
    from ndboundary.datasets import icosphere

    ico = icosphere(0)
    V0, F0 = ico.points, ico.simplices
    f = int(freq)
    # lattice (a, b, c) with a + b + c = f, and its triangles
    ij = [(i, j) for i in range(f + 1) for j in range(f + 1 - i)]
    index = {p: n for n, p in enumerate(ij)}
    lat = np.array(ij)
    tris = []
    for i in range(f):
        for j in range(f - i):
            tris.append((index[(i, j)], index[(i + 1, j)], index[(i, j + 1)]))
            if j < f - i - 1:
                tris.append((index[(i + 1, j)], index[(i + 1, j + 1)], index[(i, j + 1)]))
    tris = np.array(tris)
    wa, wb = lat[:, 0], lat[:, 1]
    wc = f - wa - wb
    nl = lat.shape[0]
    # key of a point: its weights over the 12 base vertices (sparse, 3 per face)
    W = np.zeros((F0.shape[0] * nl, 12), dtype=np.int64)
    rows = np.arange(F0.shape[0] * nl)
    for c, w in enumerate((wa, wb, wc)):
        vid = np.repeat(F0[:, c], nl)
        np.add.at(W, (rows, vid), np.tile(w, F0.shape[0]))
    uniq, inv = np.unique(W, axis=0, return_inverse=True)
    inv = inv.ravel()
    pts = (uniq @ V0) / f
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    T = (tris[None, :, :] + (np.arange(F0.shape[0]) * nl)[:, None, None]).reshape(-1, 3)
    T = inv[T]
    # orient outward like the icosahedron
    X = pts[T]
    nrm = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    neg = np.einsum("ij,ij->i", nrm, X.mean(axis=1)) < 0
    T[neg, 1], T[neg, 2] = T[neg, 2].copy(), T[neg, 1].copy()
    return pts, T


def make_mesh(family, param, jitter=0.25):
    """``(points, simplices, labels_fn)`` for one size of a series."""
    from ndboundary import SimplicialComplex  # noqa: F401
    from ndboundary.datasets import ball, icosphere, kuhn_grid

    if family == "geodesic":
        pts, T = geodesic_sphere(param)
    elif family == "icosphere":
        d = icosphere(param)
        pts, T = d.points, d.simplices
    elif family == "tets":
        d = kuhn_grid(param, 3, jitter=jitter, random_state=0)
        return d.points, d.simplices, ball
    else:
        raise ValueError(family)
    return pts, T, None


def cut_truth(cut):
    if cut == "plane":
        return lambda x: 0.3 - x[:, 2]
    return lambda x: 0.3 + 0.1 * np.sin(3 * np.arctan2(x[:, 1], x[:, 0])) - x[:, 2]


def n_vertices_of(family, param):
    if family == "geodesic":
        return 10 * param**2 + 2
    if family == "icosphere":
        return 10 * 4**param + 2
    return (param + 1) ** 3


def paper_row(nv):
    """The paper's row whose size is nearest (in log scale) to ``nv``."""
    key = min(PAPER_TABLE, key=lambda k: abs(np.log(k / nv)))
    return key, PAPER_TABLE[key]


# --- workers (run in a subprocess, one per size) -----------------------------------

def _emit(obj):
    print(json.dumps(obj), flush=True)


def worker_ours(args):
    import ndboundary
    from ndboundary import SimplicialComplex, relax
    from ndboundary.pipeline import boundary

    boundary.FACET_CENTRE_PINS = not args.vertex_pins

    _emit({"type": "start", "rss_after_import_mb": rss_mb()})
    t = time.perf_counter()
    pts, T, truth = make_mesh(args.family, args.param, args.jitter)
    t_mesh = time.perf_counter() - t
    truth = truth or cut_truth(args.cut)
    labels = (truth(pts[T].mean(axis=1)) < 0).astype(np.int64)  # datasets.label_by, without a domain
    params = ndboundary.PAPER if args.params == "paper" else {}
    if args.assembly:
        # operator assembly of the whole domain, which relax no longer needs
        t = time.perf_counter()
        dom = SimplicialComplex(pts, T)
        asm = {"construct": time.perf_counter() - t}
        for name in ("K", "G", "mass", "adjacency"):
            t = time.perf_counter()
            getattr(dom, name)
            asm[name] = time.perf_counter() - t
        asm["all"] = sum(asm.values())
        _emit({"type": "assembly", "assembly": asm, "rss_mb": rss_mb()})
        del dom
    _emit({"type": "mesh", "n_vertices": int(pts.shape[0]), "n_elements": int(T.shape[0]), "mesh_build": t_mesh})
    # cold: a fresh domain (nothing assembled) and a one-shot relax (nothing kept) per run
    for rep in range(args.repeats):
        t = time.perf_counter()
        dom = SimplicialComplex(pts, T)
        t_construct = time.perf_counter() - t
        r = relax(dom, labels, on="elements", **params)
        timings = {**r.timings, "construct": t_construct, "end_to_end": time.perf_counter() - t}
        _emit({"type": "repeat", "repeat": rep, "timings": timings,
               "solver": {k: vars(v) for k, v in r.solver.items()},
               "band_vertices": int(r.params.get("band_vertices", dom.n_vertices)),
               "n_sources": int(r.boundary.sources.size), "rss_mb": rss_mb(),
               "relax_params": {k: v for k, v in r.params.items() if isinstance(v, (int, float, str, bool))}})
        del r, dom


class _Captured(Exception):
    pass


def worker_peer(args):
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    import ndboundary
    import ndboundary.pipeline.integration as step
    from ndboundary import SimplicialComplex, relax
    from ndboundary.datasets import label_by

    _emit({"type": "start", "rss_after_import_mb": rss_mb()})
    pts, T, truth = make_mesh(args.family, args.param, args.jitter)
    truth = truth or cut_truth(args.cut)
    params = ndboundary.PAPER if args.params == "paper" else {}
    dom = SimplicialComplex(pts, T)
    labels = label_by(dom, truth)
    cap = {}

    def capture(K, mass, S, lam, rhs, **kw):
        cap.update(K=K, mass=mass, S=S, lam=lam, rhs=rhs, mu=float(kw.get("mu", 0.0)))
        raise _Captured

    original = step.solve_integration  # the solver the integration step calls
    step.solve_integration = capture  # grab the exact system the pipeline builds
    try:
        relax(dom, labels, on="elements", band=None, **params)
    except _Captured:
        pass
    finally:
        step.solve_integration = original
    K, mass, S, lam, rhs, mu = cap["K"], cap["mass"], cap["S"], cap["lam"], cap["rhs"], cap["mu"]
    del dom
    rss_before = rss_mb()
    t = time.perf_counter()
    Q = (K @ sp.diags(1.0 / mass) @ K + mu * K + lam * (S.T @ S)).tocsr()
    Q = ((Q + Q.T) * 0.5).tocsc()
    t_asm = time.perf_counter() - t
    t = time.perf_counter()
    x = spla.spsolve(Q, rhs, use_umfpack=False)
    t_solve = time.perf_counter() - t
    res = float(np.linalg.norm(Q @ x - rhs) / np.linalg.norm(rhs))
    _emit({"type": "peer", "n": int(Q.shape[0]), "nnz": int(Q.nnz), "assemble": t_asm, "spsolve": t_solve,
           "integration": t_asm + t_solve, "residual": res, "mu": mu, "lam": lam, "rss_before_mb": rss_before, "rss_mb": rss_mb()})


def run_worker(kind, family, param, args, timeout):
    cmd = [sys.executable, os.path.abspath(__file__), "--_worker", kind, "--_family", family,
           "--_param", str(param), "--repeats", "1", "--params", args.params, "--cut", args.cut,
           "--jitter", str(args.jitter)] + (["--assembly"] if args.assembly else []) + (
               ["--vertex-pins"] if args.vertex_pins else [])
    t = time.perf_counter()
    timed_out = False
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=max(timeout, 1.0))
        out, err, rc = p.stdout, p.stderr, p.returncode
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        err = e.stderr.decode() if isinstance(e.stderr, bytes) else (e.stderr or "")
        rc, timed_out = None, True
    wall = time.perf_counter() - t
    msgs = []
    for line in out.splitlines():
        try:
            msgs.append(json.loads(line))
        except json.JSONDecodeError:
            pass
    if rc not in (0, None):
        print(f"[table1] worker {kind} {family} {param} failed (rc={rc}):\n{err[-2000:]}", file=sys.stderr)
    return msgs, timed_out, wall, rc


# --- driver ---------------------------------------------------------------------------

def fmt(x, w=8):
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return f"{'-':>{w}s}"
    if x == 0:
        return f"{0:>{w}.0f}"
    if abs(x) >= 100:
        return f"{x:>{w}.0f}"
    if abs(x) >= 0.01:
        return f"{x:>{w}.3g}"
    return f"{x:>{w}.1e}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--max-vertices", type=int, default=250_000,
                    help="largest mesh (vertices); 1000000 adds the 1M row (default 250000)")
    ap.add_argument("--min-vertices", type=int, default=0, help="smallest mesh (vertices)")
    ap.add_argument("--mesh", choices=("geodesic", "icosphere"), default="geodesic",
                    help="sphere refinement (default geodesic: the paper's sizes)")
    ap.add_argument("--cut", choices=("plane", "wavy"), default="plane", help="labelling (default z > 0.3)")
    ap.add_argument("--tets", action="store_true", help="3-D Kuhn tetrahedral grids instead of spheres")
    ap.add_argument("--jitter", type=float, default=0.25,
                    help="--tets: vertex jitter of the Kuhn grids, in grid steps (default 0.25)")
    ap.add_argument("--repeats", type=int, default=3, help="runs per size; medians reported (default 3)")
    ap.add_argument("--params", choices=("default", "paper"), default="default",
                    help="library defaults (lam %(default)s) or ndboundary.PAPER (lam 0.5, 3 passes, plain)")
    ap.add_argument("--peer-max", type=int, default=250_000,
                    help="run the spsolve peer up to this many vertices (default 250000; 0 = never)")
    ap.add_argument("--budget", type=float, default=540.0,
                    help="wall-clock seconds for the whole run; sizes past it time out (default 540)")
    ap.add_argument("--size-timeout", type=float, default=300.0,
                    help="at most this many seconds per worker (default 300)")
    ap.add_argument("--assembly", action="store_true",
                    help="also time the whole domain's operator assembly (K, G, mass, adjacency), which relax "
                         "no longer needs; it raises the peak memory reported")
    ap.add_argument("--vertex-pins", action="store_true",
                    help="hold phi at the jagged boundary's vertices, as the paper does, not at its facets' centres")
    ap.add_argument("--_worker", choices=("ours", "peer"), help=argparse.SUPPRESS)
    ap.add_argument("--_family", help=argparse.SUPPRESS)
    ap.add_argument("--_param", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)

    if args._worker:
        args.family, args.param = args._family, args._param
        (worker_ours if args._worker == "ours" else worker_peer)(args)
        return 0

    import ndboundary

    family = "tets" if args.tets else args.mesh
    series = {"geodesic": GEODESIC_FREQ, "icosphere": ICOSPHERE_LEVELS, "tets": KUHN_N}[family]
    sizes = [p for p in series if args.min_vertices <= n_vertices_of(family, p) <= args.max_vertices]
    if args.params == "paper":
        pdesc = f"PAPER {ndboundary.PAPER}"
    else:
        pdesc = f"defaults lam={ndboundary.DEFAULT_LAM} smoothing={ndboundary.DEFAULT_SMOOTHING} form=mass"
    label = f"ball r=0.6, jitter {args.jitter}" if args.tets else {"plane": "z > 0.3", "wavy": "z > 0.3 + 0.1 sin(3 theta)"}[args.cut]
    print(f"# table1: {family} series, labels {label}, {pdesc}, repeats {args.repeats}, budget {args.budget:.0f} s",
          flush=True)
    t_start = time.perf_counter()
    results = []
    skip_ours = skip_peer = False
    for param in sizes:
        nv = n_vertices_of(family, param)
        row = {"bench": "table1", "family": family, "param": param, "n_vertices": nv,
               "labels": label, "params": args.params, "repeats_asked": args.repeats}
        left = args.budget - (time.perf_counter() - t_start)
        if skip_ours or left < 5:
            row["ours_status"] = "skipped"
        else:
            print(f"[table1] {family} {param}: {nv} vertices, ours (deadline {min(left, args.size_timeout):.0f} s)",
                  file=sys.stderr, flush=True)
            # every run in its own process: imports, compiled kernels loaded, a fresh domain
            msgs, timed_out, wall, rc = [], False, 0.0, 0
            for _ in range(args.repeats):
                left = args.budget - (time.perf_counter() - t_start)
                m, timed_out, w, rc = run_worker("ours", family, param, args, min(left, args.size_timeout))
                msgs, wall = msgs + m, wall + w
                if timed_out or rc != 0:
                    break
            reps = [m for m in msgs if m["type"] == "repeat"]
            asm = next((m for m in msgs if m["type"] == "assembly"), None)
            mesh = next((m for m in msgs if m["type"] == "mesh"), None)
            start = next((m for m in msgs if m["type"] == "start"), None)
            row["ours_status"] = "timeout" if timed_out else ("ok" if rc == 0 else f"error rc={rc}")
            row["ours_wall"] = wall
            row["repeats_done"] = len(reps)
            if start:
                row["rss_after_import_mb"] = start["rss_after_import_mb"]
            if mesh:
                row.update(n_vertices=mesh["n_vertices"], n_elements=mesh["n_elements"], mesh_build=mesh["mesh_build"])
            if asm:
                row["assembly"] = asm["assembly"]
            if reps:
                row["timings"] = {k: float(np.median([r["timings"][k] for r in reps])) for k in reps[0]["timings"]}
                row["timings_all"] = [r["timings"] for r in reps]
                row["solver"] = reps[-1]["solver"]
                row["band_vertices"] = reps[-1]["band_vertices"]
                row["relax_params"] = reps[-1].get("relax_params")
                row["peak_rss_mb"] = max(r["rss_mb"] for r in reps)
            if timed_out:
                skip_ours = True
        left = args.budget - (time.perf_counter() - t_start)
        if nv <= args.peer_max and not skip_peer and left >= 5:
            print(f"[table1] {family} {param}: {nv} vertices, peer spsolve (deadline {min(left, args.size_timeout):.0f} s)",
                  file=sys.stderr, flush=True)
            msgs, timed_out, wall, rc = run_worker("peer", family, param, args, min(left, args.size_timeout))
            peer = next((m for m in msgs if m["type"] == "peer"), None)
            row["peer_status"] = "timeout" if timed_out else ("ok" if peer else f"error rc={rc}")
            row["peer_deadline"] = min(left, args.size_timeout)
            if peer:
                row["peer"] = peer
            if timed_out:
                skip_peer = True
        else:
            row["peer_status"] = "skipped"
        pk, pv = paper_row(row["n_vertices"])
        row["paper_row"] = {"verts": pk, **dict(zip(STEPS, pv))}
        if "timings" in row:
            row["ratio_to_paper"] = {s: row["timings"][s] / row["paper_row"][s] for s in STEPS}
        if "timings" in row and "peer" in row:
            row["ratio_integration_to_peer"] = row["timings"]["integration"] / row["peer"]["integration"]
        results.append(row)

    # --- tables
    print()
    print("Per-step seconds (median of repeats, each on a fresh domain), ours vs the paper (nearest paper row;"
          " ratio = ours / paper)")
    hdr = f"{'verts':>8s} {'paper':>6s} {'reps':>4s} " + " ".join(
        f"{s[:6]:>8s} {'paper':>8s} {'ratio':>6s}" for s in STEPS)
    print(hdr)
    print("-" * len(hdr))
    for row in results:
        t = row.get("timings")
        pr = row["paper_row"]
        reps = f"{row.get('repeats_done', 0)}"
        if row.get("ours_status") == "timeout":
            reps += "!"
        cells = []
        for s in STEPS:
            ours = t.get(s) if t else None
            ratio = ours / pr[s] if ours else None
            cells.append(f"{fmt(ours)} {fmt(pr[s])} {fmt(ratio, 6)}")
        tag = f"{pr['verts'] // 1000}K" if pr["verts"] < 1_000_000 else "1M"
        print(f"{row['n_vertices']:>8d} {tag:>6s} {reps:>4s} " + " ".join(cells))
    if any(r.get("ours_status") == "timeout" for r in results):
        print("  '!' = the size hit its deadline; medians over the repeats that finished (none: '-').")
    print()
    print("End to end (s: a fresh domain and a one-shot relax), its parts outside the four steps, peak memory (MB),"
          " solver, and the spsolve peer")
    hdr2 = (f"{'verts':>8s} {'band %':>6s} {'constr':>7s} {'locate':>7s} {'pad':>7s} {'fill':>7s} {'e2e':>7s} "
            f"{'rss0':>6s} {'peakMB':>7s} {'heat it':>7s} {'int':>12s} "
            f"{'ours int':>8s} {'peer int':>8s} {'ratio':>6s} {'peerMB':>7s}")
    print(hdr2)
    print("-" * len(hdr2))
    for row in results:
        t = row.get("timings", {})
        sol = row.get("solver", {})
        peer = row.get("peer")
        integ = sol.get("integration")
        intdesc = f"{integ['method']}/{integ['iterations']}" if integ else "-"
        peer_int = peer["integration"] if peer else None
        if row.get("peer_status") == "timeout":
            peer_txt = f"{'>' + format(row['peer_deadline'], '.0f'):>8s}"
        else:
            peer_txt = fmt(peer_int)
        share = 100.0 * row["band_vertices"] / row["n_vertices"] if "band_vertices" in row else None
        print(f"{row['n_vertices']:>8d} {fmt(share, 6)} {fmt(t.get('construct'), 7)} {fmt(t.get('locate'), 7)} "
              f"{fmt(t.get('pad'), 7)} {fmt(t.get('fill'), 7)} {fmt(t.get('end_to_end'), 7)} "
              f"{fmt(row.get('rss_after_import_mb'), 6)} {fmt(row.get('peak_rss_mb'), 7)} "
              f"{(str(sol['heat']['iterations']) if sol else '-'):>7s} {intdesc:>12s} "
              f"{fmt(t.get('integration'))} {peer_txt} "
              f"{fmt(row.get('ratio_integration_to_peer'), 6)} {fmt(peer['rss_mb'] if peer else None, 7)}")
    print("  band % = the band's share of the vertices; constr = SimplicialComplex(points, simplices); locate ="
          " zeta and the band; fill = phi outside the band; e2e = constr + relax; rss0 = resident MB after imports;"
          " peakMB = ru_maxrss of the size's own process; peer int = the whole domain's system (band=None)"
          " assembled as K M^-1 K + mu K + lam S^T S and solved by spsolve; ratio = ours / peer.")
    print(f"  total wall time {time.perf_counter() - t_start:.0f} s")
    print()
    for row in results:
        print(json.dumps(row))
    return 0


if __name__ == "__main__":
    sys.exit(main())
