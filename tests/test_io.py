"""ndboundary.io: round trips of every writer and reader, error paths, and the shared meshes."""

from pathlib import Path

import numpy as np
import pytest

from _checks import obj_groups, read_vtp, stl_solids
from ndboundary import (
    PolygonMesh,
    PolyhedralMesh,
    SimplicialComplex,
    marching_simplices,
    read_labels,
    read_mesh,
    relax,
    write_interfaces,
    write_labels,
    write_level_set,
    write_mesh,
    write_partition,
    write_phi,
)
from ndboundary import datasets as ds
from ndboundary.datasets import hex_grid, quad_grid, voronoi_polygons
from ndboundary.metrics import fidelity

pytest.importorskip("meshio")

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
MESHES = DATA / "meshes"


def same_cells(a, b):
    """Compare two domains' element sets (order-free), by sorted vertex tuples."""
    def key(d):
        if isinstance(d, SimplicialComplex):
            rows = d.simplices
        elif isinstance(d, PolygonMesh):
            rows = d.polygons
        else:
            cell, vert = d.cell_vertices
            rows = np.split(vert, np.flatnonzero(np.diff(cell)) + 1)
        return sorted(tuple(sorted(int(i) for i in r)) for r in rows)

    return key(a) == key(b)


TRI2 = ds.kuhn_grid(3, 2, jitter=0.2, random_state=0)
TRI3 = SimplicialComplex(np.c_[TRI2.points, TRI2.points[:, 0] ** 2], TRI2.simplices)
QUAD = quad_grid(3, jitter=0.2, random_state=0)
POLY = voronoi_polygons(3, random_state=0)
HEX = hex_grid(2, jitter=0.2, random_state=0)
TET = ds.kuhn_grid(2, 3, jitter=0.1, random_state=0)
VOROCELLS = HEX.split_elements(np.r_[True, np.zeros(7, dtype=bool)])[0]  # pyramids: general polyhedra

CASES = [
    (TRI2, ".obj"), (TRI2, ".off"), (TRI2, ".ply"), (TRI2, ".vtk"), (TRI2, ".vtu"), (TRI2, ".msh"), (TRI2, ".mesh"),
    (TRI3, ".stl"), (TRI3, ".obj"),
    (QUAD, ".obj"), (QUAD, ".off"), (QUAD, ".ply"), (QUAD, ".vtu"), (QUAD, ".vtk"), (QUAD, ".mesh"), (QUAD, ".msh"),
    (POLY, ".obj"), (POLY, ".off"), (POLY, ".ply"), (POLY, ".vtu"), (POLY, ".vtk"),
    (HEX, ".mesh"), (HEX, ".vtu"), (HEX, ".vtk"), (HEX, ".msh"), (HEX, ".hedra"),
    (TET, ".mesh"), (TET, ".vtu"), (TET, ".msh"), (TET, ".hedra"),
    (VOROCELLS, ".hedra"), (VOROCELLS, ".vtu"),
]


@pytest.mark.parametrize(("domain", "ext"), CASES, ids=[f"{type(d).__name__}{d.dim}-{e}" for d, e in CASES])
def test_mesh_round_trip(tmp_path, domain, ext):
    path = tmp_path / f"m{ext}"
    write_mesh(path, domain)
    back = read_mesh(path)
    expected = type(domain)
    if ext == ".hedra":
        expected = PolyhedralMesh
    assert type(back) is expected
    assert back.n_vertices == domain.n_vertices and back.n_elements == domain.n_elements
    if ext != ".stl":  # STL stores triangle corners, not shared vertices: meshio renumbers them
        np.testing.assert_allclose(back.points, domain.points, atol=1e-12)
        assert same_cells(back, domain)
    np.testing.assert_allclose(back.A.sum(), domain.A.sum(), rtol=1e-6)


