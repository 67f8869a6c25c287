"""The classifier beyond memory: fitting on landmarks, predicting block-wise on Dask arrays."""

import gc
import time

import numpy as np
import pytest
from sklearn.datasets import make_blobs, make_moons
from sklearn.utils.estimator_checks import parametrize_with_checks

from ndboundary import LevelSetClassifier
from ndboundary._threads import available_threads

da = pytest.importorskip("dask.array")
THREADS_BEFORE_ANY_CLUSTER = available_threads()


@pytest.fixture(scope="module")
def moons():
    X, y = make_moons(3000, noise=0.25, random_state=0)
    Xt, yt = make_moons(1000, noise=0.25, random_state=1)
    return X, y, Xt, yt


@pytest.fixture(scope="module")
def fitted(moons):
    X, y, _, _ = moons
    return LevelSetClassifier().fit(X[:800], y[:800])


@parametrize_with_checks([LevelSetClassifier(max_samples=0.6, random_state=0)])
def test_sklearn_compatible_on_landmarks(estimator, check):
    check(estimator)


def test_landmarks_keep_every_class_and_their_shares():
    X, y = make_blobs([900, 90, 9, 1], centers=[[0, 0], [6, 0], [0, 6], [6, 6]], random_state=0)
    clf = LevelSetClassifier(max_samples=100, random_state=0).fit(X, y)
    assert clf.landmarks_.shape == (100,) and np.all(np.diff(clf.landmarks_) > 0)
    counts = np.bincount(y[clf.landmarks_], minlength=4)
    assert counts.sum() == 100 and counts.min() >= 1 and abs(counts[0] - 90) <= 2
    assert clf.phi_.shape[0] == 100 and clf.domain_.n_vertices == 100
    np.testing.assert_array_equal(clf.transduction_, y)  # every sample labelled: its own label
    assert clf.score(X, y) > 0.99
    assert clf.predict(X[y == 3]).tolist() == [3]  # the class of one sample is kept


def test_landmarks_cost_little_accuracy(moons):
    X, y, Xt, yt = moons
    full = LevelSetClassifier().fit(X, y).score(Xt, yt)
    part = LevelSetClassifier(max_samples=0.25, random_state=0).fit(X, y)
    assert part.landmarks_.size == 750
    assert part.score(Xt, yt) >= full - 0.02


def test_landmarks_draw_is_reproducible(moons):
    X, y, Xt, _ = moons
    a = LevelSetClassifier(max_samples=500, random_state=3).fit(X, y)
    b = LevelSetClassifier(max_samples=500, random_state=3).fit(X, y)
    np.testing.assert_array_equal(a.landmarks_, b.landmarks_)
    np.testing.assert_array_equal(a.decision_function(Xt), b.decision_function(Xt))
    assert LevelSetClassifier(max_samples=1.0).fit(X[:50], y[:50]).landmarks_ is None


def test_unlabelled_samples_beyond_the_landmarks_are_predicted(moons):
    X, y, _, _ = moons
    ys = np.where(np.random.default_rng(0).random(y.size) < 0.05, y, -1)
    clf = LevelSetClassifier(unlabeled=-1, max_samples=0.3, random_state=0).fit(X, ys)
    labelled = ys != -1
    np.testing.assert_array_equal(clf.transduction_[labelled], y[labelled])
    rest = np.ones(y.size, bool)
    rest[clf.landmarks_] = False
    rest &= ~labelled
    np.testing.assert_array_equal(clf.transduction_[rest], clf.predict(X[rest]))
    assert set(np.unique(clf.transduction_)) == {0, 1} and np.mean(clf.transduction_ == y) > 0.9


@pytest.mark.parametrize(
    "value, err, match",
    [
        (1, ValueError, "max_samples"),
        (0.0, ValueError, "max_samples"),
        (1.5, ValueError, "max_samples"),
        ("half", TypeError, "max_samples"),
    ],
)
def test_bad_max_samples(moons, value, err, match):
    X, y, _, _ = moons
    with pytest.raises(err, match=match):
        LevelSetClassifier(max_samples=value).fit(X[:100], y[:100])


