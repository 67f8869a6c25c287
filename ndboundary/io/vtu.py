"""VTK XML unstructured grids (``.vtu``) of cells of fixed size, and polygonal data
(``.vtp``) of segments or triangles, written fast.

The file is VTK's own default layout: every array zlib-compressed in blocks, behind the
block sizes (``header_type="UInt64"``), in one raw appended section. meshio writes the
same arrays base64-encoded, compressed at zlib's default level in blocks of 32 KB on one
thread, and that compression takes most of the time of writing a relaxed mesh of a
million vertices. Here the blocks are of 256 KB, compressed at level 1 on a few threads
(zlib releases the GIL). Cells that are not of fixed size (VTK polyhedra) are left to
meshio. meshio does not write ``.vtp``, the polygonal data that ParaView and 3D Slicer
read as surfaces and curves.
"""

from __future__ import annotations

import os
import zlib
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from xml.sax.saxutils import quoteattr

import numpy as np

from .common import points_3d
from .meshio_formats import vtk_values

__all__ = ["VTK_CELL_TYPES", "write_vtp", "write_vtu"]

#: The VTK cell type of each block kind this writer holds.
VTK_CELL_TYPES = {"line": 3, "triangle": 5, "polygon": 7, "quad": 9, "tetra": 10, "hexahedron": 12}

#: Uncompressed bytes per compressed block, and zlib's compression level.
BLOCK_BYTES = 1 << 18
LEVEL = 1

_VTK_TYPES = {
    np.dtype(t): name
    for t, name in [
        (np.int8, "Int8"), (np.uint8, "UInt8"), (np.int16, "Int16"), (np.uint16, "UInt16"),
        (np.int32, "Int32"), (np.uint32, "UInt32"), (np.int64, "Int64"), (np.uint64, "UInt64"),
        (np.float32, "Float32"), (np.float64, "Float64"),
    ]
}  # fmt: skip


def _compressed(values, pool):
    """An array as VTK's compressed layout: the header of block sizes, then the blocks."""
    # the bytes, as a flat view (an empty array too: memoryview's cast refuses zeros in a shape)
    raw = memoryview(
        np.ascontiguousarray(values.astype(values.dtype.newbyteorder("<"), copy=False)).reshape(-1).view(np.uint8)
    )
    starts = range(0, max(len(raw), 1), BLOCK_BYTES)
    packed = list(pool.map(partial(zlib.compress, level=LEVEL), [raw[s : s + BLOCK_BYTES] for s in starts]))
    last = len(raw) - starts[-1]
    header = np.array([len(packed), BLOCK_BYTES, last, *map(len, packed)], dtype="<u8")
    return [header.tobytes(), *packed]


def _data_array(name, values, offset):
    attrs = f'type="{_VTK_TYPES[values.dtype]}"' + (f" Name={quoteattr(name)}" if name else "")
    if values.ndim == 2:
        attrs += f' NumberOfComponents="{values.shape[1]}"'
    return f'<DataArray {attrs} format="appended" offset="{offset}"/>'


def write_vtu(path, points, blocks, *, order=None, point_data=None, cell_data=None):
    """Write points, cell blocks of fixed size and data arrays as a ``.vtu`` file.

    Parameters
    ----------
    path : path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), as VTK wants.
    blocks : list of (kind, data)
        As :func:`~ndboundary.io.cell_blocks.blocks_from_domain` gives them; every kind
        one of :data:`VTK_CELL_TYPES`, ``data`` of shape (n_cells, n_vertices_per_cell).
    order : list of array-like of int, optional
        Per block, the elements it holds, to put ``cell_data`` in the blocks' order;
        needed only with ``cell_data`` on several blocks.
    point_data, cell_data : dict of str to ndarray, optional
        Per-vertex and per-element arrays (element order) of shape (n,) or (n, k), of
        types VTK holds (:func:`~ndboundary.io.meshio_formats.vtk_values`).

    Raises
    ------
    ValueError
        On a kind of block this writer does not hold, an array of a type VTK does not, or
        ``cell_data`` on several blocks without their ``order``.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.vtu")
    ...     write_vtu(path, [[0, 0], [1, 0], [0, 1], [1, 1]], [("triangle", [[0, 1, 2], [1, 3, 2]])],
    ...               order=[[0, 1]], point_data={"phi": np.arange(4.0)}, cell_data={"label": np.array([7, 8])})
    ...     back = meshio.read(path)
    >>> back.cells[0].data.tolist(), back.point_data["phi"].tolist(), back.cell_data["label"][0].tolist()
    ([[0, 1, 2], [1, 3, 2]], [0.0, 1.0, 2.0, 3.0], [7, 8])
    """
    bad = sorted({kind for kind, _ in blocks} - set(VTK_CELL_TYPES))
    if bad:
        raise ValueError(f"{path}: this writer holds cells of fixed size ({', '.join(VTK_CELL_TYPES)}); got {bad}")
    cells = [np.asarray(data, dtype=np.int64) for _, data in blocks]
    cells = [c if c.ndim == 2 else c.reshape(len(c), -1) for c in cells]  # (n, k), also with n = 0
    sizes = np.concatenate([np.full(len(c), c.shape[1], dtype=np.int64) for c in cells])
    kinds = [VTK_CELL_TYPES[kind] for kind, _ in blocks]
    types = np.concatenate([np.full(len(c), t, dtype=np.uint8) for t, c in zip(kinds, cells, strict=True)])
    if order is None and cell_data:
        if len(cells) > 1:
            raise ValueError(f"{path}: cell_data on {len(cells)} blocks needs their order")
        order = [np.arange(len(cells[0]))]
    cell_arrays = {}
    for name, values in (cell_data or {}).items():
        values = np.asarray(values)
        cell_arrays[name] = np.concatenate([values[np.asarray(o, dtype=np.intp)] for o in order])
    sections = {
        "PointData": dict(point_data or {}),
        "CellData": cell_arrays,
        "Points": {"": points_3d(points)},
        "Cells": {
            "connectivity": np.concatenate([c.ravel() for c in cells]),
            "offsets": np.cumsum(sizes),
            "types": types,
        },
    }
    n_points = sections["Points"][""].shape[0]
    _write_xml(path, "UnstructuredGrid", f'NumberOfPoints="{n_points}" NumberOfCells="{types.size}"', sections)


