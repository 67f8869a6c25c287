"""Bands of point clouds (and Delaunay complexes): the cloud's operators restricted, and
relaxations over them that match the whole domain's near zeta."""

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import DelaunayComplex, LevelSetClassifier, PointCloud, Relaxer, relax
from ndboundary.domains.pointcloud_operators import PointCloudBand
from ndboundary.learn import band as learn_band
from ndboundary.learn.extrema import impose_extrema
from ndboundary.learn.classifier import INTEGRATION_FORM
from ndboundary.pipeline.boundary import vertex_boundary
from ndboundary.pipeline.field import graph_distance


def _sheet(n, D, rng, m=2):
    """Points on a curved m-dimensional sheet in R^D, and their sheet coordinates."""
    t = rng.uniform(-1, 1, size=(n, m))
    base = np.concatenate([t, 0.3 * np.sin(2 * t[:, :1])], axis=1)
    Q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(D, m + 1)))
    return base @ Q.T, t


def _wavy(t):
    return t[:, 1] < 0.3 * np.sin(3 * t[:, 0])


def _blocks(rows, m):
    """The rows of the flattened (element, component) operators of the elements ``rows``."""
    return (np.asarray(rows)[:, None] * m + np.arange(m)).ravel()


def _same(a, b):
    return a.shape == b.shape and abs(sp.csr_matrix(a) - sp.csr_matrix(b)).max() == 0


@pytest.fixture
def messy(rng):
    """A 2-D cloud of three clusters (bridged) with duplicates of different labels."""
    X = np.concatenate([rng.normal(size=(300, 2)), rng.normal(size=(80, 2)) + 20, rng.normal(size=(80, 2)) - 20])
    X = np.concatenate([X, X[:25]])
    labels = np.r_[X[:460, 0] > 0.2 * X[:460, 1], X[:25, 0] <= 0.2 * X[:25, 1]]
    return PointCloud(X, n_neighbors=10), labels


def test_whole_mask_gives_the_cloud_operators(messy):
    cloud, labels = messy
    assert cloud.bridges.shape[0] == 2 and cloud.unique_points.shape[0] < cloud.n_vertices
    band, vertices = cloud.subdomain(np.ones(cloud.n_elements, dtype=bool))
    assert isinstance(band, PointCloudBand) and np.array_equal(vertices, np.arange(cloud.n_vertices))
    assert band.cut.size == 0
    for name in ("G", "K", "adjacency", "incidence"):
        assert _same(getattr(band, name), getattr(cloud, name)), name
    for name in ("A", "mass", "edges", "edge_lengths"):
        assert np.array_equal(getattr(band, name), getattr(cloud, name)), name
    assert _same(band.smoothing_operator(), cloud.smoothing_operator())
    assert band.mean_edge_length() == cloud.mean_edge_length()
    assert np.array_equal(band.element_centroids(), cloud.element_centroids())
    # relaxing the band as a domain of its own is relaxing the cloud
    whole = relax(cloud, labels, on="vertices", smoothing=3, band=None)
    assert np.array_equal(relax(band, labels, on="vertices", smoothing=3, band=None).phi, whole.phi)


