"""PLY: a reader for the common layouts, and the ASCII writer of level sets.

:func:`read_ply` reads the files that hold a ``vertex`` element (``x``, ``y``, ``z`` and
other scalar properties) and then a ``face`` element of one ``vertex_indices`` list,
itself: binary files whose faces all have the same number of vertices with numpy,
ASCII files of float vertex properties with the compiled scans of :mod:`.text_scan`.
It gives what meshio gives for them. Any other file, and any file meshio would refuse
or read differently, goes to meshio
(:func:`~ndboundary.io.meshio_formats.read_with_meshio`), whose errors are kept.

meshio's PLY writer has no edge elements (it writes segments as two-vertex faces), so
level sets are written here (:func:`write_ascii_ply`); meshes go through meshio.
"""

from __future__ import annotations

import codecs
import re

import numpy as np

from . import common
from .cell_blocks import polygon_block
from .common import points_3d
from .meshio_formats import read_with_meshio
from .text_format import points_text, rows_text
from .text_numbers import fill_slow
from .text_scan import blank_rest, float_rows, index_rows

__all__ = ["read_ply", "write_ascii_ply"]

#: The property types meshio reads, by encoding (binary: its byte layout, which reads
#: ``uchar`` as signed; ASCII: the numpy type its values are converted to).
_BINARY_TYPES = {
    "uchar": "i1", "uint": "u4", "uint8": "u1", "uint16": "u2", "uint32": "u4", "uint64": "u8",
    "int": "i4", "int8": "i1", "int32": "i4", "int64": "i8", "float": "f4", "float32": "f4", "double": "f8",
}  # fmt: skip
_ASCII_TYPES = {
    "char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "int8": "i1", "int32": "i4",
    "int64": "i8", "uint": "u4", "uint8": "u1", "uint16": "u2", "uint32": "u4", "uint64": "u8",
    "float": "f4", "float32": "f4", "float64": "f8", "double": "f8",
}  # fmt: skip
_FORMATS = {"format ascii 1.0": None, "format binary_big_endian 1.0": ">", "format binary_little_endian 1.0": "<"}
_ELEMENT = re.compile(r"element (vertex|face) ([0-9]+)")


def read_ply(path):
    """Read the vertices and faces of a PLY file as cell blocks, as meshio reads them.

    Parameters
    ----------
    path : path-like
        A leading UTF-8 byte-order mark is skipped.

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        See :func:`~ndboundary.io.meshio_formats.read_with_meshio`.

    Raises
    ------
    ValueError
        When meshio cannot read the file, a face lists a vertex index outside the file's
        vertices or a coordinate is NaN or infinite (see
        :func:`~ndboundary.io.meshio_formats.read_with_meshio`).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.ply")
    ...     write_ascii_ply(path, [[0, 0], [1, 0], [0, 1]], np.array([[0, 1, 2]]))
    ...     points, blocks = read_ply(path)
    >>> points.shape, [(kind, np.asarray(rows).tolist()) for kind, rows in blocks]
    ((3, 3), [('triangle', [[0, 1, 2]])])
    """
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:3] == codecs.BOM_UTF8:
        data = data[3:]
    fast = scan_ply_bytes(data)
    return fast if fast is not None else read_with_meshio(path)


def _lines(data):
    """The header lines as meshio reads them (``readline().decode().strip()``) and the offset after each."""
    pos = 0
    while pos < len(data):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end + 1
        try:
            line = data[pos:end].decode().strip()
        except UnicodeDecodeError:
            return
        pos = end
        yield line, pos


def _header(data):
    """``(byte order or None, vertex properties, (count type, index type), n_vertices, n_faces, body offset)``.

    None unless meshio reads the header the same way and the layout is one
    :func:`scan_ply_bytes` reads: a ``vertex`` element, then a ``face`` element of one
    ``vertex_indices`` list, properties of the types meshio knows for the encoding.
    """
    lines = _lines(data)
    first = next(lines, None)
    if first is None or first[0] != "ply":
        return None
    significant = ((line, pos) for line, pos in lines if line and line[:7] != "comment")
    line, _ = next(significant, ("", 0))
    if line not in _FORMATS:
        return None
    order = _FORMATS[line]
    types = _ASCII_TYPES if order is None else _BINARY_TYPES
    elements, line = [], next(significant, None)
    while line is not None and line[0] != "end_header":
        if line[0][:8] == "obj_info":
            line = next(significant, None)
            continue
        match = _ELEMENT.fullmatch(line[0])
        if match is None or len(elements) != (match[1] == "face"):  # a vertex element, then a face element
            return None
        properties, line = [], next(significant, None)
        while line is not None and line[0][:8] == "property":
            properties.append(line[0].split(" ")[1:])
            line = next(significant, None)
        elements.append((int(match[2]), properties))
    if line is None or len(elements) != 2:
        return None
    (nv, vertex), (nf, face) = elements
    names = [p[-1] for p in vertex]
    if any(len(p) != 2 or p[0] not in types for p in vertex) or len(set(names)) != len(names):
        return None
    if not {"x", "y", "z"} <= set(names) or len(face) != 1 or len(face[0]) != 4:
        return None
    kind, count, index, name = face[0]
    if kind != "list" or name != "vertex_indices" or count not in types or index not in types:
        return None
    return order, vertex, (types[count], types[index]), nv, nf, line[1]


