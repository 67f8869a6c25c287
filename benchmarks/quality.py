"""Core quality figures of ``ndboundary.relax`` with its DEFAULT parameters, against the jagged boundary.

Each case labels a mesh from a known smooth truth, relaxes the jagged boundary and
measures the level set phi = 1/2 (and the jagged boundary, for reference) against the
truth, with a pass/fail per target:

(a) 2-D: ``kuhn_grid(n, 2, jitter=0.25)`` of [-1, 1]^2, n = 80 and 160; truths circle
    r = 0.6 and flower (r = 0.55 (1 + 0.2 cos 5 theta)). Mean/max distance to the true
    curve in units of the cell size s = 2/n and of the mean edge length h; length
    excess. Targets: mean <= 0.12 s, max <= 0.45 s, |length excess| <= 1.5 %.
(b) 3-D: ``kuhn_grid(24, 3, jitter=0.25)``; ball r = 0.6 (mean, max in units of s,
    area excess, Euler characteristic, components, closed). Targets: mean <= 0.12 s,
    max <= 0.5 s, |area excess| <= 2 %, chi = 2, one closed surface. Torus
    (``datasets.torus``): one closed surface with chi = 0.
(c) Surface: ``icosphere(5)`` cut by the plane z = 0.3; mean distance to the true circle
    {z = 0.3, |x| = 1} in units of the mean edge length h. Target: mean <= 0.12 h.
(d) 4-D: ``kuhn_grid(8, 4, jitter=0.1)`` labelled by the 3-sphere r = 0.6; mean distance
    of the level set vs of the jagged boundary's vertices (the heat sources). Target:
    the level set at least 15 % closer.
(e) All of the above again with the paper's settings (``**ndboundary.PAPER``), for
    comparison (same targets, reported, not expected to pass).

Run::

    python benchmarks/quality.py              # about a minute or two
    python benchmarks/quality.py --no-paper   # defaults only
    python benchmarks/quality.py --seed 1     # another jitter

Output: a table per parameter set, then one JSON line per case (``{"bench": "quality", ...}``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def dense_circle(r=0.6, n=40_000):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    pts = np.stack([r * np.cos(th), r * np.sin(th)], 1)
    return pts, 2 * np.pi * r


def dense_flower(n=40_000):
    from ndboundary.datasets import flower_curve
    from ndboundary.metrics import closed_curve_length

    pts = flower_curve(n)
    return pts, closed_curve_length(pts)


def check(name, value, op, target):
    ok = {"<=": value <= target, ">=": value >= target, "==": value == target}[op]
    return {"name": name, "value": value, "op": op, "target": target, "pass": bool(ok)}


def case_2d(n, truth_name, params, seed):
    from ndboundary import relax
    from ndboundary.datasets import circle, flower, kuhn_grid, label_by
    from ndboundary.metrics import as_complex, curve_distance, fidelity

    dom = kuhn_grid(n, 2, jitter=0.25, random_state=seed)
    s = 2.0 / n
    h = dom.mean_edge_length()
    truth, (pts, true_len) = (circle, dense_circle()) if truth_name == "circle" else (flower, dense_flower())
    dist = curve_distance(pts)
    r = relax(dom, label_by(dom, truth), on="elements", **params)
    ls = r.level_set()
    jag = as_complex(dom.points, r.boundary.facets)
    f, fj = fidelity(ls, dist, s), fidelity(jag, dist, s)
    fh = fidelity(ls, dist, h)
    exc = 100 * (ls.measure() / true_len - 1)
    exc_j = 100 * (jag.measure() / true_len - 1)
    return {
        "case": f"2d-{truth_name}-{n}", "mean_s": f["mean"], "max_s": f["max"], "mean_h": fh["mean"], "max_h": fh["max"],
        "excess_pct": exc, "jagged_mean_s": fj["mean"], "jagged_max_s": fj["max"], "jagged_excess_pct": exc_j,
        "components": ls.n_components(), "closed": ls.is_closed(), "h_over_s": h / s, "seconds": r.timings["total"],
        "checks": [check("mean/s", f["mean"], "<=", 0.12), check("max/s", f["max"], "<=", 0.45),
                   check("|len exc|%", abs(exc), "<=", 1.5)],
    }


def case_solid(name, truth, area, params, seed, checks):
    """A 3-D truth in ``kuhn_grid(24, 3, jitter=0.25)``: distances in cell sizes, area
    excess, topology of the level set and of the jagged boundary; ``checks(row)`` lists
    the targets."""
    from ndboundary import relax
    from ndboundary.datasets import kuhn_grid, label_by
    from ndboundary.metrics import as_complex, fidelity

    n = 24
    dom = kuhn_grid(n, 3, jitter=0.25, random_state=seed)
    s = 2.0 / n
    r = relax(dom, label_by(dom, truth), on="elements", **params)
    ls = r.level_set()
    jag = as_complex(dom.points, r.boundary.facets)
    dist = lambda x: np.abs(truth(x))  # noqa: E731
    f, fj = fidelity(ls, dist, s), fidelity(jag, dist, s)
    row = {
        "case": name, "mean_s": f["mean"], "max_s": f["max"], "excess_pct": 100 * (ls.measure() / area - 1),
        "jagged_mean_s": fj["mean"], "jagged_max_s": fj["max"], "jagged_excess_pct": 100 * (jag.measure() / area - 1),
        "euler": ls.euler_characteristic(), "components": ls.n_components(), "closed": ls.is_closed(),
        "jagged_euler": jag.euler_characteristic(), "jagged_components": jag.n_components(),
        "seconds": r.timings["total"],
    }
    row["checks"] = checks(row)
    return row


def case_ball(params, seed):
    from ndboundary.datasets import ball

    return case_solid("3d-ball-24", ball, 4 * np.pi * 0.6**2, params, seed, lambda r: [
        check("mean/s", r["mean_s"], "<=", 0.12), check("max/s", r["max_s"], "<=", 0.5),
        check("|area exc|%", abs(r["excess_pct"]), "<=", 2.0), check("chi", r["euler"], "==", 2),
        check("components", r["components"], "==", 1), check("closed", int(r["closed"]), "==", 1),
    ])


def case_torus(params, seed):
    from ndboundary.datasets import torus

    return case_solid("3d-torus-24", torus, 4 * np.pi**2 * 0.55 * 0.25, params, seed, lambda r: [
        check("components", r["components"], "==", 1), check("closed", int(r["closed"]), "==", 1),
        check("chi", r["euler"], "==", 0),
    ])


def case_icosphere(params):
    from ndboundary import relax
    from ndboundary.datasets import icosphere, label_by
    from ndboundary.metrics import as_complex, fidelity

    dom = icosphere(5)
    h = dom.mean_edge_length()
    rho = np.sqrt(1 - 0.09)

    def dist(x):
        return np.hypot(np.linalg.norm(x[:, :2], axis=1) - rho, x[:, 2] - 0.3)

    r = relax(dom, label_by(dom, lambda x: 0.3 - x[:, 2]), on="elements", **params)
    ls = r.level_set()
    jag = as_complex(dom.points, r.boundary.facets)
    f, fj = fidelity(ls, dist, h), fidelity(jag, dist, h)
    L = 2 * np.pi * rho
    return {
        "case": "ico5-plane", "mean_h": f["mean"], "max_h": f["max"], "excess_pct": 100 * (ls.measure() / L - 1),
        "jagged_mean_h": fj["mean"], "jagged_max_h": fj["max"], "jagged_excess_pct": 100 * (jag.measure() / L - 1),
        "components": ls.n_components(), "closed": ls.is_closed(), "seconds": r.timings["total"],
        "checks": [check("mean/h", f["mean"], "<=", 0.12)],
    }


def case_4d(params, seed):
    from ndboundary import relax
    from ndboundary.datasets import ball, kuhn_grid, label_by
    from ndboundary.metrics import as_complex, fidelity

    n = 8
    dom = kuhn_grid(n, 4, jitter=0.1, random_state=seed)
    s = 2.0 / n
    r = relax(dom, label_by(dom, ball), on="elements", **params)
    ls = r.level_set()
    jag = as_complex(dom.points, r.boundary.sources[:, None])
    dist = lambda x: np.abs(ball(x))  # noqa: E731
    f, fj = fidelity(ls, dist, s), fidelity(jag, dist, s)
    gain = 1 - f["mean"] / fj["mean"]
    return {
        "case": "4d-ball-8", "mean_s": f["mean"], "max_s": f["max"], "jagged_mean_s": fj["mean"],
        "jagged_max_s": fj["max"], "improvement_pct": 100 * gain, "ratio": f["mean"] / fj["mean"],
        "components": ls.n_components(), "closed": ls.is_closed(), "seconds": r.timings["total"],
        "checks": [check("closer %", 100 * gain, ">=", 15.0)],
    }


def fmtv(v):
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return f"{v:.3f}"


def run_set(label, params, seed):
    t0 = time.perf_counter()
    rows = []
    for n in (80, 160):
        for tn in ("circle", "flower"):
            rows.append(case_2d(n, tn, params, seed))
    rows.append(case_ball(params, seed))
    rows.append(case_torus(params, seed))
    rows.append(case_icosphere(params))
    rows.append(case_4d(params, seed))
    for r in rows:
        r["set"] = label
    return rows, time.perf_counter() - t0


def print_set(label, params, rows, elapsed):
    print(f"== {label}: {params} ({elapsed:.0f} s)")
    hdr = (f"{'case':<14s} {'mean':>7s} {'max':>7s} {'unit':>4s} {'mean/h':>7s} {'exc%':>7s} "
           f"{'jag mean':>8s} {'jag max':>7s} {'jag exc%':>8s} {'comp':>4s} {'closed':>6s} {'chi':>4s}  checks")
    print(hdr)
    print("-" * (len(hdr) + 40))
    for r in rows:
        unit = "h" if "mean_h" in r and "mean_s" not in r else "s"
        mean = r.get("mean_s", r.get("mean_h"))
        mx = r.get("max_s", r.get("max_h"))
        jm = r.get("jagged_mean_s", r.get("jagged_mean_h"))
        jx = r.get("jagged_max_s", r.get("jagged_max_h"))
        mean_h = r.get("mean_h") if unit == "s" else None
        chk = "  ".join(f"{c['name']} {fmtv(c['value'])}{c['op']}{fmtv(c['target'])} "
                        f"{'PASS' if c['pass'] else 'FAIL'}" for c in r["checks"])
        print(f"{r['case']:<14s} {mean:7.3f} {mx:7.3f} {unit:>4s} "
              f"{(format(mean_h, '7.3f') if mean_h is not None else '-'):>7s} "
              f"{(format(r['excess_pct'], '+7.2f') if 'excess_pct' in r else '-'):>7s} "
              f"{jm:8.3f} {jx:7.3f} "
              f"{(format(r['jagged_excess_pct'], '+8.1f') if 'jagged_excess_pct' in r else '-'):>8s} "
              f"{r['components']:>4d} {str(bool(r['closed'])):>6s} {str(r.get('euler', '-')):>4s}  {chk}")
        if r["case"].startswith("4d"):
            print(f"{'':<14s} level set / jagged vertices mean distance ratio {r['ratio']:.3f}, "
                  f"{r['improvement_pct']:.1f}% closer")
    n_fail = sum(not c["pass"] for r in rows for c in r["checks"])
    n_all = sum(len(r["checks"]) for r in rows)
    print(f"  {n_all - n_fail}/{n_all} checks pass"
          + ("" if not n_fail else ": FAIL " + ", ".join(
              f"{r['case']}:{c['name']}" for r in rows for c in r["checks"] if not c["pass"])))
    print()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--seed", type=int, default=0, help="jitter random state of the Kuhn grids (default 0)")
    ap.add_argument("--no-paper", action="store_true", help="skip (e), the run with the paper's settings")
    args = ap.parse_args(argv)

    import ndboundary

    sets = [("defaults", {})]
    if not args.no_paper:
        sets.append(("paper", dict(ndboundary.PAPER)))
    print(f"# quality: ndboundary defaults lam={ndboundary.DEFAULT_LAM} smoothing={ndboundary.DEFAULT_SMOOTHING} "
          f"form=mass; jitter seed {args.seed}; distances: s = cell size 2/n, h = mean edge length; "
          f"jag = the jagged boundary (for 4-D: its vertices)")
    all_rows = []
    for label, params in sets:
        rows, elapsed = run_set(label, params, args.seed)
        shown = params or {"lam": ndboundary.DEFAULT_LAM, "smoothing": ndboundary.DEFAULT_SMOOTHING, "form": "mass"}
        print_set(label, shown, rows, elapsed)
        all_rows += rows
    for r in all_rows:
        out = {"bench": "quality", "seed": args.seed}
        out.update({k: (bool(v) if isinstance(v, (bool, np.bool_)) else v) for k, v in r.items()})
        out["all_pass"] = all(c["pass"] for c in r["checks"])
        print(json.dumps(out, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
