"""Cell blocks, the form meshes take between files and domains.

Readers return ``(points, blocks)`` and writers take blocks; :func:`domain_from_blocks`
and :func:`blocks_from_domain` convert. A block is a pair ``(kind, data)``:

==============================================  ================================================
kind                                            data
==============================================  ================================================
``"line"``, ``"triangle"``, ``"quad"``,         integer array of shape (n, k), VTK vertex order
``"tetra"``, ``"hexahedron"``, ``"wedge"``,
``"pyramid"``
``"polygon"``                                   list of vertex index sequences
``"polyhedron"`` (``"polyhedron<n>"`` when      list of cells, each a list of faces (vertex
written: meshio's name, ``n`` vertices a cell)  index sequences)
``"hedra"``                                     ``(faces, cells)``: vertex index lists and face
                                                index lists (a HEDRA file)
==============================================  ================================================
"""

from __future__ import annotations

import numpy as np

from .._arrays import first_of_groups, group_rows
from ..domains import Domain, PolygonMesh, PolyhedralMesh, SimplicialComplex
from ..domains.polyhedral_cells import HEX_FACES, TET_FACES
from .common import flat_rows

__all__ = [
    "CELL_DIMENSIONS",
    "MESH_DOMAINS",
    "blocks_from_domain",
    "check_mesh_domain",
    "domain_from_blocks",
    "polygon_block",
    "top_blocks",
]