@pytest.mark.parametrize(("D", "m"), [(2, 2), (5, 3)])
def test_band_operators_are_the_cloud_restricted(rng, D, m):
    X = rng.uniform(-1, 1, size=(1500, 2)) if D == 2 else _sheet(1500, D, rng, m=m)[0]
    cloud = PointCloud(X, n_neighbors=12, intrinsic_dim=m)
    mask = np.linalg.norm(X - X[0], axis=1) < np.quantile(np.linalg.norm(X - X[0], axis=1), 0.4)
    band, vertices = cloud.subdomain(mask)
    k = cloud.dim
    assert np.array_equal(vertices, np.flatnonzero(mask)) and band.n_elements == mask.sum()
    inner = np.setdiff1d(np.arange(band.n_elements), band.cut)
    assert 0 < band.cut.size < inner.size
    # G, A, mass, incidence: the cloud's rows of the band's elements
    G = cloud.G[_blocks(vertices[inner], k)]
    assert G[:, np.setdiff1d(np.arange(cloud.n_vertices), vertices)].nnz == 0
    assert _same(band.G[_blocks(inner, k)], G[:, vertices])
    assert np.array_equal(band.A, cloud.A[mask]) and np.array_equal(band.mass, cloud.mass[vertices])
    assert _same(band.incidence[:, inner], cloud.incidence[vertices][:, vertices[inner]])
    # K: the cloud's row wherever every element that holds the vertex is an inner one
    whole_inner = np.zeros(cloud.n_elements, dtype=bool)
    whole_inner[vertices[inner]] = True
    held = np.asarray(cloud.incidence @ (~whole_inner).astype(float)).ravel() == 0
    rows = np.flatnonzero(held[vertices])
    assert rows.size > 0
    Kc = cloud.K[vertices[rows]]
    assert Kc[:, np.setdiff1d(np.arange(cloud.n_vertices), vertices)].nnz == 0
    np.testing.assert_allclose(band.K[rows].toarray(), Kc[:, vertices].toarray(), rtol=0, atol=1e-12 * abs(Kc).max())
    # the smoothing: the cloud's where a stencil lies in the band
    W = cloud.smoothing_operator()[_blocks(vertices[inner], k)][:, _blocks(vertices, k)]
    assert _same(band.smoothing_operator()[_blocks(inner, k)], W)
    # identities of the band as a domain of its own, edge included
    n = band.n_vertices
    assert np.abs(band.K @ np.ones(n)).max() < 1e-9 * abs(band.K).max()
    assert abs(band.K - band.K.T).max() < 1e-12 * abs(band.K).max()
    f = rng.normal(size=n)
    np.testing.assert_allclose(band.div(band.gradient(f)), band.K @ f, atol=1e-9 * np.abs(band.K @ f).max())


def test_the_edge_counts_lost_neighbours_as_its_own_value(rng):
    X = rng.uniform(-1, 1, size=(1200, 2))
    cloud = PointCloud(X, n_neighbors=10)
    band, vertices = cloud.subdomain(X[:, 0] < 0.2)
    assert band.cut.size > 0
    G, Gb = cloud.G.toarray(), band.G.toarray()
    for e in band.cut[:20]:
        p = vertices[e]
        rows = G[_blocks([p], 2)]
        lost = np.setdiff1d(np.flatnonzero(np.abs(rows).sum(axis=0)), vertices)
        assert lost.size > 0
        expected = rows[:, vertices]
        expected[:, e] += rows[:, lost].sum(axis=1)  # the lost neighbours hold the point's value
        np.testing.assert_allclose(Gb[_blocks([e], 2)], expected, atol=1e-12 * np.abs(rows).max())
    # constants have no gradient, and inside the band linear functions keep theirs
    assert np.abs(band.gradient(np.ones(band.n_vertices))).max() < 1e-9
    inner = np.setdiff1d(np.arange(band.n_elements), band.cut)
    g = np.einsum("ndm,nm->nd", cloud.frames[band._rows[inner]], band.gradient(band.points @ [1.5, -2.0])[inner])
    np.testing.assert_allclose(g, np.broadcast_to([1.5, -2.0], g.shape), atol=1e-7)


def test_band_of_a_band_is_the_band_of_the_cloud(rng):
    X = rng.uniform(-1, 1, size=(1000, 2))
    cloud = PointCloud(X, n_neighbors=10)
    first = X[:, 0] < 0.5
    outer, v1 = cloud.subdomain(first)
    second = outer.points[:, 1] < 0.3
    inner, v2 = outer.subdomain(second)
    direct, v = cloud.subdomain(first & (X[:, 1] < 0.3))
    assert np.array_equal(v1[v2], v)
    for name in ("G", "K", "adjacency", "incidence"):
        assert _same(getattr(inner, name), getattr(direct, name)), name
    assert np.array_equal(inner.edges, direct.edges) and np.array_equal(inner.mass, direct.mass)
    assert np.array_equal(inner.cut, direct.cut)


