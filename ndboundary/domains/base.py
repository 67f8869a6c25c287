"""The domain protocol: what every domain hands to the relaxation.

A domain is a small object over ``n_vertices`` points and ``n_elements`` elements that
builds a handful of sparse operators once and caches them. The relaxation
(:mod:`ndboundary.pipeline`) and the classifier (:mod:`ndboundary.learn`) use nothing
else, and never ask which kind of domain they hold.

Sign convention: ``K`` is the *positive* semidefinite stiffness matrix; the
Laplace-Beltrami operator is ``Delta = -M^{-1} K``. The weak divergence
``div(X) = G^T diag(A) X`` is consistent with ``K``: ``div(G f) == K f`` on simplices.

What a new domain provides
--------------------------
Subclass :class:`Domain` and give it

* ``points``, an array of shape (n_vertices, dim), and the properties ``n_elements``
  and ``element_dim`` (the dimension k of the elements: ``A`` scales as ``h^k``);
* the builders :meth:`~Domain.build_gradient`, :meth:`~Domain.build_measures`,
  :meth:`~Domain.build_mass`, :meth:`~Domain.build_incidence`,
  :meth:`~Domain.build_adjacency` and :meth:`~Domain.build_edges`;
* :meth:`~Domain.element_centroids`;
* for padding (paper section 4), :meth:`~Domain.split_elements`, needed only when some
  element has all its vertices on the jagged boundary;
* for level sets, :meth:`~Domain.simplicial_refinement`.

What it gets for free
---------------------
The cached operators ``G``, ``A``, ``K`` (``G^T diag(A) G`` unless
:meth:`~Domain.build_stiffness` is overridden), ``mass``, ``M``, ``incidence``,
``adjacency`` and ``edges``; :meth:`~Domain.gradient` and :meth:`~Domain.div`;
:meth:`~Domain.mean_edge_length` (the mesh size ``h``); :attr:`~Domain.vertex_components`
and :meth:`~Domain.edge_graph`; the queries that find the band and fill phi outside it
(:class:`~ndboundary.domains.queries.IncidenceQueries`); the field smoothing of the paper's step 3
(:meth:`~Domain.smooth_field`: uniform averaging over each element and its neighbours);
the calibration of the boundary weight against a regular grid
(:meth:`~Domain.lam_reference`); the label propagation graph
(:meth:`~Domain.propagation_edges`); and, with a refinement, level sets
(:meth:`~Domain.level_set_complex`). Any of these may be overridden where a domain
knows better (a kNN graph transports vectors between tangent frames when smoothing,
and has no regular grid to be calibrated against).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .._compiled import within_groups
from ..fields import smooth_rows
from .queries import IncidenceQueries
from .simplex_geometry import kuhn_grid_stiffness

__all__ = ["Domain", "MeshQualityWarning", "can_cut"]


class MeshQualityWarning(UserWarning):
    """The domain's elements are too thin for the relaxation to be trusted.

    The heat, the field smoothing and the time step ``t = h^2`` are isotropic in space,
    measured by the mean edge length ``h``: on elements much longer than wide they blur
    what lies across them, and on nearly flat ones the linear solves lose their accuracy.
    """


class Domain(IncidenceQueries):
    """Base class of the domains: the operators the relaxation needs, built once and cached.

    See the module docstring for what a subclass provides and what it gets.

    Examples
    --------
    >>> from ndboundary import SimplicialComplex
    >>> tri = SimplicialComplex([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> isinstance(tri, Domain), tri.n_vertices, tri.n_elements
    (True, 3, 1)
    """

    points: np.ndarray

    # -- sizes ----------------------------------------------------------------
    @property
    def n_vertices(self) -> int:
        """Number of vertices."""
        return int(self.points.shape[0])

    @property
    def dim(self) -> int:
        """Number of components of a field vector (the dimension the vertices live in)."""
        return int(self.points.shape[1])

    @property
    def n_elements(self) -> int:
        """Number of elements."""
        raise NotImplementedError

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements (2 for triangles and polygons, 3 for solids)."""
        raise NotImplementedError

    # -- operators (built lazily, cached) ---------------------------------------
    @cached_property
    def G(self) -> sp.csr_matrix:
        """Gradient operator, sparse of shape (n_elements * dim, n_vertices).

        Row ``e * dim + d`` holds component ``d`` of element ``e``.
        """
        return self.build_gradient().tocsr()

    @cached_property
    def A(self) -> np.ndarray:
        """Element measures (length, area, volume, ...), shape (n_elements,)."""
        return self.build_measures()

    @cached_property
    def K(self) -> sp.csr_matrix:
        """Stiffness matrix (positive semidefinite, ``K @ 1 == 0``), shape (n_vertices, n_vertices)."""
        return self.build_stiffness().tocsr()

    @cached_property
    def mass(self) -> np.ndarray:
        """Lumped vertex masses, shape (n_vertices,), all positive."""
        return self.build_mass()

    @property
    def M(self) -> sp.dia_matrix:
        """Lumped mass as a sparse diagonal matrix."""
        return sp.diags(self.mass)

    @cached_property
    def adjacency(self) -> sp.csr_matrix:
        """Element adjacency (0/1, symmetric, empty diagonal), shape (n_elements, n_elements)."""
        return self.build_adjacency().tocsr()

    @cached_property
    def incidence(self) -> sp.csr_matrix:
        """Vertex-element incidence (0/1), shape (n_vertices, n_elements)."""
        return self.build_incidence().tocsr()

    @cached_property
    def edges(self) -> np.ndarray:
        """Unique vertex pairs ``(i, j)``, ``i < j``, joined by an element edge, shape (n_edges, 2)."""
        return self.build_edges()

    @cached_property
    def vertex_components(self):
        """Connected components of the vertices along the edges: ``(n_components, labels)``."""
        return connected_components(self.edge_graph(np.ones(self.edges.shape[0])), directed=False)

    def edge_graph(self, weights) -> sp.csr_matrix:
        """The edges as an upper-triangular sparse matrix, ``weights[i]`` at ``edges[i]``,
        shape (n_vertices, n_vertices).
        """
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

    # -- geometry -------------------------------------------------------------
    @cached_property
    def edge_lengths(self) -> np.ndarray:
        """Length of every edge, in the order of :attr:`edges`."""
        e = self.edges
        return np.linalg.norm(self.points[e[:, 0]] - self.points[e[:, 1]], axis=1)

    def mean_edge_length(self) -> float:
        """Mean length of the unique edges: the mesh size ``h`` of the method."""
        return float(self.edge_lengths.mean())

    def element_centroids(self) -> np.ndarray:
        """Element centroids, shape (n_elements, dim)."""
        raise NotImplementedError

    def centroids_of(self, elements) -> np.ndarray:
        """The centroids of the elements ``elements`` (indices), shape (len(elements), dim):
        :meth:`element_centroids` at those rows, which a domain may compute without the
        others' (a region's walk among a large band's elements reads a few of them).
        """
        return self.element_centroids()[np.asarray(elements)]

    # -- what the relaxation asks of a domain -----------------------------------
    def interface_facets(self, region1):
        """The facets between elements of different labels (the jagged boundary) as vertex
        index rows, or None when the domain has no facets to show.

        Parameters
        ----------
        region1 : ndarray of bool of shape (n_elements,)
        """
        return None

    def split_elements(self, mask):
        """Padding (paper section 4): a domain in which the elements selected by ``mask``
        are split at their barycentre, and the parent of every new element.

        The first ``n_vertices`` vertices of the new domain are this domain's.

        Parameters
        ----------
        mask : ndarray of bool of shape (n_elements,)

        Returns
        -------
        domain : Domain
        parent : ndarray of int of shape (domain.n_elements,)
        """
        raise NotImplementedError(
            f"{type(self).__name__} cannot split elements; relax it with pad=False or give it split_elements"
        )

    def subdomain(self, mask):
        """The domain of the elements selected by ``mask`` alone (the relaxation's band).

        Returns
        -------
        domain : Domain
            Over the vertices those elements use, in increasing order.
        vertices : ndarray of int
            Those vertices' indices in this domain.
        """
        raise NotImplementedError(f"{type(self).__name__} cannot be cut to a band; relax it with band=None")

    #: The half-width of ``band="auto"`` with the default parameters, a graph distance
    #: along the edges in units of ``h``: 12 on grid-like cells, whose edges follow the
    #: axes, so that paths along them are longer than straight lines (by 1.5 on average
    #: over directions on a cubic lattice). 10 is the least that keeps the band's level set
    #: within 0.01 h on average of the whole domain's on hexahedra
    #: (``benchmarks/band.py --widths 8,10,12 --cases hex-40``).
    band_reach = 12.0

    #: The half-width (units of ``h``) of the inner band that a band's integration solves
    #: on (:func:`~ndboundary.pipeline.band.inner_band`), or None to integrate the whole
    #: band, as meshes do: a fixed 6 h moved the level set of a Voronoi polyhedral mesh by
    #: 0.39 h and of a polygonal surface by 0.23 h at worst (``benchmarks/band.py --suite``).
    #: Image grids set it (:class:`~ndboundary.domains.image.ImageGrid`).
    integration_reach = None

    #: Gauss-Seidel sweeps before and after the coarse correction of the AMG V-cycle that
    #: preconditions the integration (:func:`~ndboundary.solvers.amg.amg_preconditioner`).
    #: Two on meshes; cubic voxels set one (:class:`~ndboundary.domains.image.ImageGrid`).
    multigrid_sweeps = 2

    @cached_property
    def usual_degree(self) -> float:
        """The number of facet neighbours that 90 % of the elements do not exceed: the degree
        at which :meth:`smooth_field` caps an element's weight.

        A property of the mesh: its bands (:meth:`subdomain`) and paddings
        (:meth:`split_elements`) keep their parent's, so that they smooth as the whole
        mesh does.
        """
        return float(np.percentile(np.diff(self.adjacency.indptr), 90))

    def smooth_field(self, X, passes, groups=None):
        """Step 3 of the paper: ``passes`` sweeps of averaging each element's vector with its
        neighbours', renormalised after each sweep, in Jacobi order so that the result does
        not depend on the element order.

        With ``groups`` (one integer per element), an element does not average a neighbour
        of another group (a negative group: of none), as a region among several smooths
        within the sectors of its neighbours (:mod:`ndboundary.pipeline.sectors`).

        The weights are the paper's uniform ones, except that an element's weight in its
        neighbours' averages is capped at that of an element of the usual degree,
        ``min(1, d / degree)`` with ``d`` the :attr:`usual_degree`: on meshes whose
        elements have the usual number of neighbours (simplicial, quad and hexahedral
        grids) this is uniform averaging, while a cell with many more neighbours than the
        rest (a large polygon inside a ring of small cells) can no longer steer all of them
        with its one vector, which renormalisation would reinforce sweep after sweep.

        On surfaces the averages are not projected onto each element's plane: the integration
        sees the field only through the divergence, and the projection measured worse.

        Parameters
        ----------
        X : ndarray of shape (n_elements, dim)
            Unit vectors (or zero rows); not modified.
        passes : int
        groups : ndarray of int of shape (n_elements,), optional

        Returns
        -------
        ndarray of shape (n_elements, dim)
        """
        if passes == 0:
            return X
        adjacency = self.adjacency
        degree = np.diff(adjacency.indptr)
        cap = np.minimum(1.0, self.usual_degree / np.maximum(degree, 1))
        if groups is not None:
            # the neighbours across groups dropped, not weighted 0: the weights stay ones
            adjacency = within_groups(adjacency, groups)
        if (cap < 1.0).any():
            adjacency = (adjacency @ sp.diags(cap)).tocsr()
        adjacency, passes = self._smoothing(adjacency, passes)
        return smooth_rows(adjacency, X, passes, plus_identity=True)

    def _smoothing(self, adjacency, passes):
        """The weights and number of :meth:`smooth_field`'s sweeps: as given, on domains
        whose elements are alike in every direction.
        """
        return adjacency, passes

    def lam_reference(self):
        """The field term's stiffness ``diag(K M^{-1} K)`` (lengths in units of ``h``) that the
        boundary weight ``lam`` is measured against, or None not to calibrate ``lam``.

        Meshes are measured against an interior vertex of the regular Kuhn grid of their
        element dimension (:func:`kuhn_grid_stiffness`): where a discretisation makes the
        field term weaker at the jagged boundary, ``lam`` is scaled down by the same ratio.
        """
        return kuhn_grid_stiffness(self.element_dim)

    def simplicial_refinement(self):
        """A split of the elements into simplices that carries vertex functions linearly.

        Returns
        -------
        points : ndarray of shape (n_points, dim)
        simplices : ndarray of int of shape (n_simplices, k + 1)
        R : sparse matrix of shape (n_points, n_vertices) or None
            Interpolates vertex values to the points; None for the identity.
        """
        raise TypeError(f"a {type(self).__name__} has no simplices to extract a level set from")

    @cached_property
    def _refinement(self):
        return self.simplicial_refinement()

    def level_set_complex(self, f, value=None):
        """The simplicial complex carrying the vertex function ``f`` piecewise linearly:
        ``(points, simplices, values)``, the refinement built once.

        With ``value`` (a number, ``f`` one value per vertex), only the elements where the
        level set ``f == value`` can lie are refined, on a domain that can be cut to them
        and whose refinement is not built yet: those whose vertices lie on both sides of
        ``value`` (a value equal to it counts as above, as in marching simplices). The
        refinement's added points are means of an element's vertices, so an element with
        every vertex on one side has every simplex there, and the level set's cost follows
        the level set, not the domain.
        """
        if value is not None and "_refinement" not in self.__dict__ and can_cut(self):
            mixed, _ = self.mixed_elements((np.asarray(f) >= value).astype(np.int64))
            if mixed.any() and not mixed.all():
                sub, vertices = self.subdomain(mixed)
                return sub.level_set_complex(np.asarray(f)[vertices])
        points, simplices, R = self._refinement
        f = np.asarray(f, dtype=np.float64)
        return points, simplices, f if R is None else R @ f

    def aspect_ratios(self):
        """Per element, how far it is from a well-shaped one (1 for a regular simplex, growing
        as it flattens), or None when the domain does not measure it.
        """
        return None

    def propagation_edges(self, max_neighbors):
        """The vertex pairs along which labels propagate to unlabelled vertices, shape (n, 2).

        Meshes and complexes use their edges; ``max_neighbors`` bounds the degree of
        graphs whose stencils are wider than label propagation wants.
        """
        return self.edges

    def vertex_neighborhoods(self):
        """Each vertex with its neighbours: sparse 0/1 of shape (n_vertices, n_vertices), row
        ``i`` holding ``i`` and the vertices it shares an edge with (the classifier's voting).
        """
        W = self.edge_graph(np.ones(self.edges.shape[0]))
        return (W + W.T + sp.identity(self.n_vertices)).tocsr()

    def extension(self, phi, **options):
        """An evaluator of the vertex functions ``phi`` at new points (see the classifier)."""
        raise TypeError(f"a {type(self).__name__} cannot evaluate functions at new points")

    # -- to implement -----------------------------------------------------------
    def build_gradient(self):
        """The gradient operator ``G`` (any sparse format)."""
        raise NotImplementedError

    def build_measures(self):
        """The element measures ``A``."""
        raise NotImplementedError

    def build_stiffness(self):
        """The stiffness ``K``; by default ``G^T diag(A) G``."""
        A = sp.diags(np.repeat(self.A, self.dim))
        return self.G.T @ A @ self.G

    def build_mass(self):
        """The lumped vertex masses."""
        raise NotImplementedError

    def build_adjacency(self):
        """The element adjacency (any sparse format)."""
        raise NotImplementedError

    def build_incidence(self):
        """The vertex-element incidence (any sparse format)."""
        raise NotImplementedError

    def build_edges(self):
        """The unique edges, ``i < j``."""
        raise NotImplementedError


def can_cut(domain):
    """Whether ``domain`` can be cut to a band (it provides :meth:`~ndboundary.Domain.subdomain`).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.domains.base import can_cut
    >>> can_cut(kuhn_grid(4, 2))
    True
    """
    return type(domain).subdomain is not Domain.subdomain
