"""The band: relax only the elements near zeta, and extend phi outside it without a solve.

The level set depends only on the fields near zeta: the heat with ``t = h^2`` decays
within a few rings, the smoothing spreads information one ring per pass, and the boundary
term and the first-order term screen the integration. The band holds every element with
a vertex within a graph distance ``width * h`` of zeta's vertices (Dijkstra along the
edges, stopped at that distance, so its cost follows the band).

Outside the band, phi is the band-edge value plus the signed graph distance in units of
``h``: ``phi = 1/2 + s (|phi_b - 1/2| + c d(b, v) / h)`` minimised over the vertices ``b``
of the band's edge (those that an element outside the band holds) and the paths from
them that stay outside the band, with ``s = -1`` in region 0 and ``+1`` in region 1, and
``c`` the rate at which the solved ``|phi - 1/2|`` grows with the graph distance over the
band's outer half (:func:`growth_rate`). It is finite, on the side of 1/2 of its region, continuous with the
band at its edge, and grows away from zeta at the rate of the solved phi
(``phi - 1/2`` is close to a signed distance in units of ``h``).
Vertices that no path joins to the band (domain components without zeta) get
``1/2 -/+ 1``, as the whole-domain solve pins them.

On image grids, only the integration's inner band (the elements within the grid's
:attr:`~ndboundary.Domain.integration_reach` of zeta, :func:`inner_band`) is integrated: the heat and the
smoothing need the band's width, the integration does not. Pinned at zeta and fitting a
field already smoothed, its level set hardly depends on what lies beyond a few rings, and
beyond the inner band phi is continued at the rate it grows there (:func:`inner_phi`).

Outside the band, nothing but linear passes touches the domain: finding zeta and its
neighbourhood (:func:`~ndboundary.pipeline.boundary.element_boundary`), the stopped
Dijkstra of :func:`band_elements` and the one of :func:`extend_outside`, along the edges
(:meth:`~ndboundary.Domain.edge_distances`: on tetrahedral meshes and up a walk over the
simplices at each vertex, elsewhere a graph of the edges that a
:class:`~ndboundary.Relaxer` builds once for every labelling of its domain).
"""

from __future__ import annotations

import functools

import numpy as np

from ..domains.base import can_cut
from .params import DEFAULT_LAM, DEFAULT_SMOOTHING

__all__ = [
    "AUTO_BAND_MAX_SHARE",
    "AUTO_BAND_MIN_VERTICES",
    "AUTO_BAND_MIN_SMOOTHING",
    "FILL_BESIDE_MIN_SHARE",
    "OutsideFill",
    "band_elements",
    "band_width",
    "can_cut",
    "element_rings",
    "extend_outside",
    "growth_rate",
    "inner_band",
    "inner_phi",
    "integration_reach",
]


#: ``band="auto"`` relaxes the whole domain with fewer smoothing passes than this: a field
#: smoothed a few times only is rough, and its integration depends on what lies far from
#: zeta (``benchmarks/band.py --params "dict(smoothing=3)"``).
AUTO_BAND_MIN_SMOOTHING = 10

#: ``band="auto"`` relaxes the whole domain when the band would hold more than this share of
#: the elements: it would cost about as much, and the whole-domain solve is exact.
AUTO_BAND_MAX_SHARE = 0.7

#: The fill's walk is prepared on a second thread while the band is relaxed when the band
#: holds at least this share of the vertices. A band vertex costs about ten times what the
#: walk's preparation costs per vertex outside, so from about a tenth the band's relaxation
#: hides the preparation; beside a smaller band the thread would save little and slow the
#: band's parallel smoothing (``benchmarks/band_scaling.py``).
FILL_BESIDE_MIN_SHARE = 0.1

#: ``band="auto"`` relaxes the whole domain below this many vertices: finding zeta and the
#: band, and filling phi outside it, would cost about what the band saves.
AUTO_BAND_MIN_VERTICES = 20_000


