"""Domains over data: a kNN point cloud with intrinsic operators, and Delaunay complexes.

:class:`PointCloud` is a kNN graph over ``n`` points in R^D whose operators live in
the tangent spaces of the data (sign convention of :mod:`ndboundary.domain`: ``K`` is
positive semidefinite, ``Delta = -M^{-1} K``):

* **tangent frames** by local PCA over each point's ``k`` nearest neighbours, with an
  intrinsic dimension ``m`` given or estimated (Levina-Bickel maximum likelihood,
  averaged as MacKay and Ghahramani suggest);
* **gradient** per point by least squares over its neighbours in tangent coordinates:
  with ``Z`` the (k, m) tangent coordinates of the offsets ``x_i - x_j`` the gradient
  is ``(Z^T Z)^{-1} Z^T (f_N - f_j)``, exact for functions linear in the tangent space;
  ``G`` is sparse of shape ``(n * m, n)``, so the field has ``m`` components per point
  (:attr:`PointCloud.dim` is ``m``; :attr:`PointCloud.n_features` is ``D``);
* **measures** ``A_j = V_m r_j^m / k`` (``r_j`` the distance to the k-th neighbour,
  ``V_m`` the unit-ball volume: the volume per sample of a kNN density estimate), and
  ``mass = A``;
* ``K = G^T diag(A) G``, consistent with ``div``: symmetric, PSD, ``K @ 1 == 0``;
* **smoothing** (:meth:`PointCloud._smoothing_operator`) transports neighbouring
  vectors between frames, ``X_j <- sum_i T_j^T T_i X_i``, so vectors are compared in
  ambient coordinates although only ``m`` numbers per point are stored.

Only the local PCA touches the ``D`` coordinates (once, ``O(n k^2 D)``); every operator
has ``O(n k m)`` entries and the relaxation's cost does not depend on ``D``.

Elements are the points (element ``j``'s vertices are ``j`` and its neighbours), plus,
when the kNN graph falls apart into several components, one *bridge* element per
component link: a segment joining the two closest points of two components (a minimum
spanning forest over the components, Boruvka's rounds). Bridges make every operator
connected, so the relaxation is well posed on clusters far apart; their measure is set
so that a bridge couples its ends as strongly as a typical neighbour pair does.

Exact duplicates are merged for the geometry (neighbours are searched among distinct
points) and keep their own vertex, joined to their representative by an edge, so that
duplicates with different labels still form a boundary.
"""

from __future__ import annotations

import numbers
from math import gamma, pi

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ._validation import check_points
from .domain import Domain
from .simplicial import SimplicialComplex

__all__ = ["PointCloud", "delaunay_complex", "estimate_intrinsic_dim"]

#: Above this many (distinct) points the neighbours come from pynndescent.
EXACT_MAX_SAMPLES = 20000
_CHUNK = 4096
#: Elements of gathered tangent frames held at once by :meth:`PointCloud.tangent_offsets`.
_GATHER = 1 << 22
_EIG_RTOL = 1e-10
_LSQ_RTOL = 1e-10
#: Delaunay complexes are refused beyond these sizes (Qhull's practical range).
DELAUNAY_MAX_DIM = 6
DELAUNAY_MAX_POINTS = {2: 2_000_000, 3: 500_000, 4: 50_000, 5: 10_000, 6: 3_000}


def _ball_volume(m):
    return pi ** (m / 2) / gamma(m / 2 + 1)


def _seed(random_state):
    if random_state is None or isinstance(random_state, (numbers.Integral, np.random.Generator)):
        return int(np.random.default_rng(random_state).integers(2**31 - 1))
    if isinstance(random_state, np.random.RandomState):
        return int(random_state.randint(2**31 - 1))
    raise TypeError(f"random_state must be None, an int or a numpy Generator, got {type(random_state).__name__}")


def _drop_self(ind, dist, k):
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


