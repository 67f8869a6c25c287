"""The band: relax near zeta only, and a usable phi outside it."""

import numpy as np
import pytest

from ndboundary import ImageGrid, LevelSet, PolygonMesh, Relaxer, SimplicialComplex, relax
from ndboundary.datasets import ball, circle, flower, hex_grid, icosphere, kuhn_grid, label_by, voronoi_polygons
from ndboundary.domains.distances import GraphDistances, IncidenceDistances
from ndboundary.metrics import level_set_distance
from ndboundary.pipeline import relaxer as relaxer_module
from ndboundary.pipeline.band import band_width

DEFAULTS = {"mu": 0.03, "lam": 2.0, "smoothing": 60}


def level_set_gap(a, b, h):
    """Mean and max distance between two level sets, in units of h (both ways for the max)."""
    la, lb = a.level_set(), b.level_set()
    ab, ba = level_set_distance(la, lb) / h, level_set_distance(lb, la) / h
    return ab.mean(), max(ab.max(), ba.max())


@pytest.mark.parametrize(
    "make",
    [
        lambda: (kuhn_grid(120, 2, jitter=0.25, random_state=0), flower),
        lambda: (icosphere(5), lambda x: x[:, 2] - 0.3),
        lambda: (voronoi_polygons(80, random_state=0), circle),
    ],
    ids=["triangles", "surface", "polygons"],
)
def test_band_matches_the_whole_domain(make):
    mesh, truth = make()
    labels = label_by(mesh, truth)
    whole = relax(mesh, labels, on="elements", band=None)
    # the width band="auto" chooses, without its rule that small meshes relax whole
    width = band_width(DEFAULTS, mesh, whole.params["lam_scale"])
    band = relax(mesh, labels, on="elements", band=width)
    assert band.params["band_vertices"] < 0.9 * mesh.n_vertices
    if isinstance(mesh, PolygonMesh):  # lam_scale < 1: a wider band
        assert band.params["lam_scale"] < 0.9 and band.params["band"] > mesh.band_reach
    mean, worst = level_set_gap(band, whole, mesh.mean_edge_length())
    assert mean <= 0.01 and worst <= 0.05
    assert band.level_set().n_components() == whole.level_set().n_components()


def test_phi_outside_the_band_is_a_signed_distance():
    mesh = kuhn_grid(80, 2, jitter=0.25, random_state=0)
    labels = label_by(mesh, circle)
    res = relax(mesh, labels, on="elements", band=6)
    whole = relax(mesh, labels, on="elements", band=None)
    phi, h = res.phi, mesh.mean_edge_length()
    assert np.isfinite(phi).all()
    inside = circle(mesh.points) < -6 * h
    outside = circle(mesh.points) > 6 * h
    assert (phi[inside] > 0.5).all() and (phi[outside] < 0.5).all()
    # continuous across the band's edge: neighbours differ by at most their distance in h
    e = mesh.edges
    step = np.abs(phi[e[:, 0]] - phi[e[:, 1]]) - np.linalg.norm(mesh.points[e[:, 0]] - mesh.points[e[:, 1]], axis=1) / h
    assert step.max() < 0.1
    # grows away from zeta as the solved phi does
    far = np.abs(circle(mesh.points)) > 10 * h
    slope = np.polyfit(np.abs(whole.phi[far] - 0.5), np.abs(phi[far] - 0.5), 1)[0]
    assert 0.9 < slope < 1.1


def test_band_covering_the_domain_is_the_whole_domain_solve():
    mesh = kuhn_grid(12, 3, jitter=0.2, random_state=0)
    labels = label_by(mesh, ball)
    np.testing.assert_array_equal(
        relax(mesh, labels, on="elements", band=1e3).phi, relax(mesh, labels, on="elements", band=None).phi
    )


def test_band_with_components_without_boundary_and_several_boundaries():
    a = kuhn_grid(30, 2)
    points = np.concatenate([a.points, a.points + [3.0, 0.0], a.points + [6.0, 0.0]])
    simplices = np.concatenate([a.simplices + i * a.n_vertices for i in range(3)])
    mesh = SimplicialComplex(points, simplices)
    c = mesh.element_centroids()
    labels = ((np.linalg.norm(c - [0.0, 0.0], axis=1) < 0.5) | (np.linalg.norm(c - [3.0, 0.0], axis=1) < 0.5)).astype(
        int
    )
    res = relax(mesh, labels, on="elements", band=5)
    assert np.isfinite(res.phi).all()
    third = points[:, 0] > 5.0  # no boundary there: region 0, below 1/2
    assert (res.phi[third] < 0.5).all()
    assert res.level_set().n_components() == 2


