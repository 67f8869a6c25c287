"""Operator identities and hand-computed cases for SimplicialComplex."""

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import SimplicialComplex
from ndboundary.datasets import icosphere, kuhn_grid
from ndboundary.solvers import factorize_spd


def domains():
    yield "tri2d", kuhn_grid(6, 2, jitter=0.25, random_state=1)
    yield "tet3d", kuhn_grid(4, 3, jitter=0.25, random_state=2)
    yield "simplex4d", kuhn_grid(2, 4, jitter=0.1, random_state=3)
    yield "surface", icosphere(2)
    yield "segments2d", SimplicialComplex([[0, 0], [1, 0.2], [2, 0.1], [3, 0.5]], [[0, 1], [1, 2], [2, 3]])


DOMAINS = dict(domains())


@pytest.fixture(params=list(DOMAINS))
def domain(request):
    return DOMAINS[request.param]


def test_stiffness_is_gt_a_g(domain):
    A = sp.diags(np.repeat(domain.A, domain.dim))
    ref = (domain.G.T @ A @ domain.G).toarray()
    np.testing.assert_allclose(domain.K.toarray(), ref, atol=1e-12 * np.abs(ref).max())


def test_stiffness_symmetric_psd_kills_constants(domain):
    K = domain.K.toarray()
    np.testing.assert_allclose(K, K.T, atol=1e-13 * np.abs(K).max())
    np.testing.assert_allclose(K @ np.ones(domain.n_vertices), 0, atol=1e-12 * np.abs(K).max())
    assert np.linalg.eigvalsh(K).min() > -1e-10 * np.abs(K).max()


def test_mass_sums_to_total_measure(domain):
    assert np.all(domain.mass > 0)
    assert domain.mass.sum() == pytest.approx(domain.A.sum(), rel=1e-12)


def test_total_measure_of_cubes():
    assert kuhn_grid(5, 2, jitter=0.3, random_state=0).A.sum() == pytest.approx(4.0)
    assert kuhn_grid(3, 3, jitter=0.3, random_state=0).A.sum() == pytest.approx(8.0)
    assert kuhn_grid(2, 4, jitter=0.1, random_state=0).A.sum() == pytest.approx(16.0)


def test_gradient_exact_on_linear_functions(domain, rng):
    a = rng.standard_normal(domain.dim)
    f = domain.points @ a + 3.0
    g = domain.gradient(f)
    if domain.element_dim == domain.dim:
        np.testing.assert_allclose(g, np.broadcast_to(a, g.shape), atol=1e-10)
    else:
        # on a lower-dimensional simplex the gradient is a's projection on its tangent space
        X = domain.points[domain.simplices]
        Ed = X[:, 1:, :] - X[:, :1, :]
        proj = np.einsum("eki,ekl,elj->eij", Ed, np.linalg.inv(Ed @ Ed.transpose(0, 2, 1)), Ed)
        np.testing.assert_allclose(g, proj @ a, atol=1e-10)


def test_integrating_exact_gradient_returns_function(domain, rng):
    f = rng.standard_normal(domain.n_vertices)
    d = domain.div(domain.gradient(f))
    np.testing.assert_allclose(d, domain.K @ f, atol=1e-10)
    # pin one vertex and solve K phi = div(G f): phi equals f up to a constant
    K = domain.K + sp.csr_matrix(([1.0], ([0], [0])), shape=domain.K.shape)
    phi = factorize_spd(K)(d + np.eye(domain.n_vertices)[0] * f[0])
    np.testing.assert_allclose(phi, f, atol=1e-8)


