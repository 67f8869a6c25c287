"""Prediction throughput on Dask arrays (not a test): in memory, then on local clusters.

Fits ``LevelSetClassifier`` on the 5-dimensional manifold in R^50 of
``benchmarks/scale.py`` (``--fit-n`` samples, on ``--max-samples`` landmarks), then
predicts, and reports rows per second:

* in memory: ``predict`` on one ndarray of ``--check-n`` new samples;
* on a ``distributed.LocalCluster`` of worker processes for each of ``--layouts``
  (``WxT``: ``W`` worker processes of ``T`` threads; by default one process with a thread
  per core, then a process per core with one thread, which is ``LocalCluster``'s own
  default on a machine of up to 4 cores):
  the same samples as a Dask array, through the classifier's own block-wise ``predict``
  and through dask-ml's ``ParallelPostFit`` (wrapping the fitted classifier, then its
  lean copy ``for_prediction(clf)``), checked equal to the in-memory predictions;
* on ``--plain`` plain processes (one per core by default; 0 skips this), each started
  with ``OMP_NUM_THREADS=1`` as Dask starts its workers and holding the lean classifier
  and the samples: the same blocks of rows, without Dask. This is what any split of the
  work across processes can reach on this machine, the cluster's ceiling;
* ``--n`` samples (10 M by default; 0 skips this) generated block by block on the workers
  of the first layout and predicted there, the generation timed alone too: the
  throughput of a data set that never sits in one process's memory.

Each of ``--repeats`` rounds predicts the samples in memory, then on the plain processes,
with no cluster running (an idle ``LocalCluster`` slows a process beside it on a small
machine; the one closed before leaves ``OMP_NUM_THREADS=1`` in this process's environment,
which ndboundary reads only as the process was started), then starts a fresh cluster of
each layout in turn and predicts them there each way of ``--ways`` (all by default),
``--calls`` times each (1 by default; the median of a round's calls is its time, in memory
too). The ratios to the in-memory time are taken within a round, so that the drifts of a
shared machine hit both sides alike; their median is printed with their range. The
classifier's own ``predict`` ships its lean copy to the workers on its first call and
reuses it after (``ndboundary.learn.scaleout.shipped_to_workers``): that first call is
timed on its own (``cluster_first``). ``ParallelPostFit`` ships the estimator with each call.
``--pairs N`` measures instead in pairs adjacent in time, against the drifts of a shared
machine that a round's minute spans: for each layout one cluster is started and warmed,
then ``N`` times in memory, on the cluster, on the cluster, in memory (ABBA, so that a
steady drift cancels), each in-memory call with the cluster's processes suspended
(``SIGSTOP``) so that they take nothing from it. Each call is paired with its neighbour;
the median of the ``2N`` ratios is printed with a 95 % bootstrap interval and the share
of pairs at or above 1. With ``--first``, each quad runs on a fresh cluster instead, so
that its first cluster call is a user's first call, which ships the lean copy: the even
quads call in memory, the first call, a second call, in memory; the odd ones the first
call, in memory twice, the second call, so that their first call comes before any
suspension. The first calls' ratios (each against the in-memory call beside it), the
second calls', and those of the odd quads' first calls are summarised apart, with the
ratios of each second call's seconds to its first's (below 1: the first call is the
slower).
In every mode the samples are persisted on the workers, and the workers warmed, before
any call is timed.
``--chunk-cost`` first times, on one thread in a fresh process started as Dask starts a
worker, ``--check-n`` samples predicted at once, in blocks of ``--chunk`` rows (as a
cluster's tasks predict them), and in such blocks of the samples reordered by their whole
search order (medians of ``--calls`` calls, 3 at least): what a block costs more than its
share of the whole, and whether that is the search's locality.
``--faults`` first counts the minor page faults (and the seconds) of one call predicting
``--chunk`` rows on one thread, in a fresh process with and without the
``MALLOC_TRIM_THRESHOLD_`` Dask's nanny sets in its workers.
``--no-profiler`` and ``--no-malloc-trim`` start the workers without two of Dask's
defaults: its statistical profiler, which samples every worker thread's stack 100 times a
second, and ``MALLOC_TRIM_THRESHOLD_``, with which glibc hands freed memory back to the
system (and faults it in again) at once. ``--quiet`` starts the clusters with
:data:`QUIET`: no profiler, and the event loops' health check and the system monitor
run every second or two instead of every 20 and 500 ms. Idle, a ``2x1`` cluster's
processes then take 3 % of a core instead of 16 % (``--idle`` measures it for each
setting first), which on a machine whose cores the cluster shares with nothing else
is work taken from the predictions. Prints a table and one JSON line.
``--after-idle S`` first times ``--calls`` in-memory calls (3 at least) one right after
another, then as many each after ``S`` seconds in which the process does nothing, with no
cluster started yet: what a call pays for memory that the system took back while the
process was idle (on a virtual machine, the host may reclaim the guest's freed pages).
``--ship N`` first starts ``N`` fresh clusters of the first layout and on each times
``shipped_to_workers`` alone, 5 s after the samples were persisted: the part of a user's
first call that sends the model's lean copy to the workers.
``--trace N`` first traces a first and a second call on each of ``N`` fresh clusters of
the first layout (Dask's task stream, 5 s after the samples were persisted): each call's
seconds, the blocks of rows fetched from another worker before their task ran (a task
whose block another worker held), and the tail between the first and the last worker's end;
and how many blocks each worker held when the calls began. With ``--held-by-one`` the samples
are persisted on one worker only, in every mode (as when one worker loaded them).
``--pool FILE ...`` measures nothing: it reads the output of earlier runs (the JSON line
each ends with) and prints, for each kind of ratio, the median, 95 % bootstrap interval
and share at or above 1 over the ratios of every run, pooled.

Usage::

    python benchmarks/dask_predict.py [--fit-n 100000] [--max-samples 0.1] [--n 10000000]
                                      [--check-n 200000] [--chunk 100000] [--layouts 1x2,2x1]
                                      [--repeats 3] [--no-profiler] [--no-malloc-trim]
                                      [--quiet] [--idle] [--faults] [--ways cluster,...]
                                      [--calls 1] [--plain 2] [--pairs 0] [--first]
                                      [--after-idle 0] [--ship 0] [--trace 0] [--held-by-one]
                                      [--chunk-cost]
    python benchmarks/dask_predict.py --pool run1.txt run2.txt ...
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import time
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import dask
import dask.array as da
import numpy as np
from dask_ml.wrappers import ParallelPostFit
from distributed import Client, LocalCluster, wait
from scale import make_data

from ndboundary import LevelSetClassifier
from ndboundary.learn.scaleout import for_prediction, shipped_to_workers


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


_PLAIN = None  # (lean classifier, samples) in each plain process


def _plain_init(est, X):
    """A plain process's start: it keeps the lean classifier and the samples, and predicts
    a few rows (the neighbour index's query compiled, as the cluster's workers are warmed)."""
    global _PLAIN
    _PLAIN = (est, X)
    est.predict(X[:1000])


def _plain_rows(bounds):
    est, X = _PLAIN
    return est.predict(X[bounds[0] : bounds[1]])


@contextmanager
def environment(**values):
    """This process's environment with ``values`` set, for the processes started within
    (each reads it as it starts), then restored."""
    before = {name: os.environ.get(name) for name in values}
    os.environ.update(values)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                del os.environ[name]
            else:
                os.environ[name] = value


@contextmanager
def plain_processes(count, clf, X):
    """A pool of ``count`` plain processes, each started as Dask starts a worker process
    (``OMP_NUM_THREADS=1``) and holding the lean classifier and the samples ``X``: the
    same split of the work across processes, without Dask.
    """
    with environment(OMP_NUM_THREADS="1"):
        pool = multiprocessing.get_context("spawn").Pool(count, _plain_init, (for_prediction(clf), X))
    with pool:
        yield pool


def _faults_of_a_call(est, X):
    import resource

    est.predict(X[:1000])
    est.predict(X)  # warm: what the process keeps between calls is made
    r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    est.predict(X)
    seconds, r1 = time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_SELF)
    return r1.ru_minflt - r0.ru_minflt, seconds


def page_faults(clf, X, trim):
    """``(minor page faults, seconds)`` of one call predicting ``X`` on one thread, after a
    warm-up, in a fresh process started with ``OMP_NUM_THREADS=1`` and, with ``trim``, with
    the ``MALLOC_TRIM_THRESHOLD_`` that Dask's nanny gives its workers: with it, glibc hands
    freed memory back to the system at once, and every array above it that a call makes
    and frees is faulted in again on the next.
    """
    values = {"OMP_NUM_THREADS": "1"}
    if trim:
        values["MALLOC_TRIM_THRESHOLD_"] = str(
            dask.config.get("distributed.nanny.pre-spawn-environ")["MALLOC_TRIM_THRESHOLD_"]
        )
    with environment(**values):
        pool = multiprocessing.get_context("spawn").Pool(1)
    with pool:
        return pool.apply(_faults_of_a_call, (for_prediction(clf), X))


def _chunk_costs(est, X, chunk, count):
    est.predict(X[:1000])
    order = est.extension_.cloud.query_order(*est._validate_predict(X))
    Xs = np.ascontiguousarray(X[order])  # the rows in the whole search order
    ways = {
        "whole": lambda: est.predict(X),
        "chunks": lambda: [est.predict(X[a : a + chunk]) for a in range(0, X.shape[0], chunk)],
        "sorted_chunks": lambda: [est.predict(Xs[a : a + chunk]) for a in range(0, X.shape[0], chunk)],
    }
    seconds = {name: [] for name in ways}
    for _ in range(count):
        for name, way in ways.items():
            seconds[name].append(timed(way)[0])
    return {name: float(np.median(t)) for name, t in seconds.items()}


def chunk_costs(clf, X, chunk, count):
    """Median seconds, on one thread in a fresh process started as Dask starts a worker,
    of predicting ``X`` at once, in blocks of ``chunk`` rows, and in blocks of ``chunk``
    rows of ``X`` reordered by its whole search order (each block then covers a compact
    part of the space, as the whole's search does)."""
    with environment(OMP_NUM_THREADS="1"):
        pool = multiprocessing.get_context("spawn").Pool(1)
    with pool:
        costs = pool.apply(_chunk_costs, (for_prediction(clf), X, chunk, count))
    return {f"one_thread_{name}_s": t for name, t in costs.items()}


def plain_round(pool, n, chunk, ref, count):
    """Seconds to predict the ``n`` samples in blocks of ``chunk`` rows on the plain
    processes of ``pool`` (the median of ``count`` calls)."""
    blocks = [(a, min(a + chunk, n)) for a in range(0, n, chunk)]
    return calls(lambda: np.concatenate(pool.map(_plain_rows, blocks, chunksize=1)), ref, "plain", count)


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def after_idle(clf, Xc, ref, seconds, count):
    """Seconds of ``count`` in-memory calls one right after another (the first left
    out), then of ``count`` calls each after ``seconds`` idle: their medians and all."""
    back = [timed(lambda: clf.predict(Xc)) for _ in range(count + 1)][1:]
    idle = []
    for _ in range(count):
        time.sleep(seconds)
        idle.append(timed(lambda: clf.predict(Xc)))
    for _, labels in back + idle:
        check(labels, ref, "memory")
    back, idle = [t for t, _ in back], [t for t, _ in idle]
    return {
        "memory_back_to_back_s": float(np.median(back)),
        f"memory_after_{seconds:g}s_idle_s": float(np.median(idle)),
        "memory_back_to_back_all_s": [round(t, 3) for t in back],
        f"memory_after_{seconds:g}s_idle_all_s": [round(t, 3) for t in idle],
    }


def ship_times(clf, Xc, workers, threads, settings, args, count):
    """Seconds of :func:`shipped_to_workers` on ``count`` fresh clusters, each 5 s after
    the samples were persisted and the workers warmed."""
    seconds = []
    for _ in range(count):
        with cluster(workers, threads, settings) as client:
            prepared(client, clf, Xc, args)
            time.sleep(5.0)
            seconds.append(timed(lambda: shipped_to_workers(clf))[0])
    return {f"ship_s@{workers}x{threads}": float(np.median(seconds)), "ship_all_s": [round(t, 4) for t in seconds]}


def traced_calls(clf, Xc, workers, threads, settings, args, count):
    """For ``count`` fresh clusters, a first and a second call's seconds, fetches of a
    prediction task's inputs from another worker, and tail (see ``--trace``)."""
    from distributed import get_task_stream

    out, held = {"first": [], "second": []}, []
    for _ in range(count):
        with cluster(workers, threads, settings) as client:
            Xd = prepared(client, clf, Xc, args)
            time.sleep(5.0)
            holders = [w for workers in client.who_has(Xd).values() for w in workers]
            held.append(sorted(holders.count(w) for w in client.nthreads()))
            for name in out:
                with get_task_stream() as stream:
                    seconds = timed(lambda: clf.predict(Xd).compute())[0]
                tasks = [t for t in stream.data if "_apply" in str(t["key"])]
                fetched = [s for t in tasks for s in t["startstops"] if s["action"] == "transfer"]
                ends = {}
                for t in tasks:
                    stop = max(s["stop"] for s in t["startstops"])
                    ends[t["worker"]] = max(ends.get(t["worker"], stop), stop)
                tail = max(ends.values()) - min(ends.values()) if ends else 0.0
                out[name].append((seconds, len(fetched), sum(s["stop"] - s["start"] for s in fetched), tail))
    tag = f"@{workers}x{threads}"
    return {
        f"trace_{name}{tag}": [[round(s, 3), n, round(f, 3), round(t, 3)] for s, n, f, t in calls]
        for name, calls in out.items()
    } | {
        "trace_columns": ["seconds", "inputs fetched", "fetch seconds", "tail seconds"],
        f"trace_blocks_held{tag}": held,
    }


def check(labels, ref, way):
    if not np.array_equal(labels, ref):
        raise AssertionError(f"{way}: predictions differ from the in-memory ones")


WAYS = ("cluster", "parallelpostfit_lean", "parallelpostfit")

#: Dask settings of ``--quiet``: the periodic work of an idle cluster, cut down.
QUIET = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
}