def test_band_on_vertex_labels_and_hexahedra():
    mesh = kuhn_grid(60, 2, jitter=0.2, random_state=1)
    labels = label_by(mesh, circle, on="vertices")
    whole, band = relax(mesh, labels, on="vertices", band=None), relax(mesh, labels, on="vertices", band=24)
    assert level_set_gap(band, whole, mesh.mean_edge_length())[0] <= 0.01
    hexes = hex_grid(16, jitter=0.2, random_state=0)
    res = relax(hexes, label_by(hexes, ball), on="elements", band=4)
    assert res.params["band_vertices"] < hexes.n_vertices and res.level_set().is_closed()


@pytest.mark.parametrize(
    ("band", "err", "match"),
    [("wide", ValueError, "band must be"), (-1.0, ValueError, "band"), ([3], TypeError, "band")],
)
def test_band_errors(band, err, match):
    mesh = kuhn_grid(8, 2)
    with pytest.raises(err, match=match):
        relax(mesh, label_by(mesh, circle), on="elements", band=band)


def test_auto_is_the_default_and_widens_where_the_boundary_term_is_weaker():
    plane = kuhn_grid(240, 2, jitter=0.2, random_state=0)  # above AUTO_BAND_MIN_VERTICES
    labels = label_by(plane, lambda x: np.linalg.norm(x, axis=1) - 0.4)
    res = relax(plane, labels, on="elements")
    assert res.params["band"] == plane.band_reach and res.params["band_vertices"] < plane.n_vertices
    assert {"locate", "fill"} <= set(res.timings)
    assert relax(plane, labels, on="elements", lam=0.5).params["band"] > plane.band_reach
    few = relax(plane, labels, on="elements", smoothing=5)  # a rough field: the whole domain
    assert "band" not in few.params
    small = kuhn_grid(80, 2)
    assert "band" not in relax(small, label_by(small, circle), on="elements").params  # the whole domain


def test_auto_relaxes_the_whole_domain_without_the_first_order_term():
    mesh = kuhn_grid(150, 2, jitter=0.2, random_state=0)
    labels = label_by(mesh, circle)
    paper = relax(mesh, labels, on="elements", mu=0.0)
    assert "band" not in paper.params and "locate" not in paper.timings
    np.testing.assert_array_equal(paper.phi, relax(mesh, labels, on="elements", mu=0.0, band=None).phi)


def test_a_relaxer_keeps_the_edge_distances_for_every_labelling():
    mesh = kuhn_grid(240, 2, jitter=0.2, random_state=0)
    relaxer = Relaxer(mesh)
    first = relaxer.relax(label_by(mesh, circle), on="elements")
    distances = relaxer._distances[1]
    assert isinstance(distances, GraphDistances)  # 115 K triangles: a graph of the edges
    second = relaxer.relax(label_by(mesh, flower), on="elements")
    assert relaxer._distances[1] is distances
    for res, truth in ((first, circle), (second, flower)):
        np.testing.assert_array_equal(res.phi, relax(mesh, label_by(mesh, truth), on="elements").phi)


@pytest.mark.parametrize("k", [2, 3])
def test_level_set_distance_is_the_distance_to_the_simplices(k):
    rng = np.random.default_rng(k)
    corners = 0.2 * rng.normal(size=(12 * k, 3))
    simplices = np.arange(12 * k).reshape(-1, k)
    b = LevelSet(corners, simplices, np.zeros((12 * k, 2), dtype=np.int64), 0.0)
    # points on the simplices, pushed off them: the distance is at most the push
    w = rng.dirichlet(np.ones(k), size=simplices.shape[0])
    on = np.einsum("ij,ijk->ik", w, corners[simplices])
    push = 1e-3 * rng.normal(size=on.shape)
    a = LevelSet(on + push, np.zeros((0, k), dtype=np.int64), np.zeros((on.shape[0], 2), dtype=np.int64), 0.0)
    d = level_set_distance(a, b)
    assert (d <= np.linalg.norm(push, axis=1) + 1e-12).all()
    # a dense sampling of the simplices never comes closer than the exact distance
    u = rng.dirichlet(np.ones(k), size=4000)
    dense = np.einsum("ij,sjk->sik", u, corners[simplices]).reshape(-1, 3)
    far = 0.3 * rng.normal(size=(30, 3))
    a_far = LevelSet(far, np.zeros((0, k), dtype=np.int64), np.zeros((30, 2), dtype=np.int64), 0.0)
    brute = np.linalg.norm(far[:, None] - dense[None], axis=2).min(axis=1)
    exact = level_set_distance(a_far, b)
    assert (exact <= brute + 1e-12).all() and np.allclose(exact, brute, atol=0.01)


