"""The linear-time sorting and assembly helpers against their direct definitions."""

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import SimplicialComplex
from ndboundary._validation import check_cells, check_labels
from ndboundary.datasets import hex_grid, icosphere, kuhn_grid
from ndboundary import Domain, ImageGrid
from ndboundary._compiled_mesh import assemble_cell_blocks, stencil_stiffness
from ndboundary._arrays import (
    counting_sort,
    first_of_groups,
    group_rows,
    mixed_facets,
    pair_groups,
    shared_facet_adjacency,
    unique_values,
)
from ndboundary.domains.simplex_geometry import large_simplex_geometry, small_simplex_geometry


def reference_group_rows(rows):
    uniq, ids = np.unique(rows, axis=0, return_inverse=True)
    return ids.ravel(), uniq.shape[0]


@pytest.mark.parametrize("width", [1, 2, 3, 5])
@pytest.mark.parametrize("high", [3, 50, 10**9])
def test_group_rows_numbers_rows_in_lexicographic_order(rng, width, high):
    rows = rng.integers(-2, high, size=(400, width))
    rows[200:] = rows[rng.integers(0, 200, 200)]  # repeated rows
    ids, n = group_rows(rows)
    ref_ids, ref_n = reference_group_rows(rows)
    assert n == ref_n
    np.testing.assert_array_equal(ids, ref_ids)


@pytest.mark.parametrize("n", [1, 7, 300])
def testpair_groups_sorts_pairs_and_marks_the_distinct_ones(rng, n):
    first = rng.integers(0, n, size=1000).astype(np.int32)
    second = rng.integers(0, n, size=1000).astype(np.int32)
    order, new = pair_groups(first, second, n)
    pairs = np.stack([first, second], axis=1)
    np.testing.assert_array_equal(np.sort(order), np.arange(1000))
    np.testing.assert_array_equal(pairs[order], pairs[np.lexsort((second, first))])
    uniq = np.unique(pairs, axis=0)
    np.testing.assert_array_equal(pairs[order[new]], uniq)


def test_group_rows_of_nothing():
    ids, n = group_rows(np.zeros((0, 2), dtype=np.int64))
    assert ids.shape == (0,) and n == 0


@pytest.mark.parametrize("n", [0, 1, 7, 5000])
@pytest.mark.parametrize("high", [2, 10**12])
def test_unique_values_are_numpys(rng, n, high):
    a = rng.integers(-high, high, size=(n, 3))
    out = unique_values(a)
    np.testing.assert_array_equal(out, np.unique(a))
    assert out.dtype == a.dtype


def test_counting_sort_is_a_stable_argsort(rng):
    keys = rng.integers(0, 30, size=1000)
    order, starts = counting_sort(keys, 32)
    np.testing.assert_array_equal(order, np.argsort(keys, kind="stable"))
    np.testing.assert_array_equal(np.diff(starts), np.bincount(keys, minlength=32))


def reference_adjacency(facet_ids, owner, n):
    order = np.lexsort((owner, facet_ids))
    f, o = facet_ids[order], owner[order]
    same = (f[1:] == f[:-1]) & (o[1:] != o[:-1])
    adj = sp.coo_matrix((np.ones(same.sum()), (o[:-1][same], o[1:][same])), shape=(n, n))
    adj = (adj + adj.T).tocsr()
    adj.data[:] = 1.0
    return adj


@pytest.mark.parametrize("sorted_owner", [True, False])
def test_shared_facet_adjacency_matches_its_definition(rng, sorted_owner):
    owner = np.repeat(np.arange(60), 4)
    if not sorted_owner:
        owner = rng.permutation(owner)
    facet_ids = rng.integers(0, 90, size=owner.size)
    adj = shared_facet_adjacency(facet_ids, owner, 60)
    ref = reference_adjacency(facet_ids, owner, 60)
    assert adj.has_canonical_format
    np.testing.assert_array_equal(adj.indptr, ref.indptr)
    np.testing.assert_array_equal(adj.indices, ref.indices)
    np.testing.assert_array_equal(adj.data, ref.data)


