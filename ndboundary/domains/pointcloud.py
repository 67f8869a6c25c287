"""A kNN point cloud with intrinsic (tangent-space) operators.

:class:`PointCloud` is a kNN graph over ``n`` points in R^D whose operators live in
the tangent spaces of the data (sign convention of :mod:`ndboundary.domains.base`: ``K`` is
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
* **smoothing** (:meth:`PointCloud.smoothing_operator`) transports neighbouring
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

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .._validation import check_points
from ..fields import normalize_rows
from .base import Domain
from .neighbors import component_bridges, estimate_intrinsic_dim, kneighbors
from .pointcloud_extension import NeighborExtension
from .tangent import ball_volume, frame_transport, local_pca, lsq_coefficients

__all__ = ["PointCloud"]


_CHUNK = 4096
#: Elements of gathered tangent frames held at once by :meth:`PointCloud.tangent_offsets`.
_GATHER = 1 << 22


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
    >>> from ndboundary import PointCloud
    >>> X = np.random.default_rng(0).normal(size=(200, 3))
    >>> pc = PointCloud(X, n_neighbors=10, intrinsic_dim=3)
    >>> pc.G.shape
    (600, 200)
    >>> bool(abs(pc.K @ np.ones(200)).max() < 1e-8)
    True
    """

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
        Z, self.frames = local_pca(self.unique_points, self.neighbors, m)
        self._coef = lsq_coefficients(Z)  # (n_u, m, k)
        # a representative original row of each distinct point
        rep = np.empty(n_u, dtype=np.int64)
        rep[self.unique_inverse[::-1]] = np.arange(self.points.shape[0])[::-1]
        self._rep = rep
        # element j's stencil: j itself, then its neighbours' representatives
        self._stencil = np.concatenate(
            [np.arange(self.points.shape[0])[:, None], rep[self.neighbors[self.unique_inverse]]], axis=1
        )
        mult = np.bincount(self.unique_inverse, minlength=n_u)
        vol = ball_volume(m) * self.distances[:, -1] ** m / k
        self._point_measure = (vol / mult)[self.unique_inverse]
        sym = self._unique_graph()
        self.n_components, comp = connected_components(sym, directed=False)
        if self.n_components > 1:
            self.bridges = rep[component_bridges(self.unique_points, comp, self.n_components, random_state)]
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
        """Number of elements."""
        return int(self.points.shape[0] + self.bridges.shape[0])

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements."""
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

    def build_gradient(self):
        """The gradient operator (see the module docstring)."""
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

    def build_measures(self):
        """The element measures."""
        A = self._point_measure
        if self.bridges.shape[0] == 0:
            return A.copy()
        # a bridge of length L couples its ends like a typical neighbour pair
        h = self.mean_edge_length()
        return np.concatenate([A, np.median(A) * (self._bridge_lengths() / h) ** 2])

    def build_mass(self):
        """Each element's measure shared equally among its vertices."""
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

    def build_incidence(self):
        """The vertex-element incidence."""
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

    def build_adjacency(self):
        """Elements sharing a facet."""
        i, j = self._point_pairs()
        adj = sp.csr_matrix((np.ones(i.size), (i, j)), shape=(self.n_elements, self.n_elements))
        adj = (adj + adj.T).tocsr()
        adj.setdiag(0)
        adj.eliminate_zeros()
        adj.data[:] = 1.0
        return adj

    def build_edges(self):
        """The unique edges, ``i < j``."""
        i, j = self._point_pairs()
        i = np.concatenate([i, self.bridges[:, 0]])
        j = np.concatenate([j, self.bridges[:, 1]])
        N = self.points.shape[0]
        key = np.unique(np.minimum(i, j) * N + np.maximum(i, j))
        return np.stack([key // N, key % N], axis=1)

    def smoothing_operator(self):
        """The linear map of one smoothing pass on the flattened field, shape (n_elements * m,) * 2.

        Element ``j``'s new vector is ``sum_i T_j^T T_i X_i`` over ``i`` in ``j``'s
        stencil (itself and its neighbours): every neighbour's vector is carried into
        ``j``'s tangent frame through the ambient space before averaging. Bridges keep
        their own vector.
        """
        W = frame_transport(self.frames, self.unique_inverse, self._stencil)
        nb = self.bridges.shape[0]
        return sp.block_diag([W, sp.identity(nb * self.intrinsic_dim)], format="csr") if nb else W

    # -- what the relaxation asks ---------------------------------------------------------
    def smooth_field(self, X, passes):
        """Step 3 on tangent fields: ``passes`` sweeps of :meth:`smoothing_operator` (every
        neighbour's vector carried into the point's tangent frame before averaging),
        renormalised after each sweep, in Jacobi order. ``X`` is not modified.
        """
        if passes == 0:
            return X
        W = self.smoothing_operator()
        Xs = X
        for _ in range(passes):
            Xs = normalize_rows((W @ Xs.reshape(-1)).reshape(Xs.shape))
        return Xs

    def lam_reference(self):
        """None: a kNN graph has no regular grid to measure ``lam`` against."""
        return None

    def split_elements(self, mask):
        """No padding: a point's gradient is a least-squares fit over ``k`` neighbours.

        Padding exists for simplices all of whose vertices hold the same heat. Here the
        heat is never prescribed at the sources (it is the solution of ``(M + tK) u = b``
        with ``b`` proportional to the varying masses), a point's gradient draws on
        ``k`` neighbours, and the pipeline lets a point whose gradient vanishes take
        its direction from its neighbours during smoothing.
        """
        return self, np.arange(self.n_elements)

    def simplicial_refinement(self):
        """A point cloud has no simplices: evaluate phi at new points instead."""
        raise TypeError(
            "a PointCloud has no simplices to extract a level set from; build a Delaunay "
            "complex (ndboundary.DelaunayComplex) or evaluate phi at new points "
            "with LevelSetClassifier"
        )

    def propagation_edges(self, max_neighbors):
        """Each sample's ``max_neighbors`` nearest neighbours, its duplicates and the bridges.

        Label propagation wants a sparser graph than the relaxation's stencils (see
        :class:`~ndboundary.LevelSetClassifier`).
        """
        n = self.points.shape[0]
        kk = min(max_neighbors, self.neighbors.shape[1])
        i = np.repeat(np.arange(n), kk)
        j = self._rep[self.neighbors[self.unique_inverse, :kk]].ravel()
        dup = np.flatnonzero(self._rep[self.unique_inverse] != np.arange(n))
        i = np.concatenate([i, dup, self.bridges[:, 0]])
        j = np.concatenate([j, self._rep[self.unique_inverse[dup]], self.bridges[:, 1]])
        return np.stack([i, j], axis=1)

    def vertex_neighborhoods(self):
        """Row ``i``: point ``i`` and its ``k`` nearest neighbours (its gradient stencil)."""
        return self.incidence[:, : self.points.shape[0]].T.tocsr()

    def extension(self, phi, *, n_neighbors=25, power="auto", labels=None, labelled=None):
        """The first-order extension of ``phi`` from the nearest samples: a
        :class:`~ndboundary.domains.pointcloud_extension.NeighborExtension`.
        """
        return NeighborExtension(self, phi, n_neighbors=n_neighbors, power=power, labels=labels, labelled=labelled)

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
        for name in ("G", "K", "A", "mass", "adjacency", "incidence", "edges", "vertex_components", "edge_lengths"):
            state.pop(name, None)
        return state