def test_mesh_data_round_trip(tmp_path):
    p = tmp_path / "d.vtu"
    write_mesh(p, QUAD, point_data={"f": QUAD.points[:, 0]}, cell_data={"c": np.arange(QUAD.n_elements)})
    import meshio

    m = meshio.read(p)
    np.testing.assert_allclose(m.point_data["f"], QUAD.points[:, 0])
    np.testing.assert_array_equal(m.cell_data["c"][0], np.arange(QUAD.n_elements))


def test_hedra_signs_and_unused_vertices(tmp_path):
    text = (
        "9 6 1\n" + "\n".join(" ".join(map(str, p)) for p in np.r_[HEX_POINTS, [[5.0, 5.0, 5.0]]]) + "\n"
        "4 1 4 3 2\n4 5 6 7 8\n4 1 2 6 5\n4 2 3 7 6\n4 3 4 8 7\n4 4 1 5 8\n6 1 2 3 4 5 -6\n"
    )
    p = tmp_path / "c.hedra"
    p.write_text(text)
    mesh = read_mesh(p)
    assert mesh.n_vertices == 8 and np.isclose(mesh.A[0], 1.0)
    assert read_mesh(p, drop_unused=False).n_vertices == 9


HEX_POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1.0]])


def test_obj_polygons_lines_and_relative_indices(tmp_path):
    p = tmp_path / "a.obj"
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0.5 0\nvt 0 0\nf 1/1 2/1 3/1 4/1\nf -4 -1 -3\n")
    m = read_mesh(p)
    assert isinstance(m, PolygonMesh) and m.dim == 2 and m.sizes.tolist() == [4, 3]
    p.write_text("v 0 0 0\nv 1 0 0\nv 1 1 1\nl 1 2 3\n")
    c = read_mesh(p)
    assert isinstance(c, SimplicialComplex) and c.simplices.tolist() == [[0, 1], [1, 2]]


def test_mixed_cells_keep_the_highest_dimension(tmp_path):
    import meshio

    p = tmp_path / "mixed.mesh"
    meshio.write(p, meshio.Mesh(TET.points, [("triangle", TET.simplices[:, :3]), ("tetra", TET.simplices)]))
    m = read_mesh(p)
    assert isinstance(m, SimplicialComplex) and m.simplex_dim == 3 and m.n_elements == TET.n_elements


def test_phi_level_set_and_labels_writers(tmp_path):
    lab = ds.label_by(QUAD, ds.circle)
    lab[0] = 1 - lab[0] if lab.sum() in (0, lab.size) else lab[0]
    res = relax(QUAD, lab, on="elements")
    write_phi(tmp_path / "phi.vtu", res, labels=lab)
    import meshio

    m = meshio.read(tmp_path / "phi.vtu")
    np.testing.assert_allclose(m.point_data["phi"], res.phi)
    np.testing.assert_allclose(m.point_data["u"], res.u)
    np.testing.assert_array_equal(m.cell_data["labels"][0], lab)

    curve = res.level_set()
    for ext in (".obj", ".ply", ".vtk", ".vtu"):
        write_level_set(tmp_path / f"ls{ext}", curve)
    back = read_mesh(tmp_path / "ls.obj")
    assert back.simplex_dim == 1 and back.n_elements == curve.n_simplices
    np.testing.assert_allclose(back.points, curve.points)
    assert meshio.read(tmp_path / "ls.vtk").cells[0].data.shape == (curve.n_simplices, 2)
    assert "element edge" in (tmp_path / "ls.ply").read_text()


def test_surface_level_set_and_unlabelled_phi_writers(tmp_path):
    import meshio

    ball = (HEX.element_centroids()[:, 0] > 0).astype(int)
    res3 = relax(HEX, ball, on="elements")
    surf = res3.level_set()
    for ext in (".obj", ".ply"):
        write_level_set(tmp_path / f"s{ext}", surf)
        s = read_mesh(tmp_path / f"s{ext}")
        assert s.simplex_dim == 2 and s.n_elements == surf.n_simplices
        assert np.isclose(s.A.sum(), surf.measure())
    write_phi(tmp_path / "phi3.vtu", res3)
    m = meshio.read(tmp_path / "phi3.vtu")
    np.testing.assert_allclose(m.points, HEX.points)
    np.testing.assert_allclose(m.point_data["phi"], res3.phi)
    np.testing.assert_allclose(m.point_data["u"], res3.u)
    assert "labels" not in m.point_data and "labels" not in m.cell_data  # none given
    np.testing.assert_allclose(m.cell_data["field"][0], res3.field)
    np.testing.assert_allclose(m.cell_data["smoothed_field"][0], res3.smoothed_field)