def layout(text):
    """``(workers, threads)`` of a layout ``WxT``."""
    workers, threads = (int(part) for part in text.lower().split("x"))
    if workers < 1 or threads < 1:
        raise ValueError(f"a layout needs at least one worker and one thread, got {text!r}")
    return workers, threads


@contextmanager
def cluster(workers, threads, settings):
    """A client of a fresh ``LocalCluster`` of ``workers`` processes of ``threads`` threads,
    with Dask ``settings``.
    """
    with (
        dask.config.set(settings),
        LocalCluster(n_workers=workers, threads_per_worker=threads, processes=True, dashboard_address=None) as local,
        Client(local) as client,
    ):
        yield client


def idle_share(workers, threads, settings, seconds=8.0):
    """The CPU time the processes of an idle cluster take, as a share of one core."""
    import psutil

    with cluster(workers, threads, settings):
        time.sleep(2.0)  # started
        me = psutil.Process()
        procs = [me, *me.children(recursive=True)]
        cpu = lambda: sum(sum(p.cpu_times()[:2]) for p in procs)  # noqa: E731
        c0 = cpu()
        time.sleep(seconds)
        return (cpu() - c0) / seconds


def cluster_round(client, clf, Xc, ref, args):
    """Seconds to predict ``Xc`` on the cluster of ``client`` each way of ``args.ways`` (the
    median of ``args.calls`` calls), after warming every worker; ``cluster_first`` is the
    classifier's own first call, which ships its lean copy to the workers.
    """
    Xd = prepared(client, clf, Xc, args)
    wrapped, lean = ParallelPostFit(clf), ParallelPostFit(for_prediction(clf))
    ways = {
        "cluster": lambda: clf.predict(Xd).compute(),
        "parallelpostfit_lean": lambda: lean.predict(Xd).compute(),
        "parallelpostfit": lambda: wrapped.predict(Xd).compute(),
    }
    times = {}
    times["cluster_first"], labels = timed(ways["cluster"])
    check(labels, ref, "cluster_first")
    for name in args.ways:
        times[name] = calls(ways[name], ref, name, args.calls)
    return times


