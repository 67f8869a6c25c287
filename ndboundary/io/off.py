"""Object File Format (OFF): vertices and polygons of any size.

meshio's OFF support is triangles only, so OFF is read and written here. Large files
are read by compiled scans of their vertex and face rows (:mod:`.text_scan`); a file
they do not read in full is read again line by line by :func:`read_off_lines`, which
raises the errors with the line's number. Both give the same points and faces.
"""

from __future__ import annotations

import numpy as np

from . import common
from .cell_blocks import polygon_block
from .common import (
    file_bytes,
    flat_rows,
    float_tokens,
    int_tokens,
    non_finite_error,
    plural,
    points_3d,
    uncommented_lines,
)
from .text_format import points_text, rows_text
from .text_numbers import fill_slow
from .text_scan import blank_rest, float_rows, index_rows

__all__ = ["read_off", "read_off_lines", "write_off"]

#: The lines :func:`scan_off_bytes` looks through for the header before leaving the file to the line reader.
_HEADER_LINES = 1000


def _header(rows, path):
    """The vertex and face counts of an OFF file and the rows after the header."""
    if not rows or not rows[0][1][0].upper().endswith("OFF"):
        raise ValueError(f"{path}: not an OFF file (the first line should be 'OFF')")
    if len(rows[0][1]) > 1:  # the counts follow 'OFF' on its line
        (line_no, head), rest = (rows[0][0], rows[0][1][1:]), rows[1:]
    elif len(rows) > 1:
        (line_no, head), rest = rows[1], rows[2:]
    else:
        raise ValueError(f"{path}: malformed OFF content: no 'n_vertices n_faces n_edges' line after 'OFF'")
    if len(head) < 2:
        raise ValueError(f"{path}: malformed OFF content: line {line_no} should be 'n_vertices n_faces n_edges'")
    nv, nf = int_tokens(head[:2], [line_no] * 2, path, "OFF header count")
    if nv < 0 or nf < 0:
        raise ValueError(f"{path}: line {line_no}: the OFF header counts {head[0]} vertices and {head[1]} faces")
    return int(nv), int(nf), rest


def _faces(rows, nv, path):
    """The 0-based vertex lists of OFF face rows ``k i_1 ... i_k`` (trailing colour values ignored)."""
    line_nos = np.array([no for no, _ in rows], dtype=np.int64)
    sizes = int_tokens([t[0] for _, t in rows], line_nos, path, "face size")
    for (no, toks), k in zip(rows, sizes, strict=True):
        if k < 3:
            raise ValueError(f"{path}: line {no}: a face needs at least 3 vertices; got a face of {toks[0]}")
        if len(toks) < k + 1:
            raise ValueError(f"{path}: line {no}: a face of {k} vertices lists {len(toks) - 1}")
    tokens = [t for (_, toks), k in zip(rows, sizes, strict=True) for t in toks[1 : 1 + k]]
    token_lines = np.repeat(line_nos, sizes)
    flat = int_tokens(tokens, token_lines, path, "vertex index")
    bad = np.flatnonzero((flat < 0) | (flat >= nv))
    if bad.size:
        i = int(bad[0])
        raise ValueError(
            f"{path}: line {token_lines[i]}: vertex index {tokens[i][:40]} is outside the file's "
            f"{plural(nv, 'vertex')} (OFF indices are 0-based: 0..{nv - 1})"
        )
    return [r.tolist() for r in np.split(flat, np.cumsum(sizes)[:-1])]


def read_off(path):
    r"""Read the vertices and polygons of an OFF file as cell blocks.

    The first line is ``OFF`` (or a variant ending in it, such as ``COFF``), followed,
    on the same line or the next, by ``n_vertices n_faces n_edges``; then the vertices,
    one a line, and the faces ``k i_1 ... i_k`` (0-based), one a line. Trailing per-line
    values (colours) and ``#`` comments are ignored.

    Parameters
    ----------
    path : path-like
        Read as UTF-8; a leading byte-order mark is dropped.

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        One block (``"triangle"`` or ``"quad"`` arrays when all faces have three or all
        four vertices, else a ``"polygon"`` list), or none when the file has no faces.

    Raises
    ------
    ValueError
        When the file does not start with ``OFF``, its content is malformed, it holds
        fewer or more lines than its header announces, a vertex index is outside
        ``0..n_vertices - 1`` or a coordinate is NaN or infinite (the message names the
        file, the line and the value).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.off")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    ...     points, blocks = read_off(path)
    >>> points.shape, [(kind, rows.tolist()) for kind, rows in blocks]
    ((3, 3), [('triangle', [[0, 1, 2]])])
    """
    data = file_bytes(path)
    fast = scan_off_bytes(data) if len(data) >= common.FAST_MIN_BYTES else None
    if fast is not None:
        return fast
    points, blocks = read_off_lines(path)
    return points, [polygon_block(*flat_rows(rows)) for _, rows in blocks]


def _line_bounds(data, pos):
    """Where the line starting at ``pos`` ends, and where the next one starts (universal newlines)."""
    nl = data.find(b"\n", pos)
    cr = data.find(b"\r", pos, nl if nl >= 0 else len(data))
    if cr >= 0:
        return cr, cr + 2 if data[cr + 1 : cr + 2] == b"\n" else cr + 1
    return (nl, nl + 1) if nl >= 0 else (len(data), len(data))


