"""PolyhedralMesh: operator identities, hand-computed cube, orientation, padding, errors, Fig. 6 ball."""

import numpy as np
import pytest
from _checks import assert_stiffness_kernel_is_constants

from ndboundary import datasets as ds
from ndboundary import relax
from ndboundary.datasets import hex_grid
from ndboundary.metrics import fidelity
from ndboundary import PolyhedralMesh
from ndboundary.domains.polyhedral_cells import HEX_FACES

CUBE = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float
)


def octahedron_and_prism():
    """A general polyhedral mesh: an octahedron-like cell and a pentagonal prism sharing nothing."""
    ang = 2 * np.pi * np.arange(5) / 5
    ring = np.c_[np.cos(ang), np.sin(ang)]
    pts = np.concatenate([np.c_[ring, np.zeros(5)], np.c_[ring, np.ones(5)]])
    faces = [[0, 1, 2, 3, 4], [9, 8, 7, 6, 5]] + [[i, (i + 1) % 5, (i + 1) % 5 + 5, i + 5] for i in range(5)]
    return pts, faces, [list(range(7))]


def meshes():
    pts, faces, cells = octahedron_and_prism()
    rng = np.random.default_rng(0)
    tets_pts = rng.uniform(size=(30, 3))
    from scipy.spatial import Delaunay

    return {
        "hex": hex_grid(3, jitter=0.25, random_state=0),
        "prism": PolyhedralMesh(pts, faces, cells),
        "tets": PolyhedralMesh.from_tetrahedra(tets_pts, Delaunay(tets_pts).simplices),
        "combinatorial": hex_grid(2, jitter=0.2, random_state=1, laplacian="combinatorial"),
    }


@pytest.fixture(params=list(meshes()), scope="module")
def mesh(request):
    return meshes()[request.param]


def test_stiffness_symmetric_psd_constant_kernel(mesh):
    # constants only: the meshes are connected and the stabilisation removes hourglass modes
    assert_stiffness_kernel_is_constants(mesh.K)


def test_mass_measure_and_gradient_exact(mesh):
    assert mesh.mass.min() > 0
    assert np.isclose(mesh.mass.sum(), mesh.A.sum())
    a = np.array([0.3, -1.2, 2.0])
    g = mesh.gradient(mesh.points @ a - 4.0)
    np.testing.assert_allclose(g, np.broadcast_to(a, g.shape), atol=1e-10)
    assert mesh.G.shape == (3 * mesh.n_elements, mesh.n_vertices)


def test_total_volume_of_jittered_grid():
    # jitter moves interior vertices only: the cells fill the cube [-1, 1]^3 exactly
    assert np.isclose(hex_grid(4, jitter=0.3, random_state=2).A.sum(), 8.0)


def test_unit_cube_by_hand():
    cube = PolyhedralMesh.from_hexahedra(CUBE, [list(range(8))], stabilization=0.0)
    assert np.allclose(cube.A, [1.0]) and cube.n_faces == 6
    np.testing.assert_allclose(cube.mass, 1 / 8)
    # Green-Gauss on the unit cube: vertex i gets (2 x_i - 1) / 4 per axis
    expected = ((2 * CUBE - 1) / 4).T
    np.testing.assert_allclose(cube.G.toarray(), expected, atol=1e-15)
    # the consistent part alone has four hourglass modes besides the constants
    w = np.linalg.eigvalsh(cube.K.toarray())
    assert np.sum(np.abs(w) < 1e-12) == 5
    w = np.linalg.eigvalsh(PolyhedralMesh.from_hexahedra(CUBE, [list(range(8))]).K.toarray())
    assert np.sum(np.abs(w) < 1e-12) == 1


def test_faces_are_oriented_outward_whatever_the_input_winding():
    faces = [list(f) for f in HEX_FACES]
    faces[2] = faces[2][::-1]
    faces[5] = faces[5][::-1]
    cube = PolyhedralMesh(CUBE, faces, [list(range(6))])
    assert cube.cell_face_signs.tolist() == [1, 1, -1, 1, 1, -1]
    assert np.isclose(cube.A[0], 1.0)


def test_nonconvex_cell_orientation_by_propagation():
    # an L-shaped prism: its vertex mean sees one face from the wrong side
    base = np.array([[0, 0], [2, 0], [2, 0.2], [0.2, 0.2], [0.2, 2], [0, 2]], dtype=float)
    pts = np.concatenate([np.c_[base, np.zeros(6)], np.c_[base, np.ones(6)]])
    faces = [list(range(6)), list(range(6, 12))] + [[i, (i + 1) % 6, (i + 1) % 6 + 6, i + 6] for i in range(6)]
    mesh = PolyhedralMesh(pts, faces, [list(range(8))])
    assert np.isclose(mesh.A[0], 2 * 0.2 * 2 - 0.04)
    np.testing.assert_allclose(mesh.gradient(pts[:, 0]), [[1.0, 0.0, 0.0]], atol=1e-12)


def test_adjacency_edges_and_interface():
    h = hex_grid(2)
    adj = h.adjacency.toarray()
    assert (adj == adj.T).all() and adj.sum() == 8 * 3
    assert h.edges.shape == (54, 2)
    region1 = np.zeros(8, dtype=bool)
    region1[:4] = True
    tris = h.interface_facets(region1)
    assert tris.shape == (8, 3)  # four quads, two triangles each


