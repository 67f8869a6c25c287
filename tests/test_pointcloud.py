import json
import os
import textwrap

import numpy as np
import pytest
from _background import BackgroundRun

from ndboundary import relax
from ndboundary import PointCloud, delaunay_complex
from ndboundary.domains.neighbors import estimate_intrinsic_dim, kneighbors


def _manifold(n, D, rng, m=2):
    """Points on a curved m-dimensional sheet, isometrically placed in R^D."""
    t = rng.uniform(-1, 1, size=(n, m))
    base = np.concatenate([t, 0.3 * np.sin(2 * t[:, :1])], axis=1)  # (n, m + 1)
    Q, _ = np.linalg.qr(np.random.default_rng(1).normal(size=(D, m + 1)))
    return base @ Q.T, t


@pytest.fixture
def cloud(rng):
    X = rng.normal(size=(300, 3))
    return PointCloud(X, n_neighbors=12, intrinsic_dim=3)


def test_operator_identities(cloud):
    K, G, A = cloud.K, cloud.G, cloud.A
    n = cloud.n_vertices
    assert G.shape == (cloud.n_elements * cloud.dim, n)
    assert np.abs(K @ np.ones(n)).max() < 1e-9
    assert abs(K - K.T).max() < 1e-12
    assert np.linalg.eigvalsh(K.toarray()).min() > -1e-9
    f = np.random.default_rng(2).normal(size=n)
    assert np.allclose(cloud.div(cloud.gradient(f)), K @ f)
    assert np.all(cloud.mass > 0) and np.all(A > 0)
    assert abs(cloud.adjacency - cloud.adjacency.T).max() == 0
    assert cloud.incidence.shape == (n, cloud.n_elements)


def test_gradient_exact_on_linear_functions(rng):
    X, t = _manifold(400, 5, rng, m=2)
    pc = PointCloud(X[:, :], n_neighbors=10, intrinsic_dim=3)
    a = np.array([0.3, -1.2, 0.5, 2.0, 0.1])
    g = np.einsum("ndm,nm->nd", pc.frames[pc.unique_inverse], pc.gradient(X @ a))
    # the ambient gradient projected on each tangent frame
    proj = np.einsum("ndm,nem,e->nd", pc.frames[pc.unique_inverse], pc.frames[pc.unique_inverse], a)
    assert np.allclose(g, proj, atol=1e-4)  # the ridge term of the fit, 1e-10 of the trace


def test_gradient_exact_in_flat_tangent_space(rng):
    X = rng.normal(size=(200, 2))
    pc = PointCloud(X, n_neighbors=8)
    a = np.array([1.5, -2.0])
    g = np.einsum("ndm,nm->nd", pc.frames[pc.unique_inverse], pc.gradient(X @ a))
    assert np.allclose(g, a, atol=1e-7)


def test_same_result_in_10_and_500_dimensions(rng):
    X10, t = _manifold(300, 10, rng)
    X500, _ = _manifold(300, 500, np.random.default_rng(0))
    labels = (t[:, 0] + 0.3 * t[:, 1] > 0).astype(int)
    a = PointCloud(X10, n_neighbors=12, intrinsic_dim=2)
    b = PointCloud(X500, n_neighbors=12, intrinsic_dim=2)
    # the distinct points are sorted differently in 10 and 500 dimensions: compare in sample order
    assert np.array_equal(a._stencil, b._stencil)
    assert a.G.nnz == b.G.nnz and a.K.shape == b.K.shape
    ra = relax(a, labels, on="vertices", smoothing=3)
    rb = relax(b, labels, on="vertices", smoothing=3)
    assert np.allclose(ra.phi, rb.phi, atol=1e-6)