def test_mixed_facets_gives_the_first_occurrence_of_each_mixed_facet(rng):
    owner = np.repeat(np.arange(50), 3)
    facet_ids = rng.integers(0, 60, size=owner.size)
    region1 = rng.random(50) < 0.5
    got = mixed_facets(facet_ids, owner, region1)
    want = [
        int(np.flatnonzero(facet_ids == f)[0])
        for f in range(60)
        if len(set(region1[owner[facet_ids == f]].tolist())) == 2
    ]
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("k, dim", [(1, 1), (1, 3), (2, 2), (2, 3), (3, 3), (3, 4)])
def test_cofactor_geometry_matches_lu(rng, k, dim):
    points = rng.normal(size=(40, dim))
    simplices = np.array([rng.choice(40, k + 1, replace=False) for _ in range(30)])
    simplices[0, 1] = simplices[0, 0]  # a degenerate one
    g_small = np.empty((30, dim, k + 1))
    g_large = np.empty((30, dim, k + 1))
    v_small = small_simplex_geometry(np.ascontiguousarray(points.T), simplices, g_small)
    v_large = large_simplex_geometry(points, simplices, g_large)
    np.testing.assert_allclose(v_small, v_large, rtol=1e-10)
    np.testing.assert_allclose(g_small, g_large, rtol=1e-8, atol=1e-10)
    assert np.isnan(v_small[0]) and not g_small[0].any()


DOMAINS = {
    "segments": SimplicialComplex([[0, 0], [1, 0.2], [2, 0.1], [3, 0.5]], [[0, 1], [1, 2], [2, 3]]),
    "right_triangles": kuhn_grid(5, 2),
    "surface": icosphere(2),
    "tets": kuhn_grid(3, 3, jitter=0.2, random_state=0),
    "split_tets": kuhn_grid(3, 3).split_elements(np.arange(162) % 5 == 0)[0],
}


@pytest.fixture(params=list(DOMAINS))
def domain(request):
    return DOMAINS[request.param]


def test_operators_match_their_definitions(domain):
    A = sp.diags(np.repeat(domain.A, domain.dim))
    ref = (domain.G.T @ A @ domain.G).tocsr()
    K = domain.K
    assert K.has_canonical_format and not (K.data == 0).any()
    np.testing.assert_allclose(K.toarray(), ref.toarray(), atol=1e-13 * abs(ref).max())
    assert domain.G.has_canonical_format
    simplices = domain.simplices
    k1 = simplices.shape[1]
    inc = sp.coo_matrix(
        (np.ones(simplices.size), (simplices.ravel(), np.repeat(np.arange(domain.n_elements), k1)))
    ).tocsr()
    assert (domain.incidence != inc).nnz == 0 and domain.incidence.has_canonical_format
    i, j = np.triu_indices(k1, 1)
    a, b = simplices[:, i].ravel(), simplices[:, j].ravel()
    key = np.unique(np.minimum(a, b) * domain.n_vertices + np.maximum(a, b))
    np.testing.assert_array_equal(domain.edges, np.stack([key // domain.n_vertices, key % domain.n_vertices], 1))


def reference_facets(simplices):
    """The facets of every simplex, sorted, element-major, facet i leaving out vertex i."""
    srt = np.sort(simplices, axis=1)
    k1 = srt.shape[1]
    return np.concatenate([np.delete(srt, i, axis=1)[:, None] for i in range(k1)], axis=1).reshape(-1, k1 - 1)


def test_edge_of_every_vertex_pair(domain):
    srt = np.sort(domain.simplices, axis=1)
    i, j = np.triu_indices(srt.shape[1], 1)
    edges, pair_edge = domain.edge_index
    pairs = np.stack([srt[:, i].ravel(), srt[:, j].ravel()], axis=1)
    np.testing.assert_array_equal(edges[pair_edge], pairs)


def four_simplices():
    # the Kuhn triangulation of the 4-cube cut into 2^4 cubes: 16 * 24 simplices
    from itertools import permutations

    grid = np.stack(np.meshgrid(*[np.arange(3)] * 4, indexing="ij"), axis=-1).reshape(-1, 4)
    number = {tuple(p): n for n, p in enumerate(grid)}
    simplices = []
    for corner in grid[(grid < 2).all(axis=1)]:
        for perm in permutations(range(4)):
            path = [corner.copy()]
            for axis in perm:
                path.append(path[-1].copy())
                path[-1][axis] += 1
            simplices.append([number[tuple(p)] for p in path])
    rng = np.random.default_rng(3)
    return SimplicialComplex(grid + 0.1 * rng.standard_normal(grid.shape), simplices)


FACET_DOMAINS = {
    "tets": lambda: kuhn_grid(4, 3, jitter=0.2, random_state=0),
    "shuffled_tets": lambda: SimplicialComplex(
        kuhn_grid(3, 3).points, np.random.default_rng(0).permuted(kuhn_grid(3, 3).simplices, axis=1)[::-1]
    ),
    # three tetrahedra around one triangle, and a tetrahedron listed twice
    "nonmanifold_tets": lambda: SimplicialComplex(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1], [2, 0, 0]],
        [[0, 1, 2, 3], [0, 1, 2, 4], [2, 1, 0, 5], [1, 2, 3, 6]],
    ),
    "repeated_tets": lambda: SimplicialComplex(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], [[0, 1, 2, 3], [1, 2, 3, 4], [3, 2, 1, 0]]
    ),
    "4-simplices": four_simplices,
    "segments": lambda: DOMAINS["segments"],
    "triangles": lambda: kuhn_grid(5, 2, jitter=0.2, random_state=0),
}