def test_padding_splits_into_pyramids():
    h = hex_grid(2, jitter=0.2, random_state=0)
    mask = np.zeros(8, dtype=bool)
    mask[[1, 6]] = True
    split, parent = h.split_elements(mask)
    assert isinstance(split, PolyhedralMesh)
    assert split.n_elements == 6 + 12 and split.n_vertices == h.n_vertices + 2
    np.testing.assert_allclose(np.bincount(parent, weights=split.A), h.A)
    np.testing.assert_array_equal(split.points[: h.n_vertices], h.points)
    a = np.array([1.0, 2.0, -1.0])
    np.testing.assert_allclose(split.gradient(split.points @ a), np.broadcast_to(a, (18, 3)), atol=1e-10)


def test_refinement_interpolates_linear_functions():
    h = hex_grid(2, jitter=0.2, random_state=0)
    cx, R = h.to_simplicial()
    assert np.isclose(cx.A.sum(), h.A.sum())
    f = h.points @ [1.0, -2.0, 0.5]
    np.testing.assert_allclose(R @ f, cx.points @ [1.0, -2.0, 0.5], atol=1e-12)
    t = PolyhedralMesh.from_tetrahedra(CUBE[[0, 1, 3, 4]], [[0, 1, 2, 3]])
    assert t.to_simplicial()[0].simplices.tolist() == [[0, 1, 2, 3]]


def cube_mesh_with(faces=None, cells=None, points=CUBE):
    return PolyhedralMesh(points, faces if faces is not None else HEX_FACES, cells or [list(range(6))])


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: cube_mesh_with(cells=[[0, 1, 2, 3, 4]]), "cell 0 is not closed"),
        (lambda: cube_mesh_with(cells=[[0, 1, 2]]), "cells row 0 .* at least 4"),
        (lambda: cube_mesh_with(cells=[[0, 1, 2, 3, 4, 9]]), "outside 0..5"),
        (lambda: cube_mesh_with(cells=[[0, 1, 2, 3, 4, 4]]), "repeats a face"),
        (lambda: cube_mesh_with(faces=[[0, 1]] + [list(f) for f in HEX_FACES[1:]]), "faces row 0 .* 2 vertex"),
        (lambda: cube_mesh_with(points=CUBE * [1, 1, 0]), "face 2 .* zero area"),
        (lambda: cube_mesh_with(points=np.c_[CUBE[:, :2], CUBE[:, 0]]), "face .* zero area"),
        (lambda: PolyhedralMesh(CUBE[:, :2], [[0, 1, 2]], [[0]]), "3-D points"),
        (lambda: PolyhedralMesh.from_hexahedra(CUBE, [[0, 1, 2, 3]]), "expected 8 vertices"),
        (lambda: PolyhedralMesh.from_tetrahedra(CUBE, [[0, 1, 2, 3]]), "cell 0 .* zero volume"),
        (lambda: cube_mesh_with().__class__(CUBE, HEX_FACES, [list(range(6))], laplacian="x"), "laplacian"),
    ],
)
def test_bad_input(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_fig6_ball_in_jittered_hex_grid():
    domain = hex_grid(24, jitter=0.25, random_state=0)
    lab = ds.label_by(domain, ds.ball)
    res = relax(domain, lab, on="elements")
    ls = res.level_set()
    fid = fidelity(ls, ds.ball, 2 / 24)  # in units of the cell size
    excess = ls.measure() / (4 * np.pi * 0.36) - 1
    assert ls.n_components() == 1 and ls.is_closed()
    assert fid["mean"] <= 0.15
    assert abs(excess) <= 0.02


def _fresh(mesh):
    """The same faces and cells built from scratch."""
    return PolyhedralMesh(mesh.points, mesh.faces, mesh.cells)


def _assert_same_operators(derived, fresh):
    np.testing.assert_array_equal(derived.cell_face_signs, fresh.cell_face_signs)
    for name in ("A", "mass"):
        np.testing.assert_allclose(getattr(derived, name), getattr(fresh, name), rtol=1e-13)
    for name in ("G", "K", "adjacency", "incidence"):
        a, b = getattr(derived, name), getattr(fresh, name)
        assert abs(a - b).max() <= 1e-13 * abs(b).max(), name
    np.testing.assert_array_equal(derived.edges, fresh.edges)
    pa, ta, _ = derived.simplicial_refinement()
    pb, tb, _ = fresh.simplicial_refinement()
    np.testing.assert_array_equal(ta, tb)
    np.testing.assert_allclose(pa, pb, atol=1e-14)


@pytest.mark.parametrize("voxels", [False, True])
def test_cut_and_split_meshes_reuse_the_geometry_of_a_fresh_build(voxels):
    """A submesh (the band) and a split (the padding), and each of the other, keep their
    parent's geometry for what they keep: their operators are a fresh build's."""
    from ndboundary import ImageGrid

    mesh = ImageGrid((6, 5, 7), spacing=(1.0, 0.5, 2.0)) if voxels else hex_grid(6, jitter=0.25, random_state=0)
    rng = np.random.default_rng(2)
    sub, vertices = mesh.subdomain(rng.random(mesh.n_elements) < 0.5)
    np.testing.assert_array_equal(sub.points, mesh.points[vertices])
    _assert_same_operators(sub, _fresh(sub))
    split, parent = mesh.split_elements(rng.random(mesh.n_elements) < 0.15)
    _assert_same_operators(split, _fresh(split))
    np.testing.assert_allclose(np.bincount(parent, weights=split.A), mesh.A, rtol=1e-12)
    _assert_same_operators(*(lambda s: (s, _fresh(s)))(split.subdomain(rng.random(split.n_elements) < 0.5)[0]))
    _assert_same_operators(*(lambda s: (s, _fresh(s)))(sub.split_elements(rng.random(sub.n_elements) < 0.2)[0]))
