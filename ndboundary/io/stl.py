"""STL: the binary writer of level sets (triangles); STL files are read through meshio.

:func:`~ndboundary.io.write_level_set` writes surfaces to ``.stl`` with
:func:`write_binary_stl`, the format of 3-D printing: float32 corners and each
triangle's unit normal. Reading STL (ASCII or binary) goes through
:func:`~ndboundary.io.meshio_formats.read_with_meshio`, and the triangle soup it gives
is welded by :func:`~ndboundary.io.read_mesh`.
"""

from __future__ import annotations

import numpy as np

from .common import points_3d

__all__ = ["write_binary_stl"]


def write_binary_stl(path, points, triangles):
    """Triangles to a binary STL file: float32 corners, unit normals (zero for degenerate triangles).

    Parameters
    ----------
    path : str or path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended).
    triangles : array-like of int, shape (n_triangles, 3)

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.stl")
    ...     write_binary_stl(path, [[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    ...     os.path.getsize(path)  # an 80-byte header, the count, one 50-byte record
    134
    """
    corners = points_3d(points)[np.asarray(triangles, dtype=np.int64)]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)
    record = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    rows = np.zeros(corners.shape[0], dtype=record)
    rows["normal"], rows["corners"] = normals, corners
    with open(path, "wb") as fh:
        fh.write(b"binary STL written by ndboundary".ljust(80, b" "))
        fh.write(np.array([rows.size], dtype="<u4").tobytes())
        fh.write(rows.tobytes())
