"""The band: relax only the elements near zeta, and extend phi outside it without a solve.

The level set depends only on the fields near zeta: the heat with ``t = h^2`` decays
within a few rings, the smoothing spreads information one ring per pass, and the boundary
term screens the integration. The band holds every element with a vertex within a graph
distance ``width * h`` of zeta's vertices (Dijkstra along the edges, stopped at that
distance, so its cost follows the band).

Outside the band, phi is the band-edge value plus the signed graph distance in units of
``h``: ``phi = 1/2 + s (|phi_b - 1/2| + d(b, v) / h)`` minimised over the band's vertices
``b``, with ``s = -1`` in region 0 and ``+1`` in region 1. It is finite, on the side of 1/2
of its region, continuous with the band at its edge, and grows away from zeta at the
rate of the solved phi (``phi - 1/2`` is close to a signed distance in units of ``h``).
Vertices that no path joins to the band (domain components without zeta) get
``1/2 -/+ 1``, as the whole-domain solve pins them.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

__all__ = ["AUTO_BAND_WIDTH", "band_elements", "band_width", "extend_outside"]

#: ``band="auto"``: the band's half-width in units of ``h``. The first-order term of the
#: integration (``mu > 0``) screens phi from what lies farther from zeta; at this width the
#: level set matches the whole-domain solve within 0.01 h on average and 0.05 h at worst
#: with the default parameters, few smoothing passes and a weaker ``lam`` alike
#: (``benchmarks/band.py``).
AUTO_BAND_WIDTH = 30.0


def band_elements(domain, sources, h, width):
    """The elements with a vertex within graph distance ``width * h`` of the ``sources``.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import band_elements
    >>> grid = kuhn_grid(20, 2)
    >>> centre = [int(np.argmin(np.linalg.norm(grid.points, axis=1)))]
    >>> band = band_elements(grid, centre, grid.mean_edge_length(), 3.0)
    >>> bool(0 < band.sum() < grid.n_elements)
    True
    """
    graph = domain.edge_graph(domain.edge_lengths)
    dist = dijkstra(graph, directed=False, indices=sources, min_only=True, limit=width * h)
    near = np.isfinite(dist)
    return (domain.incidence.T @ near.astype(np.float64)) > 0


def extend_outside(domain, vertices, phi_band, vert_region1, h):
    """Phi on every vertex: ``phi_band`` on the band's ``vertices``, the signed graph distance
    from the band's values outside it (see the module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import extend_outside
    >>> grid = kuhn_grid(10, 1)  # a chain of 11 vertices, h = 0.2
    >>> phi = extend_outside(grid, np.array([4, 5, 6]), np.array([0.0, 0.5, 1.0]), grid.points[:, 0] > 0, 0.2)
    >>> phi.round(6).tolist()
    [-4.0, -3.0, -2.0, -1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0]
    """
    V = domain.n_vertices
    offset = np.abs(np.asarray(phi_band, dtype=np.float64) - 0.5)
    # a virtual source joined to every band vertex by its offset: one Dijkstra pass
    graph = domain.edge_graph(domain.edge_lengths / h).tocoo()
    rows = np.concatenate([graph.row, np.full(vertices.size, V)])
    cols = np.concatenate([graph.col, vertices])
    weights = np.concatenate([graph.data, offset + 1e-300])  # an explicit zero would drop the edge
    augmented = sp.csr_matrix((weights, (rows, cols)), shape=(V + 1, V + 1))
    dist = dijkstra(augmented, directed=False, indices=V)[:V]
    sign = np.where(vert_region1, 1.0, -1.0)
    phi = np.where(np.isfinite(dist), 0.5 + sign * dist, 0.5 + sign)
    phi[vertices] = phi_band
    return phi


def band_width(params):
    """The band's half-width in units of ``h`` for ``band="auto"``, or None for the whole
    domain: without the first-order term (``mu = 0``, the paper's energy) nothing screens
    phi, and the level set depends on the whole domain.

    Examples
    --------
    >>> from ndboundary.pipeline.band import band_width
    >>> band_width({"mu": 0.03}), band_width({"mu": 0.0})
    (30.0, None)
    """
    return AUTO_BAND_WIDTH if params["mu"] > 0 else None
