"""ndboundary: relax jagged boundaries between two labelled regions into smooth level sets.

The method of Livesu, "A Heat Flow Based Relaxation Scheme for n Dimensional Discrete
Hyper Surfaces" (Computers & Graphics, 2018), over any domain that provides a
Laplacian, a gradient and a divergence.
"""

from .domain import Domain
from .levelset import LevelSet, marching_simplices
from .pipeline import DEFAULT_LAM, DEFAULT_MU, DEFAULT_SMOOTHING, PAPER, Boundary, RelaxResult, relax
from .classifier import LevelSetClassifier
from .pointcloud import PointCloud, delaunay_complex
from .polygon import PolygonMesh
from .polyhedral import PolyhedralMesh
from .simplicial import SimplicialComplex
from . import io

__version__ = "0.1.0"

__all__ = [
    "Domain",
    "SimplicialComplex",
    "PolygonMesh",
    "PolyhedralMesh",
    "PointCloud",
    "delaunay_complex",
    "LevelSetClassifier",
    "io",
    "relax",
    "RelaxResult",
    "Boundary",
    "LevelSet",
    "marching_simplices",
    "DEFAULT_LAM",
    "DEFAULT_SMOOTHING",
    "DEFAULT_MU",
    "PAPER",
]
