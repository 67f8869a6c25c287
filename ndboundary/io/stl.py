"""STL: the writers of level sets and interfaces (triangles); STL files are read through meshio.

:func:`~ndboundary.io.write_level_set` writes surfaces to ``.stl`` with
:func:`write_binary_stl`, the format of 3-D printing: float32 corners and each
triangle's unit normal. :func:`~ndboundary.io.write_interfaces` writes the interfaces
between regions with :func:`write_ascii_stl_solids`: one named ``solid`` per pair of
regions, the ASCII layout in which CFD meshers (OpenFOAM's ``snappyHexMesh``) and VTK's
reader (``ScalarTags``) tell named surfaces apart; binary STL has no names. Reading STL
(ASCII or binary) goes through :func:`~ndboundary.io.meshio_formats.read_with_meshio`,
and the triangle soup it gives is welded by :func:`~ndboundary.io.read_mesh`.
"""

from __future__ import annotations

import numpy as np

from .common import points_3d
from .text_format import points_text

__all__ = ["write_ascii_stl_solids", "write_binary_stl"]


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
    corners, normals = _corners_and_normals(points, triangles)
    record = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    rows = np.zeros(corners.shape[0], dtype=record)
    rows["normal"], rows["corners"] = normals, corners
    with open(path, "wb") as fh:
        fh.write(b"binary STL written by ndboundary".ljust(80, b" "))
        fh.write(np.array([rows.size], dtype="<u4").tobytes())
        fh.write(rows.tobytes())


def _corners_and_normals(points, triangles):
    """Each triangle's corners, shape (n, 3, 3), and unit normal (zero when degenerate)."""
    corners = points_3d(points)[np.asarray(triangles, dtype=np.int64).reshape(-1, 3)]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return corners, np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


_FACET = (
    "facet normal %.17g %.17g %.17g\n outer loop\n  vertex %.17g %.17g %.17g\n  vertex %.17g %.17g %.17g\n"
    "  vertex %.17g %.17g %.17g\n endloop\nendfacet\n"
)


def write_ascii_stl_solids(path, points, triangles, groups, names):
    """Triangles to an ASCII STL file of one ``solid`` per group, named.

    Parameters
    ----------
    path : str or path-like
    points : array-like of shape (n_vertices, d), d <= 3
        Written with three coordinates (zeros appended), to full double precision, in one
        compiled pass (:func:`~ndboundary.io.text_format.points_text`).
    triangles : array-like of int, shape (n_triangles, 3)
    groups : array-like of int, shape (n_triangles,)
        Each triangle's group; the solids follow in increasing order of group.
    names : dict of int to str
        Each group's name: one word (no whitespace), as ``solid`` lines want.

    Raises
    ------
    ValueError
        On a name holding whitespace, or an empty one.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "t.stl")
    ...     write_ascii_stl_solids(path, [[0, 0], [1, 0], [0, 1], [1, 1]], [[0, 1, 2], [1, 3, 2]],
    ...                            [4, 2], {2: "a|b", 4: "a|c"})
    ...     [line.strip() for line in open(path) if "solid" in line]
    ['solid a|b', 'endsolid a|b', 'solid a|c', 'endsolid a|c']
    """
    groups = np.asarray(groups).reshape(-1)
    by_group = np.argsort(groups, kind="stable")  # each group's triangles in their order
    order, starts = np.unique(groups[by_group], return_index=True)
    bounds = np.append(starts, groups.size)
    for group in order:  # before the file is opened
        name = names[int(group)]
        if not name or any(c.isspace() for c in name):
            raise ValueError(f"{path}: the solid name {name!r} must be one word, without whitespace")
    corners, normals = _corners_and_normals(points, triangles)
    rows = np.hstack([normals, corners.reshape(-1, 9)])[by_group]
    with open(path, "w", encoding="utf-8", newline="\n") as fh:
        if not order.size:  # no triangles: one empty solid, which readers take
            fh.write("solid\nendsolid\n")
        for group, start, stop in zip(order, bounds[:-1], bounds[1:], strict=True):
            name = names[int(group)]
            fh.write(f"solid {name}\n")
            fh.write(points_text(rows[start:stop], _FACET))
            fh.write(f"endsolid {name}\n")
