import time
from math import factorial

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary.datasets import icosphere, kuhn_grid
from ndboundary.levelset import marching_simplices
from ndboundary.partition import partition


def voronoi_values(points, sites):
    # f_r(x) = 2 x.s_r - |s_r|^2: the largest is the nearest site, and every f_r is linear
    return 2 * points @ sites.T - (sites**2).sum(axis=1)


def clipped_voronoi_areas(sites, lo=-1.0, hi=1.0):
    """Exact areas of the Voronoi cells clipped to the square (Sutherland-Hodgman)."""
    areas = []
    for r, s in enumerate(sites):
        poly = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], dtype=float)
        for q, t in enumerate(sites):
            if q == r or len(poly) == 0:
                continue
            n, c = t - s, (t @ t - s @ s) / 2  # keep n.x <= c
            g = poly @ n - c
            out = []
            for i in range(len(poly)):
                a, b, ga, gb = poly[i], poly[(i + 1) % len(poly)], g[i], g[(i + 1) % len(poly)]
                if ga <= 0:
                    out.append(a)
                if (ga < 0) != (gb < 0) and ga != gb:
                    out.append(a + ga / (ga - gb) * (b - a))
            poly = np.array(out)
        x, y = poly[:, 0], poly[:, 1]
        areas.append(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) if len(poly) else 0.0)
    return np.array(areas)


def domain_measure(points, simplices):
    X = points[simplices]
    E = X[:, 1:] - X[:, :1]
    k = E.shape[1]
    if k == points.shape[1]:
        return float(np.abs(np.linalg.det(E)).sum() / factorial(k))
    return float(np.sqrt(np.linalg.det(E @ E.transpose(0, 2, 1))).sum() / factorial(k))


def check_conforming(part, points, simplices):
    """No hanging nodes or overlaps: interior facets shared by two cells, border facets by one,
    and the border facets cover exactly the border of the input.
    """
    S = part.cells.simplices
    k1 = S.shape[1]
    f = np.sort(np.concatenate([np.delete(S, i, axis=1) for i in range(k1)]), axis=1)
    _, inv, counts = np.unique(f, axis=0, return_inverse=True, return_counts=True)
    assert counts.max() <= 2
    g = np.sort(np.concatenate([np.delete(simplices, i, axis=1) for i in range(k1)]), axis=1)
    _, ginv, gcounts = np.unique(g, axis=0, return_inverse=True, return_counts=True)
    if k1 >= 3:
        border = f[counts[inv.ravel()] == 1]
        in_border = g[gcounts[ginv.ravel()] == 1]
        m_out = domain_measure(part.cells.points, border) if len(border) else 0.0
        m_in = domain_measure(points, in_border) if len(in_border) else 0.0
        assert m_out == pytest.approx(m_in, rel=1e-9, abs=1e-12)


def check_argmax_per_cell(part):
    c = part.cells
    F = c.values[c.simplices]  # (n, k+1, L)
    best = F.max(axis=2)
    mine = np.take_along_axis(F, c.regions[:, None, None], axis=2)[..., 0]
    assert np.all(mine >= best - 1e-9 * (1 + np.abs(best)))
    centre = F.mean(axis=1)
    assert np.all(np.take_along_axis(centre, c.regions[:, None], 1)[:, 0] >= centre.max(axis=1) - 1e-9)


def test_voronoi_2d_exact():
    mesh = kuhn_grid(20, 2, jitter=0.25, random_state=0)
    sites = np.random.default_rng(0).uniform(-1, 1, (7, 2))
    part = partition(mesh.points, mesh.simplices, voronoi_values(mesh.points, sites))
    faces = part.interfaces()
    d = np.linalg.norm(faces.points[faces.simplices][:, :, None, :] - sites, axis=-1)  # (n, 2, L)
    rows = np.arange(len(faces))
    gap = d[rows, :, faces.pairs[:, 0]] - d[rows, :, faces.pairs[:, 1]]  # (n, 2)
    assert np.abs(gap).max() < 1e-9
    j = faces.junctions()
    assert len(j) > 0 and j.simplices.shape[1] == 1 and j.regions.shape[1] == 3
    dj = np.linalg.norm(j.points[j.simplices[:, 0]][:, None, :] - sites[j.regions], axis=-1)
    assert np.ptp(dj, axis=1).max() < 1e-9
    exact = clipped_voronoi_areas(sites)
    np.testing.assert_allclose(part.region_measures(), exact, rtol=0, atol=1e-9)
    fine = kuhn_grid(80, 2)
    np.testing.assert_allclose(
        partition(fine.points, fine.simplices, voronoi_values(fine.points, sites)).region_measures(), exact, atol=1e-9
    )
    check_conforming(part, mesh.points, mesh.simplices)
    check_argmax_per_cell(part)


