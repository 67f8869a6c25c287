"""Cell-level algorithms of polyhedral meshes: face orientation, fans and the tetrahedral refinement."""

from __future__ import annotations

from collections import defaultdict, deque

import numpy as np
import scipy.sparse as sp

from .._arrays import expand_ranges, first_of_groups, group_rows

__all__ = [
    "HEX_FACES",
    "TET_FACES",
    "closure_defects",
    "fan_from_first",
    "faces_from_cells",
    "orient_cell",
    "orient_faces",
    "pyramid_split",
    "tetrahedral_refinement",
]

#: Faces of a VTK hexahedron (bottom 0-3, top 4-7), outward.
HEX_FACES = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
#: Faces of a tetrahedron.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])


def faces_from_cells(cells, local_faces):
    """Unique faces and face-index cells from fixed-shape cells (hexahedra, tetrahedra).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.polyhedral_cells import TET_FACES, faces_from_cells
    >>> faces, cells = faces_from_cells(np.array([[0, 1, 2, 3]]), TET_FACES)
    >>> faces.tolist(), cells.tolist()
    ([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], [[3, 2, 1, 0]])
    """
    E = cells.shape[0]
    nf, m = local_faces.shape
    allf = cells[:, local_faces].reshape(E * nf, m)
    ids, n = group_rows(np.sort(allf, axis=1))
    first = first_of_groups(ids, n)
    return allf[first], ids.reshape(E, nf)


def closure_defects(mesh, signs):
    """Cells in which some edge is not used exactly twice with opposite directions.

    Examples
    --------
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import closure_defects
    >>> cube = hex_grid(1)
    >>> signs = cube.cell_face_signs.copy()
    >>> closure_defects(cube, signs).tolist()
    []
    >>> signs[0] = -signs[0]  # one face turned inside out
    >>> closure_defects(cube, signs).tolist()
    [0]
    """
    cell_of_entry, entry_of_corner, corner = mesh.cell_face_entries
    a = mesh.face_indices[corner]
    b = mesh.face_indices[mesh.face_next[corner]]
    flip = signs[entry_of_corner] < 0
    a, b = np.where(flip, b, a), np.where(flip, a, b)
    cell = cell_of_entry[entry_of_corner]
    ids, n = group_rows(np.stack([cell, np.minimum(a, b), np.maximum(a, b)], axis=1))
    cnt = np.bincount(ids, minlength=n)
    fwd = np.bincount(ids, weights=(a < b).astype(np.float64), minlength=n)
    bad_group = (cnt != 2) | (fwd != 1)
    return np.flatnonzero(np.bincount(cell[bad_group[ids]], minlength=mesh.n_elements))


def orient_faces(mesh):
    """Sign of every cell-face entry making the face outward from its cell: geometric (the
    face seen from the cell's vertex mean), then combinatorial where a cell does not close.

    Examples
    --------
    Of the 48 cell-face entries of a 2 x 2 x 2 grid, the 12 interior faces are reversed
    in one of their two cells:

    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import orient_faces
    >>> signs = orient_faces(hex_grid(2))
    >>> signs.size, int((signs == 1).sum()), int((signs == -1).sum())
    (48, 36, 12)
    """
    cell_of_entry, entry_of_corner, corner = mesh.cell_face_entries
    centre = mesh.element_centroids()
    d = mesh.face_centres[mesh.cell_faces] - centre[cell_of_entry]
    signs = np.where(np.einsum("ij,ij->i", d, mesh.face_areas[mesh.cell_faces]) < 0, -1, 1).astype(np.int8)
    bad = closure_defects(mesh, signs)
    if bad.size:
        for c in bad:
            signs[mesh.cell_offsets[c] : mesh.cell_offsets[c + 1]] = orient_cell(mesh, int(c))
    return signs


def orient_cell(mesh, c):
    """Orient one cell's faces consistently across shared edges, or refuse an open cell.

    The first face keeps its direction; the signs are relative to it.

    Examples
    --------
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import orient_cell
    >>> orient_cell(hex_grid(1), 0).tolist()
    [1, 1, 1, 1, 1, 1]
    """
    faces = mesh.cell_faces[mesh.cell_offsets[c] : mesh.cell_offsets[c + 1]]
    loops = [mesh.face_indices[mesh.face_offsets[f] : mesh.face_offsets[f + 1]] for f in faces]
    users = defaultdict(list)
    for k, loop in enumerate(loops):
        for a, b in zip(loop, np.roll(loop, -1), strict=True):
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
        for a, b in zip(loop, np.roll(loop, -1), strict=True):
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


def fan_from_first(mesh, faces):
    """Triangles ``(v0, v_j, v_j+1)`` of the given faces over their own vertices, (n, 3).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import fan_from_first
    >>> cube = hex_grid(1)
    >>> cube.faces[0].tolist(), fan_from_first(cube, np.array([0])).tolist()
    ([2, 0, 1, 3], [[2, 0, 1], [2, 1, 3]])
    """
    sizes = np.diff(mesh.face_offsets)[faces]
    first = mesh.face_indices[mesh.face_offsets[faces]]
    corner = expand_ranges(mesh.face_offsets[faces] + 1, sizes - 2)
    return np.stack([np.repeat(first, sizes - 2), mesh.face_indices[corner], mesh.face_indices[corner + 1]], 1)


