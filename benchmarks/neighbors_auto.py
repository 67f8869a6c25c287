"""Held-out accuracy and fit time of the classifier with 40 and with 15 neighbours (not a test).

``n_neighbors="auto"`` takes 40 neighbours up to ``AUTO_NEIGHBORS_MAX_SAMPLES`` samples and
15 beyond. This measures both on data sets of ``--sizes`` training samples that the
defaults were not chosen on: five scikit-learn generators and the 5-dimensional manifold
in R^50 of ``benchmarks/scale.py``, each drawn with ``--seeds`` seeds, trained on ``n``
samples and tested on ``n`` others; SVC on the same split for reference. Features are
standardised for every model except on the manifold (as ``scale.py`` does). Prints one
line per draw, the means per size, and one JSON line.

Usage::

    python benchmarks/neighbors_auto.py [--sizes 2500,5000] [--seeds 2]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scale import make_data
from sklearn import datasets
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from ndboundary import LevelSetClassifier

GENERATORS = {
    "classification_10": lambda n, s: datasets.make_classification(n, 10, random_state=s),
    "classification_20_8": lambda n, s: datasets.make_classification(n, 20, n_informative=8, random_state=s),
    "classification_flip": lambda n, s: datasets.make_classification(
        n, 10, n_informative=4, flip_y=0.1, random_state=s
    ),
    "moons": lambda n, s: datasets.make_moons(n, noise=0.3, random_state=s),
    "gaussian_quantiles": lambda n, s: datasets.make_gaussian_quantiles(
        n_samples=n, n_features=6, n_classes=3, random_state=s
    ),
    "hastie": lambda n, s: datasets.make_hastie_10_2(n, random_state=s),
    "manifold_50": lambda n, s: make_data(n, 50, seed=s),
}


def held_out(model, X, y, n):
    """Accuracy on the second ``n`` samples after fitting on the first ``n``, and the fit's seconds."""
    t0 = time.perf_counter()
    model.fit(X[:n], y[:n])
    seconds = time.perf_counter() - t0
    return float(model.score(X[n:], y[n:])), seconds


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="2500,5000", help="training samples, comma-separated")
    ap.add_argument("--seeds", type=int, default=2)
    args = ap.parse_args()
    rows = []
    for n in [int(v) for v in args.sizes.split(",")]:
        for name, make in GENERATORS.items():
            for seed in range(args.seeds):
                X, y = make(2 * n, seed)

                def scaled(est, name=name):
                    return est if name.startswith("manifold") else make_pipeline(StandardScaler(), est)

                (a40, t40), (a15, t15) = (
                    held_out(scaled(LevelSetClassifier(n_neighbors=k)), X, y, n) for k in (40, 15)
                )
                svc, _ = held_out(scaled(SVC()), X, y, n)
                rows.append({"n": n, "data": name, "seed": seed, "k40": a40, "k15": a15, "svc": svc,
                             "k40_s": t40, "k15_s": t15})  # fmt: skip
                print(f"{n:6d} {name:20s} seed {seed}  40 neighbours {a40:.4f} ({t40:.2f} s)  "
                      f"15 {a15:.4f} ({t15:.2f} s)  svc {svc:.4f}", flush=True)  # fmt: skip
    means = {}
    for n in sorted({r["n"] for r in rows}):
        sel = [r for r in rows if r["n"] == n]
        means[n] = {key: float(np.mean([r[key] for r in sel])) for key in ("k40", "k15", "svc", "k40_s", "k15_s")}
        m = means[n]
        print(f"{n:6d} mean: 40 neighbours {m['k40']:.4f} ({m['k40_s']:.2f} s)  15 {m['k15']:.4f} "
              f"({m['k15_s']:.2f} s)  svc {m['svc']:.4f}")  # fmt: skip
    print(json.dumps({"rows": rows, "means": means}))


if __name__ == "__main__":
    main()