def test_voronoi_3d_exact():
    mesh = kuhn_grid(8, 3, jitter=0.2, random_state=0)
    sites = np.random.default_rng(0).uniform(-1, 1, (6, 3))
    part = partition(mesh.points, mesh.simplices, voronoi_values(mesh.points, sites))
    faces = part.interfaces()
    # planar: every point of a piece on the bisector plane of its pair
    s0, s1 = sites[faces.pairs[:, 0]], sites[faces.pairs[:, 1]]
    X = faces.points[faces.simplices]  # (n, 3, 3)
    plane = np.einsum("nkd,nd->nk", X, s1 - s0) - ((s1**2).sum(1) - (s0**2).sum(1))[:, None] / 2
    assert np.abs(plane).max() < 1e-9
    j = faces.junctions()
    assert len(j) > 0 and j.simplices.shape[1] == 2
    for w in range(3, j.regions.shape[1] + 1):
        sel = (j.regions >= 0).sum(axis=1) == w
        P = j.points[j.simplices[sel]]  # (n, 2, 3)
        dj = np.linalg.norm(P[:, :, None, :] - sites[j.regions[sel, :w]][:, None], axis=-1)
        assert np.ptp(dj, axis=2).max() < 1e-9
    fine = kuhn_grid(16, 3)
    ref = partition(fine.points, fine.simplices, voronoi_values(fine.points, sites)).region_measures()
    np.testing.assert_allclose(part.region_measures(), ref, rtol=0, atol=1e-9)
    check_conforming(part, mesh.points, mesh.simplices)
    check_argmax_per_cell(part)


@pytest.mark.parametrize("case", ["2d", "3d", "sphere", "4d"])
def test_no_gaps_no_overlaps(case):
    rng = np.random.default_rng(3)
    if case == "2d":
        mesh, L = kuhn_grid(20, 2, jitter=0.25, random_state=1), 6
    elif case == "3d":
        mesh, L = kuhn_grid(6, 3, jitter=0.2, random_state=1), 5
    elif case == "sphere":
        mesh, L = icosphere(3), 4
    else:
        mesh, L = kuhn_grid(3, 4), 3
    P, S = mesh.points, mesh.simplices
    values = -np.linalg.norm(P[:, None, :] - rng.uniform(-1, 1, (L, P.shape[1])), axis=-1)
    values += 0.05 * rng.normal(size=values.shape)  # not linear: an arbitrary piecewise-linear field
    part = partition(P, S, values)
    total = domain_measure(P, S)
    assert part.input_measure == pytest.approx(total, rel=1e-12)
    assert part.region_measures().sum() == pytest.approx(total, rel=1e-9)
    assert np.all(part.region_measures() >= 0)
    # the region of a point is the argmax of the values: the vertices of the input agree
    owner = np.argmax(values, axis=1)
    first = np.zeros(part.cells.points.shape[0], dtype=np.int64) - 1
    first[part.cells.simplices.ravel()] = np.repeat(part.cells.regions, S.shape[1])
    strict = np.sort(values, axis=1)[:, -1] > np.sort(values, axis=1)[:, -2] + 1e-9
    assert np.all(first[: len(P)][strict] == owner[strict])
    check_conforming(part, P, S)
    check_argmax_per_cell(part)
    if case == "sphere":  # a closed surface: every region's boundary is closed
        assert all(part.region_boundary(r).is_closed() for r in range(L) if part.region_measures()[r] > 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_enclosed_region_is_watertight(dim):
    mesh = kuhn_grid(40 if dim == 2 else 10, dim, jitter=0.25 if dim == 2 else 0.2, random_state=0)
    rho = np.linalg.norm(mesh.points, axis=1)
    values = np.stack([0.3 - rho, np.zeros_like(rho), rho - 0.6], axis=1)  # disk, ring, outside
    part = partition(mesh.points, mesh.simplices, values)
    faces = part.interfaces()
    assert sorted(map(tuple, np.unique(faces.pairs, axis=0))) == [(0, 1), (1, 2)]
    inner = part.region_boundary(0)
    assert inner.is_closed() and inner.n_components() == 1
    assert inner.euler_characteristic() == (0 if dim == 2 else 2)
    assert inner.measure() == pytest.approx(faces.simplex_measures()[(faces.pairs == [0, 1]).all(1)].sum(), rel=1e-12)
    ring = part.region_boundary(1)
    assert ring.is_closed() and ring.n_components() == 2
    assert ring.measure() == pytest.approx(faces.measure(), rel=1e-12)
    assert len(faces.junctions()) == 0
    # outward from the disk: the normals point away from the origin
    X = inner.points[inner.simplices]
    if dim == 2:
        normal = (X[:, 1] - X[:, 0]) @ np.array([[0, 1], [-1, 0]])  # det[edge; normal] > 0
    else:
        normal = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])  # det[edges; normal] > 0
    assert np.all(np.einsum("nd,nd->n", normal, X.mean(axis=1)) > 0)
    assert part.region_measures().sum() == pytest.approx(part.input_measure, rel=1e-9)


