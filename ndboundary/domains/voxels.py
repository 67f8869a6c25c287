"""The faces and the geometry of a voxel grid, from its structure.

Every voxel is the same box, so its faces need no search (each is named by its axis and
its lowest corner) and its geometry no computation per cell: the volume is the product
of the spacings and the Green-Gauss coefficient of corner ``(a, b, c)`` (0 or 1 along
each axis) is ``((2a - 1) / (4 s0), (2b - 1) / (4 s1), (2c - 1) / (4 s2))`` in the
grid's axes. These are what :class:`~ndboundary.PolyhedralMesh` computes for the same
hexahedra, to rounding (a test compares every operator).
"""

from __future__ import annotations

from itertools import product

import numpy as np
import scipy.sparse as sp

from .._arrays import used_vertices
from .._compiled_mesh import assemble_box_stencil
from .cell_operators import _cell_stiffness

__all__ = [
    "CORNER_BITS",
    "box_constants",
    "corner_strides",
    "voxel_adjacency",
    "voxel_edges",
    "voxel_faces",
    "voxel_gradient",
    "voxel_refinement",
    "voxel_stiffness",
]

#: A voxel's 8 corners as 0/1 offsets along the axes, in increasing corner index (axis 0
#: slowest, as the grid's C order).
CORNER_BITS = np.array(list(product((0, 1), repeat=3)))


def corner_strides(shape):
    """The strides of the grid's corners (C order over ``shape + 1``), one per axis.

    Examples
    --------
    >>> from ndboundary.domains.voxels import corner_strides
    >>> corner_strides((2, 3, 4)).tolist()
    [20, 5, 1]
    """
    return np.cumprod((1,) + tuple(n + 1 for n in shape[::-1]))[:-1][::-1]