def _scan_header(data):
    """The vertex and face counts of an OFF file and where its body starts, or None to leave it to the line reader.

    The first lines are read as :func:`read_off_lines` reads them (cut at ``#``, split
    on blanks, empty ones skipped); the counts must be plain non-negative integers.
    """
    rows, pos = [], 0
    for _ in range(_HEADER_LINES):
        if pos >= len(data):
            return None
        start = pos
        end, pos = _line_bounds(data, pos)
        text = data[start:end].split(b"#", 1)[0]
        if not text.isascii():
            return None
        tokens = text.decode("ascii").split()
        if tokens:
            rows.append(tokens)
        if len(rows) == 2 or (rows and len(rows[0]) > 1):
            break
    else:
        return None
    if not rows[0][0].upper().endswith("OFF"):
        return None
    head = rows[0][1:] if len(rows[0]) > 1 else rows[1]
    if len(head) < 2 or not (head[0].isdigit() and head[1].isdigit()):
        return None
    nv, nf = int(head[0]), int(head[1])
    if nv + nf > len(data):  # every row takes two bytes at least
        return None
    return nv, nf, pos


def scan_off_bytes(data):
    """The points and blocks of an OFF file's bytes (byte-order mark removed), or None when the scans defer.

    They defer on anything :func:`read_off_lines` would refuse, and on what they do not
    read themselves (see :mod:`.text_scan`), so that its errors keep their lines.
    """
    header = _scan_header(data)
    if header is None:
        return None
    nv, nf, pos = header
    buf = np.frombuffer(data, dtype=np.uint8)
    status, coords, pos = float_rows(buf, pos, nv, 3, False)
    if status:
        return None
    coords = fill_slow(coords, data)
    if not np.isfinite(coords).all():
        return None
    blocks = []
    if nf:
        status, flat, sizes, pos = index_rows(buf, pos, nf, nv, False, 2**62)
        if status:
            return None
        blocks = [polygon_block(flat, sizes)]
    if not blank_rest(buf, pos, True):  # more rows than the header announces
        return None
    return coords.reshape(-1, 3), blocks


def read_off_lines(path):
    r"""Read an OFF file line by line, as :func:`read_off` does (with a list of rows for the faces).

    The reference reader: :func:`read_off` falls back on it for the files its scans do
    not read in full.

    The first line is ``OFF`` (or a variant ending in it, such as ``COFF``), followed,
    on the same line or the next, by ``n_vertices n_faces n_edges``; then the vertices,
    one a line, and the faces ``k i_1 ... i_k`` (0-based), one a line. Trailing per-line
    values (colours) and ``#`` comments are ignored.

    Takes and returns what :func:`read_off` does (with a ``"polygon"`` block of row
    lists), and raises its errors, naming the file, the line and the value.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.off")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    ...     points, blocks = read_off_lines(path)
    >>> points.shape, blocks
    ((3, 3), [('polygon', [[0, 1, 2]])])
    """
    rows = [(no, ln.split()) for no, ln in enumerate(uncommented_lines(path), 1)]
    nv, nf, rest = _header([(no, t) for no, t in rows if t], path)
    if len(rest) < nv + nf:
        raise ValueError(
            f"{path}: the OFF header announces {plural(nv, 'vertex')} and {plural(nf, 'face')} ({nv + nf} lines), "
            f"but only {len(rest)} lines follow it: the file is shorter"
        )
    if len(rest) > nv + nf:
        raise ValueError(
            f"{path}: the OFF header announces {plural(nf, 'face')}, but {len(rest) - nv} lines follow "
            f"its {plural(nv, 'vertex')}"
        )
    vertex_rows = rest[:nv]
    for no, toks in vertex_rows:
        if len(toks) < 3:
            raise ValueError(f"{path}: line {no}: a vertex needs 3 coordinates; got {' '.join(toks)[:80]!r}")
    v_lines = [no for no, _ in vertex_rows]
    points = float_tokens(
        [t for _, toks in vertex_rows for t in toks[:3]], np.repeat(v_lines, 3), path, "coordinate"
    ).reshape(nv, 3)
    exc = non_finite_error(path, points, lambda i: f"vertex {i}", lambda i: v_lines[i])
    if exc is not None:
        raise exc
    faces = _faces(rest[nv:], nv, path) if nf else []
    return points, [("polygon", faces)] if faces else []


def write_off(path, points, blocks):
    """Write points and the polygons of cell blocks to an OFF file.

    Parameters
    ----------
    path : path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), full double precision.
    blocks : list of (kind, rows)
        Triangles, quads or polygons (0-based), written in block order.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.off")
    ...     write_off(path, [[0, 0], [1, 0], [0, 1]], [("triangle", [[0, 1, 2]])])
    ...     print(open(path).read(), end="")
    OFF
    3 1 0
    0 0 0
    1 0 0
    0 1 0
    3 0 1 2
    """
    pts = points_3d(points)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"OFF\n{pts.shape[0]} {sum(len(b) for _, b in blocks)} 0\n")
        fh.write(points_text(pts, "%.17g %.17g %.17g\n"))
        for _, rows in blocks:
            fh.write(rows_text(rows, with_size=True))