@pytest.mark.parametrize("dim", [2, 3])
def test_two_regions_equal_marching_simplices(dim):
    mesh = kuhn_grid(20 if dim == 2 else 6, dim, jitter=0.2, random_state=2)
    values = np.random.default_rng(dim).normal(size=(mesh.points.shape[0], 2))
    faces = partition(mesh.points, mesh.simplices, values).interfaces()
    ls = marching_simplices(mesh.points, mesh.simplices, values[:, 1] - values[:, 0], 0.0)
    assert faces.measure() == pytest.approx(ls.measure(), rel=1e-12)
    assert faces.points.shape == ls.points.shape
    np.testing.assert_allclose(np.unique(faces.points.round(10), axis=0), np.unique(ls.points.round(10), axis=0))
    assert np.all(faces.pairs == [0, 1])

    def oriented(P, T):  # each simplex's coordinates, cyclically rotated to start at its smallest point
        out = set()
        for X in P[T].round(10):
            j = min(range(len(X)), key=lambda q: tuple(X[q]))
            out.add(tuple(np.roll(X, -j, axis=0).ravel()))
        return out

    # same orientation too: segments compared as they are, triangles up to a cyclic shift
    if dim == 2:
        assert {tuple(X.ravel()) for X in faces.points[faces.simplices].round(10)} == {
            tuple(X.ravel()) for X in ls.points[ls.simplices].round(10)
        }
    else:
        assert oriented(faces.points, faces.simplices) == oriented(ls.points, ls.simplices)


@pytest.mark.parametrize("jitter", [0.0, 0.2])
def test_three_region_y(jitter):
    n = 10 if jitter == 0 else 11  # even n: the junction is a grid vertex where all three tie
    mesh = kuhn_grid(n, 2, jitter=jitter, random_state=0)
    ang = np.deg2rad([90.0, 210.0, 330.0])
    d = np.stack([np.cos(ang), np.sin(ang)], axis=1)
    part = partition(mesh.points, mesh.simplices, mesh.points @ d.T)
    faces = part.interfaces()
    j = faces.junctions()
    assert len(j) == 1 and j.regions.tolist() == [[0, 1, 2]]
    assert np.abs(j.points).max() < 1e-12
    directions = []
    for r, s in [(0, 1), (0, 2), (1, 2)]:
        sel = (faces.pairs == [r, s]).all(axis=1)
        X = faces.points[np.unique(faces.simplices[sel])]
        assert np.abs(X @ (d[r] - d[s])).max() < 1e-12  # straight, through the origin
        t = 3 - r - s
        assert np.all(X @ d[t] < 1e-12)  # the ray opposite the third direction
        far = X[np.argmax(np.linalg.norm(X, axis=1))]
        directions.append(far / np.linalg.norm(far))
        assert faces.measure() > 0
    cos = [directions[a] @ directions[b] for a, b in [(0, 1), (0, 2), (1, 2)]]
    np.testing.assert_allclose(cos, -0.5, atol=1e-12)
    assert part.region_measures() == pytest.approx(np.full(3, 4 / 3), rel=0, abs=0.5)
    assert part.region_measures().sum() == pytest.approx(4.0, rel=1e-12)