def test_fewer_landmarks_than_classes_is_refused():
    X, y = make_blobs(60, centers=3, random_state=0)
    with pytest.raises(ValueError, match="fewer than the 3 classes"):
        LevelSetClassifier(max_samples=2).fit(X, y)


@pytest.mark.parametrize("chunks", [(250, 2), (333, 1), (1000, 2)])
@pytest.mark.parametrize("method", ["predict", "predict_proba", "decision_function", "predict_log_proba"])
def test_dask_arrays_are_predicted_block_by_block(fitted, moons, method, chunks):
    Xt = moons[2]
    lazy = getattr(fitted, method)(da.from_array(Xt, chunks=chunks))
    assert isinstance(lazy, da.Array)
    np.testing.assert_array_equal(lazy.compute(), getattr(fitted, method)(Xt))


def test_dask_arrays_of_many_classes():
    X, y = make_blobs(600, centers=4, random_state=0)
    clf = LevelSetClassifier().fit(X[:400], y[:400])
    lazy = clf.decision_function(da.from_array(X[400:], chunks=(64, 2)))
    assert lazy.shape == (200, 4)
    np.testing.assert_array_equal(lazy.compute(), clf.decision_function(X[400:]))
    assert clf.predict(da.from_array(X[400:], chunks=64)).dtype == clf.classes_.dtype


def test_dask_arrays_of_the_wrong_width_are_refused(fitted):
    with pytest.raises(ValueError, match="fitted on 2 features"):
        fitted.predict(da.zeros((10, 3), chunks=5))


def test_fit_on_a_dask_array_computes_the_landmarks_only(moons):
    X, y, Xt, _ = moons
    Xd = da.from_array(X, chunks=(500, 2))
    with pytest.raises(ValueError, match="needs max_samples"):
        LevelSetClassifier().fit(Xd, y)
    with pytest.raises(ValueError, match="do not match"):
        LevelSetClassifier(max_samples=0.5).fit(Xd, y[:-1])
    lazy = LevelSetClassifier(max_samples=600, random_state=0).fit(Xd, da.from_array(y, chunks=500))
    eager = LevelSetClassifier(max_samples=600, random_state=0).fit(X, y)
    np.testing.assert_array_equal(lazy.landmarks_, eager.landmarks_)
    np.testing.assert_array_equal(lazy.decision_function(Xt), eager.decision_function(Xt))
    assert lazy.n_features_in_ == 2


@pytest.fixture(scope="module")
def client():
    """Two worker processes of one thread. Without work stealing, which moves queued tasks
    of blocks as small as these to whichever worker runs short, so that the tests see
    where the tasks were placed."""
    import dask

    distributed = pytest.importorskip("distributed")
    with (
        dask.config.set({"distributed.scheduler.work-stealing": False}),
        distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        distributed.Client(cluster) as c,
    ):
        yield c


def test_predictions_on_a_local_cluster_equal_the_in_memory_ones(client, fitted, moons):
    dask_ml = pytest.importorskip("dask_ml.wrappers")
    Xt = moons[2]
    Xd = da.from_array(Xt, chunks=(200, 2))
    wrapped = dask_ml.ParallelPostFit(fitted)
    np.testing.assert_array_equal(wrapped.predict(Xd).compute(), fitted.predict(Xt))
    np.testing.assert_array_equal(wrapped.predict_proba(Xd).compute(), fitted.predict_proba(Xt))
    blocks = Xd.map_blocks(fitted.decision_function, drop_axis=1, dtype=np.float64)
    np.testing.assert_array_equal(blocks.compute(), fitted.decision_function(Xt))
    np.testing.assert_array_equal(fitted.predict(Xd).compute(), fitted.predict(Xt))


def test_a_local_cluster_leaves_the_process_that_started_it_its_threads(client):
    """The cluster's nanny sets ``OMP_NUM_THREADS=1`` in this process's environment for
    its workers to inherit and leaves it there; the classifier's own passes here keep the
    threads this process was started with."""
    assert client.run(available_threads) == dict.fromkeys(client.scheduler_info()["workers"], 1)
    assert available_threads() == THREADS_BEFORE_ANY_CLUSTER