def element_rings(domain, vertices, rings=1):
    """The elements within ``rings`` rings of the ``vertices``: those touching them, then
    those touching the vertices of those, and so on (a boolean mask over the elements).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import element_rings
    >>> grid = kuhn_grid(10, 2)  # the centre vertex 60 is shared by six triangles
    >>> int(element_rings(grid, [60]).sum()), int(element_rings(grid, [60], rings=2).sum())
    (6, 24)
    """
    near = np.zeros(domain.n_vertices, dtype=bool)
    near[np.asarray(vertices, dtype=np.intp)] = True
    for _ in range(rings - 1):
        near = domain.vertices_of(domain.elements_at(near))
    return domain.elements_at(near)


def band_elements(domain, sources, width, distances):
    """The elements with a vertex within graph distance ``width`` (in units of ``h``) of the
    ``sources``, along the edges (``distances``: the domain's
    :meth:`~ndboundary.Domain.edge_distances` in units of ``h``), and every vertex's
    distance (inf beyond ``width``).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import band_elements
    >>> grid = kuhn_grid(20, 2)
    >>> centre = [int(np.argmin(np.linalg.norm(grid.points, axis=1)))]
    >>> band, dist = band_elements(grid, centre, 3.0, grid.edge_distances(grid.mean_edge_length()))
    >>> bool(0 < band.sum() < grid.n_elements), float(dist[centre[0]]), bool(np.isinf(dist).any())
    (True, 0.0, True)
    """
    dist = distances(sources, limit=width)
    return domain.elements_at(np.isfinite(dist)), dist


def growth_rate(phi_band, distance, width):
    """How fast ``|phi - 1/2|`` grows with the graph distance from zeta (both in units of
    ``h``) over the outer half of the band: the slope :func:`extend_outside` continues.

    A graph path zig-zags, so it is longer than the straight distance that the solved phi
    follows; the slope, fitted on the band's own values, makes the fill grow as phi does.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.band import growth_rate
    >>> d = np.linspace(0.0, 10.0, 11)
    >>> round(growth_rate(0.5 + 0.9 * d, d, 10.0), 6)
    0.9
    """
    phi_band, distance = np.asarray(phi_band, dtype=np.float64), np.asarray(distance, dtype=np.float64)
    outer = np.isfinite(distance) & (distance >= 0.5 * width)
    if np.count_nonzero(outer) < 2 or np.ptp(distance[outer]) == 0:
        return 1.0
    d, f = distance[outer], np.abs(phi_band[outer] - 0.5)
    slope = np.cov(d, f, bias=True)[0, 1] / np.var(d)
    return float(np.clip(slope, 0.5, 2.0))


def integration_reach(domain, width):
    """The half-width (units of ``h``) of the inner band that a band of ``width`` around
    zeta on ``domain`` integrates: the domain's
    :attr:`~ndboundary.Domain.integration_reach`, widened by the factor by which ``width``
    exceeds its :attr:`~ndboundary.Domain.band_reach` (a weaker boundary term, a rougher
    field), or None (the whole band).

    Examples
    --------
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import integration_reach
    >>> integration_reach(ImageGrid((4, 4, 4)), 18.0), integration_reach(kuhn_grid(4, 2), 8.0)
    (8.1, None)
    """
    reach = domain.integration_reach
    if reach is None:
        return None
    return reach * max(1.0, width / domain.band_reach)


def inner_band(work, distance, reach):
    """The elements of ``work`` (a band, padded or not) that the integration solves on:
    those with a vertex within ``reach`` of zeta, as a mask; None when they are all of
    them, ``reach`` is None or ``work`` cannot be cut.

    ``distance`` holds the graph distance from zeta (units of ``h``) of the band's own
    vertices, the first of ``work``'s; vertices that the padding adds split elements
    whose vertices all lie on zeta, and lie within reach.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import inner_band
    >>> chain = kuhn_grid(10, 1)  # 11 vertices, zeta at vertex 0
    >>> inner_band(chain, np.arange(11.0), 3.0).tolist()[:5]
    [True, True, True, True, False]
    """
    if reach is None or not can_cut(work):
        return None
    near = np.ones(work.n_vertices, dtype=bool)  # the padding's vertices lie on zeta
    near[: distance.size] = distance <= reach
    inner = work.elements_at(near)
    return None if inner.all() else inner