def test_degenerate_values():
    mesh = kuhn_grid(10, 2)
    x = mesh.points
    spike = np.where(np.all(x == 0, axis=1), 5.0, -5.0)
    values = np.stack([x[:, 0], x[:, 0], -x[:, 0], np.zeros(len(x)), spike, -x[:, 0]], axis=1)
    part = partition(mesh.points, mesh.simplices, values)
    m = part.region_measures()
    assert np.all(np.isfinite(part.cells.points)) and np.all(np.isfinite(m))
    assert m.sum() == pytest.approx(4.0, rel=1e-12)
    # 1 and 5 equal 0 and 2 everywhere (the smaller index wins); 3 ties 0 and 2 only on the line x = 0
    assert m[1] == 0 and m[5] == 0 and m[3] == 0
    assert m[4] > 0 and m[0] == pytest.approx(m[2], rel=1e-12)
    check_conforming(part, mesh.points, mesh.simplices)
    check_argmax_per_cell(part)
    faces = part.interfaces()
    assert set(map(tuple, faces.pairs.tolist())) == {(0, 2), (0, 4), (2, 4)}
    # a function tying the maximum on a whole vertex and nowhere larger
    tie = np.stack([x[:, 0], -x[:, 0], np.where(np.all(x == 0, axis=1), 0.0, -1.0)], axis=1)
    part = partition(mesh.points, mesh.simplices, tie)
    assert part.region_measures()[2] == 0 and part.region_measures().sum() == pytest.approx(4.0, rel=1e-12)
    # constant functions, all equal
    flat = partition(mesh.points, mesh.simplices, np.ones((len(x), 3)))
    assert flat.region_measures().tolist() == pytest.approx([4.0, 0, 0]) and len(flat.interfaces()) == 0


def test_speed_250k_vertices():
    mesh = kuhn_grid(500, 2, jitter=0.25, random_state=0)
    sites = np.random.default_rng(0).uniform(-1, 1, (8, 2))
    values = -np.linalg.norm(mesh.points[:, None, :] - sites, axis=-1)
    t0 = time.perf_counter()
    part = partition(mesh.points, mesh.simplices, values)
    faces = part.interfaces()
    j = faces.junctions()
    m = part.region_measures()
    [part.region_boundary(r) for r in range(8)]
    elapsed = time.perf_counter() - t0
    print(f"partition of {mesh.points.shape[0]} vertices, 8 regions: {elapsed:.2f} s, {len(part.cells)} cells")
    assert elapsed < 10
    assert m.sum() == pytest.approx(4.0, rel=1e-9)
    assert len(j) > 0 and len(faces) > 0


@pytest.mark.parametrize("case", ["2d", "3d", "sphere"])
def test_sparse_values_store_only_the_regions_that_can_win(case):
    """Values stored where a region may win (within reach of the largest, one ring wide)
    give the dense partition; stored everywhere, the same cells."""
    rng = np.random.default_rng(5)
    mesh, L = {"2d": (kuhn_grid(24, 2, jitter=0.25, random_state=2), 9),
               "3d": (kuhn_grid(7, 3, jitter=0.2, random_state=2), 7), "sphere": (icosphere(3), 6)}[case]  # fmt: skip
    P, S = mesh.points, mesh.simplices
    values = -np.linalg.norm(P[:, None, :] - rng.uniform(-1, 1, (L, P.shape[1])), axis=-1)
    values += 0.05 * rng.normal(size=values.shape)
    dense = partition(P, S, values)
    full = partition(P, S, sp.csr_matrix(values))
    assert len(full.cells) == len(dense.cells) and full.cells.values is None
    np.testing.assert_allclose(full.region_measures(), dense.region_measures(), rtol=0, atol=1e-12)
    near = values >= values.max(axis=1, keepdims=True) - 0.3
    keep = np.zeros_like(near)
    for j in range(S.shape[1]):  # every vertex of a simplex where the region is near the largest
        np.logical_or.at(keep, S[:, j], near[S].any(axis=1))
    assert keep.mean() < 0.6
    part = partition(P, S, sp.coo_matrix((values[keep], np.nonzero(keep)), shape=values.shape))
    assert len(part.cells) < len(dense.cells)  # fewer cuts by regions that never win there
    np.testing.assert_allclose(part.region_measures(), dense.region_measures(), rtol=0, atol=1e-12)
    assert part.interfaces().measure() == pytest.approx(dense.interfaces().measure(), rel=1e-12)
    lengths = []  # junction points in 2-D, curves in 3-D (split into other segments)
    for p in (part, dense):
        j = p.interfaces().junctions()
        x = j.points[j.simplices]
        lengths.append(len(j) if x.shape[1] == 1 else np.linalg.norm(x[:, 1] - x[:, 0], axis=1).sum())
    assert lengths[0] == pytest.approx(lengths[1], rel=1e-9)
    check_conforming(part, P, S)
    if case == "sphere":
        assert all(part.region_boundary(r).is_closed() for r in range(L) if part.region_measures()[r] > 0)


