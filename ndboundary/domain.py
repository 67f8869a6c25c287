"""The interface every domain hands to the pipeline.

A domain is a small object over ``n_vertices`` points and ``n_elements``
elements that builds a handful of sparse operators once and caches them:

``mass`` (M)
    lumped vertex mass, a positive array of shape (n_vertices,).
``G``
    gradient, sparse of shape (n_elements * dim, n_vertices): vertex scalars to
    one ``dim``-vector per element, row ``e * dim + d`` holding component ``d``
    of element ``e``.
``A``
    element measures, shape (n_elements,).
``K``
    stiffness, symmetric positive semidefinite with ``K @ 1 == 0``.

Sign convention: ``K`` is the *positive* semidefinite stiffness matrix; the
Laplace-Beltrami operator is ``Delta = -M^{-1} K``.  The weak divergence
``div(X) = G^T diag(A) X`` is consistent with ``K``: ``div(G f) == K f``.

The pipeline in :mod:`ndboundary.pipeline` never asks which kind of domain it
holds; adding a domain type means subclassing :class:`Domain` and providing the
``_build_*`` methods.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

__all__ = ["Domain"]


class Domain:
    """Base class of the domains: the operators the relaxation needs, cached."""

    points: np.ndarray
    #: Whether :func:`~ndboundary.relax` measures ``lam`` against the stiffness of the
    #: field term at zeta relative to a regular simplicial grid (meshes; not kNN graphs,
    #: whose operators have no such reference).
    _calibrate_lam = True

    # -- sizes ----------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.points.shape[0])

    @property
    def dim(self) -> int:
        """Dimension of the space the vertices live in (length of the field vectors)."""
        return int(self.points.shape[1])

    @property
    def n_elements(self) -> int:
        """Number of elements."""
        raise NotImplementedError

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements (2 for triangles and polygons, 3 for solids): ``A`` scales as h^k."""
        raise NotImplementedError

    # -- operators (built lazily, cached) ---------------------------------------
    @cached_property
    def G(self) -> sp.csr_matrix:
        """Gradient operator, sparse of shape (n_elements * dim, n_vertices)."""
        return self._build_gradient().tocsr()

    @cached_property
    def A(self) -> np.ndarray:
        """Element measures (length, area, volume, ...), shape (n_elements,)."""
        return self._build_measures()

    @cached_property
    def K(self) -> sp.csr_matrix:
        """Stiffness matrix (positive semidefinite, ``K @ 1 == 0``), shape (n_vertices, n_vertices)."""
        return self._build_stiffness().tocsr()

    @cached_property
    def mass(self) -> np.ndarray:
        """Lumped vertex masses, shape (n_vertices,), all positive."""
        return self._build_mass()

    @property
    def M(self) -> sp.dia_matrix:
        """Lumped mass as a sparse diagonal matrix."""
        return sp.diags(self.mass)

    @cached_property
    def adjacency(self) -> sp.csr_matrix:
        """Element adjacency (0/1, symmetric, empty diagonal), shape (n_elements, n_elements)."""
        return self._build_adjacency().tocsr()

    @cached_property
    def incidence(self) -> sp.csr_matrix:
        """Vertex-element incidence (0/1), shape (n_vertices, n_elements)."""
        return self._build_incidence().tocsr()

    @cached_property
    def edges(self) -> np.ndarray:
        """Unique vertex pairs ``(i, j)`` with ``i < j`` joined by an element edge, shape (n_edges, 2)."""
        return self._build_edges()

    @cached_property
    def _vertex_components(self):
        """Connected components of the vertices along the edges: ``(n_components, labels)``."""
        from scipy.sparse.csgraph import connected_components

        return connected_components(self._edge_graph(np.ones(self.edges.shape[0])), directed=False)

    def _edge_graph(self, weights) -> sp.csr_matrix:
        """The edges as a sparse matrix, ``weights[i]`` at ``edges[i]`` (one triangle),
        shape (n_vertices, n_vertices)."""
        e = self.edges
        V = self.n_vertices
        key = e[:, 0] * V + e[:, 1]
        if not np.all(key[1:] > key[:-1]):
            return sp.csr_matrix((weights, (e[:, 0], e[:, 1])), shape=(V, V))
        # edges in lexicographic order are the rows of the matrix in order
        idx = np.int32 if max(V, e.shape[0]) < np.iinfo(np.int32).max else np.int64
        indptr = np.zeros(V + 1, dtype=idx)
        np.cumsum(np.bincount(e[:, 0], minlength=V), out=indptr[1:])
        return sp.csr_matrix((weights, e[:, 1].astype(idx), indptr), shape=(V, V))

    def div(self, X) -> np.ndarray:
        """Weak divergence ``G^T diag(A) X`` of a per-element field ``X`` of shape (n_elements, dim)."""
        X = np.asarray(X, dtype=np.float64).reshape(self.n_elements, self.dim)
        return self.G.T @ (X * self.A[:, None]).reshape(-1)

    def gradient(self, f) -> np.ndarray:
        """Per-element gradient of the vertex function ``f``, shape (n_elements, dim)."""
        f = np.asarray(f, dtype=np.float64).reshape(self.n_vertices)
        return (self.G @ f).reshape(self.n_elements, self.dim)

    def _element_max(self, f) -> np.ndarray:
        """Per element, the largest value of the vertex function ``f`` over its vertices."""
        by_element = self.incidence.T.tocsr()  # every row is non-empty
        return np.maximum.reduceat(np.asarray(f)[by_element.indices], by_element.indptr[:-1])

    def _smoothing_operator(self):
        """The averaging operator of the field smoothing: uniform weights over each element
        and its neighbours, ``I + adjacency`` (acting on the (n_elements, dim) field)."""
        return (self.adjacency + sp.identity(self.n_elements, format="csr")).tocsr()

    # -- geometry -------------------------------------------------------------
    def mean_edge_length(self) -> float:
        """Mean length of the unique edges: the mesh size ``h`` of the method."""
        e = self.edges
        return float(np.linalg.norm(self.points[e[:, 0]] - self.points[e[:, 1]], axis=1).mean())

    def element_centroids(self) -> np.ndarray:
        """Element centroids, shape (n_elements, dim)."""
        raise NotImplementedError

    # -- hooks for the pipeline -------------------------------------------------
    def _split_elements(self, mask):
        """Return a domain in which the elements selected by ``mask`` are split at their
        barycentre, and the index of the parent element of every new element.

        The first ``n_vertices`` vertices of the new domain are this domain's.
        """
        raise NotImplementedError

    def _interface_facets(self, region1) -> np.ndarray:
        """Vertex indices of the facets between elements of different labels (the jagged boundary)."""
        raise NotImplementedError

    def _level_set_simplices(self) -> np.ndarray:
        """Simplices over this domain's vertices on which vertex values are interpolated linearly."""
        raise NotImplementedError

    def _refinement(self):
        """A split of the elements into simplices: ``(points, simplices, R)``, where ``R``
        (sparse, (n_points, n_vertices), or None for the identity) interpolates vertex
        values to the points. Domains whose elements are not simplices add centre vertices."""
        return self.points, self._level_set_simplices(), None

    @cached_property
    def _simplicial_split(self):
        return self._refinement()

    def _level_set_complex(self, f):
        """A simplicial complex carrying the vertex function ``f`` piecewise linearly:
        ``(points, simplices, values)``."""
        points, simplices, R = self._simplicial_split
        f = np.asarray(f, dtype=np.float64)
        return points, simplices, f if R is None else R @ f

    # -- to implement -----------------------------------------------------------
    def _build_gradient(self):
        raise NotImplementedError

    def _build_measures(self):
        raise NotImplementedError

    def _build_stiffness(self):
        A = sp.diags(np.repeat(self.A, self.dim))
        return self.G.T @ A @ self.G

    def _build_mass(self):
        raise NotImplementedError

    def _build_adjacency(self):
        raise NotImplementedError

    def _build_incidence(self):
        raise NotImplementedError

    def _build_edges(self):
        raise NotImplementedError