def inner_phi(domain, phi_inner, vertices, distance, side, reach):
    """Phi on every vertex of ``domain`` from its values ``phi_inner`` on the inner band's
    ``vertices``: beyond it ``1/2 +/- c d``, ``d`` the graph distance from zeta (units of
    ``h``, ``distance``), ``c`` the rate at which ``|phi - 1/2|`` grows over the inner
    band's outer half (:func:`growth_rate`), on the side of 1/2 of ``side`` (a mask of the
    region-1 vertices).

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import inner_phi
    >>> chain = kuhn_grid(6, 1)  # 7 vertices, zeta at vertex 2
    >>> d = np.abs(np.arange(7.0) - 2)
    >>> side = np.arange(7) >= 2
    >>> inner = 0.5 + np.where(side, 0.9, -0.9) * d  # on the inner band, vertices 0 to 4
    >>> inner_phi(chain, inner[:5], np.arange(5), d, side, 2.0).round(6).tolist()
    [-1.3, -0.4, 0.5, 1.4, 2.3, 3.2, 4.1]
    """
    vertices = np.asarray(vertices)
    d = np.zeros(domain.n_vertices)  # the padding's vertices lie on zeta
    d[: distance.size] = distance
    own = vertices < distance.size
    rate = growth_rate(phi_inner[own], d[vertices[own]], reach)
    sign = np.full(domain.n_vertices, -1.0)
    sign[: side.size][np.asarray(side, dtype=bool)] = 1.0
    phi = 0.5 + sign * rate * np.where(np.isfinite(d), d, 2 * reach)
    phi[vertices] = phi_inner
    return phi


class OutsideFill:
    """The fill of phi outside a band (see the module docstring), prepared from the band
    alone, before its phi is known.

    ``elements``: the band's elements (indices); ``vertices``: its vertices, in the order
    of the band's phi; ``distances``: the domain's
    :meth:`~ndboundary.Domain.edge_distances` in units of ``h``. :meth:`prepare` builds
    what the walk outside the band needs (the graph of its edges, where that walks
    faster): it depends on the band only, so a relaxation runs it beside the band's solve.
    Calling the fill with the band's phi gives phi on every vertex.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import OutsideFill
    >>> grid = kuhn_grid(10, 1)  # a chain of 11 vertices and its 10 segments, h = 0.2
    >>> fill = OutsideFill(grid, [4, 5], [4, 5, 6], grid.edge_distances(0.2)).prepare()
    >>> fill(np.array([0.0, 0.5, 1.0]), grid.points[:, 0] > 0).round(6).tolist()
    [-4.0, -3.0, -2.0, -1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0]
    """

    def __init__(self, domain, elements, vertices, distances):
        self.vertices = np.asarray(vertices, dtype=np.int64)
        band = np.zeros(domain.n_elements, dtype=bool)
        band[np.asarray(elements, dtype=np.int64)] = True
        inside = np.zeros(domain.n_vertices, dtype=bool)
        inside[self.vertices] = True
        # the band's edge: its vertices that an element outside it holds. Every path from
        # outside enters the band there; the walk starts there and stays outside.
        edge = inside & domain.vertices_of(~band)
        self.at_edge = edge[self.vertices]
        self.blocked = inside & ~edge
        self.distances = distances
        self.walk = functools.partial(distances, blocked=self.blocked)

    def prepare(self):
        """Build the walk outside the band (``distances.avoiding`` its interior) and return
        the fill.
        """
        self.walk = self.distances.avoiding(self.blocked)
        return self

    def __call__(self, phi_band, side, rate=1.0):
        """Phi on every vertex: ``phi_band`` on the band's vertices, outside it the
        band-edge value plus ``rate`` times the signed graph distance from the band's
        edge (``side``: the vertices of region 1, a mask).
        """
        offset = np.abs(np.asarray(phi_band, dtype=np.float64)[self.at_edge] - 0.5) / rate
        dist = rate * self.walk(self.vertices[self.at_edge], offsets=offset)
        sign = np.where(side, 1.0, -1.0)
        phi = np.where(np.isfinite(dist), 0.5 + sign * dist, 0.5 + sign)
        phi[self.vertices] = phi_band
        return phi


