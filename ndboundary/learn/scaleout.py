"""Fitting on landmarks and predicting block-wise: the classifier beyond one machine's memory.

Two pieces serve large data:

* **Landmarks** (``max_samples``). The graph is built over a stratified random draw of
  the training samples: every class (and the unlabelled samples, in semi-supervised use)
  keeps its share, and at least one sample. The relaxed functions live on the landmarks;
  every other sample is one more point the fitted extension predicts.
* **Dask arrays.** :func:`map_rows` runs a row-wise method of the fitted classifier over
  each block of rows of a Dask array, lazily: predictions of one row never depend on the
  other rows predicted with it, so the blocks agree with the in-memory result exactly.
  Dask is an optional dependency (the ``dask`` extra); nothing here imports it unless a
  Dask array is given. On a ``distributed`` cluster the lean copy of the fitted
  classifier (:func:`for_prediction`) is installed on every worker once, as a worker
  plugin, and kept there while the classifier or a prediction built from it lives
  (:func:`shipped_to_workers`): later predictions do not send it again, and each block's
  task, whose only input is its block, runs where the block is held, the blocks of a
  persisted array first spread evenly over the workers (:mod:`ndboundary.learn.placement`).
"""

from __future__ import annotations

import numbers
import weakref

import numpy as np

__all__ = [
    "is_dask_array",
    "landmark_rows",
    "landmark_samples",
    "lazy_rows",
    "for_prediction",
    "map_rows",
    "n_landmarks",
    "shipped_to_workers",
    "transduce_the_rest",
    "WorkersCopy",
]

# fitted classifier -> (its classes_ when shipped, a weak reference to the client, the WorkersCopy)
_SHIPPED = weakref.WeakKeyDictionary()


def is_dask_array(X):
    """Whether ``X`` is a Dask array (judged by its type, without importing Dask)."""
    return type(X).__module__.split(".")[0] == "dask" and hasattr(X, "map_blocks") and hasattr(X, "chunks")


def n_landmarks(max_samples, n_samples):
    """The number of landmarks ``max_samples`` asks for among ``n_samples``.

    Parameters
    ----------
    max_samples : int or float
        A count (at least 2), or a share of the samples in ``(0, 1]``.
    n_samples : int

    Returns
    -------
    int
        At most ``n_samples``.

    Examples
    --------
    >>> from ndboundary.learn.scaleout import n_landmarks
    >>> n_landmarks(0.1, 100_000), n_landmarks(500, 200)
    (10000, 200)
    """
    if isinstance(max_samples, numbers.Integral):
        return int(min(max_samples, n_samples))
    return int(min(n_samples, max(2, np.ceil(max_samples * n_samples))))


def landmark_rows(strata, m, random_state=None):
    """A stratified random draw of ``m`` rows: sorted indices into ``strata``.

    Each stratum (a class, or the unlabelled samples) gets its proportional share of the
    ``m`` rows, rounded by largest remainders, and at least one row, so that no class is
    lost however rare it is.

    Parameters
    ----------
    strata : ndarray of int of shape (n_samples,)
        The stratum of each row.
    m : int
        Rows to draw, at least the number of strata.
    random_state : int, Generator or None

    Returns
    -------
    ndarray of int of shape (m,)

    Raises
    ------
    ValueError
        If ``m`` is smaller than the number of strata.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.learn.scaleout import landmark_rows
    >>> strata = np.r_[np.zeros(990, int), np.ones(10, int)]
    >>> rows = landmark_rows(strata, 50, random_state=0)
    >>> np.bincount(strata[rows]).tolist()
    [49, 1]
    """
    values, inverse, counts = np.unique(strata, return_inverse=True, return_counts=True)
    if m < values.size:
        raise ValueError(
            f"max_samples gives {m} landmarks, fewer than the {values.size} classes (and unlabelled samples) "
            "to draw them from: every class needs one"
        )
    share = counts * (m / counts.sum())
    take = np.maximum(1, np.floor(share)).astype(np.int64)
    take = np.minimum(take, counts)
    short = m - int(take.sum())
    if short > 0:  # largest remainders first, among strata with rows left
        order = np.argsort(-(share - np.floor(share)), kind="stable")
        while short > 0:
            for s in order:
                if short and take[s] < counts[s]:
                    take[s] += 1
                    short -= 1
    elif short < 0:  # the minimum of one row overdrew: trim the largest shares
        for s in np.argsort(-take, kind="stable"):
            cut = min(-short, int(take[s]) - 1)
            take[s] -= cut
            short += cut
    rng = np.random.default_rng(random_state)
    inverse = inverse.reshape(-1)
    rows = [rng.choice(np.flatnonzero(inverse == s), size=int(t), replace=False) for s, t in enumerate(take)]
    return np.sort(np.concatenate(rows))