@pytest.mark.parametrize("name", list(FACET_DOMAINS))
def test_facets_and_adjacency_match_their_definitions(name):
    dom = FACET_DOMAINS[name]()
    E, k1 = dom.simplices.shape
    facets = reference_facets(dom.simplices)
    ref_ids, n = reference_group_rows(facets)
    np.testing.assert_array_equal(dom._facet_ids, ref_ids)
    if k1 > 3:
        ids, order, starts = dom._facet_groups
        np.testing.assert_array_equal(ids[order], np.sort(ref_ids))
        np.testing.assert_array_equal(np.diff(starts), np.bincount(ref_ids, minlength=n))
    adj = dom.adjacency
    assert adj.has_canonical_format
    ref = reference_adjacency(ref_ids, np.repeat(np.arange(E), k1), E)
    assert (adj != ref).nnz == 0
    region1 = np.arange(E) % 3 == 0
    which = mixed_facets(ref_ids, np.repeat(np.arange(E), k1), region1)
    np.testing.assert_array_equal(dom.interface_facets(region1), facets[which])


def test_element_max_matches_the_incidence(domain, rng):
    f = rng.normal(size=domain.n_vertices)
    np.testing.assert_array_equal(domain.element_max(f), Domain.element_max(domain, f))


SPLIT_DOMAINS = {
    "segments": lambda: SimplicialComplex(
        [[0, 0], [1, 0.2], [2, 0.1], [3, 0.5], [4, 0]], [[0, 1], [1, 2], [2, 3], [1, 2]]
    ),
    "right_triangles": lambda: kuhn_grid(6, 2),
    "triangles": lambda: kuhn_grid(6, 2, jitter=0.2, random_state=0),
    "surface": lambda: icosphere(2),
    "tets": lambda: kuhn_grid(4, 3, jitter=0.2, random_state=1),
    "unused_vertex": lambda: SimplicialComplex([[0, 0], [1, 0], [0, 1], [5, 5], [1, 1]], [[0, 1, 2], [1, 4, 2]]),
}


def assert_same_operators(split, fresh):
    for name in ("G", "K", "adjacency", "incidence"):
        a, b = getattr(split, name), getattr(fresh, name)
        assert a.has_canonical_format, name
        np.testing.assert_array_equal(a.indptr, b.indptr, err_msg=name)
        np.testing.assert_array_equal(a.indices, b.indices, err_msg=name)
        np.testing.assert_array_equal(a.data, b.data, err_msg=name)
    np.testing.assert_array_equal(split.edges, fresh.edges)
    np.testing.assert_array_equal(split.edge_index[1], fresh.edge_index[1])
    np.testing.assert_array_equal(split.A, fresh.A)
    np.testing.assert_array_equal(split.mass, fresh.mass)