def extend_outside(domain, elements, vertices, phi_band, vert_region1, distances, rate=1.0):
    """Phi on every vertex: ``phi_band`` on the ``vertices`` of the band's ``elements``
    (indices), outside it the band-edge value plus ``rate`` times the signed graph
    distance from the band's edge (see the module docstring), along the edges
    (``distances``: the domain's :meth:`~ndboundary.Domain.edge_distances` in units of
    ``h``). The one-off form of :class:`OutsideFill`.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import extend_outside
    >>> grid = kuhn_grid(10, 1)  # a chain of 11 vertices and its 10 segments, h = 0.2
    >>> side = grid.points[:, 0] > 0
    >>> phi = extend_outside(grid, [4, 5], [4, 5, 6], np.array([0.0, 0.5, 1.0]), side, grid.edge_distances(0.2))
    >>> phi.round(6).tolist()
    [-4.0, -3.0, -2.0, -1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0]
    """
    return OutsideFill(domain, elements, vertices, distances)(phi_band, vert_region1, rate)


def band_width(params, domain, lam_scale=1.0):
    """The band's half-width in units of ``h`` for ``band="auto"``, or None for the whole
    domain.

    The domain's :attr:`~ndboundary.Domain.band_reach` for the default parameters (8 h
    on triangles and 6 h on tetrahedra and up, whose diagonal edges make graph distances
    close to straight ones; 12 h on quads, polygons and hexahedra). The first-order term of the
    integration (``mu > 0``) screens phi from what lies farther from zeta, and the
    boundary term holds it there. The band is wider for a weaker boundary term or fewer
    smoothing passes, each of which lets phi at zeta depend on more of the
    domain: times ``(DEFAULT_LAM / (lam lam_scale))^(3/4)`` when the boundary weight
    ``lam * lam_scale`` (``lam_scale``: :func:`~ndboundary.pipeline.integration.boundary_weight_scale`)
    falls below the default's, and times ``(DEFAULT_SMOOTHING / smoothing)^(1/2)`` below
    the default passes. None without the first-order term (``mu = 0``, the paper's
    energy: nothing screens phi), with fewer than :data:`AUTO_BAND_MIN_SMOOTHING` passes,
    and on domains that cannot be cut (:func:`can_cut`).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid
    >>> from ndboundary.pipeline.band import band_width
    >>> defaults = {"mu": 0.03, "lam": 2.0, "smoothing": 60}
    >>> band_width(defaults, kuhn_grid(4, 2)), band_width(defaults, kuhn_grid(4, 2), lam_scale=0.25)
    (8.0, 22.6)
    >>> band_width({**defaults, "smoothing": 15}, kuhn_grid(4, 3))
    12.0
    >>> band_width({**defaults, "mu": 0.0}, kuhn_grid(4, 2)) is None
    True
    """
    if params["mu"] <= 0 or params["smoothing"] < AUTO_BAND_MIN_SMOOTHING or not can_cut(domain):
        return None
    weaker = max(1.0, DEFAULT_LAM / (params["lam"] * lam_scale)) ** 0.75
    rougher = max(1.0, DEFAULT_SMOOTHING / params["smoothing"]) ** 0.5
    return round(float(domain.band_reach * weaker * rougher), 1)
