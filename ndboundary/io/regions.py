"""Writing the regions of a relaxation: their names, the exact partition and the interfaces.

:func:`region_names` names the regions wherever a file does (array names, OBJ groups,
the command line's file names); :func:`write_partition` writes the refined cells of
``result.partition()``, each with its region, and :func:`write_interfaces` the
interfaces between the regions, each piece with the pair it separates (OBJ groups, PLY
properties or VTK cell data). Both take two-region results too.
"""

from __future__ import annotations

import re

import numpy as np

from .common import format_suffix, points_3d
from .meshio_formats import SIMPLEX_KINDS, check_simplices_format, vtk_values, write_with_meshio
from .stl import write_ascii_stl_solids
from .text_format import points_text, rows_text
from .vtu import write_vtp

__all__ = ["MAX_NAME_LENGTH", "region_names", "write_interfaces", "write_partition"]

#: The longest region name :func:`region_names` makes from a class.
MAX_NAME_LENGTH = 64
#: The characters a region name keeps: letters, digits, ``_``, ``.``, ``+`` and ``-``.
_UNSAFE = re.compile(r"[^\w.+-]+")


def region_names(classes):
    """Names of the regions, for data arrays, OBJ groups and file names: the classes as text, made safe.

    Each class is written as text (``str``), every run of characters other than
    letters, digits, ``_``, ``.``, ``+`` and ``-`` becomes one ``_``, and the result is
    cut to :data:`MAX_NAME_LENGTH` characters. A class that leaves nothing is named by
    its index; and when two names would be equal, ignoring case (as some file systems
    do), every region is named by its index, so that the names always tell the regions
    apart.

    Parameters
    ----------
    classes : array-like of shape (n_regions,)
        The label values of the regions (``result.classes``).

    Returns
    -------
    list of str

    Examples
    --------
    >>> region_names([0, 1, 7]), region_names(["air", "soft tissue", "bone"])
    (['0', '1', '7'], ['air', 'soft_tissue', 'bone'])
    >>> region_names([0.5, 1.5]), region_names(["a b", "a_b", "c"])
    (['0.5', '1.5'], ['0', '1', '2'])
    """
    names = []
    for r, c in enumerate(np.asarray(classes).reshape(-1).tolist()):
        name = _UNSAFE.sub("_", str(c)).strip("_")[:MAX_NAME_LENGTH]
        names.append(name or str(r))
    if len({n.lower() for n in names}) < len(names):
        return [str(r) for r in range(len(names))]
    return names


def write_partition(path, result):
    """Write the relaxed partition for ParaView: the refined cells, each with its region as cell data.

    The cells are those of ``result.partition().cells`` (the domain's simplicial
    refinement cut where two region functions tie: every cell lies in one region), so
    that a Threshold on ``region`` shows one region exactly and the cells' measures per
    region sum to ``result.region_measures()``.

    Parameters
    ----------
    path : str or path-like
        ``.vtu`` (or ``.vtk``).
    result : RelaxResult or RegionsResult
        What :func:`~ndboundary.relax` returned.

    Notes
    -----
    The cell data are ``region``, the index of the cell's region in ``result.classes``
    (int64), and, when the classes are numbers (integers, floats or booleans),
    ``label``, the class value itself.

    Raises
    ------
    ValueError
        On another extension.

    Examples
    --------
    >>> import os, tempfile
    >>> import meshio
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> grid = kuhn_grid(8, 2)
    >>> x = grid.element_centroids()[:, 0]
    >>> result = relax(grid, np.digitize(x, [-0.3, 0.3]) * 10, on="elements")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "partition.vtu")
    ...     write_partition(path, result)
    ...     back = meshio.read(path)
    >>> sorted(back.cell_data), np.unique(back.cell_data["label"][0]).tolist()
    (['label', 'region'], [0, 10, 20])
    """
    format_suffix(path, {".vtu", ".vtk"}, "partition (VTK)")
    cells = result.partition().cells
    k = cells.simplices.shape[1]
    regions = np.asarray(cells.regions, dtype=np.int64)
    cell_data = {"region": regions}
    labels = vtk_values(np.asarray(result.classes))
    if labels is not None:
        cell_data["label"] = labels[regions]
    order = [np.arange(regions.size)]
    write_with_meshio(path, cells.points, [(SIMPLEX_KINDS[k], cells.simplices)], order=order, cell_data=cell_data)


def _interface_pieces(result):
    """The points, simplices and region pairs of a result's interfaces.

    A two-region result gives its level set ``phi = 1/2`` (what :func:`write_level_set`
    writes of ``result.level_set()``), every piece between regions 0 and 1.
    """
    if hasattr(result, "level_set"):
        level_set = result.level_set()
        pairs = np.tile(np.array([[0, 1]], dtype=np.int64), (level_set.n_simplices, 1))
        return level_set.points, level_set.simplices, pairs
    if not hasattr(result, "interfaces"):
        raise TypeError(f"result must be what ndboundary.relax returns, got {type(result).__name__}")
    faces = result.interfaces()
    return faces.points, faces.simplices, np.asarray(faces.pairs, dtype=np.int64)