# pynndescent compiles its numba functions in every fresh process, which takes a minute or
# two: the tests' calls of it run in a process started with the session, beside the other
# tests, and record what the tests check
NNDESCENT = BackgroundRun(
    textwrap.dedent(
        """
        import json, os, sys
        import numpy as np
        from ndboundary import PointCloud
        from ndboundary.domains import pointcloud_extension
        from ndboundary.domains.neighbors import kneighbors

        folder = sys.argv[1]
        X = np.random.default_rng(0).normal(size=(2000, 8))
        ia, dist = kneighbors(X, 10, method="nndescent", random_state=0)
        np.savez(os.path.join(folder, "neighbours.npz"), X=X, ia=ia, dist=dist)

        X = np.random.default_rng(1).normal(size=(400, 5))
        cloud = PointCloud(X, n_neighbors=12, method="nndescent", random_state=0)
        ext = cloud.extension(X[:, :1], labels=(X[:, 0] > 0).astype(int)).for_queries()
        seen, real = [], pointcloud_extension.in_blocks

        def spy(n, size, compute, *, first_alone=True):
            seen.append(first_alone)
            return real(n, size, compute, first_alone=first_alone)

        pointcloud_extension.in_blocks = spy
        ext(X[:50] + 0.01)
        print(json.dumps({"query_prepares": ext.cloud.query_prepares, "seen": seen}))
        """
    )
)
BACKGROUND = [NNDESCENT]


@pytest.mark.background_run
@pytest.mark.parametrize("method", ["hnsw", "nndescent"])
def test_exact_and_approximate_neighbours_agree(rng, method):
    if method == "hnsw":
        pytest.importorskip("faiss")
        X = rng.normal(size=(2000, 8))
        ia, dist = kneighbors(X, 10, method=method, random_state=0)
    else:
        out = np.load(NNDESCENT.wait() / "neighbours.npz")
        X, ia, dist = out["X"], out["ia"], out["dist"]
    ie, de = kneighbors(X, 10, method="exact")
    recall = np.mean([len(set(a) & set(b)) / 10 for a, b in zip(ie, ia)])
    assert recall > 0.95
    assert ie.shape == ia.shape and not np.any(ia == np.arange(2000)[:, None])
    assert np.all(np.diff(dist, axis=1) >= 0)
    found = ia == ie
    np.testing.assert_allclose(dist[found], de[found], rtol=1e-5)  # Euclidean, not squared


def test_hnsw_graph_is_the_same_in_every_run_and_survives_pickling(rng):
    pytest.importorskip("faiss")
    import pickle

    from ndboundary.domains.neighbors import NeighborIndex

    X = rng.normal(size=(3000, 6))
    a, b = NeighborIndex(X, 8, "hnsw", None), NeighborIndex(X, 8, "hnsw", None)
    np.testing.assert_array_equal(a.graph()[0], b.graph()[0])
    c = pickle.loads(pickle.dumps(a))
    Q = rng.normal(size=(50, 6))
    np.testing.assert_array_equal(c.query(Q, 5)[0], a.query(Q, 5)[0])


def test_intrinsic_dimension_estimate(rng):
    X, _ = _manifold(2000, 20, rng, m=2)
    pc = PointCloud(X, n_neighbors=15)
    assert pc.intrinsic_dim == 2
    assert 1.5 < estimate_intrinsic_dim(pc.distances) < 2.6


def test_duplicates(rng):
    X = rng.normal(size=(100, 2))
    X = np.concatenate([X, X[:20]])
    labels = np.r_[(X[:100, 0] > 0).astype(int), 1 - (X[:20, 0] > 0).astype(int)]
    pc = PointCloud(X, n_neighbors=8)
    assert pc.unique_points.shape[0] == 100
    r = relax(pc, labels, on="vertices")
    assert np.all(np.isfinite(r.phi))
    # duplicates with different labels form cut edges
    assert any(set(e) == {0, 100} for e in r.boundary.edges.tolist())


def test_constant_features(rng):
    X = np.c_[rng.normal(size=(150, 2)), np.ones(150), np.zeros(150)]
    pc = PointCloud(X, n_neighbors=10)
    r = relax(pc, (X[:, 0] > 0).astype(int), on="vertices")
    assert np.all(np.isfinite(r.phi))
    assert ((r.phi > 0.5) == (X[:, 0] > 0)).mean() > 0.95


