"""Cross-validated accuracy of LevelSetClassifier against scikit-learn's peers.

5x2-fold cross-validation (``RepeatedStratifiedKFold(n_splits=2, n_repeats=5,
random_state=0)``; accuracy, then balanced accuracy after the slash, since haberman and
pima are imbalanced; ``--cv-seed`` draws other folds, a check that the defaults were not
fitted to these), every model behind a ``StandardScaler`` on the same folds, over ten
data sets; then the length of the 2-D decision boundaries on the moons (and a picture,
``docs/moons.png``), and a semi-supervised run on digits with 5% of the labels.

``--sets other`` cross-validates eight other sets instead, which the defaults were never
chosen on: iris, scikit-learn's diabetes split at its median, three
``make_classification`` draws, Hastie's 10-dimensional sphere, Gaussian quantiles and
blobs of four spreads (:func:`other_datasets`).

Usage::

    python benchmarks/classify.py [--param name=value ...] [--no-plot] [--sets other]

Prints a table and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np
from sklearn import datasets as skdata
from sklearn.datasets import load_breast_cancer, load_digits, load_wine, make_circles, make_moons
from sklearn.model_selection import RepeatedStratifiedKFold
from sklearn.model_selection import cross_validate as sk_cross_validate
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.semi_supervised import LabelSpreading
from sklearn.svm import SVC

from ndboundary import LevelSetClassifier

ROOT = Path(__file__).resolve().parents[1]
TABULAR = ROOT.parent / "shared" / "data" / "tabular"
CSVS = ["banknote_authentication", "pima-indians-diabetes", "ionosphere", "sonar", "haberman"]


def load_csv(name):
    rows = [line.strip().split(",") for line in (TABULAR / f"{name}.csv").read_text().splitlines() if line.strip()]
    X = np.array([[float(v) for v in r[:-1]] for r in rows])
    y = np.array([r[-1] for r in rows])
    return X, y


def datasets():
    out = {
        "moons": make_moons(600, noise=0.3, random_state=0),
        "circles": make_circles(600, noise=0.15, factor=0.5, random_state=0),
        "breast_cancer": load_breast_cancer(return_X_y=True),
        "wine": load_wine(return_X_y=True),
        "digits": load_digits(return_X_y=True),
    }
    for name in CSVS:
        if (TABULAR / f"{name}.csv").exists():
            out[name] = load_csv(name)
    return out


def other_datasets():
    """Sets the defaults were not chosen on: the held-back check of ``--sets other``."""
    X, y = skdata.load_diabetes(return_X_y=True)
    return {
        "iris": skdata.load_iris(return_X_y=True),
        "diabetes_median": (X, (y > np.median(y)).astype(int)),
        "classification_20_5": skdata.make_classification(600, 20, n_informative=5, random_state=1),
        "classification_flip": skdata.make_classification(600, 10, n_informative=4, flip_y=0.1, random_state=2),
        "classification_3": skdata.make_classification(
            600, 15, n_informative=6, n_classes=3, n_clusters_per_class=1, random_state=3
        ),
        "hastie": skdata.make_hastie_10_2(800, random_state=0),
        "gaussian_quantiles": skdata.make_gaussian_quantiles(n_samples=600, n_features=6, n_classes=3, random_state=0),
        "blobs_4_spreads": skdata.make_blobs(600, 8, centers=4, cluster_std=[1.0, 2.5, 0.5, 1.5], random_state=0),
    }


def models(params):
    return {
        "levelset": LevelSetClassifier(**params),
        "knn15": KNeighborsClassifier(n_neighbors=15),
        "svc": SVC(),
        "labelspreading": LabelSpreading(kernel="knn"),
    }


def cross_validate(sets, params, seed=0):
    cv = RepeatedStratifiedKFold(n_splits=2, n_repeats=5, random_state=seed)
    table = {}
    for name, (X, y) in sets.items():
        table[name] = {}
        for mname, est in models(params).items():
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                s = sk_cross_validate(
                    make_pipeline(StandardScaler(), est), X, y, cv=cv, scoring=("accuracy", "balanced_accuracy")
                )
            acc, bal = s["test_accuracy"], s["test_balanced_accuracy"]
            table[name][mname] = (float(acc.mean()), float(acc.std()), time.perf_counter() - t0, float(bal.mean()))
        row = "  ".join(f"{m}={v[0]:.4f}/{v[3]:.4f}" for m, v in table[name].items())
        print(f"{name:<24s} {row}", flush=True)
    return table


def boundary_length(est, X, y, n=400):
    """Length of the 0.5-probability / sign-change curve of ``est`` on a grid (marching squares)."""
    from matplotlib import contour as _contour  # noqa: F401
    import matplotlib.pyplot as plt

    lo, hi = X.min(axis=0) - 0.5, X.max(axis=0) + 0.5
    xs, ys = np.linspace(lo[0], hi[0], n), np.linspace(lo[1], hi[1], n)
    gx, gy = np.meshgrid(xs, ys)
    z = est.predict(np.c_[gx.ravel(), gy.ravel()]).reshape(gx.shape).astype(float)
    fig, ax = plt.subplots()
    cs = ax.contour(gx, gy, z, levels=[0.5])
    length = 0.0
    for path in cs.get_paths():
        for poly in path.to_polygons(closed_only=False):
            length += float(np.linalg.norm(np.diff(poly, axis=0), axis=1).sum())
    plt.close(fig)
    return length, (gx, gy, z)


def moons_boundaries(params, plot=True):
    X, y = make_moons(600, noise=0.3, random_state=0)
    ests = {
        "levelset": make_pipeline(StandardScaler(), LevelSetClassifier(**params)),
        "knn15": make_pipeline(StandardScaler(), KNeighborsClassifier(n_neighbors=15)),
        "svc": make_pipeline(StandardScaler(), SVC()),
    }
    out, grids = {}, {}
    for name, est in ests.items():
        est.fit(X, y)
        out[name], grids[name] = boundary_length(est, X, y)
    if plot:
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
        for ax, (name, (gx, gy, z)) in zip(axes, grids.items()):
            ax.contourf(gx, gy, z, levels=[-0.5, 0.5, 1.5], colors=["#c6dbef", "#fdd0a2"])
            ax.contour(gx, gy, z, levels=[0.5], colors="k", linewidths=1.2)
            ax.scatter(X[:, 0], X[:, 1], c=y, s=6, cmap="coolwarm", edgecolors="none")
            ax.set_title(f"{name}: boundary length {out[name]:.2f}")
        fig.tight_layout()
        (ROOT / "docs").mkdir(exist_ok=True)
        fig.savefig(ROOT / "docs" / "moons.png", dpi=110)
        plt.close(fig)
    return out


def semi_supervised(params, keep=0.05, n_repeats=5):
    X, y = load_digits(return_X_y=True)
    X = StandardScaler().fit_transform(X)
    acc = {"levelset": [], "labelspreading": []}
    for r in range(n_repeats):
        rng = np.random.default_rng(r)
        yl = y.copy()
        hidden = rng.random(y.shape[0]) >= keep
        yl[hidden] = -1
        for name, est in (
            ("levelset", LevelSetClassifier(unlabeled=-1, **params)),
            ("labelspreading", LabelSpreading(kernel="knn")),
        ):
            est.fit(X, yl)
            acc[name].append(float((est.transduction_[hidden] == y[hidden]).mean()))
    return {k: float(np.mean(v)) for k, v in acc.items()}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--param", action="append", default=[], help="LevelSetClassifier parameter name=value")
    ap.add_argument("--only", action="append", default=None, help="run these data sets only")
    ap.add_argument("--no-plot", action="store_true")
    ap.add_argument("--cv-seed", type=int, default=0, help="random_state of the folds (default 0)")
    ap.add_argument("--skip-extra", action="store_true", help="cross-validation only")
    ap.add_argument("--sets", choices=("ten", "other"), default="ten", help="other: the held-back sets (no extras)")
    args = ap.parse_args(argv)
    params = {}
    for p in args.param:
        k, v = p.split("=", 1)
        params[k] = json.loads(v)
    sets = datasets() if args.sets == "ten" else other_datasets()
    if args.only:
        sets = {k: v for k, v in sets.items() if k in args.only}
    table = cross_validate(sets, params, args.cv_seed)
    names = list(next(iter(table.values())).keys())
    means = {m: float(np.mean([table[s][m][0] for s in table])) for m in names}
    balanced = {m: float(np.mean([table[s][m][3] for s in table])) for m in names}
    worst = min(table[s]["levelset"][0] - table[s]["knn15"][0] for s in table)
    print("mean over sets: " + "  ".join(f"{m}={v:.4f}" for m, v in means.items()))
    print("mean balanced accuracy: " + "  ".join(f"{m}={v:.4f}" for m, v in balanced.items()))
    print(f"levelset - knn15 on the worst set: {100 * worst:+.2f} points")
    result = {"params": params, "cv": table, "mean": means, "mean_balanced": balanced, "worst_vs_knn15": worst}
    if not args.skip_extra and args.sets == "ten":
        result["moons_boundary_length"] = moons_boundaries(params, plot=not args.no_plot)
        print("moons boundary length: " + "  ".join(f"{k}={v:.3f}" for k, v in result["moons_boundary_length"].items()))
        result["digits_5pct_labels"] = semi_supervised(params)
        print(
            "digits, 5% labels, transductive accuracy: "
            + "  ".join(f"{k}={v:.4f}" for k, v in result["digits_5pct_labels"].items())
        )
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
