"""The formats read and written through meshio: PLY, STL, MEDIT, Gmsh, VTK and VTU.

meshio (``meshio>=5.3``, the ``io`` extra) is imported on the first use of one of
these formats, so that OBJ, OFF and HEDRA work without it. :func:`vtk_values` gives
data arrays the types VTK files hold, :data:`SIMPLEX_KINDS` the cell type of a
simplex, and :func:`check_simplices_format` whether a results file holds it, for the
writers of results and the command line's checks before any work.
"""

from __future__ import annotations

import codecs
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

from .cell_blocks import CELL_DIMENSIONS
from .common import non_finite_error, plural, points_3d

__all__ = [
    "MESHIO_EXTENSIONS",
    "SIMPLEX_KINDS",
    "WRITABLE_KINDS",
    "check_simplices_format",
    "holds_simplices",
    "read_with_meshio",
    "vtk_values",
    "write_with_meshio",
]

#: The block kinds every meshio format can hold (``"polyhedron"`` for any ``"polyhedron<n>"``).
WRITABLE_KINDS = {
    ".stl": {"triangle"},
    ".ply": {"triangle", "quad", "polygon", "line"},
    ".mesh": {"line", "triangle", "quad", "tetra", "hexahedron"},
    ".msh": {"line", "triangle", "quad", "tetra", "hexahedron"},
    ".vtk": {"line", "triangle", "quad", "polygon", "tetra", "hexahedron"},
    ".vtu": {"line", "triangle", "quad", "polygon", "tetra", "hexahedron", "polyhedron"},
}
#: The extensions of the formats read and written through meshio.
MESHIO_EXTENSIONS = set(WRITABLE_KINDS)
#: The block kind of a simplex of k + 1 vertices, by k + 1.
SIMPLEX_KINDS = {2: "line", 3: "triangle", 4: "tetra"}

#: The simplices of level sets and interfaces each format of the results' writers holds
#: (``.vtk`` and ``.vtu`` hold every kind).
_SIMPLICES_HELD = {".obj": ("line", "triangle"), ".ply": ("line", "triangle"), ".stl": ("triangle",),
                   ".vtp": ("line", "triangle")}  # fmt: skip


def holds_simplices(ext, kind):
    """Whether a results file of extension ``ext`` holds simplices of ``kind`` (a value of
    :data:`SIMPLEX_KINDS`).

    Examples
    --------
    >>> holds_simplices(".stl", "triangle"), holds_simplices(".obj", "tetra"), holds_simplices(".vtu", "tetra")
    (True, False, True)
    """
    return kind in _SIMPLICES_HELD.get(ext, (kind,))


def check_simplices_format(path, ext, kind, curve="a curve"):
    """Raise when the results file ``path`` (extension ``ext``) cannot hold simplices of
    ``kind``; ``curve`` names segments in the message of STL.

    Raises
    ------
    ValueError
        Naming the file and the formats that hold them.
    """
    if holds_simplices(ext, kind):
        return
    if ext == ".stl":
        what = curve if kind == "line" else "tetrahedra"
        raise ValueError(f"{path}: STL holds triangles, not {what}; use .obj, .ply, .vtk, .vtp or .vtu")
    raise ValueError(f"{path}: the {ext} format cannot hold tetrahedra; use .vtu or .vtk")


def _import_meshio():
    try:
        import meshio
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("reading and writing this format needs meshio: pip install 'meshio>=5.3'") from None
    return meshio


def read_with_meshio(path):
    """Read a file with meshio, as points and cell blocks.

    Cells of types the domains do not use (vertices, quadratic cells) are left out. A
    text file's leading UTF-8 byte-order mark is skipped.

    Parameters
    ----------
    path : path-like
        Any format meshio reads; the extension picks it.

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        meshio's cell types, polygons of any size as ``"polygon"`` blocks and general
        polyhedra as ``"polyhedron"`` blocks (see :mod:`ndboundary.io.cell_blocks`).

    Raises
    ------
    ValueError
        When meshio cannot read the file (its error is quoted), a cell lists a vertex
        index outside the file's vertices (numbered as the file numbers them: from 1 in
        MEDIT files, where meshio turns a ``0`` into -1) or a coordinate is NaN or infinite.
    ImportError
        When meshio is not installed.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.vtu")
    ...     meshio.write(path, meshio.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [("triangle", [[0, 1, 2]])]))
    ...     points, blocks = read_with_meshio(path)
    >>> points.shape, [(kind, data.tolist()) for kind, data in blocks]
    ((3, 3), [('triangle', [[0, 1, 2]])])
    """
    meshio = _import_meshio()
    m = _meshio_read(meshio, path)
    points = np.asarray(m.points)
    if points.ndim != 2 or points.dtype.kind not in "iuf":
        raise ValueError(f"{path}: the points read have shape {points.shape} and dtype {points.dtype}")
    points = points.astype(np.float64)
    one_based = Path(os.fspath(path)).suffix.lower() == ".mesh"
    exc = non_finite_error(path, points, lambda i: f"vertex {i + one_based}")
    if exc is not None:
        raise exc
    blocks = []
    for c in m.cells:
        t = c.type
        if t.startswith("polyhedron"):
            blocks.append(("polyhedron", c.data))
            for cell in c.data:
                for face in cell:
                    _check_indices(path, face, points.shape[0], t, one_based)
            continue
        if not (t.startswith("polygon") or t in CELL_DIMENSIONS):
            continue
        data = np.asarray(c.data)
        _check_indices(path, data, points.shape[0], t, one_based)
        if t.startswith("polygon"):
            blocks.append(("polygon", [list(r) for r in data]))
        else:
            blocks.append((t, data))
    return points, blocks


