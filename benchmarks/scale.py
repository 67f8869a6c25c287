"""Scale benchmark (not a test): LevelSetClassifier on data on a 5-dimensional manifold in R^50.

Usage::

    python benchmarks/scale.py [--n 100000] [--features 50] [--skip-peer]
                               [--peers labelspreading,svc,knn15,hgb]
                               [--bands none,10,20,30] [--repeat 3]
                               [--data manifold|plane] [--label-noise 0.0]
                               [--max-samples 0.1]

``--data plane`` draws two features instead, uniform on a square split by a sine curve
(the low-dimensional case, where most samples lie far from the class boundary), and
``--label-noise`` flips that share of the labels.

Times fit (kNN graph included) and prediction on as many new samples, reports peak
memory (ru_maxrss) and the band the classifier relaxed over (``band_``), and times
the ``--peers`` on the same data in the same process: ``LabelSpreading(kernel="knn")``
by default (``fit_ratio`` is ours to its), and any of ``SVC()``,
``KNeighborsClassifier(15)`` and ``HistGradientBoostingClassifier()``
(``svc``, ``knn15``, ``hgb``). ``--skip-peer`` times none. Prints a table and one JSON line.

``--max-samples`` fits once more on that share (or count) of landmarks
(``LevelSetClassifier(max_samples=...)``) and reports its fit and predict times, its
accuracy and the accuracy it costs against the fit on every sample.

``--bands`` then relaxes the fitted graph again with each band width (in units of ``h``;
``none`` for the whole graph, :mod:`ndboundary.pipeline.band`), as the classifier's fit
does (same ``lam``, smoothing and tolerance, then its extrema rule and extension): it
reports the share of the samples in the band, the relaxation's wall and CPU times
(medians over ``--repeat`` runs, widths interleaved so that a noisy machine weighs on
each alike; the graph's cached operators are dropped before each run, so that every
width pays for the operators it builds, as a fit does), the time of the extension, the
test accuracy and the test decisions that differ from the whole graph's. The graph
distance from the class boundary of every sample, in units of ``h``, is summarised too:
a band narrower than it leaves samples out.
"""

from __future__ import annotations

import argparse
import json
import resource
import time

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier
from sklearn.neighbors import KNeighborsClassifier
from sklearn.semi_supervised import LabelSpreading
from sklearn.svm import SVC

from ndboundary import LevelSetClassifier, relax
from ndboundary.learn.extrema import impose_extrema
from ndboundary.learn.scaling import apply_scaling
from ndboundary.pipeline.boundary import vertex_boundary
from ndboundary.pipeline.field import graph_distance

#: The operators a domain caches, dropped before each timed relaxation of ``--bands``.
CACHED = ("G", "K", "A", "mass", "adjacency", "incidence", "edges", "vertex_components", "edge_lengths")