@pytest.mark.parametrize("ext", [".txt", ".seg", ".npy"])
@pytest.mark.parametrize("header", [False, True])
def test_labels_round_trip(tmp_path, ext, header):
    lab = np.array([0, 1, 1, 0, 2])
    write_labels(tmp_path / f"l{ext}", lab, header=header)
    np.testing.assert_array_equal(read_labels(tmp_path / f"l{ext}"), lab)
    if header and ext != ".npy":
        assert (tmp_path / f"l{ext}").read_text().startswith("SCALAR_FIELD 5\n")


def test_labels_floats_and_strings(tmp_path):
    p = tmp_path / "f.txt"
    p.write_text("0.5\n1.5\n")
    assert read_labels(p).tolist() == [0.5, 1.5]
    p.write_text("g\nb\n")
    assert read_labels(p).tolist() == ["g", "b"]


#: Bad input files, written by the ``bad_files`` fixture for every error case.
BAD_FILES = {
    "x.xyz": "1 2 3\n",
    "bad.off": "NOT OFF\n",
    "short.off": "OFF\n4 1 0\n0 0 0\n1 0 0\n",
    "counts.off": "OFF\n",
    "bad.obj": "v 0 0 zero\n",
    "empty.obj": "v 0 0 0\n",
    "degenerate.obj": "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
    "bad.hedra": "8 6 1\n0 0 0\n",
    "bad.vtu": "<not xml",
    "h.txt": "SCALAR_FIELD 3\n0\n1\n",
    "e.txt": "\n",
}


@pytest.fixture
def bad_files(tmp_path):
    for name, text in BAD_FILES.items():
        (tmp_path / name).write_text(text)
    np.save(tmp_path / "two.npy", np.zeros((2, 2)))
    return tmp_path


def level_set_of_x():
    return marching_simplices(TRI2.points, TRI2.simplices, TRI2.points[:, 0], 0.0)


