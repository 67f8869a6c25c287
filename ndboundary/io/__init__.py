"""Reading and writing meshes, relaxed functions, level sets and labels.

Formats, chosen by the file extension (case-insensitive):

========================  ==============================  ==============================
extension                 read                            write
========================  ==============================  ==============================
``.obj``, ``.off``        triangles, polygons, segments   triangles, polygons, segments
``.hedra``                polyhedra (CinoLib)             polyhedra, tetrahedra
``.ply``                  triangles, polygons (meshio     triangles, polygons
                          for the uncommon layouts)
``.stl``                  triangles (meshio)              triangles
``.mesh`` (MEDIT),        triangles, quads, tetrahedra,   the same
``.msh`` (Gmsh)           hexahedra, wedges, pyramids
``.vtk``, ``.vtu``        any of the above; ``.vtu``      any (``.vtu`` also general
                          also general polyhedra          polyhedra)
``.vtp``                                                  level sets and interfaces:
                                                          segments, triangles
========================  ==============================  ==============================

meshio (optional dependency, ``meshio>=5.3``) is imported only for the formats it
handles; OBJ, OFF and HEDRA are read and written here (meshio's OFF is triangles
only, and its OBJ ignores segments), and so are the PLY files of one vertex and one
face element whose faces all have the same size (or any sizes, in ASCII), with the
result meshio gives. OBJ, OFF and ASCII PLY files of a megabyte or more are read in
one compiled pass over their bytes, and the text writers format large arrays in one
compiled pass too (a million-vertex mesh is read or written in about a second:
``benchmarks/io_speed.py``). Any file the compiled pass does not read in full is read
again line by line (or by meshio), so that errors keep their messages and lines.
``.vtu`` files of cells of fixed size are written here too (:mod:`ndboundary.io.vtu`), in
VTK's own compressed layout, compressed on several threads, several times faster than
meshio's encoding (``benchmarks/io_speed.py``); meshio reads them, and writes the
``.vtu`` files of general polyhedra.

:func:`read_mesh` returns the matching domain: a :class:`~ndboundary.SimplicialComplex`
for segments, triangles or tetrahedra alone, a :class:`~ndboundary.PolygonMesh` for
quads and polygons, a :class:`~ndboundary.PolyhedralMesh` for other solids. When a
file holds cells of several dimensions (a MEDIT file listing the boundary triangles
of a tetrahedral solid), the highest-dimensional cells are kept; vertex indices are
kept as in the file, except that vertices no kept cell uses are dropped (see
:func:`read_mesh`). A curve or surface mesh whose third coordinate is zero everywhere is
read with 2-D points.

Readers check what they read against the format's own conventions and refuse, with a
``ValueError`` naming the file, the line (for line-based formats) and the value, vertex
indices outside the file's vertices, header counts that disagree with the content and
NaN or infinite coordinates; a leading UTF-8 byte-order mark is skipped. Triangle soups
(STL files, and surfaces whose faces have their own copies of their vertices) are
welded: see ``weld`` in :func:`read_mesh` and :class:`WeldReport`.

Modules:

==============================  ===========================================================
module                          holds
==============================  ===========================================================
:mod:`.meshes`                  :func:`read_mesh`, :func:`write_mesh`: dispatch by extension
:mod:`.results`                 :func:`write_phi`, :func:`write_level_set`
:mod:`.regions`                 :func:`region_names`, :func:`write_partition`,
                                :func:`write_interfaces`: several regions' names, cells
                                and interfaces
:mod:`.labels`                  :func:`read_labels`, :func:`write_labels`
:mod:`.images`                  :func:`read_image`, :func:`write_image`, :class:`Image`: label
                                images and volumes (NIfTI, NRRD, TIFF, ``.npy``)
:mod:`.cell_blocks`             cell blocks (the form between files and domains) to domains
                                and back
:mod:`.obj`, :mod:`.off`,       one format each: Wavefront OBJ, OFF, CinoLib HEDRA, PLY (its
:mod:`.hedra`, :mod:`.ply`,     common layouts, and the ASCII level-set writer), STL (the
:mod:`.stl`                     binary level-set writer, and ASCII named solids for the
                                interfaces)
:mod:`.vtu`                     VTK XML files written in VTK's compressed layout: ``.vtu``
                                of cells of fixed size, ``.vtp`` of segments or triangles
:mod:`.meshio_formats`          PLY, STL, MEDIT, Gmsh, VTK and VTU through meshio; VTK data
                                types
:mod:`.text_scan`,              compiled (numba) scans of OBJ, OFF and PLY text; decimal
:mod:`.text_numbers`            tokens, correctly rounded
:mod:`.text_format`             compiled ``%.17g`` and integer text of the writers
:mod:`.weld`                    merging coincident vertices, :class:`WeldReport`
:mod:`.common`                  file and extension checks, number tokens, 3-D points
==============================  ===========================================================
"""

from .images import Image, read_image, write_image
from .labels import read_labels, write_labels
from .meshes import read_mesh, write_mesh
from .regions import region_names, write_interfaces, write_partition
from .results import write_level_set, write_phi
from .weld import WeldReport

__all__ = [
    "read_mesh",
    "write_mesh",
    "write_phi",
    "write_partition",
    "write_interfaces",
    "write_level_set",
    "region_names",
    "read_labels",
    "write_labels",
    "read_image",
    "write_image",
    "Image",
    "WeldReport",
]
