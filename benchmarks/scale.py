"""Scale benchmark (not a test): LevelSetClassifier on data on a 5-dimensional manifold in R^50.

Usage::

    python benchmarks/scale.py [--n 100000] [--features 50] [--skip-peer]

Times fit (kNN graph included) and prediction on as many new samples, reports peak
memory (ru_maxrss), and times LabelSpreading(kernel="knn") on the same data for the
ratio. Prints a table and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np

from ndboundary import LevelSetClassifier


def make_data(n, D, m=5, seed=0):
    """Two classes on a curved m-dimensional manifold isometrically placed in R^D."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(-1, 1, size=(n, m))
    base = np.concatenate([t, np.sin(2 * t), np.cos(3 * t[:, :2])], axis=1)
    Q, _ = np.linalg.qr(np.random.default_rng(12345).normal(size=(D, base.shape[1])))
    X = base @ Q.T + 0.01 * rng.normal(size=(n, D))
    y = (np.sin(3 * t[:, 0]) + t[:, 1] + 0.5 * t[:, 2] * t[:, 3] > 0).astype(int)
    return X, y


def peak_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--features", type=int, default=50)
    ap.add_argument("--skip-peer", action="store_true")
    args = ap.parse_args(argv)
    X, y = make_data(2 * args.n, args.features)
    Xtr, ytr, Xte, yte = X[: args.n], y[: args.n], X[args.n :], y[args.n :]
    out = {"n": args.n, "features": args.features}
    clf = LevelSetClassifier(random_state=0, verbose=True)
    t0 = time.perf_counter()
    clf.fit(Xtr, ytr)
    out["fit_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    acc = float((clf.predict(Xte) == yte).mean())
    out["predict_s"] = time.perf_counter() - t0
    out["accuracy"] = acc
    out["peak_gb"] = peak_gb()
    if not args.skip_peer:
        from sklearn.semi_supervised import LabelSpreading

        ls = LabelSpreading(kernel="knn")
        t0 = time.perf_counter()
        ls.fit(Xtr, ytr)
        out["labelspreading_fit_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        out["labelspreading_accuracy"] = float((ls.predict(Xte) == yte).mean())
        out["labelspreading_predict_s"] = time.perf_counter() - t0
        out["fit_ratio"] = out["fit_s"] / out["labelspreading_fit_s"]
    for k, v in out.items():
        print(f"{k:<28s} {v}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
