"""The jagged boundary zeta between the two regions, and the rows that hold phi to it."""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp

from .._arrays import used_vertices
from .band import can_cut, element_rings

__all__ = ["Boundary", "element_boundary", "pinned_rows", "vertex_boundary", "zeta_facets"]


class Boundary:
    """The jagged boundary zeta between the two regions.

    Attributes
    ----------
    sources : ndarray of int
        Vertices that receive heat (zeta's vertices for element labels; the ends of
        cut edges for vertex labels).
    S : sparse matrix of shape (n_points, n_vertices)
        One row per point of zeta with its interpolation weights over the vertices.
    points : ndarray of shape (n_points, dim)
        The points of zeta (``S @ domain.points``).
    edges : ndarray of int of shape (n_cut_edges, 2) or None
        For vertex labels, the edges whose ends differ.
    facets : ndarray of int of shape (n_facets, k) or None
        For element labels, the facets between elements of different labels: the
        jagged boundary as a complex over the domain's vertices. The relaxation needs
        only the vertices: the facets are sought when first read (given as a callable).

    Examples
    --------
    >>> from ndboundary import Boundary
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = element_boundary(mesh, label_by(mesh, circle) == 1)
    >>> isinstance(zeta, Boundary), zeta.S.shape, zeta.points.shape, zeta.facets.shape
    (True, (20, 121), (20, 2), (20, 2))
    """

    def __init__(self, sources, S, points, edges=None, facets=None):
        self.sources, self.S, self.points, self.edges = sources, S, points, edges
        self._facets = facets

    @property
    def facets(self):
        """The facets between the labels (sought once, when first read)."""
        if callable(self._facets):
            self._facets = self._facets()
        return self._facets

    def __repr__(self):
        return f"Boundary(n_sources={self.sources.size}, n_points={self.points.shape[0]})"


def element_boundary(domain, region1):
    """Zeta for element labels: the vertices shared by elements of both labels.

    The facets between the labels, which the relaxation does not need, are sought when
    first read, among the elements that touch zeta's vertices only (every such facet lies
    there), so that beyond the linear passes of the incidence the cost follows zeta.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = element_boundary(mesh, label_by(mesh, circle) == 1)
    >>> zeta.sources.size, zeta.facets.shape  # 20 vertices, joined by 20 jagged edges
    (20, (20, 2))
    """
    sources = np.flatnonzero(domain.vertices_of(region1) & domain.vertices_of(~region1))
    S = sp.csr_matrix(
        (np.ones(sources.size), (np.arange(sources.size), sources)), shape=(sources.size, domain.n_vertices)
    )
    facets = functools.partial(zeta_facets, domain, region1, sources)
    return Boundary(sources, S, domain.points[sources], facets=facets)


def zeta_facets(domain, region1, sources):
    """``domain.interface_facets(region1)``, sought among the elements touching ``sources``."""
    near = element_rings(domain, sources)
    n_near = np.count_nonzero(near)
    if n_near == 0 or 2 * n_near > domain.n_elements or not can_cut(domain):
        return domain.interface_facets(region1)
    sub, vertices = domain.subdomain(near)
    facets = sub.interface_facets(region1[near])
    return None if facets is None else vertices[facets]


def vertex_boundary(domain, region1):
    """Zeta for vertex labels: the midpoints of the edges whose ends differ.

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import vertex_boundary
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = vertex_boundary(mesh, label_by(mesh, circle, on="vertices") == 1)
    >>> zeta.edges.shape, zeta.sources.size, zeta.S[0].data.tolist()  # each point halfway along an edge
    ((38, 2), 38, [0.5, 0.5])
    """
    e = domain.edges
    cut = e[region1[e[:, 0]] != region1[e[:, 1]]]
    sources = used_vertices(cut, domain.n_vertices)[0]
    m = cut.shape[0]
    S = sp.csr_matrix((np.full(2 * m, 0.5), (np.repeat(np.arange(m), 2), cut.ravel())), shape=(m, domain.n_vertices))
    return Boundary(sources, S, 0.5 * (domain.points[cut[:, 0]] + domain.points[cut[:, 1]]), cut)


def pinned_rows(domain, S, vert_region1):
    """Constraint rows and targets: ``S`` at 1/2, and phi held at 1/2 -/+ 1 on the connected
    parts of the domain that zeta does not reach.

    There the field term alone leaves phi free up to a constant; pinning it keeps the
    system definite and puts the part on its own side of 1/2.

    Examples
    --------
    Two separate triangles, zeta on the first one only: the second, in region 1, is
    held at 3/2.

    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary import SimplicialComplex
    >>> from ndboundary.pipeline.boundary import pinned_rows
    >>> two = SimplicialComplex([[0, 0], [1, 0], [0, 1], [3, 0], [4, 0], [3, 1]], [[0, 1, 2], [3, 4, 5]])
    >>> S = sp.csr_matrix(([1.0], ([0], [0])), shape=(1, 6))
    >>> rows, targets = pinned_rows(two, S, np.array([0, 0, 0, 1, 1, 1], dtype=bool))
    >>> rows.shape, targets.tolist()
    ((4, 6), [0.5, 1.5, 1.5, 1.5])
    """
    targets = np.full(S.shape[0], 0.5)
    n_comp, comp = domain.vertex_components
    if n_comp == 1:
        return S, targets
    touched = np.zeros(n_comp, dtype=bool)
    touched[comp[S.nonzero()[1]]] = True
    free = np.flatnonzero(~touched[comp])
    if free.size == 0:
        return S, targets
    rows = sp.csr_matrix((np.ones(free.size), (np.arange(free.size), free)), shape=(free.size, domain.n_vertices))
    return sp.vstack([S, rows]).tocsr(), np.concatenate([targets, np.where(vert_region1[free], 1.5, -0.5)])
