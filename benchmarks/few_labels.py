"""Semi-supervised accuracy on the digits with 1, 3 and 5 labels per class, beside two peers.

The digits (1 797 samples, 64 features, 10 classes, ``X / 16``). For every label rate,
``--draws`` random draws of that many labelled samples per class (seeded by ``--seed``,
the rate and the draw; the same draws for every method), the rest unlabelled (``-1``).
Transductive accuracy on the unlabelled samples of:

- ``LevelSetClassifier(unlabeled=-1)``, defaults;
- ``LabelSpreading(kernel="knn", n_neighbors=10)``;
- Poisson learning (Calder et al., ICML 2020), GraphLearning's own
  ``graphlearning.ssl.poisson(graphlearning.weightmatrix.knn(X, 10))`` (``graphlearning``,
  whose neighbour search beyond 5 features is annoy's, approximate; both in the ``bench``
  extra), when it is installed;
- the same on the exact neighbour graph (``poisson_learning.py`` beside this file, a
  reimplementation from GraphLearning's sources): the peer without annoy's approximation.

Then an inductive figure for ours: per draw, a random 20% of the digits is held out (not in
the graph), the labels are drawn from the other 80%, ours is fitted there and scored on the
held-out 20%, beside its transductive accuracy on the unlabelled 80% of the same draw.

Fit times are per fit, after one warm-up fit of every method (the compiled kernels loaded).

Usage::

    python benchmarks/few_labels.py [--draws 10] [--rates 1,3,5] [--seed 0]

Prints a table and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import numpy as np
from poisson_learning import poisson_learning
from sklearn.datasets import load_digits
from sklearn.semi_supervised import LabelSpreading

from ndboundary import LevelSetClassifier

METHODS = ("levelset", "labelspreading", "poisson")
try:
    import graphlearning

    METHODS += ("graphlearning",)
except ImportError:  # not installed: the reimplementation alone
    graphlearning = None
#: the Poisson learners ours is counted against, draw by draw
POISSON = tuple(m for m in METHODS if m in ("graphlearning", "poisson"))


def draw_labels(y, pool, rate, rng):
    """Indices of ``rate`` samples of every class, drawn from ``pool`` without replacement."""
    return np.sort(np.concatenate([rng.choice(pool[y[pool] == c], rate, replace=False) for c in np.unique(y)]))


def partial_labels(y, labelled):
    """``y`` with every sample outside ``labelled`` set to ``-1``."""
    out = np.full_like(y, -1)
    out[labelled] = y[labelled]
    return out


def transduce(method, X, y_partial):
    """The labels ``method`` gives all samples of ``X`` (``y_partial``: -1 for unlabelled)."""
    if method in POISSON:
        idx = np.flatnonzero(y_partial != -1)
        if method == "poisson":
            return poisson_learning(X, idx, y_partial[idx])
        W = graphlearning.weightmatrix.knn(X, 10)
        return graphlearning.ssl.poisson(W).fit_predict(idx, y_partial[idx])
    if method == "levelset":
        model = LevelSetClassifier(unlabeled=-1)
    else:
        model = LabelSpreading(kernel="knn", n_neighbors=10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # LabelSpreading's convergence warning at max_iter
        return model.fit(X, y_partial).transduction_


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def run(rates, draws, seed):
    X, y = load_digits(return_X_y=True)
    X = X / 16
    n = y.shape[0]
    everyone = np.arange(n)
    warm = partial_labels(y, draw_labels(y, everyone, 1, np.random.default_rng(seed)))
    for method in METHODS:
        transduce(method, X, warm)
    result = {}
    for rate in rates:
        acc = {m: [] for m in METHODS}
        seconds = {m: [] for m in METHODS}
        inductive, transductive_80 = [], []
        for d in range(draws):
            rng = np.random.default_rng([seed, rate, d])
            labelled = draw_labels(y, everyone, rate, rng)
            y_partial = partial_labels(y, labelled)
            hidden = y_partial == -1
            for method in METHODS:
                pred, s = timed(transduce, method, X, y_partial)
                acc[method].append(float((pred[hidden] == y[hidden]).mean()))
                seconds[method].append(s)
            # inductive: a held-out 20%, not in the graph; labels drawn from the other 80%
            perm = rng.permutation(n)
            test, pool = np.sort(perm[: n // 5]), np.sort(perm[n // 5 :])
            labelled = draw_labels(y, pool, rate, rng)
            y_pool = np.full(pool.shape[0], -1)
            known = np.isin(pool, labelled)
            y_pool[known] = y[pool[known]]
            model = LevelSetClassifier(unlabeled=-1).fit(X[pool], y_pool)
            inductive.append(float((model.predict(X[test]) == y[test]).mean()))
            transductive_80.append(float((model.transduction_[~known] == y[pool[~known]]).mean()))
        ours = np.array(acc["levelset"])
        result[str(rate)] = {
            "accuracy": acc,
            "mean": {m: float(np.mean(v)) for m, v in acc.items()},
            "std": {m: float(np.std(v)) for m, v in acc.items()},
            "fit_seconds": {m: float(np.mean(v)) for m, v in seconds.items()},
            **{f"wins_vs_{m}": int((ours > np.array(acc[m])).sum()) for m in POISSON},
            **{f"ties_vs_{m}": int((ours == np.array(acc[m])).sum()) for m in POISSON},
            "levelset_inductive": inductive,
            "levelset_transductive_80": transductive_80,
            "levelset_inductive_mean": float(np.mean(inductive)),
            "levelset_transductive_80_mean": float(np.mean(transductive_80)),
        }
        r = result[str(rate)]
        row = "  ".join(f"{m} {r['mean'][m]:.4f} ± {r['std'][m]:.4f}" for m in METHODS)
        times = "  ".join(f"{m} {r['fit_seconds'][m]:.3f}" for m in METHODS)
        print(f"{rate} label(s)/class, {draws} draws: {row}", flush=True)
        for m in POISSON:
            print(
                f"    levelset vs {m}: {r[f'wins_vs_{m}']} wins, {r[f'ties_vs_{m}']} ties of {draws} draws", flush=True
            )
        print(f"    mean fit s: {times}", flush=True)
        print(f"    levelset on a held-out 20%: inductive {r['levelset_inductive_mean']:.4f}"
              f" ± {np.std(inductive):.4f}, transductive on the unlabelled 80% {r['levelset_transductive_80_mean']:.4f}"
              f" ± {np.std(transductive_80):.4f}", flush=True)  # fmt: skip
    return result


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=10)
    ap.add_argument("--rates", default="1,3,5", help="comma-separated labels per class")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    rates = [int(v) for v in args.rates.split(",") if v]
    result = {"draws": args.draws, "seed": args.seed, "rates": run(rates, args.draws, args.seed)}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