#: Dimension of the cells of every block kind with vertex rows (meshio's cell type names).
CELL_DIMENSIONS = {
    "line": 1,
    "triangle": 2,
    "quad": 2,
    "polygon": 2,
    "tetra": 3,
    "hexahedron": 3,
    "wedge": 3,
    "pyramid": 3,
}
#: The domains a mesh file can hold.
MESH_DOMAINS = (SimplicialComplex, PolygonMesh, PolyhedralMesh)
#: Faces of the fixed-shape solids, as local vertex indices (VTK vertex order).
_LOCAL_FACES = {
    "tetra": [list(f) for f in TET_FACES],
    "hexahedron": [list(f) for f in HEX_FACES],
    "wedge": [[0, 2, 1], [3, 4, 5], [0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]],
    "pyramid": [[0, 3, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
}


def check_mesh_domain(domain):
    """Raise a TypeError unless ``domain`` is a domain that mesh files can hold.

    Examples
    --------
    >>> from ndboundary import PolygonMesh
    >>> check_mesh_domain(PolygonMesh([[0, 0], [1, 0], [1, 1]], [[0, 1, 2]]))
    >>> check_mesh_domain("mesh")
    Traceback (most recent call last):
    ...
    TypeError: cannot write a str; expected a SimplicialComplex, PolygonMesh or PolyhedralMesh
    """
    if not isinstance(domain, MESH_DOMAINS):
        raise TypeError(
            f"cannot write a {type(domain).__name__}; expected a SimplicialComplex, PolygonMesh or PolyhedralMesh"
        )


# -- blocks to a domain -------------------------------------------------------------------------


def polygon_block(flat, sizes):
    """The block of polygons given as flat vertex indices and sizes, as the readers return them.

    Polygons all of three or all of four vertices become one ``"triangle"`` or
    ``"quad"`` array (what meshio reads too); others a ``"polygon"`` list, in order.

    Examples
    --------
    >>> import numpy as np
    >>> kind, rows = polygon_block(np.arange(6), np.array([3, 3]))
    >>> kind, rows.tolist()
    ('triangle', [[0, 1, 2], [3, 4, 5]])
    >>> polygon_block(np.arange(7), np.array([3, 4]))
    ('polygon', [[0, 1, 2], [3, 4, 5, 6]])
    """
    if sizes.size and sizes[0] in (3, 4) and np.all(sizes == sizes[0]):
        return ("triangle" if sizes[0] == 3 else "quad"), flat.reshape(-1, int(sizes[0]))
    values, ends = flat.tolist(), np.cumsum(sizes).tolist()
    return "polygon", [values[end - k : end] for end, k in zip(ends, sizes.tolist(), strict=True)]


def _block_dim(kind):
    return 3 if kind in ("hedra", "polyhedron") else CELL_DIMENSIONS[kind]


def _has_cells(kind, data):
    return len(data[1]) > 0 if kind == "hedra" else len(data) > 0


def top_blocks(blocks):
    """The non-empty blocks of the highest cell dimension, those a domain is made of.

    Raises
    ------
    ValueError
        When no block holds cells.

    Examples
    --------
    >>> import numpy as np
    >>> [k for k, _ in top_blocks([("line", np.array([[0, 1]])), ("triangle", np.array([[0, 1, 2]])), ("tetra", [])])]
    ['triangle']
    """
    blocks = [(k, d) for k, d in blocks if _has_cells(k, d)]
    if not blocks:
        raise ValueError("the file holds no cells (segments, polygons or solids)")
    top = max(_block_dim(k) for k, _ in blocks)
    return [(k, d) for k, d in blocks if _block_dim(k) == top]


def _index_rows(kind, data):
    """The vertex index rows of a block, and (for ``"hedra"``) its face index rows, as ``flat_rows`` gives them."""
    if kind == "hedra":
        return flat_rows(data[0]), flat_rows(data[1])
    if kind == "polyhedron":
        return flat_rows([f for cell in data for f in cell]), None
    return flat_rows(data), None


def _check_indices(n_points, blocks):
    """Refuse indices outside ``0..n_points - 1`` (for the faces of ``"hedra"`` blocks: ``0..n_faces - 1``)."""
    for kind, data in blocks:
        (vertices, sizes), faces = _index_rows(kind, data)
        checks = [(vertices, n_points, "vertex")] + ([(faces[0], sizes.size, "face")] if faces else [])
        for idx, n, what in checks:
            bad = (idx < 0) | (idx >= n)
            if bad.any():
                raise ValueError(f"{kind} cells list {what} {int(idx[bad][0])}, outside 0..{n - 1}")


def _drop_unused(points, blocks):
    """Remove the vertices no cell uses, renumbering the cells."""
    used = np.zeros(points.shape[0], dtype=bool)
    for kind, data in blocks:
        used[_index_rows(kind, data)[0][0]] = True
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


def _polyhedra_from_blocks(blocks):
    """Faces and face-index cells of solid blocks (fixed shapes and explicit polyhedra), shared faces merged."""
    faces, cells = [], []
    for kind, data in blocks:
        if kind == "polyhedron":
            for cell in data:
                start = len(faces)
                faces.extend(list(np.asarray(f)) for f in cell)
                cells.append(list(range(start, len(faces))))
        else:
            arr = np.asarray(data)
            local = _LOCAL_FACES[kind]
            start = len(faces)
            for row in arr:
                faces.extend([row[f] for f in local])
            nloc = len(local)
            cells.extend([list(range(start + i * nloc, start + (i + 1) * nloc)) for i in range(arr.shape[0])])
    # faces with the same vertex set are one face
    width = max(len(f) for f in faces)
    pad = np.full((len(faces), width), -1, dtype=np.int64)
    for i, f in enumerate(faces):
        pad[i, : len(f)] = np.sort(f)
    ids, n = group_rows(pad)
    first = first_of_groups(ids, n)
    return [faces[i] for i in first], [ids[c] for c in cells]


def domain_from_blocks(points, blocks, *, drop_unused=True) -> Domain:
    """The domain holding the highest-dimensional cells of a file's blocks.

    Parameters
    ----------
    points : ndarray of shape (n_vertices, 3)
    blocks : list of (kind, data)
        Empty blocks are ignored; of the others, only those of the highest cell
        dimension are kept (a solid's boundary triangles would be no part of it).
    drop_unused : bool, default=True
        Remove the vertices no kept cell uses, renumbering the rest in order: they carry
        no measure and would leave the relaxation's linear systems singular.

    Returns
    -------
    SimplicialComplex, PolygonMesh or PolyhedralMesh
        Segments, triangles or tetrahedra alone give a SimplicialComplex (triangles of
        any polygon block count); other polygons a PolygonMesh; other solids a
        PolyhedralMesh. Curves and surfaces whose third coordinate is zero everywhere
        get 2-D points.

    Raises
    ------
    ValueError
        When no block holds cells, a cell indexes a vertex (or face) that is not there,
        or the cells are invalid for the domain.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [5, 5, 0]], dtype=float)
    >>> square = domain_from_blocks(points, [("quad", np.array([[0, 1, 2, 3]])), ("line", np.array([[0, 1]]))])
    >>> type(square).__name__, square.n_vertices, square.dim
    ('PolygonMesh', 4, 2)
    """
    blocks = top_blocks(blocks)
    top = _block_dim(blocks[0][0])
    _check_indices(points.shape[0], blocks)
    if drop_unused:
        points, blocks = _drop_unused(points, blocks)
    kinds = {k for k, _ in blocks}
    if top <= 2 and points.shape[1] == 3 and not np.any(points[:, 2]):
        points = points[:, :2]
    if top == 1:
        return SimplicialComplex(points, np.concatenate([np.asarray(d, dtype=np.int64) for _, d in blocks]))
    if top == 2:
        widths = {d.shape[1] if isinstance(d, np.ndarray) and d.ndim == 2 else None for _, d in blocks}
        if len(widths) == 1 and None not in widths:  # arrays of one width: no lists of rows
            cells = np.concatenate([np.asarray(d, dtype=np.int64) for _, d in blocks])
            return (SimplicialComplex if cells.shape[1] == 3 else PolygonMesh)(points, cells)
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
    faces, cells = _polyhedra_from_blocks(blocks)
    return PolyhedralMesh(points, faces, cells)


# -- a domain to blocks -------------------------------------------------------------------------


def _oriented_loops(mesh, c):
    """The face vertex loops of cell ``c`` of a PolyhedralMesh, each turning outwards."""
    loops = []
    for k in range(mesh.cell_offsets[c], mesh.cell_offsets[c + 1]):
        f = mesh.cell_faces[k]
        loop = mesh.face_indices[mesh.face_offsets[f] : mesh.face_offsets[f + 1]]
        loops.append(loop if mesh.cell_face_signs[k] > 0 else loop[::-1])
    return loops


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
        nbr = {}
        bottom = None
        for loop in _oriented_loops(mesh, c):
            if bottom is None:  # the first face, reversed to face into the cell: VTK's bottom quad
                bottom = [loop[0], loop[3], loop[2], loop[1]]
            for a, b in zip(loop, np.roll(loop, -1), strict=True):
                nbr.setdefault(a, set()).add(b)
                nbr.setdefault(b, set()).add(a)
        top = [next(iter(nbr[v] - set(bottom))) for v in bottom]  # across each bottom vertex's vertical edge
        hexes[c] = bottom + top
    return "hexahedron", hexes


def blocks_from_domain(domain):
    """The cell blocks of a mesh domain and, per block, the element indices it holds.

    Parameters
    ----------
    domain : SimplicialComplex, PolygonMesh or PolyhedralMesh

    Returns
    -------
    blocks : list of (kind, data)
        One block for a SimplicialComplex (segments, triangles or tetrahedra); one per
        polygon size for a PolygonMesh (``"triangle"``, ``"quad"``, ``"polygon"``); for a
        PolyhedralMesh one ``"tetra"`` or ``"hexahedron"`` block when its cells all are
        such, else one ``"polyhedron<n>"`` block per number ``n`` of cell vertices.
    order : list of ndarray of int
        The elements of every block, to reorder per-element data alike.

    Raises
    ------
    ValueError
        For simplices beyond tetrahedra.
    TypeError
        When ``domain`` is not one of the mesh domains.

    Examples
    --------
    >>> from ndboundary import PolygonMesh
    >>> mesh = PolygonMesh([[0, 0], [1, 0], [1, 1], [0, 1], [2, 0]], [[0, 1, 2, 3], [1, 4, 2]])
    >>> blocks, order = blocks_from_domain(mesh)
    >>> [(kind, rows.tolist()) for kind, rows in blocks], [o.tolist() for o in order]
    ([('triangle', [[1, 4, 2]]), ('quad', [[0, 1, 2, 3]])], [[1], [0]])
    """
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
    check_mesh_domain(domain)
    std = _hexes_or_tets(domain)
    if std is not None:
        return [std], [np.arange(domain.n_elements)]
    cells = [_oriented_loops(domain, c) for c in range(domain.n_elements)]
    nv = np.bincount(domain.cell_vertices[0], minlength=domain.n_elements)
    blocks, order = [], []
    for m in np.unique(nv):
        els = np.flatnonzero(nv == m)
        blocks.append((f"polyhedron{int(m)}", [cells[e] for e in els]))
        order.append(els)
    return blocks, order
