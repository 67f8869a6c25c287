"""Regional extrema of a relaxed function only where the labels put them.

``phi - 1/2`` of a relaxation behaves like a signed distance to the relaxed boundary:
away from region 1 it falls, away from region 0 it rises, so its regional maxima lie in
region 1 and its regional minima in region 0. On a kNN graph the least-squares
integration can leave ripples that break this where the boundary is smaller than a
stencil (a class of a few isolated samples): its stiffness ``G^T A G`` barely sees
variations within one stencil, and the heat it diffuses overshoots and comes back, so a
ring of samples around a lone positive can carry peaks above 1/2, each with no positive
sample in it.

:func:`impose_extrema` removes such peaks and pits with the morphological reconstruction
of ``phi`` (Vincent 1993): ``psi_j`` is the largest over the graph's paths from a region-1
sample to ``j`` of the smallest ``phi`` along the path, so a peak without a region-1
sample is cut down to the level of the pass that joins it to one; then the same from
region 0, from below. Where a path climbs from the labels to a sample, nothing changes:
only the part of a spurious peak (pit) beyond its pass moves, and a peak that holds a
region-1 sample is kept whole.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .._compiled import widest_paths
from ..pipeline import relax

__all__ = ["impose_extrema", "relax_classes"]


def _vertex_graph(edges, n):
    """Both directions of every edge, as CSR ``(indptr, indices)`` over ``n`` vertices (int64)."""
    graph = sp.csr_matrix(
        (np.ones(2 * edges.shape[0]), (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]])),
        shape=(n, n),
    )
    return graph.indptr.astype(np.int64), graph.indices.astype(np.int64)


def _cut_peaks(graph, phi, markers):
    """Reconstruction by dilation of ``phi`` from the ``markers``: ``min(phi, bottleneck)``,
    the bottleneck of the widest (maximin) paths from the markers, by a compiled priority
    flood (:func:`~ndboundary._compiled.widest_paths`).
    """
    out = np.empty(phi.shape[0])
    widest_paths(*graph, np.ascontiguousarray(phi, dtype=np.float64), np.flatnonzero(markers).astype(np.int64), out)
    return out


def impose_extrema(domain, phi, region1):
    """``phi`` with its regional maxima only in region 1 and its regional minima only in region 0.

    Parameters
    ----------
    domain : Domain
        Its :attr:`~ndboundary.Domain.edges` join the vertices.
    phi : ndarray of shape (n_vertices,)
        A relaxed function (``phi > 1/2`` on the side of region 1).
    region1 : ndarray of bool of shape (n_vertices,)
        The vertex labels it was relaxed from.

    Returns
    -------
    ndarray of shape (n_vertices,)
        A new array. It equals ``phi`` on every vertex that a path of non-decreasing
        ``phi`` joins to region 1 and one of non-increasing ``phi`` joins to region 0;
        vertices of a component with no label of one kind keep that side of ``phi``.

    Examples
    --------
    A path of six vertices, region 1 on the first three: the pit at vertex 1 holds no
    region-0 vertex and is filled up to its pass, the peak at vertex 4 holds no region-1
    vertex and is cut down to its pass.

    >>> import numpy as np
    >>> from ndboundary import SimplicialComplex
    >>> from ndboundary.learn.extrema import impose_extrema
    >>> path = SimplicialComplex(np.c_[np.arange(6.0), np.zeros(6)], [[0, 1], [1, 2], [2, 3], [3, 4], [4, 5]])
    >>> phi = np.array([2.0, 0.8, 1.2, -1.0, 0.2, -2.0])
    >>> impose_extrema(path, phi, np.array([True, True, True, False, False, False])).tolist()
    [2.0, 1.2, 1.2, -1.0, -1.0, -2.0]
    """
    phi = np.asarray(phi, dtype=np.float64)
    return _impose(_vertex_graph(np.asarray(domain.edges), phi.shape[0]), phi, np.asarray(region1, dtype=bool))


def _impose(graph, phi, region1):
    """:func:`impose_extrema` on the vertex graph ``graph`` (:func:`_vertex_graph`)."""
    psi = _cut_peaks(graph, phi, region1)
    return -_cut_peaks(graph, -psi, ~region1)


def relax_classes(domain, votes, n_classes, **params):
    """The relaxed function of every class over ``domain``, its extrema imposed.

    Parameters
    ----------
    domain : Domain
    votes : ndarray of int of shape (n_vertices,)
        Each vertex's class, in ``range(n_classes)``.
    n_classes : int
    **params
        Passed to :func:`~ndboundary.relax` (with ``on="vertices"``).

    Returns
    -------
    ndarray of shape (n_vertices, 1) for two classes (class 1's function), else (n_vertices, n_classes)
        A class that no vertex votes for gets 0, one that every vertex votes for gets 1.
        Three or more classes present are relaxed together, as one partition (each
        against the rest, sharing the domain's operators and band graph), the same
        functions as one relaxation per class.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.learn.extrema import relax_classes
    >>> grid = kuhn_grid(12, 2)
    >>> votes = np.digitize(grid.points[:, 0], [-0.3, 0.3])  # three bands of columns
    >>> phi = relax_classes(grid, votes, 4)
    >>> phi.shape, bool((phi[:, 3] == 0).all()), bool((phi.argmax(axis=1) == votes).mean() > 0.9)
    ((169, 4), True, True)
    """
    params = {**params, "on": "vertices"}
    targets = [votes == 1] if n_classes == 2 else [votes == c for c in range(n_classes)]
    columns = {}
    if n_classes > 2 and np.unique(votes).size > 2:
        res = relax(domain, votes, **params)
        columns = {c: region.phi for c, region in zip(res.classes.tolist(), res.regions, strict=True)}
    phis = []
    graph = None  # the vertex graph of the extrema, built once for every class
    for c, target in enumerate(targets):
        if target.all() or not target.any():
            phis.append(np.full(votes.size, 1.0 if target.all() else 0.0))
            continue
        phi = columns[c] if columns else relax(domain, target, **params).phi
        if graph is None:
            graph = _vertex_graph(np.asarray(domain.edges), votes.size)
        phis.append(_impose(graph, np.asarray(phi, dtype=np.float64), target))
    return np.stack(phis, axis=1)
