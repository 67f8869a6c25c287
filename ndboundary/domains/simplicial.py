"""Simplicial complexes of any dimension: segments, triangles, tetrahedra, n-simplices.

Operators (sign convention of :mod:`ndboundary.domains.base`: ``K`` is positive
semidefinite, ``Delta = -M^{-1} K``):

* gradient of the linear interpolant, per simplex: with ``E = [x1-x0, ..., xk-x0]``
  (dim x k) the barycentric gradients are the columns of ``E (E^T E)^{-1}``, exact for
  linear functions and intrinsic to the simplex (valid for surfaces in 3-D);
* ``A`` = simplex volume ``sqrt(det(E^T E)) / k!``;
* ``K = G^T diag(A) G`` -- the cotangent Laplacian on triangles, the cotangent
  Laplacian of tetrahedral meshes on tetrahedra;
* ``mass`` = each simplex's volume shared equally among its k+1 vertices.

Incidences (edges, facets, adjacency) are built by the linear-time sorts of
:mod:`ndboundary._arrays`; the geometry by :mod:`.simplex_geometry`.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .._arrays import (
    counting_sort,
    fill_unused_mass,
    group_rows,
    index_dtype,
    kept_then,
    mixed_facets,
    pair_groups,
    shared_facet_adjacency,
    sort_rows,
    used_vertices,
)
from .._validation import check_cells, check_points, refuse_degenerate
from .base import Domain
from .simplex_geometry import (
    aspect_ratios,
    simplex_edges,
    simplex_geometry,
    simplex_incidence,
    stiffness_terms,
    symmetric_csr,
)
from .simplicial_split import SplitOperators

__all__ = ["SimplicialComplex"]


class SimplicialComplex(Domain):
    """A pure simplicial complex of k-simplices with vertices in R^dim, 1 <= k <= dim.

    Parameters
    ----------
    points : array-like of shape (n_vertices, dim)
        Vertex coordinates. Copied.
    simplices : array-like of int of shape (n_elements, k + 1)
        Vertex indices of each simplex. Copied.

    Attributes
    ----------
    sorted_simplices : ndarray of int of shape (n_elements, k + 1)
        Every simplex's vertices in increasing order: the column order of ``G``'s rows.
    barycentric_gradients : ndarray of shape (n_elements, dim, k + 1)
        Gradient of each barycentric coordinate, in the order of ``sorted_simplices``.
    volumes : ndarray of shape (n_elements,)
        Simplex volumes (``A`` is a copy).

    Raises
    ------
    ValueError
        On NaN or infinite coordinates, out-of-range indices, a simplex with a
        repeated vertex or with zero volume, or more simplex vertices than
        ``dim + 1``.
    TypeError
        On non-numeric points or non-integer indices.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import SimplicialComplex
    >>> tri = SimplicialComplex([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    >>> float(tri.A[0])
    0.5
    >>> tri.gradient([0.0, 1.0, 0.0]).tolist()
    [[1.0, 0.0]]
    """

    #: On the complexes made by :meth:`split_elements`, the :class:`SplitOperators` that
    #: derive their operators from the parent's; None otherwise.
    split_from = None

    def __init__(self, points, simplices):
        self.points = check_points(points)
        self.simplices = check_cells(simplices, self.points.shape[0], name="simplices")
        k1 = self.simplices.shape[1]
        if k1 < 2:
            raise ValueError(f"simplices has shape {self.simplices.shape}; a simplex needs at least 2 vertices")
        if k1 > self.dim + 1:
            raise ValueError(
                f"simplices has shape {self.simplices.shape} but points are {self.dim}-dimensional; "
                f"expected at most {self.dim + 1} vertices per simplex"
            )
        self.sorted_simplices = np.sort(self.simplices, axis=1)
        self.barycentric_gradients, self.volumes = self._geometry()

    # -- sizes -------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        """Number of elements."""
        return int(self.simplices.shape[0])

    @property
    def simplex_dim(self) -> int:
        """The dimension k of the simplices (2 for triangles, 3 for tetrahedra)."""
        return int(self.simplices.shape[1] - 1)

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements."""
        return self.simplex_dim

    # -- geometry ------------------------------------------------------------------
    def _geometry(self):
        """Barycentric gradients and volumes (see :func:`simplex_geometry`) over the
        vertices of every simplex in increasing order (``sorted_simplices``, the column
        order of the operators), refusing degenerate simplices.
        """
        grads, vol = simplex_geometry(self.points, self.sorted_simplices)
        k = self.simplex_dim
        refuse_degenerate(
            ~np.isfinite(vol),
            "simplex",
            lambda e: f"vertices {self.simplices[e].tolist()}",
            "length" if k == 1 else "area" if k == 2 else "volume",
            "simplices",
        )
        return grads, vol

    def aspect_ratios(self):
        """``L^k / (k! V)`` per simplex, ``L`` its longest edge and ``V`` its volume, divided
        by the regular simplex's value: 1 for a regular simplex, about ``L / w`` for a
        triangle of width ``w``.

        Examples
        --------
        >>> from ndboundary import SimplicialComplex
        >>> flat = SimplicialComplex([[0, 0], [1, 0], [0, 0.01]], [[0, 1, 2]])
        >>> round(float(flat.aspect_ratios()[0]), 1)
        86.6
        """
        return aspect_ratios(self.points, self.simplices, self.volumes)

    def element_centroids(self) -> np.ndarray:
        """Element centroids, shape (n_elements, dim)."""
        return self.points[self.simplices].mean(axis=1)

    # -- operators ------------------------------------------------------------------
    def build_gradient(self):
        """The gradient operator (see the module docstring)."""
        # one row per element and component, its k+1 entries in increasing column order;
        # the data are the barycentric gradients themselves, not a copy
        E, k1 = self.simplices.shape
        D = self.dim
        idx = index_dtype(max(E * D * k1, self.n_vertices))
        indices = np.broadcast_to(self.sorted_simplices.astype(idx)[:, None, :], (E, D, k1))
        return sp.csr_matrix(
            (self.barycentric_gradients.reshape(-1), indices.reshape(-1), np.arange(E * D + 1, dtype=idx) * k1),
            shape=(E * D, self.n_vertices),
        )

    def build_measures(self):
        """The element measures."""
        return self.volumes.copy()

    @cached_property
    def vertex_used(self):
        """Whether each vertex lies in some simplex."""
        return np.bincount(self.simplices.ravel(), minlength=self.n_vertices) > 0

    @cached_property
    def stiffness_sums(self):
        """``(off, diag, used)``: the entries of ``K = G^T diag(A) G`` at the edges (in the
        order of :attr:`edges`), its diagonal, and :attr:`vertex_used` (the rows with a
        diagonal entry). Each entry is one sum over the simplices holding the edge or vertex.
        """
        if self.split_from is not None:
            return self.split_from.stiffness_sums(self)
        off, diag = stiffness_terms(self.barycentric_gradients, self.volumes)
        edges, pair_edge = self.edge_index
        off = np.bincount(pair_edge, weights=off.ravel(), minlength=edges.shape[0])
        diag = np.bincount(self.sorted_simplices.ravel(), weights=diag.ravel(), minlength=self.n_vertices)
        return off, diag, self.vertex_used

    def build_stiffness(self):
        """The stiffness (see the module docstring)."""
        off, diag, used = self.stiffness_sums
        K = symmetric_csr(self.edges, off, diag, used)
        K.eliminate_zeros()  # an edge whose angles cancel exactly (right angles on both sides)
        return K

    def build_mass(self):
        """Each element's measure shared equally among its vertices."""
        if self.split_from is not None:
            m = self.split_from.mass(self)
            if m is not None:
                return m
        k1 = self.simplices.shape[1]
        m = np.bincount(self.simplices.ravel(), weights=np.repeat(self.volumes / k1, k1), minlength=self.n_vertices)
        return fill_unused_mass(m, self.volumes / k1)

    def build_incidence(self):
        """The vertex-element incidence."""
        return simplex_incidence(self.simplices, self.sorted_simplices, self.n_vertices)

    def element_max(self, f):
        """Per element, the largest value of the vertex function ``f`` over its vertices."""
        f = np.asarray(f)
        out = f[self.simplices[:, 0]]
        for i in range(1, self.simplices.shape[1]):
            np.maximum(out, f[self.simplices[:, i]], out=out)
        return out

    @cached_property
    def edge_index(self):
        """The unique edges, sorted (as :attr:`edges`), and the edge of every vertex pair
        ``(srt[e, i], srt[e, j])``, ``i < j`` in ``triu_indices`` order, element-major
        (``srt = sorted_simplices``).
        """
        if self.split_from is not None:
            return self.split_from.edge_index()
        return simplex_edges(self.sorted_simplices, self.n_vertices)

    @cached_property
    def _facets(self):
        """Sorted facets of every simplex, element-major, (E*(k+1), k): facet i leaves
        out vertex i.
        """
        E, k1 = self.simplices.shape
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self.sorted_simplices[:, leave_out].reshape(E * k1, k1 - 1)

    @cached_property
    def _facet_ids(self):
        """Group id of every row of :attr:`_facets` (equal facets, equal ids), the ids in
        the lexicographic order of the facets.
        """
        if self.simplices.shape[1] == 3:
            # the facets of triangles are their edges, in the reverse order of the pairs
            # of edge_index
            return self.edge_index[1].reshape(-1, 3)[:, ::-1].ravel()
        return self._facet_groups[0]

    @cached_property
    def _facet_groups(self):
        """``(ids, order, starts)``: :attr:`_facet_ids`, and the rows of :attr:`_facets`
        grouped by facet, ``order[starts[f]:starts[f + 1]]`` holding those of facet ``f``.

        A facet of more than two vertices is known by the edge of its first two vertices
        and its other vertices: for tetrahedra, a pair sorted in linear time. The edges
        are numbered in lexicographic order, so the ids are those of the facets.
        """
        E, k1 = self.simplices.shape
        if k1 == 3:
            ids = self._facet_ids
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        if k1 == 2:
            ids = group_rows(self._facets)[0]
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        edges, pair_edge = self.edge_index
        iu, ju = np.triu_indices(k1, 1)
        pair_of = np.zeros((k1, k1), dtype=np.intp)
        pair_of[iu, ju] = np.arange(iu.size)
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        lead = np.take(pair_edge.reshape(E, iu.size), pair_of[leave_out[:, 0], leave_out[:, 1]], axis=1).ravel()
        rest = np.take(self.sorted_simplices, leave_out[:, 2:], axis=1).reshape(E * k1, k1 - 3)
        if k1 == 4:
            n = max(edges.shape[0], self.n_vertices)
            idx = index_dtype(max(n, lead.size))
            order, new = pair_groups(lead.astype(idx), rest[:, 0].astype(idx), n)
        else:
            order, new = sort_rows(np.column_stack([lead, rest]))
        ids = np.empty(lead.size, dtype=order.dtype)
        ids[order] = np.cumsum(new, dtype=order.dtype) - 1
        starts = np.append(np.flatnonzero(new), lead.size).astype(order.dtype)
        return ids, order, starts

    def build_adjacency(self):
        """Elements sharing a facet."""
        E, k1 = self.simplices.shape
        ids, order, starts = self._facet_groups
        size = np.diff(starts)
        if size.max() > 2:
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)
        # every facet in at most two simplices: each simplex's neighbours, one per
        # facet (-1 on the boundary), sorted
        first = starts[:-1][size == 2]
        a, b = order[first], order[first + 1]
        across = np.full(E * k1, -1, dtype=order.dtype)
        across[a] = b // k1
        across[b] = a // k1
        across = np.sort(across.reshape(E, k1), axis=1)
        if (across[:, 1:] == across[:, :-1])[across[:, 1:] >= 0].any():
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)  # repeated simplices
        inner = across >= 0
        indptr = np.zeros(E + 1, dtype=order.dtype)
        np.cumsum(inner.sum(axis=1), out=indptr[1:])
        return sp.csr_matrix((np.ones(int(indptr[-1])), across[inner], indptr), shape=(E, E))

    def build_edges(self):
        """The unique edges, ``i < j``."""
        if self.split_from is not None:
            return self.split_from.edge_map[0]
        return self.edge_index[0]

    def interface_facets(self, region1):
        """Facets shared by a region-0 and a region-1 simplex: the jagged boundary, (n, k)."""
        k1 = self.simplices.shape[1]
        owner = np.repeat(np.arange(self.n_elements), k1)
        which = mixed_facets(self._facet_ids, owner, region1)
        if "_facets" in self.__dict__:
            return self._facets[which]
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self.sorted_simplices[which // k1][np.arange(which.size)[:, None], leave_out[which % k1]]

    @property
    def usual_degree(self) -> float:
        """``k + 1``: a simplex away from the border has a neighbour across each facet."""
        return float(self.simplices.shape[1])

    def split_elements(self, mask):
        """Split the simplices selected by ``mask`` at their barycentre (see :meth:`Domain.split_elements`)."""
        mask = np.asarray(mask, dtype=bool)
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return self, np.arange(self.n_elements)
        k1 = self.simplices.shape[1]
        V = self.n_vertices
        centres = self.points[self.simplices[idx]].mean(axis=1)
        new_ids = V + np.arange(idx.size)
        parts = []
        for i in range(k1):
            s = self.simplices[idx].copy()
            s[:, i] = new_ids
            parts.append(s)
        new = np.concatenate(parts)
        parent = np.concatenate([np.flatnonzero(~mask)] + [idx] * k1)
        # children of valid simplices are valid: skip validation, and compute the geometry
        # of the new simplices only
        keep = ~mask
        out = SimplicialComplex.__new__(SimplicialComplex)
        out.points = np.concatenate([self.points, centres])
        new_sorted = np.sort(new, axis=1)
        grads, vols = simplex_geometry(out.points, new_sorted)
        out.simplices = kept_then(self.simplices, keep, new)
        out.sorted_simplices = kept_then(self.sorted_simplices, keep, new_sorted)
        out.barycentric_gradients = kept_then(self.barycentric_gradients, keep, grads)
        out.volumes = kept_then(self.volumes, keep, vols)
        out.split_from = SplitOperators(self, idx, keep)
        return out, parent

    def subdomain(self, mask):
        """The complex of the simplices selected by ``mask``, its geometry taken from this one
        (see :meth:`Domain.subdomain`).
        """
        el = np.flatnonzero(mask)
        vertices, remap = used_vertices(self.simplices[el], self.n_vertices)
        out = SimplicialComplex.__new__(SimplicialComplex)
        out.points = self.points[vertices]
        out.simplices = remap[self.simplices[el]]
        out.sorted_simplices = remap[self.sorted_simplices[el]]  # the renumbering keeps the order
        out.barycentric_gradients = self.barycentric_gradients[el]
        out.volumes = self.volumes[el]
        return out, vertices

    def simplicial_refinement(self):
        """The complex itself: ``(points, simplices, None)``."""
        return self.points, self.simplices, None

    def __repr__(self):
        return (
            f"SimplicialComplex(n_vertices={self.n_vertices}, n_elements={self.n_elements}, "
            f"simplex_dim={self.simplex_dim}, dim={self.dim})"
        )