def tetrahedral_refinement(mesh):
    """Points, tetrahedra and the (n_refined, n_vertices) interpolation matrix of the refinement.

    Examples
    --------
    A cube gains a point per face and one at its centre, and 4 tetrahedra per face:

    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import tetrahedral_refinement
    >>> points, tets, R = tetrahedral_refinement(hex_grid(1))
    >>> points.shape, tets.shape, R.shape
    ((15, 3), (24, 4), (15, 8))
    """
    cell_of_entry, entry_of_corner, corner = mesh.cell_face_entries
    V = mesh.n_vertices
    fsizes = np.diff(mesh.face_offsets)
    big_face = fsizes > 3
    cell, vert = mesh.cell_vertices
    nv_cell = np.bincount(cell, minlength=mesh.n_elements)
    nf_cell = np.diff(mesh.cell_offsets)
    tet_cell = (nv_cell == 4) & (nf_cell == 4)
    big_faces = np.flatnonzero(big_face)
    big_cells = np.flatnonzero(~tet_cell)
    face_pt = np.full(mesh.n_faces, -1, dtype=np.int64)
    face_pt[big_faces] = V + np.arange(big_faces.size)
    cell_pt = np.full(mesh.n_elements, -1, dtype=np.int64)
    cell_pt[big_cells] = V + big_faces.size + np.arange(big_cells.size)
    # rows of R: identity, face means, cell means
    fsel = big_face[mesh.face_owner]
    f_rows = np.repeat(np.arange(big_faces.size), fsizes[big_faces])
    csel = ~tet_cell[cell]
    c_rows = np.repeat(np.arange(big_cells.size), nv_cell[big_cells])
    Rf = sp.csr_matrix(
        (1.0 / fsizes[mesh.face_owner[fsel]], (f_rows, mesh.face_indices[fsel])), shape=(big_faces.size, V)
    )
    Rc = sp.csr_matrix((1.0 / nv_cell[cell[csel]], (c_rows, vert[csel])), shape=(big_cells.size, V))
    R = sp.vstack([sp.identity(V, format="csr"), Rf, Rc]).tocsr()
    # tetrahedra of the non-tet cells: (cell point, face point or triangle)
    ccell = cell_of_entry[entry_of_corner]
    f = mesh.face_owner[corner]
    a = mesh.face_indices[corner]
    b = mesh.face_indices[mesh.face_next[corner]]
    use = ~tet_cell[ccell]
    on_big = use & big_face[f]
    tets = [np.stack([cell_pt[ccell[on_big]], face_pt[f[on_big]], a[on_big], b[on_big]], axis=1)]
    tri_entries = np.flatnonzero(~tet_cell[cell_of_entry] & ~big_face[mesh.cell_faces])
    tri = fan_from_first(mesh, mesh.cell_faces[tri_entries])
    tets.append(np.concatenate([cell_pt[cell_of_entry[tri_entries]][:, None], tri], axis=1))
    tc = np.flatnonzero(tet_cell)
    tv = vert[np.isin(cell, tc)].reshape(-1, 4)
    tets.append(tv)
    return R @ mesh.points, np.concatenate(tets), R


def pyramid_split(mesh, mask):
    """Split the cells selected by ``mask`` into pyramids over their faces, apex at the vertex mean.

    Returns ``(points, face_indices, face_offsets, cell_faces, cell_offsets, parent)`` of
    the split mesh: the kept cells in order, then one pyramid per face of every split cell.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_cells import pyramid_split
    >>> points, fi, fo, ci, co, parent = pyramid_split(hex_grid(1), np.array([True]))
    >>> points[-1].tolist(), co.size - 1, parent.tolist()  # apex at the centre; six pyramids
    ([0.0, 0.0, 0.0], 6, [0, 0, 0, 0, 0, 0])
    """
    mask = np.asarray(mask, dtype=bool)
    idx = np.flatnonzero(mask)
    cell_of_entry, entry_of_corner, corner = mesh.cell_face_entries
    V, F = mesh.n_vertices, mesh.n_faces
    apex = np.full(mesh.n_elements, -1, dtype=np.int64)
    apex[idx] = V + np.arange(idx.size)
    sel_corner = mask[cell_of_entry[entry_of_corner]]
    ent = entry_of_corner[sel_corner]
    cell = cell_of_entry[ent]
    a = mesh.face_indices[corner[sel_corner]]
    b = mesh.face_indices[mesh.face_next[corner[sel_corner]]]
    side_ids, n_side = group_rows(np.stack([cell, np.minimum(a, b), np.maximum(a, b)], axis=1))
    first = first_of_groups(side_ids, n_side)
    side_faces = np.stack([apex[cell[first]], a[first], b[first]], axis=1)
    fi = np.concatenate([mesh.face_indices, side_faces.ravel()])
    fo = np.concatenate([mesh.face_offsets, mesh.face_offsets[-1] + 3 * np.arange(1, n_side + 1)])
    keep = np.flatnonzero(~mask)
    keep_entries = ~mask[cell_of_entry]
    sel_entries = np.flatnonzero(mask[cell_of_entry])
    # new cells: one per entry of a masked cell, its base face then its side faces
    lens = np.diff(mesh.face_offsets)[mesh.cell_faces[sel_entries]]
    base_pos = np.zeros(sel_entries.size + 1, dtype=np.int64)
    np.cumsum(lens + 1, out=base_pos[1:])
    ci_new = np.empty(int(base_pos[-1]), dtype=np.int64)
    ci_new[base_pos[:-1]] = mesh.cell_faces[sel_entries]
    ci_new[expand_ranges(base_pos[:-1] + 1, lens)] = F + side_ids  # corners are in entry order
    ci = np.concatenate([mesh.cell_faces[keep_entries], ci_new])
    co_keep = np.diff(mesh.cell_offsets)[keep]
    co = np.zeros(keep.size + sel_entries.size + 1, dtype=np.int64)
    np.cumsum(np.concatenate([co_keep, lens + 1]), out=co[1:])
    parent = np.concatenate([keep, cell_of_entry[sel_entries]])
    centres = mesh.element_centroids()[idx]
    return np.concatenate([mesh.points, centres]), fi, fo, ci, co, parent