@pytest.mark.parametrize("name", list(SPLIT_DOMAINS))
@pytest.mark.parametrize("built", [(), ("K", "mass"), ("K", "mass", "incidence", "adjacency")])
@pytest.mark.parametrize("fraction", [0.1, 1.0])
def test_split_keeps_the_operators_of_a_fresh_build(rng, name, built, fraction):
    # the split complex derives its operators from the parent's when its stiffness is built
    dom = SPLIT_DOMAINS[name]()
    for op in built:
        getattr(dom, op)
    mask = rng.random(dom.n_elements) < fraction
    mask[0] = True
    split, _ = dom.split_elements(mask)
    # derived from the parent's operators when they are built, built afresh otherwise
    assert (split.split_from is not None) == ("K" in built)
    assert_same_operators(split, SimplicialComplex(split.points, split.simplices))
    # a split of a split
    for op in built:
        getattr(split, op)
    mask = rng.random(split.n_elements) < 0.2
    mask[-1] = True
    again, _ = split.split_elements(mask)
    assert_same_operators(again, SimplicialComplex(again.points, again.simplices))


def test_interface_facets_without_the_facet_table(rng):
    dom = kuhn_grid(4, 3, jitter=0.2, random_state=0)
    region1 = rng.random(dom.n_elements) < 0.5
    got = dom.interface_facets(region1)
    assert dom._facets.shape == (4 * dom.n_elements, 3)
    np.testing.assert_array_equal(got, dom.interface_facets(region1))


def test_first_of_groups_is_the_first_index_of_each_id(rng):
    ids = rng.integers(0, 40, size=500)
    ids[:40] = rng.permutation(40)
    np.testing.assert_array_equal(first_of_groups(ids, 40), np.unique(ids, return_index=True)[1])


@pytest.mark.parametrize(
    "labels",
    [[3, 5, 3, 5], [True, False, True], np.array([7, 2, 2], dtype=np.uint8), ["b", "a", "a"], [1.0, 0.0, 1.0]],
)
def test_check_labels_sorts_classes_as_unique(labels):
    classes, region1 = check_labels(labels, len(labels), what="element")
    ref, inverse = np.unique(np.asarray(labels), return_inverse=True)
    assert classes.dtype == ref.dtype
    np.testing.assert_array_equal(classes, ref)
    np.testing.assert_array_equal(region1, inverse == 1)


@pytest.mark.parametrize("labels, n", [([1, 1, 1], "one class"), ([1, 2, 3, 1], "3 classes")])
def test_check_labels_refuses_other_than_two_classes(labels, n):
    with pytest.raises(ValueError, match=n):
        check_labels(labels, len(labels), what="element")


@pytest.mark.parametrize("width", [2, 4, 8])
def test_check_cells_finds_the_first_row_with_a_repeated_vertex(rng, width):
    cells = np.array([rng.permutation(20)[:width] for _ in range(30)])
    cells[7, width - 1] = cells[7, 0]
    cells[12, 1] = cells[12, 0]
    with pytest.raises(ValueError, match="row 7 "):
        check_cells(cells, 20)


def reference_cell_blocks(cell_ptr, cell_verts, blocks, block_ptr, n):
    """``sum_c P_c^T sym(B_c) P_c`` one dense cell at a time."""
    K = np.zeros((n, n))
    for c in range(cell_ptr.size - 1):
        v = cell_verts[cell_ptr[c] : cell_ptr[c + 1]]
        m = v.size
        B = blocks[block_ptr[c] : block_ptr[c] + m * m].reshape(m, m)
        K[np.ix_(v, v)] += 0.5 * (B + B.T)
    return K


def test_cell_blocks_assemble_to_their_sum_exactly_symmetric(rng):
    # cells of 3 to 8 vertices over 60 vertices, some sharing a block, one vertex unused
    sizes = rng.integers(3, 9, size=200)
    cell_ptr = np.concatenate([[0], np.cumsum(sizes)])
    cell_verts = np.concatenate([rng.choice(59, size=m, replace=False) for m in sizes])
    own = [rng.standard_normal(m * m) for m in sizes[:150]]  # not symmetric: the sum takes the symmetric part
    shared = {m: rng.standard_normal(m * m) for m in range(3, 9)}
    blocks = np.concatenate(own + list(shared.values()))
    starts = np.concatenate([[0], np.cumsum([b.size for b in own + list(shared.values())])])
    where = {m: starts[150 + i] for i, m in enumerate(shared)}
    block_ptr = np.array([starts[c] if c < 150 else where[sizes[c]] for c in range(sizes.size)])
    K = assemble_cell_blocks(cell_ptr, cell_verts, blocks, block_ptr, 60)
    assert K.has_canonical_format and K.shape == (60, 60)
    assert (K != K.T).nnz == 0  # symmetric to the last bit
    assert K.indptr[-1] == K.indptr[-2]  # the unused vertex: an empty row
    ref = reference_cell_blocks(cell_ptr, cell_verts, blocks, block_ptr, 60)
    np.testing.assert_allclose(K.toarray(), ref, atol=1e-13 * np.abs(ref).max())


