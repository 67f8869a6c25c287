"""Nearest neighbours of data points: exact or approximate search, intrinsic dimension, bridges.

One result format for every back end: scikit-learn's exact search (up to
:data:`EXACT_MAX_SAMPLES` points), and beyond it an approximate one: faiss's HNSW graph
when faiss is installed (the ``fast`` extra), else pynndescent's NN-descent. With faiss,
points of more than :data:`TREE_MAX_FEATURES` features, which the exact search compares
pair by pair, go to the HNSW graph from :data:`HNSW_MIN_SAMPLES` points on.

faiss ships compiled code, so it searches from the first call of a process; pynndescent
compiles its kernels with numba, and its graph construction recompiles in every
process (about a minute on two cores at 100 000 samples, more than the rest of a
classifier's fit; the README's classifier section gives the figures). The HNSW
graph is built on one thread, so that it is the same in every run, and searched on all.
"""

from __future__ import annotations

import numbers

import numpy as np

__all__ = [
    "EXACT_MAX_SAMPLES",
    "HNSW_MIN_SAMPLES",
    "NeighborIndex",
    "component_bridges",
    "estimate_intrinsic_dim",
    "exact_max_samples",
    "kneighbors",
    "leading_axes",
    "locality_order",
]

#: Above this many (distinct) points the neighbours come from an approximate search.
EXACT_MAX_SAMPLES = 20000
#: The exact search builds a k-d tree on at most this many features and compares every
#: pair beyond: at 10 features a tree took 0.12 s for 3 000 points and 1.5 s for 10 000
#: (41 neighbours each), brute force 0.04 s and 0.25 s; at 5 features they were even,
#: and on 2 features at 20 000 points the tree took 0.16 s against 0.80 s.
TREE_MAX_FEATURES = 5
#: With faiss installed, points of more than :data:`TREE_MAX_FEATURES` features are
#: searched by its HNSW graph beyond this many: the exact search compares every pair,
#: and on ``make_classification(n, 20, n_informative=8)`` (27 neighbours each) it took
#: 3.9 s at 20 000 points, 2.5 s at 14 000 and 0.6-1.1 s at 10 000, against 1.4, 0.86
#: and 0.56-0.66 s for building and searching the HNSW graph (which found 98.6 % of
#: the exact neighbours at 10 000 points, 93 % on 64 features).
HNSW_MIN_SAMPLES = 8000
#: faiss's HNSW graph: links per point, and the candidate lists of its construction and
#: of the graph's search (at least the neighbours asked for). On 30 000 samples of
#: intrinsic dimension about 11 (``make_classification(n, 20, n_informative=8)``) these
#: find 98.5 % of the 15 exact neighbours, against 98.1 % for pynndescent.
HNSW_LINKS, HNSW_EF_CONSTRUCTION, HNSW_EF_SEARCH = 16, 40, 32
#: The candidate list of a search of new points, at least the neighbours asked for: on
#: the 100 000 samples of ``benchmarks/scale.py`` a list of 26 for 26 neighbours finds
#: 99.68 % of the exact ones (32: 99.89 %) in a fifth less time, and changes 4 of
#: 100 000 predictions.
HNSW_EF_QUERY = 0


def has_faiss():
    """Whether faiss can be imported."""
    try:
        import faiss  # noqa: F401
    except ImportError:
        return False
    return True


def seed_of(random_state):
    if random_state is None or isinstance(random_state, (numbers.Integral, np.random.Generator)):
        return int(np.random.default_rng(random_state).integers(2**31 - 1))
    if isinstance(random_state, np.random.RandomState):
        return int(random_state.randint(2**31 - 1))
    raise TypeError(f"random_state must be None, an int or a numpy Generator, got {type(random_state).__name__}")


