"""Object File Format (OFF): vertices and polygons of any size.

meshio's OFF support is triangles only, so OFF is read and written here.
"""

from __future__ import annotations

import numpy as np

from .common import points_3d, uncommented_lines

__all__ = ["read_off", "write_off"]


def read_off(path):
    r"""Read the vertices and polygons of an OFF file as cell blocks.

    The first line is ``OFF`` (or a variant ending in it, such as ``COFF``), followed,
    on the same line or the next, by ``n_vertices n_faces n_edges``; then the vertices
    and the faces ``k i_1 ... i_k`` (0-based). Trailing per-line values (colours) and
    ``#`` comments are ignored.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        One ``"polygon"`` block, or none when the file has no faces.

    Raises
    ------
    ValueError
        When the file does not start with ``OFF``, its content is malformed, or it is
        shorter than its header announces.

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
    lines = [ln.split() for ln in uncommented_lines(path)]
    lines = [ln for ln in lines if ln]
    if not lines or not lines[0][0].upper().endswith("OFF"):
        raise ValueError(f"{path}: not an OFF file (the first line should be 'OFF')")
    try:
        if len(lines[0]) > 1:  # the counts follow 'OFF' on its line
            head, rest = lines[0][1:], lines[1:]
        else:
            head, rest = lines[1], lines[2:]
        nv, nf = int(head[0]), int(head[1])
        points = np.array([[float(t) for t in ln[:3]] for ln in rest[:nv]])
        faces = []
        for ln in rest[nv : nv + nf]:
            k = int(ln[0])
            faces.append([int(t) for t in ln[1 : 1 + k]])
            if len(faces[-1]) != k:
                raise ValueError(f"face line {ln} lists fewer than {k} vertices")
    except (ValueError, IndexError) as exc:
        raise ValueError(f"{path}: malformed OFF content: {exc}") from None
    if points.shape[0] != nv or len(faces) != nf:
        raise ValueError(f"{path}: OFF header announces {nv} vertices and {nf} faces; the file is shorter")
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
