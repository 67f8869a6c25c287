"""The jagged boundary zeta between the two regions, and the rows that hold phi to it."""

from __future__ import annotations

import functools

import numpy as np
import scipy.sparse as sp

from .._arrays import used_vertices
from ..domains.image import grid_facets
from ..domains.simplicial import SimplicialComplex
from .band import can_cut, element_rings

__all__ = [
    "FACET_CENTRE_PINS",
    "Boundary",
    "element_boundary",
    "facet_centre_rows",
    "facet_pins",
    "pinned_rows",
    "pins_facet_centres",
    "vertex_boundary",
    "zeta_facets",
]


class Boundary:
    """The jagged boundary zeta between the two regions.

    Attributes
    ----------
    sources : ndarray of int
        Vertices that receive heat (zeta's vertices for element labels; the ends of
        cut edges for vertex labels).
    S : sparse matrix of shape (n_points, n_vertices)
        One row per point of zeta with its interpolation weights over the vertices,
        times the square root of the point's weight in the boundary term. Given as a
        callable of the boundary returning ``(S, points, targets)``, they are built when
        first read.
    points : ndarray of shape (n_points, dim)
        The points of zeta: its vertices, the centres of its facets
        (:func:`element_boundary`) or the midpoints of cut edges (:func:`vertex_boundary`).
    edges : ndarray of int of shape (n_cut_edges, 2) or None
        For vertex labels, the edges whose ends differ.
    facets : ndarray of int of shape (n_facets, k) or None
        For element labels, the facets between elements of different labels: the
        jagged boundary as a complex over the domain's vertices, sought when first read
        (given as a callable).
    targets : ndarray of shape (n_points,)
        The values the rows ``S`` hold phi at: 1/2 times each row's scale.

    Examples
    --------
    >>> from ndboundary import Boundary
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = element_boundary(mesh, label_by(mesh, circle) == 1)
    >>> isinstance(zeta, Boundary), zeta.S.shape, zeta.points.shape, zeta.facets.shape
    (True, (20, 121), (20, 2), (20, 2))
    >>> bool((zeta.targets == 0.5).all())  # 20 facets, 20 vertices: every pin weighs one
    True
    """

    def __init__(self, sources, S, points, edges=None, facets=None, targets=None):
        self.sources, self.edges = sources, edges
        self._facets = facets
        self._pins = (S, points, targets)

    def _pinned(self):
        """``(S, points, targets)``, built when first read where ``S`` was given as a
        callable returning them from this boundary.
        """
        S, points, targets = self._pins
        if callable(S):
            S, points, targets = S(self)
        if targets is None:
            targets = np.full(S.shape[0], 0.5)
        self._pins = (S, points, targets)
        return self._pins

    @property
    def S(self):
        """The pins' rows (see the class docstring)."""
        return self._pinned()[0]

    @property
    def points(self):
        """The pins' points (see the class docstring)."""
        return self._pinned()[1]

    @property
    def targets(self):
        """The pins' targets (see the class docstring)."""
        return self._pinned()[2]

    @property
    def facets(self):
        """The facets between the labels (sought once, when first read)."""
        if callable(self._facets):
            self._facets = self._facets()
        return self._facets

    def __repr__(self):
        return f"Boundary(n_sources={self.sources.size}, n_points={self.S.shape[0]})"


def element_boundary(domain, region1, sources=None):
    """Zeta for element labels: the vertices shared by elements of both labels, which
    receive the heat, and the points where phi is held at 1/2.

    On a complex of triangles or higher simplices (:func:`pins_facet_centres`) phi is
    held at the centre of every facet between the labels, elsewhere at zeta's vertices
    (the paper's pins). A staircase of simplices zig-zags across their diagonals: its
    vertices alternate between the tips and the roots of its teeth, so that holding phi
    at each bends the level set towards every tip, where two tips close together folded
    it; the centres of its facets lie between them. The level sets then lie nearer the
    truth on the triangle and tetrahedron meshes of the benchmarks, most on tetrahedra
    (``benchmarks/meshes.py`` and ``benchmarks/regions.py``, with and without
    ``--vertex-pins``; figures in the README). On quads, hexahedra and Voronoi cells,
    whose staircases run along the cells' sides as a voxel's do, the facets' centres did
    no better, and the vertices stay pinned. The rows weigh alike and
    their weights sum to the number of zeta's vertices, so that ``lam`` means what it
    means with a pin per vertex.

    The facets between the labels are sought among the elements that touch zeta's
    vertices only (every such facet lies there), so that beyond the linear passes of the
    incidence the cost follows zeta. The facets and the pins are found when first read.
    ``sources``, when given, are zeta's vertices, found before (for many regions at once,
    by :meth:`~ndboundary.Domain.code_boundaries`).

    Examples
    --------
    >>> from ndboundary.datasets import kuhn_grid, label_by, circle
    >>> from ndboundary.pipeline.boundary import element_boundary
    >>> mesh = kuhn_grid(10, 2)
    >>> zeta = element_boundary(mesh, label_by(mesh, circle) == 1)
    >>> zeta.sources.size, zeta.facets.shape  # 20 vertices, joined by 20 jagged edges
    (20, (20, 2))
    >>> zeta.S.shape, zeta.S[0].data.tolist()  # one pin at the middle of each edge
    ((20, 121), [0.5, 0.5])
    """
    if sources is None:
        sources = np.flatnonzero(domain.vertices_of(region1) & domain.vertices_of(~region1))
    # the pins are built when first read: a band's relaxation reads its own zeta's alone
    pins = functools.partial(_element_pins, domain)
    return Boundary(sources, pins, None, facets=functools.partial(zeta_facets, domain, region1, sources))


