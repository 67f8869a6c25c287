"""Shortest distances along a domain's edges, as the band search and the fill outside the
band ask for them (:meth:`~ndboundary.Domain.edge_distances`).

Both kinds answer the same call, ``distances(sources, offsets=None, limit=inf,
blocked=None)``: the distance of every vertex from the nearest source, each source
starting at its offset, along paths that avoid the ``blocked`` vertices; ``inf`` beyond
``limit`` or where no path leads. Both run the same Dijkstra
(:mod:`ndboundary._compiled_walk`), and give the same distances.

* :class:`GraphDistances` runs Dijkstra on the graph of the edges' lengths, built once and
  kept for every call.
* :class:`IncidenceDistances` walks the simplices at each vertex of a simplicial complex
  (:func:`~ndboundary._compiled_walk.incidence_distances`), without a graph: on large
  complexes the graph of the edges costs more to build than the walks that read it.

``distances.avoiding(blocked)`` gives the same distances for the paths that avoid
``blocked``, prepared for a walk that must be fast (the fill outside the band): the graph
of the edges between the other vertices, built where it pays, which the relaxation builds
while the band is being solved.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["GraphDistances", "IncidenceDistances"]


def _as_sources(sources, offsets, n_vertices):
    sources = np.asarray(sources).reshape(-1)
    if sources.size and (
        not np.issubdtype(sources.dtype, np.integer) or sources.min() < 0 or sources.max() >= n_vertices
    ):
        raise ValueError(f"sources must be vertex indices in [0, {n_vertices}); got {sources[:5].tolist()}...")
    sources = sources.astype(np.int64)
    if offsets is not None:
        offsets = np.asarray(offsets, dtype=np.float64).reshape(-1)
        if offsets.shape != sources.shape:
            raise ValueError(f"offsets has shape {offsets.shape}; expected one per source, {sources.shape}")
        if not (offsets >= 0).all():  # NaN too
            raise ValueError("offsets must be non-negative numbers (distances to start from)")
    return sources, offsets


class GraphDistances:
    """Distances along the edges of ``graph`` (lengths, both ways, shape (V, V)).

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary.domains.distances import GraphDistances
    >>> path = sp.diags([np.ones(4), np.ones(4)], [-1, 1]).tocsr()  # 5 vertices, unit edges
    >>> distances = GraphDistances(path)
    >>> distances([0]).tolist(), distances([0], limit=2.5).tolist()
    ([0.0, 1.0, 2.0, 3.0, 4.0], [0.0, 1.0, 2.0, inf, inf])
    >>> distances([0, 4], offsets=[2.0, 0.0]).tolist()  # the nearer source, its offset added
    [2.0, 3.0, 2.0, 1.0, 0.0]
    >>> distances([0], blocked=np.arange(5) == 2).tolist()  # no path through vertex 2
    [0.0, 1.0, inf, inf, inf]
    """

    def __init__(self, graph):
        self.graph = sp.csr_matrix(graph)

    def __call__(self, sources, offsets=None, limit=np.inf, blocked=None):
        """Every vertex's distance from the nearest source (plus its offset), along paths
        that avoid the vertices selected by the boolean mask ``blocked``.
        """
        from .._compiled_walk import graph_distances

        sources, offsets = _as_sources(sources, offsets, self.graph.shape[0])
        return graph_distances(self.graph, sources, offsets=offsets, limit=limit, blocked=blocked)

    def avoiding(self, blocked):
        """These distances along the paths that avoid the ``blocked`` vertices (a mask)."""
        return _Avoiding(self, np.array(blocked, dtype=bool))


class IncidenceDistances:
    """Distances along the edges of the simplicial complex ``complex_`` in units of
    ``unit``, walked over its incidence.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.domains.distances import IncidenceDistances
    >>> grid = kuhn_grid(4, 3)  # 125 vertices 0.5 apart, cells' diagonals 0.866 long
    >>> d = IncidenceDistances(grid, 0.5)([0])
    >>> float(d[0]), round(float(d.max()), 6)  # the far corner: four steps along the diagonals
    (0.0, 6.928203)
    """

    def __init__(self, complex_, unit=1.0):
        self.domain, self.unit = complex_, float(unit)

    def __call__(self, sources, offsets=None, limit=np.inf, blocked=None):
        """Every vertex's distance from the nearest source (plus its offset), along paths
        that avoid the vertices selected by the boolean mask ``blocked``.
        """
        from .._compiled_walk import incidence_distances

        d = self.domain
        sources, offsets = _as_sources(sources, offsets, d.n_vertices)
        return incidence_distances(
            d.vertex_simplices,
            d.simplices,
            d.points,
            sources,
            unit=self.unit,
            offsets=offsets,
            limit=limit,
            blocked=blocked,
        )

    def avoiding(self, blocked):
        """These distances along the paths that avoid the ``blocked`` vertices (a mask), as
        Dijkstra on the graph of the edges between the other vertices
        (:func:`~ndboundary._compiled_walk.kept_edge_graph`): the same distances, several
        times faster to walk than the simplices once the graph is built.
        """
        from .._compiled_walk import kept_edge_graph

        d = self.domain
        keep = ~np.asarray(blocked, dtype=bool)
        return GraphDistances(kept_edge_graph(d.vertex_simplices, d.simplices, d.points, keep, unit=self.unit))


class _Avoiding:
    """Distances that avoid a fixed set of vertices, and those a call adds."""

    def __init__(self, distances, blocked):
        self.distances, self.blocked = distances, blocked

    def __call__(self, sources, offsets=None, limit=np.inf, blocked=None):
        """As the distances given, with the fixed vertices blocked too."""
        blocked = self.blocked if blocked is None else self.blocked | np.asarray(blocked, dtype=bool)
        return self.distances(sources, offsets=offsets, limit=limit, blocked=blocked)