@pytest.mark.parametrize("dim, n, L", [(2, 20, 7), (3, 6, 6), (4, 3, 5)])
def test_sparse_sweep_cuts_as_the_dense_one(dim, n, L):
    """Every region stored at every vertex, the sparse sweep (compiled, region by region
    on the cells it is stored at) makes the points of the dense one, from the same edges
    in the same order (to rounding: the sparse values are shifted), and the same cells
    with the same regions and orientations."""
    rng = np.random.default_rng(dim)
    mesh = kuhn_grid(n, dim, jitter=0.2, random_state=dim)
    P, S = mesh.points, mesh.simplices
    values = voronoi_values(P, rng.uniform(-1, 1, (L, dim))) + 0.02 * rng.normal(size=(len(P), L))
    dense, sparse = partition(P, S, values), partition(P, S, sp.csr_matrix(values))
    assert len(dense.cells) > 1.5 * len(S)  # many cuts
    np.testing.assert_array_equal(sparse.cells.parents, dense.cells.parents)
    np.testing.assert_allclose(sparse.cells.points, dense.cells.points, rtol=0, atol=1e-12)

    def rows(c):  # cells with their region, as a sorted table (their order may differ)
        table = np.column_stack([c.simplices, c.regions])
        return table[np.lexsort(table.T[::-1])]

    np.testing.assert_array_equal(rows(sparse.cells), rows(dense.cells))


@pytest.mark.parametrize("dim", [2, 3])
def test_beaten_simplices_hold_no_cell_of_the_region(dim):
    """A simplex flagged as beaten for region r holds none of r's cells in the partition
    of every simplex, nor a point of them (on its faces): r's cells lie in the simplices
    left. The test flags most of the simplices that hold none."""
    from ndboundary._compiled_partition import beaten_simplices

    rng = np.random.default_rng(dim)
    mesh = kuhn_grid(12 if dim == 2 else 5, dim, jitter=0.2, random_state=dim)
    P, S = mesh.points, mesh.simplices
    values = voronoi_values(P, rng.uniform(-1, 1, (6, dim))) + 0.02 * rng.normal(size=(len(P), 6))
    values = sp.csr_matrix(values - values.min() + 1.0)  # stored >= 1, as the partition shifts them
    cells = partition(P, S, values).cells
    corners = cells.points[cells.simplices]
    parent = np.argmin(_outside(P[S], corners.mean(axis=1)), axis=0)  # the simplex holding each cell
    for r in range(6):
        beaten = beaten_simplices(S, values, r)
        holds = np.zeros(len(S), dtype=bool)
        holds[parent[cells.regions == r]] = True
        assert holds.any() and not (beaten & holds).any()
        points = corners[cells.regions == r].reshape(-1, dim)
        assert _outside(P[S[~beaten]], points).min(axis=0).max() < 1e-9
        assert beaten.sum() >= 0.7 * (~holds).sum()


def _outside(corners, x):
    """How far, in barycentric coordinates, each of the points ``x`` (m, k) lies outside
    each simplex of ``corners`` (n, k + 1, k): shape (n, m), 0 inside it or on it."""
    T = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))
    lam = np.linalg.solve(T[:, None], (x[None] - corners[:, :1])[..., None])[..., 0]
    bary = np.concatenate([1 - lam.sum(axis=2, keepdims=True), lam], axis=2)
    return np.maximum(-bary.min(axis=2), 0.0)