ERRORS = [
    pytest.param(lambda d: read_mesh(d / "nope.obj"), FileNotFoundError, "nope.obj", id="read_mesh-missing"),
    pytest.param(lambda d: read_labels(d / "nope.txt"), FileNotFoundError, "nope.txt", id="read_labels-missing"),
    pytest.param(lambda d: read_mesh(d / "x.xyz"), ValueError, r"x\.xyz.*unknown mesh format '\.xyz'",
                 id="read_mesh-unknown-extension"),
    pytest.param(lambda d: write_mesh(d / "x.xyz", QUAD), ValueError, "unknown mesh format",
                 id="write_mesh-unknown-extension"),
    pytest.param(lambda d: read_mesh(d / "bad.off"), ValueError, r"bad\.off.*not an OFF file", id="off-no-header"),
    pytest.param(lambda d: read_mesh(d / "short.off"), ValueError, r"short\.off.*shorter", id="off-short"),
    pytest.param(lambda d: read_mesh(d / "counts.off"), ValueError, r"counts\.off: malformed OFF", id="off-no-counts"),
    pytest.param(lambda d: read_mesh(d / "bad.obj"), ValueError, r"bad\.obj: line 1 is not valid OBJ",
                 id="obj-bad-number"),
    pytest.param(lambda d: read_mesh(d / "empty.obj"), ValueError, "no cells", id="obj-no-cells"),
    pytest.param(lambda d: read_mesh(d / "degenerate.obj"), ValueError, r"degenerate\.obj: simplex 0 .* zero area",
                 id="obj-degenerate-triangle"),
    pytest.param(lambda d: read_mesh(d / "bad.hedra"), ValueError, r"bad\.hedra.*malformed HEDRA", id="hedra-short"),
    pytest.param(lambda d: read_mesh(d / "bad.vtu"), ValueError, r"bad\.vtu: could not read", id="vtu-not-xml"),
    pytest.param(lambda d: write_mesh(d / "p.mesh", POLY), ValueError, "cannot hold polygon",
                 id="write-polygons-to-medit"),
    pytest.param(lambda d: write_mesh(d / "h.obj", HEX), ValueError, "surfaces only", id="write-solid-to-obj"),
    pytest.param(lambda d: write_mesh(d / "q.hedra", QUAD), ValueError, "HEDRA holds polyhedra",
                 id="write-quads-to-hedra"),
    pytest.param(lambda d: write_mesh(d / "q.obj", QUAD, point_data={"f": np.zeros(QUAD.n_vertices)}), ValueError,
                 "carries no data", id="write-data-to-obj"),
    pytest.param(lambda d: write_mesh(d / "q.vtu", QUAD, point_data={"f": np.zeros(3)}), ValueError,
                 "'f' has shape", id="write-data-wrong-length"),
    pytest.param(lambda d: write_mesh(d / "q.vtu", "mesh"), TypeError, "cannot write a str", id="write-not-a-domain"),
    pytest.param(lambda d: read_labels(d / "h.txt"), ValueError, "announces 3 labels but the file holds 2",
                 id="labels-header-count"),
    pytest.param(lambda d: read_labels(d / "e.txt"), ValueError, "no labels", id="labels-empty"),
    pytest.param(lambda d: read_labels(d / "two.npy"), ValueError, "one-dimensional", id="labels-npy-2d"),
    pytest.param(lambda d: write_labels(d / "w.txt", np.zeros((2, 2))), ValueError, "one-dimensional",
                 id="write-labels-2d"),
    pytest.param(lambda d: write_level_set(d / "l.stl", level_set_of_x()), ValueError,
                 r"l\.stl: STL holds triangles, not a curve", id="curve-to-stl"),
    pytest.param(lambda d: write_level_set(d / "l.off", level_set_of_x()), ValueError, "unknown level set format",
                 id="level-set-to-off"),
]


@pytest.mark.parametrize(("case", "error", "message"), ERRORS)
def test_errors(bad_files, case, error, message):
    with pytest.raises(error, match=message):
        case(bad_files)


# -- the shared meshes --------------------------------------------------------------------------

SHARED = sorted(p.name for p in MESHES.iterdir()) if MESHES.is_dir() else []


@pytest.mark.skipif(not MESHES.is_dir(), reason="shared data folder ../shared/data absent")
@pytest.mark.parametrize("name", SHARED)
def test_shared_mesh_reads_and_relaxes(name):
    domain = read_mesh(MESHES / name)
    centre = domain.points.mean(axis=0)
    normal = np.ones(domain.dim)
    normal[0] = 1.3
    normal /= np.linalg.norm(normal)

    def plane(x):
        return (x - centre) @ normal

    labels = (plane(domain.element_centroids()) > 0).astype(int)
    res = relax(domain, labels, on="elements")
    curve = res.level_set()
    assert curve.n_simplices > 0
    assert fidelity(curve, plane, domain.mean_edge_length())["mean"] < 0.25


@pytest.mark.skipif(not MESHES.is_dir(), reason="shared data folder ../shared/data absent")
@pytest.mark.parametrize("name", SHARED)
def test_shared_mesh_kinds(name):
    domain = read_mesh(MESHES / name)
    kind = {".obj": SimplicialComplex, ".off": PolygonMesh, ".hedra": PolyhedralMesh}.get(Path(name).suffix)
    if name == "sphere.mesh":
        kind = SimplicialComplex
    elif name.endswith(".mesh"):
        kind = PolyhedralMesh
    assert isinstance(domain, kind)
    assert domain.mass.min() > 0


# -- results of three or more regions: phi per region, the partition, the interfaces ---------------------------


