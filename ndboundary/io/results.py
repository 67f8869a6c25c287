"""Writing what a relaxation gives: ``phi`` over the domain, and level sets."""

from __future__ import annotations

import numpy as np

from .common import format_suffix, points_3d
from .meshes import write_mesh
from .meshio_formats import write_with_meshio
from .obj import write_obj
from .ply import write_ascii_ply

__all__ = ["write_level_set", "write_phi"]


def _vtk_labels(labels, classes):
    """Labels as an array of a type VTK files hold: native-order (u)int8..64, float32 or float64."""
    kind = labels.dtype.kind
    if kind == "b":
        return labels.astype(np.uint8)
    if kind in "iu":
        return labels.astype(np.dtype(f"{kind}{labels.dtype.itemsize}"))
    if kind == "f":
        return labels.astype(np.float32 if labels.dtype.itemsize <= 4 else np.float64)
    return (labels == classes[1]).astype(np.int64)


def write_phi(path, result, labels=None):
    """Write a relaxation result for ParaView: the domain with ``phi`` and ``u`` as point data.

    Parameters
    ----------
    path : str or path-like
        ``.vtu`` (or ``.vtk``).
    result : RelaxResult
        What :func:`~ndboundary.relax` returned.
    labels : array-like, optional
        The labels given to :func:`~ndboundary.relax`, written as cell data ``labels``
        (element labels) or point data ``labels`` (vertex labels): integers and floats as
        they are (in the nearest type VTK has), booleans as 0 and 1, and labels that are
        not numbers (strings, objects) as the region index, 1 for ``result.classes[1]``
        and 0 otherwise. None (the
        default) writes no labels. When the domain was not padded, the unit field and
        the smoothed field are written as cell data too.

    Returns
    -------
    str
        The file's lower-case extension.

    Raises
    ------
    ValueError
        On another extension or labels of the wrong length.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
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
    """
    ext = format_suffix(path, {".vtu", ".vtk"}, "phi (VTK)")
    domain = result.domain
    point_data = {"phi": result.phi, "u": result.u}
    cell_data = {}
    if labels is not None:
        labels = _vtk_labels(np.asarray(labels), result.classes)
        on = result.params.get("on", "elements")
        (cell_data if on == "elements" else point_data)["labels"] = labels
    if result.field.shape[0] == domain.n_elements:
        cell_data["field"] = points_3d(result.field)
        cell_data["smoothed_field"] = points_3d(result.smoothed_field)
    write_mesh(path, domain, point_data=point_data, cell_data=cell_data)
    return ext


def write_level_set(path, level_set):
    """Write a level set (segments, triangles or tetrahedra) to ``.obj``, ``.ply``, ``.vtk`` or ``.vtu``.

    Parameters
    ----------
    path : str or path-like
    level_set : LevelSet
        E.g. ``result.level_set()``. Curves are written as line segments (OBJ ``l``
        lines, PLY ``edge`` elements), surfaces as triangles.

    Raises
    ------
    ValueError
        On another extension, or tetrahedra (3-D level sets of 4-D domains) to OBJ or PLY.

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
    ext = format_suffix(path, {".obj", ".ply", ".vtk", ".vtu"}, "level set")
    k = level_set.simplices.shape[1]
    kind = {2: "line", 3: "triangle", 4: "tetra"}.get(k)
    if kind is None:
        raise ValueError(f"{path}: cannot write a level set made of {k - 1}-simplices")
    if kind == "tetra" and ext in (".obj", ".ply"):
        raise ValueError(f"{path}: the {ext} format cannot hold tetrahedra; use .vtu or .vtk")
    if ext == ".obj":
        write_obj(path, level_set.points, [(kind, level_set.simplices)])
    elif ext == ".ply":
        write_ascii_ply(path, level_set.points, level_set.simplices)
    else:
        write_with_meshio(path, level_set.points, [(kind, level_set.simplices)])