def _element_pins(domain, zeta):
    """``(S, points, targets)`` of :func:`element_boundary`'s ``zeta`` on ``domain``."""
    sources = zeta.sources
    if pins_facet_centres(domain):
        facets = zeta.facets
        if facets is not None and len(facets):
            S, targets = facet_centre_rows(facets, sources.size, domain.n_vertices)
            return S, domain.points[facets].mean(axis=1), targets
    S = sp.csr_matrix(
        (np.ones(sources.size), (np.arange(sources.size), sources)), shape=(sources.size, domain.n_vertices)
    )
    return S, domain.points[sources], None


#: Whether element labels on a complex of triangles or higher simplices hold phi at the
#: centres of zeta's facets (read at call time; False holds it at zeta's vertices, the
#: paper's pins, which the benchmarks compare with).
FACET_CENTRE_PINS = True


def pins_facet_centres(domain):
    """Whether :func:`element_boundary` holds phi at the centres of zeta's facets on
    ``domain``: a simplicial complex of triangles or higher simplices, while
    :data:`FACET_CENTRE_PINS` is set.
    """
    return FACET_CENTRE_PINS and isinstance(domain, SimplicialComplex) and domain.simplex_dim >= 2


def facet_centre_rows(facets, n_sources, n_vertices):
    """Rows holding phi at 1/2 at the centre of each of ``facets``, and their targets.

    Each row averages its facet's vertices and is scaled by ``sqrt(n_sources / n_facets)``
    (its target too), so that the weights of the rows in the boundary term sum to
    ``n_sources``, as a pin per vertex of zeta's ``n_sources`` would.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary.pipeline.boundary import facet_centre_rows
    >>> S, targets = facet_centre_rows(np.array([[0, 1, 2], [1, 2, 3]]), 4, 5)
    >>> S.toarray().round(3).tolist()[0], targets.round(3).tolist()
    ([0.471, 0.471, 0.471, 0.0, 0.0], [0.707, 0.707])
    """
    n, k = facets.shape
    scale = np.sqrt(n_sources / n)
    cols = np.sort(facets, axis=1).ravel()
    S = sp.csr_matrix((np.full(n * k, scale / k), cols, np.arange(0, n * k + 1, k)), shape=(n, n_vertices))
    return S, np.full(n, 0.5 * scale)


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


#: Facet pins on image grids (:func:`facet_pins`): the passes that spread the facets'
#: normals into the jagged boundary's mean normal around each (times the square of the
#: ratio of the coarsest spacing to the finest), and the least weight of a facet, relative
#: to one across that normal.
FACET_PIN_PASSES = 3
FACET_PIN_FLOOR = 0.03

#: A facet counts as a riser when it turns more than this from the staircase around it
#: (``1 - |n . m|``: a riser of a staircase of slope ``s`` turns about ``1 - s``; every
#: facet of a 45 degree staircase, or along a box's edge, 0.29), and a tread is light only
#: with a riser within this many times :data:`FACET_PIN_PASSES` passes of it.
FACET_PIN_RISER = 0.5
FACET_PIN_REACH = 4