def _strip(n, D, m, rng):
    """Points on a curved m-dimensional strip [-3, 3] x [-1, 1]^(m-1) in R^D (flat when
    D == m), and their strip coordinates: zeta across the middle, the ends far from it.
    """
    t = rng.uniform(-1, 1, size=(n, m)) * np.r_[3.0, np.ones(m - 1)]
    if D == m:
        return t, t
    base = np.concatenate([t, 0.3 * np.sin(2 * t[:, 1:2])], axis=1)
    Q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(D, m + 1)))
    return base @ Q.T, t


def _decisions_match(domain, labels, width, *, mean_tol=0.01, max_tol=0.15, flip_tol=0.02):
    """Relax with ``band=width`` and without: the band cuts, the decisions at the samples
    agree but where phi is within ``flip_tol`` of 1/2, and phi agrees near zeta (within
    3 h) to ``mean_tol`` on average and ``max_tol`` at worst (phi - 1/2 is in units of h).
    """
    whole = relax(domain, labels, on="vertices", band=None)
    cut = relax(domain, labels, on="vertices", band=width)
    assert cut.params["band_vertices"] < 0.8 * domain.n_vertices
    assert np.all(np.isfinite(cut.phi))
    flips = (cut.phi > 0.5) != (whole.phi > 0.5)
    assert np.all(np.abs(whole.phi[flips] - 0.5) < flip_tol)
    h = domain.mean_edge_length()
    near = graph_distance(domain, vertex_boundary(domain, np.asarray(labels, dtype=bool)).sources) < 3 * h
    gap = np.abs(cut.phi - whole.phi)[near]
    assert gap.mean() < mean_tol and gap.max() < max_tol
    return whole, cut


@pytest.mark.parametrize(
    ("n", "D", "m", "width"),
    [(6000, 2, 2, 16.0), (6000, 6, 2, 16.0), (10000, 3, 3, 12.0)],
    ids=["plane", "sheet-in-6d", "solid"],
)
def test_band_matches_the_whole_cloud(rng, n, D, m, width):
    X, t = _strip(n, D, m, rng)
    cloud = PointCloud(X, n_neighbors=15, intrinsic_dim=m)
    _decisions_match(cloud, t[:, 0] < 0.3 * np.sin(3 * t[:, 1]), width)


def test_band_with_duplicates_and_bridges(messy):
    cloud, labels = messy
    _decisions_match(cloud, labels, 4.0, mean_tol=0.05, max_tol=0.5)
    # the band's own zeta is the cloud's: cut edges between duplicates and across bridges
    zeta = vertex_boundary(cloud, labels)
    near = graph_distance(cloud, zeta.sources) <= 4.0 * cloud.mean_edge_length()
    mask = (cloud.incidence.T @ near.astype(float)) > 0
    band, vertices = cloud.subdomain(mask)
    assert band.n_vertices < cloud.n_vertices and band._dup_pairs.shape[0] > 0
    assert np.array_equal(vertices[vertex_boundary(band, labels[vertices]).edges], zeta.edges)


def test_band_covering_the_cloud_is_the_whole_cloud_solve(rng):
    X = rng.uniform(-1, 1, size=(800, 2))
    cloud = PointCloud(X, n_neighbors=10)
    labels = _wavy(X)
    np.testing.assert_array_equal(
        relax(cloud, labels, on="vertices", band=1e3).phi, relax(cloud, labels, on="vertices", band=None).phi
    )


def test_relaxer_reuses_the_band(rng):
    X = rng.uniform(-1, 1, size=(3000, 2))
    cloud = PointCloud(X, n_neighbors=12)
    relaxer = Relaxer(cloud)
    a = relaxer.relax(_wavy(X), on="vertices", band=10.0)
    b = relaxer.relax(_wavy(X), on="vertices", band=10.0, lam=1.0)
    assert a.params["band_vertices"] == b.params["band_vertices"] < cloud.n_vertices
    np.testing.assert_allclose(b.phi, relax(cloud, _wavy(X), on="vertices", band=10.0, lam=1.0).phi, atol=1e-8)


