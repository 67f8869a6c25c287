"""Prediction throughput on Dask arrays (not a test): in memory, then on a local cluster.

Fits ``LevelSetClassifier`` on the 5-dimensional manifold in R^50 of
``benchmarks/scale.py`` (``--fit-n`` samples, on ``--max-samples`` landmarks), then
predicts, and reports rows per second:

* in memory: ``predict`` on one ndarray of ``--check-n`` new samples;
* on a ``distributed.LocalCluster`` of ``--workers`` worker processes (``--threads`` each,
  default one):
  the same samples as a Dask array, through the classifier's own block-wise ``predict``
  and through dask-ml's ``ParallelPostFit`` (wrapping the fitted classifier, then its
  lean copy ``for_prediction(clf)``), checked equal to the in-memory predictions;
* ``--n`` samples (10 M by default; 0 skips this) generated block by block on the workers and
  predicted there, the generation timed alone too: the throughput of a data set that
  never sits in one process's memory.

Medians of ``--repeats`` runs for the first two. The classifier's own ``predict`` ships
its lean copy to the workers on its first call and reuses it after
(``ndboundary.learn.scaleout.shipped_to_workers``): that first call is timed on its own
(``cluster_first_s``), the median over the calls after it. ``ParallelPostFit`` ships the
estimator with each call. Prints a table and one JSON line.

Usage::

    python benchmarks/dask_predict.py [--fit-n 100000] [--max-samples 0.1] [--n 10000000]
                                      [--check-n 200000] [--chunk 100000] [--workers 2]
                                      [--threads 1]
"""

from __future__ import annotations

import argparse
import json
import time

import dask.array as da
import numpy as np
from dask_ml.wrappers import ParallelPostFit
from distributed import Client, LocalCluster
from scale import make_data

from ndboundary import LevelSetClassifier
from ndboundary.learn.scaleout import for_prediction


def _block(block_id, chunk, features):
    """Block ``block_id`` of the ``--n`` samples: scale.py's data with a seed per block."""
    X, _ = make_data(chunk, features, seed=1000 + block_id[0])
    return X


def generated(n, chunk, features):
    """A lazy Dask array of ``n`` new samples, each block generated where it is computed."""
    n_blocks = -(-n // chunk)
    chunks = ((chunk,) * (n // chunk) + ((n % chunk,) if n % chunk else ()), (features,))
    return da.map_blocks(
        lambda block_id=None: _block(block_id, chunks[0][block_id[0]], features),
        dtype=np.float64,
        chunks=chunks,
        meta=np.empty((0, 0)),
    ), n_blocks


def timed(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fit-n", type=int, default=100_000)
    ap.add_argument("--max-samples", type=float, default=0.1)
    ap.add_argument("--features", type=int, default=50)
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--check-n", type=int, default=200_000)
    ap.add_argument("--chunk", type=int, default=100_000)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1, help="threads per worker process")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    X, y = make_data(args.fit_n, args.features)
    m = args.max_samples
    clf = LevelSetClassifier(max_samples=None if m <= 0 else (int(m) if m > 1 else m), random_state=0)
    t0 = time.perf_counter()
    clf.fit(X, y)
    out = {"fit_n": args.fit_n, "landmarks": int(clf.domain_.n_vertices), "fit_s": time.perf_counter() - t0}
    Xc, yc = make_data(args.check_n, args.features, seed=1)
    clf.predict(Xc[:1000])  # the neighbour index's query compiled
    t_mem, ref = timed(lambda: clf.predict(Xc), args.repeats)
    out.update(memory_s=t_mem, memory_rows_per_s=args.check_n / t_mem, accuracy=float((ref == yc).mean()))
    with (
        LocalCluster(
            n_workers=args.workers, threads_per_worker=args.threads, processes=True, dashboard_address=None
        ) as cluster,
        Client(cluster) as client,
    ):
        shipped = client.scatter(clf, broadcast=True)
        client.submit(lambda est, Z: est.predict(Z), shipped, Xc[:1000]).result()  # warm every worker
        del shipped
        Xd = client.persist(da.from_array(Xc, chunks=(args.chunk, args.features)))
        t_first, lazy = timed(lambda: clf.predict(Xd).compute(), 1)
        if not np.array_equal(lazy, ref):
            raise AssertionError("block-wise predictions differ from the in-memory ones")
        t_own, lazy = timed(lambda: clf.predict(Xd).compute(), args.repeats)
        if not np.array_equal(lazy, ref):
            raise AssertionError("block-wise predictions differ from the in-memory ones")
        wrapped = ParallelPostFit(clf)
        t_ppf, lazy = timed(lambda: wrapped.predict(Xd).compute(), args.repeats)
        if not np.array_equal(lazy, ref):
            raise AssertionError("ParallelPostFit's predictions differ from the in-memory ones")
        lean = ParallelPostFit(for_prediction(clf))
        t_lean, lazy = timed(lambda: lean.predict(Xd).compute(), args.repeats)
        if not np.array_equal(lazy, ref):
            raise AssertionError("ParallelPostFit's predictions differ from the in-memory ones")
        out.update(
            parallelpostfit_lean_s=t_lean,
            parallelpostfit_lean_vs_memory=t_mem / t_lean,
            cluster_first_s=t_first,
            cluster_first_vs_memory=t_mem / t_first,
            cluster_s=t_own,
            cluster_rows_per_s=args.check_n / t_own,
            cluster_vs_memory=t_mem / t_own,
            parallelpostfit_s=t_ppf,
            parallelpostfit_vs_memory=t_mem / t_ppf,
        )
        if args.n > 0:
            big, n_blocks = generated(args.n, args.chunk, args.features)
            t0 = time.perf_counter()
            big.sum(axis=1).compute()
            out["generate_s"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            share = float((clf.predict(big) == clf.classes_[1]).mean().compute())
            out.update(n=args.n, blocks=n_blocks, big_s=time.perf_counter() - t0, big_share_of_class_1=share)
            out["big_rows_per_s"] = args.n / out["big_s"]
            out["big_rows_per_s_without_generation"] = args.n / max(out["big_s"] - out["generate_s"], 1e-9)
    for k, v in out.items():
        print(f"{k:<36s} {v:.4g}" if isinstance(v, float) else f"{k:<36s} {v}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
