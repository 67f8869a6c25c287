"""What the relaxation asks of a domain's incidence and edges beyond its operators:
:class:`IncidenceQueries`, mixed into :class:`~ndboundary.Domain`.

The band (:mod:`ndboundary.pipeline.band`) is found, and phi filled outside it, by these
queries alone: which vertices the selected elements hold, which elements hold the
selected vertices, and distances along the edges; the jagged boundaries of many regions
are found at once by where their codes meet. Here they read the ``incidence`` and the
``edges``; a domain that can answer them from its own arrays overrides them
(:class:`~ndboundary.SimplicialComplex` reads its simplices, without the incidence of a
large mesh).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .distances import GraphDistances

__all__ = ["IncidenceQueries", "as_mask"]


def as_mask(mask, n, what):
    """``mask`` as a boolean array of shape (n,), or a ValueError naming ``what`` it masks."""
    mask = np.asarray(mask)
    if mask.shape != (n,) or mask.dtype != bool:
        raise ValueError(f"expected a boolean mask over the {n} {what}, got {mask.dtype} of shape {mask.shape}")
    return mask


class IncidenceQueries:
    """Queries over a domain's ``incidence``, ``edges`` and ``edge_lengths``."""

    def vertices_of(self, elements) -> np.ndarray:
        """The vertices of the elements selected by the boolean mask ``elements``, as a
        boolean mask over the vertices.

        Examples
        --------
        >>> import numpy as np
        >>> from ndboundary.datasets import kuhn_grid
        >>> grid = kuhn_grid(2, 2)  # 9 vertices, 8 triangles
        >>> np.flatnonzero(grid.vertices_of(np.arange(8) == 0)).tolist()
        [0, 3, 4]
        """
        elements = as_mask(elements, self.n_elements, "elements")
        return (self.incidence @ elements.astype(np.float64)) > 0

    def elements_at(self, vertices) -> np.ndarray:
        """The elements holding a vertex selected by the boolean mask ``vertices``, as a
        boolean mask over the elements.

        Examples
        --------
        >>> import numpy as np
        >>> from ndboundary.datasets import kuhn_grid
        >>> grid = kuhn_grid(2, 2)
        >>> int(grid.elements_at(np.arange(9) == 4).sum())  # the centre: six triangles
        6
        """
        vertices = as_mask(vertices, self.n_vertices, "vertices")
        return (self.incidence.T @ vertices.astype(np.float64)) > 0

    def code_boundaries(self, codes, n_codes):
        """Every region's jagged boundary at once: for the element codes ``codes`` (ints
        in ``0 .. n_codes - 1``), the vertices shared by an element of each code and an
        element of another, as ``n_codes`` increasing arrays.

        One pass over the incidence finds the vertices where codes meet; beyond it the cost
        follows those vertices, where each code's boundary alone
        (``vertices_of(codes == r) & vertices_of(codes != r)``) reads the whole domain.

        Examples
        --------
        >>> import numpy as np
        >>> from ndboundary.datasets import kuhn_grid
        >>> grid = kuhn_grid(4, 2)
        >>> c = grid.element_centroids()
        >>> codes = np.where(c[:, 1] < 0, 0, np.where(c[:, 0] < 0, 1, 2))  # a T
        >>> [b.tolist() for b in grid.code_boundaries(codes, 3)]
        [[2, 7, 12, 17, 22], [2, 7, 12, 13, 14], [12, 13, 14, 17, 22]]
        """
        codes = _check_codes(codes, self.n_elements, n_codes)
        vertex, code = self._meeting_codes(codes, n_codes)
        key = np.unique(np.asarray(code, dtype=np.int64) * self.n_vertices + vertex)
        of_code = key // self.n_vertices
        bounds = np.searchsorted(of_code, np.arange(n_codes + 1))
        vertices = key - of_code * self.n_vertices
        return [vertices[bounds[r] : bounds[r + 1]] for r in range(n_codes)]

    def _meeting_codes(self, codes, n_codes):
        """The (vertex, code) pairs of :meth:`code_boundaries`, repeats allowed: the codes
        of the elements at the vertices where codes differ, read off the rows of
        :attr:`_vertex_elements` (the lowest and highest code at every vertex first).
        """
        A = self._vertex_elements
        used = np.flatnonzero(np.diff(A.indptr))
        at = codes[A.indices]
        mixed = np.zeros(0, dtype=np.int64)
        if used.size:
            starts = A.indptr[used]
            mixed = used[np.minimum.reduceat(at, starts) != np.maximum.reduceat(at, starts)]
        rows = A[mixed]
        return np.repeat(mixed, np.diff(rows.indptr)), codes[rows.indices]

    @property
    def _vertex_elements(self):
        """The elements at each vertex: a CSR matrix of shape (n_vertices, n_elements)
        whose structure alone is read.
        """
        return self.incidence

    def element_max(self, f) -> np.ndarray:
        """Per element, the largest value of the vertex function ``f`` over its vertices."""
        by_element = self.incidence.T.tocsr()  # every row is non-empty
        return np.maximum.reduceat(np.asarray(f)[by_element.indices], by_element.indptr[:-1])

    def mixed_elements(self, codes):
        """Per element, whether the integer vertex codes ``codes`` differ among its
        vertices, and its lowest code: ``(mixed, lowest)``, two arrays over the elements.

        Examples
        --------
        >>> import numpy as np
        >>> from ndboundary.datasets import kuhn_grid
        >>> grid = kuhn_grid(2, 2)  # 9 vertices, 8 triangles
        >>> mixed, lowest = grid.mixed_elements((np.arange(9) == 4).astype(int))
        >>> int(mixed.sum()), int(lowest.max())  # the six triangles at the centre
        (6, 0)
        """
        codes = np.asarray(codes)
        lowest = -self.element_max(-codes)
        return lowest != self.element_max(codes), lowest

    def edge_length_graph(self, unit=1.0) -> sp.csr_matrix:
        """The edges' lengths in units of ``unit`` as a symmetric sparse matrix, both ways,
        shape (n_vertices, n_vertices).
        """
        upper = self.edge_graph(self.edge_lengths / unit)
        return (upper + upper.T).tocsr()  # a sum of sorted halves, no sort

    def edge_distances(self, unit=1.0):
        """Shortest distances along the edges in units of ``unit``: a callable
        ``distances(sources, offsets=None, limit=inf)`` (see
        :mod:`~ndboundary.domains.distances`), here Dijkstra on :meth:`edge_length_graph`.
        """
        return GraphDistances(self.edge_length_graph(unit))


def _check_codes(codes, n_elements, n_codes):
    """``codes`` as an integer array over the ``n_elements`` elements, each in
    ``0 .. n_codes - 1``, or a ValueError naming what is wrong.
    """
    codes = np.asarray(codes)
    if codes.shape != (n_elements,) or codes.dtype.kind not in "iu":
        raise ValueError(
            f"expected integer codes over the {n_elements} elements, got {codes.dtype} of shape {codes.shape}"
        )
    if codes.size and (codes.min() < 0 or codes.max() >= n_codes):
        raise ValueError(f"codes must lie in 0 .. {n_codes - 1}, got {codes.min()} .. {codes.max()}")
    return codes