def _sectors(domain, names=None):
    """Labels of three sectors around the origin, by element centroid (names: the labels of the sectors)."""
    c = domain.element_centroids()
    sector = np.floor((np.arctan2(c[:, 1], c[:, 0]) + np.pi) / (2 * np.pi / 3)).astype(int) % 3
    return sector if names is None else np.asarray(names)[sector]


def _simplex_measures(points, simplices):
    """Length, area or volume of every simplex (points of any dimension)."""
    edges = points[simplices[:, 1:]] - points[simplices[:, :1]]
    gram = np.einsum("nij,nkj->nik", edges, edges)
    k = simplices.shape[1] - 1
    return np.sqrt(np.maximum(np.linalg.det(gram), 0)) / np.prod(np.arange(1, k + 1))


REGIONS2 = ds.kuhn_grid(30, 2, jitter=0.2, random_state=0)


def test_regions_phi_writer_one_array_per_region(tmp_path):
    import meshio

    labels = _sectors(REGIONS2, ["air", "soft tissue", "bone"])
    res = relax(REGIONS2, labels, on="elements")
    assert res.classes.tolist() == ["air", "bone", "soft tissue"]
    write_phi(tmp_path / "phi.vtu", res, labels=labels)
    back = meshio.read(tmp_path / "phi.vtu")
    assert sorted(back.point_data) == ["phi_air", "phi_bone", "phi_soft_tissue"]
    for r, name in enumerate(["air", "bone", "soft_tissue"]):
        np.testing.assert_array_equal(back.point_data[f"phi_{name}"], res.phi[:, r])
    np.testing.assert_array_equal(back.cell_data["labels"][0], np.searchsorted(res.classes, labels))
    with pytest.raises(ValueError, match=r"labels\[0\] = 'water' is not one of the result's classes"):
        write_phi(tmp_path / "bad.vtu", res, labels=np.r_[["water"], labels[1:]])


def test_partition_writer_cells_per_region_sum_to_the_domain(tmp_path):
    import meshio

    labels = _sectors(REGIONS2) * 10 - 5  # numeric classes -5, 5, 15
    res = relax(REGIONS2, labels, on="elements")
    write_partition(tmp_path / "p.vtu", res)
    back = meshio.read(tmp_path / "p.vtu")
    cells = res.partition().cells
    (block,) = back.cells
    assert block.type == "triangle" and block.data.shape == cells.simplices.shape
    region = back.cell_data["region"][0]
    np.testing.assert_array_equal(region, cells.regions)
    np.testing.assert_array_equal(back.cell_data["label"][0], res.classes[region])
    measures = np.bincount(region, weights=_simplex_measures(back.points[:, :2], block.data), minlength=3)
    np.testing.assert_allclose(measures, res.region_measures(), rtol=1e-12)
    assert np.isclose(measures.sum(), REGIONS2.A.sum(), rtol=1e-12)  # the square [-1, 1]^2: 4
    write_partition(tmp_path / "p.vtk", res)
    assert meshio.read(tmp_path / "p.vtk").cells[0].data.shape == cells.simplices.shape
    with pytest.raises(ValueError, match="unknown partition"):
        write_partition(tmp_path / "p.obj", res)


