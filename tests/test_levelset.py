"""Marching simplices: exactness on linear functions, shared vertices, watertightness, orientation."""

import numpy as np
import pytest

from ndboundary import SimplicialComplex, marching_simplices, relax, relax_image
from ndboundary.datasets import icosphere, kuhn_grid, voronoi_polygons


@pytest.mark.parametrize("dim, n", [(2, 9), (3, 5), (4, 3)])
def test_linear_function_gives_flat_level_set(dim, n, rng):
    dom = kuhn_grid(n, dim, jitter=0.2, random_state=0)
    a = rng.standard_normal(dim)
    a /= np.linalg.norm(a)
    ls = marching_simplices(dom.points, dom.simplices, dom.points @ a, 0.1)
    assert ls.n_simplices > 0
    assert ls.simplices.shape[1] == dim
    np.testing.assert_allclose(ls.points @ a, 0.1, atol=1e-12)
    # oriented so the function increases along the normal: in the plane, (d, a) is right-handed
    if dim == 2:
        d = ls.points[ls.simplices[:, 1]] - ls.points[ls.simplices[:, 0]]
        assert np.all(d[:, 0] * a[1] - d[:, 1] * a[0] > 0)
    # a flat cut of a convex cube is one connected open piece
    assert ls.n_components() == 1
    assert not ls.is_closed()


def test_a_surface_is_closed_when_every_edge_meets_its_reverse_once():
    """A closed surface stays closed whatever its points' numbering and its triangles'
    order; a hole, a flipped triangle, a repeated one or a flap opens it. Triangles are
    checked by their edges as integers; the rows of sorted ids that every other kind of
    simplex is checked by give the same answers."""
    import ndboundary.levelset as levelset

    dom = kuhn_grid(8, 3, jitter=0.25, random_state=3)
    ball = marching_simplices(dom.points, dom.simplices, np.linalg.norm(dom.points, axis=1), 0.6)
    rng = np.random.default_rng(0)
    perm = rng.permutation(ball.n_points)
    shuffled = levelset.LevelSet(ball.points[np.argsort(perm)], perm[ball.simplices][rng.permutation(ball.n_simplices)],
                                 ball.edges, 0.6)  # fmt: skip
    T = ball.simplices
    flipped = T.copy()
    flipped[7, [0, 1]] = flipped[7, [1, 0]]
    flap = np.vstack([T, [T[0, 0], T[0, 1], ball.n_points]])  # a triangle on an edge already closed
    cases = {"ball": (T, True), "shuffled": (shuffled.simplices, True), "hole": (T[1:], False),
             "flipped": (flipped, False), "repeated": (np.vstack([T, T[:1]]), False),
             "flap": (flap, False)}  # fmt: skip
    points = np.vstack([ball.points, ball.points[:1]])
    for name, (simplices, closed) in cases.items():
        surface = levelset.LevelSet(points, simplices, None, 0.6)
        assert surface.is_closed() == closed, name
        assert levelset._closed_facets(surface.facets(), surface.n_points) == closed, name


@pytest.mark.parametrize("dim, n, chi", [(2, 12, 0), (3, 8, 2)])
def test_sphere_level_set_is_closed_and_oriented(dim, n, chi):
    dom = kuhn_grid(n, dim, jitter=0.25, random_state=3)
    ls = marching_simplices(dom.points, dom.simplices, np.linalg.norm(dom.points, axis=1), 0.6)
    assert ls.is_closed()
    assert ls.n_components() == 1
    assert ls.euler_characteristic() == chi
    # vertices are shared: every level-set point lies on one distinct domain edge
    assert np.unique(ls.edges, axis=0).shape[0] == ls.n_points
    np.testing.assert_array_equal(ls.edges, np.unique(ls.edges, axis=0))  # in the order of their ends
    radius = np.linalg.norm(dom.points, axis=1)  # each edge from below the level to above it
    assert radius[ls.edges[:, 0]].max() < 0.6 <= radius[ls.edges[:, 1]].min()
    if dim == 3:
        # outward orientation: the signed volume enclosed is positive
        P = ls.points[ls.simplices]
        vol = np.einsum("ij,ij->i", P[:, 0], np.cross(P[:, 1], P[:, 2])).sum() / 6
        assert vol == pytest.approx(4 / 3 * np.pi * 0.6**3, rel=0.15)