def drop_self(ind, dist, k):
    """Remove each row's own index (or, if absent, its last neighbour); keep k columns."""
    n = ind.shape[0]
    is_self = ind == np.arange(n)[:, None]
    no_self = ~is_self.any(axis=1)
    is_self[no_self, -1] = True
    keep = ~is_self
    first = np.argmax(is_self, axis=1)
    keep[np.arange(n), first] = False
    keep &= np.cumsum(keep, axis=1) <= k
    return ind[keep].reshape(n, k), dist[keep].reshape(n, k)


def exact_max_samples(n_features):
    """The most points ``method="auto"`` searches exactly, for points of ``n_features``."""
    if n_features > TREE_MAX_FEATURES and has_faiss():
        return HNSW_MIN_SAMPLES
    return EXACT_MAX_SAMPLES


def kneighbors(points, n_neighbors, *, method="auto", random_state=None, return_index=False):
    """The ``n_neighbors`` nearest other points of every point (exact or pynndescent).

    Parameters
    ----------
    points : ndarray of shape (n_points, n_features)
        Distinct points.
    n_neighbors : int
        Neighbours per point, ``< n_points``.
    method : {"auto", "exact", "approximate", "hnsw", "nndescent"}, default="auto"
        ``"exact"``: scikit-learn's NearestNeighbors; ``"hnsw"``: faiss's HNSW graph;
        ``"nndescent"``: pynndescent; ``"approximate"``: HNSW if faiss is installed, else
        NN-descent; ``"auto"``: exact up to ``EXACT_MAX_SAMPLES`` points (with faiss
        installed, ``HNSW_MIN_SAMPLES`` on more than ``TREE_MAX_FEATURES`` features),
        approximate beyond.
    random_state : int, Generator or None, default=None
        Seed of pynndescent's random projection trees (the HNSW graph does not depend on
        it, and is the same in every run).
    return_index : bool, default=False
        Also return the fitted index (it answers queries of new points).

    Returns
    -------
    indices : ndarray of int of shape (n_points, n_neighbors)
        Sorted by increasing distance, never the point itself.
    distances : ndarray of shape (n_points, n_neighbors)
    index : NeighborIndex
        Only with ``return_index=True``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import kneighbors
    >>> X = np.random.default_rng(0).uniform(size=(100, 2))
    >>> ind, dist = kneighbors(X, 5)
    >>> ind.shape, bool(np.all(ind != np.arange(100)[:, None])), bool(np.all(np.diff(dist, axis=1) >= 0))
    ((100, 5), True, True)
    """
    n = points.shape[0]
    if method == "auto":
        method = "exact" if n <= exact_max_samples(points.shape[1]) else "approximate"
    if method == "approximate":
        method = "hnsw" if has_faiss() else "nndescent"
    index = NeighborIndex(points, n_neighbors + 1, method, random_state)
    ind, dist = index.graph()
    ind, dist = drop_self(ind, dist, n_neighbors)
    return (ind, dist, index) if return_index else (ind, dist)