def _meshio_read(meshio, path):
    """The mesh meshio reads from a file, its errors as ValueErrors; a text file's byte-order mark is skipped."""
    with open(path, "rb") as fh:
        head = fh.read(8)
    # a binary STL starts with 80 free bytes: only an ASCII one ('solid ...') has a byte-order mark
    bom = head[:3] == codecs.BOM_UTF8 and (Path(os.fspath(path)).suffix.lower() != ".stl" or head[3:8] == b"solid")
    try:
        with warnings.catch_warnings():
            # meshio tells ASCII from binary STL by a size test that overflows on ASCII files
            warnings.filterwarnings("ignore", "overflow encountered", RuntimeWarning)
            if not bom:
                return meshio.read(os.fspath(path))
            with tempfile.TemporaryDirectory() as tmp:
                copy = Path(tmp) / Path(os.fspath(path)).name
                copy.write_bytes(Path(os.fspath(path)).read_bytes()[3:])
                return meshio.read(os.fspath(copy))
    except (Exception, SystemExit) as exc:  # meshio exits on some unreadable files
        raise ValueError(f"{path}: could not read the file: {type(exc).__name__}: {exc}") from None


def _check_indices(path, data, n, kind, one_based):
    """Raise a ValueError unless ``data`` holds integer vertex indices in ``0..n - 1``.

    meshio gives 0-based indices; for the 1-based formats (MEDIT) the message quotes the
    file's own value.
    """
    data = np.asarray(data)
    if data.size == 0:
        return
    if data.dtype.kind not in "iu":
        raise ValueError(f"{path}: {kind} cells hold {data.dtype} values, not vertex indices")
    bad = (data < 0) | (data >= n)
    if bad.any():
        cell = int(np.argwhere(bad)[0, 0]) if data.ndim > 1 else 0
        value = int(data[bad][0]) + one_based
        lo, hi = int(one_based), n - 1 + one_based
        raise ValueError(
            f"{path}: {kind} {cell + one_based} lists vertex {value}, outside the file's {plural(n, 'vertex')} "
            f"(numbered {lo}..{hi})"
        )


def _in_order(values, order):
    """``values[order]``, without the copy when ``order`` is ``0, 1, ..., len(values) - 1`` (one block)."""
    values, order = np.asarray(values), np.asarray(order)
    if order.size == values.shape[0] and np.array_equal(order, np.arange(order.size)):
        return values
    return values[order]


def vtk_values(values):
    """Numbers as an array of a type VTK files hold (native-order (u)int8..64, float32 or float64), else None.

    Booleans become uint8; arrays that are not numbers (strings, objects) give None.

    Examples
    --------
    >>> import numpy as np
    >>> vtk_values(np.array([True, False])).dtype, vtk_values(np.array([1.5], dtype=np.float16)).dtype
    (dtype('uint8'), dtype('float32'))
    >>> vtk_values(np.array(["air"])) is None
    True
    """
    kind = values.dtype.kind
    if kind == "b":
        return values.astype(np.uint8)
    if kind in "iu":
        return values.astype(np.dtype(f"{kind}{values.dtype.itemsize}"))
    if kind == "f":
        return values.astype(np.float32 if values.dtype.itemsize <= 4 else np.float64)
    return None


def write_with_meshio(path, points, blocks, *, order=None, point_data=None, cell_data=None):
    """Write points, cell blocks and data arrays with meshio.

    Parameters
    ----------
    path : path-like
        A ``.ply``, ``.stl``, ``.mesh``, ``.msh``, ``.vtk`` or ``.vtu`` file. Gmsh files
        are written in the ASCII format 2.2 (meshio's ``gmsh22``), the others in
        meshio's default encoding for the format.
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), as every one of these formats
        wants.
    blocks : list of (kind, data)
        As :func:`~ndboundary.io.cell_blocks.blocks_from_domain` gives them.
    order : list of array-like of int, optional
        Per block, the elements it holds, to split ``cell_data`` by block; needed only
        with ``cell_data``.
    point_data : dict of str to array-like, optional
        Per-vertex arrays; none by default.
    cell_data : dict of str to array-like, optional
        Per-element arrays, in element order; none by default.

    Raises
    ------
    ValueError
        When the format cannot hold a block's cells (the message suggests one that can),
        or meshio fails to write (its error is quoted).
    ImportError
        When meshio is not installed.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.vtu")
    ...     write_with_meshio(path, [[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 2]])],
    ...                       order=[[0]], cell_data={"label": [7]})
    ...     back = meshio.read(path)
    >>> back.points.tolist(), back.cell_data["label"][0].tolist()
    ([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], [7])
    """
    meshio = _import_meshio()
    ext = Path(os.fspath(path)).suffix.lower()
    kinds = {"polyhedron" if k.startswith("polyhedron") else k for k, _ in blocks}
    bad = kinds - WRITABLE_KINDS[ext]
    if bad:
        raise ValueError(
            f"{path}: the {ext} format cannot hold {', '.join(sorted(bad))} cells; "
            f"use one of {', '.join(sorted(e for e, k in WRITABLE_KINDS.items() if bad <= k) or ['.vtu'])}"
        )
    cells = [(k, np.asarray(d, dtype=np.int32) if not k.startswith("polyhedron") else d) for k, d in blocks]
    cd = {name: [_in_order(v, o) for o in order] for name, v in (cell_data or {}).items()}
    mesh = meshio.Mesh(points_3d(points), cells, point_data=point_data or {}, cell_data=cd)
    try:
        if ext == ".msh":
            meshio.write(os.fspath(path), mesh, file_format="gmsh22", binary=False)
        else:
            meshio.write(os.fspath(path), mesh)
    except Exception as exc:
        raise ValueError(f"{path}: could not write: {type(exc).__name__}: {exc}") from None