def scan_ply_bytes(data):
    """The points and blocks of a PLY file's bytes (byte-order mark removed), or None to leave it to meshio."""
    header = _header(data)
    if header is None:
        return None
    order, vertex, (count, index), nv, nf, pos = header
    if nv == 0 or nf == 0 or count[0] not in "iu" or index[0] not in "iu":
        return None
    if order is None:
        if len(data) < common.FAST_MIN_BYTES:  # meshio is as quick, without loading the compiled scans
            return None
        read = _ascii_body(data, pos, vertex, count, index, nv, nf)
    else:
        read = _binary_body(data, pos, order, vertex, count, index, nv, nf)
    if read is None:
        return None
    points, flat, sizes = read
    if not np.isfinite(points).all() or flat.min() < 0 or flat.max() >= nv:
        return None
    return points, [polygon_block(flat, sizes)]


def _binary_body(data, pos, order, vertex, count, index, nv, nf):
    """Points, face indices and sizes of a binary body whose faces all have the same size, else None."""
    vertices = np.dtype([(name, order + _BINARY_TYPES[kind]) for kind, name in vertex])
    faces_at = pos + nv * vertices.itemsize
    if faces_at + nf > len(data):
        return None
    v = np.frombuffer(data, dtype=vertices, count=nv, offset=pos)
    k = int.from_bytes(data[faces_at : faces_at + int(count[1])], "little" if order == "<" else "big")
    row = np.dtype([("count", order + "u" + count[1]), ("data", order + index, (k,))])
    if k < 3 or faces_at + nf * row.itemsize != len(data):  # meshio ignores what follows the faces
        return None
    rows = np.frombuffer(data, dtype=row, count=nf, offset=faces_at)
    if not np.all(rows["count"] == k):
        return None
    points = np.column_stack([v["x"], v["y"], v["z"]]).astype(np.float64)
    return points, rows["data"].astype(np.int64).ravel(), np.full(nf, k, dtype=np.int64)


def _ascii_body(data, pos, vertex, count, index, nv, nf):
    """Points, face indices and sizes of an ASCII body of float vertex properties, ``x y z`` first, else None."""
    if [name for _, name in vertex[:3]] != ["x", "y", "z"] or any(_ASCII_TYPES[t][0] != "f" for t, _ in vertex):
        return None
    if nv - 1 > np.iinfo(index).max:
        return None
    buf = np.frombuffer(data, dtype=np.uint8)
    status, coords, pos = float_rows(buf, pos, nv, len(vertex), True)
    if status:
        return None
    status, flat, sizes, pos = index_rows(buf, pos, nf, nv, True, min(np.iinfo(count).max, 2**62))
    if status or not blank_rest(buf, pos, False):
        return None
    columns = fill_slow(coords, data).reshape(-1, 3)
    points = np.column_stack([columns[:, j].astype(_ASCII_TYPES[vertex[j][0]]) for j in range(3)])
    return points.astype(np.float64), flat, sizes


def write_ascii_ply(path, points, simplices):
    """Write segments or triangles to an ASCII PLY file.

    Parameters
    ----------
    path : path-like
    points : array-like of shape (n_points, d), d <= 3
        Written as ``double`` x, y, z (zeros appended), full precision.
    simplices : ndarray of int of shape (n, 2) or (n, 3)
        Segments become ``edge`` elements (``vertex1``, ``vertex2``), triangles ``face``
        elements (``vertex_indices``).

    Raises
    ------
    ValueError
        When the simplices are neither segments nor triangles.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "curve.ply")
    ...     write_ascii_ply(path, [[0, 0], [1, 0], [1, 1]], np.array([[0, 1], [1, 2]]))
    ...     text = open(path).read().splitlines()
    >>> text[7:10], text[-1]
    (['element edge 2', 'property int vertex1', 'property int vertex2'], '1 2')
    """
    pts = points_3d(points)
    simplices = np.asarray(simplices)
    if simplices.ndim != 2 or simplices.shape[1] not in (2, 3):
        raise ValueError(f"PLY level sets hold segments or triangles; got simplices of shape {simplices.shape}")
    segments = simplices.shape[1] == 2
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("ply\nformat ascii 1.0\ncomment written by ndboundary\n")
        fh.write(f"element vertex {pts.shape[0]}\nproperty double x\nproperty double y\nproperty double z\n")
        if segments:
            fh.write(f"element edge {simplices.shape[0]}\nproperty int vertex1\nproperty int vertex2\n")
        else:
            fh.write(f"element face {simplices.shape[0]}\nproperty list uchar int vertex_indices\n")
        fh.write("end_header\n")
        fh.write(points_text(pts, "%.17g %.17g %.17g\n"))
        if simplices.dtype.kind in "iu":
            fh.write(rows_text(simplices, with_size=not segments))
        elif segments:
            np.savetxt(fh, simplices, fmt="%d")
        else:
            np.savetxt(fh, np.concatenate([np.full((simplices.shape[0], 1), 3), simplices], axis=1), fmt="%d")
