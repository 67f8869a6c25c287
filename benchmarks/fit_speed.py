"""Fit times of the classifier on small tables, beside its peers, in the same run.

Cases: ``make_classification(3000, 10)``; the digits (1 797 samples, 64 features, 10
classes, ``X / 16``); the digits with one labelled sample per class (the rest
``-1``: ``LevelSetClassifier(unlabeled=-1)`` against ``LabelSpreading``, transductive
accuracy on the unlabelled samples). Every fit is timed after one warm-up fit (the
compiled kernels loaded); medians of ``--repeats``.

``--high-dim 7000,20000``: one fit each of ``make_classification(n, 20, n_informative=8)``
(intrinsic dimension about 11), each in a fresh process, with its peak memory.

Usage::

    python benchmarks/fit_speed.py [--repeats 3] [--high-dim 7000,20000]
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import time

import numpy as np
from sklearn.datasets import load_digits, make_classification
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.neighbors import KNeighborsClassifier
from sklearn.semi_supervised import LabelSpreading
from sklearn.svm import SVC

from ndboundary import LevelSetClassifier


def median_fit(make, X, y, repeats):
    """Median seconds of ``make().fit(X, y)`` after one warm-up fit, and the last model."""
    model = make().fit(X, y)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        model = make().fit(X, y)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), model


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--high-dim", default="", help="comma-separated sizes of the high-dimensional fits")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)  # a single high-dimensional fit
    args = parser.parse_args()
    if args.one:
        X, y = make_classification(args.one, 20, n_informative=8, random_state=0)
        t0 = time.perf_counter()
        LevelSetClassifier().fit(X, y)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
        print(f"make_classification({args.one}, 20, n_informative=8): fit {time.perf_counter() - t0:.1f} s, peak {peak:.2f} GB")
        return
    for n in [int(v) for v in args.high_dim.split(",") if v]:
        subprocess.run([sys.executable, __file__, "--one", str(n)], check=True)
    if args.high_dim:
        return
    supervised = {
        "levelset": LevelSetClassifier,
        "svc": SVC,
        "knn15": lambda: KNeighborsClassifier(15),
        "labelspreading": lambda: LabelSpreading(kernel="knn"),
        "hgb": HistGradientBoostingClassifier,
    }
    X, y = make_classification(3000, 10, random_state=0)
    Xd, yd = load_digits(return_X_y=True)
    Xd = Xd / 16
    for name, (A, b) in {"make_classification(3000, 10)": (X, y), "digits": (Xd, yd)}.items():
        row = {m: median_fit(make, A, b, args.repeats)[0] for m, make in supervised.items()}
        print(f"{name:32s} fit s: " + "  ".join(f"{m} {t:.3f}" for m, t in row.items()), flush=True)
    rng = np.random.default_rng(0)
    partial = np.full_like(yd, -1)
    for c in range(10):
        partial[rng.choice(np.flatnonzero(yd == c), 1)] = c
    hidden = partial == -1
    for m, make in {
        "levelset": lambda: LevelSetClassifier(unlabeled=-1),
        "labelspreading": lambda: LabelSpreading(kernel="knn", n_neighbors=10),
    }.items():
        seconds, model = median_fit(make, Xd, partial, args.repeats)
        accuracy = float((model.transduction_[hidden] == yd[hidden]).mean())
        print(f"{'digits, 1 label per class':32s} {m}: fit {seconds:.3f} s, transductive accuracy {accuracy:.4f}")


if __name__ == "__main__":
    main()