@pytest.mark.parametrize("case", ["triangles", "tetrahedra", "surface"])
def test_the_compiled_orientations_are_those_of_the_blocks_of_arrays(monkeypatch, case):
    """Owners up to tetrahedra orient their output simplices in one compiled pass; the
    triangles, segments and their windings are those of the arrays' pass, on a jittered
    grid whose values are rough (every crossing pattern) and on a curve on a surface."""
    from ndboundary import levelset

    rng = np.random.default_rng(0)
    dom = icosphere(3) if case == "surface" else kuhn_grid(7, 2 if case == "triangles" else 3, jitter=0.3)
    values = dom.points[:, 2] if case == "surface" else rng.uniform(size=dom.n_vertices)
    compiled = marching_simplices(dom.points, dom.simplices, values, 0.5)
    monkeypatch.setattr(levelset, "COMPILED_ORIENTATION_DIM", 0)
    arrays = marching_simplices(dom.points, dom.simplices, values, 0.5)
    assert compiled.n_simplices > 20
    np.testing.assert_array_equal(compiled.simplices, arrays.simplices)
    np.testing.assert_array_equal(compiled.points, arrays.points)


@pytest.mark.parametrize("dim", [1, 2, 3, 4])
def test_the_compiled_crossing_pass_lays_out_the_staircase_of_each_simplex(dim):
    """One compiled pass finds the crossed simplices and their output simplices: each
    crossed simplex sorted, with its sort's parity, and the staircase paths of its pattern,
    grouped by pattern, then path, then owner, as a loop over the simplices lays them out."""
    from itertools import permutations

    from ndboundary._compiled_geometry import crossing_pattern
    from ndboundary.levelset import _crossing_table, staircase_paths

    dom = kuhn_grid({1: 12, 4: 2}.get(dim, 4), dim)
    rng = np.random.default_rng(dim)
    simplices = np.array([rng.permutation(s) for s in dom.simplices])
    above = rng.uniform(size=dom.n_vertices) < 0.5
    S, parity, E, owner, local = crossing_pattern(simplices, above, *_crossing_table(dim + 1))
    rows, signs, by_code = [], [], {}
    for s in simplices:
        ab = above[s]
        if ab.all() or not ab.any():
            continue
        order = sorted(range(dim + 1), key=lambda i: s[i])
        inversions = sum(order[i] > order[j] for i, j in permutations(range(dim + 1), 2) if i < j)
        row = s[order]
        code = int(sum(1 << i for i in range(dim + 1) if above[row[i]]))
        lo, hi = np.flatnonzero(~above[row]), np.flatnonzero(above[row])
        for p, path in enumerate(staircase_paths(lo.size, hi.size)):
            loc = np.stack([lo[path[:, 0]], hi[path[:, 1]]], axis=-1)
            by_code.setdefault((code, p), []).append((len(rows), row[loc], loc))
        rows.append(row)
        signs.append(-1 if inversions % 2 else 1)
    assert len(rows) > 3
    np.testing.assert_array_equal(S, rows)
    np.testing.assert_array_equal(parity, signs)
    expected = [entry for key in sorted(by_code) for entry in by_code[key]]
    np.testing.assert_array_equal(owner, [o for o, _, _ in expected])
    np.testing.assert_array_equal(E, [e for _, e, _ in expected])
    np.testing.assert_array_equal(local, [loc for _, _, loc in expected])


def test_simplices_that_index_no_point_are_refused():
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match="outside 0..2"):
        marching_simplices(tri, [[0, 1, 3]], np.array([0.0, 1.0, 1.0]))
    with pytest.raises(ValueError, match="one per point"):
        marching_simplices(tri, [[0, 1, 2]], np.array([0.0, 1.0]))


def test_four_dimensional_level_set_is_a_closed_tetrahedral_complex():
    dom = kuhn_grid(4, 4, jitter=0.1, random_state=0)
    ls = marching_simplices(dom.points, dom.simplices, np.linalg.norm(dom.points, axis=1), 0.7)
    assert ls.simplices.shape[1] == 4
    assert ls.is_closed()
    assert ls.n_components() == 1
    assert ls.euler_characteristic() == 0  # a closed 3-manifold


def test_staircase_split_of_a_tetrahedron():
    tet = np.vstack([np.zeros(3), np.eye(3)])
    two_two = marching_simplices(tet, [[0, 1, 2, 3]], np.array([0.0, 0.0, 1.0, 1.0]), 0.5)
    assert two_two.n_simplices == 2 and two_two.n_points == 4
    one_three = marching_simplices(tet, [[0, 1, 2, 3]], np.array([0.0, 1.0, 1.0, 1.0]), 0.5)
    assert one_three.n_simplices == 1 and one_three.n_points == 3
    # the crossing is the rectangle through the midpoints of edges 02, 03, 12, 13
    assert two_two.measure() == pytest.approx(0.5 * np.sqrt(0.5))