def facet_pins(grid, region1, sources):
    """Zeta's constraint rows on an image grid: one per facet between the labels, at its
    centre, weighted by how far the facet turns from the boundary around it.

    A staircase of pixels says where the true boundary crosses the grid only at its
    risers. Where a boundary of slope ``s`` runs along the pixels, the facets parallel to
    it (the treads) lie anywhere up to half a pixel off it, while the centre of a riser,
    across it, lies within ``s / 2`` of it. Pinning every vertex of the staircase alike
    holds the level set to the treads, which then waver along it; weighting each facet by
    ``1 - |n . m|``, ``n`` its normal and ``m`` the mean normal of the staircase around it
    (:data:`FACET_PIN_PASSES` passes of facet to corner to facet), pins the level set
    where the labels place it and lets the field carry it along the treads. The mean must
    reach the risers, and treads widen with the step: a step of the coarsest spacing
    ``s`` along a surface of radius ``R`` leaves treads about ``sqrt(2 R s)`` wide. A grid
    ``s / d`` times coarser along one axis than along the finest gets ``(s / d)^2`` times
    the passes: on a ball of spacing (1, 1, 3) its volume error was 0.085 % against 0.136
    % with ``s / d`` times (``benchmarks/images.py --cases aniso``), while isotropic grids
    give the same surfaces with 2 to 27 passes. The weights sum to the number of zeta's
    vertices ``sources``, so that ``lam`` means what it means with a pin per vertex. The
    least weight, :data:`FACET_PIN_FLOOR`, keeps the band's level set within its targets
    of the whole grid's (``benchmarks/band.py``): with 0.005 a disc's strayed 0.014 pixel
    on average, against 0.0096 with 0.03.

    A face all of treads (a flat face along the grid's axes: a box's side, a region cut by
    the image's border) has no risers to hold it, and the field would carry it off: a
    tread with no riser within :data:`FACET_PIN_REACH` times the passes takes a riser's
    weight (a box of 12 x 12 x 8 voxels on the image's border gained 9.7 % of its
    volume without this, 1.9 % with it, and 0.9 % with every vertex pinned alike). A
    tread is also light only while the level set keeps between the centres of the two
    pixels it parts, as the labels say it does: the integration checks the pixels'
    centres and, where the level set passed one, gives the facet the weight of an even
    pin and solves again (:func:`~ndboundary.pipeline.integration.within_slabs`).

    Returns
    -------
    S : sparse matrix of shape (n_facets, grid.n_vertices)
    targets : ndarray of shape (n_facets,)
        1/2 at every pin, in the rows' weights.
    slabs : tuple ``(inside, outside, lift)``
        The corners of each facet's pixel in ``region1`` and of its other pixel, shape
        ``(n_facets, 2 ** dim)``, and the weight (as its row's scale) that each facet
        takes where the level set passes one of their centres.

    Examples
    --------
    A disc: the pins' weights stay positive and sum to zeta's vertices.

    >>> import numpy as np
    >>> from ndboundary import ImageGrid
    >>> from ndboundary.pipeline.boundary import element_boundary, facet_pins
    >>> grid = ImageGrid((20, 20))
    >>> disc = np.linalg.norm(grid.element_centroids() - 9.3, axis=1) < 6.2
    >>> sources = element_boundary(grid, disc).sources
    >>> S, targets, slabs = facet_pins(grid, disc, sources)
    >>> weights = (2 * targets) ** 2
    >>> S.shape[0] == sources.size, bool(weights.min() > 0), round(float(weights.sum()), 9) == sources.size
    (True, True, True)
    """
    hot = np.zeros(grid.n_vertices, dtype=bool)
    hot[sources] = True
    facets, normals, areas, inner, outer = grid_facets(grid, region1, grid.elements_at(hot))
    n_pins, (n, k) = sources.size, facets.shape
    B = sp.csr_matrix((np.ones(facets.size), (np.repeat(np.arange(n), k), facets.ravel())), shape=(n, grid.n_vertices))
    passes = int(np.ceil(FACET_PIN_PASSES * (max(grid.spacing) / min(grid.spacing)) ** 2))

    mean = normals * areas[:, None]  # summed over the facets around each, pass by pass
    for _ in range(passes):
        mean = B @ (B.T @ mean)
        mean /= max(float(np.abs(mean).max(initial=0.0)), 1e-300)  # only its direction counts
    norm = np.linalg.norm(mean, axis=1)
    turned = np.ones(n)
    some = norm > 1e-12 * max(float(norm.max(initial=0.0)), 1e-300)
    turned[some] = 1.0 - np.abs(np.einsum("ij,ij->i", normals[some], mean[some]) / norm[some])
    turned = np.maximum(turned, FACET_PIN_FLOOR)
    # a tread with no riser within reach lies on a face along the axes (a box's side, a
    # region cut by the image's border): its facets are where the boundary is
    near = (turned > FACET_PIN_RISER).astype(np.float64)
    for _ in range(FACET_PIN_REACH * passes):
        near = (B @ (B.T @ near) > 0.0).astype(np.float64)
    turned = np.where(near > 0.0, turned, 1.0)
    root = np.sqrt(turned * n_pins / turned.sum())
    S = sp.csr_matrix((np.repeat(root / k, k), facets.ravel(), np.arange(0, facets.size + 1, k)), shape=B.shape)
    return S, 0.5 * root, (np.hstack([facets, inner]), np.hstack([facets, outer]), np.full(n, np.sqrt(n_pins / n)))


def pinned_rows(domain, S, vert_region1, targets=None, all_reached=False):
    """Constraint rows and targets: ``S`` at ``targets`` (1/2 by default), and phi held at
    1/2 -/+ 1 on the connected parts of the domain that zeta does not reach.

    There the field term alone leaves phi free up to a constant; pinning it keeps the
    system definite and puts the part on its own side of 1/2. With ``all_reached``, zeta
    is known to reach every part (as it reaches every part of a band around it): the
    domain's components are not sought.

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
    targets = np.full(S.shape[0], 0.5) if targets is None else targets
    if all_reached:
        return S, targets
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