@contextmanager
def suspended():
    """This process's child processes (a local cluster's workers and their nannies)
    stopped with ``SIGSTOP`` for the duration, then resumed: a cluster that takes no
    CPU time at all beside an in-memory call."""
    import psutil

    me = psutil.Process()
    procs = me.children(recursive=True)
    for proc in procs:
        proc.suspend()
    try:
        yield
    finally:
        for proc in procs:
            proc.resume()


def median_interval(ratios, draws=10_000, seed=0):
    """The median of ``ratios`` and a 95 % percentile-bootstrap interval of it."""
    r = np.asarray(ratios)
    rng = np.random.default_rng(seed)
    medians = np.median(r[rng.integers(0, r.size, size=(draws, r.size))], axis=1)
    return float(np.median(r)), [round(float(q), 3) for q in np.quantile(medians, [0.025, 0.975])]


def paired(client, clf, Xc, ref, args):
    """The ratios of in-memory to cluster seconds in ``args.pairs`` ABBA quads of calls on
    the warmed cluster of ``client`` (see ``--pairs``): one ratio per adjacent pair."""
    Xd = prepared(client, clf, Xc, args)
    check(clf.predict(Xd).compute(), ref, "cluster_first")  # ships the lean copy
    memory, on_cluster = partial(_in_memory, clf, Xc, ref), partial(_on, clf, Xd, ref)
    ratios, seconds = [], {"memory": [], "cluster": []}
    for _ in range(args.pairs):
        m1, c1, c2, m2 = memory(), on_cluster(), on_cluster(), memory()
        ratios += [m1 / c1, m2 / c2]
        seconds["memory"] += [m1, m2]
        seconds["cluster"] += [c1, c2]
    return ratios, seconds