def test_disconnected_clusters(rng):
    X = np.concatenate([rng.normal(size=(60, 2)), rng.normal(size=(60, 2)) + 100, rng.normal(size=(60, 2)) - 100])
    labels = np.r_[(X[:60, 0] > 0).astype(int), np.ones(60, int), np.zeros(60, int)]
    pc = PointCloud(X, n_neighbors=8)
    assert pc.n_components == 3 and pc.bridges.shape == (2, 2)
    assert np.abs(pc.K @ np.ones(180)).max() < 1e-9
    r = relax(pc, labels, on="vertices")
    assert np.all(np.isfinite(r.phi))
    assert ((r.phi > 0.5) == labels.astype(bool)).mean() > 0.95


def test_smoothing_operator_transports_constant_fields(rng):
    X, _ = _manifold(300, 6, rng)
    pc = PointCloud(X, n_neighbors=10, intrinsic_dim=3)
    T = pc.frames[pc.unique_inverse]
    v = rng.normal(size=6)
    local = np.einsum("ndm,d->nm", T, v)
    out = (pc.smoothing_operator() @ local.ravel()).reshape(local.shape)
    # on a linear subspace every frame spans it: the averaged field keeps its direction
    unit = local / np.linalg.norm(local, axis=1, keepdims=True)
    np.testing.assert_allclose(out / np.linalg.norm(out, axis=1, keepdims=True), unit, atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "err", "match"),
    [
        ({"X": np.zeros((5, 2))}, ValueError, "fewer than 2 distinct"),
        ({"X": [[0.0, np.nan], [1, 1]]}, ValueError, "NaN"),
        ({"X": np.zeros(5)}, ValueError, "shape"),
        ({"X": np.eye(3), "n_neighbors": 0}, ValueError, "n_neighbors must be >= 1"),
        ({"X": np.eye(3), "n_neighbors": 2.5}, TypeError, "n_neighbors must be an integer"),
        ({"X": np.eye(3), "intrinsic_dim": 4}, ValueError, "intrinsic_dim must be between"),
        ({"X": np.eye(3), "method": "kd"}, ValueError, "method must be"),
        ({"X": np.eye(3), "search_neighbors": 2.0}, TypeError, "search_neighbors must be an integer"),
        ({"X": "abc"}, TypeError, "X must be"),
    ],
)
def test_bad_input(kwargs, err, match):
    X = kwargs.pop("X")
    with pytest.raises(err, match=match):
        PointCloud(X, **kwargs)


def test_level_set_refused(cloud):
    result = relax(cloud, cloud.points[:, 0] > 0, on="vertices")
    with pytest.raises(TypeError, match="DelaunayComplex"):
        result.level_set()


def test_delaunay_complex(rng):
    X = rng.uniform(size=(200, 2))
    sc = delaunay_complex(X)
    assert sc.n_vertices == 200 and sc.simplex_dim == 2
    from scipy.spatial import ConvexHull

    assert np.isclose(sc.A.sum(), ConvexHull(X).volume)
    r = relax(sc, (X[:, 0] > 0.5).astype(int), on="vertices")
    assert np.all(np.isfinite(r.phi))


@pytest.mark.parametrize(
    ("X", "match"),
    [
        (np.random.default_rng(0).normal(size=(50, 7)), "kNN alternative"),
        (np.r_[np.eye(3)[:, :2], np.eye(3)[:1, :2]], "duplicate"),
        (np.c_[np.arange(10.0), np.arange(10.0)], "Qhull"),
    ],
)
def test_delaunay_refusals(X, match):
    with pytest.raises(ValueError, match=match):
        delaunay_complex(X)


