"""Polyhedral meshes derived from another one, reusing its geometry.

A band, the two rings that measure the boundary weight, and a padded mesh are cut from
or split out of a mesh whose faces and cells already have their geometry. A face or a
cell that is kept has the same vertices, so its fan, vector areas, orientation, volume
and Green-Gauss coefficients are the ones already computed: only the new cells (the
pyramids of a split) are computed afresh. The derived mesh is the one a fresh build
of the same faces and cells gives, to rounding (a test checks every operator).
"""

from __future__ import annotations

import numpy as np

from .._arrays import expand_ranges, used_vertices

__all__ = ["Geometry", "pyramid_cells", "split_geometry", "sub_geometry"]


class Geometry:
    """Everything a polyhedral mesh computes when it is built, handed to a derived mesh.

    Attributes
    ----------
    face_centres, fan_areas, face_areas : ndarray
        See :func:`~ndboundary.domains.polyhedral_geometry.face_geometry`.
    cell_face_signs : ndarray of int8
    volumes : ndarray of shape (n_elements,)
    cell_vertices : tuple of two ndarray of int64
        Sorted unique (cell, vertex) pairs.
    pair_grads : ndarray of shape (n_pairs, 3)
        The Green-Gauss coefficient of every pair.
    """

    __slots__ = ("face_centres", "fan_areas", "face_areas", "cell_face_signs", "volumes", "cell_vertices", "pair_grads")

    def __init__(self, face_centres, fan_areas, face_areas, cell_face_signs, volumes, cell_vertices, pair_grads):
        self.face_centres, self.fan_areas, self.face_areas = face_centres, fan_areas, face_areas
        self.cell_face_signs, self.volumes = cell_face_signs, volumes
        self.cell_vertices, self.pair_grads = cell_vertices, pair_grads


def sub_geometry(mesh, cells):
    """The mesh of the cells ``cells`` (increasing indices) of ``mesh``, its geometry reused.

    Returns
    -------
    points, face_indices, face_offsets, cell_faces, cell_offsets : ndarray
        The submesh over the vertices it uses.
    geometry : Geometry
    vertices : ndarray of int64
        The mesh's vertex of every submesh vertex, increasing.
    """
    lens = np.diff(mesh.cell_offsets)[cells]
    entries = expand_ranges(mesh.cell_offsets[cells], lens)
    old_faces = mesh.cell_faces[entries]
    faces, face_remap = used_vertices(old_faces, mesh.n_faces)
    flens = np.diff(mesh.face_offsets)[faces]
    corners = expand_ranges(mesh.face_offsets[faces], flens)
    vertices, remap = used_vertices(mesh.face_indices[corners], mesh.n_vertices)
    fo = np.zeros(faces.size + 1, dtype=np.int64)
    np.cumsum(flens, out=fo[1:])
    co = np.zeros(cells.size + 1, dtype=np.int64)
    np.cumsum(lens, out=co[1:])
    keep = np.zeros(mesh.n_elements, dtype=bool)
    keep[cells] = True
    rank = np.cumsum(keep) - 1
    cv, vv = mesh.cell_vertices
    pairs = keep[cv]
    geometry = Geometry(
        mesh.face_centres[faces],
        mesh.fan_areas[corners],
        mesh.face_areas[faces],
        mesh.cell_face_signs[entries],
        mesh._volumes[cells],
        (rank[cv[pairs]], remap[vv[pairs]]),
        mesh._pair_grads[pairs],
    )
    return mesh.points[vertices], remap[mesh.face_indices[corners]], fo, face_remap[old_faces], co, geometry, vertices


def split_geometry(mesh, mask, pyramids, first_new):
    """The geometry of the split of ``mesh`` at ``mask`` (:func:`~.polyhedral_cells.pyramid_split`):
    the kept cells' and all the old faces' from ``mesh``, the new faces' and cells' from
    ``pyramids``, the mesh of the pyramids alone (:func:`pyramid_cells`), whose faces from
    ``first_new`` on are the new ones.
    """
    kept = ~mask
    cv, vv = mesh.cell_vertices
    pairs = kept[cv]
    rank = np.cumsum(kept) - 1
    n_keep = int(np.count_nonzero(kept))
    pc, pv = pyramids.cell_vertices
    entries = kept[mesh.cell_face_entries[0]]
    return Geometry(
        np.concatenate([mesh.face_centres, pyramids.face_centres[first_new:]]),
        np.concatenate([mesh.fan_areas, pyramids.fan_areas[pyramids.face_offsets[first_new] :]]),
        np.concatenate([mesh.face_areas, pyramids.face_areas[first_new:]]),
        np.concatenate([mesh.cell_face_signs[entries], pyramids.cell_face_signs]),
        np.concatenate([mesh._volumes[kept], pyramids._volumes]),
        (np.concatenate([rank[cv[pairs]], pc + n_keep]), np.concatenate([vv[pairs], pv])),
        np.concatenate([mesh._pair_grads[pairs], pyramids._pair_grads]),
    )


def pyramid_cells(split, n_keep, n_old):
    """The pyramids of a split (the arrays of :func:`~.polyhedral_cells.pyramid_split`) as
    their own mesh's arrays ``(face_indices, face_offsets, cell_faces, cell_offsets)`` over
    the split's points, and the number of its faces among the ``n_old`` faces of the mesh
    that was split (they come first, the new faces after them).
    """
    _, fi, fo, ci, co, _ = split
    ci_p = ci[co[n_keep] :]
    co_p = co[n_keep:] - co[n_keep]
    faces, remap = used_vertices(ci_p, fo.size - 1)
    flens = np.diff(fo)[faces]
    fo_p = np.zeros(faces.size + 1, dtype=np.int64)
    np.cumsum(flens, out=fo_p[1:])
    first_new = int(np.searchsorted(faces, n_old))
    return fi[expand_ranges(fo[faces], flens)], fo_p, remap[ci_p], co_p, first_new
