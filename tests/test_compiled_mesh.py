"""The compiled passes over the incidence of tetrahedral (and large) complexes give what the
sorted tables of every vertex pair and facet give."""

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import SimplicialComplex
from ndboundary._arrays import shared_facet_adjacency
from ndboundary._compiled_geometry import small_simplex_geometry_compiled, small_simplex_volumes
from ndboundary._compiled_mesh import facet_neighbours
from ndboundary.datasets import hex_grid, kuhn_grid
from ndboundary.domains import Domain
from ndboundary.domains.simplex_geometry import (
    COMPILED_MIN_SIMPLICES,
    compiled_passes,
    simplex_geometry,
    symmetric_csr,
)
from ndboundary.fields import smooth_rows
from ndboundary.pipeline.band import band_width


@pytest.fixture
def tets():
    return kuhn_grid(7, 3, jitter=0.2, random_state=3)


def test_edge_graph_and_h_match_the_sorted_edges(tets):
    assert compiled_passes(tets.simplices)
    graph = tets.edge_length_graph(0.5)
    reference = Domain.edge_length_graph(tets, 0.5)
    assert graph.has_canonical_format
    np.testing.assert_array_equal(graph.indptr, reference.indptr)
    np.testing.assert_array_equal(graph.indices, reference.indices)
    np.testing.assert_allclose(graph.data, reference.data, rtol=1e-14)
    assert (graph != graph.T).nnz == 0
    assert tets.mean_edge_length() == pytest.approx(Domain.mean_edge_length(tets), rel=1e-13)


def test_large_triangle_meshes_take_the_compiled_passes():
    plane = kuhn_grid(320, 2)  # 204 800 triangles
    assert plane.n_elements >= COMPILED_MIN_SIMPLICES and compiled_passes(plane.simplices)
    assert not compiled_passes(kuhn_grid(20, 2).simplices)
    assert plane.mean_edge_length() == pytest.approx(Domain.mean_edge_length(plane), rel=1e-12)
    reference = SimplicialComplex(plane.points, plane.simplices)
    np.testing.assert_array_equal(plane.incidence.indices, reference.incidence.indices)


def test_large_triangle_meshes_take_the_compiled_geometry_and_defer_the_gradients():
    for plane in (kuhn_grid(320, 2, jitter=0.2, random_state=0), kuhn_grid(20, 2, jitter=0.2, random_state=0)):
        mesh = SimplicialComplex(plane.points, plane.simplices)
        large = compiled_passes(mesh.simplices)
        mesh.volumes
        assert ("barycentric_gradients" in vars(mesh)) is not large  # large meshes compute them when asked
        grads, vol = simplex_geometry(mesh.points, mesh.sorted_simplices)
        np.testing.assert_allclose(mesh.volumes, vol, rtol=1e-12)
        np.testing.assert_allclose(mesh.barycentric_gradients, grads, rtol=1e-10, atol=1e-10 * np.abs(grads).max())
        x = mesh.points[:, 0]
        np.testing.assert_allclose(mesh.K @ x, mesh.G.T @ (mesh.A[:, None] * mesh.gradient(x)).ravel(), atol=1e-10)


def test_stiffness_is_the_sum_of_the_pair_table_bit_for_bit(tets):
    K = tets.K  # summed over the incidence
    off, diag, used = tets.stiffness_sums  # summed over the table of every vertex pair
    reference = symmetric_csr(tets.edges, off, diag, used)
    reference.eliminate_zeros()
    np.testing.assert_array_equal(K.indptr, reference.indptr)
    np.testing.assert_array_equal(K.indices, reference.indices)
    np.testing.assert_array_equal(K.data, reference.data)
    np.testing.assert_allclose(K @ np.ones(tets.n_vertices), 0.0, atol=1e-12)
    x = tets.points[:, 0]  # K = G^T diag(A) G
    np.testing.assert_allclose(K @ x, tets.G.T @ (tets.A[:, None] * tets.gradient(x)).ravel(), atol=1e-12)


