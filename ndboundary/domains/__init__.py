"""The domains: each kind of discretisation builds the operators of the relaxation.

=========================  ===================================================
module                     domain
=========================  ===================================================
:mod:`.base`               :class:`Domain`, the protocol every domain follows
:mod:`.simplicial`         :class:`SimplicialComplex`: simplices of any dimension
:mod:`.polygon`            :class:`PolygonMesh`: quads and general polygons
:mod:`.polyhedral`         :class:`PolyhedralMesh`: hexahedra and general polyhedra
:mod:`.image`              :class:`ImageGrid`: the pixels or voxels of a label image;
                           :class:`GridBand`: some of them (a large image's band)
:mod:`.pointcloud`         :class:`PointCloud`: a kNN graph over data points
:mod:`.delaunay`           :class:`DelaunayComplex`: Delaunay simplices over data
=========================  ===================================================
"""

from .base import Domain, MeshQualityWarning
from .simplex_geometry import kuhn_grid_stiffness
from .delaunay import DelaunayComplex, delaunay_complex
from .image import GridBand, ImageGrid, PixelBand, PixelGrid, VoxelBand, VoxelGrid
from .pointcloud import PointCloud
from .polygon import PolygonMesh
from .polyhedral import PolyhedralMesh
from .simplicial import SimplicialComplex

__all__ = [
    "DelaunayComplex",
    "Domain",
    "GridBand",
    "ImageGrid",
    "MeshQualityWarning",
    "PixelBand",
    "PixelGrid",
    "PointCloud",
    "PolygonMesh",
    "PolyhedralMesh",
    "SimplicialComplex",
    "VoxelBand",
    "VoxelGrid",
    "delaunay_complex",
    "kuhn_grid_stiffness",
]
