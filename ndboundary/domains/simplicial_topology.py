"""The topology of simplicial complexes: edges, facets, adjacency, read off the simplices.

:class:`SimplicialTopology` is the part of :class:`~ndboundary.SimplicialComplex` that
needs no coordinates beyond edge lengths: the unique edges and the edge of every vertex
pair, the facets and the simplices across them, the interface between two labels. On
tetrahedra and up, compiled passes over the vertex-simplex incidence build the edge
graph and the adjacency without the sorted tables of every vertex pair and facet.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np
import scipy.sparse as sp

from .._arrays import (
    counting_sort,
    group_rows,
    index_dtype,
    mixed_facets,
    pair_groups,
    shared_facet_adjacency,
    sort_rows,
)
from .queries import as_mask
from .simplex_geometry import COMPILED_MIN_VERTICES_PER_SIMPLEX, compiled_passes, simplex_edges, simplex_incidence

__all__ = ["SimplicialTopology"]


#: :meth:`SimplicialTopology.elements_at` reads the rows of the selected vertices when
#: they are fewer than this fraction's inverse of all: a column pass over every simplex
#: costs about as much as reading this many times more rows.
SPARSE_SELECTION = 8


class SimplicialTopology:
    """Edges, facets and adjacency of a complex with ``simplices``, ``sorted_simplices``,
    ``points`` and an ``incidence`` (mixed into :class:`~ndboundary.SimplicialComplex`).
    """

    #: On the complexes made by ``split_elements``, the
    #: :class:`~ndboundary.domains.simplicial_split.SplitOperators` that derive their
    #: operators from the parent's; None otherwise.
    split_from = None

    @cached_property
    def vertex_simplices(self) -> sp.csr_matrix:
        """The simplices at each vertex, in increasing order: the structure of the
        ``incidence`` (shape (n_vertices, n_elements)) with boolean entries.

        The compiled passes read the structure alone, and ``incidence`` is built from it
        when asked for: its float entries take 190 MB on a tetrahedral mesh of a million
        vertices, which finding the band and filling phi outside it do not need.
        """
        if "incidence" in self.__dict__:
            return self.incidence
        return simplex_incidence(self.simplices, self.sorted_simplices, self.n_vertices, dtype=bool)

    @property
    def _vertex_elements(self):
        """The simplices at each vertex, for the incidence queries (:attr:`vertex_simplices`)."""
        return self.vertex_simplices

    def mean_edge_length(self) -> float:
        """Mean length of the unique edges: the mesh size ``h`` of the method.

        On tetrahedra and up, and on large complexes, read off the incidence in one
        compiled pass, without building the edges.
        """
        if not compiled_passes(self.simplices) or self.split_from is not None:
            return super().mean_edge_length()
        return self._compiled_mean_edge_length

    @cached_property
    def _compiled_mean_edge_length(self) -> float:
        """The mean edge length from one compiled pass over the incidence."""
        from .._compiled_mesh import edge_length_graph

        return edge_length_graph(self.vertex_simplices, self.simplices, self.points, with_graph=False)[1]

    def edge_length_graph(self, unit=1.0) -> sp.csr_matrix:
        """The edges' lengths in units of ``unit``, both ways, shape (n_vertices, n_vertices);
        on tetrahedra and up, and on large complexes, from the incidence in two compiled
        passes, without building the edges.
        """
        if not compiled_passes(self.simplices) or self.split_from is not None:
            return super().edge_length_graph(unit)
        from .._compiled_mesh import edge_length_graph

        return edge_length_graph(self.vertex_simplices, self.simplices, self.points, unit=unit)[0]

    def vertices_of(self, elements) -> np.ndarray:
        """The vertices of the simplices selected by the boolean mask ``elements`` (a mask),
        read off the simplices a column at a time.
        """
        elements = as_mask(elements, self.n_elements, "elements")
        out = np.zeros(self.n_vertices, dtype=bool)
        for column in self.simplices.T:
            out[column[elements]] = True
        return out

    def elements_at(self, vertices) -> np.ndarray:
        """The simplices holding a vertex selected by the boolean mask ``vertices`` (a mask),
        read off the simplices, or off the rows of :attr:`vertex_simplices` when it is
        built and the vertices are few (a band among many regions'), so that the cost
        follows them beyond the mask itself.
        """
        vertices = as_mask(vertices, self.n_vertices, "vertices")
        if "vertex_simplices" in self.__dict__:
            ids = np.flatnonzero(vertices)
            if ids.size * SPARSE_SELECTION < self.n_vertices:
                out = np.zeros(self.n_elements, dtype=bool)
                out[self.vertex_simplices[ids].indices] = True
                return out
        out = vertices[self.simplices[:, 0]]
        for column in self.simplices.T[1:]:
            out |= vertices[column]
        return out

    def edge_distances(self, unit=1.0):
        """Shortest distances along the edges in units of ``unit`` (a callable, see
        :meth:`ndboundary.Domain.edge_distances`); on tetrahedra and up walked over the
        incidence, without a graph of the edges. A triangle has few edges per vertex: its
        graph costs little memory, and walks along it less than over the triangles.
        """
        if self.simplices.shape[1] < COMPILED_MIN_VERTICES_PER_SIMPLEX or self.split_from is not None:
            return super().edge_distances(unit)
        from .distances import IncidenceDistances

        return IncidenceDistances(self, unit)

    @cached_property
    def vertex_components(self):
        """Connected components of the vertices along the edges: ``(n_components, labels)``;
        on tetrahedra and up, and on large complexes, from one union-find pass over the
        simplices (the same numbering), without the edges.
        """
        if not compiled_passes(self.simplices) or self.split_from is not None:
            return super().vertex_components
        from .._compiled import row_components

        return row_components(self.simplices, self.n_vertices)

    @cached_property
    def edge_index(self):
        """The unique edges, sorted (as :attr:`edges`), and the edge of every vertex pair
        ``(srt[e, i], srt[e, j])``, ``i < j`` in ``triu_indices`` order, element-major
        (``srt = sorted_simplices``).
        """
        if self.split_from is not None:
            return self.split_from.edge_index()
        return simplex_edges(self.sorted_simplices, self.n_vertices)

    @cached_property
    def _facets(self):
        """Sorted facets of every simplex, element-major, (E*(k+1), k): facet i leaves
        out vertex i.
        """
        E, k1 = self.simplices.shape
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self.sorted_simplices[:, leave_out].reshape(E * k1, k1 - 1)

    @cached_property
    def _facet_ids(self):
        """Group id of every row of :attr:`_facets` (equal facets, equal ids), the ids in
        the lexicographic order of the facets.
        """
        if self.simplices.shape[1] == 3:
            # the facets of triangles are their edges, in the reverse order of the pairs
            # of edge_index
            return self.edge_index[1].reshape(-1, 3)[:, ::-1].ravel()
        return self._facet_groups[0]

    @cached_property
    def _facet_groups(self):
        """``(ids, order, starts)``: :attr:`_facet_ids`, and the rows of :attr:`_facets`
        grouped by facet, ``order[starts[f]:starts[f + 1]]`` holding those of facet ``f``.

        A facet of more than two vertices is known by the edge of its first two vertices
        and its other vertices: for tetrahedra, a pair sorted in linear time. The edges
        are numbered in lexicographic order, so the ids are those of the facets.
        """
        E, k1 = self.simplices.shape
        if k1 == 3:
            ids = self._facet_ids
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        if k1 == 2:
            ids = group_rows(self._facets)[0]
            order, starts = counting_sort(ids, int(ids.max()) + 1)
            return ids, order, starts
        edges, pair_edge = self.edge_index
        iu, ju = np.triu_indices(k1, 1)
        pair_of = np.zeros((k1, k1), dtype=np.intp)
        pair_of[iu, ju] = np.arange(iu.size)
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        lead = np.take(pair_edge.reshape(E, iu.size), pair_of[leave_out[:, 0], leave_out[:, 1]], axis=1).ravel()
        rest = np.take(self.sorted_simplices, leave_out[:, 2:], axis=1).reshape(E * k1, k1 - 3)
        if k1 == 4:
            n = max(edges.shape[0], self.n_vertices)
            idx = index_dtype(max(n, lead.size))
            order, new = pair_groups(lead.astype(idx), rest[:, 0].astype(idx), n)
        else:
            order, new = sort_rows(np.column_stack([lead, rest]))
        ids = np.empty(lead.size, dtype=order.dtype)
        ids[order] = np.cumsum(new, dtype=order.dtype) - 1
        starts = np.append(np.flatnonzero(new), lead.size).astype(order.dtype)
        return ids, order, starts

    def build_adjacency(self):
        """Elements sharing a facet."""
        E, k1 = self.simplices.shape
        if k1 >= COMPILED_MIN_VERTICES_PER_SIMPLEX:
            # each facet's partner among the simplices at its lowest vertex, in one pass
            from .._compiled_mesh import facet_adjacency, facet_neighbours

            across = facet_neighbours(self.vertex_simplices, self.sorted_simplices)
            rows = None if across is None else facet_adjacency(across)
            if rows is not None:
                indptr, indices = rows
                return sp.csr_matrix((np.ones(indices.size), indices, indptr), shape=(E, E))
            return shared_facet_adjacency(self._facet_groups[0], np.repeat(np.arange(E), k1), E)
        ids, order, starts = self._facet_groups
        size = np.diff(starts)
        if size.max() > 2:
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)
        # every facet in at most two simplices: each simplex's neighbours, one per
        # facet (-1 on the boundary), sorted
        first = starts[:-1][size == 2]
        a, b = order[first], order[first + 1]
        across = np.full(E * k1, -1, dtype=order.dtype)
        across[a] = b // k1
        across[b] = a // k1
        across = np.sort(across.reshape(E, k1), axis=1)
        if (across[:, 1:] == across[:, :-1])[across[:, 1:] >= 0].any():
            return shared_facet_adjacency(ids, np.repeat(np.arange(E), k1), E)  # repeated simplices
        inner = across >= 0
        indptr = np.zeros(E + 1, dtype=order.dtype)
        np.cumsum(inner.sum(axis=1), out=indptr[1:])
        return sp.csr_matrix((np.ones(int(indptr[-1])), across[inner], indptr), shape=(E, E))

    def build_edges(self):
        """The unique edges, ``i < j``."""
        if self.split_from is not None:
            return self.split_from.edge_map[0]
        return self.edge_index[0]

    def interface_facets(self, region1):
        """Facets shared by a region-0 and a region-1 simplex: the jagged boundary, (n, k)."""
        k1 = self.simplices.shape[1]
        owner = np.repeat(np.arange(self.n_elements), k1)
        which = mixed_facets(self._facet_ids, owner, region1)
        if "_facets" in self.__dict__:
            return self._facets[which]
        leave_out = np.array([np.delete(np.arange(k1), i) for i in range(k1)])
        return self.sorted_simplices[which // k1][np.arange(which.size)[:, None], leave_out[which % k1]]
