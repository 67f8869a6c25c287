"""Wavefront OBJ: vertices, faces (``f``) and polylines (``l``).

:func:`read_obj` scans large files in one compiled pass (:func:`~.text_scan.scan_obj`);
a file the scan does not read in full (a malformed line, a token that is not a plain
number, non-ASCII text on a ``v``, ``f`` or ``l`` line) is read again line by line by
:func:`read_obj_lines`, which raises the errors with the line's number. Both give the
same points and cells.
"""

from __future__ import annotations

import numpy as np

from . import common
from .cell_blocks import polygon_block
from .common import file_bytes, flat_rows, non_finite_error, points_3d
from .text_format import points_text, rows_text
from .text_numbers import fill_slow
from .text_scan import scan_obj

__all__ = ["read_obj", "read_obj_lines", "write_obj"]


def _vertex_indices(tokens, n_so_far, path, line_no):
    """0-based vertex indices of OBJ tokens ``v``, ``v/vt``, ``v//vn``, ``v/vt/vn``.

    OBJ indices are 1-based; negative ones count back from the last vertex defined so
    far (-1 is that vertex). Positive indices are checked against the file's vertex
    count once it is read; relative ones here.
    """
    out = []
    for tok in tokens:
        i = int(tok.split("/", 1)[0])
        if i > 0:
            out.append(i - 1)
        elif i < 0 and -i <= n_so_far:
            out.append(n_so_far + i)
        elif i == 0:
            raise ValueError(f"{path}: line {line_no}: vertex index 0; OBJ vertex indices start at 1")
        else:
            raise ValueError(
                f"{path}: line {line_no}: relative vertex index {i} reaches before the first vertex "
                f"(the {n_so_far} vertices defined so far take -1..-{n_so_far})"
            )
    return out


def _points(coords, v_lines, path):
    """The vertex coordinates as an (n, 3) array, checked to be finite and of one width."""
    if not coords:
        return np.zeros((0, 3))
    widths = np.array([len(c) for c in coords])
    if np.any(widths != widths[0]):  # 2-D files (``v x y`` throughout) are read with z = 0
        i = int(np.flatnonzero(widths != widths[0])[0])
        raise ValueError(
            f"{path}: line {v_lines[i]}: a vertex with {widths[i]} coordinates; line {v_lines[0]} has {widths[0]}"
        )
    points = points_3d(np.array(coords, dtype=np.float64))
    exc = non_finite_error(path, points, lambda i: f"vertex {i + 1}", lambda i: v_lines[i])
    if exc is not None:
        raise exc
    return points


def read_obj(path):
    r"""Read the vertices and the faces (else the polylines) of an OBJ file as cell blocks.

    Texture coordinates, normals, groups and materials are ignored. Faces come as one
    block (``"triangle"`` or ``"quad"`` arrays when all faces have three or all four
    vertices, else a ``"polygon"`` list); a file without faces gives its polylines as a
    ``"line"`` array of segments, one per pair of consecutive vertices of each ``l`` line.

    Parameters
    ----------
    path : path-like
        Read as UTF-8; a leading byte-order mark is dropped.

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        See :mod:`ndboundary.io.cell_blocks`; empty when the file has neither.

    Raises
    ------
    ValueError
        On a line that is not valid OBJ, a face of fewer than three vertices, a vertex
        index outside the file's vertices (1-based; negative ones counting back from the
        last vertex defined so far) or a coordinate that is NaN or infinite; the message
        names the file, the line and the value.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "l.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3\n")
    ...     points, blocks = read_obj(path)
    >>> points.shape, [(kind, rows.tolist()) for kind, rows in blocks]
    ((3, 3), [('line', [[0, 1], [1, 2]])])
    """
    data = file_bytes(path)
    fast = scan_obj_bytes(data) if len(data) >= common.FAST_MIN_BYTES else None
    if fast is not None:
        return fast
    points, blocks = read_obj_lines(path)
    return points, [
        ("line", np.array(rows, dtype=np.int64).reshape(-1, 2)) if kind == "line" else polygon_block(*flat_rows(rows))
        for kind, rows in blocks
    ]