def test_gradients_wait_until_asked_and_equal_the_vectorised_ones(tets):
    fresh = SimplicialComplex(tets.points, tets.simplices)
    assert "barycentric_gradients" not in fresh.__dict__
    grads, vol = simplex_geometry(fresh.points, fresh.sorted_simplices)
    np.testing.assert_allclose(fresh.volumes, vol, rtol=1e-13)
    np.testing.assert_allclose(fresh.barycentric_gradients, grads, rtol=1e-11, atol=1e-11)
    band, _ = fresh.subdomain(np.arange(fresh.n_elements) % 2 == 0)
    np.testing.assert_array_equal(band.barycentric_gradients, fresh.barycentric_gradients[::2])


def test_the_tetrahedra_pass_is_the_general_one_bit_for_bit(tets):
    # in four dimensions, with a zero last coordinate, the general loops add only zeros
    flat = np.column_stack([tets.points, np.zeros(tets.n_vertices)])
    grads, vol = small_simplex_geometry_compiled(tets.points, tets.sorted_simplices, 1e-10)
    grads4, vol4 = small_simplex_geometry_compiled(flat, tets.sorted_simplices, 1e-10)
    np.testing.assert_array_equal(grads, grads4[:, :3])
    np.testing.assert_array_equal(vol, vol4)
    np.testing.assert_array_equal(small_simplex_volumes(tets.points, tets.sorted_simplices, 1e-10), vol)


def test_a_degenerate_tetrahedron_is_refused():
    points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 0, 1]]
    with pytest.raises(ValueError, match="simplex 1 .*volume"):
        SimplicialComplex(points, [[0, 1, 2, 4], [0, 1, 2, 3]])


def _reference_adjacency(simplices):
    """Simplices sharing a facet, by brute force over the sets of their vertices."""
    E, k1 = simplices.shape
    owner = {}
    for e, s in enumerate(simplices):
        for i in range(k1):
            owner.setdefault(tuple(sorted(np.delete(s, i))), []).append(e)
    pairs = [(a, b) for held in owner.values() for a in held for b in held if a != b]
    rows, cols = np.array(pairs, dtype=int).reshape(-1, 2).T
    return sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(E, E))


@pytest.mark.parametrize(
    "simplices",
    [
        [[0, 1, 2, 3], [1, 2, 3, 4], [1, 2, 3, 5]],  # a facet of three tetrahedra
        [[0, 1, 2, 3], [1, 2, 3, 4], [0, 1, 2, 3]],  # a repeated tetrahedron
        [[0, 1, 2, 3], [4, 5, 6, 7]],  # apart
    ],
    ids=["three-on-a-facet", "repeated", "apart"],
)
def test_adjacency_off_manifold_is_the_facet_tables(simplices):
    # the compiled pass hands such complexes to the sorted facet table
    rng = np.random.default_rng(0)
    dom = SimplicialComplex(rng.normal(size=(8, 3)), simplices)
    E, k1 = dom.simplices.shape
    reference = shared_facet_adjacency(dom._facet_groups[0], np.repeat(np.arange(E), k1), E)
    assert (dom.adjacency != reference).nnz == 0
    assert dom.adjacency[1, 0] == (simplices[1] != [4, 5, 6, 7])  # joined unless apart


def _reference_across(srt):
    """The simplex across each facet by brute force, -1 on the border; None off manifold."""
    owner = {}
    for e, s in enumerate(srt):
        for i in range(len(s)):
            owner.setdefault(tuple(np.delete(s, i)), []).append((e, i))
    across = np.full(srt.shape, -1)
    for held in owner.values():
        if len(held) > 2:
            return None
        if len(held) == 2:
            (e, i), (f, j) = held
            across[e, i], across[f, j] = f, e
    return across


def _across(srt):
    E, k1 = srt.shape
    inc = sp.csr_matrix((np.ones(srt.size), (srt.ravel(), np.repeat(np.arange(E), k1))), shape=(srt.max() + 1, E))
    return facet_neighbours(inc, srt)