#: The section of VTK's polygonal data that holds each kind of cell ``write_vtp`` writes.
_POLYDATA_SECTIONS = {"line": "Lines", "triangle": "Polys"}


def write_vtp(path, points, kind, cells, *, point_data=None, cell_data=None):
    """Write segments or triangles and their data arrays as VTK polygonal data (``.vtp``).

    Parameters
    ----------
    path : path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), as VTK wants.
    kind : {"line", "triangle"}
        Segments (VTK's ``Lines``: a curve) or triangles (``Polys``: a surface).
    cells : array-like of int of shape (n_cells, 2) or (n_cells, 3)
    point_data, cell_data : dict of str to ndarray, optional
        Per-vertex and per-cell arrays of shape (n,) or (n, k), of types VTK holds.

    Raises
    ------
    ValueError
        On another kind of cell, cells of the wrong width, or an array of a type VTK does
        not hold.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.vtp")
    ...     write_vtp(path, [[0, 0], [1, 0], [0, 1]], "triangle", [[0, 1, 2]])
    ...     head = open(path, "rb").read(400).decode(errors="replace")
    >>> 'type="PolyData"' in head, 'NumberOfPolys="1"' in head
    (True, True)
    """
    if kind not in _POLYDATA_SECTIONS:
        raise ValueError(f"{path}: VTK polygonal data is written of {' or '.join(_POLYDATA_SECTIONS)}, not {kind!r}")
    width = 2 if kind == "line" else 3
    cells = np.asarray(cells, dtype=np.int64).reshape(-1, width)
    n = cells.shape[0]
    section = _POLYDATA_SECTIONS[kind]
    sections = {
        "PointData": dict(point_data or {}),
        "CellData": dict(cell_data or {}),
        "Points": {"": points_3d(points)},
        section: {"connectivity": cells.ravel(), "offsets": np.arange(width, width * n + 1, width, dtype=np.int64)},
    }
    counts = {name: n if name == section else 0 for name in ("Verts", "Lines", "Strips", "Polys")}
    piece = f'NumberOfPoints="{sections["Points"][""].shape[0]}" ' + " ".join(
        f'NumberOf{name}="{count}"' for name, count in counts.items()
    )
    _write_xml(path, "PolyData", piece, sections)


def _write_xml(path, data_type, piece, sections):
    """A VTK XML file of ``data_type`` with one piece of attributes ``piece``: each
    section's arrays compressed into one raw appended section.
    """
    xml, parts, offset = [], [], 0
    with ThreadPoolExecutor(min(4, os.cpu_count() or 1)) as pool:
        for section, arrays in sections.items():
            xml.append(f"<{section}>")
            for name, values in arrays.items():
                values = vtk_values(np.asarray(values))
                if values is None:
                    raise ValueError(f"{path}: array {name!r} holds no numbers; VTK files hold numbers only")
                xml.append(_data_array(name, values, offset))
                packed = _compressed(values, pool)
                parts += packed
                offset += sum(map(len, packed))
            xml.append(f"</{section}>")
    head = (
        f'<?xml version="1.0"?>\n<VTKFile type="{data_type}" version="1.0" byte_order="LittleEndian" '
        f'header_type="UInt64" compressor="vtkZLibDataCompressor">\n<{data_type}>\n'
        f"<Piece {piece}>\n" + "\n".join(xml) + f'\n</Piece>\n</{data_type}>\n<AppendedData encoding="raw">\n_'
    )
    with open(os.fspath(path), "wb") as f:
        f.write(head.encode())
        for part in parts:
            f.write(part)
        f.write(b"\n</AppendedData>\n</VTKFile>\n")
