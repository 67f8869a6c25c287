"""Object File Format (OFF): vertices and polygons of any size.

meshio's OFF support is triangles only, so OFF is read and written here.
"""

from __future__ import annotations

import numpy as np

from .common import float_tokens, int_tokens, non_finite_error, plural, points_3d, uncommented_lines

__all__ = ["read_off", "write_off"]


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
        One ``"polygon"`` block, or none when the file has no faces.

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
    rows = [r for _, b in blocks for r in b]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"OFF\n{pts.shape[0]} {len(rows)} 0\n")
        np.savetxt(fh, pts, fmt="%.17g")
        for r in rows:
            fh.write(f"{len(r)} " + " ".join(str(int(i)) for i in r) + "\n")
