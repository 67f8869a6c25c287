"""Reading and writing meshes: the extension picks the format module."""

from __future__ import annotations

import numbers

import numpy as np

from ..domains import Domain, PolyhedralMesh, SimplicialComplex
from .cell_blocks import blocks_from_domain, check_mesh_domain, domain_from_blocks, top_blocks
from .common import existing_file, format_suffix, non_finite_error
from .hedra import read_hedra, write_hedra
from .meshio_formats import MESHIO_EXTENSIONS, read_with_meshio, write_with_meshio
from .obj import read_obj, write_obj
from .off import read_off, write_off
from .ply import read_ply
from .vtu import VTK_CELL_TYPES, write_vtu
from .weld import OPEN_EDGE_FRACTION, WeldReport, open_edge_fraction, weld_blocks, weld_map

__all__ = ["DATA_EXTENSIONS", "MESH_EXTENSIONS", "read_mesh", "write_mesh"]

_READERS = {".obj": read_obj, ".off": read_off, ".hedra": read_hedra, ".ply": read_ply}
#: The mesh formats read and written, by extension.
MESH_EXTENSIONS = set(_READERS) | MESHIO_EXTENSIONS
#: The mesh formats that carry per-vertex and per-element data arrays.
DATA_EXTENSIONS = (".vtu", ".vtk", ".msh", ".ply")


def _weld_option(weld, weld_tolerance):
    if not (isinstance(weld, (bool, np.bool_)) or (isinstance(weld, str) and weld == "auto")):
        raise ValueError(f"weld must be True, False or 'auto'; got {weld!r}")
    weld = weld if isinstance(weld, str) else bool(weld)
    if isinstance(weld_tolerance, (bool, np.bool_)) or not isinstance(weld_tolerance, numbers.Real):
        raise TypeError(f"weld_tolerance must be a number; got {type(weld_tolerance).__name__}")
    if not (np.isfinite(weld_tolerance) and weld_tolerance >= 0):
        raise ValueError(f"weld_tolerance must be a finite number >= 0; got {weld_tolerance!r}")
    return weld, float(weld_tolerance)


def _welded(points, blocks, ext, weld, weld_tolerance):
    """Points and blocks, welded when ``weld`` asks for it, and the report (None when not welded)."""
    if weld is False or points.shape[0] == 0:
        return points, blocks, None
    blocks = top_blocks(blocks)
    surface = all(k in ("triangle", "quad", "polygon") for k, _ in blocks)
    if weld == "auto" and ext != ".stl" and not (surface and open_edge_fraction(blocks) > OPEN_EDGE_FRACTION):
        return points, blocks, None
    scale = float(np.max(np.abs(points))) or 1.0  # scaled, so that the diagonal of huge boxes does not overflow
    diagonal = scale * float(np.linalg.norm(points.max(axis=0) / scale - points.min(axis=0) / scale))
    tolerance = min(weld_tolerance * diagonal, np.finfo(np.float64).max)
    mapping = weld_map(points, tolerance)
    if weld == "auto" and ext != ".stl" and mapping[1].size == points.shape[0]:
        return points, blocks, None  # open edges, but no duplicated vertices: a surface with holes
    welded, blocks, dropped = weld_blocks(points, blocks, tolerance, mapping=mapping)
    return welded, blocks, WeldReport(points.shape[0], welded.shape[0], dropped, tolerance)


def read_mesh(path, *, weld="auto", weld_tolerance=1e-9, drop_unused=True) -> Domain:
    r"""Read a mesh file into the matching domain.

    Parameters
    ----------
    path : str or path-like
        A ``.obj``, ``.off``, ``.ply``, ``.stl``, ``.mesh``, ``.msh``, ``.vtk``, ``.vtu`` or
        ``.hedra`` file (see :mod:`ndboundary.io`). Text files are read as UTF-8; a
        leading byte-order mark is skipped.
    weld : bool or "auto", default="auto"
        Merge coincident vertices: positions within ``weld_tolerance`` times the diagonal
        of the bounding box are one vertex (the first of them, vertex order kept; see
        :func:`~ndboundary.io.weld.weld_map`), and cells that become degenerate (two of
        their vertices merged) are dropped. Triangle soups, where every face has its own
        copies of its vertices, need it: without it they fall apart into one component
        per face. ``"auto"`` welds STL files (they store triangle soups) always, and
        other surface files (triangles and polygons) when more than 10% of their edges
        bound one face only and welding merges vertices; curves and solids it leaves as
        they are. False keeps the vertices of the file.
    weld_tolerance : float, default=1e-9
        The merging distance, relative to the bounding box's diagonal (0: exactly equal
        positions only).
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
        PolyhedralMesh. Only the highest-dimensional cells of a file are kept. Its
        attribute ``weld`` is a :class:`~ndboundary.io.weld.WeldReport` (vertices before
        and after, cells dropped, the absolute tolerance) when the vertices were welded,
        else None.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist (the message quotes it).
    IsADirectoryError
        When ``path`` is a directory.
    ValueError
        On an unknown extension, content that is not the announced format, header counts
        that disagree with the content, a vertex index outside the file's vertices, a NaN
        or infinite coordinate, a file with no cells, or invalid cells (the message names
        the file, the line where the format is line based, and the problem).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "square.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    ...     square = read_mesh(path)
    >>> square, square.weld
    (PolygonMesh(n_vertices=4, n_elements=1, dim=2, laplacian='consistent'), None)

    Two triangles, each with its own copy of the diagonal's vertices, welded:

    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "soup.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 4 5 6\n")
    ...     soup, apart = read_mesh(path), read_mesh(path, weld=False)
    >>> soup.n_vertices, apart.n_vertices, apart.weld
    (4, 6, None)
    >>> soup.weld.n_vertices_before, soup.weld.n_vertices_after, soup.weld.n_cells_dropped
    (6, 4, 0)
    """
    weld, weld_tolerance = _weld_option(weld, weld_tolerance)
    path = existing_file(path)
    ext = format_suffix(path, MESH_EXTENSIONS, "mesh")
    try:
        points, blocks = _READERS.get(ext, read_with_meshio)(path)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file: {exc}") from None
    if points.ndim != 2 or points.shape[0] == 0:
        raise ValueError(f"{path}: the file holds no vertices")
    exc = non_finite_error(path, points, lambda i: f"vertex {i} (0-based)")
    if exc is not None:
        raise exc
    try:
        points, blocks, report = _welded(points, blocks, ext, weld, weld_tolerance)
        domain = domain_from_blocks(points, blocks, drop_unused=drop_unused)
    except (ValueError, TypeError) as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: {exc}") from None
    domain.weld = report
    return domain


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
    if ext == ".vtu" and all(kind in VTK_CELL_TYPES for kind, _ in blocks):
        write_vtu(path, domain.points, blocks, order=order, point_data=point_data, cell_data=cell_data)
        return
    write_with_meshio(path, domain.points, blocks, order=order, point_data=point_data, cell_data=cell_data)