def first_pairs(clf, Xc, ref, workers, threads, settings, args):
    """The ratios of in-memory to cluster seconds of ``args.pairs`` quads, each on a fresh
    cluster of ``workers`` processes of ``threads`` threads (see ``--first``).

    Even quads run in memory, the user's first call (which ships the lean copy), a second
    call, in memory; odd quads the first call, in memory twice, the second call. Each
    cluster call is paired with the in-memory call beside it. In the odd quads the first
    call comes before the cluster has been suspended at all, which tells a first call's
    own cost from that of resuming the cluster's processes. Returns the first calls'
    ratios, the second calls' ratios and the seconds of each kind of call.
    """
    first, second, seconds = [], [], {"memory": [], "cluster_first": [], "cluster": []}
    for quad in range(args.pairs):
        with cluster(workers, threads, settings) as client:
            Xd = prepared(client, clf, Xc, args)
            memory, on_cluster = partial(_in_memory, clf, Xc, ref), partial(_on, clf, Xd, ref)
            if quad % 2 == 0:
                m1, c1, c2, m2 = memory(), on_cluster(), on_cluster(), memory()
            else:
                c1, m1, m2, c2 = on_cluster(), memory(), memory(), on_cluster()
        first.append(m1 / c1)
        second.append(m2 / c2)
        seconds["memory"] += [m1, m2]
        seconds["cluster_first"].append(c1)
        seconds["cluster"].append(c2)
    return first, second, seconds


