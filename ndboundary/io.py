"""Reading and writing meshes, relaxed functions, level sets and labels.

Formats, chosen by the file extension (case-insensitive):

========================  ==============================  ==============================
extension                 read                            write
========================  ==============================  ==============================
``.obj``, ``.off``        triangles, polygons, segments   triangles, polygons, segments
``.hedra``                polyhedra (CinoLib)             polyhedra, tetrahedra
``.ply``                  triangles, polygons (meshio)    triangles, polygons
``.stl``                  triangles (meshio)              triangles
``.mesh`` (MEDIT),        triangles, quads, tetrahedra,   the same
``.msh`` (Gmsh)           hexahedra, wedges, pyramids
``.vtk``, ``.vtu``        any of the above; ``.vtu``      any (``.vtu`` also general
                          also general polyhedra          polyhedra)
========================  ==============================  ==============================

meshio (optional dependency, ``meshio>=5.3``) is imported only for the formats it
handles; OBJ, OFF and HEDRA are read and written here (meshio's OFF is triangles
only, and its OBJ ignores segments).

:func:`read_mesh` returns the matching domain: a :class:`~ndboundary.SimplicialComplex`
for segments, triangles or tetrahedra alone, a :class:`~ndboundary.PolygonMesh` for
quads and polygons, a :class:`~ndboundary.PolyhedralMesh` for other solids. When a
file holds cells of several dimensions (a MEDIT file listing the boundary triangles
of a tetrahedral solid), the highest-dimensional cells are kept; vertex indices are
kept as in the file, except that vertices no kept cell uses are dropped (see
:func:`read_mesh`). A curve or surface mesh whose third coordinate is zero everywhere is
read with 2-D points.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from ._arrays import group_rows
from .domains import Domain, PolygonMesh, PolyhedralMesh, SimplicialComplex
from .domains.polyhedral_cells import HEX_FACES, TET_FACES

__all__ = ["read_mesh", "write_mesh", "write_phi", "write_level_set", "read_labels", "write_labels"]

_MESHIO_READ = {".ply", ".stl", ".mesh", ".msh", ".vtk", ".vtu"}
_READ = {".obj", ".off", ".hedra"} | _MESHIO_READ
_WRITE = _READ
_CELL_DIM = {"line": 1, "triangle": 2, "quad": 2, "polygon": 2, "tetra": 3, "hexahedron": 3, "wedge": 3, "pyramid": 3}
#: Faces of a VTK wedge and pyramid.
_LOCAL_FACES = {
    "tetra": [list(f) for f in TET_FACES],
    "hexahedron": [list(f) for f in HEX_FACES],
    "wedge": [[0, 2, 1], [3, 4, 5], [0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]],
    "pyramid": [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
}


# -- helpers ---------------------------------------------------------------------------------

def _existing(path):
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"no such file: '{path}'")
    return path


def _suffix(path, allowed, what):
    ext = Path(os.fspath(path)).suffix.lower()
    if ext not in allowed:
        raise ValueError(
            f"{os.fspath(path)}: unknown {what} format {ext or '(no extension)'!r}; "
            f"expected one of {', '.join(sorted(allowed))}"
        )
    return ext


def _meshio():
    try:
        import meshio
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("reading and writing this format needs meshio: pip install 'meshio>=5.3'") from None
    return meshio


def _int_tokens(tokens, n_points, path, line_no):
    """OBJ face tokens ``v``, ``v/vt``, ``v//vn``, ``v/vt/vn``; 1-based, negative = relative."""
    out = []
    for tok in tokens:
        i = int(tok.split("/")[0])
        out.append(i - 1 if i > 0 else n_points + i)
    return out


# -- reading ------------------------------------------------------------------------------------

def _read_obj(path):
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
                    faces.append(_int_tokens(parts[1:], len(points), path, line_no))
                elif key == "l":
                    idx = _int_tokens(parts[1:], len(points), path, line_no)
                    lines.extend(zip(idx[:-1], idx[1:]))
            except ValueError:
                raise ValueError(f"{path}: line {line_no} is not valid OBJ: {line.strip()[:80]!r}") from None
    if faces:
        return np.array(points), [("polygon", faces)]
    return np.array(points), [("line", lines)] if lines else []


