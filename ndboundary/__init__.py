"""ndboundary: relax jagged boundaries between two labelled regions into smooth level sets.

The method of Livesu, "A Heat Flow Based Relaxation Scheme for n Dimensional Discrete
Hyper Surfaces" (Computers & Graphics, 2018), over any domain that provides a
Laplacian, a gradient and a divergence.

Where things are: :mod:`ndboundary.domains` (one module per kind of discretisation),
:mod:`ndboundary.pipeline` (one module per step of the paper), :mod:`ndboundary.solvers`,
:mod:`ndboundary.levelset`, :mod:`ndboundary.learn` (the classifier), :mod:`ndboundary.io`,
:mod:`ndboundary.datasets`, :mod:`ndboundary.plot` and :mod:`ndboundary.cli`.
"""

from . import datasets, io
from .domains import (
    DelaunayComplex,
    Domain,
    ImageGrid,
    MeshQualityWarning,
    PointCloud,
    PolygonMesh,
    PolyhedralMesh,
    SimplicialComplex,
    delaunay_complex,
)
from .io import (
    read_image,
    read_labels,
    read_mesh,
    write_image,
    write_interfaces,
    write_labels,
    write_level_set,
    write_mesh,
    write_partition,
    write_phi,
)
from .images import relax_image
from .levelset import LevelSet, marching_simplices
from .pipeline import DEFAULT_LAM, DEFAULT_MU, DEFAULT_SMOOTHING, PAPER, Boundary, Relaxer, RelaxResult, relax

__version__ = "0.1.0"


def __getattr__(name):
    """Load :mod:`ndboundary.learn` on first use of it or of ``LevelSetClassifier``.

    The classifier needs scikit-learn, whose import takes longer than the rest of the
    package's: the command line and the relaxation of meshes and images do without it.
    """
    if name in ("learn", "LevelSetClassifier"):
        import importlib

        learn = importlib.import_module(".learn", __name__)
        return learn if name == "learn" else learn.LevelSetClassifier
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), "learn", *__all__})


__all__ = [
    "DEFAULT_LAM",
    "DEFAULT_MU",
    "DEFAULT_SMOOTHING",
    "PAPER",
    "Boundary",
    "DelaunayComplex",
    "Domain",
    "ImageGrid",
    "LevelSet",
    "LevelSetClassifier",
    "MeshQualityWarning",
    "PointCloud",
    "PolygonMesh",
    "PolyhedralMesh",
    "RelaxResult",
    "Relaxer",
    "SimplicialComplex",
    "datasets",
    "delaunay_complex",
    "io",
    "marching_simplices",
    "read_image",
    "read_labels",
    "read_mesh",
    "relax",
    "relax_image",
    "write_image",
    "write_interfaces",
    "write_labels",
    "write_level_set",
    "write_mesh",
    "write_partition",
    "write_phi",
]
