"""Three or more labels: one relaxed partition, with interfaces and junctions."""

import numpy as np
import pytest

from ndboundary import relax
from ndboundary.datasets import kuhn_grid, label_by


@pytest.fixture(scope="module")
def voronoi():
    mesh = kuhn_grid(60, 2, jitter=0.25, random_state=0)
    sites = np.array([[-0.5, -0.4], [0.5, -0.5], [0.1, 0.6], [-0.6, 0.5], [0.7, 0.3]])
    c = mesh.element_centroids()
    labels = np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)
    return mesh, sites, labels, relax(mesh, labels, on="elements")


def test_partition_has_no_gaps_or_overlaps(voronoi):
    mesh, _, _, res = voronoi
    assert res.phi.shape == (mesh.n_vertices, 5)
    assert res.region_measures().sum() == pytest.approx(mesh.A.sum(), rel=1e-9)


def test_interfaces_follow_the_bisectors(voronoi):
    mesh, sites, _, res = voronoi
    faces = res.interfaces()
    a, b = sites[faces.pairs[:, 0]], sites[faces.pairs[:, 1]]
    n = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    d = np.abs(((faces.points[faces.simplices] - 0.5 * (a + b)[:, None]) * n[:, None]).sum(axis=2))
    h = mesh.mean_edge_length()
    assert d.mean() / h < 0.12 and d.max() / h < 0.6
    # every junction lies near the circumcentre of its three sites
    j = faces.junctions()
    assert len(j) >= 3
    for p, regions in zip(j.points[j.simplices[:, 0]], j.regions, strict=True):
        dist = np.linalg.norm(sites[regions[regions >= 0][:3]] - p, axis=1)
        assert (dist.max() - dist.min()) / 2 < 0.5 * h


def test_each_region_keeps_its_components(voronoi):
    _, _, labels, res = voronoi
    for r in range(5):
        assert res.region_boundary(r).n_components() == 1


def test_enclosed_region_has_a_closed_boundary_and_no_junction():
    mesh = kuhn_grid(40, 2, jitter=0.2, random_state=1)
    c = mesh.element_centroids()
    r = np.linalg.norm(c, axis=1)
    labels = np.where(r < 0.3, 2, np.where(r < 0.7, 1, 0))
    res = relax(mesh, labels, on="elements")
    inner = res.region_boundary(2)
    assert inner.is_closed() and inner.n_components() == 1
    assert len(res.interfaces().junctions()) == 0
    assert inner.measure() == pytest.approx(2 * np.pi * 0.3, rel=0.02)


def test_two_regions_interfaces_are_the_level_set():
    mesh = kuhn_grid(30, 2, jitter=0.25, random_state=0)
    res = relax(mesh, label_by(mesh, lambda x: np.linalg.norm(x, axis=1) - 0.5), on="elements")
    faces = res.interfaces()
    assert (faces.pairs == [0, 1]).all()
    assert faces.measure() == pytest.approx(res.level_set().measure(), rel=1e-12)


def test_regions_on_vertices_and_tetrahedra():
    mesh = kuhn_grid(10, 3, jitter=0.2, random_state=0)
    x = mesh.points
    labels = np.where(x[:, 0] < 0, 0, np.where(x[:, 1] < 0, 1, 2))
    res = relax(mesh, labels, on="vertices")
    assert res.region_measures().sum() == pytest.approx(8.0, rel=1e-9)
    assert len(res.interfaces().junctions()) > 0  # a junction curve along the z axis


def _t_labels(x):
    """Three regions meeting like a T: x < 0, then x >= 0 split by y."""
    return np.where(x[:, 0] < 0, 0, np.where(x[:, 1] < 0, 1, 2))


def _kinds():
    from ndboundary.datasets import hex_grid, icosphere, quad_grid, voronoi_polygons

    return {
        "triangles": (lambda: kuhn_grid(24, 2, jitter=0.2, random_state=0), 1),
        "surface": (lambda: icosphere(3), 2),  # the T meets the sphere's poles (0, 0, +-1)
        "quads": (lambda: quad_grid(20, jitter=0.2, random_state=0), 1),
        "polygons": (lambda: voronoi_polygons(20, random_state=0), 1),
        "tetrahedra": (lambda: kuhn_grid(8, 3, jitter=0.2, random_state=0), None),
        "hexahedra": (lambda: hex_grid(8, jitter=0.2, random_state=0), None),
        "4-simplices": (lambda: kuhn_grid(4, 4, jitter=0.1, random_state=0), None),
    }


