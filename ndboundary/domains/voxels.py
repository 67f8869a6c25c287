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

from .polyhedral_reuse import Geometry

__all__ = ["box_geometry", "voxel_faces"]


def voxel_faces(shape, lowest, strides):
    """Faces and cells of the voxels of ``shape`` (C order) over the grid's corners.

    Parameters
    ----------
    shape : tuple of 3 int
    lowest : ndarray of int64 of shape (n_voxels,)
        Every voxel's lowest corner.
    strides : tuple of 3 int
        The corners' strides (C order over ``shape + 1``).

    Returns
    -------
    face_indices, face_offsets, cell_faces, cell_offsets : ndarray of int64
        Faces axis by axis, each listed counter-clockwise seen from its axis' positive
        side; every voxel's faces low then high along axis 0, 1 and 2.
    cell_face_signs : ndarray of int8
        -1 for a low face, +1 for a high face (outward).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.domains.voxels import voxel_faces
    >>> fi, fo, ci, co, signs = voxel_faces((1, 1, 1), np.array([0]), (4, 2, 1))
    >>> fi[:4].tolist(), ci.tolist(), signs.tolist()
    ([0, 2, 3, 1], [0, 1, 2, 3, 4, 5], [-1, 1, -1, 1, -1, 1])
    """
    n = np.asarray(shape)
    index = np.stack(np.unravel_index(np.arange(int(np.prod(n))), shape), axis=1)
    faces, cell_faces, start = [], [], 0
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        fshape = n.copy()
        fshape[a] += 1
        grid = np.stack(np.unravel_index(np.arange(int(np.prod(fshape))), tuple(fshape)), axis=1)
        p = grid @ np.asarray(strides)
        faces.append(np.stack([p, p + strides[b], p + strides[b] + strides[c], p + strides[c]], axis=1))
        low = start + np.ravel_multi_index(index.T, tuple(fshape))
        high = low + int(np.prod(fshape[a + 1 :]))
        cell_faces += [low, high]
        start += p.size
    fi = np.concatenate(faces).ravel()
    ci = np.stack(cell_faces, axis=1).ravel()
    signs = np.tile(np.array([-1, 1], dtype=np.int8), 3 * lowest.size)
    return fi, 4 * np.arange(fi.size // 4 + 1), ci, 6 * np.arange(lowest.size + 1), signs


def box_geometry(shape, points, fi, lowest, strides, spacing, direction, signs):
    """The :class:`~.polyhedral_reuse.Geometry` of the voxels (see :func:`voxel_faces`).

    Every face of one axis is the same rectangle: its area vector and the offset from its
    first corner to its centre are computed once per axis, not from the corners of each.
    """
    axes = np.eye(3) if direction is None else np.asarray(direction)
    steps = axes * np.asarray(spacing, dtype=np.float64)  # column a: one voxel along axis a
    per_axis, counts = [], []
    for a in range(3):
        b, c = (a + 1) % 3, (a + 2) % 3
        per_axis.append((np.cross(steps[:, b], steps[:, c]), 0.5 * (steps[:, b] + steps[:, c])))
        counts.append(int(np.prod([n + (k == a) for k, n in enumerate(shape)])))
    face_areas = np.repeat(np.array([area for area, _ in per_axis]), counts, axis=0)
    centres = points[fi[::4]] + np.repeat(np.array([half for _, half in per_axis]), counts, axis=0)
    bits = np.array(list(product((0, 1), repeat=3)))  # increasing corner ids: axis 0 slowest
    grads = (2 * bits - 1) / (4.0 * np.asarray(spacing))
    if direction is not None:
        grads = grads @ direction.T
    n = lowest.size
    cells = np.repeat(np.arange(n), 8)
    vertices = (lowest[:, None] + bits @ np.asarray(strides)).ravel()
    return Geometry(
        centres,
        np.repeat(face_areas / 4.0, 4, axis=0),
        face_areas,
        signs,
        np.full(n, float(np.prod(spacing))),
        (cells, vertices),
        np.tile(grads, (n, 1)),
    )