@pytest.mark.parametrize("dim", [3, 4])
def test_the_simplex_across_each_facet_is_the_brute_force_one(dim):
    grid = kuhn_grid(4, dim, jitter=0.2, random_state=1)
    srt = grid.sorted_simplices[np.random.default_rng(0).random(grid.n_elements) < 0.7]  # holes
    np.testing.assert_array_equal(_across(srt), _reference_across(srt))
    np.testing.assert_array_equal(_across(np.array([[0, 1, 2, 3], [0, 1, 2, 3]])), [[1] * 4, [0] * 4])
    assert _across(np.array([[0, 1, 2, 3], [1, 2, 3, 4], [1, 2, 3, 5]])) is None


def test_stiffness_of_four_simplices_is_the_pair_table_bit_for_bit():
    grid = kuhn_grid(3, 4, jitter=0.2, random_state=3)  # the general loop, not the tetrahedra's
    off, diag, used = grid.stiffness_sums
    reference = symmetric_csr(grid.edges, off, diag, used)
    reference.eliminate_zeros()
    K = grid.K
    np.testing.assert_array_equal(K.indptr, reference.indptr)
    np.testing.assert_array_equal(K.indices, reference.indices)
    np.testing.assert_array_equal(K.data, reference.data)


def test_adjacency_of_a_jittered_grid(tets):
    assert (tets.adjacency != _reference_adjacency(tets.simplices)).nnz == 0


def test_smoothing_with_the_identity_added_matches_the_formed_sum(tets, rng):
    X = rng.normal(size=(tets.n_elements, 3))
    W = (tets.adjacency + sp.identity(tets.n_elements, format="csr")).tocsr()
    np.testing.assert_array_equal(smooth_rows(tets.adjacency, X, 20, plus_identity=True), smooth_rows(W, X, 20))
    # the caller's matrix, unsorted, is left as it is
    shuffled = tets.adjacency.copy()
    shuffled.indices = shuffled.indices.copy()
    for r in range(shuffled.shape[0]):
        lo, hi = shuffled.indptr[r], shuffled.indptr[r + 1]
        shuffled.indices[lo:hi] = shuffled.indices[lo:hi][::-1]
    shuffled.has_sorted_indices = False
    before = shuffled.indices.copy()
    smooth_rows(shuffled, X, 2, plus_identity=True)
    np.testing.assert_array_equal(shuffled.indices, before)


def test_the_band_reaches_farther_along_edges_that_follow_the_axes():
    defaults = {"mu": 0.03, "lam": 2.0, "smoothing": 60}
    assert band_width(defaults, kuhn_grid(4, 3)) == kuhn_grid(4, 3).band_reach == 6.0
    assert band_width(defaults, kuhn_grid(4, 2)) == kuhn_grid(4, 2).band_reach == 8.0
    assert band_width(defaults, hex_grid(4)) == hex_grid(4).band_reach == 12.0


def test_components_and_mass_equal_the_edge_graphs_and_bincounts(tets):
    from scipy.sparse.csgraph import connected_components

    # three copies of the grid, the middle one unused, and a loose vertex at the end
    V = tets.n_vertices
    points = np.vstack([tets.points + [3.0 * i, 0.0, 0.0] for i in range(3)] + [[[9.0, 9.0, 9.0]]])
    simplices = np.vstack([tets.simplices[::-1] + 2 * V, tets.simplices])
    mesh = SimplicialComplex(points, simplices)
    n, labels = mesh.vertex_components
    n_ref, labels_ref = connected_components(Domain.edge_length_graph(mesh), directed=False)
    assert n == n_ref == V + 3  # two grids, and every unused vertex alone
    np.testing.assert_array_equal(labels, labels_ref)
    k1 = simplices.shape[1]
    share = np.repeat(mesh.volumes / k1, k1)
    reference = np.bincount(simplices.ravel(), weights=share, minlength=mesh.n_vertices)
    used = reference > 0
    np.testing.assert_array_equal(mesh.mass[used], reference[used])  # the same sums, bit for bit
    assert (mesh.mass[~used] > 0).all()