def test_interfaces_writer_groups_and_pairs(tmp_path):
    import meshio

    res = relax(REGIONS2, _sectors(REGIONS2, ["air", "soft tissue", "bone"]), on="elements")
    faces = res.interfaces()
    pairs, counts = np.unique(faces.pairs, axis=0, return_counts=True)
    names = ["air", "bone", "soft_tissue"]
    write_interfaces(tmp_path / "i.obj", res)
    assert obj_groups(tmp_path / "i.obj") == [
        (f"{names[a]}|{names[b]}", int(n)) for (a, b), n in zip(pairs, counts, strict=True)
    ]
    back = read_mesh(tmp_path / "i.obj")  # the groups' segments on the shared points
    assert back.n_elements == len(faces) and np.isclose(back.A.sum(), faces.measure(), rtol=1e-12)
    for ext in (".vtu", ".vtk"):
        write_interfaces(tmp_path / f"i{ext}", res)
        m = meshio.read(tmp_path / f"i{ext}")
        np.testing.assert_array_equal(np.c_[m.cell_data["region_a"][0], m.cell_data["region_b"][0]], faces.pairs)
        assert "label_a" not in m.cell_data  # string classes: no label values
    write_interfaces(tmp_path / "i.ply", res)
    text = (tmp_path / "i.ply").read_text().splitlines()
    assert f"element edge {len(faces)}" in text[: text.index("end_header")] and "property int region_b" in text
    rows = np.array([line.split() for line in text[-len(faces):]], dtype=int)
    np.testing.assert_array_equal(rows[:, 2:], faces.pairs)
    with pytest.raises(ValueError, match="STL holds triangles, not curves"):
        write_interfaces(tmp_path / "i.stl", res)
    with pytest.raises(ValueError, match="unknown interfaces format"):
        write_interfaces(tmp_path / "i.off", res)
    write_interfaces(tmp_path / "i.vtp", res)  # curves: VTK's lines
    back = read_vtp(tmp_path / "i.vtp")
    assert back["Piece"]["NumberOfLines"] == len(faces) and back["Piece"]["NumberOfPolys"] == 0
    np.testing.assert_array_equal(back["Lines"]["connectivity"].reshape(-1, 2), faces.simplices)
    np.testing.assert_array_equal(np.c_[back["CellData"]["region_a"], back["CellData"]["region_b"]], faces.pairs)
    with pytest.raises(TypeError, match="what ndboundary.relax returns"):
        write_interfaces(tmp_path / "i.obj", faces)


def test_interfaces_writer_on_a_solid_numeric_classes(tmp_path):
    import meshio

    res = relax(TET3, _ball_in_halves(TET3), on="elements")
    faces = res.interfaces()
    write_interfaces(tmp_path / "i.vtu", res)
    m = meshio.read(tmp_path / "i.vtu")
    assert m.cells[0].type == "triangle"
    np.testing.assert_array_equal(m.cell_data["label_a"][0], res.classes[faces.pairs[:, 0]])
    np.testing.assert_array_equal(m.cell_data["label_b"][0], res.classes[faces.pairs[:, 1]])
    write_interfaces(tmp_path / "i.ply", res)
    back = meshio.read(tmp_path / "i.ply")  # face properties, as meshio reads them
    np.testing.assert_array_equal(back.cell_data["region_a"][0], faces.pairs[:, 0])
    np.testing.assert_array_equal(back.cell_data["region_b"][0], faces.pairs[:, 1])
    pairs, counts = np.unique(faces.pairs, axis=0, return_counts=True)
    write_interfaces(tmp_path / "i.obj", res)
    assert obj_groups(tmp_path / "i.obj") == [(f"{a}|{b}", int(n)) for (a, b), n in zip(pairs, counts, strict=True)]


