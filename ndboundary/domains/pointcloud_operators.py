"""The operators of a point cloud's elements, written once for the kNN graph and its bands.

The elements of a :class:`~ndboundary.PointCloud` are its points, each with its gradient
stencil (the point's own vertex, then its neighbours'), and one segment per *bridge*
between components of the kNN graph. :class:`StencilDomain` builds every operator from
those arrays alone: the stencils, the least-squares weights and tangent frames they use,
the vertex measures, the bridges and the pairs of exact duplicates.

A band of the cloud (:class:`PointCloudBand`, from :meth:`StencilDomain.subdomain`) is
the cloud of the selected elements' points. Unlike a simplex, whose own gradient ties its
vertices together, a point's value is tied down by the point's own element (the weight
``-sum(coef)`` at its vertex): a neighbour whose element lies outside the band would enter
the band's operators only through the least-squares fits of others, which leave it free,
and the relaxation over the band would be singular there. So each element of the band
keeps the neighbours whose elements are in the band, with the cloud's weights, and the
neighbours it loses count as holding its own value (their weight moves to its vertex, as
a zero-flux condition at the band's edge would have it). Refitting the least squares over
the kept neighbours instead would be exact on linear functions, but on the band's edge in
5 dimensions it leaves fits over a handful of neighbours whose weights make the systems
ill-conditioned: on the data of ``benchmarks/scale.py`` (20 000 samples, 15 neighbours,
a band 2 h wide) the heat took 900 conjugate-gradient iterations instead of 31, and the
integration's did not converge. The cloud's weights keep the band's systems as
well-conditioned as the cloud's. The band shares the cloud's frames, weights and measures
and searches no neighbours: cutting it costs a pass over the mask and work in proportion
to the band.

Its operators are the cloud's restricted to the band wherever an element's stencil lies
in the band (every element but those on the band's edge, :attr:`PointCloudBand.cut`):

* ``G``, ``A``, ``incidence``: the cloud's rows and columns of those elements and points;
* ``mass``: the cloud's vertex measures (a local volume estimate, not a share of the
  elements, so it does not depend on which elements are kept);
* ``K = G^T diag(A) G`` over the band's elements, so the cloud's row at a point all of
  whose elements (its own and those whose stencils hold it) are in the band;
* ``edges``: the pairs each kept element joins (its point with its kept neighbours, a
  bridge's two ends) and the duplicate pairs in the band;
* element adjacency and the field smoothing: the cloud's, between kept elements.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .._arrays import unique_values, used_vertices
from .._compiled_mesh import stencil_stiffness
from ..fields import normalize_rows
from .base import Domain
from .tangent import frame_transport

__all__ = ["PointCloudBand", "StencilDomain"]


class StencilDomain(Domain):
    """A domain whose elements are points with least-squares gradient stencils, and bridges.

    Subclasses set the arrays below; the operators follow from them (see the module
    docstring of :mod:`ndboundary.domains.pointcloud` for the formulas).

    Attributes
    ----------
    points : ndarray of shape (n_vertices, n_features)
    intrinsic_dim : int
        ``m``, the number of field components per element.
    bridges : ndarray of int of shape (n_bridges, 2)
        The vertex pairs of the bridge elements.
    distances : ndarray of shape (n_unique, k)
        Neighbour distances of the rows of ``frames`` (they give the scale ``h``).
    frames : ndarray of shape (n_unique, n_features, m)
        Tangent frames; element ``j`` uses row ``_rows[j]``.
    _stencil : ndarray of int of shape (n_point_elements, k + 1)
        Per point element, its own vertex and then its neighbours' vertices (-1 for a
        neighbour that is not in the domain: its weight is 0).
    _rows : ndarray of int of shape (n_point_elements,)
        Per point element, its row of ``frames`` and ``distances``.
    _point_measure : ndarray of shape (n_vertices,)
        Vertex measures: the mass, and a point element's measure.
    _dup_pairs : ndarray of int of shape (n_duplicates, 2)
        Vertex pairs (duplicate, its representative): edges of no element.
    """

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
        """Number of elements: the point elements, then the bridges."""
        return int(self._stencil.shape[0] + self.bridges.shape[0])

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements."""
        return self.intrinsic_dim

    def mean_edge_length(self) -> float:
        """Mean distance from a point to its neighbours (bridges excluded): the scale ``h``."""
        return float(self.distances[unique_values(self._rows)].mean())

    def element_centroids(self) -> np.ndarray:
        """The points of the point elements, then the bridges' midpoints, shape (n_elements, n_features)."""
        mid = 0.5 * (self.points[self.bridges[:, 0]] + self.points[self.bridges[:, 1]])
        return np.concatenate([self.points[self._stencil[:, 0]], mid])

    # -- operators ----------------------------------------------------------------------
    def _bridge_lengths(self):
        b = self.bridges
        return np.linalg.norm(self.points[b[:, 0]] - self.points[b[:, 1]], axis=1)

    def _bridge_measures(self):
        """The measures of the bridge elements."""
        raise NotImplementedError

    def _element_coef(self, elements):
        """The least-squares gradient weights of the point ``elements`` over their neighbours, (n, m, k)."""
        raise NotImplementedError

    def _element_of_vertex(self):
        """Per vertex, the index of its point element, or -1 where it has none in this domain."""
        out = np.full(self.n_vertices, -1, dtype=np.int64)
        out[self._stencil[:, 0]] = np.arange(self._stencil.shape[0])
        return out

    def _stencil_rows(self):
        """Every element's vertices and gradient rows over them: ``(stencils, coef)`` of
        shapes (n_elements, k + 1) and (n_elements, m, k + 1); -1 (weight 0) where a
        stencil has no vertex. A bridge's stencil is its two ends, its one row ``(-1, 1) / L``.
        """
        N, k1 = self._stencil.shape
        m, nb = self.intrinsic_dim, self.bridges.shape[0]
        coef = self._element_coef(slice(None))  # (N, m, k)
        data = np.concatenate([-coef.sum(axis=2, keepdims=True), coef], axis=2)  # (N, m, k+1)
        if nb == 0:
            return self._stencil, data
        stencils = np.full((N + nb, max(k1, 2)), -1, dtype=np.int64)
        stencils[:N, :k1] = self._stencil
        stencils[N:, :2] = self.bridges
        rows = np.zeros((N + nb, m, stencils.shape[1]))
        rows[:N, :, :k1] = data
        L = self._bridge_lengths()
        rows[N:, 0, 0], rows[N:, 0, 1] = -1.0 / L, 1.0 / L
        return stencils, rows

    def build_gradient(self):
        """The gradient operator (see the module docstring of :mod:`ndboundary.domains.pointcloud`)."""
        stencils, data = self._stencil_rows()
        E, k1 = stencils.shape
        V, m, N = self.n_vertices, self.intrinsic_dim, self._stencil.shape[0]
        indices = np.broadcast_to(stencils[:, None, :], (E, m, k1))
        present = stencils >= 0
        if present.all() and E == N:
            indptr = np.arange(E * m + 1, dtype=np.int64) * k1
            return sp.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(E * m, V))
        keep = np.broadcast_to(present[:, None, :], (E, m, k1)).copy()
        keep[N:, 1:] = False  # a bridge's one row
        indptr = np.zeros(E * m + 1, dtype=np.int64)
        np.cumsum(keep.reshape(E * m, k1).sum(axis=1), out=indptr[1:])
        return sp.csr_matrix((data[keep], indices[keep], indptr), shape=(E * m, V))

    def build_stiffness(self):
        """``K = G^T diag(A) G``, stencil by stencil (:func:`~ndboundary._compiled_mesh.stencil_stiffness`)."""
        stencils, coef = self._stencil_rows()
        return stencil_stiffness(stencils, coef, self.A, self.n_vertices)

    def build_measures(self):
        """The element measures: the point elements' vertex measures, then the bridges'."""
        A = self._point_measure[self._stencil[:, 0]]
        if self.bridges.shape[0] == 0:
            return A
        return np.concatenate([A, self._bridge_measures()])

    def build_mass(self):
        """The vertex measures."""
        return self._point_measure.copy()

    def build_incidence(self):
        """The vertex-element incidence."""
        N, k1 = self._stencil.shape
        e = np.concatenate([np.repeat(np.arange(N), k1), np.repeat(N + np.arange(self.bridges.shape[0]), 2)])
        v = np.concatenate([self._stencil.ravel(), self.bridges.ravel()])
        if v.min() < 0:
            e, v = e[v >= 0], v[v >= 0]
        inc = sp.csr_matrix((np.ones(e.size), (v, e)), shape=(self.n_vertices, self.n_elements))
        inc.data[:] = 1.0
        return inc

    def _point_pairs(self):
        """Vertex pairs ``(i, j)``: each point element's own vertex with its stencil, then the duplicates."""
        k = self._stencil.shape[1] - 1
        i = np.concatenate([np.repeat(self._stencil[:, 0], k), self._dup_pairs[:, 0]])
        j = np.concatenate([self._stencil[:, 1:].ravel(), self._dup_pairs[:, 1]])
        if j.size and j.min() < 0:
            i, j = i[j >= 0], j[j >= 0]
        return i, j

    def build_adjacency(self):
        """Elements sharing a facet: point elements joined by a stencil or as duplicates."""
        i, j = self._point_pairs()
        elem = self._element_of_vertex()
        i, j = elem[i], elem[j]
        both = (i >= 0) & (j >= 0)
        if not both.all():
            i, j = i[both], j[both]
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
        V = self.n_vertices
        key = unique_values(np.minimum(i, j) * V + np.maximum(i, j))
        return np.stack([key // V, key % V], axis=1)

    def smoothing_operator(self):
        """The linear map of one smoothing pass on the flattened field, shape (n_elements * m,) * 2.

        Element ``j``'s new vector is ``sum_i T_j^T T_i X_i`` over the elements ``i`` of
        ``j``'s stencil (itself and its neighbours): every neighbour's vector is carried
        into ``j``'s tangent frame through the ambient space before averaging. Bridges
        keep their own vector.
        """
        s = self._stencil
        W = frame_transport(self.frames, self._rows, np.where(s >= 0, self._element_of_vertex()[s], -1))
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
            f"a {type(self).__name__} has no simplices to extract a level set from; build a Delaunay "
            "complex (ndboundary.DelaunayComplex) or evaluate phi at new points "
            "with LevelSetClassifier"
        )

    def subdomain(self, mask):
        """The band of the elements selected by ``mask``: a :class:`PointCloudBand` over the
        vertices those elements use (their points, and the ends of the selected bridges),
        and those vertices' indices (see :meth:`~ndboundary.Domain.subdomain` and the
        module docstring).

        Parameters
        ----------
        mask : array-like of bool of shape (n_elements,)
            The point elements, then the bridges; at least one selected.

        Returns
        -------
        domain : PointCloudBand
        vertices : ndarray of int
            Increasing.

        Raises
        ------
        TypeError
            If ``mask`` is not boolean.
        ValueError
            If ``mask`` does not have one entry per element or selects none.

        Examples
        --------
        >>> import numpy as np
        >>> from ndboundary import PointCloud
        >>> cloud = PointCloud(np.random.default_rng(0).normal(size=(200, 2)), n_neighbors=8)
        >>> band, vertices = cloud.subdomain(cloud.points[:, 0] < 0)
        >>> bool(band.n_elements == vertices.size < cloud.n_vertices)  # the selected points
        True
        >>> bool(0 < band.cut.size < band.n_elements)  # the edge's stencils lost neighbours
        True
        """
        band = PointCloudBand(self, mask)
        return band, band.vertices


def _check_mask(mask, n_elements):
    """``mask`` as a boolean array of ``n_elements`` entries selecting at least one."""
    arr = np.asarray(mask)
    if arr.dtype != np.bool_:
        raise TypeError(f"mask must be an array of booleans, one per element, got dtype {arr.dtype}")
    if arr.shape != (n_elements,):
        raise ValueError(f"mask has shape {arr.shape} but the domain has {n_elements} elements")
    if not arr.any():
        raise ValueError("mask selects no element; a band needs at least one")
    return arr


class PointCloudBand(StencilDomain):
    """The cloud of the elements of a point cloud (or of a band of one) selected by a mask.

    Its vertices, in increasing order, are the points of the selected point elements and
    the ends of the selected bridges. Each element keeps the neighbours whose elements are
    selected, with the cloud's weights; those it loses count as holding its own value
    (module docstring). Everything else is the cloud's: tangent frames, least-squares
    weights, measures. Made by :meth:`StencilDomain.subdomain`.

    Parameters
    ----------
    domain : StencilDomain
        A :class:`~ndboundary.PointCloud` or a band of one.
    mask : array-like of bool of shape (domain.n_elements,)

    Attributes
    ----------
    vertices : ndarray of int
        The band's vertices' indices in ``domain``.
    elements : ndarray of int
        The band's elements' indices in ``domain``.
    cut : ndarray of int
        The band's point elements whose stencils lost neighbours (the band's edge).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PointCloud
    >>> cloud = PointCloud(np.random.default_rng(0).normal(size=(200, 2)), n_neighbors=8)
    >>> band, vertices = cloud.subdomain(np.ones(cloud.n_elements, dtype=bool))
    >>> bool(abs(band.K - cloud.K).max() == 0), vertices.size  # the whole cloud: the same operators
    (True, 200)
    """

    def __init__(self, domain, mask):
        mask = _check_mask(mask, domain.n_elements)
        n_points = domain._stencil.shape[0]
        pe, be = np.flatnonzero(mask[:n_points]), np.flatnonzero(mask[n_points:])
        stencil, bridges = domain._stencil[pe], domain.bridges[be]
        kept = np.zeros(domain.n_vertices, dtype=bool)
        kept[stencil[:, 0]] = True
        self.vertices, remap = used_vertices(np.concatenate([stencil[:, 0], bridges.ravel()]), domain.n_vertices)
        self.elements = np.concatenate([pe, n_points + be])
        self.points = domain.points[self.vertices]
        self.intrinsic_dim = domain.intrinsic_dim
        self.frames, self.distances = domain.frames, domain.distances
        self._rows = domain._rows[pe]
        present = stencil >= 0
        inside = present & kept[np.where(present, stencil, 0)]
        self._stencil = np.where(inside, remap[stencil], -1)
        self._coef = domain._element_coef(pe)
        self._coef *= inside[:, None, 1:]  # an absent neighbour has no weight
        self.cut = np.flatnonzero(~inside[:, 1:].all(axis=1))
        self.bridges = remap[bridges]
        self._bridge_measure = domain.A[n_points + be]
        self._point_measure = domain._point_measure[self.vertices]
        dup = remap[domain._dup_pairs]
        self._dup_pairs = dup[(dup >= 0).all(axis=1)]

    def _element_coef(self, elements):
        return self._coef[elements]

    def _bridge_measures(self):
        return self._bridge_measure

    def __repr__(self):
        return (
            f"PointCloudBand(n_vertices={self.n_vertices}, n_elements={self.n_elements}, "
            f"n_features={self.n_features}, intrinsic_dim={self.intrinsic_dim})"
        )