def _apply(X, est, method):
    return getattr(est, method)(X)


def for_prediction(est):
    """A copy of the fitted classifier ``est`` that predicts as it does but holds no
    graph: no ``domain_``, ``phi_`` or ``transduction_``, and an extension that only
    evaluates new points. It is what the workers of a cluster receive.
    """
    import copy

    lean = copy.copy(est)
    lean.domain_ = lean.phi_ = lean.transduction_ = lean.landmarks_ = None
    if getattr(est, "extension_", None) is not None and hasattr(est.extension_, "for_queries"):
        lean.extension_ = est.extension_.for_queries()
    if getattr(est, "kernel_extension_", None) is not None:
        lean.kernel_extension_ = est.kernel_extension_.for_queries()
    return lean


def _current_client():
    """The ``distributed`` client Dask computes with by default, or None."""
    try:
        from distributed import default_client
    except ImportError:
        return None
    try:
        return default_client()
    except ValueError:  # no client
        return None


class WorkersCopy:
    """A handle on the lean copy of a fitted classifier that a cluster's workers hold.

    It names the worker plugin that holds the copy (:class:`~ndboundary.learn.workercopy.HeldCopy`).
    The fitted classifier and every lazy prediction built from it hold the handle; when
    the last of them lets it go, the plugin is unregistered and the workers drop their
    copy. Pickled, as a prediction task's argument, it is its name alone; in the process
    that made it, it also holds the copy itself, which a task run there (Dask's threads)
    uses directly.
    """

    __slots__ = ("name", "lean", "__weakref__")

    def __init__(self, name, lean=None):
        self.name = name
        self.lean = lean

    def __reduce__(self):
        return (WorkersCopy, (self.name,))

    def __dask_tokenize__(self):
        return ("ndboundary.WorkersCopy", self.name)

    def __repr__(self):
        return f"WorkersCopy({self.name!r})"

    def resolve(self):
        """The lean copy: this process's own, or the one the running worker holds."""
        if self.lean is not None:
            return self.lean
        from .workercopy import held_copy

        return held_copy(self.name)


def _apply_held(X, held, method):
    return getattr(held.resolve(), method)(X)


def _unregister(client_ref, name):
    """Unregister the worker plugin ``name`` without waiting, if its client still runs
    (a finalizer may run on any thread, the client's event loop's among them).
    """
    client = client_ref()
    if client is None or client.status != "running":
        return

    async def drop():
        try:
            await client._unregister_worker_plugin(name=name, nanny=False)
        except Exception:  # the cluster closing meanwhile drops it anyway
            pass

    client.loop.add_callback(drop)


def shipped_to_workers(est):
    """The workers' copy of the fitted classifier ``est`` on the current ``distributed``
    client, as a :class:`WorkersCopy`; None without a client.

    The lean copy (:func:`for_prediction`) is installed on every worker, and on every
    worker that joins later, as a worker plugin on the first call, and reused by later
    ones while ``est`` lives, the client runs and ``est`` is not refitted. The copy holds
    the training samples and their neighbour index, which sent with each prediction would
    cost each call a transfer of that size. As a plugin rather than as data each task
    depends on, it leaves each task's block of rows its only input, so that the
    scheduler runs the task where that block is held (see
    :mod:`ndboundary.learn.workercopy`).
    """
    client = _current_client()
    if client is None or client.status != "running":
        return None
    held = _SHIPPED.get(est)
    if held is not None and held[0] is est.classes_ and held[1]() is client:
        return held[2]
    import uuid

    from .workercopy import HeldCopy

    lean = for_prediction(est)
    name = f"ndboundary-classifier-{uuid.uuid4().hex}"
    client.register_plugin(HeldCopy(name, lean), name=name)
    handle = WorkersCopy(name, lean)
    weakref.finalize(handle, _unregister, weakref.ref(client), name).atexit = False
    _SHIPPED[est] = (est.classes_, weakref.ref(client), handle)
    return handle