def _in_memory(clf, Xc, ref):
    """Seconds of one in-memory call, the cluster's processes suspended."""
    with suspended():
        return calls(lambda: clf.predict(Xc), ref, "memory", 1)


def _on(clf, Xd, ref):
    """Seconds of one call of the classifier's own ``predict`` on the cluster's array ``Xd``."""
    return calls(lambda: clf.predict(Xd).compute(), ref, "cluster", 1)


def prepared(client, clf, Xc, args):
    """The samples ``Xc`` persisted on the cluster of ``client`` in blocks of ``args.chunk``
    rows, and every worker warmed, before any call is timed.

    Each worker imports ndboundary and compiles the neighbour index's query by predicting a
    few rows with a copy of ``clf`` that is then dropped (the in-memory process did the
    same before its calls), and the samples are on the workers when this returns: a
    persist runs in the background, and a call timed before it lands would count the
    transfer of every sample to the cluster as prediction time.
    """
    shipped = client.scatter(clf, broadcast=True)
    warm = [
        client.submit(lambda est, Z: est.predict(Z), shipped, Xc[:1000], workers=[w], pure=False)
        for w in client.nthreads()
    ]
    client.gather(warm)
    del shipped, warm
    # --held-by-one: every block on one worker, as when one worker loaded the samples
    held_by = sorted(client.nthreads())[:1] if args.held_by_one else None
    Xd = client.persist(da.from_array(Xc, chunks=(args.chunk, args.features)), workers=held_by)
    wait(Xd)
    return Xd