def test_interfaces_as_named_stl_solids_and_vtk_polygonal_data(tmp_path):
    """A solid's interfaces: one ASCII STL solid per pair, named as the OBJ groups, holding
    that pair's triangles, oriented from the smaller region to the larger, at the shared
    points to full precision; VTP holds the triangles with their pairs and labels, and a
    region's boundary as written by ``write_level_set``."""
    res = relax(TET3, _ball_in_halves(TET3) * 10 + 1, on="elements")  # labels 1, 11, 21
    faces = res.interfaces()
    write_interfaces(tmp_path / "i.stl", res)
    pairs, counts = np.unique(faces.pairs, axis=0, return_counts=True)
    solids = stl_solids(tmp_path / "i.stl")
    assert [(name, len(c)) for name, _, c in solids] == [
        (f"{res.classes[a]}|{res.classes[b]}", int(n)) for (a, b), n in zip(pairs, counts, strict=True)
    ]
    for (a, b), (_, normals, corners) in zip(pairs, solids, strict=True):
        mine = faces.simplices[(faces.pairs[:, 0] == a) & (faces.pairs[:, 1] == b)]
        np.testing.assert_array_equal(corners, faces.points[mine])  # %.17g: the doubles themselves
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        np.testing.assert_allclose(normals, cross / np.linalg.norm(cross, axis=1, keepdims=True), atol=1e-8)
    write_interfaces(tmp_path / "i.vtp", res)
    back = read_vtp(tmp_path / "i.vtp")
    assert back["Piece"]["NumberOfPolys"] == len(faces) and back["Piece"]["NumberOfLines"] == 0
    np.testing.assert_array_equal(back["Points"][""], faces.points)
    np.testing.assert_array_equal(back["Polys"]["connectivity"].reshape(-1, 3), faces.simplices)
    np.testing.assert_array_equal(back["Polys"]["offsets"], 3 * np.arange(1, len(faces) + 1))
    np.testing.assert_array_equal(back["CellData"]["label_a"], res.classes[faces.pairs[:, 0]])
    np.testing.assert_array_equal(back["CellData"]["region_b"], faces.pairs[:, 1])
    ball = res.region_boundary(2)
    write_level_set(tmp_path / "ball.vtp", ball)
    back = read_vtp(tmp_path / "ball.vtp")
    np.testing.assert_array_equal(back["Polys"]["connectivity"].reshape(-1, 3), ball.simplices)
    assert _enclosed_volume(back["Points"][""], back["Polys"]["connectivity"].reshape(-1, 3)) == pytest.approx(
        res.region_measures()[2], rel=1e-12
    )
    flat = relax(REGIONS2, ds.label_by(REGIONS2, ds.circle), on="elements").level_set()
    write_level_set(tmp_path / "curve.vtp", flat)
    back = read_vtp(tmp_path / "curve.vtp")
    assert back["Piece"]["NumberOfLines"] == flat.n_simplices
    np.testing.assert_array_equal(back["Points"][""][:, :2], flat.points)
    assert not back["Points"][""][:, 2].any()  # a plane curve: zeros appended


def test_empty_vtk_and_stl_files_are_valid(tmp_path):
    """No cells (an empty level set): the files still follow their formats."""
    from ndboundary.io.stl import write_ascii_stl_solids
    from ndboundary.io.vtu import write_vtp, write_vtu

    write_vtp(tmp_path / "e.vtp", np.zeros((0, 3)), "triangle", np.zeros((0, 3), int))
    back = read_vtp(tmp_path / "e.vtp")
    assert back["Piece"]["NumberOfPoints"] == 0 and back["Polys"]["connectivity"].size == 0
    write_vtu(tmp_path / "e.vtu", np.zeros((0, 3)), [("triangle", np.zeros((0, 3), int))])
    assert "NumberOfCells=\"0\"" in (tmp_path / "e.vtu").read_bytes()[:600].decode(errors="replace")
    write_ascii_stl_solids(tmp_path / "e.stl", np.zeros((0, 3)), np.zeros((0, 3), int), np.zeros(0, int), {})
    assert (tmp_path / "e.stl").read_text() == "solid\nendsolid\n"


def test_stl_solid_names_are_one_word_or_nothing_is_written(tmp_path):
    from ndboundary.io.stl import write_ascii_stl_solids

    with pytest.raises(ValueError, match="must be one word"):
        write_ascii_stl_solids(tmp_path / "s.stl", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]], [0], {0: "a b"})
    assert not (tmp_path / "s.stl").exists()


