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
points, numbered along a Z-order curve when there are many) and keep their own vertex,
joined to their representative by an edge, so that duplicates with different labels
still form a boundary.

The operators are built from these arrays by
:class:`~ndboundary.domains.pointcloud_operators.StencilDomain`, which a band of the
cloud (:meth:`PointCloud.subdomain`, the relaxation's ``band=``) shares: the band keeps
the cloud's neighbours, frames and weights, and its operators are the cloud's restricted
to its elements.
"""

from __future__ import annotations

import numbers

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .._compiled import tangent_coordinates
from .._validation import check_points
from .neighbors import component_bridges, drop_self, estimate_intrinsic_dim, kneighbors, leading_axes, locality_order
from .pointcloud_extension import NeighborExtension
from .pointcloud_operators import StencilDomain
from .tangent import ball_volume, local_pca, lsq_coefficients

__all__ = ["PointCloud", "distinct_rows"]

#: Distinct points from which they are numbered along a Z-order curve
#: (:func:`~ndboundary.domains.neighbors.locality_order`) rather than lexicographically.
LOCALITY_MIN_POINTS = 8192


def distinct_rows(X):
    """The distinct rows of ``X`` (n, D) and each row's index among them: ``(unique, inverse)``.

    Up to :data:`LOCALITY_MIN_POINTS` rows, those of ``np.unique(X, axis=0)`` (sorted);
    beyond, in an order of their own, found by sorting one random projection of the rows
    instead of the rows themselves (a twentieth of the time on 100 000 rows of 50
    features), equal projections confirmed equal rows, or the rows sorted after all.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.pointcloud import distinct_rows
    >>> X = np.array([[1.0, 2.0], [0.0, 1.0], [1.0, 2.0], [-0.0, 1.0]])
    >>> unique, inverse = distinct_rows(X)
    >>> unique.tolist(), inverse.tolist()
    ([[0.0, 1.0], [1.0, 2.0]], [1, 0, 1, 0])
    """
    X = np.asarray(X)
    if X.shape[0] > LOCALITY_MIN_POINTS:
        key = X @ np.random.default_rng(0).normal(size=X.shape[1])
        order = np.argsort(key, kind="stable")
        key = key[order]
        tied = np.flatnonzero(key[1:] == key[:-1]) + 1  # a row and the one before it
        if (X[order[tied]] == X[order[tied - 1]]).all():  # ties are duplicates: no collision
            new = np.ones(order.size, dtype=bool)
            new[tied] = False
            inverse = np.empty(order.size, dtype=np.int64)
            inverse[order] = np.cumsum(new) - 1
            return X[order[new]], inverse
    unique, inverse = np.unique(X, axis=0, return_inverse=True)
    return unique, inverse.reshape(-1)


class PointCloud(StencilDomain):
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
    method : {"auto", "exact", "approximate", "hnsw", "nndescent"}, default="auto"
        Neighbour search: scikit-learn's exact search, faiss's HNSW graph, pynndescent,
        the best approximate one installed (HNSW, else NN-descent), or exact up to
        ``EXACT_MAX_SAMPLES`` distinct points (``HNSW_MIN_SAMPLES`` on more than five
        features when faiss is installed) and approximate beyond
        (:mod:`ndboundary.domains.neighbors`).
    random_state : int, Generator or None, default=None
        Seed of pynndescent's search (the HNSW graph is the same in every run).
    search_neighbors : int or None, default=None
        Neighbours to search per distinct point, when more than ``n_neighbors``: the
        graph keeps its ``n_neighbors`` nearest, and :meth:`sample_neighbors` the rest, so
        that an extension over more neighbours than the graph holds reads them from the
        same search instead of searching again.

    Attributes
    ----------
    points : ndarray of shape (n_samples, n_features)
    unique_points : ndarray of shape (n_unique, n_features)
        The distinct points, on which the geometry is computed: sorted as by
        ``np.unique`` up to ``LOCALITY_MIN_POINTS`` of them, beyond in the order of a
        Z-order curve over their leading principal axes, so that near points sit near
        each other in memory for every pass that gathers neighbours.
    unique_inverse : ndarray of int of shape (n_samples,)
        Row of ``unique_points`` of every point.
    n_unique : int
        The number of distinct points.
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

    def __init__(
        self, X, *, n_neighbors=15, intrinsic_dim=None, method="auto", random_state=None, search_neighbors=None
    ):
        self.points = check_points(X, name="X")
        if isinstance(n_neighbors, bool) or not isinstance(n_neighbors, numbers.Integral):
            raise TypeError(f"n_neighbors must be an integer, got {type(n_neighbors).__name__}")
        if n_neighbors < 1:
            raise ValueError(f"n_neighbors must be >= 1, got {n_neighbors}")
        if method not in ("auto", "exact", "approximate", "hnsw", "nndescent"):
            raise ValueError(f"method must be 'auto', 'exact', 'approximate', 'hnsw' or 'nndescent', got {method!r}")
        if intrinsic_dim is not None:
            if isinstance(intrinsic_dim, bool) or not isinstance(intrinsic_dim, numbers.Integral):
                raise TypeError(f"intrinsic_dim must be an integer or None, got {type(intrinsic_dim).__name__}")
            if not 1 <= intrinsic_dim <= self.points.shape[1]:
                raise ValueError(
                    f"intrinsic_dim must be between 1 and n_features={self.points.shape[1]}, got {intrinsic_dim}"
                )
        self.unique_points, self.unique_inverse = distinct_rows(self.points)
        n_u = self.n_unique = self.unique_points.shape[0]
        if n_u > LOCALITY_MIN_POINTS:
            # near points at near indices: every pass that gathers neighbours reads memory
            # in runs (the graph's construction and searches, the operators, the solves)
            order = locality_order(self.unique_points, *self._query_axes())
            rank = np.empty_like(order)
            rank[order] = np.arange(n_u)
            self.unique_points, self.unique_inverse = self.unique_points[order], rank[self.unique_inverse]
        if n_u < 2:
            raise ValueError(
                f"X has {self.points.shape[0]} point(s) but fewer than 2 distinct ones; a point cloud needs at least 2"
            )
        k = int(min(n_neighbors, n_u - 1))
        self.n_neighbors = k
        wide = k
        if search_neighbors is not None:
            if isinstance(search_neighbors, bool) or not isinstance(search_neighbors, numbers.Integral):
                raise TypeError(f"search_neighbors must be an integer or None, got {type(search_neighbors).__name__}")
            wide = int(min(max(search_neighbors, k), n_u - 1))
        ind, dist, self._index = kneighbors(
            self.unique_points, wide, method=method, random_state=random_state, return_index=True
        )
        self._wide = (ind, dist) if wide > k else None
        self.neighbors, self.distances = np.ascontiguousarray(ind[:, :k]), np.ascontiguousarray(dist[:, :k])
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
        self._rows = self.unique_inverse
        dup = np.flatnonzero(rep[self.unique_inverse] != np.arange(self.points.shape[0]))
        self._dup_pairs = np.stack([dup, rep[self.unique_inverse[dup]]], axis=1)
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

    def mean_edge_length(self) -> float:
        """Mean distance from a point to its neighbours (bridges excluded): the scale ``h``."""
        return float(self.distances.mean())

    def _element_coef(self, elements):
        return self._coef[self._rows[elements]]

    def _bridge_measures(self):
        """A bridge of length ``L`` couples its ends like a typical neighbour pair."""
        h = self.mean_edge_length()
        return np.median(self._point_measure) * (self._bridge_lengths() / h) ** 2

    def propagation_edges(self, max_neighbors):
        """Each sample's ``max_neighbors`` nearest neighbours, its duplicates and the bridges.

        Label propagation wants a sparser graph than the relaxation's stencils (see
        :class:`~ndboundary.LevelSetClassifier`).
        """
        n = self.points.shape[0]
        kk = min(max_neighbors, self.neighbors.shape[1])
        i = np.repeat(np.arange(n), kk)
        j = self._rep[self.neighbors[self.unique_inverse, :kk]].ravel()
        i = np.concatenate([i, self._dup_pairs[:, 0], self.bridges[:, 0]])
        j = np.concatenate([j, self._dup_pairs[:, 1], self.bridges[:, 1]])
        return np.stack([i, j], axis=1)

    def vertex_neighborhoods(self):
        """Row ``i``: point ``i`` and its ``k`` nearest neighbours (its gradient stencil)."""
        return self.incidence[:, : self.points.shape[0]].T.tocsr()

    def extension(self, phi, *, n_neighbors=25, power="auto", labels=None, labelled=None):
        """The first-order extension of ``phi`` from the nearest samples: a
        :class:`~ndboundary.domains.pointcloud_extension.NeighborExtension`.
        """
        return NeighborExtension(self, phi, n_neighbors=n_neighbors, power=power, labels=labels, labelled=labelled)

    def sample_neighbors(self, count):
        """The ``count`` nearest other distinct points of every distinct point:
        ``(indices, distances)`` of shape (n_unique, min(count, n_unique - 1)), nearest first.

        The graph's own neighbours when it holds that many, else those of one wider
        search, kept for the next call (the ``search_neighbors`` of the constructor, or
        searched now). Not pickled.
        """
        count = int(min(count, self.n_unique - 1))
        if count <= self.neighbors.shape[1]:
            return self.neighbors[:, :count], self.distances[:, :count]
        wide = self.__dict__.get("_wide")
        if wide is None or wide[0].shape[1] < count:
            ind, dist = self._index.query(self.unique_points, count + 1)
            wide = self._wide = drop_self(ind, dist, count)
        return wide[0][:, :count], wide[1][:, :count]

    # -- new points -------------------------------------------------------------------------
    def kneighbors(self, X, n_neighbors=None):
        """Nearest distinct points of new points ``X``: (indices into ``unique_points``, distances)."""
        k = self.n_neighbors if n_neighbors is None else int(min(n_neighbors, self.n_unique))
        return self._index.query(np.asarray(X, dtype=np.float64), k)

    @property
    def searches_into(self):
        """Whether :meth:`kneighbors_into` is available: the neighbour index can write a
        search into given arrays (:meth:`~ndboundary.domains.neighbors.NeighborIndex.search_into`).
        """
        return self._index.searches_into

    def kneighbors_into(self, X, sq, ind):
        """:meth:`kneighbors` of the float32 points ``X`` written into ``ind`` (int64) and
        ``sq`` (float32, squared distances): ``ind.shape[1]`` neighbours, at most
        ``n_unique``. Only where :attr:`searches_into`.
        """
        if ind.shape[1] > self.n_unique:
            raise ValueError(f"{ind.shape[1]} neighbours asked of {self.n_unique} distinct points")
        self._index.search_into(X, sq, ind)

    @property
    def query_prepares(self):
        """Whether the neighbour index prepares itself on its first search of new points
        (pynndescent compiles its search then): a first block of searches should run
        alone, before others run beside it.
        """
        return self._index.method == "nndescent"

    def query_order(self, X, transform=None):
        """An order of the rows of new points ``X`` (a permutation) in which they are best
        searched: near points one after the other (:func:`~ndboundary.domains.neighbors.locality_order`
        along the cloud's leading principal axes, found at the first call and kept), the
        points being ``transform(X)`` where it is given.
        """
        return locality_order(np.asarray(X, dtype=np.float64), *self._query_axes(), transform=transform)

    def _query_axes(self):
        """The center and leading axes :meth:`query_order` projects on, found once."""
        axes = self.__dict__.get("_axes")
        if axes is None:
            axes = self._axes = leading_axes(self.unique_points)
        return axes

    def tangent_offsets(self, X, ind):
        """Tangent coordinates ``T_j^T (x - x_j)`` of ``X`` (n, D) seen from ``ind`` (n, q): (n, q, m).

        Summed by a compiled pass (:func:`ndboundary._compiled.tangent_coordinates`), which
        reads each neighbour's frame in place instead of gathering them.
        """
        out = np.empty(ind.shape + (self.intrinsic_dim,))
        points = np.ascontiguousarray(self.unique_points, dtype=np.float64)
        X = np.asarray(X, dtype=np.float64)
        tangent_coordinates(X, points, self.frames, np.asarray(ind).astype(np.int64, copy=False), out)
        return out

    def for_queries(self, frames=True):
        """A copy holding only what :meth:`kneighbors` reads (the neighbour index, lean:
        :meth:`~ndboundary.domains.neighbors.NeighborIndex.for_queries`) and, if
        ``frames``, what :meth:`tangent_offsets` reads (the distinct points and their
        frames): much smaller to ship to the workers of a cluster than the whole cloud.
        """
        lean = object.__new__(type(self))
        keep = ("n_unique", "n_neighbors", "intrinsic_dim") + (("unique_points", "frames") if frames else ())
        lean.__dict__.update({name: self.__dict__[name] for name in keep})
        lean._index = self._index.for_queries()
        lean._axes = self._query_axes()
        return lean

    def __repr__(self):
        return (
            f"PointCloud(n_samples={self.points.shape[0]}, n_features={self.n_features}, "
            f"n_neighbors={self.n_neighbors}, intrinsic_dim={self.intrinsic_dim}, "
            f"n_components={self.n_components})"
        )

    def __getstate__(self):
        state = self.__dict__.copy()
        for name in (
            "G", "K", "A", "mass", "adjacency", "incidence", "edges", "vertex_components", "edge_lengths", "_wide"
        ):  # fmt: skip
            state.pop(name, None)
        return state
