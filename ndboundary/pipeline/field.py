"""Step 2: the unit field that crosses zeta, from region 0 into region 1.

Per element ``X = grad u / |grad u|`` in region 0 and ``-grad u / |grad u|`` in region 1.
Far from zeta the heat falls below the iterative solver's accuracy (absolute, not
relative); there the direction comes from the graph distance to zeta instead, which
points the same way and is exact in any range. For vertex labels, the elements whose
vertices disagree (they straddle zeta) take the gradient of the region-1 indicator,
which points from region 0 to region 1. Elements all of whose vertices receive heat, when
padding did not split them, take the mean field of their neighbours.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import dijkstra

from ..fields import normalize_rows

__all__ = ["HEAT_FLOOR", "fill_flat", "graph_distance", "initial_field"]

#: Where the heat is below this fraction of its maximum (or 100 times the solver's
#: ``rtol``, if larger), its gradient is at the level of the solver's error: the field
#: there follows the graph distance to zeta.
HEAT_FLOOR = 1e-5


def graph_distance(domain, sources):
    """Shortest-path distance along the domain's edges from the vertices ``sources``.

    Vertices that no path reaches get distance 0 (they get no field direction).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.field import graph_distance
    >>> mesh = kuhn_grid(10, 2)
    >>> d = graph_distance(mesh, [0])  # from the corner (-1, -1), along the grid's edges
    >>> float(d[0]), round(float(d[mesh.n_vertices - 1]), 6)  # to (1, 1) along the diagonal
    (0.0, 2.828427)
    """
    dist = dijkstra(domain.edge_graph(domain.edge_lengths), directed=False, indices=sources, min_only=True)
    dist[~np.isfinite(dist)] = 0.0
    return dist


def initial_field(domain, padded, region1, sources, u, rtol, distance=None):
    """The unit field ``X`` of step 2 on the padded domain, shape (n_elements, dim).

    Parameters
    ----------
    domain : Domain
        The input domain (distances are taken on it).
    padded : Padded
    region1 : ndarray of bool
        The labels as given (per element or per vertex).
    sources : ndarray of int
        zeta's heated vertices.
    u : ndarray of shape (padded.work.n_vertices,)
        The heat.
    rtol : float
        The heat solve's tolerance.
    distance : ndarray of shape (domain.n_vertices,), optional
        The graph distance of each vertex from zeta along the edges, ``inf`` where it is
        not known (beyond a band's width), as the band's search found it; unknown ones count
        as one ``h`` beyond the largest known, in the unit of the known ones (which only
        the field's direction reads). By default it is searched again
        (:func:`graph_distance`).

    Examples
    --------
    Steps 0 to 2 on a labelled disc: the field has unit length and, inside the disc,
    points inward (against the position).

    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> from ndboundary.pipeline.padding import pad
    >>> from ndboundary.pipeline.heat import diffuse
    >>> from ndboundary.pipeline.field import initial_field
    >>> mesh = kuhn_grid(10, 2)
    >>> region1 = label_by(mesh, circle) == 1
    >>> zeta = element_boundary(mesh, region1)
    >>> padded = pad(mesh, region1, zeta, "elements")
    >>> u, _ = diffuse(padded.work, zeta.sources, mesh.mean_edge_length() ** 2, 1e-10)
    >>> X = initial_field(mesh, padded, region1, zeta.sources, u, 1e-10)
    >>> X.shape, bool(np.allclose(np.linalg.norm(X, axis=1), 1.0))
    ((200, 2), True)
    >>> inside = region1 & (np.linalg.norm(mesh.element_centroids(), axis=1) > 0.3)
    >>> bool(np.all(np.einsum("ij,ij->i", X[inside], mesh.element_centroids()[inside]) < 0))
    True
    """
    work = padded.work
    V = domain.n_vertices
    X = normalize_rows(work.gradient(u))
    far = work.element_max(u) < max(HEAT_FLOOR, 100.0 * rtol) * u.max()
    if far.any():
        # distances on the unpadded domain; a padding vertex takes its element's mean
        dist = graph_distance(domain, sources) if distance is None else np.asarray(distance, dtype=np.float64)
        if work is not domain:  # padded: its vertices beyond the domain's need distances too
            if work.n_vertices - V == padded.split.size:
                inc = domain.incidence[:, padded.split].T.tocsr()
                dist = np.concatenate([dist, (inc @ dist) / np.diff(inc.indptr)])
            else:
                dist = graph_distance(work, sources)
        known = np.isfinite(dist)
        if not known.all():  # beyond the band's width: one unit of h past the farthest known
            dist = np.where(known, dist, dist[known].max(initial=0.0) + 1.0)
        X[far] = -normalize_rows(work.gradient(dist)[far])
    X[padded.elem_region1] *= -1.0
    if padded.straddle.any():
        ind = np.zeros(work.n_vertices)
        ind[:V] = region1
        X[padded.straddle] = normalize_rows(work.gradient(ind)[padded.straddle])
    if padded.flat.any():
        X = fill_flat(work, X, padded.flat)
    return X


def fill_flat(domain, X, flat):
    """``X`` with each ``flat`` element's vector replaced by the normalised mean of its
    neighbours' (not modified).

    The heat is (nearly) equal at every vertex of an element all of whose vertices lie on
    zeta, so its gradient there has no direction to follow. Unless padding split such
    elements, they take their neighbours' direction, in Jacobi order: an element whose
    neighbours are all flat waits for them, and one that no defined field reaches keeps a
    zero vector.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.field import fill_flat
    >>> mesh = kuhn_grid(4, 2)
    >>> X = np.tile([1.0, 0.0], (mesh.n_elements, 1))
    >>> flat = np.zeros(mesh.n_elements, dtype=bool)
    >>> flat[[0, 1, 2]] = True
    >>> X[flat] = [0.0, 1.0]
    >>> fill_flat(mesh, X, flat)[:3].tolist()
    [[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]]
    """
    X = X.copy()
    todo = np.flatnonzero(flat)
    X[todo] = 0.0
    adjacency = domain.adjacency
    while todo.size:
        mean = adjacency[todo] @ X
        norm = np.linalg.norm(mean, axis=1)
        done = norm > 0.0
        if not done.any():
            break
        X[todo[done]] = mean[done] / norm[done, None]
        todo = todo[~done]
    return X
