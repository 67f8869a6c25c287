"""Reading and writing meshes: the extension picks the format module."""

from __future__ import annotations

import numpy as np

from ..domains import Domain, PolyhedralMesh, SimplicialComplex
from .cell_blocks import blocks_from_domain, check_mesh_domain, domain_from_blocks
from .common import existing_file, format_suffix
from .hedra import read_hedra, write_hedra
from .meshio_formats import MESHIO_EXTENSIONS, read_with_meshio, write_with_meshio
from .obj import read_obj, write_obj
from .off import read_off, write_off

__all__ = ["DATA_EXTENSIONS", "MESH_EXTENSIONS", "read_mesh", "write_mesh"]

_READERS = {".obj": read_obj, ".off": read_off, ".hedra": read_hedra}
#: The mesh formats read and written, by extension.
MESH_EXTENSIONS = set(_READERS) | MESHIO_EXTENSIONS
#: The mesh formats that carry per-vertex and per-element data arrays.
DATA_EXTENSIONS = (".vtu", ".vtk", ".msh", ".ply")


def read_mesh(path, *, drop_unused=True) -> Domain:
    r"""Read a mesh file into the matching domain.

    Parameters
    ----------
    path : str or path-like
        A ``.obj``, ``.off``, ``.ply``, ``.stl``, ``.mesh``, ``.msh``, ``.vtk``, ``.vtu`` or
        ``.hedra`` file (see :mod:`ndboundary.io`).
    drop_unused : bool, default=True
        Remove the vertices that no kept cell uses (they carry no measure and would
        leave the relaxation's linear systems singular), renumbering the rest in order.
        Files often hold such vertices (a HEDRA file's unused points, the boundary
        vertices of a solid's lower-dimensional cells).

    Returns
    -------
    SimplicialComplex, PolygonMesh or PolyhedralMesh
        Segments, triangles or tetrahedra alone give a SimplicialComplex; quads and
        polygons a PolygonMesh; hexahedra, wedges, pyramids and general polyhedra a
        PolyhedralMesh. Only the highest-dimensional cells of a file are kept.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist (the message quotes it).
    ValueError
        On an unknown extension, content that is not the announced format, a file with
        no cells, or invalid cells (the message names the file and the problem).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "square.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    ...     square = read_mesh(path)
    >>> square
    PolygonMesh(n_vertices=4, n_elements=1, dim=2, laplacian='consistent')
    """
    ext = format_suffix(path, MESH_EXTENSIONS, "mesh")
    path = existing_file(path)
    try:
        points, blocks = _READERS.get(ext, read_with_meshio)(path)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file: {exc}") from None
    if points.ndim != 2 or points.shape[0] == 0:
        raise ValueError(f"{path}: the file holds no vertices")
    try:
        return domain_from_blocks(points, blocks, drop_unused=drop_unused)
    except (ValueError, TypeError) as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: {exc}") from None


def _check_data(data, n, what):
    """The data arrays as a dict of str to ndarray, each checked to have ``n`` rows."""
    out = {}
    for name, values in (data or {}).items():
        arr = np.asarray(values)
        if arr.shape[:1] != (n,):
            raise ValueError(f"{what} {name!r} has shape {arr.shape}; expected {n} rows, one per {what.split('_')[0]}")
        out[str(name)] = arr
    return out


def write_mesh(path, domain, point_data=None, cell_data=None):
    """Write a domain (and optional per-vertex / per-element data) to a mesh file.

    Parameters
    ----------
    path : str or path-like
        The extension picks the format (see :mod:`ndboundary.io`). OBJ, OFF, STL,
        MEDIT and HEDRA files carry no data arrays: ``point_data`` and ``cell_data``
        need ``.vtu``, ``.vtk``, ``.msh`` or ``.ply``.
    domain : SimplicialComplex, PolygonMesh or PolyhedralMesh
        Polygon meshes of mixed sizes are written one block per polygon size, so the
        elements of the file come grouped by size; polyhedral meshes whose cells are
        all hexahedra (or all tetrahedra) are written as such, other polyhedra as VTK
        polyhedra (``.vtu`` only) or HEDRA. A tetrahedral SimplicialComplex written to
        ``.hedra`` becomes polyhedra.
    point_data : dict of str to array-like of shape (n_vertices,) or (n_vertices, k), optional
        Per-vertex arrays, written under their names; none by default, so that every
        format can hold the file.
    cell_data : dict of str to array-like of shape (n_elements,) or (n_elements, k), optional
        Per-element arrays in the domain's element order (reordered with the blocks);
        none by default.

    Raises
    ------
    ValueError
        On an unknown extension, a format that cannot hold the domain's cells or data,
        or data of the wrong length.
    TypeError
        When ``domain`` is not one of the mesh domains.

    Examples
    --------
    >>> import os, tempfile
    >>> from ndboundary import PolygonMesh
    >>> square = PolygonMesh([[0, 0], [1, 0], [1, 1], [0, 1]], [[0, 1, 2, 3]])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "square.vtu")
    ...     write_mesh(path, square, cell_data={"label": [1]})
    ...     back = read_mesh(path)
    >>> back.n_vertices, back.n_elements, float(back.A.sum())
    (4, 1, 1.0)
    """
    ext = format_suffix(path, MESH_EXTENSIONS, "mesh")
    check_mesh_domain(domain)
    point_data = _check_data(point_data, domain.n_vertices, "point_data")
    cell_data = _check_data(cell_data, domain.n_elements, "cell_data")
    if (point_data or cell_data) and ext not in DATA_EXTENSIONS:
        raise ValueError(f"{path}: the {ext} format carries no data arrays; use .vtu, .vtk, .msh or .ply")
    if ext == ".hedra":
        if isinstance(domain, SimplicialComplex) and domain.simplex_dim == 3 and domain.dim == 3:
            domain = PolyhedralMesh.from_tetrahedra(domain.points, domain.simplices)
        if not isinstance(domain, PolyhedralMesh):
            raise ValueError(f"{path}: HEDRA holds polyhedra; got a {type(domain).__name__}")
        write_hedra(path, domain)
        return
    blocks, order = blocks_from_domain(domain)
    if ext in (".obj", ".off"):
        if any(k not in ("line", "triangle", "quad", "polygon") for k, _ in blocks) or (
            ext == ".off" and blocks[0][0] == "line"
        ):
            raise ValueError(f"{path}: the {ext} format holds surfaces only; use .vtu, .mesh or .hedra for solids")
        (write_obj if ext == ".obj" else write_off)(path, domain.points, blocks)
        return
    write_with_meshio(path, domain.points, blocks, order=order, point_data=point_data, cell_data=cell_data)