def test_single_triangle_by_hand():
    tri = SimplicialComplex([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    assert tri.A[0] == pytest.approx(0.5)
    np.testing.assert_allclose(tri.mass, [1 / 6] * 3)
    # cotangent weights: the right angle at vertex 0 gives cot = 0 on edge (1, 2)
    np.testing.assert_allclose(tri.K.toarray(), [[1, -0.5, -0.5], [-0.5, 0.5, 0], [-0.5, 0, 0.5]])
    np.testing.assert_allclose(tri.G.toarray(), [[-1, 1, 0], [-1, 0, 1]])


def test_single_tetrahedron_by_hand():
    tet = SimplicialComplex(np.vstack([np.zeros(3), np.eye(3)]), [[0, 1, 2, 3]])
    assert tet.A[0] == pytest.approx(1 / 6)
    np.testing.assert_allclose(tet.mass, [1 / 24] * 4)
    expected = np.array([[3, -1, -1, -1], [-1, 1, 0, 0], [-1, 0, 1, 0], [-1, 0, 0, 1]]) / 6
    np.testing.assert_allclose(tet.K.toarray(), expected, atol=1e-15)


def test_triangle_in_3d_matches_its_planar_copy(rng):
    planar = SimplicialComplex([[0, 0], [2, 0], [0.5, 1.5]], [[0, 1, 2]])
    Q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    lifted = SimplicialComplex(np.c_[planar.points, np.zeros(3)] @ Q.T + 5, [[0, 1, 2]])
    np.testing.assert_allclose(lifted.K.toarray(), planar.K.toarray(), atol=1e-12)
    np.testing.assert_allclose(lifted.A, planar.A)


def test_adjacency_shares_facets():
    dom = kuhn_grid(4, 2)
    deg = np.asarray(dom.adjacency.sum(axis=1)).ravel()
    assert deg.max() == 3 and deg.min() >= 1
    i, j = dom.adjacency.nonzero()
    shared = [len(set(dom.simplices[a]) & set(dom.simplices[b])) for a, b in zip(i, j)]
    assert set(shared) == {2}
    assert (dom.adjacency != dom.adjacency.T).nnz == 0


def test_edges_and_mean_edge_length():
    dom = kuhn_grid(1, 2, lo=0.0, hi=1.0)
    assert dom.edges.tolist() == [[0, 1], [0, 2], [0, 3], [1, 3], [2, 3]]
    assert dom.mean_edge_length() == pytest.approx((4 + np.sqrt(2)) / 5)


def test_centroids():
    tri = SimplicialComplex([[0, 0], [3, 0], [0, 3]], [[0, 1, 2]])
    np.testing.assert_allclose(tri.element_centroids(), [[1, 1]])


@pytest.mark.parametrize("dim", [2, 3])
def test_split_elements_matches_a_fresh_build(dim):
    dom = kuhn_grid(4, dim, jitter=0.2, random_state=0)
    mask = np.zeros(dom.n_elements, dtype=bool)
    mask[[0, 5, 7]] = True
    split, parent = dom.split_elements(mask)
    fresh = SimplicialComplex(split.points, split.simplices)
    assert split.n_elements == dom.n_elements + 3 * dim
    np.testing.assert_allclose(split.K.toarray(), fresh.K.toarray(), atol=1e-12)
    np.testing.assert_allclose(split.A, fresh.A)
    assert split.A.sum() == pytest.approx(dom.A.sum())
    np.testing.assert_array_equal(np.bincount(parent, minlength=dom.n_elements), np.where(mask, dim + 1, 1))


@pytest.mark.parametrize("dim", [2, 3, 4])
def test_compiled_edges_and_incidence_equal_numpys(dim, monkeypatch):
    """The compiled counting passes (tetrahedra and up) and numpy's sorts (triangles) give
    the same edges, pair edges and incidence, whichever a simplex size uses."""
    from ndboundary.domains import simplex_geometry as g
    from ndboundary.datasets import kuhn_grid

    mesh = kuhn_grid(6, dim, jitter=0.2, random_state=0)
    results = []
    for threshold in (1, 99):  # every size compiled, then none
        monkeypatch.setattr(g, "COMPILED_MIN_VERTICES_PER_SIMPLEX", threshold)
        edges, pair_edge = g.simplex_edges(mesh.sorted_simplices, mesh.n_vertices)
        inc = g.simplex_incidence(mesh.simplices, mesh.sorted_simplices, mesh.n_vertices)
        results.append((edges, pair_edge, inc))
    (e1, p1, i1), (e2, p2, i2) = results
    np.testing.assert_array_equal(e1, e2)
    np.testing.assert_array_equal(p1, p2)
    assert (i1 != i2).nnz == 0 and i1.has_sorted_indices and i2.has_sorted_indices
    assert np.array_equal(e1[:, 0] < e1[:, 1], np.ones(len(e1), bool))
