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
    DEGENERATE_RTOL,
    fill_unused_mass,
    index_dtype,
    kept_then,
    used_vertices,
)
from .._compiled_mesh import corner_means
from .._validation import check_cells, check_points, refuse_degenerate
from .base import Domain
from .simplex_geometry import (
    COMPILED_MIN_VERTICES_PER_SIMPLEX,
    aspect_ratios,
    compiled_passes,
    simplex_geometry,
    simplex_incidence,
    stiffness_terms,
    symmetric_csr,
)
from .simplicial_split import SplitOperators
from .simplicial_topology import SimplicialTopology

__all__ = ["SimplicialComplex"]


class SimplicialComplex(SimplicialTopology, Domain):
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

    @property
    def band_reach(self) -> float:
        """The half-width of ``band="auto"`` with the default parameters (see
        :attr:`ndboundary.Domain.band_reach`): simplicial edges include the cells'
        diagonals, so paths along them are nearly straight. 6 h on tetrahedra and up and
        8 h on triangles keep the band's level set within 0.01 h on average and 0.05 h at
        worst of the whole domain's on every relaxation of ``benchmarks/band.py --suite``;
        6 h on triangles missed on a curved surface (0.077 h on ``spot_triangulated.obj``).
        """
        return 8.0 if self.element_dim <= 2 else 6.0

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
        self.volumes = self._geometry()

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
    def _compiled_geometry(self):
        """Whether the geometry comes from the compiled pass, where the volumes are
        computed first and the gradients when asked for: tetrahedra, and triangles where
        the other passes are compiled too (:func:`compiled_passes`, large meshes).
        """
        k1 = self.simplices.shape[1]
        return k1 == 4 or (k1 == 3 and compiled_passes(self.simplices))

    def _geometry(self):
        """The volumes, refusing degenerate simplices; also the barycentric gradients (see
        :func:`simplex_geometry`), over the vertices of every simplex in increasing order
        (``sorted_simplices``, the column order of the operators), except where the
        compiled pass computes them (:meth:`_compiled_geometry`): there they wait until an
        operator needs them, and a band needs them on its elements only.
        """
        if self._compiled_geometry():
            from .._compiled_geometry import small_simplex_volumes

            vol = small_simplex_volumes(self.points, self.sorted_simplices, DEGENERATE_RTOL)
        else:
            self.barycentric_gradients, vol = simplex_geometry(self.points, self.sorted_simplices)
        k = self.simplex_dim
        refuse_degenerate(
            ~np.isfinite(vol),
            "simplex",
            lambda e: f"vertices {self.simplices[e].tolist()}",
            "length" if k == 1 else "area" if k == 2 else "volume",
            "simplices",
        )
        return vol

    @cached_property
    def barycentric_gradients(self) -> np.ndarray:
        """Gradient of each barycentric coordinate, shape (n_elements, dim, k + 1), in the
        order of ``sorted_simplices``.
        """
        return self._geometry_of(self.points, self.sorted_simplices)[0]

    def _geometry_of(self, points, sorted_simplices):
        """``(grads, volumes)`` of simplices like these, by the same pass as this complex's
        own, so that a split's or a band's geometry is that of a fresh complex.
        """
        if self._compiled_geometry():
            from .._compiled_geometry import small_simplex_geometry_compiled

            return small_simplex_geometry_compiled(points, sorted_simplices, DEGENERATE_RTOL)
        return simplex_geometry(points, sorted_simplices)

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
        """Element centroids, shape (n_elements, dim): the vertices summed a column at a
        time (the sum and the values of a mean over the (n_elements, k + 1, dim) table of
        corners, which this does not build).
        """
        points, simplices = self.points, self.simplices
        out = points[simplices[:, 0]]
        for column in simplices.T[1:]:
            out += points[column]
        out /= simplices.shape[1]
        return out

    def centroids_of(self, elements) -> np.ndarray:
        """:meth:`element_centroids` of the simplices ``elements`` alone (the same sums)."""
        return corner_means(self.points, self.simplices, np.asarray(elements))

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
        if self.split_from is None and self.simplices.shape[1] >= COMPILED_MIN_VERTICES_PER_SIMPLEX:
            # summed row by row over the incidence, without the edge of every vertex pair
            # of every simplex; the same sums as below (the terms of the same compiled
            # stiffness_terms), in the same order
            from .._compiled_mesh import stiffness_matrix

            K = stiffness_matrix(self.vertex_simplices, self.sorted_simplices, self.barycentric_gradients, self.volumes)
            K.eliminate_zeros()
            return K
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
        share = self.volumes / self.simplices.shape[1]
        if compiled_passes(self.simplices):
            from .._compiled import row_sums

            m = row_sums(self.simplices, share, self.n_vertices)  # the same sums, no repeated shares
        else:
            k1 = self.simplices.shape[1]
            m = np.bincount(self.simplices.ravel(), weights=np.repeat(share, k1), minlength=self.n_vertices)
        return fill_unused_mass(m, share)

    def build_incidence(self):
        """The vertex-element incidence (on :attr:`vertex_simplices`' structure, when built)."""
        held = self.__dict__.get("vertex_simplices")
        if held is not None:
            return sp.csr_matrix((np.ones(held.nnz), held.indices, held.indptr), shape=held.shape)
        return simplex_incidence(self.simplices, self.sorted_simplices, self.n_vertices)

    def element_max(self, f):
        """Per element, the largest value of the vertex function ``f`` over its vertices."""
        f = np.asarray(f)
        out = f[self.simplices[:, 0]]
        for i in range(1, self.simplices.shape[1]):
            np.maximum(out, f[self.simplices[:, i]], out=out)
        return out

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
        grads, vols = self._geometry_of(out.points, new_sorted)
        out.simplices = kept_then(self.simplices, keep, new)
        out.sorted_simplices = kept_then(self.sorted_simplices, keep, new_sorted)
        out.volumes = kept_then(self.volumes, keep, vols)
        if "barycentric_gradients" in self.__dict__:
            out.barycentric_gradients = kept_then(self.barycentric_gradients, keep, grads)
        if "K" in self.__dict__:
            # the parent's operators are built: patch them where the split simplices lie.
            # Otherwise (a band, cut for one labelling) a fresh build costs less than the
            # parent's operators and the patch.
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
        if "barycentric_gradients" in self.__dict__:
            out.barycentric_gradients = self.barycentric_gradients[el]
        out.volumes = self.volumes[el]
        return out, vertices

    def simplicial_refinement(self):
        """The complex itself: ``(points, simplices, None)``."""
        return self.points, self.simplices, None

    def level_set_complex(self, f, value=None):
        """The complex itself carries ``f``: ``(points, simplices, f)``, whatever the
        ``value`` (marching simplices passes over the simplices its level set misses).
        """
        return self.points, self.simplices, np.asarray(f, dtype=np.float64)

    def __repr__(self):
        return (
            f"SimplicialComplex(n_vertices={self.n_vertices}, n_elements={self.n_elements}, "
            f"simplex_dim={self.simplex_dim}, dim={self.dim})"
        )