@pytest.mark.parametrize("kind", list(_kinds()))
@pytest.mark.parametrize("on", ["elements", "vertices"])
def test_every_domain_kind(kind, on):
    """A T of three regions on every kind of domain, labelled on elements or vertices: the
    partition covers the domain exactly, each region stays one piece, the interfaces pair
    only regions that touch, and the junction is where the T's strokes meet."""
    make, n_junctions = _kinds()[kind]
    mesh = make()
    x = mesh.element_centroids() if on == "elements" else mesh.points
    labels = _t_labels(x)
    res = relax(mesh, labels, on=on)
    assert res.phi.shape == (mesh.n_vertices, 3) and np.isfinite(res.phi).all()
    measure = float(mesh.A.sum()) if mesh.element_dim == mesh.dim else float(res.partition().input_measure)
    assert res.region_measures().sum() == pytest.approx(measure, rel=1e-9)
    assert (res.region_measures() > 0.15 * measure).all()
    faces = res.interfaces()
    assert {tuple(p) for p in faces.pairs.tolist()} == {(0, 1), (0, 2), (1, 2)}
    if mesh.element_dim <= 3:
        for r in range(3):
            boundary = res.region_boundary(r)
            assert boundary.n_components() == 1
            assert boundary.is_closed() == (kind == "surface")  # elsewhere every region meets the border
    junctions = faces.junctions()
    if n_junctions is not None:
        assert len(junctions.points) == n_junctions
    else:  # a curve (3-D) or a surface (4-D) along the T's stem, x = y = 0
        assert len(junctions) > 0
        h = mesh.mean_edge_length()
        assert np.abs(junctions.points[:, :2]).max() < 1.5 * h


def test_band_partition_needs_no_fill():
    """On a mesh large enough for the band, the partition is built from each region's band
    alone; it is the partition of the filled functions, which are read only when asked for."""
    from ndboundary.partition import partition

    mesh, labels = _band_voronoi()
    sites = np.array([[-0.5, -0.4], [0.5, -0.5], [0.1, 0.6], [-0.6, 0.5], [0.7, 0.3]])
    res = relax(mesh, labels, on="elements")
    assert "band" in res.regions[0].params
    bounded = res.region_measures()
    faces = res.interfaces()
    filled = partition(*mesh.level_set_complex(res.phi))
    np.testing.assert_allclose(filled.region_measures(), bounded, rtol=1e-12)
    assert len(filled.interfaces()) == len(faces)
    # the filled functions: finite, on the right side of 1/2 in each region away from zeta
    assert np.isfinite(res.phi).all()
    far = np.linalg.norm(mesh.points - sites[2], axis=1) < 0.1  # deep inside region 2
    assert far.any() and (res.phi[far, 2] > 0.5).all() and (res.phi[far][:, [0, 1, 3, 4]] < 0.5).all()


def _band_voronoi():
    mesh = kuhn_grid(150, 2, jitter=0.25, random_state=0)  # 22 801 vertices: the band is used
    sites = np.array([[-0.5, -0.4], [0.5, -0.5], [0.1, 0.6], [-0.6, 0.5], [0.7, 0.3]])
    c = mesh.element_centroids()
    return mesh, np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)


def test_each_region_goes_on_while_the_last_ones_factor_is_built(monkeypatch):
    """On two threads a region's steps run while the previous region's factor is built
    beside, and that region is finished after them; on one thread every region runs in
    turn. The regions come back in order with the same functions (to the rounding of
    another factorisation, PARDISO's where installed, beside)."""
    from ndboundary import _threads

    mesh, labels = _band_voronoi()
    monkeypatch.setattr(_threads, "available_threads", lambda: 2)
    beside = relax(mesh, labels, on="elements")
    monkeypatch.setattr(_threads, "available_threads", lambda: 1)
    in_turn = relax(mesh, labels, on="elements")
    for a, b in zip(beside.regions, in_turn.regions, strict=True):
        np.testing.assert_allclose(a.phi, b.phi, rtol=0, atol=1e-9)
        assert a.timings["total"] <= beside.timings["total"]
    assert sum(r.timings["total"] for r in beside.regions) <= beside.timings["total"]


