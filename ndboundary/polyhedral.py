"""Polyhedral meshes: hexahedra, tetrahedra and general polyhedra in 3-D.

A mesh is given by its polygonal ``faces`` (vertex indices in cyclic order) and its
``cells`` (face indices). The winding of a face in the input does not matter: every
face is oriented outward from each of its cells by the library, geometrically (the
face's fan seen from the cell's vertex mean) and, where that fails on a non-convex
cell, combinatorially (propagated across the cell's edges); a cell whose faces do
not close into a surface (an edge used by other than two of its faces) is refused.

Every face is read as the fan of triangles from its vertex mean ``c_f`` (exactly the
face when it is planar). Operators (sign convention of :mod:`ndboundary.domain`:
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

from collections import defaultdict, deque
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ._validation import check_cells, check_points
from .domain import Domain
from .polygon import (
    check_laplacian_options,
    check_ragged,
    combinatorial_laplacian,
    local_stiffness,
    ragged_next,
    ragged_rows,
)
from .simplicial import (
    SimplicialComplex,
    _row_groups,
    first_of_groups,
    group_rows,
    mixed_facets,
    shared_facet_adjacency,
)

__all__ = ["PolyhedralMesh"]

_DEGENERATE_RTOL = 1e-10

#: Faces of a VTK hexahedron (bottom 0-3, top 4-7), outward.
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
#: Faces of a tetrahedron.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def _expand_ranges(starts, lengths):
    """Concatenation of ``arange(s, s + l)`` for every pair."""
    total = int(lengths.sum())
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    first = np.zeros(lengths.size, dtype=np.int64)
    np.cumsum(lengths[:-1], out=first[1:])
    return np.repeat(starts - first, lengths) + np.arange(total)


def _faces_from_cells(cells, local_faces):
    """Unique faces and face-index cells from fixed-shape cells (hexahedra, tetrahedra)."""
    E = cells.shape[0]
    nf, m = local_faces.shape
    allf = cells[:, local_faces].reshape(E * nf, m)
    ids, n = group_rows(np.sort(allf, axis=1))
    first = first_of_groups(ids, n)
    return allf[first], ids.reshape(E, nf)


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
    >>> from ndboundary.polyhedral import PolyhedralMesh
    >>> cube = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
    ...                  [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
    >>> mesh = PolyhedralMesh.from_hexahedra(cube, [[0, 1, 2, 3, 4, 5, 6, 7]])
    >>> round(float(mesh.A[0]), 12)
    1.0
    >>> mesh.gradient(cube[:, 2]).round(12).tolist()
    [[0.0, 0.0, 1.0]]
    """

    def __init__(self, points, faces, cells, *, laplacian="consistent", stabilization=4.0):
        points = check_points(points)
        if points.shape[1] != 3:
            raise ValueError(f"points has shape {points.shape}; a PolyhedralMesh needs 3-D points")
        fi, fo = check_ragged(faces, points.shape[0], name="faces", min_size=3)
        ci, co = check_ragged(cells, fo.size - 1, name="cells", min_size=4, what="face")
        self._init(points, fi, fo, ci, co, laplacian, stabilization)

    @classmethod
    def _from_flat(cls, points, fi, fo, ci, co, laplacian, stabilization):
        self = cls.__new__(cls)
        self._init(points, fi, fo, ci, co, laplacian, stabilization)
        return self

    def _init(self, points, fi, fo, ci, co, laplacian, stabilization):
        self.stabilization = check_laplacian_options(laplacian, stabilization)
        self.laplacian = laplacian
        self.points = points
        self.face_indices, self.face_offsets = fi, fo
        self.cell_faces, self.cell_offsets = ci, co
        self._face_geometry()
        self.cell_face_signs = self._orient()
        self._cell_geometry()

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
        faces, cell_faces = _faces_from_cells(cells, face_table)
        return cls(points, faces, cell_faces, **kwargs)

    # -- sizes -------------------------------------------------------------------------
    @property
    def n_elements(self) -> int:
        return int(self.cell_offsets.size - 1)

    @property
    def n_faces(self) -> int:
        """Number of faces."""
        return int(self.face_offsets.size - 1)

    @property
    def element_dim(self) -> int:
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
        owner, nxt, _ = ragged_next(self.face_offsets)
        self._face_owner, self._face_next = owner, nxt
        sizes = np.diff(self.face_offsets)
        X = self.points[self.face_indices]
        c = np.stack([np.bincount(owner, weights=X[:, d], minlength=sizes.size) for d in range(3)], 1)
        c /= sizes[:, None]
        Xc = X - c[owner]
        Nt = 0.5 * np.cross(Xc, Xc[nxt])  # fan triangle (c_f, x_j, x_j+1)
        Nf = np.stack([np.bincount(owner, weights=Nt[:, d], minlength=sizes.size) for d in range(3)], 1)
        scale = np.bincount(owner, weights=((Xc[nxt] - Xc) ** 2).sum(axis=1)) / sizes
        bad = ~(np.linalg.norm(Nf, axis=1) > _DEGENERATE_RTOL * scale)
        if bad.any():
            f = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"face {f} (vertices {self.face_indices[self.face_offsets[f]:self.face_offsets[f + 1]].tolist()}) "
                "is degenerate: zero area"
            )
        self._face_centres, self._fan_areas, self._face_areas = c, Nt, Nf

    @cached_property
    def _entries(self):
        """Per cell-face entry: its cell; per entry corner: its entry and flat face corner."""
        cell_of_entry = np.repeat(np.arange(self.n_elements), np.diff(self.cell_offsets))
        fsizes = np.diff(self.face_offsets)
        lens = fsizes[self.cell_faces]
        corner = _expand_ranges(self.face_offsets[self.cell_faces], lens)
        entry_of_corner = np.repeat(np.arange(self.cell_faces.size), lens)
        return cell_of_entry, entry_of_corner, corner

    @cached_property
    def _cell_vertices(self):
        """Sorted unique (cell, vertex) pairs: arrays ``cell``, ``vertex``."""
        cell_of_entry, entry_of_corner, corner = self._entries
        cell = cell_of_entry[entry_of_corner]
        pairs = np.stack([cell, self.face_indices[corner]], axis=1)
        _, first = _row_groups(pairs)
        return pairs[first, 0], pairs[first, 1]

    def element_centroids(self) -> np.ndarray:
        """Vertex means of the cells, shape (n_elements, 3)."""
        cell, vert = self._cell_vertices
        cnt = np.bincount(cell, minlength=self.n_elements)
        c = np.stack([np.bincount(cell, weights=self.points[vert, d], minlength=self.n_elements) for d in range(3)], 1)
        return c / cnt[:, None]

    def _closure_defects(self, signs):
        """Cells in which some edge is not used exactly twice with opposite directions."""
        cell_of_entry, entry_of_corner, corner = self._entries
        a = self.face_indices[corner]
        b = self.face_indices[self._face_next[corner]]
        flip = signs[entry_of_corner] < 0
        a, b = np.where(flip, b, a), np.where(flip, a, b)
        cell = cell_of_entry[entry_of_corner]
        ids, n = group_rows(np.stack([cell, np.minimum(a, b), np.maximum(a, b)], axis=1))
        cnt = np.bincount(ids, minlength=n)
        fwd = np.bincount(ids, weights=(a < b).astype(np.float64), minlength=n)
        bad_group = (cnt != 2) | (fwd != 1)
        return np.flatnonzero(np.bincount(cell[bad_group[ids]], minlength=self.n_elements))

    def _orient(self):
        """Sign of every cell-face entry making the face outward from its cell."""
        cell_of_entry, entry_of_corner, corner = self._entries
        centre = self.element_centroids()
        d = self._face_centres[self.cell_faces] - centre[cell_of_entry]
        signs = np.where(np.einsum("ij,ij->i", d, self._face_areas[self.cell_faces]) < 0, -1, 1).astype(np.int8)
        bad = self._closure_defects(signs)
        if bad.size:
            for c in bad:
                signs[self.cell_offsets[c]:self.cell_offsets[c + 1]] = self._orient_cell(int(c))
        return signs

    def _orient_cell(self, c):
        """Orient one cell's faces consistently across shared edges, or refuse an open cell."""
        faces = self.cell_faces[self.cell_offsets[c]:self.cell_offsets[c + 1]]
        loops = [self.face_indices[self.face_offsets[f]:self.face_offsets[f + 1]] for f in faces]
        users = defaultdict(list)
        for k, loop in enumerate(loops):
            for a, b in zip(loop, np.roll(loop, -1)):
                users[(min(a, b), max(a, b))].append((k, a < b))
        for (a, b), use in users.items():
            if len(use) != 2:
                raise ValueError(
                    f"cell {c} is not closed: its edge ({a}, {b}) is used by {len(use)} of its faces "
                    "instead of 2 (faces do not close)"
                )
        signs = np.zeros(len(loops), dtype=np.int8)
        signs[0] = 1
        queue = deque([0])
        while queue:
            k = queue.popleft()
            loop = loops[k]
            for a, b in zip(loop, np.roll(loop, -1)):
                (k1, d1), (k2, d2) = users[(min(a, b), max(a, b))]
                other, d_other, d_self = (k2, d2, d1) if k1 == k else (k1, d1, d2)
                want = -signs[k] if d_self == d_other else signs[k]
                if signs[other] == 0:
                    signs[other] = want
                    queue.append(other)
                elif signs[other] != want:
                    raise ValueError(f"cell {c} is not orientable: its faces do not close into a surface")
        if (signs == 0).any():
            raise ValueError(f"cell {c} is not connected: its faces do not close into one surface")
        return signs

    def _cell_geometry(self):
        """Volumes and per (cell, vertex) Green-Gauss coefficients; flips inward cells."""
        cell_of_entry, entry_of_corner, corner = self._entries
        E = self.n_elements
        centre = self.element_centroids()
        fo = self._face_owner[corner]
        s = self.cell_face_signs[entry_of_corner].astype(np.float64)
        cell = cell_of_entry[entry_of_corner]
        Nt = self._fan_areas[corner] * s[:, None]
        # signed volume of the fan surface: sum over triangles of (c_f - centre) . N_t / 3
        vol = np.bincount(
            cell, weights=np.einsum("ij,ij->i", self._face_centres[fo] - centre[cell], Nt) / 3.0, minlength=E
        )
        inward = vol < 0
        if inward.any():
            self.cell_face_signs[inward[cell_of_entry]] *= -1
            vol[inward] *= -1
            s = self.cell_face_signs[entry_of_corner].astype(np.float64)
            Nt = self._fan_areas[corner] * s[:, None]
        cv, vv = self._cell_vertices
        ext = np.maximum.reduceat(self.points[vv], np.r_[0, np.flatnonzero(np.diff(cv)) + 1], axis=0) - \
            np.minimum.reduceat(self.points[vv], np.r_[0, np.flatnonzero(np.diff(cv)) + 1], axis=0)
        scale = np.linalg.norm(ext, axis=1) ** 3
        bad = ~(vol > _DEGENERATE_RTOL * scale)
        if bad.any():
            c = int(np.flatnonzero(bad)[0])
            more = "" if bad.sum() == 1 else f" ({int(bad.sum())} degenerate cells in all)"
            raise ValueError(
                f"cell {c} (faces {self.cell_faces[self.cell_offsets[c]:self.cell_offsets[c + 1]].tolist()}) "
                f"is degenerate: zero volume{more}"
            )
        # vertex j of a face gets (N_{t,j-1} + N_{t,j}) / 3 + N_f / (3 m)
        prev_corner = np.empty_like(self._face_next)
        prev_corner[self._face_next] = np.arange(self._face_next.size)
        m = np.diff(self.face_offsets)[fo]
        Nf = self._face_areas[fo] * s[:, None]
        coef = (Nt + self._fan_areas[prev_corner[corner]] * s[:, None]) / 3.0 + Nf / (3.0 * m[:, None])
        coef /= vol[cell, None]
        inv, n_pairs = group_rows(np.stack([cell, self.face_indices[corner]], axis=1))
        g = np.stack([np.bincount(inv, weights=coef[:, d], minlength=n_pairs) for d in range(3)], 1)
        self._volumes = vol
        self._pair_grads = g  # aligned with self._cell_vertices

    # -- operators -------------------------------------------------------------------------
    def _build_gradient(self):
        cell, vert = self._cell_vertices
        rows = cell[:, None] * 3 + np.arange(3)[None, :]
        cols = np.broadcast_to(vert[:, None], rows.shape)
        return sp.csr_matrix(
            (self._pair_grads.ravel(), (rows.ravel(), cols.ravel())), shape=(self.n_elements * 3, self.n_vertices)
        )

    def _build_measures(self):
        return self._volumes.copy()

    def _build_stiffness(self):
        if self.laplacian == "combinatorial":
            return combinatorial_laplacian(self.edges, self.n_vertices, self.mean_edge_length())
        cell, vert = self._cell_vertices
        return local_stiffness(
            self.points, cell, vert, self._pair_grads, self._volumes, self.stabilization, self.n_vertices
        )

    def _build_mass(self):
        cell, vert = self._cell_vertices
        cnt = np.bincount(cell, minlength=self.n_elements)
        m = np.bincount(vert, weights=(self._volumes / cnt)[cell], minlength=self.n_vertices)
        unused = m <= 0
        if unused.any():
            # Vertices in no cell carry no measure; give them a tiny one so M stays invertible.
            m[unused] = (self._volumes / cnt).mean() * 1e-12
        return m

    def _build_incidence(self):
        cell, vert = self._cell_vertices
        return sp.csr_matrix((np.ones(cell.size), (vert, cell)), shape=(self.n_vertices, self.n_elements))

    @cached_property
    def _face_ids(self):
        """Group id of every face (faces with the same vertex set share one)."""
        sizes = np.diff(self.face_offsets)
        width = int(sizes.max())
        pad = np.full((sizes.size, width), -1, dtype=np.int64)
        pos = np.arange(self.face_indices.size) - self.face_offsets[self._face_owner]
        pad[self._face_owner, pos] = self.face_indices
        pad.sort(axis=1)
        return group_rows(pad)[0]

    def _build_adjacency(self):
        cell_of_entry = self._entries[0]
        return shared_facet_adjacency(self._face_ids[self.cell_faces], cell_of_entry, self.n_elements)

    def _build_edges(self):
        a = self.face_indices
        b = self.face_indices[self._face_next]
        pairs = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
        return pairs[_row_groups(pairs)[1]]

    def _fan_from_first(self, faces):
        """Triangles ``(v0, v_j, v_j+1)`` of the given faces over their own vertices, (n, 3)."""
        sizes = np.diff(self.face_offsets)[faces]
        first = self.face_indices[self.face_offsets[faces]]
        corner = _expand_ranges(self.face_offsets[faces] + 1, sizes - 2)
        return np.stack([np.repeat(first, sizes - 2), self.face_indices[corner], self.face_indices[corner + 1]], 1)

    def _interface_facets(self, region1):
        """Faces shared by a region-0 and a region-1 cell, as fan triangles, (n, 3)."""
        ids = self._face_ids[self.cell_faces]
        which = mixed_facets(ids, self._entries[0], region1)
        return self._fan_from_first(self.cell_faces[which])

    # -- padding and level sets -------------------------------------------------------------
    def _split_elements(self, mask):
        """Split the cells selected by ``mask`` into pyramids over their faces, apex at the vertex mean."""
        mask = np.asarray(mask, dtype=bool)
        idx = np.flatnonzero(mask)
        if idx.size == 0:
            return self, np.arange(self.n_elements)
        cell_of_entry, entry_of_corner, corner = self._entries
        V, F = self.n_vertices, self.n_faces
        apex = np.full(self.n_elements, -1, dtype=np.int64)
        apex[idx] = V + np.arange(idx.size)
        sel_corner = mask[cell_of_entry[entry_of_corner]]
        ent = entry_of_corner[sel_corner]
        cell = cell_of_entry[ent]
        a = self.face_indices[corner[sel_corner]]
        b = self.face_indices[self._face_next[corner[sel_corner]]]
        side_ids, n_side = group_rows(np.stack([cell, np.minimum(a, b), np.maximum(a, b)], axis=1))
        first = first_of_groups(side_ids, n_side)
        side_faces = np.stack([apex[cell[first]], a[first], b[first]], axis=1)
        fi = np.concatenate([self.face_indices, side_faces.ravel()])
        fo = np.concatenate([self.face_offsets, self.face_offsets[-1] + 3 * np.arange(1, n_side + 1)])
        keep = np.flatnonzero(~mask)
        keep_entries = ~mask[cell_of_entry]
        sel_entries = np.flatnonzero(mask[cell_of_entry])
        # new cells: one per entry of a masked cell, its base face then its side faces
        lens = np.diff(self.face_offsets)[self.cell_faces[sel_entries]]
        base_pos = np.zeros(sel_entries.size + 1, dtype=np.int64)
        np.cumsum(lens + 1, out=base_pos[1:])
        ci_new = np.empty(int(base_pos[-1]), dtype=np.int64)
        ci_new[base_pos[:-1]] = self.cell_faces[sel_entries]
        ci_new[_expand_ranges(base_pos[:-1] + 1, lens)] = F + side_ids  # corners are in entry order
        ci = np.concatenate([self.cell_faces[keep_entries], ci_new])
        co_keep = np.diff(self.cell_offsets)[keep]
        co = np.zeros(keep.size + sel_entries.size + 1, dtype=np.int64)
        np.cumsum(np.concatenate([co_keep, lens + 1]), out=co[1:])
        parent = np.concatenate([keep, cell_of_entry[sel_entries]])
        centres = self.element_centroids()[idx]
        out = PolyhedralMesh._from_flat(
            np.concatenate([self.points, centres]), fi, fo, ci, co, self.laplacian, self.stabilization
        )
        return out, parent

    def _refinement(self):
        """Points, tetrahedra and the (n_refined, n_vertices) interpolation matrix of the refinement."""
        cell_of_entry, entry_of_corner, corner = self._entries
        V = self.n_vertices
        fsizes = np.diff(self.face_offsets)
        big_face = fsizes > 3
        cell, vert = self._cell_vertices
        nv_cell = np.bincount(cell, minlength=self.n_elements)
        nf_cell = np.diff(self.cell_offsets)
        tet_cell = (nv_cell == 4) & (nf_cell == 4)
        big_faces = np.flatnonzero(big_face)
        big_cells = np.flatnonzero(~tet_cell)
        face_pt = np.full(self.n_faces, -1, dtype=np.int64)
        face_pt[big_faces] = V + np.arange(big_faces.size)
        cell_pt = np.full(self.n_elements, -1, dtype=np.int64)
        cell_pt[big_cells] = V + big_faces.size + np.arange(big_cells.size)
        # rows of R: identity, face means, cell means
        fsel = big_face[self._face_owner]
        f_rows = np.repeat(np.arange(big_faces.size), fsizes[big_faces])
        csel = ~tet_cell[cell]
        c_rows = np.repeat(np.arange(big_cells.size), nv_cell[big_cells])
        Rf = sp.csr_matrix((1.0 / fsizes[self._face_owner[fsel]], (f_rows, self.face_indices[fsel])),
                           shape=(big_faces.size, V))
        Rc = sp.csr_matrix((1.0 / nv_cell[cell[csel]], (c_rows, vert[csel])), shape=(big_cells.size, V))
        R = sp.vstack([sp.identity(V, format="csr"), Rf, Rc]).tocsr()
        # tetrahedra of the non-tet cells: (cell point, face point or triangle)
        ccell = cell_of_entry[entry_of_corner]
        f = self._face_owner[corner]
        a = self.face_indices[corner]
        b = self.face_indices[self._face_next[corner]]
        use = ~tet_cell[ccell]
        on_big = use & big_face[f]
        tets = [np.stack([cell_pt[ccell[on_big]], face_pt[f[on_big]], a[on_big], b[on_big]], axis=1)]
        tri_entries = np.flatnonzero(~tet_cell[cell_of_entry] & ~big_face[self.cell_faces])
        tri = self._fan_from_first(self.cell_faces[tri_entries])
        tets.append(np.concatenate([cell_pt[cell_of_entry[tri_entries]][:, None], tri], axis=1))
        tc = np.flatnonzero(tet_cell)
        tv = vert[np.isin(cell, tc)].reshape(-1, 4)
        tets.append(tv)
        return R @ self.points, np.concatenate(tets), R

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
        pts, tets, R = self._simplicial_split
        return SimplicialComplex(pts, tets), R

    def _level_set_simplices(self):
        """Tetrahedra over this mesh's vertices only: each cell coned from its lowest vertex.

        Faces are fanned from their lowest vertex, so neighbouring cells agree; valid for
        convex cells. :meth:`_level_set_complex` is preferred.
        """
        cell_of_entry, entry_of_corner, corner = self._entries
        cell, vert = self._cell_vertices
        first = np.r_[0, np.flatnonzero(np.diff(cell)) + 1]
        apex = vert[first]  # pairs are sorted by (cell, vertex)
        touches = np.zeros(self.cell_faces.size, dtype=bool)
        np.logical_or.at(touches, entry_of_corner, self.face_indices[corner] == apex[cell_of_entry[entry_of_corner]])
        ent = np.flatnonzero(~touches)
        faces = self.cell_faces[ent]
        # rotate each face so that it starts at its lowest vertex
        fo = self.face_offsets
        sizes = np.diff(fo)[faces]
        cidx = _expand_ranges(fo[faces], sizes)
        owner = np.repeat(np.arange(faces.size), sizes)
        lowest = np.minimum.reduceat(self.face_indices[cidx], np.r_[0, np.cumsum(sizes)[:-1]])
        pos = np.flatnonzero(self.face_indices[cidx] == lowest[owner])
        start = pos - np.r_[0, np.cumsum(sizes)[:-1]]
        j = _expand_ranges(np.ones(faces.size, dtype=np.int64), sizes - 2)
        tri_owner = np.repeat(np.arange(faces.size), sizes - 2)
        base = fo[faces][tri_owner]
        sz = sizes[tri_owner]
        st = start[tri_owner]
        v0 = self.face_indices[base + st]
        v1 = self.face_indices[base + (st + j) % sz]
        v2 = self.face_indices[base + (st + j + 1) % sz]
        return np.stack([apex[cell_of_entry[ent]][tri_owner], v0, v1, v2], axis=1)

    def __repr__(self):
        return (
            f"PolyhedralMesh(n_vertices={self.n_vertices}, n_faces={self.n_faces}, "
            f"n_elements={self.n_elements}, laplacian={self.laplacian!r})"
        )