@pytest.mark.parametrize(("D", "k"), [(3, 12), (20, 8)])  # the covariance, then the Gram matrix
def test_local_pca_frames_are_orthonormal_and_the_same_in_blocks_on_threads(monkeypatch, rng, D, k):
    from ndboundary.domains import tangent

    X, _ = _manifold(700, D, rng, m=2)
    nbr, _ = kneighbors(X, k, method="exact")
    whole = tangent.local_pca(X, nbr, 2)
    monkeypatch.setattr(tangent, "_CHUNK", 64)  # 11 blocks, shared by the threads
    Z, T = tangent.local_pca(X, nbr, 2)
    np.testing.assert_array_equal(Z, whole[0])
    np.testing.assert_array_equal(T, whole[1])
    np.testing.assert_allclose(T.transpose(0, 2, 1) @ T, np.broadcast_to(np.eye(2), (700, 2, 2)), atol=1e-10)
    offsets = X[nbr] - X[:, None, :]
    np.testing.assert_allclose(Z, offsets @ T, atol=1e-10)  # the coordinates are the offsets in the frame


def test_the_extension_is_the_same_in_blocks_on_threads(monkeypatch, rng):
    import pickle

    from ndboundary.domains import pointcloud_extension

    X, t = _manifold(600, 5, rng)
    cloud, phi, labels = PointCloud(X, n_neighbors=12), np.c_[t[:, 0], -t[:, 0]], (t[:, 0] > 0).astype(int)
    Q = X[:300] + 0.01 * rng.normal(size=(300, 5))
    ext = cloud.extension(phi, labels=labels)  # the power by leave-one-out, over 25 neighbours
    whole, loo = ext(Q), ext.leave_one_out(np.arange(600))  # one block each
    monkeypatch.setattr(pointcloud_extension, "_CHUNK", 16)  # blocks shared by the threads
    blocks = cloud.extension(phi, labels=labels)
    assert blocks.power == ext.power
    np.testing.assert_array_equal(blocks.leave_one_out(np.arange(600)), loo)
    np.testing.assert_array_equal(blocks(Q), whole)  # in the cloud's query order, the same values
    lean = pickle.loads(pickle.dumps(blocks.for_queries()))  # the order's axes travel with the copy
    np.testing.assert_array_equal(lean(Q), whole)
    assert whole.shape == (300, 2) and np.isfinite(whole).all()
    assert abs(whole[:, 0] - t[:300, 0]).mean() < 0.05  # it follows the function


@pytest.mark.parametrize("power", [0.0, 4.0])
def test_the_extensions_compiled_pass_over_hnsw_searches_is_its_arrays_pass(monkeypatch, rng, power):
    """Over an HNSW index, blocks of new points are searched into arrays each thread keeps
    and summed by one compiled pass; the values are those of the pass over every row's
    terms, on points inside the data, on training samples and far outside."""
    pytest.importorskip("faiss")
    from ndboundary.domains import pointcloud_extension
    from ndboundary.domains.neighbors import NeighborIndex

    X, t = _manifold(600, 5, rng)
    cloud = PointCloud(X, n_neighbors=12, method="hnsw")
    assert cloud.searches_into
    Q = np.r_[X[:300] + 0.01 * rng.normal(size=(300, 5)), X[300:340], 5.0 * X[340:360]]
    ext = cloud.extension(np.c_[t[:, 0]], power=power)
    monkeypatch.setattr(pointcloud_extension, "_CHUNK", 16)  # blocks on threads, each thread's arrays reused
    compiled = ext(Q)
    monkeypatch.setattr(NeighborIndex, "searches_into", property(lambda self: False))
    np.testing.assert_allclose(compiled, ext(Q), rtol=0.0, atol=1e-13)
    assert np.abs(compiled[300:340, 0] - t[300:340, 0]).max() < (1e-12 if power else 0.05)