@pytest.mark.parametrize(
    ("mask", "err", "match"),
    [
        (np.ones(10, dtype=bool), ValueError, "mask has shape"),
        (np.ones(200, dtype=int), TypeError, "booleans"),
        (np.zeros(200, dtype=bool), ValueError, "selects no element"),
        ([[True] * 200], ValueError, "mask has shape"),
    ],
)
def test_bad_masks(rng, mask, err, match):
    cloud = PointCloud(rng.normal(size=(200, 2)), n_neighbors=8)
    with pytest.raises(err, match=match):
        cloud.subdomain(mask)


@pytest.mark.filterwarnings("ignore::ndboundary.MeshQualityWarning")
def test_delaunay_band(rng):
    X, t = _strip(6000, 2, 2, rng)
    dc = DelaunayComplex(X)
    keep = dc.element_centroids()[:, 0] < 0
    band, vertices = dc.subdomain(keep)
    assert _same(band.G, dc.G[_blocks(np.flatnonzero(keep), 2)][:, vertices])
    assert np.array_equal(band.A, dc.A[keep])
    # random Delaunay triangulations (slivers at the hull) converge more slowly with the width
    _decisions_match(dc, t[:, 0] < 0.3 * np.sin(3 * t[:, 1]), 16.0, mean_tol=0.06, max_tol=1.0, flip_tol=0.1)


def test_classifier_relaxes_small_graphs_whole(rng):
    X = rng.uniform(-1, 1, size=(1500, 2))
    y = _wavy(X).astype(int)
    clf = LevelSetClassifier(n_neighbors=15).fit(X, y)
    assert clf.band_ is None
    res = relax(
        clf.domain_, y == 1, on="vertices", lam=clf.lam, smoothing=0, rtol=clf.tol, band=None, form=INTEGRATION_FORM
    )
    np.testing.assert_array_equal(clf.phi_[:, 0], impose_extrema(clf.domain_, res.phi, y == 1))


@pytest.mark.filterwarnings("ignore::ndboundary.MeshQualityWarning")
def test_classifier_band_on_large_graphs(rng, monkeypatch):
    X, t = _strip(5000, 2, 2, rng)
    y = (t[:, 0] < 0.3 * np.sin(3 * t[:, 1])).astype(int)
    Xte = _strip(4000, 2, 2, np.random.default_rng(1))[0]
    whole = LevelSetClassifier(band=None).fit(X, y)
    monkeypatch.setattr(learn_band, "AUTO_BAND_MIN_SAMPLES", 3000)
    auto = LevelSetClassifier().fit(X, y)
    assert whole.band_ is None and auto.band_ == learn_band.AUTO_BAND_WIDTH
    assert np.mean(auto.predict(Xte) != whole.predict(Xte)) < 1e-3
    near = np.abs(whole.decision_function(X)) < 3
    assert np.abs(auto.phi_ - whole.phi_)[near].max() < 0.05
    # on a Delaunay complex, and for three classes (one band per class)
    assert LevelSetClassifier(graph="delaunay").fit(X, y).band_ is None
    y3 = np.digitize(t[:, 0], [-1.0, 1.0])
    three = LevelSetClassifier(band=8.0).fit(X, y3)
    assert three.band_ == 8.0 and (three.predict(X) == y3).mean() > 0.99
    # samples of intrinsic dimension 5 span a few h: a band would hold them all, so none is sought
    X5 = rng.uniform(-1, 1, size=(5000, 5))
    assert LevelSetClassifier().fit(X5, (X5[:, 0] > 0).astype(int)).band_ is None


@pytest.mark.parametrize(
    ("band", "err", "match"),
    [("wide", ValueError, "band must be"), (0.0, ValueError, "positive finite"), ([3], TypeError, "band must be")],
)
def test_classifier_bad_band(band, err, match):
    X = np.random.default_rng(0).normal(size=(50, 2))
    with pytest.raises(err, match=match):
        LevelSetClassifier(band=band).fit(X, X[:, 0] > 0)