class NeighborIndex:
    """A kNN index over fixed points with one result format for every back end
    (``method``: ``"exact"``, ``"hnsw"`` or ``"nndescent"``).

    ``graph()`` gives every point's neighbours, itself first; ``query(X, k)`` those of new points.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import NeighborIndex
    >>> X = np.random.default_rng(0).uniform(size=(100, 2))
    >>> index = NeighborIndex(X, 3, "exact", None)
    >>> ind, dist = index.graph()
    >>> ind.shape, ind[:3, 0].tolist(), float(dist[:, 0].max())  # each point first, at distance 0
    ((100, 3), [0, 1, 2], 0.0)
    >>> index.query(X[[7]] + 1e-9, 1)[0].tolist()
    [[7]]
    """

    def __init__(self, points, n_neighbors, method, random_state):
        self.method = method
        self.n_neighbors = n_neighbors
        self.n_points = points.shape[0]
        if method == "exact":
            from sklearn.neighbors import NearestNeighbors

            algorithm = "kd_tree" if points.shape[1] <= TREE_MAX_FEATURES else "brute"
            self._nn = NearestNeighbors(n_neighbors=n_neighbors, algorithm=algorithm).fit(points)
        elif method == "hnsw":
            self._points32 = np.ascontiguousarray(points, dtype=np.float32)
            self._nn = _hnsw_index(self._points32)
        else:
            from pynndescent import NNDescent

            self._nn = NNDescent(
                points,
                n_neighbors=max(n_neighbors, 10),
                random_state=np.random.RandomState(seed_of(random_state)),
                low_memory=True,
            )

    def graph(self):
        """Every point's neighbours, itself first: ``(indices, distances)``."""
        if self.method == "exact":
            dist, ind = self._nn.kneighbors(n_neighbors=self.n_neighbors - 1)
            n = ind.shape[0]
            # kneighbors() without X excludes the point itself; put it back first
            ind = np.concatenate([np.arange(n)[:, None], ind[:, : self.n_neighbors - 1]], axis=1)
            dist = np.concatenate([np.zeros((n, 1)), dist[:, : self.n_neighbors - 1]], axis=1)
            return ind, dist
        if self.method == "hnsw":
            return self._hnsw_search(self._points32, self.n_neighbors, HNSW_EF_SEARCH)
        ind, dist = self._nn.neighbor_graph
        return ind[:, : self.n_neighbors].astype(np.int64), dist[:, : self.n_neighbors].astype(np.float64)

    def _hnsw_search(self, X, k, ef):
        self._nn.hnsw.efSearch = max(ef, k)
        sq, ind = self._nn.search(np.ascontiguousarray(X, dtype=np.float32), k)
        return ind.astype(np.int64), np.sqrt(np.maximum(sq, 0.0), dtype=np.float64)

    def for_queries(self):
        """A copy that answers :meth:`query` only: without the float32 copy of the points
        that :meth:`graph` searches (the HNSW graph holds its own).
        """
        lean = object.__new__(type(self))
        lean.__dict__.update(self.__dict__)
        lean.__dict__.pop("_points32", None)
        return lean

    def __getstate__(self):
        state = self.__dict__.copy()
        if self.method == "hnsw":  # faiss indexes pickle as their serialised bytes
            import faiss

            state["_nn"] = faiss.serialize_index(self._nn)
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        if self.method == "hnsw":
            import faiss

            self._nn = faiss.deserialize_index(state["_nn"])

    @property
    def searches_into(self):
        """Whether :meth:`search_into` is available (the HNSW index)."""
        return self.method == "hnsw"

    def search_into(self, X, sq, ind):
        """The ``ind.shape[1]`` nearest indexed points of the float32 points ``X``, written
        into ``ind`` (int64), nearest first, with their squared distances into ``sq``
        (float32): the search of :meth:`query` without allocating its results, for
        searches repeated over blocks of rows that reuse one pair of arrays. HNSW only
        (:attr:`searches_into`).
        """
        if not self.searches_into:
            raise ValueError(f"search_into needs the HNSW index, not {self.method!r}")
        k = ind.shape[1]
        self._nn.hnsw.efSearch = max(HNSW_EF_QUERY, k)
        self._nn.search(X, k, D=sq, I=ind)

    def query(self, X, k):
        """The ``k`` nearest indexed points of new points ``X``: ``(indices, distances)``, nearest first."""
        if self.method == "exact":
            dist, ind = self._nn.kneighbors(X, n_neighbors=k)
            return ind, dist
        if self.method == "hnsw":
            return self._hnsw_search(X, k, HNSW_EF_QUERY)
        ind, dist = self._nn.query(X, k=k)
        order = np.argsort(dist, axis=1, kind="stable")
        return np.take_along_axis(ind, order, 1).astype(np.int64), np.take_along_axis(dist, order, 1).astype(np.float64)


#: The Z-order of :func:`locality_order`: axes of the points it reads, and bits per axis.
ORDER_AXES, ORDER_BITS = 8, 5
#: Points :func:`leading_axes` reads at most (evenly spaced rows).
AXES_SAMPLE = 2048
#: Rows :func:`locality_order` transforms at a time.
TRANSFORM_SLAB = 8192