def calls(way, ref, name, count):
    """The median seconds of ``count`` calls of ``way``, each checked against ``ref``."""
    seconds = []
    for _ in range(count):
        t, labels = timed(way)
        check(labels, ref, name)
        seconds.append(t)
    return float(np.median(seconds))


def rounds(clf, Xc, ref, layouts, settings, args):
    """Seconds and ratios to in memory of ``args.repeats`` rounds (see above)."""
    names = [f"{name}@{w}x{t}" for w, t in layouts for name in ("cluster_first", *args.ways)]
    if args.plain > 0:
        names.insert(0, f"plain@{args.plain}")
    times = {name: [] for name in ("memory", *names)}
    for _ in range(args.repeats):
        times["memory"].append(calls(lambda: clf.predict(Xc), ref, "memory", args.calls))  # no cluster running
        if args.plain > 0:
            with plain_processes(args.plain, clf, Xc) as pool:
                times[f"plain@{args.plain}"].append(plain_round(pool, args.check_n, args.chunk, ref, args.calls))
        for w, th in layouts:
            with cluster(w, th, settings) as client:
                for name, t in cluster_round(client, clf, Xc, ref, args).items():
                    times[f"{name}@{w}x{th}"].append(t)
    mem = np.asarray(times["memory"])
    out = {"memory_s": float(np.median(mem)), "memory_rows_per_s": args.check_n / float(np.median(mem))}
    for name in names:
        t = np.asarray(times[name])
        out[f"{name}_s"] = float(np.median(t))
        out[f"{name}_vs_memory"] = float(np.median(mem / t))  # ratios within each round
        out[f"{name}_vs_memory_range"] = [round(float(r), 3) for r in (np.min(mem / t), np.max(mem / t))]
    for w, th in layouts:
        out[f"cluster_rows_per_s@{w}x{th}"] = args.check_n / out[f"cluster@{w}x{th}_s"]
    return out


