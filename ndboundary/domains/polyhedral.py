"""Polyhedral meshes: hexahedra, tetrahedra and general polyhedra in 3-D.

A mesh is given by its polygonal ``faces`` (vertex indices in cyclic order) and its
``cells`` (face indices). The winding of a face in the input does not matter: every
face is oriented outward from each of its cells by the library, geometrically (the
face's fan seen from the cell's vertex mean) and, where that fails on a non-convex
cell, combinatorially (propagated across the cell's edges); a cell whose faces do
not close into a surface (an edge used by other than two of its faces) is refused.

Every face is read as the fan of triangles from its vertex mean ``c_f`` (exactly the
face when it is planar). Operators (sign convention of :mod:`ndboundary.domains.base`:
``K`` is positive semidefinite, ``Delta = -M^{-1} K``):

* gradient by Green-Gauss (Livesu 2018, section 3): ``grad u = (1/V) sum_t ubar_t N_t``
  over the fan triangles ``t`` of the cell's outward faces, ``N_t`` their vector
  areas and ``ubar_t`` the mean of ``u`` at their corners, ``u(c_f)`` being the mean
  over the face's vertices. This is the divergence theorem on the closed fan
  surface, so it is exact on linear functions for every cell (planar faces or not);
* ``A`` = cell volume ``V``, enclosed by that surface; ``mass`` = each cell's volume
  shared equally among its vertices;
* ``K``: as for :class:`~ndboundary.PolygonMesh` -- the consistent ``G^T diag(A) G``
  with the stabilisation of its hourglass modes (a hexahedron has four), or the
  uniform graph Laplacian scaled by ``h``.

Level sets are extracted on a refinement into tetrahedra that adds a vertex at the
mean of every non-triangular face and of every non-tetrahedral cell
(see :meth:`PolyhedralMesh.to_simplicial`).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .._arrays import (
    expand_ranges,
    fill_unused_mass,
    group_rows,
    mixed_facets,
    ragged_next,
    ragged_rows,
    row_groups,
    shared_facet_adjacency,
)
from .._validation import check_cells, check_points, check_ragged
from .base import Domain
from .cell_operators import check_laplacian_options, combinatorial_laplacian, local_stiffness
from .polyhedral_cells import (
    HEX_FACES,
    TET_FACES,
    fan_from_first,
    faces_from_cells,
    orient_faces,
    pyramid_split,
    tetrahedral_refinement,
)
from .polyhedral_geometry import cell_geometry, face_geometry
from .polyhedral_reuse import pyramid_cells, split_geometry, sub_geometry
from .simplicial import SimplicialComplex

__all__ = ["PolyhedralMesh"]


class PolyhedralMesh(Domain):
    """A mesh of polyhedra in 3-D given by faces and cells.

    Parameters
    ----------
    points : array-like of shape (n_vertices, 3)
        Vertex coordinates. Copied.
    faces : array-like of int of shape (n_faces, m), or sequence of sequences of int
        Vertex indices of each face in cyclic order (either winding), ``m >= 3``.
    cells : array-like of int of shape (n_elements, f), or sequence of sequences of int
        Face indices of each cell (at least 4), without signs: the library orients
        each face outward from each cell.
    laplacian : {"consistent", "combinatorial"}, default="consistent"
        See :class:`~ndboundary.PolygonMesh`.
    stabilization : float, default=4.0
        See :class:`~ndboundary.PolygonMesh`.
    face_signs : array-like of +1 / -1, optional
        The orientation of every cell-face entry (see ``cell_face_signs``) when the
        caller knows it (a generated grid): the faces are then not oriented, nor the
        cells checked for closure.

    Attributes
    ----------
    face_indices, face_offsets : ndarray of int64
        Face ``f`` is ``face_indices[face_offsets[f]:face_offsets[f + 1]]``.
    cell_faces, cell_offsets : ndarray of int64
        Cell ``e`` has the faces ``cell_faces[cell_offsets[e]:cell_offsets[e + 1]]``.
    cell_face_signs : ndarray of int8 of shape (len(cell_faces),)
        +1 where the face as listed winds counter-clockwise seen from outside the cell.

    Raises
    ------
    ValueError
        On points that are not 3-D, NaN or infinite coordinates, faces with fewer than
        3 or repeated vertices, cells with fewer than 4 or repeated faces, out-of-range
        indices, a face of zero area, a cell whose faces do not close or a cell of zero
        volume (the message names the face or cell).
    TypeError
        On non-numeric points or non-integer indices.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary import PolyhedralMesh
    >>> cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
    ...                  [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
    >>> mesh = PolyhedralMesh.from_hexahedra(cube, [[0, 1, 2, 3, 4, 5, 6, 7]])
    >>> round(float(mesh.A[0]), 12)
    1.0
    >>> mesh.gradient(cube[:, 2]).round(12).tolist()
    [[0.0, 0.0, 1.0]]
    """

    def __init__(self, points, faces, cells, *, laplacian="consistent", stabilization=4.0, face_signs=None):
        points = check_points(points)
        if points.shape[1] != 3:
            raise ValueError(f"points has shape {points.shape}; a PolyhedralMesh needs 3-D points")
        fi, fo = check_ragged(faces, points.shape[0], name="faces", min_size=3)
        ci, co = check_ragged(cells, fo.size - 1, name="cells", min_size=4, what="face")
        if face_signs is not None:
            face_signs = np.asarray(face_signs, dtype=np.int8)
            if face_signs.shape != ci.shape or not np.isin(face_signs, (-1, 1)).all():
                raise ValueError(f"face_signs must hold one +1 or -1 per cell face ({ci.size}), got {face_signs.shape}")
        self._init(points, fi, fo, ci, co, laplacian, stabilization, face_signs)

    @classmethod
    def _from_flat(cls, points, fi, fo, ci, co, laplacian, stabilization):
        self = cls.__new__(cls)
        self._init(points, fi, fo, ci, co, laplacian, stabilization)
        return self

    def _init(self, points, fi, fo, ci, co, laplacian, stabilization, face_signs=None):
        self.stabilization = check_laplacian_options(laplacian, stabilization)
        self.laplacian = laplacian
        self.points = points
        self.face_indices, self.face_offsets = fi, fo
        self.cell_faces, self.cell_offsets = ci, co
        self._face_geometry()
        self.cell_face_signs = orient_faces(self) if face_signs is None else face_signs
        self._cell_geometry()

    @classmethod
    def _derived(cls, points, fi, fo, ci, co, laplacian, stabilization, geometry):
        """A mesh whose geometry is known (:mod:`.polyhedral_reuse`): nothing is recomputed."""
        self = PolyhedralMesh.__new__(PolyhedralMesh)
        self._init_known(points, fi, fo, ci, co, laplacian, stabilization, geometry)
        return self

    def _init_known(self, points, fi, fo, ci, co, laplacian, stabilization, geometry):
        """Set the mesh's arrays and its known geometry."""
        self.stabilization, self.laplacian, self.points = stabilization, laplacian, points
        self.face_indices, self.face_offsets, self.cell_faces, self.cell_offsets = fi, fo, ci, co
        self.face_owner, self.face_next, _ = ragged_next(fo)
        self.face_centres, self.fan_areas = geometry.face_centres, geometry.fan_areas
        self.face_areas = geometry.face_areas
        self.cell_face_signs = geometry.cell_face_signs
        self._volumes, self._pair_grads = geometry.volumes, geometry.pair_grads
        self.__dict__["cell_vertices"] = geometry.cell_vertices

    @classmethod
    def from_hexahedra(cls, points, hexes, **kwargs):
        """Build from hexahedra in VTK vertex order (bottom quad 0-3, top quad 4-7 above 0-3).

        Parameters
        ----------
        points : array-like of shape (n_vertices, 3)
        hexes : array-like of int of shape (n_elements, 8)
        **kwargs
            ``laplacian``, ``stabilization``.

        Returns
        -------
        PolyhedralMesh
        """
        return cls._from_cells(points, hexes, "hexes", HEX_FACES, **kwargs)

    @classmethod
    def from_tetrahedra(cls, points, tets, **kwargs):
        """Build from tetrahedra (any vertex order).

        Parameters
        ----------
        points : array-like of shape (n_vertices, 3)
        tets : array-like of int of shape (n_elements, 4)
        **kwargs
            ``laplacian``, ``stabilization``.

        Returns
        -------
        PolyhedralMesh
        """
        return cls._from_cells(points, tets, "tets", TET_FACES, **kwargs)

    @classmethod
    def _from_cells(cls, points, cells, name, face_table, **kwargs):
        """Build from cells of one type, each with the faces ``face_table`` (local vertex indices)."""
        points = check_points(points)
        n_per_cell = int(np.max(np.concatenate([np.ravel(f) for f in face_table]))) + 1
        cells = check_cells(cells, points.shape[0], name=name, n_per_cell=n_per_cell)
        faces, cell_faces = faces_from_cells(cells, face_table)
        return cls(points, faces, cell_faces, **kwargs)

    # -- sizes -------------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        """Number of elements."""
        return int(self.cell_offsets.size - 1)

    @property
    def n_faces(self) -> int:
        """Number of faces."""
        return int(self.face_offsets.size - 1)

    @property
    def element_dim(self) -> int:
        """Dimension k of the elements."""
        return 3

    @property
    def faces(self) -> list:
        """The faces as a list of vertex index arrays."""
        return ragged_rows(self.face_indices, self.face_offsets)

    @property
    def cells(self) -> list:
        """The cells as a list of face index arrays."""
        return ragged_rows(self.cell_faces, self.cell_offsets)

    # -- geometry ------------------------------------------------------------------------
    def _face_geometry(self):
        """Face vertex means, fan-triangle vector areas (per face corner) and face vector areas."""
        self.face_owner, self.face_next, self.face_centres, self.fan_areas, self.face_areas = face_geometry(
            self.points, self.face_indices, self.face_offsets
        )

    @cached_property
    def cell_face_entries(self):
        """Per cell-face entry: its cell; per entry corner: its entry and flat face corner."""
        cell_of_entry = np.repeat(np.arange(self.n_elements), np.diff(self.cell_offsets))
        fsizes = np.diff(self.face_offsets)
        lens = fsizes[self.cell_faces]
        corner = expand_ranges(self.face_offsets[self.cell_faces], lens)
        entry_of_corner = np.repeat(np.arange(self.cell_faces.size), lens)
        return cell_of_entry, entry_of_corner, corner

    @cached_property
    def cell_vertices(self):
        """Sorted unique (cell, vertex) pairs: arrays ``cell``, ``vertex``."""
        cell_of_entry, entry_of_corner, corner = self.cell_face_entries
        cell = cell_of_entry[entry_of_corner]
        pairs = np.stack([cell, self.face_indices[corner]], axis=1)
        _, first = row_groups(pairs)
        return pairs[first, 0], pairs[first, 1]

    def element_centroids(self) -> np.ndarray:
        """Vertex means of the cells, shape (n_elements, 3)."""
        cell, vert = self.cell_vertices
        cnt = np.bincount(cell, minlength=self.n_elements)
        c = np.stack([np.bincount(cell, weights=self.points[vert, d], minlength=self.n_elements) for d in range(3)], 1)
        return c / cnt[:, None]

    def _cell_geometry(self):
        """Volumes and per (cell, vertex) Green-Gauss coefficients; flips inward cells."""
        self._volumes, self._pair_grads = cell_geometry(self)  # pair grads aligned with self.cell_vertices

    # -- operators -------------------------------------------------------------------------
    def build_gradient(self):
        """The gradient operator (see the module docstring)."""
        cell, vert = self.cell_vertices
        rows = cell[:, None] * 3 + np.arange(3)[None, :]
        cols = np.broadcast_to(vert[:, None], rows.shape)
        return sp.csr_matrix(
            (self._pair_grads.ravel(), (rows.ravel(), cols.ravel())), shape=(self.n_elements * 3, self.n_vertices)
        )

    def build_measures(self):
        """The element measures."""
        return self._volumes.copy()

    def build_stiffness(self):
        """The stiffness (see the module docstring)."""
        if self.laplacian == "combinatorial":
            return combinatorial_laplacian(self.edges, self.n_vertices, self.mean_edge_length())
        cell, vert = self.cell_vertices
        return local_stiffness(
            self.points, cell, vert, self._pair_grads, self._volumes, self.stabilization, self.n_vertices
        )

    def build_mass(self):
        """Each element's measure shared equally among its vertices."""
        cell, vert = self.cell_vertices
        cnt = np.bincount(cell, minlength=self.n_elements)
        m = np.bincount(vert, weights=(self._volumes / cnt)[cell], minlength=self.n_vertices)
        return fill_unused_mass(m, self._volumes / cnt)

    def build_incidence(self):
        """The vertex-element incidence."""
        cell, vert = self.cell_vertices
        return sp.csr_matrix((np.ones(cell.size), (vert, cell)), shape=(self.n_vertices, self.n_elements))

    @cached_property
    def _face_ids(self):
        """Group id of every face (faces with the same vertex set share one)."""
        sizes = np.diff(self.face_offsets)
        width = int(sizes.max())
        pad = np.full((sizes.size, width), -1, dtype=np.int64)
        pos = np.arange(self.face_indices.size) - self.face_offsets[self.face_owner]
        pad[self.face_owner, pos] = self.face_indices
        pad.sort(axis=1)
        return group_rows(pad)[0]

    def build_adjacency(self):
        """Elements sharing a facet."""
        cell_of_entry = self.cell_face_entries[0]
        return shared_facet_adjacency(self._face_ids[self.cell_faces], cell_of_entry, self.n_elements)

    def build_edges(self):
        """The unique edges, ``i < j``."""
        a = self.face_indices
        b = self.face_indices[self.face_next]
        pairs = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
        return pairs[row_groups(pairs)[1]]

    def interface_facets(self, region1):
        """Faces shared by a region-0 and a region-1 cell, as fan triangles, (n, 3)."""
        ids = self._face_ids[self.cell_faces]
        which = mixed_facets(ids, self.cell_face_entries[0], region1)
        return fan_from_first(self, self.cell_faces[which])

    # -- padding and level sets -------------------------------------------------------------
    def split_elements(self, mask):
        """Split the cells selected by ``mask`` into pyramids over their faces, apex at the vertex mean."""
        mask = np.asarray(mask, dtype=bool)
        if not mask.any():
            return self, np.arange(self.n_elements)
        split = pyramid_split(self, mask)
        points, fi, fo, ci, co, parent = split
        fi_p, fo_p, ci_p, co_p, first_new = pyramid_cells(split, int(np.count_nonzero(~mask)), self.n_faces)
        pyramids = PolyhedralMesh._from_flat(points, fi_p, fo_p, ci_p, co_p, self.laplacian, self.stabilization)
        geometry = split_geometry(self, mask, pyramids, first_new)
        out = PolyhedralMesh._derived(points, fi, fo, ci, co, self.laplacian, self.stabilization, geometry)
        out.usual_degree = self.usual_degree
        return out, parent

    def subdomain(self, mask):
        """The mesh of the cells selected by ``mask`` (see :meth:`Domain.subdomain`)."""
        points, fi, fo, ci, co, geometry, vertices = sub_geometry(self, np.flatnonzero(np.asarray(mask, dtype=bool)))
        sub = PolyhedralMesh._derived(points, fi, fo, ci, co, self.laplacian, self.stabilization, geometry)
        sub.usual_degree = self.usual_degree
        return sub, vertices

    def simplicial_refinement(self):
        """Points, tetrahedra and the (n_refined, n_vertices) interpolation matrix of the
        refinement (see :meth:`to_simplicial`).
        """
        return tetrahedral_refinement(self)

    def to_simplicial(self):
        """Split the mesh into tetrahedra: a vertex at the mean of every non-triangular face and
        of every non-tetrahedral cell, one tetrahedron per (cell, face fan triangle).

        Returns
        -------
        complex : SimplicialComplex
            Tetrahedra over this mesh's vertices followed by the added vertices.
        R : scipy.sparse.csr_matrix of shape (complex.n_vertices, n_vertices)
            Interpolation of vertex values to the refinement (identity, then vertex means).
        """
        pts, tets, R = self.simplicial_refinement()
        return SimplicialComplex(pts, tets), R

    def __repr__(self):
        return (
            f"PolyhedralMesh(n_vertices={self.n_vertices}, n_faces={self.n_faces}, "
            f"n_elements={self.n_elements}, laplacian={self.laplacian!r})"
        )
