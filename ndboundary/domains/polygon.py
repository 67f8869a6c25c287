"""Polygon meshes: quads and general polygons, in the plane or on a surface in 3-D.

Operators (sign convention of :mod:`ndboundary.domains.base`: ``K`` is positive
semidefinite, ``Delta = -M^{-1} K``):

* gradient by Green-Gauss (Livesu 2018, section 3), per polygon with area ``A``,
  edges ``e`` of length ``l_e``, in-plane outward normals ``n_e`` and end-point means
  ``ubar_e``: ``grad u = (1/A) sum_e ubar_e n_e l_e``. For a polygon on a surface the
  in-plane normals are ``t_e x n`` with ``n`` the polygon's area-weighted normal
  (its vector area ``N = 1/2 sum_i x_i x x_{i+1}``, ``A = |N|``). The gradient is exact
  on linear functions for planar polygons, and gives their tangential part
  otherwise. Vertex ``i`` receives ``(x_{i+1} - x_{i-1}) x n / (2A)``.
* ``A`` = polygon area ``|N|``; ``mass`` = each polygon's area shared equally among
  its vertices.
* ``K``, ``laplacian="consistent"`` (default): ``G^T diag(A) G`` plus a
  stabilisation of the part of a function the gradient does not see. On a quad the
  Green-Gauss gradient is blind to the checkerboard ("hourglass") mode
  ``(1, -1, 1, -1)``, so ``G^T A G`` alone has a null space beyond constants and the
  integration step of the relaxation becomes singular. Per element, with ``P`` the
  projection of the element's vertex values onto linear functions
  (``(P u)_i = mean(u) + (x_i - xbar) . G_e u``), the stabilised stiffness is
  ``K_e = A G_e^T G_e + s_e (I - P)^T (I - P)``, ``s_e = stabilization * tr(A G_e^T G_e) / m``
  (the virtual-element "trace" stabilisation; cf. Alexa and Wardetzky 2011,
  Bunge et al. 2020). ``P`` reproduces linear functions, so ``K`` stays exact on them
  and, on triangles, ``I - P = 0``: ``K`` is the cotangent Laplacian. ``K`` is then no
  longer exactly ``G^T diag(A) G``, so the stabilisation must stay moderate: measured on
  relaxed boundaries (``benchmarks/meshes.py``), weights below 1 leave wiggles (hourglass
  modes of ``phi``), and 4 (the default) gives the shortest boundaries on Voronoi cells
  while leaving quads, hexahedra and the shared meshes as good or better.
* ``K``, ``laplacian="combinatorial"``: the paper's uniform graph Laplacian over the
  mesh edges (weight 1 per edge), times ``h^(k-2)`` (``h`` the mean edge length,
  ``k = element_dim``) so that it scales like a stiffness matrix.

Level sets are extracted on a refinement into simplices that adds one vertex at
each polygon's vertex mean (see :meth:`PolygonMesh.to_simplicial`).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .._arrays import (
    DEGENERATE_RTOL,
    fill_unused_mass,
    first_of_groups,
    group_rows,
    mixed_facets,
    ragged_next,
    ragged_rows,
    shared_facet_adjacency,
    used_vertices,
)
from .._validation import check_points, check_ragged, refuse_degenerate
from .base import Domain
from .cell_operators import check_laplacian_options, combinatorial_laplacian, local_stiffness, refinement_matrix
from .simplicial import SimplicialComplex

__all__ = ["PolygonMesh"]


class PolygonMesh(Domain):
    """A mesh of polygons (triangles, quads, any polygon) in the plane or on a surface in 3-D.

    Parameters
    ----------
    points : array-like of shape (n_vertices, dim)
        Vertex coordinates, ``dim`` 2 or 3. Copied.
    polygons : array-like of int of shape (n_elements, m), or sequence of sequences of int
        Vertex indices of each polygon in cyclic order (either winding), ``m >= 3``;
        polygons may have different numbers of vertices. Copied.
    laplacian : {"consistent", "combinatorial"}, default="consistent"
        Stiffness matrix: the Green-Gauss ``G^T diag(A) G`` with the stabilisation of
        its hourglass modes, or the paper's uniform graph Laplacian (module docstring).
    stabilization : float, default=4.0
        Weight of the stabilisation of the consistent stiffness, relative to the trace of
        each element's ``A G_e^T G_e`` per vertex. 0 gives plain ``G^T diag(A) G``, whose
        hourglass modes make the integration singular on quads; the default is the weight
        that relaxed boundaries measured best with (module docstring).

    Attributes
    ----------
    indices : ndarray of int64 of shape (n_corners,)
        All polygons' vertex indices, concatenated.
    offsets : ndarray of int64 of shape (n_elements + 1,)
        Polygon ``e`` is ``indices[offsets[e]:offsets[e + 1]]``.

    Raises
    ------
    ValueError
        On NaN or infinite coordinates, points not 2- or 3-dimensional, a polygon with
        fewer than 3 vertices, a repeated or out-of-range vertex index, a polygon of
        zero area (the message names its index), or an unknown ``laplacian``.
    TypeError
        On non-numeric points or non-integer indices.

    Examples
    --------
    >>> from ndboundary import PolygonMesh
    >>> sq = PolygonMesh([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1, 2, 3]])
    >>> float(sq.A[0])
    1.0
    >>> sq.gradient([0.0, 1.0, 1.0, 0.0]).tolist()
    [[1.0, 0.0]]
    """

    def __init__(self, points, polygons, *, laplacian="consistent", stabilization=4.0):
        points = check_points(points)
        if points.shape[1] not in (2, 3):
            raise ValueError(f"points has shape {points.shape}; a PolygonMesh needs 2-D or 3-D points")
        indices, offsets = check_ragged(polygons, points.shape[0], name="polygons", min_size=3)
        self._init(points, indices, offsets, laplacian, stabilization)

    @classmethod
    def _from_flat(cls, points, indices, offsets, laplacian, stabilization):
        self = cls.__new__(cls)
        self._init(points, indices, offsets, laplacian, stabilization)
        return self

    def _init(self, points, indices, offsets, laplacian, stabilization):
        self.stabilization = check_laplacian_options(laplacian, stabilization)
        self.laplacian = laplacian
        self.points = points
        self.indices = indices
        self.offsets = offsets
        self._corner_grads, self._areas = self._geometry()

    # -- sizes ---------------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        """Number of elements."""
        return int(self.offsets.size - 1)

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements."""
        return 2

    @property
    def sizes(self) -> np.ndarray:
        """Number of vertices of every polygon, shape (n_elements,)."""
        return np.diff(self.offsets)

    @property
    def polygons(self) -> list:
        """The polygons as a list of index arrays."""
        return ragged_rows(self.indices, self.offsets)

    # -- geometry --------------------------------------------------------------------------
    @cached_property
    def _corners(self):
        return ragged_next(self.offsets)

    def _geometry(self):
        """Green-Gauss coefficient of every corner (n_corners, dim) and areas (E,)."""
        owner, nxt, prv = self._corners
        sizes = self.sizes
        X = self.points[self.indices]
        centre = np.zeros((self.n_elements, self.dim))
        np.add.at(centre, owner, X)
        centre /= sizes[:, None]
        Xc = X - centre[owner]
        edge = Xc[nxt] - Xc
        scale = np.bincount(owner, weights=(edge**2).sum(axis=1)) / sizes  # mean squared edge length
        if self.dim == 2:
            cross = Xc[:, 0] * Xc[nxt, 1] - Xc[:, 1] * Xc[nxt, 0]
            signed = 0.5 * np.bincount(owner, weights=cross, minlength=self.n_elements)
            area = np.abs(signed)
        else:
            cross = np.cross(Xc, Xc[nxt])
            N = 0.5 * np.stack(
                [np.bincount(owner, weights=cross[:, d], minlength=self.n_elements) for d in range(3)], 1
            )
            area = np.linalg.norm(N, axis=1)
        refuse_degenerate(
            ~(area > DEGENERATE_RTOL * scale),
            "polygon",
            lambda e: f"vertices {self.indices[self.offsets[e] : self.offsets[e + 1]].tolist()}",
            "area",
            "polygons",
        )
        span = X[nxt] - X[prv]
        if self.dim == 2:
            coef = np.stack([span[:, 1], -span[:, 0]], axis=1) / (2.0 * signed[owner, None])
        else:
            n = N / area[:, None]
            coef = np.cross(span, n[owner]) / (2.0 * area[owner, None])
        return coef, area

    def element_centroids(self) -> np.ndarray:
        """Vertex means of the polygons, shape (n_elements, dim)."""
        owner = self._corners[0]
        c = np.zeros((self.n_elements, self.dim))
        np.add.at(c, owner, self.points[self.indices])
        return c / self.sizes[:, None]

    # -- operators ---------------------------------------------------------------------------
    def build_gradient(self):
        """The gradient operator (see the module docstring)."""
        owner = self._corners[0]
        D = self.dim
        rows = owner[:, None] * D + np.arange(D)[None, :]
        cols = np.broadcast_to(self.indices[:, None], rows.shape)
        return sp.csr_matrix(
            (self._corner_grads.ravel(), (rows.ravel(), cols.ravel())), shape=(self.n_elements * D, self.n_vertices)
        )

    def build_measures(self):
        """The element measures."""
        return self._areas.copy()

    def build_stiffness(self):
        """The stiffness (see the module docstring)."""
        if self.laplacian == "combinatorial":
            return combinatorial_laplacian(
                self.edges, self.n_vertices, self.mean_edge_length() ** (self.element_dim - 2)
            )
        return local_stiffness(
            self.points,
            self._corners[0],
            self.indices,
            self._corner_grads,
            self._areas,
            self.stabilization,
            self.n_vertices,
        )

    def build_mass(self):
        """Each element's measure shared equally among its vertices."""
        w = (self._areas / self.sizes)[self._corners[0]]
        m = np.bincount(self.indices, weights=w, minlength=self.n_vertices)
        return fill_unused_mass(m, self._areas / self.sizes)

    def build_incidence(self):
        """The vertex-element incidence."""
        return sp.csr_matrix(
            (np.ones(self.indices.size), (self.indices, self._corners[0])), shape=(self.n_vertices, self.n_elements)
        )

    @cached_property
    def _edge_ids(self):
        """Undirected edge of every corner (corner -> next) as (n_corners, 2) sorted pairs, and group ids."""
        _, nxt, _ = self._corners
        pairs = np.sort(np.stack([self.indices, self.indices[nxt]], axis=1), axis=1)
        ids, _ = group_rows(pairs)
        return pairs, ids

    def build_adjacency(self):
        """Elements sharing a facet."""
        return shared_facet_adjacency(self._edge_ids[1], self._corners[0], self.n_elements)

    def build_edges(self):
        """The unique edges, ``i < j``."""
        pairs, ids = self._edge_ids
        return pairs[first_of_groups(ids, int(ids.max()) + 1)]

    def interface_facets(self, region1):
        """Edges shared by a region-0 and a region-1 polygon: the jagged boundary, (n, 2)."""
        pairs, ids = self._edge_ids
        return pairs[mixed_facets(ids, self._corners[0], region1)]

    # -- padding and level sets -----------------------------------------------------------------
    def split_elements(self, mask):
        """Split the polygons selected by ``mask`` into fans of triangles at their vertex mean."""
        mask = np.asarray(mask, dtype=bool)
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return self, np.arange(self.n_elements)
        owner, nxt, _ = self._corners
        keep = np.flatnonzero(~mask)
        centres = self.element_centroids()[idx]
        new_id = np.full(self.n_elements, -1, dtype=np.int64)
        new_id[idx] = self.n_vertices + np.arange(idx.size)
        sel = mask[owner]
        tris = np.stack([new_id[owner[sel]], self.indices[sel], self.indices[nxt[sel]]], axis=1)
        kept_sizes = self.sizes[keep]
        kept = self.indices[~sel]
        indices = np.concatenate([kept, tris.ravel()])
        sizes = np.concatenate([kept_sizes, np.full(tris.shape[0], 3)])
        offsets = np.zeros(sizes.size + 1, dtype=np.int64)
        np.cumsum(sizes, out=offsets[1:])
        parent = np.concatenate([keep, owner[sel]])
        out = PolygonMesh._from_flat(
            np.concatenate([self.points, centres]), indices, offsets, self.laplacian, self.stabilization
        )
        out.usual_degree = self.usual_degree
        return out, parent

    def subdomain(self, mask):
        """The mesh of the polygons selected by ``mask`` (see :meth:`Domain.subdomain`)."""
        mask = np.asarray(mask, dtype=bool)
        corners = mask[self._corners[0]]
        vertices, remap = used_vertices(self.indices[corners], self.n_vertices)
        offsets = np.zeros(int(mask.sum()) + 1, dtype=np.int64)
        np.cumsum(self.sizes[mask], out=offsets[1:])
        indices = remap[self.indices[corners]]
        sub = PolygonMesh._from_flat(self.points[vertices], indices, offsets, self.laplacian, self.stabilization)
        sub.usual_degree = self.usual_degree
        return sub, vertices

    def simplicial_refinement(self):
        """Points, triangles and the (n_refined, n_vertices) interpolation matrix of the
        centroid fan: triangles are kept, larger polygons are fanned from their vertex mean.
        """
        owner, nxt, _ = self._corners
        sizes = self.sizes
        big = sizes > 3
        tri = self.indices[~big[owner]].reshape(-1, 3)
        big_idx = np.flatnonzero(big)
        centre_id = np.full(self.n_elements, -1, dtype=np.int64)
        centre_id[big_idx] = self.n_vertices + np.arange(big_idx.size)
        sel = big[owner]
        fan = np.stack([centre_id[owner[sel]], self.indices[sel], self.indices[nxt[sel]]], axis=1)
        sub_off = np.zeros(big_idx.size + 1, dtype=np.int64)
        np.cumsum(sizes[big_idx], out=sub_off[1:])
        R = refinement_matrix(self.n_vertices, self.indices[sel], sub_off)
        return R @ self.points, np.concatenate([tri, fan]), R

    def to_simplicial(self):
        """Split every polygon with more than three vertices into a fan at its vertex mean.

        Returns
        -------
        complex : SimplicialComplex
            Triangles over this mesh's vertices followed by one new vertex per split polygon.
        R : scipy.sparse.csr_matrix of shape (complex.n_vertices, n_vertices)
            Interpolation of vertex values to the refinement (identity, then vertex means).
        """
        pts, tris, R = self.simplicial_refinement()
        return SimplicialComplex(pts, tris), R

    def __repr__(self):
        return (
            f"PolygonMesh(n_vertices={self.n_vertices}, n_elements={self.n_elements}, dim={self.dim}, "
            f"laplacian={self.laplacian!r})"
        )
