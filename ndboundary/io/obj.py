"""Wavefront OBJ: vertices, faces (``f``) and polylines (``l``)."""

from __future__ import annotations

import numpy as np

from .common import points_3d

__all__ = ["read_obj", "write_obj"]


def _vertex_indices(tokens, n_points):
    """0-based vertex indices of OBJ tokens ``v``, ``v/vt``, ``v//vn``, ``v/vt/vn`` (1-based; negative
    ones count back from the last vertex read so far).
    """
    out = []
    for tok in tokens:
        i = int(tok.split("/")[0])
        out.append(i - 1 if i > 0 else n_points + i)
    return out


def read_obj(path):
    r"""Read the vertices and the faces (else the polylines) of an OBJ file as cell blocks.

    Texture coordinates, normals, groups and materials are ignored. Faces come as one
    ``"polygon"`` block; a file without faces gives its polylines as a ``"line"`` block
    of segments, one per pair of consecutive vertices of each ``l`` line.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        See :mod:`ndboundary.io.cell_blocks`; empty when the file has neither.

    Raises
    ------
    ValueError
        On a line that is not valid OBJ (the message gives its number).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "l.obj")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("v 0 0 0\nv 1 0 0\nv 1 1 0\nl 1 2 3\n")
    ...     points, blocks = read_obj(path)
    >>> points.shape, blocks
    ((3, 3), [('line', [(0, 1), (1, 2)])])
    """
    points, faces, lines = [], [], []
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line_no, line in enumerate(fh, 1):
            parts = line.split()
            if not parts:
                continue
            key = parts[0]
            try:
                if key == "v":
                    points.append([float(t) for t in parts[1:4]])
                elif key == "f":
                    faces.append(_vertex_indices(parts[1:], len(points)))
                elif key == "l":
                    idx = _vertex_indices(parts[1:], len(points))
                    lines.extend(zip(idx[:-1], idx[1:], strict=True))
            except ValueError:
                raise ValueError(f"{path}: line {line_no} is not valid OBJ: {line.strip()[:80]!r}") from None
    if faces:
        return np.array(points), [("polygon", faces)]
    return np.array(points), [("line", lines)] if lines else []


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
        np.savetxt(fh, pts, fmt="v %.17g %.17g %.17g")
        for kind, rows in blocks:
            tag = "l" if kind == "line" else "f"
            for r in rows:
                fh.write(tag + " " + " ".join(str(int(i) + 1) for i in r) + "\n")