def test_vtk_reads_the_polygonal_data_and_the_named_solids(tmp_path):
    """VTK's own readers (the ``[bench]`` extra) read the files: the VTP's cells and arrays,
    and one tag per STL solid."""
    vtk = pytest.importorskip("vtk")
    from vtk.util.numpy_support import vtk_to_numpy

    res = relax(TET3, _ball_in_halves(TET3), on="elements")
    faces = res.interfaces()
    write_interfaces(tmp_path / "i.vtp", res)
    write_interfaces(tmp_path / "i.stl", res)
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(tmp_path / "i.vtp"))
    reader.Update()
    out = reader.GetOutput()
    assert out.GetNumberOfPolys() == len(faces) and out.GetNumberOfPoints() == len(faces.points)
    np.testing.assert_array_equal(vtk_to_numpy(out.GetCellData().GetArray("region_a")), faces.pairs[:, 0])
    stl = vtk.vtkSTLReader()
    stl.SetFileName(str(tmp_path / "i.stl"))
    stl.SetScalarTags(True)
    stl.Update()
    tags = vtk_to_numpy(stl.GetOutput().GetCellData().GetArray(0))
    assert stl.GetOutput().GetNumberOfPolys() == len(faces)
    assert np.unique(tags).size == np.unique(faces.pairs, axis=0).shape[0]


def test_two_region_interfaces_are_the_level_set_with_its_pair(tmp_path):
    import meshio

    res = relax(REGIONS2, ds.label_by(REGIONS2, ds.circle), on="elements")
    write_level_set(tmp_path / "ls.obj", res.level_set())
    write_interfaces(tmp_path / "i.obj", res)

    def body(name):
        return [line for line in (tmp_path / name).read_text().splitlines() if not line.startswith(("#", "g "))]

    assert body("i.obj") == body("ls.obj")
    assert obj_groups(tmp_path / "i.obj") == [("0|1", res.level_set().n_simplices)]
    write_interfaces(tmp_path / "i.vtu", res)
    m = meshio.read(tmp_path / "i.vtu")
    assert set(m.cell_data["region_a"][0]) == {0} and set(m.cell_data["region_b"][0]) == {1}
    np.testing.assert_array_equal(m.cells[0].data, res.level_set().simplices)


TET3 = ds.kuhn_grid(10, 3, jitter=0.2, random_state=0)


def _ball_in_halves(domain):
    """A ball (label 2) inside the two halves x < 0 (label 0) and x > 0 (label 1), by element centroid."""
    c = domain.element_centroids()
    return np.where(np.linalg.norm(c, axis=1) < 0.5, 2, np.where(c[:, 0] < 0, 0, 1))


def _enclosed_volume(points, triangles):
    """The volume a closed triangulated surface encloses (divergence theorem; sign by orientation)."""
    p = points[triangles]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)


def _every_edge_twice(triangles):
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    return bool(np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2))


def test_region_boundary_to_stl_is_closed_and_encloses_the_region(tmp_path):
    import meshio

    res = relax(TET3, _ball_in_halves(TET3), on="elements")
    ball = res.region_boundary(2)
    assert ball.is_closed()
    write_level_set(tmp_path / "ball.stl", ball)
    assert (tmp_path / "ball.stl").read_bytes()[:6] != b"solid "  # binary STL
    soup = meshio.read(tmp_path / "ball.stl")
    assert soup.cells[0].data.shape == (ball.n_simplices, 3)
    volume = res.region_measures()[2]
    assert np.isclose(_enclosed_volume(soup.points.astype(np.float64), soup.cells[0].data), volume, rtol=1e-6)
    welded = read_mesh(tmp_path / "ball.stl")  # STL is welded: the float32 corners of a vertex are equal
    assert welded.n_vertices == ball.n_points and _every_edge_twice(welded.simplices)
    with pytest.raises(ValueError, match="STL holds triangles, not a curve"):
        write_level_set(tmp_path / "c.stl", relax(REGIONS2, _sectors(REGIONS2), on="elements").region_boundary(0))


def test_region_names_are_safe_and_distinct():
    from ndboundary.io import region_names

    assert region_names(np.array([-1, 0, 7])) == ["-1", "0", "7"]
    assert region_names(np.array(["air", "soft tissue", "bone/marrow"])) == ["air", "soft_tissue", "bone_marrow"]
    assert region_names(np.array(["a", "***", "c"])) == ["a", "1", "c"]  # nothing left: the index
    assert region_names(np.array(["Bone", "bone"])) == ["0", "1"]  # equal but for case: indices throughout
    assert region_names(np.array(["x" * 100, "y"])) == ["x" * 64, "y"]