def test_a_facet_of_three_cells_pairs_them_in_turn():
    """Three triangles on one edge (not a manifold): the edge lies between the first and
    the second cell and between the second and the third, where their regions differ."""
    from ndboundary.partition_clip import interface_facets

    points = np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]])
    book = np.array([[0, 1, 2], [0, 1, 3], [0, 1, 4]])
    facets, pairs, cells = interface_facets(points, book, np.array([0, 1, 2]))
    assert sorted(map(tuple, np.sort(facets, axis=1))) == [(0, 1), (0, 1)]
    assert pairs.tolist() == [[0, 1], [1, 2]] and cells.tolist() == [[0, 1], [1, 2]]
    facets, pairs, cells = interface_facets(points, book, np.array([0, 0, 1]))
    assert pairs.tolist() == [[0, 1]] and cells.tolist() == [[1, 2]]


def test_interfaces_of_a_region():
    """``of_region(r)`` lists, increasing, the interface simplices with ``r`` on a side,
    and none for a region with no interface or out of range."""
    mesh = kuhn_grid(16, 2, jitter=0.2, random_state=1)
    values = voronoi_values(mesh.points, np.random.default_rng(3).uniform(-1, 1, (6, 2)))
    values = np.column_stack([values, np.full(len(mesh.points), -100.0)])  # a region that never wins
    faces = partition(mesh.points, mesh.simplices, values).interfaces()
    for r in range(8):
        np.testing.assert_array_equal(faces.of_region(r), np.flatnonzero((faces.pairs == r).any(axis=1)))
    assert faces.of_region(6).size == 0 and faces.of_region(7).size == 0 and faces.of_region(0).size > 0


def test_sparse_values_need_a_region_at_every_vertex():
    points, simplices = [[0, 0], [1, 0], [0, 1]], [[0, 1, 2]]
    values = sp.csr_matrix(([0.0, 1.0, 2.0], ([0, 1, 1], [0, 0, 1])), shape=(3, 2))
    with pytest.raises(ValueError, match="no region at vertex 2"):
        partition(points, simplices, values)
    with pytest.raises(ValueError, match="NaN"):
        partition(points, simplices, sp.csr_matrix([[0.0, 1.0], [np.nan, 1.0], [1.0, 0.0]]))
    # a stored zero is a value, not an absent region
    values = sp.csr_matrix((np.tile([-1.0, 0.0], 3), (np.repeat(np.arange(3), 2), np.tile([0, 1], 3))), shape=(3, 2))
    assert values.nnz == 6 and partition(points, simplices, values).region_measures().tolist() == [0.0, 0.5]


def test_validation():
    with pytest.raises(ValueError):
        partition([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [[0], [1], [2]])
    with pytest.raises(ValueError):
        partition([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]], [[0, np.nan], [1, 0], [2, 0]])


@pytest.mark.parametrize("dim", [2, 3])
def test_junctions_sorted_a_share_of_the_faces_at_a_time_are_the_same(monkeypatch, dim):
    """The junctions found from the faces' keys a share at a time (JUNCTION_KEYS_AT_ONCE)
    are those found from every key at once, in the same order: the junction points of a
    Voronoi partition in the plane, its junction curves in a volume."""
    from ndboundary import partition as partition_module

    mesh = kuhn_grid(30 if dim == 2 else 8, dim, jitter=0.2, random_state=1)
    sites = np.random.default_rng(3).uniform(-1, 1, (9, dim))
    values = -np.linalg.norm(mesh.points[:, None, :] - sites, axis=-1)
    faces = partition(mesh.points, mesh.simplices, values).interfaces()
    at_once = faces.junctions()
    monkeypatch.setattr(partition_module, "JUNCTION_KEYS_AT_ONCE", 50)
    by_share = faces.junctions()
    assert len(at_once) >= 5 and dim * len(faces) > 4 * 50  # several shares
    for name in ("points", "simplices", "regions", "point_ids"):
        np.testing.assert_array_equal(getattr(by_share, name), getattr(at_once, name))
