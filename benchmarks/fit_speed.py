"""Fit times of the classifier on small tables, beside its peers, in the same run.

Cases: ``make_classification(3000, 10)``; the digits (1 797 samples, 64 features, 10
classes, ``X / 16``); the digits with one labelled sample per class (the rest
``-1``: ``LevelSetClassifier(unlabeled=-1)`` against ``LabelSpreading``, transductive
accuracy on the unlabelled samples). Every fit is timed after one warm-up fit (the
compiled kernels loaded); medians of ``--repeats``.

``--cold``: every fit in a fresh process instead (imports and the compiled kernels'
loading included, nothing carried over between fits), medians of ``--repeats``.

``--high-dim 7000,20000``: fits of ``make_classification(n, 20, n_informative=8)``
(intrinsic dimension about 11), ``--repeats`` fresh processes each: ours with its peak
memory (taken before the peers run), then SVC, KNN15, LabelSpreading and
HistGradientBoosting on the same data in the same process; medians.

Usage::

    python benchmarks/fit_speed.py [--repeats 3] [--cold] [--high-dim 7000,20000]
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


def _case(name):
    """The data of a case: features and labels (-1: unlabelled)."""
    if name == "make_classification(3000, 10)":
        return make_classification(3000, 10, random_state=0)
    X, y = load_digits(return_X_y=True)
    if name == "digits-1-label":
        rng = np.random.default_rng(0)
        partial = np.full_like(y, -1)
        for c in range(10):
            partial[rng.choice(np.flatnonzero(y == c), 1)] = c
        y = partial
    return X / 16, y


def _models(case):
    """The models of a case, by name."""
    if case == "digits-1-label":
        return {
            "levelset": lambda: LevelSetClassifier(unlabeled=-1),
            "labelspreading": lambda: LabelSpreading(kernel="knn", n_neighbors=10),
        }
    return {
        "levelset": LevelSetClassifier,
        "svc": SVC,
        "knn15": lambda: KNeighborsClassifier(15),
        "labelspreading": lambda: LabelSpreading(kernel="knn"),
        "hgb": HistGradientBoostingClassifier,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--high-dim", default="", help="comma-separated sizes of the high-dimensional fits")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)  # a single high-dimensional fit
    parser.add_argument("--cold", action="store_true", help="every fit in a fresh process")
    parser.add_argument("--cold-one", nargs=2, help=argparse.SUPPRESS)  # CASE MODEL: one fit, timed
    args = parser.parse_args()
    if args.cold_one:
        case, model = args.cold_one
        X, y = _case(case)
        t0 = time.perf_counter()
        fitted = _models(case)[model]().fit(X, y)
        seconds = time.perf_counter() - t0
        extra = ""
        if case == "digits-1-label":
            hidden = y == -1
            extra = f" {float((fitted.transduction_[hidden] == _case('digits')[1][hidden]).mean()):.4f}"
        print(f"{seconds:.4f}{extra}")
        return
    if args.cold:
        for case in ("make_classification(3000, 10)", "digits", "digits-1-label"):
            row = []
            for model in _models(case):
                runs = [
                    subprocess.run([sys.executable, __file__, "--cold-one", case, model], check=True,
                                   capture_output=True, text=True).stdout.split()
                    for _ in range(args.repeats)
                ]  # fmt: skip
                seconds = float(np.median([float(r[0]) for r in runs]))
                row.append(f"{model} {seconds:.3f}" + (f" (accuracy {runs[0][1]})" if len(runs[0]) > 1 else ""))
            print(f"{case:32s} cold fit s: " + "  ".join(row), flush=True)
        return
    if args.one:
        X, y = make_classification(args.one, 20, n_informative=8, random_state=0)
        t0 = time.perf_counter()
        LevelSetClassifier().fit(X, y)
        seconds = time.perf_counter() - t0
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
        peers = []
        for model in _models("make_classification(3000, 10)").values():
            if not isinstance(model(), LevelSetClassifier):
                t0 = time.perf_counter()
                model().fit(X, y)
                peers.append(time.perf_counter() - t0)
        print(" ".join(f"{v:.4f}" for v in [seconds, peak, *peers]))
        return
    for n in [int(v) for v in args.high_dim.split(",") if v]:
        runs = np.array([
            subprocess.run([sys.executable, __file__, "--one", str(n)], check=True, capture_output=True,
                           text=True).stdout.split()
            for _ in range(args.repeats)
        ], dtype=float)  # fmt: skip
        fit, peak, *peers = np.median(runs, axis=0)
        names = [m for m in _models("make_classification(3000, 10)") if m != "levelset"]
        print(
            f"make_classification({n}, 20, n_informative=8): fit {fit:.2f} s ({', '.join(f'{v:.2f}' for v in runs[:, 0])}), "
            f"peak {peak:.2f} GB; " + "  ".join(f"{m} {v:.3f} s" for m, v in zip(names, peers, strict=True)),
            flush=True,
        )
    if args.high_dim:
        return
    for case in ("make_classification(3000, 10)", "digits", "digits-1-label"):
        X, y = _case(case)
        row = []
        for name, make in _models(case).items():
            seconds, model = median_fit(make, X, y, args.repeats)
            if case == "digits-1-label":
                hidden = y == -1
                truth = _case("digits")[1]
                row.append(f"{name} {seconds:.3f} (accuracy {(model.transduction_[hidden] == truth[hidden]).mean():.4f})")
            else:
                row.append(f"{name} {seconds:.3f}")
        print(f"{case:32s} fit s: " + "  ".join(row), flush=True)

if __name__ == "__main__":
    main()