def voxel_faces(shape, strides, voxels=None):
    """Faces and cells of the voxels of ``shape`` (C order), or of some of them, over the
    grid's corners.

    Parameters
    ----------
    shape : tuple of 3 int
    strides : tuple of 3 int
        The corners' strides (C order over ``shape + 1``).
    voxels : ndarray of int, optional
        The voxels to keep (their C-order indices, increasing); all of them by default.

    Returns
    -------
    face_indices, face_offsets, cell_faces, cell_offsets : ndarray of int64
        Faces axis by axis, each listed counter-clockwise seen from its axis' positive
        side; every voxel's faces low then high along axis 0, 1 and 2. Face corners are
        the grid's corner indices (C order over ``shape + 1``).
    cell_face_signs : ndarray of int8
        -1 for a low face, +1 for a high face (outward).
    axis_counts : list of 3 int
        How many of the faces lie across each axis.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.voxels import voxel_faces
    >>> fi, fo, ci, co, signs, counts = voxel_faces((1, 1, 1), (4, 2, 1))
    >>> fi[:4].tolist(), ci.tolist(), signs.tolist(), counts
    ([0, 2, 3, 1], [0, 1, 2, 3, 4, 5], [-1, 1, -1, 1, -1, 1], [2, 2, 2])

    Two voxels of a row of three share one face:

    >>> fi, fo, ci, co, signs, counts = voxel_faces((1, 1, 3), (8, 4, 1), voxels=np.array([0, 1]))
    >>> counts, ci.reshape(2, 6)[:, 4:].tolist()
    ([4, 4, 3], [[8, 9], [9, 10]])
    """
    n = np.asarray(shape)
    if voxels is None:
        index = np.stack(np.unravel_index(np.arange(int(np.prod(n))), shape), axis=1)
    else:
        index = np.stack(np.unravel_index(voxels, shape), axis=1)
    faces, cell_faces, counts, start = [], [], [], 0
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        fshape = n.copy()
        fshape[a] += 1
        low = np.ravel_multi_index(index.T, tuple(fshape))
        high = low + int(np.prod(fshape[a + 1 :]))
        if voxels is None:
            ids = np.arange(int(np.prod(fshape)))
        else:  # the faces the voxels hold, each once
            ids, remap = used_vertices(np.stack([low, high]), int(np.prod(fshape)))
            low, high = remap[low], remap[high]
        p = np.stack(np.unravel_index(ids, tuple(fshape)), axis=1) @ np.asarray(strides)
        faces.append(np.stack([p, p + strides[b], p + strides[b] + strides[c], p + strides[c]], axis=1))
        cell_faces += [start + low, start + high]
        counts.append(int(ids.size))
        start += ids.size
    fi = np.concatenate(faces).ravel()
    ci = np.stack(cell_faces, axis=1).ravel()
    signs = np.tile(np.array([-1, 1], dtype=np.int8), 3 * index.shape[0])
    return fi, 4 * np.arange(fi.size // 4 + 1), ci, 6 * np.arange(index.shape[0] + 1), signs, counts


def box_constants(spacing, direction):
    """What every voxel of a grid shares: ``(face_areas, half_diagonals, grads)``.

    ``face_areas[a]`` is the area vector of a face across axis ``a``, seen from its
    positive side; ``half_diagonals[a]`` the offset from its first corner to its centre;
    ``grads`` of shape (8, 3) the Green-Gauss coefficient of each corner
    (:data:`CORNER_BITS` order). Each face and voxel takes these, not a computation of its
    own: every face of one axis is the same rectangle, every voxel the same box.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.voxels import box_constants
    >>> areas, halves, grads = box_constants((1.0, 2.0, 4.0), None)
    >>> areas.diagonal().tolist(), grads[7].tolist()
    ([8.0, 4.0, 2.0], [0.25, 0.125, 0.0625])
    """
    axes = np.eye(3) if direction is None else np.asarray(direction)
    steps = axes * np.asarray(spacing, dtype=np.float64)  # column a: one voxel along axis a
    areas, halves = np.zeros((3, 3)), np.zeros((3, 3))
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        areas[a], halves[a] = np.cross(steps[:, b], steps[:, c]), 0.5 * (steps[:, b] + steps[:, c])
    grads = (2 * CORNER_BITS - 1) / (4.0 * np.asarray(spacing))
    if direction is not None:
        grads = grads @ np.asarray(direction).T
    return areas, halves, grads


def _corners_of(mesh):
    """Every voxel's 8 vertices, shape (n_elements, 8), in :data:`CORNER_BITS` order (the
    order of ``mesh.cell_vertices``), whose coefficients are ``mesh.box`` (:func:`box_constants`).
    """
    return mesh.cell_vertices[1].reshape(mesh.n_elements, 8)


def voxel_stiffness(mesh):
    """The stiffness of a voxel mesh: one voxel's matrix, added into the rows of every
    voxel's corners (:func:`~ndboundary._compiled_mesh.assemble_box_stencil`).

    Every voxel is the same box, so the matrix that
    :func:`~ndboundary.domains.cell_operators.local_stiffness` would find shared by all of
    them is computed from the first alone, and each entry goes to its slot in the grid's
    stencil without a search. Couplings that vanish but for rounding (with the default
    stabilisation, those of a voxel's opposite corners: 8 of the 27 of a row) are left
    out of the pattern, so that every product with the matrix reads 19 entries a row.
    """
    corners = _corners_of(mesh)
    grads = mesh.box[2][None]
    X = mesh.points[corners[0]][None]
    block = _cell_stiffness(grads, mesh._volumes[:1], X - X.mean(axis=1, keepdims=True), mesh.stabilization)[0]
    block = 0.5 * (block + block.T)
    block[np.abs(block) <= 1e-12 * np.abs(block).max()] = 0.0
    return assemble_box_stencil(corners, block, CORNER_BITS @ corner_strides(mesh.shape), mesh.n_vertices)


def voxel_gradient(mesh):
    """The gradient operator of a voxel mesh, shape (3 n_elements, n_vertices), built in
    CSR form: row ``3 e + a`` holds voxel ``e``'s 8 corners with the coefficients along
    axis ``a`` that every voxel shares.
    """
    corners = _corners_of(mesh)
    n = mesh.n_elements
    idx = np.int32 if max(mesh.n_vertices, 24 * n) < np.iinfo(np.int32).max else np.int64
    indices = np.broadcast_to(corners.astype(idx)[:, None, :], (n, 3, 8)).reshape(-1)
    data = np.broadcast_to(mesh.box[2].T[None], (n, 3, 8)).reshape(-1)
    indptr = 8 * np.arange(3 * n + 1, dtype=idx)
    return sp.csr_matrix((data, indices, indptr), shape=(3 * n, mesh.n_vertices))


#: A voxel's edges as pairs of its corners (:data:`CORNER_BITS` order), along axis 2,
#: then 1, then 0: for one lowest corner, the order of the other end's index.
VOXEL_EDGES = (((0, 1), (2, 3), (4, 5), (6, 7)), ((0, 2), (1, 3), (4, 6), (5, 7)), ((0, 4), (1, 5), (2, 6), (3, 7)))


def voxel_edges(mesh):
    """The unique edges ``(i, j)``, ``i < j``, of a voxel mesh, in lexicographic order
    (as :meth:`~ndboundary.PolyhedralMesh.build_edges` gives them), shape (n_edges, 2).

    An edge is named by its lower end and its axis, so marking the names in a table of
    three slots per vertex lists each once, in order, without a sort.
    """
    corners = _corners_of(mesh)
    V = mesh.n_vertices
    other = np.full(3 * V, -1, dtype=np.int64)
    for k, pairs in enumerate(VOXEL_EDGES):
        for i, j in pairs:
            other[3 * corners[:, i] + k] = corners[:, j]
    slots = np.flatnonzero(other >= 0)
    return np.stack([slots // 3, other[slots]], axis=1)


def voxel_adjacency(mesh):
    """The voxels sharing a face, as a CSR matrix of ones with sorted columns.

    Voxel ``e``'s neighbour across its high face along an axis is the voxel one stride
    further along it (found among a band's ``pixels`` by a binary search), unless ``e`` lies
    at the grid's end; across its low face, the voxel whose high neighbour it is. The
    neighbours in the order low faces along axes 0, 1, 2, then high faces along axes 2, 1,
    0 are in increasing order (the voxels are numbered in C order), so each row's columns
    come sorted without a sort, and no face is listed.
    """
    n, shape = mesh.n_elements, mesh.shape
    pixels = getattr(mesh, "pixels", None)  # None: every voxel of the grid
    index = np.arange(n) if pixels is None else pixels
    idx = np.int32 if 6 * n < np.iinfo(np.int32).max else np.int64
    nbr = np.full((n, 6), -1, dtype=idx)
    for a in range(3):
        stride = int(np.prod(shape[a + 1 :]))
        above = index + stride
        inside = (index // stride) % shape[a] < shape[a] - 1
        if pixels is None:
            high = np.where(inside, above, -1)
        else:
            pos = np.minimum(np.searchsorted(pixels, above), n - 1)
            high = np.where(inside & (pixels[pos] == above), pos, -1)
        nbr[:, 5 - a] = high
        has = np.flatnonzero(high >= 0)
        nbr[high[has], a] = has  # the low-side neighbour of the voxel above
    there = nbr >= 0
    indptr = np.zeros(n + 1, dtype=idx)
    np.cumsum(there.sum(axis=1), out=indptr[1:])
    return sp.csr_matrix((np.ones(int(indptr[-1])), nbr[there], indptr), shape=(n, n))


def voxel_refinement(mesh):
    """:func:`~ndboundary.domains.polyhedral_cells.tetrahedral_refinement` of a mesh of
    voxels, read off its faces and corners: a point at the centre of every face and of
    every voxel, and 24 tetrahedra per voxel, (voxel centre, face centre, edge) for the
    4 edges of each of its 6 faces.

    The same points, tetrahedra and interpolation matrix as the general refinement, in the
    same order and to the bit (a test compares them), without its tables of every corner
    of every face of every cell: at an atlas's size (2.2 M voxels that interfaces cross)
    those held several gigabytes.

    Examples
    --------
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.domains.voxels import voxel_refinement
    >>> points, tets, R = voxel_refinement(ImageGrid((1, 1, 1)))
    >>> points.shape, tets.shape, R.shape, points[-1].tolist()
    ((15, 3), (24, 4), (15, 8), [0.0, 0.0, 0.0])
    """
    V, N = mesh.n_vertices, mesh.n_elements
    fi = mesh.face_indices
    F = fi.size // 4
    corners = mesh.cell_vertices[1]  # 8 a voxel, increasing, as the general refinement's rows
    indptr = np.concatenate([np.arange(V + 1), V + 4 * np.arange(1, F + 1), V + 4 * F + 8 * np.arange(1, N + 1)])
    indices = np.concatenate([np.arange(V), np.sort(fi.reshape(F, 4), axis=1).ravel(), corners])
    data = np.concatenate([np.ones(V), np.full(fi.size, 0.25), np.full(corners.size, 0.125)])
    R = sp.csr_matrix((data, indices, indptr), shape=(V + F + N, V))
    del indices, data
    faces = mesh.cell_faces.reshape(N, 6)
    tets = np.empty((N, 6, 4, 4), dtype=np.int64)
    tets[..., 0] = (V + F + np.arange(N))[:, None, None]
    tets[..., 1] = V + faces[:, :, None]
    ring = fi.reshape(F, 4)
    tets[..., 2] = ring[faces]
    tets[..., 3] = ring[:, [1, 2, 3, 0]][faces]
    return R @ mesh.points, tets.reshape(-1, 4), R