@pytest.mark.parametrize("make", [lambda: hex_grid(5, jitter=0.2, random_state=0), lambda: ImageGrid((4, 5, 6))])
def test_cell_stiffness_is_the_sum_of_every_cell_s_matrix(make):
    mesh = make()  # jittered cells each with its own matrix; voxels sharing one
    cell, vert = mesh.cell_vertices
    starts = np.concatenate([[0], np.cumsum(np.bincount(cell, minlength=mesh.n_elements))])
    n = mesh.n_vertices
    ref = np.zeros((n, n))
    grad = mesh.G.tocsr()
    for c in range(mesh.n_elements):
        v = vert[starts[c] : starts[c + 1]]
        G = grad[3 * c : 3 * c + 3][:, v].toarray().T  # each vertex's gradient coefficient in cell c
        X = mesh.points[v] - mesh.points[v].mean(axis=0)
        Kc = mesh.A[c] * G @ G.T
        Q = np.eye(v.size) - (1.0 / v.size + X @ G.T)
        Kc = Kc + mesh.stabilization * np.trace(Kc) / v.size * Q.T @ Q
        ref[np.ix_(v, v)] += 0.5 * (Kc + Kc.T)
    K = mesh.K
    assert K.has_canonical_format and (K != K.T).nnz == 0
    np.testing.assert_allclose(K.toarray(), ref, atol=1e-12 * np.abs(ref).max())
    np.testing.assert_allclose(K @ np.ones(n), 0.0, atol=1e-12 * np.abs(ref).max())


def test_stencil_stiffness_is_g_transpose_a_g_exactly_symmetric(rng):
    """Random stencils of 6 slots, some empty (-1), one row each of weight 0: the
    stencil-by-stencil assembly equals the sparse product, bit-symmetric, canonical."""
    n, s, m = 300, 6, 3
    stencils = rng.integers(0, n - 5, size=(400, s))  # the last five vertices in no stencil
    stencils[rng.random(stencils.shape) < 0.15] = -1
    coef = rng.standard_normal((400, m, s))
    weight = rng.uniform(0.5, 2.0, 400)
    weight[7] = 0.0
    K = stencil_stiffness(stencils, coef, weight, n)
    rows = np.repeat(np.arange(400 * m), s)
    cols = np.broadcast_to(stencils[:, None, :], (400, m, s)).ravel()
    keep = cols >= 0
    G = sp.csr_matrix((coef.ravel()[keep], (rows[keep], cols[keep])), shape=(400 * m, n))
    ref = (G.T @ sp.diags(np.repeat(weight, m)) @ G).toarray()
    np.testing.assert_allclose(K.toarray(), ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())
    assert (K != K.T).nnz == 0 and K.has_canonical_format
    assert K[n - 5 :].nnz == 0


def test_point_cloud_stiffness_with_bridges_and_in_a_band(rng):
    from ndboundary import PointCloud

    blobs = np.concatenate([rng.normal(size=(150, 3)), 12.0 + rng.normal(size=(150, 3))])
    cloud = PointCloud(blobs, n_neighbors=8)
    assert cloud.bridges.shape[0] > 0
    band, _ = cloud.subdomain(cloud.element_centroids()[:, 0] < 0.5)  # stencils cut at its edge
    for dom in (cloud, band):
        ref = dom.G.T @ sp.diags(np.repeat(dom.A, dom.dim)) @ dom.G
        np.testing.assert_allclose(dom.K.toarray(), ref.toarray(), atol=1e-12 * abs(ref).max())
        np.testing.assert_allclose(dom.K @ np.ones(dom.n_vertices), 0.0, atol=1e-10 * abs(ref).max())
