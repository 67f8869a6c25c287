"""Geometry of a polyhedral mesh computed when it is built: the fan of every face (its vertex
mean, fan-triangle and face vector areas), and every cell's volume and Green-Gauss gradient
coefficients, refusing faces of zero area and cells of zero volume.
"""

from __future__ import annotations

import numpy as np

from .._arrays import DEGENERATE_RTOL, group_rows, ragged_next
from .._validation import refuse_degenerate

__all__ = ["face_geometry", "cell_geometry"]


def face_geometry(points, face_indices, face_offsets):
    """Face vertex means, fan-triangle vector areas (per face corner) and face vector areas.

    Returns
    -------
    owner, nxt : ndarray of int64 of shape (n_corners,)
        The face of every flat face corner, and the next corner around that face.
    centres : ndarray of shape (n_faces, 3)
        The vertex mean ``c_f`` of every face.
    fan_areas : ndarray of shape (n_corners, 3)
        Vector area of the fan triangle ``(c_f, x_j, x_j+1)`` of every corner ``j``.
    face_areas : ndarray of shape (n_faces, 3)
        Vector area of every face, the sum over its fan.

    Raises
    ------
    ValueError
        On a face of zero area (the message names the face and its vertices).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_geometry import face_geometry
    >>> cube = hex_grid(1)  # the cube [-1, 1]^3
    >>> owner, nxt, centres, fan, areas = face_geometry(cube.points, cube.face_indices, cube.face_offsets)
    >>> fan.shape, np.linalg.norm(areas, axis=1).round(12).tolist()
    ((24, 3), [4.0, 4.0, 4.0, 4.0, 4.0, 4.0])
    """
    owner, nxt, _ = ragged_next(face_offsets)
    sizes = np.diff(face_offsets)
    X = points[face_indices]
    c = np.stack([np.bincount(owner, weights=X[:, d], minlength=sizes.size) for d in range(3)], 1)
    c /= sizes[:, None]
    Xc = X - c[owner]
    Nt = 0.5 * np.cross(Xc, Xc[nxt])  # fan triangle (c_f, x_j, x_j+1)
    Nf = np.stack([np.bincount(owner, weights=Nt[:, d], minlength=sizes.size) for d in range(3)], 1)
    scale = np.bincount(owner, weights=((Xc[nxt] - Xc) ** 2).sum(axis=1)) / sizes
    refuse_degenerate(
        ~(np.linalg.norm(Nf, axis=1) > DEGENERATE_RTOL * scale),
        "face",
        lambda f: f"vertices {face_indices[face_offsets[f] : face_offsets[f + 1]].tolist()}",
        "area",
    )
    return owner, nxt, c, Nt, Nf


def cell_geometry(mesh):
    """Volumes and per (cell, vertex) Green-Gauss coefficients of a mesh whose faces have their
    geometry (:func:`face_geometry`) and their orientation ``mesh.cell_face_signs``.

    A cell whose faces all point inward has its signs flipped, in place in
    ``mesh.cell_face_signs``.

    Returns
    -------
    volumes : ndarray of shape (n_elements,)
    pair_grads : ndarray of shape (n_pairs, 3)
        The gradient coefficient of every (cell, vertex) pair of ``mesh.cell_vertices``.

    Raises
    ------
    ValueError
        On a cell of zero volume (the message names the first such cell and its faces).

    Examples
    --------
    >>> from ndboundary.datasets import hex_grid
    >>> from ndboundary.domains.polyhedral_geometry import cell_geometry
    >>> volumes, grads = cell_geometry(hex_grid(1))  # the cube [-1, 1]^3
    >>> volumes.round(12).tolist(), grads.shape
    ([8.0], (8, 3))
    """
    cell_of_entry, entry_of_corner, corner = mesh.cell_face_entries
    E = mesh.n_elements
    centre = mesh.element_centroids()
    fo = mesh.face_owner[corner]
    s = mesh.cell_face_signs[entry_of_corner].astype(np.float64)
    cell = cell_of_entry[entry_of_corner]
    Nt = mesh.fan_areas[corner] * s[:, None]
    # signed volume of the fan surface: sum over triangles of (c_f - centre) . N_t / 3
    vol = np.bincount(cell, weights=np.einsum("ij,ij->i", mesh.face_centres[fo] - centre[cell], Nt) / 3.0, minlength=E)
    inward = vol < 0
    if inward.any():
        mesh.cell_face_signs[inward[cell_of_entry]] *= -1
        vol[inward] *= -1
        s = mesh.cell_face_signs[entry_of_corner].astype(np.float64)
        Nt = mesh.fan_areas[corner] * s[:, None]
    cv, vv = mesh.cell_vertices
    starts = np.r_[0, np.flatnonzero(np.diff(cv)) + 1]  # cell_vertices is sorted by cell
    ext = np.maximum.reduceat(mesh.points[vv], starts, axis=0) - np.minimum.reduceat(mesh.points[vv], starts, axis=0)
    scale = np.linalg.norm(ext, axis=1) ** 3
    refuse_degenerate(
        ~(vol > DEGENERATE_RTOL * scale),
        "cell",
        lambda c: f"faces {mesh.cell_faces[mesh.cell_offsets[c] : mesh.cell_offsets[c + 1]].tolist()}",
        "volume",
        "cells",
    )
    # vertex j of a face gets (N_{t,j-1} + N_{t,j}) / 3 + N_f / (3 m)
    prev_corner = np.empty_like(mesh.face_next)
    prev_corner[mesh.face_next] = np.arange(mesh.face_next.size)
    m = np.diff(mesh.face_offsets)[fo]
    Nf = mesh.face_areas[fo] * s[:, None]
    coef = (Nt + mesh.fan_areas[prev_corner[corner]] * s[:, None]) / 3.0 + Nf / (3.0 * m[:, None])
    coef /= vol[cell, None]
    inv, n_pairs = group_rows(np.stack([cell, mesh.face_indices[corner]], axis=1))
    g = np.stack([np.bincount(inv, weights=coef[:, d], minlength=n_pairs) for d in range(3)], 1)
    return vol, g