@pytest.mark.background_run
@pytest.mark.parametrize("method", ["exact", "hnsw", "nndescent"])
def test_only_an_index_that_prepares_on_its_first_search_has_a_first_block_searched_alone(monkeypatch, rng, method):
    """pynndescent compiles its search on the first query, which the first block of new
    points takes alone; faiss and scikit-learn search every block at once."""
    if method == "hnsw":
        pytest.importorskip("faiss")
    if method == "nndescent":
        NNDESCENT.wait()
        assert json.loads(NNDESCENT.stdout.strip().splitlines()[-1]) == {"query_prepares": True, "seen": [True]}
        return
    from ndboundary import _threads
    from ndboundary.domains import pointcloud_extension

    X, t = _manifold(400, 5, rng)
    cloud = PointCloud(X, n_neighbors=12, method=method, random_state=0)
    ext = cloud.extension(np.c_[t[:, 0]], labels=(t[:, 0] > 0).astype(int)).for_queries()
    assert ext.cloud.query_prepares is False
    seen = []
    real = _threads.in_blocks

    def spy(n, size, compute, *, first_alone=True):
        seen.append(first_alone)
        return real(n, size, compute, first_alone=first_alone)

    monkeypatch.setattr(pointcloud_extension, "in_blocks", spy)
    ext(X[:50] + 0.01)
    assert seen == [False]


def test_distinct_rows_of_many_points_are_those_of_numpy_unique(rng):
    from ndboundary.domains.pointcloud import LOCALITY_MIN_POINTS, distinct_rows

    X = rng.normal(size=(LOCALITY_MIN_POINTS + 500, 6))
    X = np.concatenate([X, X[:700], -0.0 * X[:3]])  # duplicates, and zeros of either sign
    X[:3] = 0.0
    X = X[rng.permutation(X.shape[0])]
    unique, inverse = distinct_rows(X)
    expected = np.unique(X, axis=0)
    assert unique.shape == expected.shape
    np.testing.assert_array_equal(unique[inverse], X)
    np.testing.assert_array_equal(np.unique(unique, axis=0), expected)
    # two distinct rows whose projections are equal: the rows are sorted after all
    r = np.random.default_rng(0).normal(size=2)
    for x in np.linspace(1.0, 2.0, 1000):
        y = x * r[0] / r[1]
        if x * r[0] == y * r[1]:
            break
    else:
        pytest.fail("no colliding pair found")
    pair = np.zeros((LOCALITY_MIN_POINTS + 10, 2))
    pair[:, 0] = rng.normal(size=pair.shape[0])
    pair[:2] = [[x, 0.0], [0.0, y]]
    unique, inverse = distinct_rows(pair)
    np.testing.assert_array_equal(unique, np.unique(pair, axis=0))  # numpy's sorted rows
    np.testing.assert_array_equal(unique[inverse], pair)


def test_the_query_order_follows_the_data_and_is_a_permutation(rng):
    """Consecutive points in the order are close: the Z-order over the leading axes
    keeps the steps near the spacing of the data, far below a random order's."""
    from ndboundary.domains.neighbors import leading_axes, locality_order

    X, _ = _manifold(3000, 12, rng, m=3)
    cloud = PointCloud(X, n_neighbors=10)
    Q = X[rng.permutation(3000)] + 0.001 * rng.normal(size=X.shape)
    order = cloud.query_order(Q)
    assert np.array_equal(np.sort(order), np.arange(3000))
    step = np.linalg.norm(np.diff(Q[order], axis=0), axis=1).mean()
    random_step = np.linalg.norm(np.diff(Q, axis=0), axis=1).mean()
    assert step < 0.3 * random_step
    center, axes = leading_axes(X, 20)  # no more axes than features
    assert axes.shape == (12, 12)
    np.testing.assert_allclose(axes @ axes.T, np.eye(12), atol=1e-8)
    one = locality_order(X[:1], center, axes)
    assert one.tolist() == [0]


