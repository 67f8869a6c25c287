"""CinoLib's HEDRA format: general polyhedra as faces and signed face lists.

The file holds ``n_vertices n_faces n_cells``, the vertex coordinates, every face as
``k v_1 ... v_k`` and every cell as ``k ±f_1 ... ±f_k``, all indices 1-based; a face's
sign tells whether its vertex loop turns outwards (+) or inwards (-) for that cell.
"""

from __future__ import annotations

import itertools

import numpy as np

from .common import float_tokens, int_tokens, non_finite_error, plural, uncommented_lines

__all__ = ["read_hedra", "write_hedra"]


def _malformed(path, message):
    return ValueError(f"{path}: malformed HEDRA content: {message}")


def _check_line_counts(body, nv, nf, nc, path):
    """Compare the header with the lines of a file written one vertex, face or cell a line (as CinoLib does).

    ``body`` holds the token lists of the non-empty lines after the header. Vertex lines
    hold 3 numbers, face and cell lines ``k`` and ``k >= 3`` indices, so the two kinds are
    told apart; files laid out otherwise are left to the token count.
    """
    sizes = np.fromiter(map(len, body), dtype=np.int64, count=len(body))
    heads = np.fromiter((int(t[0]) if len(t[0]) < 10 and t[0].isdecimal() else -1 for t in body), np.int64, len(body))
    vertex = sizes == 3
    if not np.all(vertex | ((sizes >= 4) & (heads == sizes - 1))):
        return
    n_vertex_lines = int(np.argmin(vertex)) if not vertex.all() else len(body)
    if vertex[n_vertex_lines:].any():
        return
    n_records = len(body) - n_vertex_lines
    if n_vertex_lines != nv:
        raise _malformed(
            path, f"the header announces {plural(nv, 'vertex')}, but the file holds {n_vertex_lines} vertex lines"
        )
    if n_records != nf + nc:
        raise _malformed(
            path,
            f"the header announces {plural(nf, 'face')} and {plural(nc, 'cell')}, but {n_records} lines follow "
            f"the vertices ({n_records - nf} after the {plural(nf, 'face')}, where {plural(nc, 'cell')} are announced)",
        )


def _records(toks, lines, pos, count, what, least, path):
    """``count`` records ``k x_1 ... x_k`` from token ``pos`` on: their sizes, start positions and the end."""
    sizes, starts = [], []
    for r in range(count):
        if pos >= len(toks):
            raise _malformed(path, f"the header announces {plural(count, what)}, but the file ends after {r}")
        try:
            k = int(toks[pos])
        except ValueError:
            raise _malformed(path, f"line {lines[pos]}: {what} {r + 1} has size {toks[pos][:40]!r}") from None
        if k < least:
            raise _malformed(
                path, f"line {lines[pos]}: {what} {r + 1} has {toks[pos]} entries; at least {least} needed"
            )
        if pos + 1 + k > len(toks):
            raise _malformed(path, f"the file ends inside {what} {r + 1} of the {count} announced (line {lines[-1]})")
        sizes.append(k)
        starts.append(pos + 1)
        pos += 1 + k
    return np.array(sizes, dtype=np.int64), np.array(starts, dtype=np.int64), pos


def _count_records(toks, pos):
    """How many whole records ``k x_1 ... x_k`` the tokens from ``pos`` on make, or 0 when they make none."""
    count = 0
    while pos < len(toks):
        try:
            k = int(toks[pos])
        except ValueError:
            return 0
        if k < 1 or pos + 1 + k > len(toks):
            return 0
        pos += 1 + k
        count += 1
    return count


def _indices(toks, lines, sizes, starts, n, what, of, path, signed=False):
    """The 1-based (``signed``: signed) indices of records, 0-based, checked to lie in ``1..n``."""
    if sizes.size == 0:
        return []
    pos = (np.repeat(starts - np.cumsum(np.r_[0, sizes[:-1]]), sizes) + np.arange(sizes.sum())).astype(np.int64)
    flat = int_tokens([toks[i] for i in pos], lines[pos], path, f"{of} index")
    value = np.abs(flat) if signed else flat
    bad = np.flatnonzero((value < 1) | (value > n))
    if bad.size:
        i = int(bad[0])
        record = int(np.searchsorted(np.cumsum(sizes), i, side="right")) + 1
        runs = f"+-1..+-{n}" if signed else f"1..{n}"
        raise _malformed(
            path,
            f"line {lines[pos[i]]}: {what} {record} lists {of} {toks[pos[i]][:40]}; the file has {plural(n, of)} "
            f"(HEDRA {of} indices run {runs})",
        )
    return [r.tolist() for r in np.split(value - 1, np.cumsum(sizes)[:-1])]


def read_hedra(path):
    """Read a HEDRA file as one ``"hedra"`` cell block.

    The face signs are dropped: :class:`~ndboundary.PolyhedralMesh` orients every cell's
    faces itself.

    Parameters
    ----------
    path : path-like
        Read as UTF-8; a leading byte-order mark is dropped.

    Returns
    -------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        ``[("hedra", (faces, cells))]``, the faces as 0-based vertex lists and the cells
        as 0-based face lists.

    Raises
    ------
    ValueError
        On malformed content, a file holding fewer or more vertices, faces or cells than
        its header announces (both counts named), a vertex index outside ``1..n_vertices``,
        a face index outside ``+-1..+-n_faces`` or a NaN or infinite coordinate; the message
        names the file and, for bad values, the line.

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
    split = [ln.split() for ln in uncommented_lines(path)]
    counts = np.fromiter(map(len, split), dtype=np.int64, count=len(split))
    toks = list(itertools.chain.from_iterable(split))
    lines = np.repeat(np.arange(1, len(split) + 1), counts)
    if len(toks) < 3:
        raise _malformed(path, "expected 'n_vertices n_faces n_cells', then vertices, faces and cells")
    nv, nf, nc = (int(c) for c in int_tokens(toks[:3], lines[:3], path, "HEDRA header count"))
    if min(nv, nf, nc) < 0:
        raise _malformed(path, f"line {lines[0]}: negative counts in the header {' '.join(toks[:3])!r}")
    body = [t for t in split if t]
    if len(body[0]) == 3:
        _check_line_counts(body[1:], nv, nf, nc, path)
    if len(toks) < 3 + 3 * nv:
        raise _malformed(
            path, f"the header announces {plural(nv, 'vertex')}, but the file ends after {(len(toks) - 3) // 3}"
        )
    pos = 3 + 3 * nv
    points = float_tokens(toks[3:pos], lines[3:pos], path, "coordinate").reshape(nv, 3)
    exc = non_finite_error(path, points, lambda i: f"vertex {i + 1}", lambda i: lines[3 + 3 * i])
    if exc is not None:
        raise exc
    f_sizes, f_starts, pos = _records(toks, lines, pos, nf, "face", 3, path)
    c_sizes, c_starts, pos = _records(toks, lines, pos, nc, "cell", 4, path)
    if pos < len(toks):
        extra = _count_records(toks, pos)
        holds = f"the file holds {nc + extra}" if extra else "more follows"
        raise _malformed(path, f"the header announces {plural(nc, 'cell')}, but {holds} (from line {lines[pos]} on)")
    faces = _indices(toks, lines, f_sizes, f_starts, nv, "face", "vertex", path)
    cells = _indices(toks, lines, c_sizes, c_starts, nf, "cell", "face", path, signed=True)
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