def test_band_that_reaches_the_border_matches_the_whole_domain():
    mesh = kuhn_grid(120, 2, jitter=0.25, random_state=0)
    labels = label_by(mesh, lambda x: np.hypot(x[:, 0] - 0.75, x[:, 1] - 0.75) - 0.2)  # 0.05 from two sides
    whole = relax(mesh, labels, on="elements", band=None)
    band = relax(mesh, labels, on="elements", band=mesh.band_reach)
    assert band.params["band_vertices"] < 0.5 * mesh.n_vertices
    mean, worst = level_set_gap(band, whole, mesh.mean_edge_length())
    assert mean <= 0.01 and worst <= 0.05
    assert band.level_set().n_components() == whole.level_set().n_components() == 1


def test_a_relaxer_on_the_band_equals_relax_when_the_width_changes():
    mesh = kuhn_grid(240, 2, jitter=0.2, random_state=0)
    labels = label_by(mesh, lambda x: np.linalg.norm(x, axis=1) - 0.4)
    relaxer = Relaxer(mesh)
    first = relaxer.relax(labels, on="elements")
    for kwargs in ({"smoothing": 20}, {"smoothing": 200}, {"lam": 0.5}, {}):
        res = relaxer.relax(labels, on="elements", **kwargs)
        one_shot = relax(mesh, labels, on="elements", **kwargs)
        assert res.params["band"] == one_shot.params["band"]
        np.testing.assert_array_equal(res.phi, one_shot.phi)
    assert relaxer.relax(labels, on="elements", smoothing=20).params["band"] > first.params["band"]


def _two_grids(dim, n):
    """Two jittered Kuhn grids side by side, as one complex without a path between them."""
    grid = kuhn_grid(n, dim, jitter=0.25, random_state=dim)
    shift = np.zeros(dim)
    shift[0] = 3.0
    return SimplicialComplex(
        np.vstack([grid.points, grid.points + shift]), np.vstack([grid.simplices, grid.simplices + grid.n_vertices])
    )