def kneighbors(points, n_neighbors, *, method="auto", random_state=None, return_index=False):
    """The ``n_neighbors`` nearest other points of every point (exact or pynndescent).

    Parameters
    ----------
    points : ndarray of shape (n_points, n_features)
        Distinct points.
    n_neighbors : int
        Neighbours per point, ``< n_points``.
    method : {"auto", "exact", "approximate"}, default="auto"
        ``"exact"``: scikit-learn's NearestNeighbors; ``"approximate"``: pynndescent;
        ``"auto"``: exact up to ``EXACT_MAX_SAMPLES`` points.
    random_state : int, Generator or None, default=None
        Seed of pynndescent's random projection trees.
    return_index : bool, default=False
        Also return the fitted index (it answers queries of new points).

    Returns
    -------
    indices : ndarray of int of shape (n_points, n_neighbors)
        Sorted by increasing distance, never the point itself.
    distances : ndarray of shape (n_points, n_neighbors)
    index : _NeighborIndex
        Only with ``return_index=True``.
    """
    n = points.shape[0]
    if method == "auto":
        method = "exact" if n <= EXACT_MAX_SAMPLES else "approximate"
    index = _NeighborIndex(points, n_neighbors + 1, method, random_state)
    ind, dist = index.graph()
    ind, dist = _drop_self(ind, dist, n_neighbors)
    return (ind, dist, index) if return_index else (ind, dist)