def paired_layouts(clf, Xc, ref, layouts, settings, args):
    """The paired measurement of ``--pairs`` on a fresh cluster of each layout."""
    out = {}
    for w, th in layouts:
        if args.first:
            first, second, seconds = first_pairs(clf, Xc, ref, w, th, settings, args)
            groups = {f"first_pairs@{w}x{th}": first, f"first_pairs_second_call@{w}x{th}": second}
            if args.pairs > 1:  # the odd quads'
                groups[f"first_pairs_before_any_suspension@{w}x{th}"] = first[1::2]
            # each second call's seconds over its first's: below 1, the first call is the slower
            slower = np.asarray(seconds["cluster"]) / np.asarray(seconds["cluster_first"])
            key = f"first_pairs_second_over_first@{w}x{th}"
            out[key], out[f"{key}_ci95"] = median_interval(slower)
        else:
            with cluster(w, th, settings) as client:
                ratios, seconds = paired(client, clf, Xc, ref, args)
            groups = {f"paired@{w}x{th}": ratios}
        for key, ratios in groups.items():
            out[f"{key}_vs_memory"], out[f"{key}_vs_memory_ci95"] = median_interval(ratios)
            out[f"{key}_share_at_least_1"] = float(np.mean(np.asarray(ratios) >= 1.0))
            out[f"{key}_ratios"] = [round(r, 3) for r in ratios]
        key = next(iter(groups))
        for name, t in seconds.items():
            out[f"{key}_{name}_s"] = float(np.median(t))
            out[f"{key}_{name}_rows_per_s"] = args.check_n / float(np.median(t))
    return out