def make_data(n, D, m=5, seed=0):
    """Two classes on a curved m-dimensional manifold isometrically placed in R^D."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(-1, 1, size=(n, m))
    base = np.concatenate([t, np.sin(2 * t), np.cos(3 * t[:, :2])], axis=1)
    Q, _ = np.linalg.qr(np.random.default_rng(12345).normal(size=(D, base.shape[1])))
    X = base @ Q.T + 0.01 * rng.normal(size=(n, D))
    y = (np.sin(3 * t[:, 0]) + t[:, 1] + 0.5 * t[:, 2] * t[:, 3] > 0).astype(int)
    return X, y


def make_plane(n, noise=0.0, seed=0):
    """Two classes on the square [-1, 1]^2 split by the curve ``y = 0.3 sin(3 x)``, a share
    ``noise`` of the labels flipped.
    """
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1, 1, size=(n, 2))
    y = (X[:, 1] < 0.3 * np.sin(3 * X[:, 0])).astype(int)
    flip = rng.random(n) < noise
    y[flip] = 1 - y[flip]
    return X, y


def peak_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def band_widths(text):
    """``"none,10,20"`` as ``[None, 10.0, 20.0]``."""
    return [None if w.strip().lower() == "none" else float(w) for w in text.split(",")]


def relax_like_fit(clf, target, band):
    """The classifier's relaxation of ``target`` over its fitted graph with ``band``, then its
    extrema rule and extension: ``(relax result, extension)`` and the wall and CPU times of
    the relaxation and of the rest.
    """
    domain = clf.domain_
    for name in CACHED:
        domain.__dict__.pop(name, None)
    wall, cpu = time.perf_counter(), time.process_time()
    # the graph is not complete at these sizes: the classifier uses its lam as it is
    res = relax(domain, target, on="vertices", lam=clf.lam, smoothing=clf.smoothing, rtol=clf.tol, band=band)
    times = [time.perf_counter() - wall, time.process_time() - cpu]
    wall, cpu = time.perf_counter(), time.process_time()
    phi = impose_extrema(domain, res.phi, target)
    ext = domain.extension(phi[:, None], n_neighbors=clf.extension_neighbors, power="auto", labels=target.astype(int))
    times += [time.perf_counter() - wall, time.process_time() - cpu]
    return res, ext, times


def measure_bands(clf, Xtr, ytr, Xte, yte, widths, repeat):
    """The figures of ``--bands`` (module docstring), one dict per width."""
    target = ytr == clf.classes_[1]
    domain = clf.domain_
    h = domain.mean_edge_length()
    dist = graph_distance(domain, vertex_boundary(domain, target).sources) / h
    out = {"distance_to_zeta_h": {q: round(float(np.quantile(dist, q)), 2) for q in (0.5, 0.9, 0.99, 1.0)}}
    Xs = apply_scaling(Xte, clf.center_, clf.scale_)
    rows = {w: {"times": []} for w in widths}
    reference = None
    for rep in range(repeat):
        for w in widths:
            res, ext, times = relax_like_fit(clf, target, w)
            rows[w]["times"].append(times)
            if rep == 0:
                pred = ext(Xs)[:, 0] > 0.5
                reference = pred if reference is None else reference
                rows[w].update(
                    share=round(res.params.get("band_vertices", domain.n_vertices) / domain.n_vertices, 4),
                    accuracy=float((clf.classes_[pred.astype(int)] == yte).mean()),
                    test_changes=int((pred != reference).sum()),
                    power=ext.power,
                )
    table = []
    for w in widths:
        med = np.median(np.array(rows[w].pop("times")), axis=0)
        rows[w].update(relax_wall_s=med[0], relax_cpu_s=med[1], extension_wall_s=med[2], extension_cpu_s=med[3])
        table.append({"band": w, **{k: round(v, 3) if k.endswith("_s") else v for k, v in rows[w].items()}})
    out["bands"] = table
    return out


#: the peers ``--peers`` can time beside ours, each made fresh
PEERS = {
    "labelspreading": lambda: LabelSpreading(kernel="knn"),
    "svc": SVC,
    "knn15": lambda: KNeighborsClassifier(15),
    "hgb": HistGradientBoostingClassifier,
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100_000)
    ap.add_argument("--features", type=int, default=50)
    ap.add_argument("--skip-peer", action="store_true")
    ap.add_argument("--peers", default="labelspreading", help=f"comma-separated, from {', '.join(PEERS)}")
    ap.add_argument("--bands", type=band_widths, default=None, help="band widths in h, e.g. none,10,20,30")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per band width (median)")
    ap.add_argument("--data", choices=("manifold", "plane"), default="manifold")
    ap.add_argument("--label-noise", type=float, default=0.0, help="share of flipped labels (--data plane)")
    ap.add_argument("--max-samples", type=float, default=None, help="also fit on landmarks: a share, or a count")
    args = ap.parse_args(argv)
    peers = [] if args.skip_peer else [p for p in args.peers.split(",") if p]
    if unknown := sorted(set(peers) - set(PEERS)):
        ap.error(f"unknown peers {unknown}; choose from {', '.join(PEERS)}")
    if args.data == "plane":
        X, y = make_plane(2 * args.n, args.label_noise)
    else:
        X, y = make_data(2 * args.n, args.features)
    Xtr, ytr, Xte, yte = X[: args.n], y[: args.n], X[args.n :], y[args.n :]
    out = {"n": args.n, "data": args.data, "features": X.shape[1], "label_noise": args.label_noise}
    clf = LevelSetClassifier(random_state=0, verbose=True)
    t0 = time.perf_counter()
    clf.fit(Xtr, ytr)
    out["fit_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    acc = float((clf.predict(Xte) == yte).mean())
    out["predict_s"] = time.perf_counter() - t0
    out["accuracy"] = acc
    out["band"] = clf.band_
    out["peak_gb"] = peak_gb()
    for name in peers:
        peer = PEERS[name]()
        t0 = time.perf_counter()
        peer.fit(Xtr, ytr)
        out[f"{name}_fit_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        out[f"{name}_accuracy"] = float((peer.predict(Xte) == yte).mean())
        out[f"{name}_predict_s"] = time.perf_counter() - t0
    if "labelspreading" in peers:
        out["fit_ratio"] = out["fit_s"] / out["labelspreading_fit_s"]
    if args.max_samples is not None:
        m = args.max_samples
        part = LevelSetClassifier(max_samples=int(m) if m > 1 else m, random_state=0)
        t0 = time.perf_counter()
        part.fit(Xtr, ytr)
        out["landmarks"] = int(part.landmarks_.size) if part.landmarks_ is not None else args.n
        out["landmarks_fit_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        out["landmarks_accuracy"] = float((part.predict(Xte) == yte).mean())
        out["landmarks_predict_s"] = time.perf_counter() - t0
        out["landmarks_accuracy_cost"] = acc - out["landmarks_accuracy"]
    for k, v in out.items():
        print(f"{k:<28s} {v}")
    if args.bands:
        out.update(measure_bands(clf, Xtr, ytr, Xte, yte, args.bands, args.repeat))
        print(f"graph distance of the samples to zeta (h), quantiles: {out['distance_to_zeta_h']}")
        cols = ("band", "share", "relax_wall_s", "relax_cpu_s", "extension_wall_s", "accuracy", "test_changes")
        print("  ".join(f"{c:>16s}" for c in cols))
        for row in out["bands"]:
            print("  ".join(f"{row[c]!s:>16s}" for c in cols))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