def test_the_query_order_sorts_by_the_interleaved_bits_of_each_rows_cell(rng):
    """The order is a stable sort of each row's Morton key: the bits of its cell on each
    axis, interleaved most significant first, the cells of one width on every axis."""
    from ndboundary.domains.neighbors import leading_axes, locality_order

    X = rng.normal(size=(400, 6)) * [3.0, 2.0, 1.0, 0.5, 0.1, 0.01]
    center, axes = leading_axes(X, 3)
    bits = 4
    P = np.array([axes @ (x - center) for x in X])
    width = (P.max(axis=0) - P.min(axis=0)).max() / 2**bits
    keys = []
    for p in P:
        cell = [min(int((c - lo) / width), 2**bits - 1) for c, lo in zip(p, P.min(axis=0), strict=True)]
        keys.append(int("".join(str(c >> b & 1) for b in range(bits - 1, -1, -1) for c in cell), 2))
    expected = np.argsort(keys, kind="stable")
    order = locality_order(X, center, axes, bits=bits)
    # a row exactly on a cell's edge may round either way in the two computations
    assert (order == expected).mean() > 0.99
    assert np.array_equal(np.sort(order), np.arange(400))


@pytest.mark.parametrize("n_features", [3, 8])
def test_exact_neighbours_by_tree_and_by_brute_force(rng, n_features):
    """Few features search a k-d tree, more compare every pair: both are the exact graph."""
    from ndboundary.domains.neighbors import TREE_MAX_FEATURES

    X = rng.normal(size=(400, n_features))
    ind, dist = kneighbors(X, 12, method="exact")
    D = np.linalg.norm(X[:, None] - X[None], axis=2)
    np.fill_diagonal(D, np.inf)
    np.testing.assert_allclose(dist, np.sort(D, axis=1)[:, :12], rtol=1e-12)
    np.testing.assert_array_equal(ind, np.argsort(D, axis=1, kind="stable")[:, :12])
    assert (n_features <= TREE_MAX_FEATURES) == (n_features == 3)


def test_threads_follow_omp_num_threads_as_the_process_was_started(monkeypatch):
    """A process started with ``OMP_NUM_THREADS=1`` (a Dask worker) runs one thread; a
    change of the variable after ndboundary is imported (a ``LocalCluster`` starting its
    workers sets it and leaves it set) changes nothing."""
    import subprocess
    import sys

    from ndboundary._threads import available_threads

    count = "from ndboundary._threads import available_threads; print(available_threads())"
    for value, expected in (("1", "1"), ("not a number", None), ("", None)):
        env = {**os.environ, "OMP_NUM_THREADS": value}
        out = subprocess.run([sys.executable, "-c", count], env=env, capture_output=True, text=True, check=True)
        assert int(out.stdout) >= 1 and (expected is None or out.stdout.strip() == expected)
    before = available_threads()
    monkeypatch.setenv("OMP_NUM_THREADS", "1" if before > 1 else "2")
    assert available_threads() == before


def test_compiled_first_order_values_equal_the_gathered_sums():
    """The compiled pass of the extension's first-order values against the same sums
    over a gathered (b, q, r, D) array, on neighbour indices sliced out of a wider array."""
    from ndboundary._compiled import ambient_values

    rng = np.random.default_rng(0)
    c, g = rng.normal(size=(50, 2)), rng.normal(size=(50, 2, 7))
    lo, hi = c - rng.uniform(0.0, 2.0, c.shape), c + rng.uniform(0.0, 2.0, c.shape)
    ind = rng.integers(0, 50, size=(30, 9))[:, :6]  # not contiguous
    X = rng.normal(size=(30, 7))
    out = np.empty((30, 6, 2))
    ambient_values(c, g, ind, X, lo, hi, out)
    expected = np.clip(c[ind] + np.einsum("bqrd,bd->bqr", g[ind], X), lo[ind], hi[ind])
    np.testing.assert_allclose(out, expected, rtol=1e-13, atol=1e-13)
    assert (out == lo[ind]).any() and (out == hi[ind]).any()  # both bounds were met