class _NeighborIndex:
    """A kNN index over fixed points with one result format for both back ends."""

    def __init__(self, points, n_neighbors, method, random_state):
        self.method = method
        self.n_neighbors = n_neighbors
        if method == "exact":
            from sklearn.neighbors import NearestNeighbors

            self._nn = NearestNeighbors(n_neighbors=n_neighbors).fit(points)
        else:
            from pynndescent import NNDescent

            self._nn = NNDescent(
                points,
                n_neighbors=max(n_neighbors, 10),
                random_state=np.random.RandomState(_seed(random_state)),
                low_memory=True,
            )

    def graph(self):
        if self.method == "exact":
            dist, ind = self._nn.kneighbors(n_neighbors=self.n_neighbors - 1)
            n = ind.shape[0]
            # kneighbors() without X excludes the point itself; put it back first
            ind = np.concatenate([np.arange(n)[:, None], ind[:, : self.n_neighbors - 1]], axis=1)
            dist = np.concatenate([np.zeros((n, 1)), dist[:, : self.n_neighbors - 1]], axis=1)
            return ind, dist
        ind, dist = self._nn.neighbor_graph
        return ind[:, : self.n_neighbors].astype(np.int64), dist[:, : self.n_neighbors].astype(np.float64)

    def query(self, X, k):
        if self.method == "exact":
            dist, ind = self._nn.kneighbors(X, n_neighbors=k)
            return ind, dist
        ind, dist = self._nn.query(X, k=k)
        order = np.argsort(dist, axis=1, kind="stable")
        return np.take_along_axis(ind, order, 1).astype(np.int64), np.take_along_axis(dist, order, 1).astype(np.float64)


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
    """
    d = np.asarray(distances, dtype=np.float64)
    k = d.shape[1]
    if k < 2:
        return 1.0
    logs = np.log(d[:, -1:] / np.maximum(d[:, :-1], 1e-300))
    inv = logs.sum(axis=1) / (k - 1)  # 1 / m_j
    return float(1.0 / max(inv.mean(), 1e-12))


def _local_pca(points, nbr, m):
    """Tangent coordinates of the neighbour offsets (n, k, m) and frames (n, D, m)."""
    n, k = nbr.shape
    D = points.shape[1]
    Z = np.empty((n, k, m))
    T = np.empty((n, D, m))
    for s in range(0, n, _CHUNK):
        c = slice(s, min(n, s + _CHUNK))
        Y = points[nbr[c]] - points[c][:, None, :]  # (b, k, D)
        C = Y @ Y.transpose(0, 2, 1)
        w, V = np.linalg.eigh(C)
        w, V = w[:, ::-1][:, :m], V[:, :, ::-1][:, :, :m]
        ok = w > _EIG_RTOL * np.maximum(w[:, :1], 1e-300)
        sw = np.sqrt(np.where(ok, w, 0.0))
        Z[c] = V * sw[:, None, :]
        T[c] = (Y.transpose(0, 2, 1) @ V) * np.where(ok, 1.0 / np.where(ok, sw, 1.0), 0.0)[:, None, :]
    return Z, T


def _lsq_coefficients(Z):
    """Least-squares gradient weights ``(Z^T Z)^{-1} Z^T`` per point, (n, m, k)."""
    ZtZ = Z.transpose(0, 2, 1) @ Z
    m = Z.shape[2]
    tr = np.trace(ZtZ, axis1=1, axis2=2)
    reg = _LSQ_RTOL * np.maximum(tr, 1e-300) / m
    ZtZ = ZtZ + reg[:, None, None] * np.eye(m)
    return np.linalg.solve(ZtZ, Z.transpose(0, 2, 1))


def _bridges(points, labels, n_comp, random_state):
    """Pairs of points linking the components of a graph (Boruvka over closest pairs)."""
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

        def find(a):
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        for _, a, b in sorted(best.values()):
            ra, rb = find(comp[a]), find(comp[b])
            if ra != rb:
                parent[ra] = rb
                pairs.append((a, b))
        roots = np.array([find(c) for c in range(n_comp)])
        _, comp_new = np.unique(roots[comp], return_inverse=True)
        comp = comp_new.reshape(-1)
        n_comp = int(comp.max()) + 1
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


class PointCloud(Domain):
    """A kNN graph over data points with intrinsic (tangent-space) operators.

    Parameters
    ----------
    X : array-like of shape (n_samples, n_features)
        The points. Copied.
    n_neighbors : int, default=15
        Neighbours per point ``k`` (capped at the number of distinct points minus one).
    intrinsic_dim : int or None, default=None
        Dimension ``m`` of the tangent spaces; estimated from the kNN distances when
        None (rounded, at least 1, at most ``min(n_features, k // 3)`` so that the
        least-squares gradient has three neighbours per unknown).
    method : {"auto", "exact", "approximate"}, default="auto"
        Neighbour search: scikit-learn's exact search, pynndescent, or exact up to
        ``EXACT_MAX_SAMPLES`` distinct points.
    random_state : int, Generator or None, default=None
        Seed of the approximate neighbour search.

    Attributes
    ----------
    points : ndarray of shape (n_samples, n_features)
    unique_points : ndarray of shape (n_unique, n_features)
        The distinct points, on which the geometry is computed.
    unique_inverse : ndarray of int of shape (n_samples,)
        Row of ``unique_points`` of every point.
    neighbors : ndarray of int of shape (n_unique, k)
        Neighbours of every distinct point (rows of ``unique_points``), nearest first.
    distances : ndarray of shape (n_unique, k)
    frames : ndarray of shape (n_unique, n_features, m)
        Orthonormal tangent frames (a column is zero where the local data has lower rank).
    intrinsic_dim : int
        ``m``, the number of field components per point.
    n_components : int
        Connected components of the kNN graph before bridging.
    bridges : ndarray of int of shape (n_bridges, 2)
        The point pairs joining components.

    Raises
    ------
    ValueError
        On fewer than two distinct points, NaN or infinite coordinates, a bad
        ``n_neighbors``, ``intrinsic_dim`` or ``method``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pointcloud import PointCloud
    >>> X = np.random.default_rng(0).normal(size=(200, 3))
    >>> pc = PointCloud(X, n_neighbors=10, intrinsic_dim=3)
    >>> pc.G.shape
    (600, 200)
    >>> bool(abs(pc.K @ np.ones(200)).max() < 1e-8)
    True
    """

    _calibrate_lam = False

    def __init__(self, X, *, n_neighbors=15, intrinsic_dim=None, method="auto", random_state=None):
        self.points = check_points(X, name="X")
        if isinstance(n_neighbors, bool) or not isinstance(n_neighbors, numbers.Integral):
            raise TypeError(f"n_neighbors must be an integer, got {type(n_neighbors).__name__}")
        if n_neighbors < 1:
            raise ValueError(f"n_neighbors must be >= 1, got {n_neighbors}")
        if method not in ("auto", "exact", "approximate"):
            raise ValueError(f"method must be 'auto', 'exact' or 'approximate', got {method!r}")
        if intrinsic_dim is not None:
            if isinstance(intrinsic_dim, bool) or not isinstance(intrinsic_dim, numbers.Integral):
                raise TypeError(f"intrinsic_dim must be an integer or None, got {type(intrinsic_dim).__name__}")
            if not 1 <= intrinsic_dim <= self.points.shape[1]:
                raise ValueError(
                    f"intrinsic_dim must be between 1 and n_features={self.points.shape[1]}, got {intrinsic_dim}"
                )
        self.unique_points, self.unique_inverse = np.unique(self.points, axis=0, return_inverse=True)
        self.unique_inverse = self.unique_inverse.reshape(-1)
        n_u = self.unique_points.shape[0]
        if n_u < 2:
            raise ValueError(
                f"X has {self.points.shape[0]} point(s) but fewer than 2 distinct ones; a point cloud needs at least 2"
            )
        k = int(min(n_neighbors, n_u - 1))
        self.n_neighbors = k
        self.neighbors, self.distances, self._index = kneighbors(
            self.unique_points, k, method=method, random_state=random_state, return_index=True
        )
        D = self.points.shape[1]
        if intrinsic_dim is None:
            m = int(np.clip(round(estimate_intrinsic_dim(self.distances)), 1, max(1, min(D, k // 3))))
        else:
            m = int(min(intrinsic_dim, k))
        self.intrinsic_dim = m
        Z, self.frames = _local_pca(self.unique_points, self.neighbors, m)
        self._coef = _lsq_coefficients(Z)  # (n_u, m, k)
        # a representative original row of each distinct point
        rep = np.empty(n_u, dtype=np.int64)
        rep[self.unique_inverse[::-1]] = np.arange(self.points.shape[0])[::-1]
        self._rep = rep
        # element j's stencil: j itself, then its neighbours' representatives
        self._stencil = np.concatenate(
            [np.arange(self.points.shape[0])[:, None], rep[self.neighbors[self.unique_inverse]]], axis=1
        )
        mult = np.bincount(self.unique_inverse, minlength=n_u)
        vol = _ball_volume(m) * self.distances[:, -1] ** m / k
        self._point_measure = (vol / mult)[self.unique_inverse]
        sym = self._unique_graph()
        self.n_components, comp = connected_components(sym, directed=False)
        if self.n_components > 1:
            self.bridges = rep[_bridges(self.unique_points, comp, self.n_components, random_state)]
        else:
            self.bridges = np.zeros((0, 2), dtype=np.int64)

    def _unique_graph(self):
        n_u, k = self.neighbors.shape
        g = sp.csr_matrix((np.ones(n_u * k), (np.repeat(np.arange(n_u), k), self.neighbors.ravel())), shape=(n_u, n_u))
        return g + g.T

    # -- sizes ------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """Number of field components per element: the intrinsic dimension ``m``."""
        return self.intrinsic_dim

    @property
    def n_features(self) -> int:
        """Dimension ``D`` of the ambient space."""
        return int(self.points.shape[1])

    @property
    def n_elements(self) -> int:
        return int(self.points.shape[0] + self.bridges.shape[0])

    @property
    def element_dim(self) -> int:
        return self.intrinsic_dim

    def mean_edge_length(self) -> float:
        """Mean distance from a point to its neighbours (bridges excluded): the scale ``h``."""
        return float(self.distances.mean())

    def element_centroids(self) -> np.ndarray:
        """The points, then the bridges' midpoints, shape (n_elements, n_features)."""
        mid = 0.5 * (self.points[self.bridges[:, 0]] + self.points[self.bridges[:, 1]])
        return np.concatenate([self.points, mid])

    # -- operators ----------------------------------------------------------------------
    def _bridge_lengths(self):
        b = self.bridges
        return np.linalg.norm(self.points[b[:, 0]] - self.points[b[:, 1]], axis=1)

    def _build_gradient(self):
        N = self.points.shape[0]
        m, s = self.intrinsic_dim, self._stencil
        k1 = s.shape[1]
        coef = self._coef[self.unique_inverse]  # (N, m, k)
        data = np.concatenate([-coef.sum(axis=2, keepdims=True), coef], axis=2)  # (N, m, k+1)
        indices = np.broadcast_to(s[:, None, :], (N, m, k1))
        indptr = np.arange(N * m + 1, dtype=np.int64) * k1
        G = sp.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(N * m, N))
        nb = self.bridges.shape[0]
        if nb == 0:
            return G
        L = self._bridge_lengths()
        rows = np.repeat(np.arange(nb) * m, 2)
        cols = self.bridges.ravel()
        vals = np.stack([-1.0 / L, 1.0 / L], axis=1).ravel()
        Gb = sp.csr_matrix((vals, (rows, cols)), shape=(nb * m, N))
        return sp.vstack([G, Gb]).tocsr()

    def _build_measures(self):
        A = self._point_measure
        if self.bridges.shape[0] == 0:
            return A.copy()
        # a bridge of length L couples its ends like a typical neighbour pair
        h = self.mean_edge_length()
        return np.concatenate([A, np.median(A) * (self._bridge_lengths() / h) ** 2])

    def _build_mass(self):
        return self._point_measure.copy()

    def _element_vertices(self):
        """(element index, vertex index) pairs of the incidence."""
        N, k1 = self._stencil.shape
        e = np.repeat(np.arange(N), k1)
        v = self._stencil.ravel()
        nb = self.bridges.shape[0]
        if nb:
            e = np.concatenate([e, np.repeat(N + np.arange(nb), 2)])
            v = np.concatenate([v, self.bridges.ravel()])
        return e, v

    def _build_incidence(self):
        e, v = self._element_vertices()
        inc = sp.csr_matrix((np.ones(e.size), (v, e)), shape=(self.n_vertices, self.n_elements))
        inc.data[:] = 1.0
        return inc

    def _point_pairs(self):
        N = self.points.shape[0]
        i = np.repeat(np.arange(N), self._stencil.shape[1] - 1)
        j = self._stencil[:, 1:].ravel()
        dup = np.flatnonzero(self._rep[self.unique_inverse] != np.arange(N))
        i = np.concatenate([i, dup])
        j = np.concatenate([j, self._rep[self.unique_inverse[dup]]])
        return i, j

    def _build_adjacency(self):
        i, j = self._point_pairs()
        adj = sp.csr_matrix((np.ones(i.size), (i, j)), shape=(self.n_elements, self.n_elements))
        adj = (adj + adj.T).tocsr()
        adj.setdiag(0)
        adj.eliminate_zeros()
        adj.data[:] = 1.0
        return adj

    def _build_edges(self):
        i, j = self._point_pairs()
        i = np.concatenate([i, self.bridges[:, 0]])
        j = np.concatenate([j, self.bridges[:, 1]])
        N = self.points.shape[0]
        key = np.unique(np.minimum(i, j) * N + np.maximum(i, j))
        return np.stack([key // N, key % N], axis=1)

    def _smoothing_operator(self):
        """The linear map of one smoothing pass on the flattened field, shape (n_elements * m,) * 2.

        Element ``j``'s new vector is ``sum_i T_j^T T_i X_i`` over ``i`` in ``j``'s
        stencil (itself and its neighbours): every neighbour's vector is carried into
        ``j``'s tangent frame through the ambient space before averaging. Bridges keep
        their own vector.
        """
        N = self.points.shape[0]
        m, s = self.intrinsic_dim, self._stencil
        k1 = s.shape[1]
        u = self.unique_inverse
        data = np.empty((N, m, k1, m))
        for a in range(0, N, _CHUNK):
            c = slice(a, min(N, a + _CHUNK))
            Tj = self.frames[u[c]]  # (b, D, m)
            Ti = self.frames[u[s[c]]]  # (b, k1, D, m)
            data[c] = np.einsum("bda,bkdc->bakc", Tj, Ti, optimize=True)
        indices = (s[:, None, :, None] * m + np.arange(m)[None, None, None, :]).repeat(m, axis=1)
        indptr = np.arange(N * m + 1, dtype=np.int64) * (k1 * m)
        W = sp.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(N * m, N * m))
        nb = self.bridges.shape[0]
        if nb:
            W = sp.block_diag([W, sp.identity(nb * m)], format="csr")
        return W

    # -- hooks ------------------------------------------------------------------------------
    def _split_elements(self, mask):
        """No padding: a point's gradient is a least-squares fit over ``k`` neighbours.

        Padding exists for simplices all of whose vertices hold the same heat. Here the
        heat is never prescribed at the sources (it is the solution of ``(M + tK) u = b``
        with ``b`` proportional to the varying masses), a point's gradient draws on
        ``k`` neighbours, and the pipeline lets a point whose gradient vanishes take
        its direction from its neighbours during smoothing.
        """
        return self, np.arange(self.n_elements)

    def _level_set_simplices(self):
        raise NotImplementedError(
            "a PointCloud has no simplices to extract a level set from; build a Delaunay "
            "complex (ndboundary.pointcloud.delaunay_complex) or evaluate phi at new points "
            "with LevelSetClassifier"
        )

    # -- new points -------------------------------------------------------------------------
    def kneighbors(self, X, n_neighbors=None):
        """Nearest distinct points of new points ``X``: (indices into ``unique_points``, distances)."""
        k = self.n_neighbors if n_neighbors is None else int(min(n_neighbors, self.unique_points.shape[0]))
        return self._index.query(np.asarray(X, dtype=np.float64), k)

    def tangent_offsets(self, X, ind):
        """Tangent coordinates ``T_j^T (x - x_j)`` of ``X`` (n, D) seen from ``ind`` (n, q): (n, q, m)."""
        out = np.empty(ind.shape + (self.intrinsic_dim,))
        # rows per chunk: the gathered frames (rows, q, D, m) stay within _GATHER elements
        step = max(1, min(_CHUNK, _GATHER // max(1, ind.shape[1] * self.frames[0].size)))
        for a in range(0, X.shape[0], step):
            c = slice(a, min(X.shape[0], a + step))
            off = X[c][:, None, :] - self.unique_points[ind[c]]  # (b, q, D)
            out[c] = np.einsum("bqd,bqdm->bqm", off, self.frames[ind[c]], optimize=True)
        return out

    def __repr__(self):
        return (
            f"PointCloud(n_samples={self.points.shape[0]}, n_features={self.n_features}, "
            f"n_neighbors={self.n_neighbors}, intrinsic_dim={self.intrinsic_dim}, "
            f"n_components={self.n_components})"
        )

    def __getstate__(self):
        state = self.__dict__.copy()
        for name in ("G", "K", "A", "mass", "adjacency", "incidence", "edges"):
            state.pop(name, None)
        return state


def delaunay_complex(points, *, rtol=1e-10):
    """The Delaunay triangulation of data points as a :class:`SimplicialComplex`.

    Parameters
    ----------
    points : array-like of shape (n_points, dim)
        Distinct points, ``2 <= dim <= 6``.
    rtol : float, default=1e-10
        Simplices whose volume is below ``rtol`` times that of a regular simplex
        of the mean edge length (Qhull's flat slivers) are dropped.

    Returns
    -------
    SimplicialComplex
        Over all of ``points``, in the original order.

    Raises
    ------
    ValueError
        Beyond Qhull's practical range (dimension above 6, or too many points for the
        dimension), on duplicate points, on points Qhull leaves out of every simplex,
        or on fewer than ``dim + 1`` affinely independent points. The message names
        the kNN alternative, :class:`PointCloud`.
    """
    pts = check_points(points, min_dim=2)
    n, dim = pts.shape
    alt = "use the kNN alternative, ndboundary.PointCloud(points, n_neighbors=...)"
    if dim > DELAUNAY_MAX_DIM:
        raise ValueError(
            f"points are {dim}-dimensional; Delaunay complexes are practical up to "
            f"{DELAUNAY_MAX_DIM} dimensions: {alt}"
        )
    if n > DELAUNAY_MAX_POINTS[dim]:
        raise ValueError(
            f"{n} points in {dim} dimensions exceed what Qhull triangulates in reasonable time "
            f"and memory (at most {DELAUNAY_MAX_POINTS[dim]}): {alt}"
        )
    uniq = np.unique(pts, axis=0).shape[0]
    if uniq < n:
        raise ValueError(f"points contain {n - uniq} duplicate row(s); Delaunay needs distinct points: {alt}")
    from scipy.spatial import Delaunay, QhullError

    try:
        tri = Delaunay(pts)
    except QhullError as exc:
        raise ValueError(
            f"Qhull could not triangulate the {n} points (they may lie in a lower-dimensional "
            f"subspace): {str(exc).splitlines()[0]}; {alt}"
        ) from None
    simplices = tri.simplices.astype(np.int64)
    X = pts[simplices]
    E = X[:, 1:, :] - X[:, :1, :]
    det = np.abs(np.linalg.det(E))
    edges = np.linalg.norm(E, axis=2).mean()
    from math import factorial, sqrt

    regular = sqrt(dim + 1) / (factorial(dim) * 2 ** (dim / 2)) * edges**dim * factorial(dim)
    simplices = simplices[det > rtol * regular]
    used = np.zeros(n, dtype=bool)
    used[simplices.ravel()] = True
    if not used.all():
        raise ValueError(
            f"{int((~used).sum())} point(s) (first: row {int(np.flatnonzero(~used)[0])}) lie in no "
            f"non-degenerate Delaunay simplex; {alt}"
        )
    return SimplicialComplex(pts, simplices)