def _numbers(path):
    """All whitespace-separated tokens of a file, comments (``#``) removed."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        text = [ln.split("#", 1)[0] for ln in fh]
    return text


def _read_off(path):
    lines = [ln.split() for ln in _numbers(path)]
    lines = [ln for ln in lines if ln]
    if not lines or not lines[0][0].upper().endswith("OFF"):
        raise ValueError(f"{path}: not an OFF file (the first line should be 'OFF')")
    head = lines[0][1:] if len(lines[0]) > 1 else None
    rest = lines[1:] if head is None else lines
    if head is None:
        head, rest = rest[0], rest[1:]
    else:
        rest = lines[1:]
    try:
        nv, nf = int(head[0]), int(head[1])
        points = np.array([[float(t) for t in ln[:3]] for ln in rest[:nv]])
        faces = []
        for ln in rest[nv:nv + nf]:
            k = int(ln[0])
            faces.append([int(t) for t in ln[1:1 + k]])
            if len(faces[-1]) != k:
                raise ValueError(f"face line {ln} lists fewer than {k} vertices")
    except (ValueError, IndexError) as exc:
        raise ValueError(f"{path}: malformed OFF content: {exc}") from None
    if points.shape[0] != nv or len(faces) != nf:
        raise ValueError(f"{path}: OFF header announces {nv} vertices and {nf} faces; the file is shorter")
    return points, [("polygon", faces)] if faces else []


def _read_hedra(path):
    toks = " ".join(_numbers(path)).split()
    try:
        nv, nf, nc = (int(t) for t in toks[:3])
        pos = 3
        points = np.array(toks[pos:pos + 3 * nv], dtype=np.float64).reshape(nv, 3)
        pos += 3 * nv
        faces = []
        for _ in range(nf):
            k = int(toks[pos])
            faces.append([int(t) - 1 for t in toks[pos + 1:pos + 1 + k]])
            pos += 1 + k
        cells = []
        for _ in range(nc):
            k = int(toks[pos])
            cells.append([abs(int(t)) - 1 for t in toks[pos + 1:pos + 1 + k]])
            pos += 1 + k
    except (ValueError, IndexError) as exc:
        raise ValueError(f"{path}: malformed HEDRA content (expected 'n_vertices n_faces n_cells', "
                         f"then vertices, faces and cells): {exc}") from None
    if len(cells) != nc or any(len(c) == 0 for c in cells[-1:]):
        raise ValueError(f"{path}: HEDRA file is shorter than its header announces")
    return points, [("hedra", (faces, cells))]


def _read_meshio(path):
    meshio = _meshio()
    try:
        with warnings.catch_warnings():
            # meshio tells ASCII from binary STL by a size test that overflows on ASCII files
            warnings.filterwarnings("ignore", "overflow encountered", RuntimeWarning)
            m = meshio.read(os.fspath(path))
    except (Exception, SystemExit) as exc:  # meshio exits on some unreadable files
        raise ValueError(f"{path}: could not read the file: {type(exc).__name__}: {exc}") from None
    blocks = []
    for c in m.cells:
        t = c.type
        if t.startswith("polyhedron"):
            blocks.append(("polyhedron", c.data))
        elif t.startswith("polygon"):
            blocks.append(("polygon", [list(r) for r in np.asarray(c.data)]))
        elif t in _CELL_DIM:
            blocks.append((t, np.asarray(c.data)))
    return np.asarray(m.points, dtype=np.float64), blocks


def _block_dim(kind):
    return 3 if kind in ("hedra", "polyhedron") else _CELL_DIM[kind]


def _polyhedra_from_blocks(points, blocks):
    """Faces and face-index cells from solid blocks (local face tables and explicit polyhedra)."""
    faces, cells = [], []
    for kind, data in blocks:
        if kind == "polyhedron":
            for cell in data:
                start = len(faces)
                faces.extend(list(np.asarray(f)) for f in cell)
                cells.append(list(range(start, len(faces))))
        else:
            arr = np.asarray(data)
            for local in _LOCAL_FACES[kind]:
                pass
            start = len(faces)
            nloc = len(_LOCAL_FACES[kind])
            for row in arr:
                faces.extend([row[f] for f in _LOCAL_FACES[kind]])
            cells.extend([list(range(start + i * nloc, start + (i + 1) * nloc)) for i in range(arr.shape[0])])
    # merge faces with the same vertex set
    width = max(len(f) for f in faces)
    pad = np.full((len(faces), width), -1, dtype=np.int64)
    for i, f in enumerate(faces):
        pad[i, :len(f)] = np.sort(f)
    ids, n = group_rows(pad)
    first = np.unique(ids, return_index=True)[1]
    return [faces[i] for i in first], [ids[c] for c in cells]


def _to_domain(points, blocks, path, drop_unused):
    blocks = [(k, d) for k, d in blocks if len(d) if k != "hedra" or len(d[1])]
    if not blocks:
        raise ValueError(f"{path}: the file holds no cells (segments, polygons or solids)")
    top = max(_block_dim(k) for k, _ in blocks)
    blocks = [(k, d) for k, d in blocks if _block_dim(k) == top]
    if drop_unused:
        points, blocks = _drop_unused(points, blocks)
    kinds = {k for k, _ in blocks}
    if top <= 2 and points.shape[1] == 3 and not np.any(points[:, 2]):
        points = points[:, :2]
    if top == 1:
        return SimplicialComplex(points, np.concatenate([np.asarray(d, dtype=np.int64) for _, d in blocks]))
    if top == 2:
        polys = [list(r) for _, d in blocks for r in (d.tolist() if isinstance(d, np.ndarray) else d)]
        if all(len(p) == 3 for p in polys):
            return SimplicialComplex(points, np.array(polys, dtype=np.int64))
        return PolygonMesh(points, polys)
    if kinds == {"tetra"}:
        return SimplicialComplex(points, np.concatenate([d for _, d in blocks]))
    if kinds == {"hedra"}:
        faces, cells = blocks[0][1]
        return PolyhedralMesh(points, faces, cells)
    if kinds == {"hexahedron"}:
        return PolyhedralMesh.from_hexahedra(points, np.concatenate([d for _, d in blocks]))
    faces, cells = _polyhedra_from_blocks(points, blocks)
    return PolyhedralMesh(points, faces, cells)


def _drop_unused(points, blocks):
    """Remove the vertices no cell uses, renumbering the cells."""
    used = np.zeros(points.shape[0], dtype=bool)
    for kind, data in blocks:
        if kind == "hedra":
            faces = data[0]
            for f in faces:
                used[f] = True
        elif kind == "polyhedron":
            for cell in data:
                for f in cell:
                    used[np.asarray(f)] = True
        else:
            for r in (data if not isinstance(data, np.ndarray) else [data.ravel()]):
                used[np.asarray(r, dtype=np.int64)] = True
    if used.all():
        return points, blocks
    new = np.cumsum(used) - 1
    out = []
    for kind, data in blocks:
        if kind == "hedra":
            out.append((kind, ([new[np.asarray(f)] for f in data[0]], data[1])))
        elif kind == "polyhedron":
            out.append((kind, [[new[np.asarray(f)] for f in cell] for cell in data]))
        elif isinstance(data, np.ndarray):
            out.append((kind, new[data]))
        else:
            out.append((kind, [new[np.asarray(r, dtype=np.int64)] for r in data]))
    return points[used], out


def read_mesh(path, *, drop_unused=True) -> Domain:
    """Read a mesh file into the matching domain.

    Parameters
    ----------
    path : str or path-like
        A ``.obj``, ``.off``, ``.ply``, ``.stl``, ``.mesh``, ``.msh``, ``.vtk``, ``.vtu`` or
        ``.hedra`` file (see the module docstring).
    drop_unused : bool, default=True
        Remove the vertices that no kept cell uses (they carry no measure and would
        leave the relaxation's linear systems singular), renumbering the rest in order.
        Files often hold such vertices (a HEDRA file's unused points, the boundary
        vertices of a solid's lower-dimensional cells).

    Returns
    -------
    SimplicialComplex, PolygonMesh or PolyhedralMesh
        Segments, triangles or tetrahedra alone give a SimplicialComplex; quads and
        polygons a PolygonMesh; hexahedra, wedges, pyramids and general polyhedra a
        PolyhedralMesh. Only the highest-dimensional cells of a file are kept.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist (the message quotes it).
    ValueError
        On an unknown extension, content that is not the announced format, a file with
        no cells, or invalid cells (the message names the file and the problem).
    """
    ext = _suffix(path, _READ, "mesh")
    path = _existing(path)
    try:
        if ext == ".obj":
            points, blocks = _read_obj(path)
        elif ext == ".off":
            points, blocks = _read_off(path)
        elif ext == ".hedra":
            points, blocks = _read_hedra(path)
        else:
            points, blocks = _read_meshio(path)
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file: {exc}") from None
    if points.ndim != 2 or points.shape[0] == 0:
        raise ValueError(f"{path}: the file holds no vertices")
    try:
        return _to_domain(points, blocks, path, drop_unused)
    except (ValueError, TypeError) as exc:
        if str(exc).startswith(str(path)):
            raise
        raise ValueError(f"{path}: {exc}") from None


# -- writing ------------------------------------------------------------------------------------

def _points3(points):
    points = np.asarray(points, dtype=np.float64)
    if points.shape[1] == 3:
        return points
    if points.shape[1] > 3:
        raise ValueError(f"points are {points.shape[1]}-dimensional; mesh files hold at most 3 coordinates")
    return np.concatenate([points, np.zeros((points.shape[0], 3 - points.shape[1]))], axis=1)


def _hexes_or_tets(mesh):
    """VTK hexahedra or tetrahedra of a PolyhedralMesh whose cells all are such, else None."""
    cell, vert = mesh.cell_vertices
    nv = np.bincount(cell, minlength=mesh.n_elements)
    nf = np.diff(mesh.cell_offsets)
    fs = np.diff(mesh.face_offsets)
    if np.all((nv == 4) & (nf == 4)):
        tets = vert.reshape(-1, 4).copy()
        X = mesh.points[tets]
        neg = np.linalg.det(X[:, 1:] - X[:, :1]) < 0
        tets[neg, 0], tets[neg, 1] = tets[neg, 1].copy(), tets[neg, 0].copy()
        return "tetra", tets
    quads = np.all(fs[mesh.cell_faces] == 4)
    if not (quads and np.all((nv == 8) & (nf == 6))):
        return None
    hexes = np.empty((mesh.n_elements, 8), dtype=np.int64)
    for c in range(mesh.n_elements):
        ents = range(mesh.cell_offsets[c], mesh.cell_offsets[c + 1])
        nbr = {}
        bottom = None
        for k in ents:
            f = mesh.cell_faces[k]
            loop = mesh.face_indices[mesh.face_offsets[f]:mesh.face_offsets[f + 1]]
            if mesh.cell_face_signs[k] < 0:
                loop = loop[::-1]
            if bottom is None:
                bottom = [loop[0], loop[3], loop[2], loop[1]]
            for a, b in zip(loop, np.roll(loop, -1)):
                nbr.setdefault(a, set()).add(b)
                nbr.setdefault(b, set()).add(a)
        top = [next(iter(nbr[v] - set(bottom))) for v in bottom]
        hexes[c] = bottom + top
    return "hexahedron", hexes


def _cell_blocks(domain):
    """meshio cell blocks and, per block, the element indices it holds."""
    if isinstance(domain, SimplicialComplex):
        kind = {1: "line", 2: "triangle", 3: "tetra"}.get(domain.simplex_dim)
        if kind is None:
            raise ValueError(f"{domain.simplex_dim}-simplices cannot be written to a mesh file (at most tetrahedra)")
        return [(kind, domain.simplices)], [np.arange(domain.n_elements)]
    if isinstance(domain, PolygonMesh):
        sizes = domain.sizes
        blocks, order = [], []
        for m in np.unique(sizes):
            els = np.flatnonzero(sizes == m)
            rows = np.stack([domain.indices[domain.offsets[els] + i] for i in range(m)], axis=1)
            blocks.append(({3: "triangle", 4: "quad"}.get(int(m), "polygon"), rows))
            order.append(els)
        return blocks, order
    if isinstance(domain, PolyhedralMesh):
        std = _hexes_or_tets(domain)
        if std is not None:
            return [std], [np.arange(domain.n_elements)]
        cells = []
        for c in range(domain.n_elements):
            ents = range(domain.cell_offsets[c], domain.cell_offsets[c + 1])
            loops = []
            for k in ents:
                f = domain.cell_faces[k]
                loop = domain.face_indices[domain.face_offsets[f]:domain.face_offsets[f + 1]]
                loops.append(loop if domain.cell_face_signs[k] > 0 else loop[::-1])
            cells.append(loops)
        nv = np.bincount(domain.cell_vertices[0], minlength=domain.n_elements)
        blocks, order = [], []
        for m in np.unique(nv):
            els = np.flatnonzero(nv == m)
            blocks.append((f"polyhedron{int(m)}", [cells[e] for e in els]))
            order.append(els)
        return blocks, order
    raise TypeError(f"cannot write a {type(domain).__name__}; expected a SimplicialComplex, PolygonMesh or PolyhedralMesh")


def _check_data(data, n, what):
    out = {}
    for name, values in (data or {}).items():
        arr = np.asarray(values)
        if arr.shape[:1] != (n,):
            raise ValueError(f"{what} {name!r} has shape {arr.shape}; expected {n} rows, one per {what.split('_')[0]}")
        out[str(name)] = arr
    return out


def _write_obj(path, points, blocks):
    pts = _points3(points)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("# written by ndboundary\n")
        np.savetxt(fh, pts, fmt="v %.17g %.17g %.17g")
        for kind, rows in blocks:
            tag = "l" if kind == "line" else "f"
            for r in rows:
                fh.write(tag + " " + " ".join(str(int(i) + 1) for i in r) + "\n")


def _write_off(path, points, blocks):
    pts = _points3(points)
    rows = [r for _, b in blocks for r in b]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"OFF\n{pts.shape[0]} {len(rows)} 0\n")
        np.savetxt(fh, pts, fmt="%.17g")
        for r in rows:
            fh.write(f"{len(r)} " + " ".join(str(int(i)) for i in r) + "\n")


def _write_hedra(path, mesh):
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"{mesh.n_vertices} {mesh.n_faces} {mesh.n_elements}\n")
        np.savetxt(fh, mesh.points, fmt="%.17g")
        for f in mesh.faces:
            fh.write(f"{f.size} " + " ".join(str(int(i) + 1) for i in f) + "\n")
        signed = (mesh.cell_faces + 1) * mesh.cell_face_signs
        for r in np.split(signed, mesh.cell_offsets[1:-1]):
            fh.write(f"{r.size} " + " ".join(str(int(i)) for i in r) + "\n")


_MESHIO_WRITE_KINDS = {
    ".stl": {"triangle"},
    ".ply": {"triangle", "quad", "polygon", "line"},
    ".mesh": {"line", "triangle", "quad", "tetra", "hexahedron"},
    ".msh": {"line", "triangle", "quad", "tetra", "hexahedron"},
    ".vtk": {"line", "triangle", "quad", "polygon", "tetra", "hexahedron"},
    ".vtu": {"line", "triangle", "quad", "polygon", "tetra", "hexahedron", "polyhedron"},
}


def _write_meshio(path, ext, points, blocks, order, point_data, cell_data):
    meshio = _meshio()
    kinds = {"polyhedron" if k.startswith("polyhedron") else k for k, _ in blocks}
    bad = kinds - _MESHIO_WRITE_KINDS[ext]
    if bad:
        raise ValueError(
            f"{path}: the {ext} format cannot hold {', '.join(sorted(bad))} cells; "
            f"use one of {', '.join(sorted(e for e, k in _MESHIO_WRITE_KINDS.items() if bad <= k) or ['.vtu'])}"
        )
    pts = _points3(points) if ext in (".stl", ".ply", ".mesh", ".vtk", ".vtu", ".msh") else points
    cells = [(k, np.asarray(d, dtype=np.int32) if not k.startswith("polyhedron") else d) for k, d in blocks]
    cd = {name: [np.asarray(v)[o] for o in order] for name, v in cell_data.items()}
    mesh = meshio.Mesh(pts, cells, point_data=point_data, cell_data=cd)
    fmt = {".msh": "gmsh22"}.get(ext)
    try:
        if fmt:
            meshio.write(os.fspath(path), mesh, file_format=fmt, binary=False)
        else:
            meshio.write(os.fspath(path), mesh)
    except Exception as exc:
        raise ValueError(f"{path}: could not write: {type(exc).__name__}: {exc}") from None


def write_mesh(path, domain, point_data=None, cell_data=None):
    """Write a domain (and optional per-vertex / per-element data) to a mesh file.

    Parameters
    ----------
    path : str or path-like
        The extension picks the format (see the module docstring). OBJ, OFF, STL,
        MEDIT and HEDRA files carry no data arrays: ``point_data`` and ``cell_data``
        need ``.vtu``, ``.vtk``, ``.msh`` or ``.ply``.
    domain : SimplicialComplex, PolygonMesh or PolyhedralMesh
    point_data : dict of str to array-like of shape (n_vertices,) or (n_vertices, k), optional
    cell_data : dict of str to array-like of shape (n_elements,) or (n_elements, k), optional
        Polygon meshes of mixed sizes are written one block per polygon size, so the
        elements of the file come grouped by size; polyhedral meshes whose cells are
        all hexahedra (or all tetrahedra) are written as such, other polyhedra as VTK
        polyhedra (``.vtu`` only) or HEDRA.

    Raises
    ------
    ValueError
        On an unknown extension, a format that cannot hold the domain's cells or data,
        or data of the wrong length.
    TypeError
        When ``domain`` is not one of the mesh domains.
    """
    ext = _suffix(path, _WRITE, "mesh")
    if not isinstance(domain, (SimplicialComplex, PolygonMesh, PolyhedralMesh)):
        raise TypeError(
            f"cannot write a {type(domain).__name__}; expected a SimplicialComplex, PolygonMesh or PolyhedralMesh"
        )
    point_data = _check_data(point_data, domain.n_vertices, "point_data")
    cell_data = _check_data(cell_data, domain.n_elements, "cell_data")
    if (point_data or cell_data) and ext not in (".vtu", ".vtk", ".msh", ".ply"):
        raise ValueError(f"{path}: the {ext} format carries no data arrays; use .vtu, .vtk, .msh or .ply")
    if ext == ".hedra":
        if isinstance(domain, SimplicialComplex) and domain.simplex_dim == 3 and domain.dim == 3:
            domain = PolyhedralMesh.from_tetrahedra(domain.points, domain.simplices)
        if not isinstance(domain, PolyhedralMesh):
            raise ValueError(f"{path}: HEDRA holds polyhedra; got a {type(domain).__name__}")
        _write_hedra(path, domain)
        return
    blocks, order = _cell_blocks(domain)
    if ext in (".obj", ".off"):
        if any(k not in ("line", "triangle", "quad", "polygon") for k, _ in blocks) or (
            ext == ".off" and blocks[0][0] == "line"
        ):
            raise ValueError(f"{path}: the {ext} format holds surfaces only; use .vtu, .mesh or .hedra for solids")
        (_write_obj if ext == ".obj" else _write_off)(path, domain.points, blocks)
        return
    _write_meshio(path, ext, domain.points, blocks, order, point_data, cell_data)


def write_phi(path, result, labels=None):
    """Write a relaxation result for ParaView: the domain with ``phi`` and ``u`` as point data.

    Parameters
    ----------
    path : str or path-like
        ``.vtu`` (or ``.vtk``).
    result : RelaxResult
    labels : array-like, optional
        The labels given to :func:`~ndboundary.relax`, written as cell data ``labels``
        (element labels) or point data ``labels`` (vertex labels). When the domain was
        not padded, the unit field and the smoothed field are written as cell data too.

    Raises
    ------
    ValueError
        On another extension or labels of the wrong length.
    """
    ext = _suffix(path, {".vtu", ".vtk"}, "phi (VTK)")
    domain = result.domain
    point_data = {"phi": result.phi, "u": result.u}
    cell_data = {}
    if labels is not None:
        labels = np.asarray(labels)
        if labels.dtype.kind not in "biuf":
            labels = (labels == result.classes[1]).astype(np.int64)
        on = result.params.get("on", "elements")
        (cell_data if on == "elements" else point_data)["labels"] = labels
    if result.field.shape[0] == domain.n_elements:
        cell_data["field"] = _points3(result.field)
        cell_data["smoothed_field"] = _points3(result.smoothed_field)
    write_mesh(path, domain, point_data=point_data, cell_data=cell_data)
    return ext


def write_level_set(path, level_set):
    """Write a level set (segments, triangles or tetrahedra) to ``.obj``, ``.ply``, ``.vtk`` or ``.vtu``.

    Parameters
    ----------
    path : str or path-like
    level_set : LevelSet
        E.g. ``result.level_set()``. Curves are written as line segments (OBJ ``l``
        lines, PLY ``edge`` elements), surfaces as triangles.

    Raises
    ------
    ValueError
        On another extension, or tetrahedra (3-D level sets of 4-D domains) to OBJ or PLY.
    """
    ext = _suffix(path, {".obj", ".ply", ".vtk", ".vtu"}, "level set")
    k = level_set.simplices.shape[1]
    kind = {2: "line", 3: "triangle", 4: "tetra"}.get(k)
    if kind is None:
        raise ValueError(f"{path}: cannot write a level set made of {k - 1}-simplices")
    if kind == "tetra" and ext in (".obj", ".ply"):
        raise ValueError(f"{path}: the {ext} format cannot hold tetrahedra; use .vtu or .vtk")
    if ext == ".obj":
        _write_obj(path, level_set.points, [(kind, level_set.simplices)])
    elif ext == ".ply":
        _write_ply(path, level_set.points, kind, level_set.simplices)
    else:
        _write_meshio(path, ext, level_set.points, [(kind, level_set.simplices)], [np.arange(len(level_set))], {}, {})


def _write_ply(path, points, kind, simplices):
    pts = _points3(points)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("ply\nformat ascii 1.0\ncomment written by ndboundary\n")
        fh.write(f"element vertex {pts.shape[0]}\nproperty double x\nproperty double y\nproperty double z\n")
        if kind == "line":
            fh.write(f"element edge {simplices.shape[0]}\nproperty int vertex1\nproperty int vertex2\n")
        else:
            fh.write(f"element face {simplices.shape[0]}\nproperty list uchar int vertex_indices\n")
        fh.write("end_header\n")
        np.savetxt(fh, pts, fmt="%.17g")
        if kind == "line":
            np.savetxt(fh, simplices, fmt="%d")
        else:
            np.savetxt(fh, np.concatenate([np.full((simplices.shape[0], 1), 3), simplices], axis=1), fmt="%d")


# -- labels -------------------------------------------------------------------------------------

def read_labels(path):
    """Read labels: one per line, optionally after a ``SCALAR_FIELD n`` header; or a ``.npy`` array.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    ndarray of shape (n,)
        Integers when every label is an integer, else floats, else strings.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    ValueError
        On an empty file, a header whose count disagrees with the number of labels,
        or a ``.npy`` array that is not one-dimensional.
    """
    path = _existing(path)
    if path.suffix.lower() == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except Exception as exc:
            raise ValueError(f"{path}: could not read as .npy: {exc}") from None
        if arr.ndim != 1:
            raise ValueError(f"{path}: labels must be one-dimensional, got an array of shape {arr.shape}")
        return arr
    try:
        with open(path, encoding="utf-8") as fh:
            tokens = [ln.strip() for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file of labels: {exc}") from None
    expected = None
    if tokens and tokens[0].upper().startswith("SCALAR_FIELD"):
        head = tokens.pop(0).split()
        try:
            expected = int(head[1])
        except (IndexError, ValueError):
            raise ValueError(f"{path}: malformed header {' '.join(head)!r}; expected 'SCALAR_FIELD n'") from None
    if not tokens:
        raise ValueError(f"{path}: no labels in the file")
    if expected is not None and expected != len(tokens):
        raise ValueError(f"{path}: the header announces {expected} labels but the file holds {len(tokens)}")
    for conv in (int, float):
        try:
            return np.array([conv(t) for t in tokens])
        except ValueError:
            continue
    return np.array(tokens)


def write_labels(path, labels, *, header=False):
    """Write labels one per line (``.npy``: a NumPy array file).

    Parameters
    ----------
    path : str or path-like
    labels : array-like of shape (n,)
    header : bool, default=False
        Precede the labels with ``SCALAR_FIELD n``, as the paper's reference code does.

    Raises
    ------
    ValueError
        When ``labels`` is not one-dimensional or is empty.
    """
    arr = np.asarray(labels)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"labels must be a non-empty one-dimensional array, got shape {arr.shape}")
    path = Path(os.fspath(path))
    if path.suffix.lower() == ".npy":
        np.save(path, arr)
        return
    fmt = "%.17g" if arr.dtype.kind == "f" else "%s"
    with open(path, "w", encoding="utf-8") as fh:
        if header:
            fh.write(f"SCALAR_FIELD {arr.size}\n")
        np.savetxt(fh, arr.astype(str) if fmt == "%s" else arr, fmt=fmt)