def test_a_region_that_fails_stops_the_one_waiting_for_its_factor(monkeypatch):
    """A region that raises while the one before waits for its factor closes that one: no
    factorisation goes on after relax has raised."""
    import threading

    from ndboundary import _threads
    from ndboundary.pipeline import relaxer

    mesh, labels = _band_voronoi()
    monkeypatch.setattr(_threads, "available_threads", lambda: 2)
    real, regions, closed = relaxer.Relaxer._relax_steps, [], []

    def steps(self, labels, **kwargs):
        region = None
        if self.domain is mesh and labels.dtype == bool:  # a region's relaxation (not its band's)
            region = len(regions)
            regions.append(region)
            if region == 2:
                raise ArithmeticError("the third region failed")
        try:
            return (yield from real(self, labels, **kwargs))
        except GeneratorExit:
            if region is not None:
                closed.append(region)
            raise

    monkeypatch.setattr(relaxer.Relaxer, "_relax_steps", steps)
    before = threading.active_count()
    with pytest.raises(ArithmeticError, match="third region"):
        relax(mesh, labels, on="elements")
    assert closed == [1]  # the second region, paused when the third started, was closed
    assert threading.active_count() == before


def test_regions_relax_the_same_with_what_they_share(voronoi):
    """A Relaxer that keeps its operators between calls gives the one-shot result, bit for bit."""
    from ndboundary import Relaxer

    mesh, _, labels, res = voronoi
    relaxer = Relaxer(mesh)
    np.testing.assert_array_equal(relaxer.relax(labels, on="elements").phi, res.phi)
    np.testing.assert_array_equal(relaxer.relax(labels, on="elements").phi, res.phi)


def _voronoi_tetrahedra():
    """Six Voronoi regions of [-1, 1]^3 on jittered tetrahedra 16^3, the sites of the volume
    cases of benchmarks/regions.py: ``(mesh, sites, labels)``."""
    mesh = kuhn_grid(16, 3, jitter=0.25, random_state=0)
    rng = np.random.default_rng(0)
    rng.uniform(-0.8, 0.8, (7, 2))  # the plane's sites of benchmarks/regions.py come first
    sites = rng.uniform(-0.8, 0.8, (6, 3))
    c = mesh.element_centroids()
    return mesh, sites, np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)


def _bisector_distances(mesh, sites, labels):
    """The distances (in h) of the relaxed interfaces' corners to their pair's bisector
    (a line in the plane, a plane in space)."""
    faces = relax(mesh, labels, on="elements").interfaces()
    a, b = sites[faces.pairs[:, 0]], sites[faces.pairs[:, 1]]
    n = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    d = np.abs(((faces.points[faces.simplices] - 0.5 * (a + b)[:, None]) * n[:, None]).sum(axis=2))
    return d / mesh.mean_edge_length()


def test_sector_smoothing_brings_volume_interfaces_nearer(monkeypatch):
    """Six Voronoi regions in a cube: smoothing each region's field within the sectors of
    its neighbours puts the interfaces nearer to the true bisector planes than relaxing
    each region on its own (the independent one-vs-rest relaxations)."""
    from ndboundary.pipeline import sectors

    voronoi = _voronoi_tetrahedra()
    coupled = _bisector_distances(*voronoi).mean()
    monkeypatch.setattr(sectors, "SECTOR_SMOOTHING", False)
    independent = _bisector_distances(*voronoi).mean()
    assert coupled < 0.12 and coupled < 0.9 * independent, (coupled, independent)


def test_facet_centre_pins_bring_volume_interfaces_nearer(monkeypatch):
    """Six Voronoi regions of tetrahedra: each region held at the centres of its jagged
    facets gives interfaces nearer the bisector planes than held at the facets' vertices."""
    from ndboundary.pipeline import boundary

    voronoi = _voronoi_tetrahedra()
    facets = _bisector_distances(*voronoi)
    monkeypatch.setattr(boundary, "FACET_CENTRE_PINS", False)
    vertices = _bisector_distances(*voronoi)
    assert facets.mean() < 0.85 * vertices.mean() and facets.max() < 0.75 * vertices.max()