def test_tangent_offsets_equal_the_gathered_frames_products():
    rng = np.random.default_rng(0)
    cloud = PointCloud(rng.normal(size=(500, 6)), n_neighbors=10, intrinsic_dim=3)
    X, ind = rng.normal(size=(40, 6)), rng.integers(0, 500, size=(40, 9))[:, :7]
    expected = np.einsum("bqd,bqdm->bqm", X[:, None, :] - cloud.unique_points[ind], cloud.frames[ind])
    np.testing.assert_allclose(cloud.tangent_offsets(X, ind), expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(cloud.tangent_offsets(X, ind.astype(np.int32)), expected, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("method", ["exact", "hnsw"])
def test_a_wider_search_keeps_the_graph_and_serves_the_next_neighbours(rng, method):
    if method == "hnsw":
        pytest.importorskip("faiss")
    import pickle

    X = rng.normal(size=(1500, 6))
    X[7] = X[3]  # a duplicate: neighbours are among the distinct points
    narrow = PointCloud(X, n_neighbors=8, method=method)
    wide = PointCloud(X, n_neighbors=8, method=method, search_neighbors=20)
    np.testing.assert_array_equal(wide.neighbors, narrow.neighbors)
    np.testing.assert_array_equal(wide.distances, narrow.distances)
    ind, dist = wide.sample_neighbors(20)
    assert ind.shape == (wide.n_unique, 20) and np.array_equal(ind[:, :8], wide.neighbors)
    assert not np.any(ind == np.arange(wide.n_unique)[:, None]) and np.all(np.diff(dist, axis=1) >= 0)
    if method == "exact":
        exact, exact_dist = kneighbors(wide.unique_points, 20, method="exact")
        np.testing.assert_array_equal(ind, exact)
        np.testing.assert_allclose(dist, exact_dist)
    # searched when asked for and not kept (by a query of the index, whose candidate
    # lists are shorter for HNSW); the graph's own when it holds them
    later, _ = narrow.sample_neighbors(20)
    recall = np.mean([len(set(a) & set(b)) / 20 for a, b in zip(later, ind)])
    assert recall == 1.0 if method == "exact" else recall > 0.97
    np.testing.assert_array_equal(narrow.sample_neighbors(5)[0], narrow.neighbors[:, :5])
    assert "_wide" not in pickle.loads(pickle.dumps(wide)).__dict__


def test_hnsw_searches_points_of_many_features_beyond_a_smaller_size():
    from ndboundary.domains.neighbors import (
        EXACT_MAX_SAMPLES,
        HNSW_MIN_SAMPLES,
        TREE_MAX_FEATURES,
        exact_max_samples,
        has_faiss,
    )

    assert exact_max_samples(TREE_MAX_FEATURES) == EXACT_MAX_SAMPLES
    assert exact_max_samples(TREE_MAX_FEATURES + 1) == (HNSW_MIN_SAMPLES if has_faiss() else EXACT_MAX_SAMPLES)
    assert HNSW_MIN_SAMPLES < EXACT_MAX_SAMPLES


def test_the_lean_copy_for_queries_drops_what_queries_do_not_read(rng):
    import pickle

    X = rng.normal(size=(800, 7))
    cloud = PointCloud(X, n_neighbors=10, intrinsic_dim=3)
    phi = (X[:, 0] > 0).astype(float)
    ext = cloud.extension(phi, power=2.0)
    lean = ext.for_queries()
    assert "unique_points" not in lean.cloud.__dict__ and "frames" not in lean.cloud.__dict__
    assert lean._grad_u is None and lean.cloud.n_unique == cloud.n_unique
    Q = rng.normal(size=(300, 7))
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(lean))(Q), ext(Q))
    # two functions on a one-dimensional tangent space: the frames are read, and kept
    cloud1 = PointCloud(X, n_neighbors=10, intrinsic_dim=1)
    ext2 = cloud1.extension(np.stack([phi, 1.0 - phi], axis=1), power=2.0)
    lean2 = ext2.for_queries()
    assert "frames" in lean2.cloud.__dict__ and lean2._grad_u is not None
    np.testing.assert_array_equal(lean2(Q), ext2(Q))