def leading_axes(points, count=ORDER_AXES):
    """The mean of ``points`` and their ``count`` leading principal axes, (count, n_features)
    (fewer on fewer features), from at most :data:`AXES_SAMPLE` evenly spaced rows.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import leading_axes
    >>> X = np.random.default_rng(0).normal(size=(500, 3)) * [10.0, 1.0, 0.1]
    >>> center, axes = leading_axes(X, 2)
    >>> axes.shape, np.abs(axes).argmax(axis=1).tolist()
    ((2, 3), [0, 1])
    """
    from sklearn.utils.extmath import randomized_svd

    sample = points[:: max(1, -(-points.shape[0] // AXES_SAMPLE))]
    center = sample.mean(axis=0)
    count = min(count, points.shape[1], sample.shape[0])
    _, _, axes = randomized_svd(sample - center, count, n_iter=2, random_state=0)
    return center, axes


def locality_order(X, center, axes, bits=ORDER_BITS, transform=None):
    """A permutation of the rows of ``X`` along a Z-order (Morton) curve of their
    coordinates on ``axes`` (:func:`leading_axes`), cut into cells of one width (the
    widest range of the rows in ``2**bits``): rows close in space come close in the order.
    With ``transform`` (a map of an array of rows to the rows the axes are of, called as
    ``transform(A, out=B)``), the rows are projected through it :data:`TRANSFORM_SLAB` at a
    time, so that no transformed copy of ``X`` is held.

    Searching an index in this order reads the same parts of it one query after the
    next: on 100 000 new points of 50 features, searching faiss's HNSW graph took half
    the time it took in a random order (``benchmarks/scale.py``). Each query's answer
    is the same in any order.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import leading_axes, locality_order
    >>> X = np.random.default_rng(0).uniform(size=(1000, 2))
    >>> order = locality_order(X, *leading_axes(X))
    >>> step = np.linalg.norm(np.diff(X[order], axis=0), axis=1).mean()
    >>> sorted(order.tolist()) == list(range(1000)), bool(step < 0.1)  # random order: about 0.52
    (True, True)
    """
    # without arrays the size of X, nor of a column per step: a Dask worker's allocator
    # hands each freed array back to the system and faults the next one in
    n, m = X.shape[0], axes.shape[0]
    slab_rows = min(TRANSFORM_SLAB, n)
    if transform is None:
        P = X @ axes.T
    else:
        P = np.empty((n, m))
        slab = np.empty((slab_rows, X.shape[1]))
        for s in range(0, n, TRANSFORM_SLAB):
            rows = slab[: min(TRANSFORM_SLAB, n - s)]
            np.matmul(transform(X[s : s + TRANSFORM_SLAB], out=rows), axes.T, out=P[s : s + TRANSFORM_SLAB])
    P -= center @ axes.T
    lo = P.min(axis=0)
    # cells of one width on every axis, the widest axis cut in 2**bits: an axis along which
    # the points barely spread takes few cells, and does not scatter the order
    cells = 1 << bits
    width = float((P.max(axis=0) - lo).max()) / cells
    P -= lo
    P /= max(width, np.finfo(np.float64).tiny)
    key = np.zeros(n, dtype=np.int64)
    q_all = np.empty((m, slab_rows), dtype=np.int64)  # a slab's cells, one row per axis
    bit_all = np.empty(slab_rows, dtype=np.int64)
    for s in range(0, n, TRANSFORM_SLAB):
        k = key[s : s + TRANSFORM_SLAB]
        q, bit = q_all[:, : k.shape[0]], bit_all[: k.shape[0]]
        np.copyto(q, P[s : s + TRANSFORM_SLAB].T, casting="unsafe")  # truncated, as astype
        np.clip(q, 0, cells - 1, out=q)
        for b in range(bits - 1, -1, -1):  # interleave the axes' bits, most significant first
            for axis in q:
                np.left_shift(k, 1, out=k)
                np.right_shift(axis, b, out=bit)
                np.bitwise_and(bit, 1, out=bit)
                np.bitwise_or(k, bit, out=k)
    del P
    return np.argsort(key, kind="stable")


def _hnsw_index(points32):
    """The HNSW graph of faiss over ``points32`` (float32, C order), built on one thread."""
    import faiss

    index = faiss.IndexHNSWFlat(points32.shape[1], HNSW_LINKS)
    index.hnsw.efConstruction = HNSW_EF_CONSTRUCTION
    threads = faiss.omp_get_max_threads()
    faiss.omp_set_num_threads(1)  # concurrent insertions would make the graph vary between runs
    try:
        index.add(points32)
    finally:
        faiss.omp_set_num_threads(threads)
    return index


def estimate_intrinsic_dim(distances):
    """Maximum-likelihood intrinsic dimension from kNN distances (Levina and Bickel 2004).

    Parameters
    ----------
    distances : ndarray of shape (n_points, k)
        Sorted distances to the ``k >= 2`` nearest other points, all positive.

    Returns
    -------
    float
        The harmonic mean of the per-point estimates (MacKay and Ghahramani's correction).

    Examples
    --------
    Points on a plane in 3-D have intrinsic dimension about 2:

    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import estimate_intrinsic_dim, kneighbors
    >>> X = np.random.default_rng(0).normal(size=(500, 3)) * [1.0, 1.0, 0.0]
    >>> _, dist = kneighbors(X, 10)
    >>> round(estimate_intrinsic_dim(dist), 1)
    2.1
    """
    d = np.asarray(distances, dtype=np.float64)
    k = d.shape[1]
    if k < 2:
        return 1.0
    logs = np.log(d[:, -1:] / np.maximum(d[:, :-1], 1e-300))
    inv = logs.sum(axis=1) / (k - 1)  # 1 / m_j
    return float(1.0 / max(inv.mean(), 1e-12))


def _find(parent, a):
    """The root of ``a`` in the union-find forest ``parent``, halving the path on the way."""
    while parent[a] != a:
        parent[a] = parent[parent[a]]
        a = parent[a]
    return a


def component_bridges(points, labels, n_comp, random_state):
    """Pairs of points linking the components of a graph (Boruvka over closest pairs).

    Examples
    --------
    Three clusters on a line, joined by their closest pairs:

    >>> import numpy as np
    >>> from ndboundary.domains.neighbors import component_bridges
    >>> points = np.array([[0.0, 0.0], [0.1, 0.0], [1.0, 0.0], [1.1, 0.0], [3.0, 0.0]])
    >>> component_bridges(points, np.array([0, 0, 1, 1, 2]), 3, None).tolist()
    [[1, 2], [4, 3]]
    """
    from sklearn.neighbors import NearestNeighbors

    comp = labels.copy()
    pairs = []
    while n_comp > 1:
        best = {}
        for c in range(n_comp):
            inside = np.flatnonzero(comp == c)
            outside = np.flatnonzero(comp != c)
            nn = NearestNeighbors(n_neighbors=1).fit(points[outside])
            dist, ind = nn.kneighbors(points[inside])
            j = int(np.argmin(dist[:, 0]))
            best[c] = (float(dist[j, 0]), int(inside[j]), int(outside[ind[j, 0]]))
        parent = list(range(n_comp))
        for _, a, b in sorted(best.values()):
            ra, rb = _find(parent, comp[a]), _find(parent, comp[b])
            if ra != rb:
                parent[ra] = rb
                pairs.append((a, b))
        roots = np.array([_find(parent, c) for c in range(n_comp)])
        _, comp_new = np.unique(roots[comp], return_inverse=True)
        comp = comp_new.reshape(-1)
        n_comp = int(comp.max()) + 1
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)