def _write_obj_groups(path, points, simplices, pairs, names):
    """An OBJ file of the interfaces: one group ``g <a>|<b>`` per pair of regions, its pieces in it."""
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))
    simplices, pairs = simplices[order], pairs[order]
    starts = np.flatnonzero(np.r_[True, (pairs[1:] != pairs[:-1]).any(axis=1)]) if len(pairs) else np.zeros(0, int)
    ends = np.r_[starts[1:], len(pairs)].astype(int)
    prefix = "l " if simplices.shape[1] == 2 else "f "
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("# written by ndboundary\n# interfaces between relaxed regions: one group <a>|<b> per pair\n")
        fh.write(points_text(points_3d(points), "v %.17g %.17g %.17g\n"))
        for start, end in zip(starts, ends, strict=True):
            a, b = (int(i) for i in pairs[start])
            fh.write(f"# between region {a} and region {b}, oriented from {a} towards {b}\n")
            fh.write(f"g {names[a]}|{names[b]}\n")
            fh.write(rows_text(simplices[start:end], base=1, prefix=prefix))


def _write_ply_pairs(path, points, simplices, pairs, names):
    """An ASCII PLY file of the interfaces, each edge or face with the properties ``region_a`` and ``region_b``."""
    pts = points_3d(points)
    n, k = simplices.shape
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("ply\nformat ascii 1.0\ncomment written by ndboundary\n")
        fh.write("comment interfaces between relaxed regions; region_a, region_b: the regions on either side\n")
        for r, name in enumerate(names):
            fh.write(f"comment region {r}: {name}\n")
        fh.write(f"element vertex {pts.shape[0]}\nproperty double x\nproperty double y\nproperty double z\n")
        if k == 2:
            fh.write(f"element edge {n}\nproperty int vertex1\nproperty int vertex2\n")
            rows = np.column_stack([simplices, pairs])
        else:
            fh.write(f"element face {n}\nproperty list uchar int vertex_indices\n")
            rows = np.column_stack([np.full(n, k, dtype=np.int64), simplices, pairs])
        fh.write("property int region_a\nproperty int region_b\nend_header\n")
        fh.write(points_text(pts, "%.17g %.17g %.17g\n"))
        fh.write(rows_text(rows.astype(np.int64)))


def write_interfaces(path, result):
    """Write the interfaces between the relaxed regions, each piece with the two regions it separates.

    Parameters
    ----------
    path : str or path-like
        ``.obj``, ``.ply``, ``.stl``, ``.vtk``, ``.vtp`` or ``.vtu``.
    result : RelaxResult or RegionsResult
        What :func:`~ndboundary.relax` returned. Its interfaces
        (:meth:`~ndboundary.pipeline.result.RegionsResult.interfaces`) are written: curves
        as segments, surfaces as triangles, each oriented with its normal from the
        smaller region index ``a`` towards the larger ``b``. A two-region result gives its
        level set ``phi = 1/2``: the file :func:`write_level_set` writes of
        ``result.level_set()``, with the pair (0, 1).

    Notes
    -----
    How each format holds the pair:

    - OBJ: one group (``g``) per pair, named ``<a>|<b>`` from :func:`region_names` of
      ``result.classes`` (``g air|bone``), its pieces listed under it;
    - PLY: the edge or face properties ``region_a`` and ``region_b`` (ints; comments
      name the regions);
    - STL (surfaces only): ASCII, one ``solid <a>|<b>`` per pair, named as OBJ's groups
      (binary STL, which :func:`write_level_set` writes, has no names);
    - VTK, VTP, VTU: the cell data ``region_a`` and ``region_b`` (int64), and ``label_a``
      and ``label_b``, the class values, when the classes are numbers.

    Raises
    ------
    ValueError
        On another extension, interfaces made of points (a curve's regions meet at
        points), curves to STL, or tetrahedra (the interfaces of 4-D domains) to OBJ,
        PLY, STL or VTP.
    TypeError
        When ``result`` is not a relaxation result.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from ndboundary import relax
    >>> from ndboundary.datasets import kuhn_grid
    >>> grid = kuhn_grid(8, 2)
    >>> x = grid.element_centroids()[:, 0]
    >>> tissue = np.where(x < -0.3, "air", np.where(x < 0.3, "fat", "bone"))
    >>> result = relax(grid, tissue, on="elements")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "interfaces.obj")
    ...     write_interfaces(path, result)
    ...     groups = [line.split()[1] for line in open(path) if line.startswith("g ")]
    >>> groups
    ['air|fat', 'bone|fat']
    """
    ext = format_suffix(path, {".obj", ".ply", ".stl", ".vtk", ".vtp", ".vtu"}, "interfaces")
    points, simplices, pairs = _interface_pieces(result)
    k = simplices.shape[1]
    kind = SIMPLEX_KINDS.get(k)
    if kind is None:
        what = "points" if k == 1 else f"{k - 1}-simplices"
        raise ValueError(f"{path}: cannot write interfaces made of {what}")
    check_simplices_format(path, ext, kind, curve="curves")
    names = region_names(result.classes)
    if ext == ".obj":
        _write_obj_groups(path, points, simplices, pairs, names)
    elif ext == ".ply":
        _write_ply_pairs(path, points, simplices, pairs, names)
    elif ext == ".stl":
        pair_ids, group = np.unique(pairs, axis=0, return_inverse=True)
        solids = {g: f"{names[a]}|{names[b]}" for g, (a, b) in enumerate(pair_ids.tolist())}
        write_ascii_stl_solids(path, points, simplices, group.reshape(-1), solids)
    else:
        cell_data = {"region_a": pairs[:, 0], "region_b": pairs[:, 1]}
        labels = vtk_values(np.asarray(result.classes))
        if labels is not None:
            cell_data.update(label_a=labels[pairs[:, 0]], label_b=labels[pairs[:, 1]])
        if ext == ".vtp":
            write_vtp(path, points, kind, simplices, cell_data=cell_data)
        else:
            order = [np.arange(pairs.shape[0])]
            write_with_meshio(path, points, [(kind, simplices)], order=order, cell_data=cell_data)