@pytest.mark.parametrize("dim, n", [(3, 9), (4, 4)])
def test_the_incidence_walk_gives_dijkstras_distances_on_the_edge_graph(dim, n, rng):
    from scipy.sparse.csgraph import dijkstra

    mesh = _two_grids(dim, n)
    h = mesh.mean_edge_length()
    walk = mesh.edge_distances(h)
    assert isinstance(walk, IncidenceDistances)
    graph = GraphDistances(mesh.edge_length_graph(h))
    sources = rng.choice(mesh.n_vertices // 2, 6, replace=False)
    sources = np.append(sources, sources[0])  # a repeated source
    offsets = rng.uniform(0.0, 3.0, sources.size)
    blocked = rng.random(mesh.n_vertices) < 0.2
    blocked[sources[1:]] = False  # the first source blocked: its offset, no path through it
    with_offsets = ({"offsets": offsets}, {"offsets": offsets, "limit": 2.0}, {"blocked": blocked})
    for kwargs in ({}, {"limit": 2.5}, {"limit": 0.0}, *with_offsets):
        a, b = walk(sources, **kwargs), graph(sources, **kwargs)
        np.testing.assert_array_equal(a, b)  # the same sums along the same paths
        if set(kwargs) <= {"limit"}:
            reference = dijkstra(graph.graph, indices=sources, min_only=True, limit=kwargs.get("limit", np.inf))
            np.testing.assert_array_equal(a, reference)  # and scipy's
        assert np.isinf(a[mesh.n_vertices // 2 :]).all()  # the other grid: no path
    assert walk(sources)[sources[0]] == 0.0 and walk(sources, offsets=offsets)[sources[1]] <= offsets[1]
    # prepared to avoid the blocked vertices (the fill's walk): the same distances
    expected = walk(sources, offsets=offsets, blocked=blocked)
    for distances in (walk, graph):
        avoiding = distances.avoiding(blocked)
        np.testing.assert_array_equal(avoiding(sources, offsets=offsets), expected)
        more = blocked | (np.arange(mesh.n_vertices) % 7 == 0)
        more[sources] = False
        np.testing.assert_array_equal(
            avoiding(sources, offsets=offsets, blocked=more), walk(sources, offsets=offsets, blocked=more)
        )
    for distances in (walk, graph):
        with pytest.raises(ValueError, match="offsets has shape"):
            distances(sources, offsets=offsets[:-1])
        with pytest.raises(ValueError, match="non-negative"):
            distances(sources, offsets=np.where(offsets > 1.0, np.nan, offsets))
        with pytest.raises(ValueError, match="sources must be vertex indices"):
            distances([0, mesh.n_vertices])
        with pytest.raises(ValueError, match="sources must be vertex indices"):
            distances([-1])


def test_the_band_on_tetrahedra_is_the_same_walked_or_on_the_graph(monkeypatch):
    mesh = kuhn_grid(36, 3, jitter=0.25, random_state=0)
    labels = label_by(mesh, lambda x: ball(x, r=0.3))
    walked = relax(mesh, labels, on="elements")
    assert walked.params["band_vertices"] < mesh.n_vertices
    on_graph = lambda self, unit=1.0: GraphDistances(self.edge_length_graph(unit))  # noqa: E731
    monkeypatch.setattr(SimplicialComplex, "edge_distances", on_graph)
    on_graph = relax(mesh, labels, on="elements")
    np.testing.assert_array_equal(walked.phi, on_graph.phi)


@pytest.mark.parametrize("n_regions", [2, 3])  # three: each region's fill deferred to its first read
def test_the_fill_is_the_same_prepared_beside_the_band_or_after_it(monkeypatch, n_regions):
    mesh = kuhn_grid(160, 2, jitter=0.25, random_state=0)
    labels = label_by(mesh, lambda x: circle(x, r=0.3))
    if n_regions == 3:
        labels = labels + (labels == 1) * (mesh.element_centroids()[:, 0] > 0)
    results = []
    for share in (0.0, 1.1):  # the fill prepared beside every band, then after it
        monkeypatch.setattr(relaxer_module, "FILL_BESIDE_MIN_SHARE", share)
        r = relax(mesh, labels, on="elements")
        assert n_regions == 3 or r.params["band_vertices"] < 0.2 * mesh.n_vertices
        results.append(np.asarray(r.phi))
    assert results[0].shape == ((mesh.n_vertices,) if n_regions == 2 else (mesh.n_vertices, 3))
    assert np.isfinite(results[0]).all()
    np.testing.assert_array_equal(*results)


@pytest.mark.parametrize("make", [lambda: kuhn_grid(6, 3), lambda: voronoi_polygons(20, random_state=0)])
def test_incidence_queries_agree_and_refuse_bad_masks(make, rng):
    from ndboundary.domains.queries import IncidenceQueries

    mesh = make()
    elements, vertices = rng.random(mesh.n_elements) < 0.3, rng.random(mesh.n_vertices) < 0.3
    # the simplices' reading equals the incidence's, on complexes; any domain has both
    np.testing.assert_array_equal(mesh.vertices_of(elements), IncidenceQueries.vertices_of(mesh, elements))
    np.testing.assert_array_equal(mesh.elements_at(vertices), IncidenceQueries.elements_at(mesh, vertices))
    # a few vertices: a complex whose vertex-simplex rows are built reads those rows
    few = np.zeros(mesh.n_vertices, dtype=bool)
    few[rng.choice(mesh.n_vertices, 3, replace=False)] = True
    if isinstance(mesh, SimplicialComplex):
        _ = mesh.vertex_simplices
    np.testing.assert_array_equal(mesh.elements_at(few), IncidenceQueries.elements_at(mesh, few))
    for bad in (elements[:-1], elements.astype(int)):
        with pytest.raises(ValueError, match="boolean mask over the"):
            mesh.vertices_of(bad)
    with pytest.raises(ValueError, match=f"{mesh.n_vertices} vertices"):
        mesh.elements_at(vertices[1:])


@pytest.mark.parametrize(
    "make",
    [
        lambda: kuhn_grid(20, 2, jitter=0.2, random_state=0),
        lambda: kuhn_grid(6, 3),
        lambda: icosphere(3),
        lambda: voronoi_polygons(20, random_state=0),
        lambda: hex_grid(6),
        lambda: ImageGrid((9, 8, 7)),
        lambda: ImageGrid((15, 12)),
    ],
    ids=["triangles", "tetrahedra", "surface", "polygons", "hexahedra", "voxels", "pixels"],
)
def test_every_region_s_zeta_at_once_is_each_region_s_own(make, rng):
    mesh = make()
    c = mesh.element_centroids()
    sites = rng.uniform(c.min(axis=0), c.max(axis=0), (5, c.shape[1]))
    codes = np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=-1), axis=1)
    codes[codes == 4] = 3  # a code of no element: an empty boundary
    zetas = mesh.code_boundaries(codes, 5)
    assert len(zetas) == 5 and zetas[4].size == 0
    for r, zeta in enumerate(zetas):
        alone = np.flatnonzero(mesh.vertices_of(codes == r) & mesh.vertices_of(codes != r))
        np.testing.assert_array_equal(zeta, alone)
    assert sum(z.size for z in zetas) > 0
    with pytest.raises(ValueError, match="codes must lie in 0 .. 2"):
        mesh.code_boundaries(codes, 3)
    with pytest.raises(ValueError, match="integer codes over the"):
        mesh.code_boundaries(codes[1:], 5)
    # the narrowest integers that hold every code: 256 codes in 8 bits
    many = (np.arange(mesh.n_elements) % 256).astype(np.uint8)
    for r, zeta in enumerate(mesh.code_boundaries(many, 256)):
        np.testing.assert_array_equal(zeta, np.flatnonzero(mesh.vertices_of(many == r) & mesh.vertices_of(many != r)))


def test_auto_widens_the_band_by_the_whole_domain_s_boundary_scale():
    # Voronoi polygons weaken the field term at zeta (lam_scale < 1): the band is widened
    # by the scale, read on a first band, which must be the whole domain's
    cells = voronoi_polygons(150, random_state=1)
    assert cells.n_vertices > 20_000  # above AUTO_BAND_MIN_VERTICES
    labels = label_by(cells, lambda x: np.linalg.norm(x - 0.1, axis=1) - 0.45)
    whole = relax(cells, labels, on="elements", band=None)
    auto = relax(cells, labels, on="elements")
    scale = whole.params["lam_scale"]
    assert scale < 0.9
    assert auto.params["band"] == band_width(auto.params, cells, scale) > cells.band_reach
    assert auto.params["lam_scale"] == pytest.approx(scale, rel=1e-9)
    mean, worst = level_set_gap(auto, whole, cells.mean_edge_length())
    assert mean <= 0.01 and worst <= 0.05


@pytest.mark.parametrize("shape", [(120, 120), (30, 30, 30)], ids=["pixels", "voxels"])
def test_an_image_band_integrates_its_inner_band_and_continues_phi_beyond(shape, monkeypatch):
    from ndboundary import ImageGrid
    from ndboundary.pipeline.boundary import element_boundary

    grid = ImageGrid(shape, spacing=2.0 / np.array(shape))
    c = grid.element_centroids() - 1.0 + 1.0 / np.array(shape)
    labels = np.linalg.norm(c - 0.03, axis=1) < 0.55
    h = grid.mean_edge_length()
    width = 12.0
    res = relax(grid, labels, on="elements", band=width)
    monkeypatch.setattr(type(grid), "integration_reach", None)  # the whole band integrated, as on meshes
    whole_band = relax(grid, labels, on="elements", band=width)
    assert res.params["band_vertices"] == whole_band.params["band_vertices"] < grid.n_vertices
    # beyond the inner band (6 h, and the 3 edges of a cube's diagonal) phi is 1/2 +/- c d
    dist = grid.edge_distances(h)(element_boundary(grid, labels).sources, limit=width)
    far = np.isfinite(dist) & (dist > 6.0 + 3.5)
    rate = np.abs(res.phi[far] - 0.5) / dist[far]
    assert far.sum() > 100 and np.ptp(rate) < 1e-9
    assert np.ptp(np.abs(whole_band.phi[far] - 0.5) / dist[far]) > 1e-3
    # and the level set is where the whole band's integration puts it
    gap = level_set_distance(res.level_set(), whole_band.level_set()) / h
    assert gap.mean() < 0.005 and gap.max() < 0.03


def test_the_integration_built_beside_the_field_equals_the_one_built_after_it(monkeypatch):
    """The integration's matrix and preconditioner are built on a thread of their own
    while the heat and field steps run; with one thread they are built after them. The
    result is the same to the bit, and on cubic voxels the V-cycle sweeps once each way.
    """
    from ndboundary import ImageGrid, _threads

    grid = ImageGrid((30, 30, 30), spacing=1.0 / 15)
    c = grid.element_centroids() - 1.0 + 1.0 / 30
    labels = np.linalg.norm(c - 0.03, axis=1) < 0.55
    assert grid.multigrid_sweeps == 1 and ImageGrid((8, 8, 8), spacing=(1.0, 1.0, 3.0)).multigrid_sweeps == 2
    beside = relax(grid, labels, on="elements", band=12.0, solver="pcg")
    monkeypatch.setattr(_threads, "available_threads", lambda: 1)
    after = relax(grid, labels, on="elements", band=12.0, solver="pcg")
    assert beside.solver["integration"].method == "pcg-amg"
    assert beside.solver["integration"].iterations == after.solver["integration"].iterations
    assert np.array_equal(beside.phi, after.phi)


def test_a_mesh_band_integrates_the_whole_band():
    from ndboundary.pipeline.boundary import element_boundary

    mesh = kuhn_grid(160, 2, jitter=0.25, random_state=0)
    labels = label_by(mesh, circle)
    h = mesh.mean_edge_length()
    res = relax(mesh, labels, on="elements", band=12.0)
    dist = mesh.edge_distances(h)(element_boundary(mesh, labels == 1).sources, limit=12.0)
    far = np.isfinite(dist) & (dist > 9.5)
    assert far.sum() > 100 and np.ptp(np.abs(res.phi[far] - 0.5) / dist[far]) > 1e-3


def test_the_far_field_follows_given_distances_also_at_the_bands_edge():
    """Given the graph distances from zeta that an image band's search found (inf beyond
    its width), the field far from zeta is the one the field step searches for itself,
    and in the pixels at the band's edge, which hold a corner beyond the width, it still
    points into region 1."""
    from ndboundary import ImageGrid
    from ndboundary.pipeline.boundary import element_boundary
    from ndboundary.pipeline.field import graph_distance, initial_field
    from ndboundary.pipeline.heat import diffuse
    from ndboundary.pipeline.padding import pad

    grid = ImageGrid((80, 80), spacing=2 / 80, origin=-1 + 1 / 80)
    h = grid.mean_edge_length()
    distance = graph_distance(grid, element_boundary(grid, label_by(grid, circle) == 1).sources) / h
    band, vertices = grid.subdomain(grid.elements_at(distance <= 6.5))  # no distance ties the width
    region1 = label_by(band, circle) == 1
    zeta = element_boundary(band, region1)
    padded = pad(band, region1, zeta, "elements", enabled=False)  # as relax_image relaxes pixels
    u, _ = diffuse(padded.work, zeta.sources, h**2, 1e-10)
    # a coarse heat tolerance: the field follows the distance from 1 % of the heat's peak
    searched = initial_field(band, padded, region1, zeta.sources, u, 1e-4)
    given = distance[vertices]
    cut = np.where(given <= 6.5, given, np.inf)
    X = initial_field(band, padded, region1, zeta.sources, u, 1e-4, cut)
    unknown = band.element_max(np.isinf(cut).astype(float)) > 0  # all far from zeta
    assert 0 < unknown.sum() < 0.5 * unknown.size
    np.testing.assert_allclose(X[~unknown], searched[~unknown], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(X[unknown], axis=1), 1.0)
    centroids = band.element_centroids()[unknown]
    inward = -centroids / np.linalg.norm(centroids, axis=1)[:, None]  # into the disc, region 1
    assert np.einsum("ij,ij->i", X[unknown], inward).min() > 0.7
