"""The classifier's kernel fit of phi pair by pair against one fit per class, by number of
classes (not a test).

For blobs of ``L`` classes (``--samples`` training samples of 10 features, as many again
held out), fits ``LevelSetClassifier`` once, then fits both kernel extensions of its
``phi_`` (:mod:`ndboundary.learn.kernel_extension`): ``PairwiseKernelExtension``, the
classifier's for three classes or more, and ``KernelExtension``, one fit per class
against the rest. Prints the classifier's fit time and, for each extension, its fit time
(median of ``--repeats``) and the held-out accuracy of its largest class function alone.
Also Gaussian quantiles of three classes in 6 dimensions, where the pairs matter.

Usage::

    python benchmarks/kernel_pairs.py [--classes 3,10,26,60] [--samples 4000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from sklearn.datasets import make_blobs, make_gaussian_quantiles

from ndboundary import LevelSetClassifier
from ndboundary.learn.kernel_extension import KernelExtension, PairwiseKernelExtension
from ndboundary.learn.scaling import apply_scaling


def timed(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def compare(name, X, y, n, repeats):
    t0 = time.perf_counter()
    clf = LevelSetClassifier().fit(X[:n], y[:n])
    fit_s = time.perf_counter() - t0
    Xs = apply_scaling(X[:n], clf.center_, clf.scale_)
    Xt = apply_scaling(X[n:], clf.center_, clf.scale_)
    codes = np.searchsorted(clf.classes_, clf.transduction_)
    row = {"set": name, "classes": int(clf.classes_.size), "classifier_fit_s": fit_s}
    for label, make in (
        ("pairs", lambda: PairwiseKernelExtension(Xs, clf.phi_, codes)),
        ("against_rest", lambda: KernelExtension(Xs, clf.phi_)),
    ):
        seconds, ext = timed(make, repeats)
        row[f"{label}_s"] = seconds
        row[f"{label}_accuracy"] = float((clf.classes_[ext(Xt).argmax(axis=1)] == y[n:]).mean())
    print(
        f"{name:<24s} classifier fit {fit_s:6.2f} s   kernel fits: pairs {row['pairs_s']:.3f} s "
        f"(accuracy {row['pairs_accuracy']:.4f}), against the rest {row['against_rest_s']:.3f} s "
        f"(accuracy {row['against_rest_accuracy']:.4f})",
        flush=True,
    )
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--classes", default="3,10,26,60")
    ap.add_argument("--samples", type=int, default=4000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    rows = []
    X, y = make_gaussian_quantiles(n_samples=600, n_features=6, n_classes=3, random_state=0)
    rows.append(compare("gaussian_quantiles", X, y, 300, args.repeats))
    for L in (int(v) for v in args.classes.split(",") if v):
        X, y = make_blobs(2 * args.samples, n_features=10, centers=L, cluster_std=2.0, random_state=0)
        rows.append(compare(f"blobs_{L}", X, y, args.samples, args.repeats))
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