def test_facet_centre_pins_keep_a_triangle_partition_from_folding(monkeypatch):
    """Seven Voronoi regions on triangles 160^2 (the sites of seed 5 of
    benchmarks/regions.py): held at its staircase's vertices, one region's level set
    folds between two tips of its teeth, half an h off the bisector; held at its
    facets' centres, every interface stays within a quarter of an h."""
    from ndboundary.pipeline import boundary

    mesh = kuhn_grid(160, 2, jitter=0.25, random_state=0)
    sites = np.random.default_rng(5).uniform(-0.8, 0.8, (7, 2))
    c = mesh.element_centroids()
    labels = np.argmin(((c[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)
    facets = _bisector_distances(mesh, sites, labels).max()
    monkeypatch.setattr(boundary, "FACET_CENTRE_PINS", False)
    vertices = _bisector_distances(mesh, sites, labels).max()
    assert facets < 0.3 < 0.45 < vertices, (facets, vertices)


@pytest.mark.parametrize("kind", ["triangles", "hexahedra"])
def test_only_the_elements_where_the_largest_function_changes_are_cut(kind):
    """Measures, interfaces and boundaries from the cut of the mixed elements alone equal
    those of the whole domain's partition."""
    from ndboundary.datasets import hex_grid

    mesh = (
        kuhn_grid(40, 2, jitter=0.2, random_state=0)
        if kind == "triangles"
        else hex_grid(10, jitter=0.2, random_state=0)
    )
    c = mesh.element_centroids()
    res = relax(mesh, _t_labels(c), on="elements")
    full = res.partition()
    np.testing.assert_allclose(res.region_measures(), full.region_measures(), rtol=1e-9)
    assert res.interfaces().measure() == pytest.approx(full.interfaces().measure(), rel=1e-9)
    assert len(res.interfaces().junctions()) == len(full.interfaces().junctions())
    for r in range(3):
        assert res.region_boundary(r).measure() == pytest.approx(full.region_boundary(r).measure(), rel=1e-9)


@pytest.mark.parametrize("index", [np.int32, np.int64])
def test_the_compiled_walk_graph_and_group_filter_are_their_array_definitions(index):
    """A region's walk graph (its elements and the ring outside, joined from inside,
    weighted by centroid distances) and the smoothing's adjacency within groups, each
    built in one compiled pass, equal the matrices the array expressions define."""
    import scipy.sparse as sp

    from ndboundary._compiled import region_walk_graph, within_groups

    grid = kuhn_grid(12, 2, jitter=0.3, random_state=0)
    A = grid.adjacency
    grid.__dict__["adjacency"] = sp.csr_matrix((A.data, A.indices.astype(index), A.indptr.astype(index)), A.shape)
    c = grid.element_centroids()
    inside = np.linalg.norm(c - 0.2, axis=1) < 0.4
    nodes, graph = region_walk_graph(grid.adjacency, inside, grid.centroids_of)
    rows = np.repeat(np.arange(A.shape[0]), np.diff(A.indptr))
    edges = inside[rows] & (rows != A.indices)
    assert np.array_equal(nodes, np.union1d(np.flatnonzero(inside), A.indices[edges]))
    local = np.searchsorted(nodes, np.stack([rows[edges], A.indices[edges]]))
    lengths = np.linalg.norm(c[rows[edges]] - c[A.indices[edges]], axis=1)
    expected = sp.csr_matrix((lengths, tuple(local)), shape=graph.shape)
    assert abs(graph - expected).max() < 1e-15 and graph.nnz == expected.nnz

    groups = np.random.default_rng(0).integers(-1, 3, A.shape[0])
    a, b = groups[rows], groups[A.indices]
    same = (a == b) | (a < 0) | (b < 0)
    kept = within_groups(grid.adjacency, groups)
    assert kept.nnz == same.sum()
    assert (kept != sp.csr_matrix((A.data[same], (rows[same], A.indices[same])), shape=A.shape)).nnz == 0


def test_fitted_interfaces_bring_polygon_interfaces_nearer(monkeypatch):
    """Seven Voronoi regions on Voronoi polygons: each interface fitted to its two regions'
    centroids (the smoothest curve that parts them) lies nearer to the true bisectors
    than the relaxed one, within the many-regions target of 0.12 h on average; the
    partition stays exact and every region keeps its one component."""
    from ndboundary.datasets import voronoi_polygons
    from ndboundary.pipeline import interface_fit

    mesh = voronoi_polygons(40, random_state=0)
    sites = np.random.default_rng(0).uniform(-0.8, 0.8, (7, 2))
    labels = np.argmin(((mesh.element_centroids()[:, None] - sites) ** 2).sum(axis=2), axis=1)
    fitted = _bisector_distances(mesh, sites, labels)
    result = relax(mesh, labels, on="elements")
    assert result.region_measures().sum() == pytest.approx(mesh.A.sum(), rel=1e-9)
    assert result.params["fitted_interfaces"] > 0
    assert all(result.region_boundary(r).n_components() == 1 for r in range(7))
    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", False)
    relaxed = _bisector_distances(mesh, sites, labels)
    assert fitted.mean() < 0.12 and fitted.mean() < 0.8 * relaxed.mean(), (fitted.mean(), relaxed.mean())


@pytest.mark.parametrize("loose", [(False, False), (False, True), (True, True)])
def test_an_interface_fit_slides_only_its_loose_ends(loose):
    """A straight polyline 0.2 off the middle of the gap between two rows of sites moves
    to the middle, all of it when both its ends are loose (on the domain's border); a
    held end stays put, and a loose one moves most of the way beside a held one."""
    from ndboundary.pipeline.interface_fit import refine

    x = np.linspace(0.0, 10.0, 21)
    points = np.column_stack([x, np.full(x.size, 0.2)])
    grid = np.arange(0.25, 10.0, 0.5)
    rows = [np.column_stack([grid, np.full(grid.size, y)]) for y in (-0.3, 0.3)]
    side = np.r_[np.ones(grid.size), -np.ones(grid.size)]
    delta, normal = refine(points, 0.5, np.concatenate(rows), side, closed=False, loose=loose)
    y = (points + delta[:, None] * normal)[:, 1]
    for end, free in zip((0, -1), loose, strict=True):
        assert abs(y[end]) < 0.1 if free else y[end] == 0.2, (end, y[end])
    if all(loose):
        assert np.abs(y).max() < 0.01, y


def test_narrowed_margins_part_crowded_sites_by_their_middle():
    """Two rows of sites 0.2 apart crowd a line, one row twice as dense as the other: with
    the widest soft minimum of the margins the line leans away from the dense row by half
    the width times log 2 (0.035); narrowed through ``TAUS`` it lies within 0.005 of the
    middle, as the largest margin does."""
    from ndboundary.pipeline.interface_fit import TAU, TAUS, refine

    x = np.linspace(0.0, 20.0, 41)
    points = np.column_stack([x, np.full(x.size, 0.05)])
    dense, sparse = np.arange(0.125, 20.0, 0.25), np.arange(0.25, 20.0, 0.5)
    sites = np.concatenate([np.column_stack([dense, np.full(dense.size, -0.1)]),
                            np.column_stack([sparse, np.full(sparse.size, 0.1)])])  # fmt: skip
    side = np.r_[np.ones(dense.size), -np.ones(sparse.size)]
    middle = {}
    for tau in (TAU, TAUS):
        delta, normal = refine(points, 0.5, sites, side, tau=tau, closed=False, loose=(True, True))
        middle[len(np.atleast_1d(tau))] = (points + delta[:, None] * normal)[10:31, 1]
    np.testing.assert_allclose(middle[1], 0.5 * TAU * np.log(2.0), rtol=0.02)
    assert np.abs(middle[len(TAUS)]).max() < 0.005, middle


def test_a_junction_fitted_with_its_interfaces_moves_nearer_the_true_one():
    """Three straight interfaces from a junction, labelled on a jittered lattice of sites,
    drawn from a point up to 0.6 off the true junction to their true far ends (held): the
    junction fitted with them (its move shared by the three ends), each held straight as the
    first rung of the fit holds an open interface, lands nearer."""
    from ndboundary.pipeline.interface_fit import BETA, STRAIGHT, _line_terms, fit_network

    before, after = [], []
    for seed in range(4):
        rng = np.random.default_rng(seed)
        grid = np.stack(np.meshgrid(np.arange(-20.0, 20.0), np.arange(-20.0, 20.0)), axis=-1).reshape(-1, 2)
        sites = grid + rng.uniform(-0.3, 0.3, grid.shape)
        angles = np.sort((np.radians([90.0, 210.0, 330.0]) + rng.uniform(-0.2, 0.2, 3)) % (2 * np.pi))
        centre = rng.uniform(-0.5, 0.5, 2)
        start = centre + rng.uniform(-0.4, 0.4, 2)
        region = np.searchsorted(angles, np.arctan2(*(sites - centre).T[::-1]) % (2 * np.pi)) % 3
        lines = []
        for q in range(3):  # ray q parts region q (before it, counter-clockwise) from q + 1
            d = np.array([np.cos(angles[q]), np.sin(angles[q])])
            points = start + np.linspace(0.0, 1.0, 37)[:, None] * (centre + 18.0 * d - start)
            mine = np.isin(region, [q, (q + 1) % 3]) & (np.abs((sites - centre) @ [-d[1], d[0]]) < 2.0)
            mine &= (sites - centre) @ d > -3.0
            nearest = np.argmin(((sites[mine][:, None] - points[None]) ** 2).sum(axis=2), axis=1)
            side = np.where(region[mine] == q, 1.0, -1.0)
            step = float(np.linalg.norm(points[1] - points[0]))
            terms = _line_terms(points, step, sites[mine], side, BETA, False, nearest, (True, False), STRAIGHT)
            lines.append((terms, (0, "held")))
        moves, shifts = fit_network(lines, 1)
        assert len(moves) == 3 and all(m[-1] == 0.0 for m in moves)  # the far ends held
        before.append(np.linalg.norm(start - centre))
        after.append(np.linalg.norm(start + shifts[0] - centre))
    assert np.mean(after) < 0.5 * np.mean(before), (before, after)