def _eventually(condition, seconds=30.0):
    """Whether ``condition()`` holds within ``seconds`` (the cluster acts on its own time)."""
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.05)
    return condition()


def _holding(client, name):
    """The number of the client's workers that hold the classifier's copy ``name``."""
    return sum(client.run(lambda dask_worker: name in dask_worker.plugins).values())


def test_the_workers_keep_their_copy_while_a_fit_or_a_prediction_holds_it(client, moons):
    from ndboundary.learn.scaleout import shipped_to_workers

    X, y, Xt, _ = moons
    clf = LevelSetClassifier().fit(X[:600], y[:600])
    Xd = da.from_array(Xt, chunks=(250, 2))
    np.testing.assert_array_equal(clf.predict(Xd).compute(), clf.predict(Xt))
    first = shipped_to_workers(clf)
    assert _holding(client, first.name) == 2  # on both workers
    older = clf.predict_proba(Xd)
    assert shipped_to_workers(clf) is first  # not sent again
    expected = clf.predict_proba(Xt)
    clf.fit(X[600:1200], y[600:1200])
    np.testing.assert_array_equal(clf.decision_function(Xd).compute(), clf.decision_function(Xt))
    assert shipped_to_workers(clf) is not first
    # the prediction built before the refit still holds the first fit's copy, and gives it
    np.testing.assert_array_equal(older.compute(), expected)
    name = first.name
    del older, first
    gc.collect()
    assert _eventually(lambda: _holding(client, name) == 0)  # released with the last prediction that held it
    # a copy taken away under a prediction: its tasks say so
    lazy = clf.predict(Xd)
    client.unregister_worker_plugin(shipped_to_workers(clf).name)
    with pytest.raises(RuntimeError, match="no longer hold the classifier's copy"):
        lazy.compute()


@pytest.mark.parametrize("seed", range(20))
def test_the_blocks_moved_even_out_the_rows_per_thread(seed):
    """Whatever the placement, after the moves the busiest worker's rows per thread are
    within one block of the even share and no more than before."""
    from ndboundary.learn.placement import balance_plan

    rng = np.random.default_rng(seed)
    threads = {f"w{i}": int(t) for i, t in enumerate(rng.integers(1, 4, rng.integers(2, 5)))}
    workers = sorted(threads)
    rows = rng.integers(50, 150, rng.integers(3, 40)).tolist()
    before = [workers[0]] * len(rows) if seed % 2 else list(rng.choice(workers, len(rows)))
    moves = balance_plan(rows, [[w] for w in before], threads)
    assert all(dest in threads and dest != before[i] for i, dest in moves.items())
    after = [moves.get(i, w) for i, w in enumerate(before)]

    def busiest(place):
        load = dict.fromkeys(threads, 0.0)
        for r, w in zip(rows, place, strict=True):
            load[w] += r / threads[w]
        return max(load.values())

    share = sum(rows) / sum(threads.values())
    assert busiest(after) <= min(busiest(before), share + max(rows) / min(threads.values())) + 1e-9
    if seed % 2:
        assert busiest(after) < busiest(before)


def test_many_blocks_on_one_of_many_workers_are_dealt_out_evenly():
    from ndboundary.learn.placement import balance_plan

    threads = {f"w{i:03d}": 1 + i % 2 for i in range(200)}
    moves = balance_plan([1000] * 30000, [["w000"]] * 30000, threads)
    counts = dict.fromkeys(threads, 0)
    for w in moves.values():
        counts[w] += 1
    counts["w000"] = 30000 - len(moves)
    assert all(counts[w] == 100 * threads[w] for w in threads)


def test_a_block_held_by_several_workers_is_not_moved():
    from ndboundary.learn.placement import balance_plan

    threads = {"a": 1, "b": 1}
    assert balance_plan([100] * 4, [["a", "b"]] * 4, threads) == {}
    assert balance_plan([100] * 4, [["a"], ["a"], ["a"], ["a", "b"]], threads) == {2: "b"}
    assert balance_plan([100] * 4, [["a"], ["gone"], [], ["a"]], threads) == {3: "b"}


