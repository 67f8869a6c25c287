"""The sectors of a region among several: how its field is smoothed next to its neighbours.

Each region of a partition into three or more is relaxed against the rest, but its
boundary is made of interfaces with different neighbours, which meet at junctions with
an angle. Smoothed over the whole region at once, the field inside a region turns around
such a corner, and the relaxed region loses its corner: the largest function of the
partition then puts the junction where the corners' roundings meet, not where the
interfaces cross. Inside the region, its field is therefore smoothed within the sector of
each neighbour (the elements nearer to that neighbour than to any other), so that it
keeps the corner's fold along their medial line; outside, it is smoothed as one, since
around a corner a distance grows in a fan. Against smoothing each region as one
(``benchmarks/regions.py``; figures in the README) the junctions in volumes and on the
sphere lie nearer to the truth, and each region's own level set nearer to its
neighbours'. Cutting the smoothing outside the region too, between the neighbours, put
the junctions of straight interfaces nearer still, but moved those of curved ones.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import dijkstra

from .._compiled import region_walk_graph

__all__ = ["SECTOR_SMOOTHING", "region_sectors"]

#: Whether a relaxation of three or more regions smooths each region's field within its
#: sectors (read at call time; False smooths every region as one, the independent
#: one-vs-rest relaxations that ``benchmarks/regions.py`` measures against).
SECTOR_SMOOTHING = True


def region_sectors(domain, codes, region):
    """The sector of every element for the relaxation of ``region`` against the rest.

    Parameters
    ----------
    domain : Domain
    codes : ndarray of int of shape (n_elements,)
        Every element's region.
    region : int

    Returns
    -------
    ndarray of int of shape (n_elements,)
        An element inside ``region`` is in the sector of the region of the nearest element
        outside (along the element adjacency, centroid to centroid); elements outside, and
        inside ones that no element outside reaches, are in none (-1).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.sectors import region_sectors
    >>> grid = kuhn_grid(8, 2)
    >>> c = grid.element_centroids()
    >>> codes = np.where(c[:, 1] < 0, 0, np.where(c[:, 0] < 0, 1, 2))  # a T
    >>> sectors = region_sectors(grid, codes, 0)
    >>> bool((sectors[codes != 0] == -1).all())
    True
    >>> below = codes == 0  # region 0 splits between its two neighbours along x = 0
    >>> bool((sectors[below & (c[:, 0] < -0.3)] == 1).all() and (sectors[below & (c[:, 0] > 0.3)] == 2).all())
    True
    """
    codes = np.asarray(codes)
    inside = codes == region
    sectors = np.full(codes.shape, -1, dtype=np.int64)
    if inside.all() or not inside.any():
        return sectors
    # a shortest path from outside enters the region from the ring of outside elements
    # next to it and then stays inside: the walk needs the region and that ring alone
    nodes, graph = region_walk_graph(domain.adjacency, inside, domain.centroids_of)
    ring = np.flatnonzero(~inside[nodes])
    _, _, source = dijkstra(graph, directed=False, indices=ring, min_only=True, return_predecessors=True)
    reached = np.flatnonzero(inside[nodes] & (source >= 0))
    sectors[nodes[reached]] = codes[nodes[source[reached]]]
    return sectors