def pooled(paths):
    """The ratios of several runs' JSON lines (the last line of each file in ``paths``,
    as this script prints it) pooled key by key: each key's median, its 95 % bootstrap
    interval and share at or above 1 over the ratios of every run that has the key."""
    runs = []
    for path in paths:
        lines = [line for line in Path(path).read_text().splitlines() if line.startswith("{")]
        if not lines:
            raise SystemExit(f"{path}: no JSON line of this script's output")
        runs.append(json.loads(lines[-1]))
    out = {}
    for key in dict.fromkeys(k for run in runs for k in run if k.endswith("_ratios")):
        ratios = [r for run in runs for r in run.get(key, [])]
        name = key.removesuffix("_ratios")
        out[f"{name}_runs"] = sum(key in run for run in runs)
        out[f"{name}_vs_memory"], out[f"{name}_vs_memory_ci95"] = median_interval(ratios)
        out[f"{name}_share_at_least_1"] = float(np.mean(np.asarray(ratios) >= 1.0))
        out[f"{name}_n"] = len(ratios)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--pool",
        nargs="+",
        metavar="FILE",
        help="measure nothing: pool the ratios of earlier runs' printed output, key by key",
    )
    ap.add_argument("--fit-n", type=int, default=100_000)
    ap.add_argument("--max-samples", type=float, default=0.1)
    ap.add_argument("--features", type=int, default=50)
    ap.add_argument("--n", type=int, default=10_000_000)
    ap.add_argument("--check-n", type=int, default=200_000)
    ap.add_argument("--chunk", type=int, default=100_000)
    cores = len(os.sched_getaffinity(0))
    ap.add_argument(
        "--layouts",
        default=f"1x{cores},{cores}x1",
        help="comma-separated cluster layouts WxT: W worker processes of T threads each",
    )
    ap.add_argument("--repeats", type=int, default=3, help="rounds (0: none)")
    ap.add_argument("--no-profiler", action="store_true", help="workers without Dask's statistical profiler")
    ap.add_argument("--no-malloc-trim", action="store_true", help="workers without Dask's MALLOC_TRIM_THRESHOLD_")
    ap.add_argument("--quiet", action="store_true", help="clusters with QUIET's settings")
    ap.add_argument("--idle", action="store_true", help="first measure an idle cluster's CPU share, each setting")
    ap.add_argument(
        "--faults",
        action="store_true",
        help="first count the page faults of predicting --chunk rows on one thread, with and without malloc trim",
    )
    ap.add_argument("--ways", default=",".join(WAYS), help=f"comma-separated, from {', '.join(WAYS)}")
    ap.add_argument("--calls", type=int, default=1, help="calls per way and round, their median kept")
    ap.add_argument(
        "--after-idle",
        type=float,
        default=0.0,
        metavar="S",
        help="first time in-memory calls back to back and each after S seconds idle (0: skip)",
    )
    ap.add_argument("--ship", type=int, default=0, metavar="N", help="first time the model's shipping on N clusters")
    ap.add_argument(
        "--chunk-cost",
        action="store_true",
        help="first time the samples predicted on one thread at once, in blocks, and in blocks of the sorted rows",
    )
    ap.add_argument(
        "--held-by-one", action="store_true", help="persist every block of the samples on one worker"
    )
    ap.add_argument(
        "--trace", type=int, default=0, metavar="N", help="first trace a first and second call on N clusters"
    )
    ap.add_argument(
        "--plain",
        type=int,
        default=cores,
        help="plain processes of one thread each round, without Dask (0: none)",
    )
    ap.add_argument(
        "--pairs",
        type=int,
        default=0,
        help="measure in ABBA quads of in-memory and cluster calls on one cluster per layout (see above) "
        "instead of rounds",
    )
    ap.add_argument(
        "--first",
        action="store_true",
        help="with --pairs, start a fresh cluster for each quad, whose first cluster call is the user's first "
        "(the odd quads in the order BAAB)",
    )
    args = ap.parse_args(argv)
    if args.pool:
        for k, v in pooled(args.pool).items():
            print(f"{k:<46s} {v:.4g}" if isinstance(v, float) else f"{k:<46s} {v}")
        return
    args.ways = [way for way in args.ways.split(",") if way]
    if unknown := sorted(set(args.ways) - set(WAYS)):
        ap.error(f"unknown ways {unknown}; choose from {', '.join(WAYS)}")
    if args.first and args.pairs <= 0:
        ap.error("--first needs --pairs N with N of at least 1")
    X, y = make_data(args.fit_n, args.features)
    m = args.max_samples
    clf = LevelSetClassifier(max_samples=None if m <= 0 else (int(m) if m > 1 else m), random_state=0)
    t0 = time.perf_counter()
    clf.fit(X, y)
    out = {"fit_n": args.fit_n, "landmarks": int(clf.domain_.n_vertices), "fit_s": time.perf_counter() - t0}
    Xc, yc = make_data(args.check_n, args.features, seed=1)
    clf.predict(Xc[:1000])  # the neighbour index's query compiled
    ref = clf.predict(Xc)
    out["accuracy"] = float((ref == yc).mean())
    settings = {"distributed.worker.profile.enabled": not args.no_profiler}
    if args.quiet:
        settings.update(QUIET)
    if args.no_malloc_trim:
        environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ"))
        environ.pop("MALLOC_TRIM_THRESHOLD_", None)
        settings["distributed.nanny.pre-spawn-environ"] = environ
    layouts = [layout(text) for text in args.layouts.split(",")]
    if args.idle:
        for name, conf in (("default", {}), ("quiet", QUIET)):
            out[f"idle_core_share_{name}@{layouts[0][0]}x{layouts[0][1]}"] = idle_share(*layouts[0], conf)
    if args.faults:
        for name, trim in (("trim", True), ("no_trim", False)):
            faults, seconds = page_faults(clf, Xc[: args.chunk], trim)
            out[f"page_faults_{name}"], out[f"one_thread_s_{name}"] = faults, seconds
    if args.chunk_cost:
        out.update(chunk_costs(clf, Xc, args.chunk, max(args.calls, 3)))
    if args.ship > 0:
        out.update(ship_times(clf, Xc, *layouts[0], settings, args, args.ship))
    if args.trace > 0:
        out.update(traced_calls(clf, Xc, *layouts[0], settings, args, args.trace))
    if args.after_idle > 0:
        out.update(after_idle(clf, Xc, ref, args.after_idle, max(3, args.calls)))
    if args.pairs > 0:
        out.update(paired_layouts(clf, Xc, ref, layouts, settings, args))
    elif args.repeats > 0:
        out.update(rounds(clf, Xc, ref, layouts, settings, args))
    if args.n > 0:
        with cluster(*layouts[0], settings):
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
        print(f"{k:<46s} {v:.4g}" if isinstance(v, float) else f"{k:<46s} {v}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
