"""Built-in example domains and labellings with a known smooth truth.

The one public home of the example domains (:func:`kuhn_grid`, :func:`icosphere`,
:func:`quad_grid`, :func:`hex_grid`, :func:`voronoi_polygons`) and of the smooth truths
(signed functions, negative inside: :func:`circle`, :func:`flower`, :func:`ball`,
:func:`torus`) used by the demo, the tests and the benchmarks; nothing is downloaded.
"""

from .grids import hex_grid, icosphere, kuhn_grid, quad_grid, voronoi_polygons
from .truths import ball, circle, flower, flower_curve, label_by, torus

__all__ = [
    "ball",
    "circle",
    "flower",
    "flower_curve",
    "hex_grid",
    "icosphere",
    "kuhn_grid",
    "label_by",
    "quad_grid",
    "torus",
    "voronoi_polygons",
]
