"""Writing what a relaxation gives: ``phi`` over the domain, and level sets.

Two-region results (:class:`~ndboundary.RelaxResult`) and results of three or more
regions (:class:`~ndboundary.pipeline.result.RegionsResult`) are written by
:func:`write_phi`, which names the regions' arrays by
:func:`~ndboundary.io.regions.region_names`; :func:`write_level_set` writes any level
set (a boundary, a region's boundary) to OBJ, PLY, binary STL, VTK or VTU. The
partition and the interfaces between regions are written by :mod:`.regions`.
"""

from __future__ import annotations

import numpy as np

from .common import format_suffix, points_3d
from .meshes import write_mesh
from .meshio_formats import SIMPLEX_KINDS, check_simplices_format, vtk_values, write_with_meshio
from .obj import write_obj
from .ply import write_ascii_ply
from .regions import region_names
from .stl import write_binary_stl
from .vtu import write_vtp

__all__ = ["write_level_set", "write_phi"]


def _vtk_labels(labels, classes):
    """Labels as VTK data: numbers as :func:`.vtk_values` gives them, others as their index in ``classes``."""
    numbers = vtk_values(labels)
    if numbers is not None:
        return numbers
    classes = np.asarray(classes)
    index = np.clip(np.searchsorted(classes, labels), 0, classes.size - 1)
    missing = classes[index] != labels
    if missing.any():
        first = int(np.flatnonzero(missing)[0])
        value = labels[first : first + 1].tolist()[0]
        raise ValueError(f"labels[{first}] = {value!r} is not one of the result's classes")
    return index.astype(np.int64)


def write_phi(path, result, labels=None):
    """Write a relaxation result for ParaView: the domain with the relaxed functions as point data.

    A two-region result (:class:`~ndboundary.RelaxResult`) gives the point data ``phi``
    and ``u`` (the heat). A result of three or more regions gives one scalar array per
    region, ``phi_<name>`` with the names of :func:`region_names` (``phi_0``,
    ``phi_bone``): column ``r`` of ``result.phi`` is the array of region ``r``.
    Separate scalars rather than one array of ``n_regions`` components, since ParaView's
    Contour and Threshold filters take single-component arrays: the contour 1/2 of
    ``phi_<name>`` is that region's relaxed boundary.

    Parameters
    ----------
    path : str or path-like
        ``.vtu`` (or ``.vtk``).
    result : RelaxResult or RegionsResult
        What :func:`~ndboundary.relax` returned.
    labels : array-like, optional
        The labels given to :func:`~ndboundary.relax`, written as cell data ``labels``
        (element labels) or point data ``labels`` (vertex labels): integers and floats as
        they are (in the nearest type VTK has), booleans as 0 and 1, and labels that are
        not numbers (strings, objects) as their region index, their position in
        ``result.classes``. None (the default) writes no labels. When the domain of a
        two-region result was not padded, the unit field and the smoothed field are
        written as cell data too.

    Returns
    -------
    str
        The file's lower-case extension.

    Raises
    ------
    ValueError
        On another extension, labels of the wrong length, or labels that are not numbers
        and not among ``result.classes``.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import circle, kuhn_grid, label_by
    >>> grid = kuhn_grid(8, 2)
    >>> labels = label_by(grid, circle)
    >>> result = relax(grid, labels, on="elements")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "phi.vtu")
    ...     _ = write_phi(path, result, labels=labels)
    ...     back = meshio.read(path)
    >>> sorted(back.point_data), sorted(back.cell_data)
    (['phi', 'u'], ['labels'])

    Three regions, labelled by name:

    >>> x = grid.element_centroids()[:, 0]
    >>> tissue = np.where(x < -0.3, "air", np.where(x < 0.3, "fat", "bone"))
    >>> result = relax(grid, tissue, on="elements")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "phi.vtu")
    ...     _ = write_phi(path, result, labels=tissue)
    ...     back = meshio.read(path)
    >>> sorted(back.point_data), np.unique(back.cell_data["labels"][0]).tolist()
    (['phi_air', 'phi_bone', 'phi_fat'], [0, 1, 2])
    """
    ext = format_suffix(path, {".vtu", ".vtk"}, "phi (VTK)")
    domain = result.domain
    phi = np.asarray(result.phi)
    if phi.ndim == 2:
        point_data = {f"phi_{name}": phi[:, r] for r, name in enumerate(region_names(result.classes))}
    else:
        point_data = {"phi": phi, "u": result.u}
    cell_data = {}
    if labels is not None:
        labels = _vtk_labels(np.asarray(labels), result.classes)
        on = result.params.get("on", "elements")
        (cell_data if on == "elements" else point_data)["labels"] = labels
    field = getattr(result, "field", None)
    if field is not None and field.shape[0] == domain.n_elements:
        cell_data["field"] = points_3d(field)
        cell_data["smoothed_field"] = points_3d(result.smoothed_field)
    write_mesh(path, domain, point_data=point_data, cell_data=cell_data)
    return ext


def write_level_set(path, level_set):
    """Write a level set (segments, triangles or tetrahedra) to OBJ, PLY, STL, VTK, VTP or VTU.

    Parameters
    ----------
    path : str or path-like
    level_set : LevelSet
        E.g. ``result.level_set()`` or ``result.region_boundary(r)``. Curves are written
        as line segments (OBJ ``l`` lines, PLY ``edge`` elements), surfaces as triangles.
        STL, the format of 3-D printing, holds triangles only: surfaces are written as
        binary STL (float32 coordinates, the triangles' unit normals). VTP is VTK's
        polygonal data, which ParaView and 3D Slicer open as a curve or a surface.

    Raises
    ------
    ValueError
        On another extension, curves or tetrahedra to STL, or tetrahedra (3-D level sets
        of 4-D domains) to OBJ, PLY or VTP.

    Examples
    --------
    >>> import os, tempfile
    >>> from ndboundary import marching_simplices, read_mesh
    >>> from ndboundary.datasets import kuhn_grid
    >>> grid = kuhn_grid(4, 2)
    >>> line = marching_simplices(grid.points, grid.simplices, grid.points[:, 0], 0.1)
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "line.obj")
    ...     write_level_set(path, line)
    ...     back = read_mesh(path)
    >>> back.simplex_dim, back.n_elements == line.n_simplices
    (1, True)
    """
    ext = format_suffix(path, {".obj", ".ply", ".stl", ".vtk", ".vtp", ".vtu"}, "level set")
    k = level_set.simplices.shape[1]
    kind = SIMPLEX_KINDS.get(k)
    if kind is None:
        raise ValueError(f"{path}: cannot write a level set made of {k - 1}-simplices")
    check_simplices_format(path, ext, kind)
    if ext == ".obj":
        write_obj(path, level_set.points, [(kind, level_set.simplices)])
    elif ext == ".ply":
        write_ascii_ply(path, level_set.points, level_set.simplices)
    elif ext == ".stl":
        write_binary_stl(path, level_set.points, level_set.simplices)
    elif ext == ".vtp":
        write_vtp(path, level_set.points, kind, level_set.simplices)
    else:
        write_with_meshio(path, level_set.points, [(kind, level_set.simplices)])