def scan_obj_bytes(data):
    """The points and blocks of an OBJ file's bytes (byte-order mark removed), or None when the scan defers.

    The scan defers on anything :func:`read_obj_lines` would refuse, and on what it
    does not read itself (see :mod:`.text_scan`), so that its errors keep their lines.
    """
    status, coords, flat, sizes, kinds = scan_obj(np.frombuffer(data, dtype=np.uint8))
    if status:
        return None
    coords = fill_slow(coords, data)
    if not np.isfinite(coords).all():
        return None
    points = coords.reshape(-1, 3)
    faces = kinds == ord("f")
    if faces.any():
        if not faces.all():
            flat, sizes = flat[np.repeat(faces, sizes)], sizes[faces]
        return points, [polygon_block(flat, sizes)]
    ends = np.repeat(np.cumsum(sizes), sizes)
    first = np.flatnonzero(np.arange(flat.size) + 1 < ends)  # every vertex but the last of its line
    segments = np.stack([flat[first], flat[first + 1]], axis=1)
    return points, [("line", segments)] if segments.size else []


def read_obj_lines(path):
    r"""Read an OBJ file line by line, as :func:`read_obj` does (with lists of rows for cells).

    The reference reader: :func:`read_obj` falls back on it for the files its scan does
    not read in full. Texture coordinates, normals, groups and materials are ignored.
    Faces come as one ``"polygon"`` block; a file without faces gives its polylines as a
    ``"line"`` block of segments, one per pair of consecutive vertices of each ``l`` line.

    Takes and returns what :func:`read_obj` does (with lists of rows), and raises its
    errors, naming the file, the line and the value.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "l.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3\n")
    ...     points, blocks = read_obj_lines(path)
    >>> points.shape, blocks
    ((3, 3), [('line', [(0, 1), (1, 2)])])
    """
    coords, v_lines, faces, lines = [], [], [], []
    ahead = []  # (line number, largest index) of rows indexing past the vertices defined so far
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        for line_no, line in enumerate(fh, 1):
            parts = line.split()
            if not parts or parts[0] not in ("v", "f", "l"):
                continue
            key = parts[0]
            try:
                if key == "v":
                    if len(parts) < 3:  # x y z, optionally w or a colour; 2-D files have x y
                        raise ValueError
                    coords.append([float(t) for t in parts[1:4]])
                    v_lines.append(line_no)
                    continue
                idx = _vertex_indices(parts[1:], len(coords), path, line_no)
            except ValueError as exc:
                if str(exc).startswith(str(path)):
                    raise
                raise ValueError(f"{path}: line {line_no} is not valid OBJ: {line.strip()[:80]!r}") from None
            if idx and max(idx) >= len(coords):
                ahead.append((line_no, max(idx)))
            if key == "f":
                if len(idx) < 3:
                    raise ValueError(f"{path}: line {line_no}: a face needs at least 3 vertices; got {len(idx)}")
                faces.append(idx)
            else:
                lines.extend(zip(idx[:-1], idx[1:], strict=True))
    points = _points(coords, v_lines, path)
    for line_no, i in ahead:
        if i >= points.shape[0]:
            raise ValueError(
                f"{path}: line {line_no}: vertex index {i + 1} is past the last vertex "
                f"(the file defines {points.shape[0]}, indexed 1..{points.shape[0]})"
            )
    if faces:
        return points, [("polygon", faces)]
    return points, [("line", lines)] if lines else []


def write_obj(path, points, blocks):
    """Write points and cell blocks to an OBJ file: ``"line"`` blocks as ``l`` lines, others as ``f`` faces.

    Parameters
    ----------
    path : path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), full double precision.
    blocks : list of (kind, rows)
        Segments, triangles, quads or polygons (0-based; the file is 1-based).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.obj")
    ...     write_obj(path, [[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 2]])])
    ...     print(open(path).read(), end="")
    # written by ndboundary
    v 0 0 0
    v 1 0 0
    v 0 1 0
    f 1 2 3
    """
    pts = points_3d(points)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("# written by ndboundary\n")
        fh.write(points_text(pts, "v %.17g %.17g %.17g\n"))
        for kind, rows in blocks:
            fh.write(rows_text(rows, base=1, prefix="l " if kind == "line" else "f "))
