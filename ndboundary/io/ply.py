"""ASCII PLY for level sets: curves as ``edge`` elements, surfaces as ``face`` elements.

meshio's PLY writer has no edge elements (it writes segments as two-vertex faces), so
level sets are written here; meshes go through meshio (:mod:`ndboundary.io.meshio_formats`).
"""

from __future__ import annotations

import numpy as np

from .common import points_3d

__all__ = ["write_ascii_ply"]


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
        np.savetxt(fh, pts, fmt="%.17g")
        if segments:
            np.savetxt(fh, simplices, fmt="%d")
        else:
            np.savetxt(fh, np.concatenate([np.full((simplices.shape[0], 1), 3), simplices], axis=1), fmt="%d")
