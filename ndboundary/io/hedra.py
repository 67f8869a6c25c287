"""CinoLib's HEDRA format: general polyhedra as faces and signed face lists.

The file holds ``n_vertices n_faces n_cells``, the vertex coordinates, every face as
``k v_1 ... v_k`` and every cell as ``k ±f_1 ... ±f_k``, all indices 1-based; a face's
sign tells whether its vertex loop turns outwards (+) or inwards (-) for that cell.
"""

from __future__ import annotations

import numpy as np

from .common import uncommented_lines

__all__ = ["read_hedra", "write_hedra"]


def read_hedra(path):
    """Read a HEDRA file as one ``"hedra"`` cell block.

    The face signs are dropped: :class:`~ndboundary.PolyhedralMesh` orients every cell's
    faces itself.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        ``[("hedra", (faces, cells))]``, the faces as 0-based vertex lists and the cells
        as 0-based face lists.

    Raises
    ------
    ValueError
        On malformed content or a file shorter than its header announces.

    Examples
    --------
    >>> import os, tempfile
    >>> text = '''4 4 1
    ... 0 0 0  1 0 0  0 1 0  0 0 1
    ... 3 1 3 2  3 1 2 4  3 2 3 4  3 3 1 4
    ... 4 1 2 3 4
    ... '''
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "tet.hedra")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write(text)
    ...     points, [(kind, (faces, cells))] = read_hedra(path)
    >>> points.shape, kind, faces[0], cells
    ((4, 3), 'hedra', [0, 2, 1], [[0, 1, 2, 3]])
    """
    toks = " ".join(uncommented_lines(path)).split()
    try:
        nv, nf, nc = (int(t) for t in toks[:3])
        pos = 3
        points = np.array(toks[pos : pos + 3 * nv], dtype=np.float64).reshape(nv, 3)
        pos += 3 * nv
        faces = []
        for _ in range(nf):
            k = int(toks[pos])
            faces.append([int(t) - 1 for t in toks[pos + 1 : pos + 1 + k]])
            pos += 1 + k
        cells = []
        for _ in range(nc):
            k = int(toks[pos])
            cells.append([abs(int(t)) - 1 for t in toks[pos + 1 : pos + 1 + k]])
            pos += 1 + k
    except (ValueError, IndexError) as exc:
        raise ValueError(
            f"{path}: malformed HEDRA content (expected 'n_vertices n_faces n_cells', "
            f"then vertices, faces and cells): {exc}"
        ) from None
    if len(cells) != nc or any(len(c) == 0 for c in cells[-1:]):
        raise ValueError(f"{path}: HEDRA file is shorter than its header announces")
    return points, [("hedra", (faces, cells))]


def write_hedra(path, mesh):
    """Write a polyhedral mesh to a HEDRA file, each cell's faces signed by their orientation.

    Parameters
    ----------
    path : path-like
    mesh : PolyhedralMesh

    Examples
    --------
    >>> import os, tempfile
    >>> from ndboundary import PolyhedralMesh
    >>> tet = PolyhedralMesh.from_tetrahedra([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "tet.hedra")
    ...     write_hedra(path, tet)
    ...     lines = open(path).read().splitlines()
    >>> lines[0], len(lines)
    ('4 4 1', 10)
    """
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"{mesh.n_vertices} {mesh.n_faces} {mesh.n_elements}\n")
        np.savetxt(fh, mesh.points, fmt="%.17g")
        for f in mesh.faces:
            fh.write(f"{f.size} " + " ".join(str(int(i) + 1) for i in f) + "\n")
        signed = (mesh.cell_faces + 1) * mesh.cell_face_signs
        for r in np.split(signed, mesh.cell_offsets[1:-1]):
            fh.write(f"{r.size} " + " ".join(str(int(i)) for i in r) + "\n")