def map_rows(est, method, X, n_outputs, dtype):
    """The method ``method`` of the fitted classifier ``est`` applied to each block of rows
    of the Dask array ``X``, lazily.

    The estimator enters the task graph once and lean (:func:`for_prediction`): without a
    ``distributed`` client, as one object that every block's task depends on; on a
    ``distributed`` client, as the copy its workers already hold
    (:func:`shipped_to_workers`), named in each task, so that a task's only input is
    its block. The blocks of an array already in the cluster's memory are first spread
    evenly over the workers, the fewest of them copied to another worker
    (:func:`~ndboundary.learn.placement.balanced_blocks`).

    Parameters
    ----------
    est : LevelSetClassifier
        Fitted.
    method : str
        A method mapping an ndarray of shape (b, n_features) to shape (b,) (``n_outputs``
        None) or (b, n_outputs).
    X : dask.array.Array of shape (n_samples, n_features)
    n_outputs : int or None
    dtype : numpy dtype
        Of the result.

    Returns
    -------
    dask.array.Array of shape (n_samples,) or (n_samples, n_outputs)

    Raises
    ------
    ValueError
        If ``X`` is not two-dimensional with as many columns as ``est`` was fitted on.
    """
    import dask

    n_features = est.n_features_in_
    if X.ndim != 2 or X.shape[1] != n_features:
        raise ValueError(f"X has shape {X.shape}; the classifier was fitted on {n_features} features")
    if len(X.chunks[1]) > 1:
        X = X.rechunk({1: -1})  # each block holds whole rows
    held = shipped_to_workers(est)
    if held is None:
        # pure=False: a fresh key instead of hashing the whole fitted estimator
        fn, model = _apply, dask.delayed(for_prediction(est), pure=False, traverse=False)
    else:
        from .placement import balanced_blocks

        fn, model = _apply_held, held
        X = balanced_blocks(_current_client(), X)
    if n_outputs is None:
        return X.map_blocks(fn, model, method, drop_axis=1, dtype=dtype, meta=np.empty((0,), dtype=dtype))
    return X.map_blocks(
        fn,
        model,
        method,
        chunks=(X.chunks[0], (n_outputs,)),
        dtype=dtype,
        meta=np.empty((0, 0), dtype=dtype),
    )


def landmark_samples(est, X, y):
    """The training samples of the classifier ``est`` and the rows its graph is built over.

    Returns
    -------
    X_all, y_all
        All the samples: ``X_all`` validated, or as given when a Dask array; ``y_all`` an
        ndarray.
    X, y : ndarray
        The validated rows of the graph: the landmarks of ``est.max_samples``, or all.
    landmarks : ndarray of int or None
        Their indices into ``X_all``; None for all.

    Raises
    ------
    ValueError
        For a Dask ``X`` without ``max_samples``, or ``X`` and ``y`` of different lengths.
    """
    from sklearn.utils.multiclass import check_classification_targets
    from sklearn.utils.validation import validate_data

    dask_x = is_dask_array(X)
    if dask_x:
        if est.max_samples is None:
            raise ValueError(
                "X is a Dask array: fit builds its graph in memory, so it needs max_samples "
                "(the landmarks drawn from X, whose rows alone are computed)"
            )
        y_all = np.asarray(y.compute() if is_dask_array(y) else y)
        if X.ndim != 2 or y_all.ndim != 1 or y_all.shape[0] != X.shape[0]:
            raise ValueError(f"X of shape {X.shape} and y of shape {y_all.shape} do not match")
        X_all = X
    else:
        X_all, y_all = validate_data(est, X, y, ensure_min_samples=2, dtype=np.float64)
    check_classification_targets(y_all)
    n = y_all.shape[0]
    landmarks = None
    if est.max_samples is not None and n_landmarks(est.max_samples, n) < n:
        strata = np.unique(y_all, return_inverse=True)[1].reshape(-1)
        landmarks = landmark_rows(strata, n_landmarks(est.max_samples, n), est.random_state)
    rows = slice(None) if landmarks is None else landmarks
    if not dask_x:
        return X_all, y_all, X_all[rows], y_all[rows], landmarks
    X_l = np.asarray(X_all[rows].compute())
    X_l, y_l = validate_data(est, X_l, y_all[rows], ensure_min_samples=2, dtype=np.float64)
    return X_all, y_all, X_l, y_l, landmarks


def transduce_the_rest(est, X_all, y_all):
    """The labels of all training samples of a classifier fitted on landmarks: the
    landmarks' from the fit (``est.transduction_``), the other unlabelled samples' predicted.
    """
    out = np.asarray(y_all).copy()
    out[est.landmarks_] = est.transduction_
    if est.unlabeled is None:
        return out
    rest = out == est.unlabeled
    rest[est.landmarks_] = False
    if rest.any():
        pred = est.predict(X_all[np.flatnonzero(rest)])
        out[rest] = pred.compute() if is_dask_array(pred) else pred
    return out


def lazy_rows(est, method, X):
    """The method ``method`` of the fitted classifier ``est`` over the row blocks of the
    Dask array ``X``, lazily (:func:`map_rows`); None when ``X`` is not a Dask array.
    """
    if not is_dask_array(X):
        return None
    from sklearn.utils.validation import check_is_fitted

    check_is_fitted(est)
    n_cls = est.classes_.shape[0]
    if method == "predict":
        return map_rows(est, method, X, None, est.classes_.dtype)
    if method == "decision_function":
        return map_rows(est, method, X, None if n_cls <= 2 else n_cls, np.float64)
    return map_rows(est, method, X, n_cls, np.float64)