def _where_predicted(client, clf, Xd, expected):
    """The workers holding each block of ``Xd``, and the worker each block's prediction
    ran on; no prediction task may have fetched its input from another worker."""
    from distributed import get_task_stream

    held = {key[1]: set(workers) for key, workers in client.who_has(Xd).items()}
    with get_task_stream(client) as stream:
        labels = clf.predict(Xd).compute()
    np.testing.assert_array_equal(labels, expected)
    # a moved block's task reads the copy under its block's key: two tasks, one worker
    tasks = [t for t in stream.data if "_apply_held" in str(t["key"])]
    assert not [t["key"] for t in tasks if any(s["action"] == "transfer" for s in t["startstops"])]
    ran = {}
    for t in tasks:
        ran.setdefault(t["key"][1], set()).add(t["worker"])
    assert set(ran) == set(held) and all(len(workers) == 1 for workers in ran.values())
    return held, {i: workers.pop() for i, workers in ran.items()}


def test_each_block_is_predicted_where_it_is_held(client, moons):
    """The copy is no input of the tasks, so the scheduler places each with its block:
    as a dependency every worker holds, it made every worker a candidate, and the
    scheduler's greedy choice moved blocks between workers. Only the fewest blocks that
    even out an uneven placement move, before their tasks run."""
    from distributed import wait

    X, y, Xt, _ = moons
    clf = LevelSetClassifier().fit(X[:600], y[:600])
    Xt = np.repeat(Xt, 4, axis=0)
    Xd = client.persist(da.from_array(Xt, chunks=(100, 2)))
    wait(Xd)
    clf.predict(Xd[:200]).compute()  # the copy shipped and the tasks' duration known
    held, ran = _where_predicted(client, clf, Xd, clf.predict(Xt))
    workers = sorted(client.nthreads())
    before = [sum(w in held[i] for i in held) for w in workers]
    after = [sum(ran[i] == w for i in ran) for w in workers]
    assert len(held) == 40 and abs(after[0] - after[1]) <= 1
    assert sum(ran[i] not in held[i] for i in ran) == abs(before[0] - before[1]) // 2


def test_blocks_held_by_one_worker_are_spread_over_all(client, moons):
    from distributed import wait

    X, y, Xt, _ = moons
    clf = LevelSetClassifier().fit(X[:600], y[:600])
    first = sorted(client.nthreads())[0]
    Xd = client.persist(da.from_array(Xt, chunks=(125, 2)), workers=[first])
    wait(Xd)
    held, ran = _where_predicted(client, clf, Xd, clf.predict(Xt))
    assert all(workers == {first} for workers in held.values())
    assert sorted(ran.values()).count(first) == 4 and len(set(ran.values())) == 2
    assert all(first in workers for workers in client.who_has(Xd).values())  # the user's blocks stay
    # the copies of the blocks moved are made as the prediction is built, held while it is
    Xd = client.persist(da.from_array(Xt[:500], chunks=(125, 2)), workers=[first])
    wait(Xd)
    lazy = clf.predict_proba(Xd)
    assert _eventually(lambda: len(_moved_keys(client)) == 2)
    np.testing.assert_array_equal(lazy.compute(), clf.predict_proba(Xt[:500]))
    del lazy
    gc.collect()
    assert _eventually(lambda: not _moved_keys(client))


def _moved_keys(client):
    return [key for key in client.who_has() if str(key).startswith("ndboundary-moved")]


@pytest.mark.parametrize("n_classes", [2, 4])
def test_the_workers_copy_predicts_alike_and_is_small(n_classes):
    import pickle

    from ndboundary.learn.scaleout import for_prediction

    X, y = make_blobs(1200, n_features=6, centers=n_classes, cluster_std=3.0, random_state=0)
    clf = LevelSetClassifier().fit(X[:900], y[:900])
    lean = for_prediction(clf)
    for method in ("predict", "predict_proba", "decision_function"):
        np.testing.assert_array_equal(getattr(lean, method)(X[900:]), getattr(clf, method)(X[900:]))
    assert len(pickle.dumps(lean)) < 0.5 * len(pickle.dumps(clf))
    assert clf.domain_ is not None and clf.phi_ is not None  # the fitted estimator is left whole