def test_values_equal_to_the_level_count_as_above():
    tri = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    ls = marching_simplices(tri, [[0, 1, 2]], np.array([0.0, 0.5, 1.0]), 0.5)
    assert ls.n_simplices == 1
    # vertex 1 (value exactly 0.5) is above: the crossings are vertex 1 itself and edge 0-2's midpoint
    np.testing.assert_allclose(ls.points[np.lexsort(ls.points.T)], [[1.0, 0.0], [0.0, 0.5]])
    assert np.all(np.isfinite(ls.points))


def test_empty_level_set():
    dom = kuhn_grid(3, 2)
    ls = marching_simplices(dom.points, dom.simplices, np.zeros(dom.n_vertices), 0.5)
    assert ls.n_simplices == 0 and ls.measure() == 0.0 and ls.n_components() == 0


def test_nan_values_are_refused():
    dom = kuhn_grid(2, 2)
    with pytest.raises(ValueError, match="NaN"):
        marching_simplices(dom.points, dom.simplices, np.full(dom.n_vertices, np.nan))


def test_curve_on_a_surface_is_consistently_oriented():
    dom = icosphere(3)
    ls = marching_simplices(dom.points, dom.simplices, dom.points[:, 2], 0.3)
    assert ls.is_closed() and ls.n_components() == 1
    # seen from above (+z), the curve around the cap z > 0.3 turns one way everywhere
    d = ls.points[ls.simplices[:, 1]] - ls.points[ls.simplices[:, 0]]
    m = 0.5 * (ls.points[ls.simplices[:, 1]] + ls.points[ls.simplices[:, 0]])
    turn = m[:, 0] * d[:, 1] - m[:, 1] * d[:, 0]
    assert np.all(turn > 0) or np.all(turn < 0)
    assert ls.measure() == pytest.approx(2 * np.pi * np.sqrt(1 - 0.09), rel=0.02)


def test_segments_give_points():
    dom = SimplicialComplex([[0.0], [1.0], [2.0]], [[0, 1], [1, 2]])
    ls = marching_simplices(dom.points, dom.simplices, np.array([0.0, 1.0, 0.0]), 0.5)
    np.testing.assert_allclose(np.sort(ls.points[:, 0]), [0.5, 1.5])


@pytest.mark.parametrize(("dim", "n", "radius", "chi"), [(2, 10, 0.6, 0), (3, 10, 0.6, 2), (4, 4, 0.5, 0)])
def test_level_set_through_vertices_is_closed(dim, n, radius, chi):
    # the sphere passes exactly through grid vertices: their crossings are one point each
    grid = kuhn_grid(n, dim)
    values = np.linalg.norm(grid.points, axis=1) - radius
    assert (values == 0).any()
    ls = marching_simplices(grid.points, grid.simplices, values, 0.0)
    assert ls.is_closed() and ls.n_components() == 1 and ls.euler_characteristic() == chi


@pytest.mark.parametrize("value", [0.5, 0.3])
@pytest.mark.parametrize(
    "make",
    [
        lambda: relax_image(ball_mask(), spacing=(1.0, 0.8, 1.2)),
        lambda: relax_image(ball_mask()[6]),
        lambda: relax(
            voronoi_polygons(30, random_state=0), disc_labels(voronoi_polygons(30, random_state=0)), on="elements"
        ),
    ],
    ids=["voxels", "pixels", "polygons"],
)
def test_level_set_refines_only_the_elements_it_crosses(make, value):
    res = make()
    curve = res.level_set(value)
    assert "_refinement" not in res.domain.__dict__  # the whole refinement was never built
    whole = marching_simplices(*res.domain.level_set_complex(res.phi), value)
    assert curve.simplices.shape == whole.simplices.shape and curve.is_closed() and whole.is_closed()
    assert curve.measure() == pytest.approx(whole.measure(), rel=1e-12)
    np.testing.assert_allclose(
        np.unique(np.round(curve.points, 9), axis=0), np.unique(np.round(whole.points, 9), axis=0), atol=1e-9
    )
    assert (curve.euler_characteristic(), curve.n_components()) == (whole.euler_characteristic(), whole.n_components())


def ball_mask():
    i, j, k = np.indices((14, 15, 16))
    return (i - 6.7) ** 2 + (j - 7.2) ** 2 + (k - 7.9) ** 2 < 25


def disc_labels(cells):
    return np.linalg.norm(cells.element_centroids() - 0.05, axis=1) < 0.5
