"""Redo the paper's Fig. 8: the joint effect of lam and the number of smoothing passes.

Livesu 2018, Fig. 8, shows a grid of relaxed boundaries, smoothing passes in rows and
lam in columns, and says: for lam >= 0.5 the result stays faithful to the jagged
boundary whatever the number of passes; small lam with many passes relaxes further.
Here the grid is measured rather than eyeballed. Domain: a jittered Kuhn grid
``kuhn_grid(80, 2, jitter=0.25, random_state=0)`` of [-1, 1]^2, cell size s = 2/80;
labels: the five-lobed flower ``datasets.flower`` (r = 0.55 (1 + 0.2 cos 5 theta)),
elements labelled by their centroid. Per cell of the grid:

* mean and max distance from the level set phi = 1/2 to the true flower, in units of
  s (distance to a dense sampling of the true curve, ``metrics.curve_distance``);
* length excess of the level set over the true length, in percent;
* whether the level set is one closed curve.

The same numbers for the jagged boundary are printed for reference. Both forms of the
integration are run: ``form="mass"`` (the library default) and ``form="plain"`` (the
paper's). The defaults cell (``DEFAULT_LAM``, ``DEFAULT_SMOOTHING``) and the paper's
cell (``PAPER``: lam 0.5, 3 passes) are marked.

Pictures (``--out-dir``, default ``docs/``): ``fig8.png`` (form mass) and
``fig8_plain.png`` (form plain), one panel per cell zoomed on a lobe of the flower:
jagged boundary grey, true curve thin black dashed, level set red, each panel titled
by its figures; the defaults cell is framed blue, the paper's cell framed orange.

Run::

    python benchmarks/fig8.py                       # about a minute
    python benchmarks/fig8.py --lams 0.1 0.5 2 --passes 3 60 --forms mass --no-plot

Output: two tables (one per form), then one JSON line per cell (``{"bench": "fig8", ...}``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

ZOOM = (0.28, 0.74, -0.14, 0.32)  # x0, x1, y0, y1: one lobe tip (theta = 0) and a concave waist


def true_flower(n=40_000):
    from ndboundary.datasets import flower_curve
    from ndboundary.metrics import closed_curve_length

    pts = flower_curve(n)
    return pts, closed_curve_length(pts)


def measure(complex_, dist, s, true_len):
    from ndboundary.metrics import fidelity

    f = fidelity(complex_, dist, s)
    L = complex_.measure()
    return {"mean": f["mean"], "max": f["max"], "length_excess_pct": 100.0 * (L / true_len - 1.0)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--n", type=int, default=80, help="grid cells a side (default 80)")
    ap.add_argument("--jitter", type=float, default=0.25, help="vertex jitter, fraction of a cell (default 0.25)")
    ap.add_argument("--seed", type=int, default=0, help="jitter random state (default 0)")
    ap.add_argument("--lams", type=float, nargs="+", default=[0.05, 0.1, 0.5, 2.0, 10.0], help="lam values (columns)")
    ap.add_argument("--passes", type=int, nargs="+", default=[3, 5, 10, 30, 60, 120],
                    help="smoothing passes (rows)")
    ap.add_argument("--forms", nargs="+", choices=("mass", "plain"), default=["mass", "plain"],
                    help="integration forms to run (default both)")
    ap.add_argument("--out-dir", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "docs"),
                    help="where fig8.png / fig8_plain.png go (default docs/)")
    ap.add_argument("--mu", type=float, default=None,
                    help="first-order fit weight passed to relax (default: the library's DEFAULT_MU, if any)")
    ap.add_argument("--no-plot", action="store_true", help="skip the pictures")
    args = ap.parse_args(argv)

    import ndboundary
    from ndboundary import relax
    from ndboundary.datasets import flower, kuhn_grid, label_by
    from ndboundary.metrics import as_complex, curve_distance

    t_start = time.perf_counter()
    dom = kuhn_grid(args.n, 2, jitter=args.jitter, random_state=args.seed)
    s = 2.0 / args.n
    labels = label_by(dom, flower)
    truth_pts, true_len = true_flower()
    dist = curve_distance(truth_pts)
    defaults = (float(ndboundary.DEFAULT_LAM), int(ndboundary.DEFAULT_SMOOTHING))
    paper = (float(ndboundary.PAPER["lam"]), int(ndboundary.PAPER["smoothing"]))

    jag = None
    results = {}
    for form in args.forms:
        for k in args.passes:
            for lam in args.lams:
                t = time.perf_counter()
                extra = {} if args.mu is None else {"mu": args.mu}
                r = relax(dom, labels, on="elements", lam=lam, smoothing=k, form=form, **extra)
                ls = r.level_set()
                if jag is None:
                    jag_c = as_complex(dom.points, r.boundary.facets)
                    jag = measure(jag_c, dist, s, true_len)
                m = measure(ls, dist, s, true_len)
                m.update(closed=bool(ls.is_closed()), components=int(ls.n_components()),
                         seconds=time.perf_counter() - t, solver=r.solver["integration"].method,
                         iterations=int(r.solver["integration"].iterations))
                results[(form, k, lam)] = (m, ls, r)
    elapsed = time.perf_counter() - t_start

    mu_used = args.mu if args.mu is not None else getattr(ndboundary, "DEFAULT_MU", None)
    print(f"# fig8: mu = {mu_used} (other parameters: library defaults)")
    print(f"# fig8: kuhn_grid({args.n}, 2, jitter={args.jitter}, random_state={args.seed}), flower labels, "
          f"s = 2/{args.n} = {s:.4f}, true length {true_len:.4f}")
    print(f"# jagged boundary: mean {jag['mean']:.3f} s, max {jag['max']:.3f} s, "
          f"length excess {jag['length_excess_pct']:+.1f}%")
    print(f"# defaults lam={defaults[0]:g} passes={defaults[1]} marked [D]; paper lam={paper[0]:g} passes={paper[1]} "
          f"marked [P] (the paper's form is plain)")
    for form in args.forms:
        print()
        print(f"form={form}: each cell 'mean/max distance (units of s)  length excess %'")
        head = f"{'passes':>6s} | " + " | ".join(f"{'lam=' + format(lam, 'g'):^21s}" for lam in args.lams)
        print(head)
        print("-" * len(head))
        for k in args.passes:
            cells = []
            for lam in args.lams:
                m = results[(form, k, lam)][0]
                tag = ""
                if (lam, k) == defaults:
                    tag = "D"
                if (lam, k) == paper:
                    tag = "P"
                bad = "" if (m["closed"] and m["components"] == 1) else "!"
                cells.append(f"{m['mean']:.3f}/{m['max']:.3f} {m['length_excess_pct']:+5.1f}%{tag:1s}{bad:1s}")
            print(f"{k:>6d} | " + " | ".join(f"{c:^21s}" for c in cells))
        print("  D = library defaults, P = paper's lam/passes; '!' = level set not a single closed curve")
    print(f"  {len(results)} runs in {elapsed:.0f} s")

    if not args.no_plot:
        os.makedirs(args.out_dir, exist_ok=True)
        for form in args.forms:
            name = "fig8.png" if form == "mass" else f"fig8_{form}.png"
            path = os.path.abspath(os.path.join(args.out_dir, name))
            plot(path, form, args, results, dom, truth_pts, jag, defaults, paper)
            print(f"  wrote {path}")

    print()
    for (form, k, lam), (m, _, r) in results.items():
        print(json.dumps({"bench": "fig8", "n": args.n, "jitter": args.jitter, "seed": args.seed, "form": form,
                          "lam": lam, "smoothing": k, "mu": r.params.get("mu"), "unit": "s", **m,
                          "jagged": jag, "is_default": (lam, k) == defaults, "is_paper": (lam, k) == paper}))
    return 0


def plot(path, form, args, results, dom, truth_pts, jag, defaults, paper):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    nr, nc = len(args.passes), len(args.lams)
    fig, axes = plt.subplots(nr, nc, figsize=(2.35 * nc, 2.45 * nr), squeeze=False)
    x0, x1, y0, y1 = ZOOM
    closed_truth = np.concatenate([truth_pts, truth_pts[:1]])
    any_r = next(iter(results.values()))[2]
    jag_segs = dom.points[any_r.boundary.facets]
    for i, k in enumerate(args.passes):
        for j, lam in enumerate(args.lams):
            ax = axes[i, j]
            m, ls, _ = results[(form, k, lam)]
            ax.add_collection(LineCollection(jag_segs, colors="0.6", linewidths=0.8))
            ax.plot(closed_truth[:, 0], closed_truth[:, 1], "k--", lw=0.6, dashes=(3, 2))
            ax.add_collection(LineCollection(ls.points[ls.simplices], colors="red", linewidths=1.2))
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(f"λ={lam:g}, {k} passes\nmean {m['mean']:.2f}s max {m['max']:.2f}s "
                         f"L{m['length_excess_pct']:+.1f}%", fontsize=7)
            frame = None
            if (lam, k) == defaults:
                frame, txt = "tab:blue", "default"
            if (lam, k) == paper:
                frame, txt = "tab:orange", "paper" + (" (exact)" if form == "plain" else " λ/passes")
            if frame:
                for sp_ in ax.spines.values():
                    sp_.set_edgecolor(frame)
                    sp_.set_linewidth(3)
                ax.text(0.03, 0.04, txt, transform=ax.transAxes, color=frame, fontsize=8, weight="bold")
    fig.suptitle(f"Fig. 8 redone, form={form}: rows = smoothing passes, columns = λ. kuhn_grid({args.n}, 2, "
                 f"jitter {args.jitter}), flower. Grey: jagged (mean {jag['mean']:.2f}s, max {jag['max']:.2f}s, "
                 f"L{jag['length_excess_pct']:+.0f}%), dashed: truth, red: φ = ½. s = cell size.", fontsize=8)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
