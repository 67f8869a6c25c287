"""Pixel and voxel grids (ImageGrid) and relax_image."""

import numpy as np
import pytest
from scipy.spatial import cKDTree
from _checks import assert_stiffness_kernel_is_constants

from ndboundary import ImageGrid, relax_image
from ndboundary.domains import PixelGrid, VoxelGrid
from ndboundary.metrics import level_set_distance


@pytest.mark.parametrize(
    ("shape", "spacing", "origin"),
    [((4, 3), (0.5, 2.0), (10.0, -1.0)), ((3, 2, 4), (1.0, 0.25, 3.0), (0.0, 5.0, -2.0))],
)
def test_elements_are_pixels_in_c_order_centred_at_origin_plus_index_times_spacing(shape, spacing, origin):
    grid = ImageGrid(shape, spacing=spacing, origin=origin)
    assert isinstance(grid, ImageGrid) and isinstance(grid, PixelGrid if len(shape) == 2 else VoxelGrid)
    assert grid.n_elements == np.prod(shape) and grid.n_vertices == np.prod(np.add(shape, 1))
    index = np.stack(np.unravel_index(np.arange(grid.n_elements), shape), axis=1)
    np.testing.assert_allclose(grid.element_centroids(), np.asarray(origin) + index * np.asarray(spacing), atol=1e-12)
    np.testing.assert_allclose(grid.A, np.prod(spacing), rtol=1e-12)  # every pixel's measure
    assert grid.shape == shape and grid.spacing == spacing and grid.origin == origin


@pytest.mark.parametrize("shape", [(5, 4), (4, 3, 3)])
def test_operators_are_exact_on_linear_functions_and_keep_constants(shape):
    grid = ImageGrid(shape, spacing=np.linspace(0.5, 2.0, len(shape)), origin=1.0)
    a = np.arange(1.0, len(shape) + 1)
    np.testing.assert_allclose(grid.gradient(grid.points @ a), np.tile(a, (grid.n_elements, 1)), atol=1e-10)
    assert_stiffness_kernel_is_constants(grid.K)
    assert grid.mass.sum() == pytest.approx(float(grid.A.sum()), rel=1e-12)


def test_relax_image_disc_with_anisotropic_pixels():
    """A disc of radius 9 (in mm) on pixels 0.5 x 0.25 mm: in units of the smaller spacing
    the relaxed curve lies within 0.15 of the true circle on average and 0.6 at most (the
    imaging issue's anisotropic targets), its length within 1 % and its area 0.5 %."""
    spacing = (0.5, 0.25)
    i, j = np.indices((48, 96))
    x = np.stack([i * spacing[0], j * spacing[1]], axis=-1) - [11.75, 11.875]
    disc = np.linalg.norm(x, axis=-1) < 9.0
    before = disc.copy()
    result = relax_image(disc, spacing=spacing)
    assert np.array_equal(disc, before)  # the input is not modified
    curve = result.level_set()
    d = np.abs(np.linalg.norm(curve.points - [11.75, 11.875], axis=1) - 9.0)
    assert curve.n_components() == 1 and curve.is_closed()
    assert d.mean() < 0.15 * min(spacing) and d.max() < 0.6 * min(spacing)
    assert curve.measure() == pytest.approx(2 * np.pi * 9.0, rel=0.01)
    assert result.region_measures()[1] == pytest.approx(np.pi * 81.0, rel=0.005)


def test_relax_image_ball_is_closed_and_keeps_its_volume():
    i, j, k = np.indices((24, 24, 24))
    ball = (i - 11.5) ** 2 + (j - 11.5) ** 2 + (k - 11.5) ** 2 < 8.0**2
    result = relax_image(ball, spacing=2.0, origin=(-23.0, -23.0, -23.0))
    surface = result.level_set()
    assert surface.is_closed() and surface.n_components() == 1
    r = np.linalg.norm(surface.points, axis=1)  # the ball's centre is the origin in mm
    assert np.abs(r - 16.0).mean() < 0.1 * 2.0
    # the volume of the voxels, kept (a ball of 8 voxels' radius is itself 1.5 % off the sphere)
    assert result.region_measures()[1] == pytest.approx(8.0 * ball.sum(), rel=0.01)


def test_relax_image_many_labels_and_background():
    i, j = np.indices((40, 40))
    labels = np.where(i < 14, 0, np.where(j < 20, 1, 2))  # a T of three regions
    labels[(i - 28) ** 2 + (j - 28) ** 2 < 25] = 3  # a small disc inside region 2
    result = relax_image(labels, background=0)
    assert result.params["background"] == 0
    assert result.region_measures().sum() == pytest.approx(1600.0, rel=1e-9)
    assert result.region_boundary(3).is_closed()
    assert len(result.interfaces().junctions()) == 1


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: relax_image(np.zeros(10, dtype=int)), "2-D image or a 3-D volume"),
        (lambda: relax_image(np.zeros((2, 2, 2, 2), dtype=int)), "2-D image or a 3-D volume"),
        (lambda: ImageGrid((3, 3), spacing=(1.0, 0.0)), "spacing must be positive"),
        (lambda: ImageGrid((3, 3), spacing=(1.0, 1.0, 1.0)), "one number or one per axis"),
        (lambda: ImageGrid((3, 0)), "positive sizes"),
        (lambda: ImageGrid((3, 3), origin=np.nan), "finite"),
        (lambda: relax_image(np.eye(6, dtype=int), background=5), "background 5 is not one of the labels"),
    ],
)
def test_bad_input(make, match):
    with pytest.raises(ValueError, match=match):
        make()


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: ImageGrid((4.5, 4)), "shape must be a sequence of integers"),
        (lambda: ImageGrid((True, 4)), "shape must be a sequence of integers"),
        (lambda: ImageGrid(4), "shape must be a sequence of integers"),
        (lambda: ImageGrid((4, 4), spacing="a"), "spacing must be one number or one per axis"),
        (lambda: ImageGrid((4, 4), origin=[1, "b"]), "origin must be one number or one per axis"),
    ],
)
def test_grid_geometry_of_the_wrong_type(make, match):
    """A fractional size would be truncated, a string would fail inside numpy: both are
    refused, naming the argument."""
    with pytest.raises(TypeError, match=match):
        make()


def test_grid_sizes_may_be_numpy_integers():
    grid = ImageGrid(np.array([3, 4]), spacing=np.float32(0.5))
    assert grid.shape == (3, 4) and grid.spacing == (0.5, 0.5)


def test_oblique_grid_relaxes_like_the_straight_one_rotated():
    """A scan tilted by a rotation: pixels centred at origin + direction @ (index * spacing),
    and the relaxation is the straight grid's, rotated (measures equal, curve moved)."""
    t = np.radians(17.0)
    rotation = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    grid = ImageGrid((5, 4), spacing=(0.5, 1.0), origin=(3.0, -1.0), direction=rotation)
    index = np.stack(np.unravel_index(np.arange(20), (5, 4)), axis=1)
    np.testing.assert_allclose(grid.element_centroids(), (3.0, -1.0) + (index * (0.5, 1.0)) @ rotation.T, atol=1e-12)
    i, j = np.indices((30, 30))
    disc = (i - 14.5) ** 2 + (j - 14.5) ** 2 < 64
    straight = relax_image(disc, spacing=0.5)
    tilted = relax_image(disc, spacing=0.5, origin=(2.0, 1.0), direction=rotation)
    np.testing.assert_allclose(tilted.region_measures(), straight.region_measures(), rtol=1e-8)
    a, b = straight.level_set(), tilted.level_set()
    np.testing.assert_allclose(b.points, (2.0, 1.0) + a.points @ rotation.T, atol=1e-8)
    with pytest.raises(ValueError, match="orthonormal"):
        ImageGrid((3, 3), direction=[[1.0, 0.5], [0.0, 1.0]])


@pytest.mark.parametrize("reflect", [False, True])
def test_voxel_grid_face_signs_are_the_oriented_ones(reflect):
    """The face orientation a voxel grid states equals the one the polyhedral mesh works out."""
    from ndboundary import PolyhedralMesh

    direction = np.diag([1.0, 1.0, -1.0]) if reflect else None
    grid = ImageGrid((3, 2, 4), spacing=(1.0, 0.5, 2.0), origin=1.0, direction=direction)
    general = PolyhedralMesh(grid.points, grid.faces, np.split(grid.cell_faces, grid.cell_offsets[1:-1]))
    np.testing.assert_array_equal(grid.cell_face_signs, general.cell_face_signs)
    np.testing.assert_allclose(grid.A, general.A)


def _rotation(seed):
    q, _ = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    return q


@pytest.mark.parametrize(
    "spacing, origin, direction",
    [(1.0, 0.0, None), ((0.5, 1.0, 3.0), (1.0, -2.0, 0.5), None), ((0.7, 1.1, 0.9), 0.3, "rotation"),
     (1.0, 0.0, "reflection")],
)  # fmt: skip
def test_voxel_grid_operators_equal_the_general_hexahedra(spacing, origin, direction):
    """The grid's faces and geometry come from its structure; every operator equals the one a
    PolyhedralMesh of the same hexahedra computes (enough voxels that the stiffness is
    computed once for their shared shape)."""
    from ndboundary import PolyhedralMesh

    direction = {"rotation": _rotation(0), "reflection": -np.eye(3), None: None}[direction]
    grid = ImageGrid((5, 6, 7), spacing=spacing, origin=origin, direction=direction)
    i, j, k = (a.ravel() for a in np.indices(grid.shape))
    corner = lambda a, b, c: ((i + a) * 7 + (j + b)) * 8 + (k + c)  # noqa: E731
    hexes = np.stack([corner(0, 0, 0), corner(1, 0, 0), corner(1, 1, 0), corner(0, 1, 0),
                      corner(0, 0, 1), corner(1, 0, 1), corner(1, 1, 1), corner(0, 1, 1)], axis=1)  # fmt: skip
    general = PolyhedralMesh.from_hexahedra(grid.points, hexes)
    np.testing.assert_allclose(grid.A, general.A, rtol=1e-12)
    np.testing.assert_allclose(grid.mass, general.mass, rtol=1e-12)
    np.testing.assert_allclose(grid.element_centroids(), general.element_centroids(), atol=1e-12)
    for name in ("G", "K", "adjacency", "incidence"):
        a, b = getattr(grid, name), getattr(general, name)
        assert abs(a - b).max() <= 1e-12 * abs(b).max(), name
    np.testing.assert_array_equal(grid.edges, general.edges)
    labels = np.random.default_rng(1).random(grid.n_elements) < 0.5
    a, b = grid.interface_facets(labels), general.interface_facets(labels)
    assert a.shape == b.shape and np.isclose(
        np.linalg.norm(np.cross(*(grid.points[a[:, 1:]] - grid.points[a[:, :1]]).transpose(1, 0, 2)), axis=1).sum(),
        np.linalg.norm(np.cross(*(grid.points[b[:, 1:]] - grid.points[b[:, :1]]).transpose(1, 0, 2)), axis=1).sum(),
    )


@pytest.mark.parametrize("direction", [None, "reflection"])
def test_a_voxel_refinement_is_the_general_one_to_the_bit(direction):
    """The voxels' refinement, read off their faces, gives the points, tetrahedra and
    interpolation of the general polyhedral one, in the same order, on a grid and on a
    band of it."""
    from ndboundary.domains.polyhedral_cells import tetrahedral_refinement

    direction = {"reflection": -np.eye(3), None: None}[direction]
    grid = ImageGrid((4, 5, 6), spacing=(0.5, 1.0, 3.0), origin=(1.0, -2.0, 0.5), direction=direction)
    band = grid.subdomain(np.random.default_rng(0).random(grid.n_elements) < 0.3)[0]
    for mesh in (grid, band):
        (p, t, R), (p0, t0, R0) = mesh.simplicial_refinement(), tetrahedral_refinement(mesh)
        assert t.shape == (24 * mesh.n_elements, 4)
        np.testing.assert_array_equal(t, t0)
        np.testing.assert_array_equal(p, p0)
        for name in ("indptr", "indices", "data"):
            np.testing.assert_array_equal(getattr(R, name), getattr(R0.tocsr(), name))


def _ball(n, radius):
    x = np.indices((n, n, n)).reshape(3, -1).T - (n - 1) / 2 - 0.2
    return (np.linalg.norm(x, axis=1) < radius * n).reshape(n, n, n)


def test_a_grid_whose_band_would_hold_most_of_it_is_relaxed_whole_without_a_band(monkeypatch):
    # relaxed on the whole ImageGrid: the first band holds under 70 % of this grid and the
    # one its scale widens it to more; the grid's scale hint sends it to the whole domain
    # without padding a band
    from ndboundary import Relaxer, relax

    mask = _ball(36, 0.2)
    grid = ImageGrid(mask.shape)
    whole = relax(grid, mask.ravel(), on="elements", band=None)

    def padded_band(*args, **kwargs):
        raise AssertionError("a band was padded to read its scale")

    monkeypatch.setattr(Relaxer, "_lam_scale", padded_band)
    auto = relax(grid, mask.ravel(), on="elements")
    assert "band" not in auto.params
    np.testing.assert_array_equal(auto.phi, whole.phi)


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.6, 0.6, 1.5)])
def test_grid_scale_hint_is_close_to_the_padded_scale(spacing):
    from ndboundary.pipeline.integration import grid_scale_hint

    result = relax_image(_ball(24, 0.3), spacing=spacing, band=None)
    hint = grid_scale_hint(result.domain, result.params["h"])
    assert abs(hint / result.params["lam_scale"] - 1) < 0.1


def _voronoi(shape, n_sites, spacing, seed=0):
    """Labels of the nearest of ``n_sites`` random sites, by pixel centre."""
    x = np.indices(shape).reshape(len(shape), -1).T * np.asarray(spacing)
    sites = np.random.default_rng(seed).uniform(0, 1, (n_sites, len(shape))) * np.max(x, axis=0)
    return np.argmin(((x[:, None, :] - sites[None]) ** 2).sum(axis=-1), axis=1).reshape(shape)


@pytest.mark.parametrize(
    ("labels", "spacing", "direction"),
    [(_ball(30, 0.2), (1.0, 0.5, 2.0), None), (_ball(24, 0.2), (1.0, 1.0, 1.0), "reflection"),
     (_voronoi((50, 60), 2, (1.5, 1.0)), (1.5, 1.0), None),
     (_voronoi((40, 30), 2, (1.0, 1.0)), (1.0, 1.0), "reflection")],
    ids=["ball", "ball-reflected", "halves-2d", "halves-2d-reflected"],
)  # fmt: skip
def test_an_image_band_is_the_whole_grids_band_cut_without_the_grid(labels, spacing, direction, monkeypatch):
    """relax_image cuts the band on the image's index grid: the same pixels, operators and
    phi as the band the whole grid's relaxation cuts, and the measures of the whole image."""
    from ndboundary import PolygonMesh, PolyhedralMesh, relax
    from ndboundary.domains.image import GridBand
    from ndboundary.pipeline import interface_fit, surface_fit

    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", False)  # relax_image's fits of a curve
    monkeypatch.setattr(surface_fit, "SURFACE_FIT", False)  # and of a surface, which relax leaves out

    if direction == "reflection":  # (a rotation and) a reflection of the last axis
        rotation = _rotation(2) if labels.ndim == 3 else np.eye(2)
        direction = rotation @ np.diag([1.0] * (labels.ndim - 1) + [-1.0])
    # a width that no path length ties (rounding would decide a tie differently on the two)
    result = relax_image(labels, spacing=spacing, direction=direction, band=4.3)
    band = result.domain
    assert isinstance(band, GridBand) and band.pixels.size < labels.size
    grid = ImageGrid(labels.shape, spacing=spacing, direction=direction)
    whole = relax(grid, labels.ravel(), on="elements", band=4.3, pad=False)
    assert result.params["band_vertices"] == whole.params["band_vertices"] == band.n_vertices
    mask = np.zeros(labels.size, dtype=bool)
    mask[band.pixels] = True
    sub, corners = (PolyhedralMesh if labels.ndim == 3 else PolygonMesh).subdomain(grid, mask)  # a general cut
    np.testing.assert_array_equal(band.corners, corners)
    # the same stiffness to rounding (the grid leaves out the couplings that vanish)
    assert abs(band.K - sub.K).max() <= 1e-14 * abs(sub.K).max() and np.array_equal(band.mass, sub.mass)
    np.testing.assert_allclose(result.phi, whole.phi[corners], atol=1e-12)
    np.testing.assert_allclose(result.region_measures(), whole.region_measures(), rtol=1e-12)
    assert result.region_measures().sum() == pytest.approx(grid.A.sum(), rel=1e-12)


def test_many_regions_of_an_image_band_partition_the_whole_image():
    from ndboundary import relax

    labels = _voronoi((26, 28, 30), 5, (1.0, 1.0, 1.0))
    result = relax_image(labels, band=4.0)
    whole = relax(ImageGrid(labels.shape), labels.ravel(), on="elements", band=4.0, pad=False)
    assert result.domain.n_elements < labels.size
    np.testing.assert_allclose(result.region_measures(), whole.region_measures(), rtol=1e-10)
    a, b = result.interfaces(), whole.interfaces()
    np.testing.assert_allclose(np.sort(a.points, axis=0), np.sort(b.points, axis=0), atol=1e-10)
    assert len(a.junctions()) == len(b.junctions()) > 0
    for r in range(5):
        assert result.region_boundary(r).measure() == pytest.approx(whole.region_boundary(r).measure(), rel=1e-10)


def test_results_on_grids_and_grid_bands_survive_pickling():
    """A result is sent to another process by pickle (joblib, dask): its grid, or the band
    of a large image, is rebuilt there, and gives the same boundaries."""
    import pickle

    i, j = np.indices((20, 20))
    disc = relax_image((i - 9.3) ** 2 + (j - 9.6) ** 2 < 30)
    regions = relax_image(_voronoi((26, 28, 30), 4, (1.0, 1.0, 1.0)), band=4.0)
    assert type(regions.domain).__name__ == "VoxelBand"
    for result, boundary in ((disc, "level_set"), (regions, "interfaces")):
        copy = pickle.loads(pickle.dumps(result))
        assert type(copy.domain) is type(result.domain)
        np.testing.assert_array_equal(getattr(copy, boundary)().points, getattr(result, boundary)().points)
        np.testing.assert_allclose(copy.region_measures(), result.region_measures(), rtol=1e-12)
        again = pickle.loads(pickle.dumps(result))  # its partition built, and cut beside the fit
        np.testing.assert_array_equal(getattr(again, boundary)().points, getattr(result, boundary)().points)
    values_only = relax_image(_voronoi((40, 44, 48), 5, (1.0, 1.0, 1.0), seed=3))
    values_only.region_values()
    assert "_cut_beside" in values_only.__dict__
    copy = pickle.loads(pickle.dumps(values_only))
    np.testing.assert_array_equal(copy.interfaces().simplices, values_only.interfaces().simplices)
    grid = ImageGrid((4, 3, 2), spacing=(1.0, 2.0, 0.5))
    assert repr(pickle.loads(pickle.dumps(grid))) == repr(grid)


def test_the_regions_of_a_2d_image_overlap_as_they_relax_in_turn(monkeypatch):
    """In 2-D each region of an image goes on while the last one's factor is built beside:
    the same functions, to the bit, as relaxing them one after another."""
    from ndboundary import _threads
    from ndboundary import images as images_module
    from ndboundary.pipeline import relaxer

    monkeypatch.setattr(_threads, "available_threads", lambda: 2)
    labels = _voronoi((160, 170), 5, (1.0, 1.0))  # enough pixels for each region's own band
    overlapped = relax_image(labels)
    calls = []

    def in_turn(count, start, verbose, overlap=True):
        calls.append(overlap)
        return relaxer.relax_in_turn(count, start, verbose, overlap=False)

    monkeypatch.setattr(images_module, "relax_in_turn", in_turn)
    one_by_one = relax_image(labels)
    assert calls == [True]  # 2-D: overlapped by default
    for a, b in zip(overlapped.regions, one_by_one.regions, strict=True):
        np.testing.assert_array_equal(a.phi, b.phi)


def test_the_regions_of_a_volume_relax_at_once_as_they_would_in_turn(monkeypatch):
    """In 3-D the regions of an image relax two at a time, each on a thread of its own:
    the same functions, to the bit, as one after another."""
    from ndboundary import images as images_module
    from ndboundary.pipeline import relaxer

    monkeypatch.setattr(relaxer, "available_threads", lambda: 2)
    labels = _voronoi((30, 32, 34), 5, (1.0, 1.0, 1.0))
    together = relax_image(labels, band=4.0)
    calls = []

    def in_turn(count, start, verbose, order=None):
        calls.append(sorted(order))  # every region started, in some order
        return relaxer.relax_in_turn(count, start, verbose, overlap=False)

    monkeypatch.setattr(images_module, "relax_at_once", in_turn)
    one_by_one = relax_image(labels, band=4.0)
    assert calls == [list(range(5))]
    for a, b in zip(together.regions, one_by_one.regions, strict=True):
        np.testing.assert_array_equal(a.phi, b.phi)
    np.testing.assert_array_equal(together.interfaces().points, one_by_one.interfaces().points)


def test_relax_at_once_runs_two_together_a_large_band_alone_and_prints_in_order(monkeypatch, capsys):
    """Two relaxations run at once (both wait at one barrier, which would time out were
    they in turn); a band above ALONE_MIN_VERTICES runs with no other beside it; the
    results and each one's progress lines come out in order; an error is raised."""
    import threading

    from ndboundary.pipeline import relaxer

    barrier = threading.Barrier(2, timeout=30)
    inside, alone = [0], []
    lock = threading.Lock()

    def start(i, lines, gate):
        large = i == 2
        with gate.held(relaxer.ALONE_MIN_VERTICES + 1 if large else 10):
            with lock:
                inside[0] += 1
                if large:
                    alone.append(inside[0])
            if i < 2:
                barrier.wait()  # regions 0 and 1 together
            for step in ("heat", "integration"):
                relaxer._say(lines, f"{step}-{i}", 0.0)
            yield from ()
            with lock:
                inside[0] -= 1
        return i * 10

    assert relaxer.relax_at_once(5, start, True, threads=2) == [0, 10, 20, 30, 40]
    assert alone == [1]
    printed = [line.split()[1] for line in capsys.readouterr().err.splitlines()]
    assert printed == [f"{step}-{i}" for i in range(5) for step in ("heat", "integration")]

    def failing(i, lines, gate):
        if i == 3:
            raise ValueError("region 3 failed")
        yield from ()
        return i

    with pytest.raises(ValueError, match="region 3 failed"):
        relaxer.relax_at_once(5, failing, False, threads=2)


@pytest.mark.parametrize(
    ("shape", "spacing", "band"),
    [((30, 34, 28), (1.0, 1.2, 0.9), 4.3), ((60, 70), (1.0, 1.0), 5.3), ((20, 22, 18), (1.0, 1.0, 1.0), 10.3)],
    ids=["voxels-band", "pixels-band", "voxels-whole"],
)
def test_each_region_of_an_image_relaxes_on_its_own_band(shape, spacing, band):
    """Every region is relaxed on the band cut around it from the image alone: the same
    functions on the same bands as relax cuts from the whole grid, which the image's
    regions never build (no edges, no adjacency of the whole grid or of the union band)."""
    from ndboundary import relax

    labels = _voronoi(shape, 7, spacing, seed=1) * 3 + 1  # labels that are not their indices
    result = relax_image(labels, spacing=spacing, band=band)
    grid = ImageGrid(shape, spacing=spacing)
    whole = relax(grid, labels.ravel(), on="elements", band=band, pad=False)
    corners = getattr(result.domain, "corners", np.arange(grid.n_vertices))
    assert (band == 10.3) == (corners.size == grid.n_vertices)  # the union band is the whole grid
    np.testing.assert_array_equal(result.classes, whole.classes)
    a, b = result.region_values(), whole.region_values()[corners]
    # the same, but for the junctions and interfaces fitted to the labels: iterated to a
    # step of 1e-7, then narrowed to a nearly hard minimum of the margins, whose Newton
    # systems (priors of weight 1e7 beside margins of 1e4) carry differences of 1e-8 to 1e-5
    assert a.nnz == b.nnz and abs(a - b).max() < 5e-5
    for mine, theirs in zip(result._regions, whole._regions, strict=True):
        assert mine.params["band_vertices"] == theirs.params["band_vertices"] < corners.size
        np.testing.assert_array_equal(corners[mine.boundary.sources], theirs.boundary.sources)
    for mine, theirs in zip(result._regions[:2], whole._regions[:2], strict=True):  # sought on the domain
        a, b = np.sort(corners[mine.boundary.facets], axis=1), np.sort(theirs.boundary.facets, axis=1)
        np.testing.assert_array_equal(a[np.lexsort(a.T)], b[np.lexsort(b.T)])
    assert not {"edges", "adjacency", "_faces"} & set(result.domain.__dict__)
    np.testing.assert_allclose(result.region_measures(), whole.region_measures(), rtol=1e-6)  # as above
    # filled beyond its band (along the domain's own edges), phi keeps the labels' sides
    pixels = getattr(result.domain, "pixels", np.arange(labels.size))
    bands = [res.phi.vertices for res in result._regions]
    for r, label in enumerate(result.classes):
        beyond = np.ones(corners.size, dtype=bool)
        beyond[bands[r]] = False
        inside = result.domain.vertices_of(labels.ravel()[pixels] == label)
        assert beyond.any() and np.array_equal((result.phi[:, r] > 0.5)[beyond], inside[beyond])


def test_grid_usual_degree_is_the_adjacencys():
    from ndboundary.domains.image import grid_usual_degree

    for shape in [(1, 5), (2, 3), (3, 3), (12, 3), (3, 4, 5), (2, 9, 9), (1, 1, 4), (10, 10, 10)]:
        degrees = np.diff(ImageGrid(shape).build_adjacency().indptr)
        assert grid_usual_degree(shape) == np.percentile(degrees, 90)


@pytest.mark.parametrize("band", [False, True], ids=["grid", "band"])
@pytest.mark.parametrize("shape", [(9, 11), (7, 8, 9)], ids=["2d", "3d"])
def test_grid_facets_are_the_interface_facets_oriented_out_of_region_1(shape, band):
    """The facets found from the pixels' indices are the mesh's own between the labels,
    their normals point out of region 1, and their opposite corners are those of the two
    pixels they part."""
    from scipy.spatial import cKDTree

    from ndboundary.domains.image import grid_facets
    from ndboundary.metrics import as_complex

    grid = ImageGrid(shape, spacing=(0.5, 1.0, 2.0)[: len(shape)])
    x = grid.element_centroids()
    region1 = np.linalg.norm(x - x.mean(axis=0), axis=1) < 2.5
    if band:
        keep = np.random.default_rng(0).random(grid.n_elements) < 0.8
        grid, region1 = grid.subdomain(keep)[0], region1[keep]
    facets, normals, areas, inner, outer = grid_facets(grid, region1)
    mesh = grid.interface_facets(region1)
    assert np.array_equal(np.unique(facets), np.unique(mesh))
    assert areas.sum() == pytest.approx(as_complex(grid.points, mesh).measure())
    centres = cKDTree(grid.element_centroids())
    middle = grid.points[facets].mean(axis=1)
    step = 0.1 * min(grid.spacing)
    assert (~region1[centres.query(middle + step * normals)[1]]).all() and region1[
        centres.query(middle - step * normals)[1]
    ].all()
    for corners, side in ((inner, True), (outer, False)):
        centre = grid.points[np.hstack([facets, corners])].mean(axis=1)
        dist, pixel = centres.query(centre)
        assert np.allclose(dist, 0.0) and (region1[pixel] == side).all()


@pytest.mark.parametrize("fit", [False, True])
def test_a_shallow_staircase_is_straightened_between_its_risers(fit):
    """A line of slope 0.13 across the pixels: its treads lie up to half a pixel off it,
    the centres of its risers within 0.07. Pinned at the facets by how much they turn from
    the staircase around them, the relaxed line keeps within 0.06 pixel of the true one on
    average (0.084 with every vertex of the staircase pinned alike); fitted to the pixels,
    within 0.02."""
    n, normal, c = 128, np.array([-0.13, 1.0]) / np.hypot(0.13, 1.0), np.array([0.37, 0.21])
    centres = np.stack(np.indices((n, n)), axis=-1).reshape(-1, 2) - (n - 1) / 2
    result = relax_image(((centres - c) @ normal < 0).reshape(n, n), fit=fit)
    x = result.level_set().points - (n - 1) / 2
    d = np.abs((x[np.all(np.abs(x) < n / 2 - 16, axis=1)] - c) @ normal)
    assert (d.mean() < 0.02 and d.max() < 0.06) if fit else (d.mean() < 0.06 and d.max() < 0.16), (d.mean(), d.max())


def test_a_disc_on_pixels_three_times_as_long_is_fitted_within_the_anisotropic_targets():
    """A disc of radius 30 on pixels of 1 x 3: as relaxed, its curve strayed 0.20 (mean) and
    1.1 (max) from the circle, in units of the smaller spacing; fitted to the pixels it
    keeps within the imaging issue's anisotropic targets (0.15 and 0.6) and its area
    within 0.5 %."""
    spacing, radius = (1.0, 3.0), 30.0
    centre = np.array([39.13, 38.79])
    x = np.stack(np.indices((78, 26)), axis=-1) * spacing
    disc = np.linalg.norm(x - centre, axis=-1) < radius
    result = relax_image(disc, spacing=spacing)
    d = np.abs(np.linalg.norm(result.level_set().points - centre, axis=1) - radius)
    assert d.mean() < 0.1 and d.max() < 0.3, (d.mean(), d.max())
    assert result.region_measures()[1] == pytest.approx(np.pi * radius**2, rel=0.005)


def test_a_curve_of_two_regions_is_fitted_to_its_pixels():
    """A five-lobed flower on 96² pixels: the relaxed curve moved to the smoothest one
    parting the pixel centres with the largest margins lies nearer the flower than as
    relaxed (0.06 against 0.10 pixel on average, 0.27 against 0.35 at most), encloses its
    area more nearly,
    and is the same curve when the two labels are swapped."""
    from ndboundary.metrics import sample_points

    n, centre = 96, np.array([47.3, 46.8])
    g = np.stack(np.indices((n, n)), axis=-1).reshape(-1, 2) - centre
    radius = lambda t: 28.0 * (1.0 + 0.2 * np.cos(5.0 * (t - 0.3)))  # noqa: E731
    labels = (np.linalg.norm(g, axis=1) < radius(np.arctan2(g[:, 1], g[:, 0]))).reshape(n, n)
    t = np.linspace(0.0, 2.0 * np.pi, 40000, endpoint=False)
    truth = cKDTree(centre + radius(t)[:, None] * np.stack([np.cos(t), np.sin(t)], axis=1))
    area = 0.5 * (radius(t) ** 2).mean() * 2.0 * np.pi

    def errors(result):
        d = truth.query(sample_points(result.level_set()))[0]
        return d.mean(), d.max(), abs(result.region_measures()[1] / area - 1)

    fitted = relax_image(labels)
    swapped = relax_image(~labels)
    relaxed = relax_image(labels, fit=False)
    (mean, top, off), (mean0, top0, off0) = errors(fitted), errors(relaxed)
    assert fitted.params["fitted_interfaces"] == 1 and "fitted_interfaces" not in relaxed.params
    assert mean < 0.65 * mean0 and top < 0.85 * top0 and off < off0, (errors(fitted), errors(relaxed))
    np.testing.assert_allclose(swapped.phi - 0.5, -(fitted.phi - 0.5), atol=1e-8)


def test_a_face_of_treads_keeps_between_its_pixel_centres():
    """A rectangle's sides run along the pixels: no riser holds them, and the level set
    keeps within a fifth of a pixel of them, between the centres of the pixels they part
    (the integration lifts the pins of a facet whose pixels' centres it crossed)."""
    image = np.zeros((60, 50), dtype=bool)
    image[15:45, 15:35] = True
    x = relax_image(image).level_set().points
    top = (np.abs(x[:, 1] - 24.5) < 5) & (x[:, 0] < 30)
    side = (np.abs(x[:, 0] - 29.5) < 8) & (x[:, 1] > 25)
    assert np.abs(x[top, 0] - 14.5).max() < 0.2 and np.abs(x[side, 1] - 34.5).max() < 0.2


def test_a_box_on_the_border_keeps_its_volume():
    """A box of voxels standing on the image's border: its sides run along the grid with no
    riser anywhere, and their facets hold them as a staircase's risers would (without
    that, the box gained 9.7 % of its volume)."""
    labels = np.zeros((24, 24, 24), dtype=bool)
    labels[6:18, 6:18, 0:8] = True
    volume = relax_image(labels).region_measures()[1]
    assert abs(volume / labels.sum() - 1) < 0.03


def test_lifted_pins_are_solved_for_near_them_as_over_the_band(monkeypatch):
    """A ball cut flat: where the level set passed a pixel centre by the flat face, the
    pins there are lifted, and the correction solved on their neighbourhood alone lies
    within 0.01 voxel of the one solved over the band."""
    import ndboundary.pipeline.integration as integration

    i, j, k = np.indices((48, 48, 48))
    c = 24 + np.array([0.13, -0.21, 0.07])
    ball = ((i - c[0]) ** 2 + (j - c[1]) ** 2 + (k - c[2]) ** 2 < 18**2) & (k < c[2] + 14)
    surfaces = []
    for share in (1.0, 0.0):  # every correction near the pins, then every one over the band
        monkeypatch.setattr(integration, "SLAB_LOCAL_SHARE", share)
        result = relax_image(ball)
        assert result.params["lifted_pins"] > 0
        surfaces.append(result.level_set())
    gaps = [level_set_distance(a, b) for a, b in (surfaces, surfaces[::-1])]
    assert max(g.max() for g in gaps) < 0.01


def test_a_large_image_with_a_small_boundary_is_relaxed_on_its_band_by_default():
    """band="auto": the band of the pixels' reach, cut when it holds under 70 % of the
    pixels; the relaxed disc is the whole grid's within the band's targets (mean 0.01 h,
    max 0.05 h), and its measures count the pixels outside the band."""
    from ndboundary.domains.image import GridBand

    i, j = np.indices((300, 300))
    disc = (i - 150.3) ** 2 + (j - 149.6) ** 2 < 20.0**2
    result = relax_image(disc)
    assert isinstance(result.domain, GridBand) and result.domain.pixels.size < 0.2 * disc.size
    curve = result.level_set()
    d = np.abs(np.linalg.norm(curve.points - [150.3, 149.6], axis=1) - 20.0)
    assert curve.is_closed() and curve.n_components() == 1 and d.mean() < 0.1
    np.testing.assert_allclose(result.region_measures(), [disc.size - np.pi * 400, np.pi * 400], rtol=0.01)
    whole = relax_image(disc, band=None)
    gaps = [level_set_distance(a, b) for a, b in ((curve, whole.level_set()), (whole.level_set(), curve))]
    assert max(g.mean() for g in gaps) < 0.01 and max(g.max() for g in gaps) < 0.05
    np.testing.assert_allclose(result.region_measures(), whole.region_measures(), rtol=1e-3)


@pytest.mark.parametrize(
    ("pixels", "match"),
    [(np.array([3, 2]), "increasing"), (np.array([0, 64]), r"increasing indices in \[0, 64\)"),
     (np.array([], dtype=int), "non-empty"), (np.array([0.5]), "pixel indices")],
)  # fmt: skip
def test_grid_band_refuses_bad_pixels(pixels, match):
    from ndboundary.domains.image import GridBand

    with pytest.raises(ValueError, match=match):
        GridBand((4, 4, 4), pixels)


def test_voxels_with_every_corner_on_the_staircase_take_their_neighbours_field():
    """relax_image leaves the flat voxels whole (pad=False): the level set stays where the
    pyramids of a padding would put it, to a few thousandths of a voxel."""
    from ndboundary.metrics import level_set_distance

    mask = _ball(32, 0.3)
    kept, split = relax_image(mask), relax_image(mask, pad=True)
    assert kept.params["pad"] is False and kept.field.shape[0] == mask.size < split.field.shape[0]
    assert np.allclose(np.linalg.norm(kept.field, axis=1), 1.0)
    d = level_set_distance(kept.level_set(), split.level_set())
    assert d.mean() < 0.005 and d.max() < 0.03


@pytest.mark.parametrize("inset", [False, True])
@pytest.mark.parametrize("shape", [(9, 10, 11), (12, 13)])
def test_a_grid_bands_components_edges_and_operators_are_its_meshs(shape, inset):
    """The band's vertex components come from its pixels on the index grid: the same
    partition as the mesh's edges give, with pixels that touch at a corner joined. Its
    voxels' edges, stiffness and gradient, built from the one box they all are, are
    those of the general hexahedra, to the bit. Pixels set in from the grid's sides (as a
    region's band in a large image) are numbered through their own box, not the grid:
    their corners are the grid's, at the grid's points."""
    from ndboundary import Domain, ImageGrid, PolyhedralMesh
    from ndboundary.domains.image import GridBand

    rng = np.random.default_rng(1)
    keep = rng.uniform(size=shape) < 0.12
    if inset:  # the pixels of a box set in from the grid's sides
        box = np.zeros(shape, dtype=bool)
        box[tuple(slice(2, n - 1) for n in shape)] = True
        keep &= box
    pixels = np.flatnonzero(keep)
    band = GridBand(shape, pixels, spacing=0.7)
    if inset:
        grid = ImageGrid(shape, spacing=0.7)
        np.testing.assert_array_equal(band.points, grid.points[band.corners])
        assert np.all(np.diff(band.corners) > 0)
        if len(shape) == 3:  # each voxel's corners surround its pixel's centre
            rows, cols = band.cell_vertices
            centres = np.zeros((pixels.size, 3))
            np.add.at(centres, rows, band.points[cols] / 8)
            np.testing.assert_allclose(centres, grid.element_centroids()[pixels], atol=1e-12)
            some = rng.choice(pixels.size, size=9, replace=False)  # a few voxels' alone
            np.testing.assert_array_equal(band.centroids_of(some), band.element_centroids()[some])
            np.testing.assert_array_equal(grid.centroids_of(pixels[some]), grid.element_centroids()[pixels[some]])
    n, comp = band.vertex_components
    n_edges, comp_edges = Domain.vertex_components.func(band)
    assert n == n_edges > 3
    assert np.unique(np.stack([comp, comp_edges]), axis=1).shape[1] == n  # one to one
    if len(shape) == 3:
        np.testing.assert_array_equal(band.edges, PolyhedralMesh.build_edges(band))
        for name, build in (("K", "stiffness"), ("G", "gradient"), ("adjacency", "adjacency")):
            general = getattr(PolyhedralMesh, f"build_{build}")(band).tocsr()
            # to rounding: the grid's stiffness sums in another order, without the couplings that vanish
            assert abs(getattr(band, name) - general).max() <= 1e-14 * abs(general).max(), name


@pytest.mark.parametrize("shape", [(14, 15, 16), (30, 31)])
def test_a_grid_cut_to_some_pixels_is_the_general_cut(shape):
    """subdomain() of an image grid or of its band is a GridBand of those pixels, built from
    their indices: the mesh, operators and vertex map of the general mesh's cut."""
    from ndboundary import PolygonMesh, PolyhedralMesh
    from ndboundary.domains.image import GridBand

    general = PolyhedralMesh if len(shape) == 3 else PolygonMesh
    rng = np.random.default_rng(2)
    grid = ImageGrid(shape, spacing=(0.5, 1.0, 2.0)[: len(shape)], direction=-np.eye(len(shape)))
    band, _ = grid.subdomain(rng.uniform(size=grid.n_elements) < 0.6)
    mask = rng.uniform(size=band.n_elements) < 0.5
    for mesh, m in ((grid, rng.uniform(size=grid.n_elements) < 0.3), (band, mask)):
        cut, vertices = mesh.subdomain(m)
        ref, ref_vertices = general.subdomain(mesh, m)
        assert isinstance(cut, GridBand) and cut.usual_degree == mesh.usual_degree
        np.testing.assert_array_equal(vertices, ref_vertices)
        np.testing.assert_array_equal(cut.points, ref.points)
        np.testing.assert_array_equal(cut.mass, ref.mass)
        for name in ("K", "G", "adjacency"):
            assert abs(getattr(cut, name) - getattr(ref, name)).max() == 0, name
    with pytest.raises(ValueError, match="one value per pixel"):
        band.subdomain(mask[:-1])


def test_many_regions_on_the_whole_grid_take_the_images_band_width():
    """An image whose band holds the whole grid is relaxed on it, and each region on its own
    band of the image's width (the grid's boundary weight is known), as when the image is
    cut to its band; the regions keep their volumes."""
    labels = np.repeat(np.repeat(np.repeat([0, 1, 2], [13, 13, 14])[:, None, None], 40, axis=1), 40, axis=2)
    result = relax_image(labels)
    assert isinstance(result.domain, ImageGrid)
    width = relax_image(labels == 0).params["band"]
    assert result.regions[0].params["band"] == result.regions[2].params["band"] == width
    np.testing.assert_allclose(result.region_measures(), [13 * 1600, 13 * 1600, 14 * 1600], rtol=1e-3)


def _fitted_and_relaxed(monkeypatch, labels, off, fitted_below, relaxed_above):
    """``relax_image(labels)`` with its junctions fitted puts them within ``fitted_below``
    of the truth by ``off`` (a function of the result), keeping the regions' volumes,
    and the relaxation alone farther than ``relaxed_above``.
    """
    from ndboundary.pipeline import junctions

    fitted = relax_image(labels)
    assert off(fitted) < fitted_below  # the fit is made when the partition is first built
    np.testing.assert_allclose(fitted.region_measures(), np.bincount(labels.ravel()), rtol=3e-3)
    monkeypatch.setattr(junctions, "JUNCTION_FIT", False)
    assert off(relax_image(labels)) > relaxed_above


def _meeting_points(result):
    """The points where the junction curves of ``result`` meet."""
    j = result.interfaces().junctions()
    return j.points[np.bincount(j.simplices.ravel(), minlength=j.points.shape[0]) >= 3]


def test_a_junction_curve_the_relaxation_misplaces_is_moved_onto_its_line(monkeypatch):
    """Three regions of unequal angles (80, 150 and 130 degrees) meet along a straight line
    tilted to the voxels: the relaxed functions put their junction curve a third of a
    voxel off it, the fit of its cross-sections to the voxels within a tenth, and the
    regions keep their volumes."""
    n = 28
    axis = np.array([0.2, 0.3, 1.0]) / np.linalg.norm([0.2, 0.3, 1.0])
    centre = np.array([13.7, 13.2, 13.5])
    first = np.cross(axis, [1.0, 0.0, 0.0])
    first /= np.linalg.norm(first)
    rel = np.indices((n, n, n)).reshape(3, -1).T - centre
    theta = np.mod(np.arctan2(rel @ np.cross(axis, first), rel @ first), 2 * np.pi)
    labels = (np.searchsorted(np.radians([0.0, 80.0, 230.0]), theta, side="right") - 1).reshape((n,) * 3)

    def off_line(result):
        points = result.interfaces().junctions().points
        points = points[np.all((points > 2) & (points < n - 3), axis=1)]  # away from the border
        r = points - centre
        return np.linalg.norm(r - np.outer(r @ axis, axis), axis=1).mean()

    _fitted_and_relaxed(monkeypatch, labels, off_line, 0.1, 0.25)


def test_a_straight_curve_waving_with_the_voxels_is_averaged_over_the_widest_windows():
    """A straight junction curve's relaxed samples wave about its line with the voxels (a
    quarter of a voxel over 25 samples): its curvature, read over CURVATURE_REACH samples,
    lets its middle average its fits over WIDE samples either side; circles of 8 to 60
    voxels are not averaged so."""
    from ndboundary.pipeline import junction_curves

    s = np.arange(60.0)
    wavy = np.column_stack([0.6 * s, 0.8 * s, 0.25 * np.sin(2 * np.pi * s / 25)])
    widths = junction_curves._straight_widths(wavy)
    assert np.all(widths[20:41] == junction_curves.WIDE)
    for radius in (8.0, 29.0, 60.0):
        t = np.arange(80.0) / radius
        circle = np.column_stack([radius * np.cos(t), radius * np.sin(t), 0 * t])
        assert junction_curves._straight_widths(circle).max() == 0


def test_the_fits_along_a_straight_junction_curve_are_averaged_over_its_length(monkeypatch):
    """Three regions (sectors of 75, 140 and 145 degrees) meet along straight lines at
    three slants to the voxels. Each cross-section's fit wavers with where its slab meets
    the voxels; averaged over up to 12 samples either side where the curve is straight,
    the fitted curves lie within 0.04 voxel of their lines on average (0.035), and nearer
    than three quarters of the distance of the fits averaged over a few samples only
    (0.055)."""
    from ndboundary.pipeline import junction_curves

    n = 40
    centre = np.full(3, (n - 1) / 2) + np.random.default_rng(0).uniform(-0.5, 0.5, 3)
    rel = np.indices((n,) * 3).reshape(3, -1).T - centre
    cases = []
    for axis in ([0.2, 0.3, 1.0], [0.13, 0.41, 1.0], [0.35, 0.1, 1.0]):
        axis = np.asarray(axis) / np.linalg.norm(axis)
        first = np.cross(axis, [1.0, 0.0, 0.0])
        first /= np.linalg.norm(first)
        theta = np.mod(np.arctan2(rel @ np.cross(axis, first), rel @ first), 2 * np.pi)
        labels = np.searchsorted(np.radians([0.0, 75.0, 215.0]), theta, side="right") - 1
        cases.append((labels.reshape((n,) * 3), axis))

    def mean_off():
        distances = []
        for labels, axis in cases:
            points = relax_image(labels).interfaces().junctions().points
            r = points[np.all((points > 2) & (points < n - 3), axis=1)] - centre  # away from the border
            distances.append(np.linalg.norm(r - np.outer(r @ axis, axis), axis=1))
        return np.concatenate(distances).mean()

    wide = mean_off()
    monkeypatch.setattr(junction_curves, "WIDE_MIN", n)  # no window is that wide
    narrow = mean_off()
    assert wide < 0.04
    assert wide < 0.75 * narrow


def test_a_junction_circle_is_fitted_nearer_the_truth_than_relaxed(monkeypatch):
    """Two overlapping balls parted by their radical plane meet the space outside on a
    circle of 5.9 voxels (sectors of about 133, 114 and 114 degrees). Over three
    placements, the fitted junction curves lie within 0.17 voxel of it on average (a
    slab of 1.5 h about each cross-section left them 0.20 off), and the relaxed ones
    farther than 0.19."""
    from ndboundary.pipeline import junctions

    n, radii = 32, np.array([8.0, 6.4])
    x = np.indices((n, n, n)).reshape(3, -1).T.astype(np.float64)
    cases = []
    for placement in range(3):  # as benchmarks/junction_circles.py places them
        rng = np.random.default_rng(placement)
        middle = np.full(3, (n - 1) / 2) + rng.uniform(-1.0, 1.0, 3)
        axis = np.array([0.3, 0.2, 0.93]) + rng.normal(0.0, 0.3, 3)
        axis /= np.linalg.norm(axis)
        centres = middle + np.outer([-4.0, 4.0], axis)
        power = ((x[:, None, :] - centres[None]) ** 2).sum(axis=2) - radii**2
        labels = np.where(power.min(axis=1) < 0, power.argmin(axis=1), 2).reshape(n, n, n)
        along = (8.0**2 + radii[0] ** 2 - radii[1] ** 2) / 16.0  # the circle's plane, from the first centre
        cases.append((labels, centres[0] + along * axis, axis, np.sqrt(radii[0] ** 2 - along**2)))

    def mean_off():
        distances = []
        for labels, centre, axis, radius in cases:
            v = relax_image(labels).interfaces().junctions().points - centre
            up = v @ axis
            distances.append(np.hypot(up, np.linalg.norm(v - np.outer(up, axis), axis=1) - radius))
        return np.concatenate(distances).mean()

    assert mean_off() < 0.17
    monkeypatch.setattr(junctions, "JUNCTION_FIT", False)
    assert mean_off() > 0.19


def test_a_point_where_four_regions_meet_is_moved_onto_the_truth(monkeypatch):
    """Four regions of unequal solid angles meet at a point off the voxels' lattice: the
    relaxed functions put their corner (where junction curves meet) most of a voxel off
    it, its fit to the voxels around it within a fifth, and the regions keep their
    volumes."""
    n = 28
    corner = np.array([13.3, 12.6, 14.1])
    gradients = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [0.1, 1.0, 0.3], [-0.6, -0.5, 1.0]])
    labels = np.argmax((np.indices((n, n, n)).reshape(3, -1).T - corner) @ gradients.T, axis=1).reshape((n,) * 3)

    def off(result):
        return np.linalg.norm(_meeting_points(result) - corner, axis=1).min()

    _fitted_and_relaxed(monkeypatch, labels, off, 0.2, 0.6)


def test_two_corners_near_each_other_are_fitted_together(monkeypatch):
    """The Voronoi partition of five sites has two corners 4.9 voxels apart: fitted as one
    partition of five affine functions about both, each lies within a fifth of a voxel of
    the truth (as relaxed, 0.58 and 0.39 voxel)."""
    from scipy.spatial import Voronoi, cKDTree

    n = 28
    sites = np.random.default_rng(44).uniform(4, n - 5, (5, 3))
    corners = Voronoi(sites).vertices
    corners = corners[np.all((corners > -0.5) & (corners < n - 0.5), axis=1)]
    assert len(corners) == 2 and 4.5 < np.linalg.norm(corners[0] - corners[1]) < 5.5
    labels = cKDTree(sites).query(np.indices((n, n, n)).reshape(3, -1).T)[1].reshape((n,) * 3)

    def off(result):
        meeting = _meeting_points(result)
        return max(np.linalg.norm(meeting - c, axis=1).min() for c in corners)

    _fitted_and_relaxed(monkeypatch, labels, off, 0.2, 0.5)


def test_many_regions_partition_their_bands_as_their_filled_functions():
    """The partition reads each region on its band only, without the entries that cannot
    win: it is the partition of the filled functions, and every region enclosed by the
    frame has a closed boundary."""
    from ndboundary.partition import partition

    labels = np.pad(_voronoi((16, 18, 20), 5, (1.0, 1.0, 1.0)), 1, constant_values=7)
    result = relax_image(labels, band=4.0)
    values = result.region_values()
    assert hasattr(values, "tocsr") and values.nnz < 0.8 * values.shape[0] * values.shape[1]
    filled = partition(*result.domain.level_set_complex(result.phi))  # on the image's band
    outside = result.domain.measures_outside(result.classes)  # the voxels beyond it, whole
    np.testing.assert_allclose(result.region_measures(), filled.region_measures() + outside, rtol=1e-12)
    assert result.interfaces().measure() == pytest.approx(filled.interfaces().measure(), rel=1e-12)
    j, k = result.interfaces().junctions(), filled.interfaces().junctions()
    length = [np.linalg.norm(np.diff(x.points[x.simplices], axis=1), axis=2).sum() for x in (j, k)]
    assert length[0] == pytest.approx(length[1], rel=1e-9) and length[0] > 0
    assert all(result.region_boundary(r).is_closed() for r in range(5))


def _triangles(surface):
    """The surface's oriented triangles, whatever their order and their first vertex."""
    rows = [tuple(map(tuple, t)) for t in np.round(surface.points[surface.simplices], 9)]
    return sorted(min(t[i:] + t[:i] for i in range(len(t))) for t in rows)


def _pieces(faces):
    """The interfaces' oriented triangles and their pairs, whatever their order and their
    first vertex."""
    rows = [tuple(map(tuple, t)) for t in np.round(faces.points[faces.simplices], 9)]
    return sorted((min(t[i:] + t[:i] for i in range(len(t))), tuple(p)) for t, p in zip(rows, faces.pairs.tolist()))


def test_many_regions_cut_region_by_region_as_all_at_once(monkeypatch):
    """Beyond PARTITION_BY_REGION_SIMPLICES, each region is cut from the simplices where it
    is stored: the same boundary, simplex for simplex, and the same measures, without the
    partition of every region at once. (Junction curves are fitted only below it, where
    the cut near them fits in memory: both are left as relaxed here.)"""
    from ndboundary.pipeline import junctions
    from ndboundary.pipeline import result as result_module

    monkeypatch.setattr(junctions, "JUNCTION_FIT", False)
    labels = np.pad(_voronoi((16, 18, 20), 6, (1.0, 1.0, 1.0), seed=2), 1, constant_values=9)
    whole = relax_image(labels, band=4.0)
    whole.region_measures()  # the partition of every region at once
    assert whole._by_region() is None
    monkeypatch.setattr(result_module, "PARTITION_BY_REGION_SIMPLICES", 0)
    by_region = relax_image(labels, band=4.0)
    assert by_region._by_region() is not None
    np.testing.assert_allclose(by_region.region_measures(), whole.region_measures(), rtol=1e-12)
    assert "_cut_cache" not in by_region.__dict__  # no partition of every region was built
    for r in range(whole.classes.size):
        a, b = by_region.region_boundary(r), whole.region_boundary(r)
        assert a.simplices.shape == b.simplices.shape and a.is_closed() == b.is_closed()
        assert _triangles(a) == _triangles(b)
        assert a.measure() == pytest.approx(b.measure(), rel=1e-12)
    assert by_region.region_boundary(6).is_closed()  # enclosed by the frame of label 9
    # the interfaces, each piece from the cut of the lower of its regions: the whole
    # partition's simplices and pairs, their points shared as there (the same junctions)
    faces, all_at_once = by_region.interfaces(), whole.interfaces()
    assert "_cut_cache" not in by_region.__dict__ and by_region.interfaces() is faces  # built once
    assert faces.points.shape == all_at_once.points.shape and faces.cells is None
    assert _pieces(faces) == _pieces(all_at_once)
    curves = [faces.junctions(), all_at_once.junctions()]
    segments = [
        sorted(
            (tuple(sorted(map(tuple, np.round(j.points[e], 9)))), tuple(r))
            for e, r in zip(j.simplices, j.regions.tolist())
        )
        for j in curves
    ]
    assert len(segments[0]) > 0 and segments[0] == segments[1]


def test_the_largest_region_is_never_cut(monkeypatch):
    """Cut region by region, each interface piece comes from the cut of the smaller of its
    two regions, the largest region's boundary is its pieces and its measure the rest of
    the simplices': the region stored at the most points (an atlas's background) is never
    cut, and the interfaces, boundaries and measures are those of the partition of them
    all."""
    from ndboundary.pipeline import junctions
    from ndboundary.pipeline import result as result_module

    monkeypatch.setattr(junctions, "JUNCTION_FIT", False)
    labels = np.pad(_voronoi((12, 14, 16), 4, (1.0, 1.0, 1.0), seed=3) + 1, 5)  # background 0 about them
    whole = relax_image(labels, band=4.0)
    all_at_once = (whole.interfaces(), whole.region_measures(), whole.region_boundary(0))
    assert whole._by_region() is None
    monkeypatch.setattr(result_module, "PARTITION_BY_REGION_SIMPLICES", 0)
    by_region = relax_image(labels, band=4.0)
    cut = []
    partition_of = result_module._RegionCuts._partition
    monkeypatch.setattr(result_module._RegionCuts, "_partition", lambda self, r: cut.append(r) or partition_of(self, r))
    faces = by_region.interfaces()
    assert by_region._by_region()._largest == 0 and sorted(cut) == [1, 2, 3, 4]
    measures = by_region.region_measures()
    by_region.region_boundaries([1, 2, 3, 4])
    assert 0 not in cut
    assert _pieces(faces) == _pieces(all_at_once[0])
    np.testing.assert_allclose(measures, all_at_once[1], rtol=1e-12)
    assert measures.sum() == pytest.approx(labels.size, rel=1e-12)
    outside = by_region.region_boundary(0)
    assert _triangles(outside) == _triangles(all_at_once[2]) and outside.is_closed()
    assert outside.edges.shape == (outside.n_points, 2)
    assert 0 not in cut
    # alone, from its neighbours' cuts; with every boundary at once, from the pieces
    # their cuts keep
    for ask in (lambda result: [result.region_boundary(0)], lambda result: result.region_boundaries()):
        cut.clear()
        surfaces = ask(relax_image(labels, band=4.0))
        assert sorted(cut) == [1, 2, 3, 4]  # each cut once
        assert [_triangles(b) for b in surfaces] == [_triangles(whole.region_boundary(r)) for r in range(len(surfaces))]
    # one batch at a time, the largest last; in the order given where all are cut at once
    monkeypatch.setattr(result_module, "BOUNDARIES_AT_ONCE", 1)
    cut.clear()
    streamed = list(relax_image(labels, band=4.0).each_region_boundary([3, 0, 1, 4, 2]))
    assert [r for r, _ in streamed] == [3, 1, 4, 2, 0] and sorted(cut) == [1, 2, 3, 4]
    assert all(_triangles(b) == _triangles(whole.region_boundary(r)) for r, b in streamed)
    assert [r for r, _ in whole.each_region_boundary([3, 0, 1])] == [3, 0, 1]
    with pytest.raises(ValueError, match="out of range"):
        whole.each_region_boundary([0, 5])


def test_every_regions_boundary_at_once_is_each_regions_boundary(monkeypatch):
    """``region_boundaries`` cuts the regions on two threads at once beyond
    PARTITION_BY_REGION_SIMPLICES, in the order asked: the same surfaces, simplex for
    simplex, as ``region_boundary`` one region after another, and the same measures."""
    from ndboundary.pipeline import result as result_module

    labels = np.pad(_voronoi((16, 18, 20), 6, (1.0, 1.0, 1.0), seed=2), 1, constant_values=9)
    monkeypatch.setattr(result_module, "PARTITION_BY_REGION_SIMPLICES", 0)
    monkeypatch.setattr(result_module, "available_threads", lambda: 2)
    cuts = []
    mixed_of = result_module._mixed_of
    monkeypatch.setattr(result_module, "_mixed_of", lambda *args: cuts.append(1) or mixed_of(*args))
    one_by_one = relax_image(labels, band=4.0)
    at_once = relax_image(labels, band=4.0)
    assert at_once._by_region() is not None
    assert len(cuts) == 1  # the junction curves' fit, skipped here, leaves its cut to the partition
    n = at_once.classes.size
    order = [5, 0, 3, 3, 6, 1]
    for r, surface in zip(order, at_once.region_boundaries(order), strict=True):
        alone = one_by_one.region_boundary(r)
        np.testing.assert_array_equal(surface.points, alone.points)
        np.testing.assert_array_equal(surface.simplices, alone.simplices)
    assert len(at_once.region_boundaries()) == n
    np.testing.assert_array_equal(at_once.region_measures(), one_by_one.region_measures())
    with pytest.raises(ValueError, match="out of range"):
        at_once.region_boundaries([0, n])
    with pytest.raises(TypeError, match="integer index"):
        at_once.region_boundary(1.5)
    with pytest.raises(ValueError, match="out of range"):
        at_once.region_boundary(-1)


def test_the_junctions_of_a_volume_are_found_refining_the_elements_near_them_only():
    """The mixed elements near those where three regions lead, refined alone, give the
    same complex near the junctions as the refinement of every mixed element: the same
    simplices, point for point, with the same largest function."""
    from ndboundary.pipeline import result as result_module

    labels = _voronoi((18, 20, 22), 7, (1.0, 1.0, 1.0), seed=4)
    result = relax_image(labels)
    values = result._relaxed_values()
    lead = result_module._argmax_rows(values)
    h = result.domain.mean_edge_length()
    full = result_module._mixed_of(result.domain, values, lead)[0]
    expected = result_module._near_junctions(*full, result_module._argmax_rows(full[2]), 5.0 * h)
    near, cut_size, _ = result_module._near_junction_elements(result.domain, values, lead, 5.0 * h, np.inf)
    assert cut_size == full[1].shape[0]  # voxels refine alike: the estimate is exact
    limited = result_module._near_junction_elements(result.domain, values, lead, 5.0 * h, cut_size - 1)
    assert limited == (None, cut_size, None)
    assert near[1].shape[0] == expected[1].shape[0]

    def simplices(points, simplices, values):
        corners = np.sort(points[simplices].reshape(len(simplices), -1).round(9), axis=1)
        order = np.lexsort(corners.T)
        return corners[order], result_module._argmax_rows(values)[simplices][order]

    for got, want in zip(simplices(*near), simplices(*expected), strict=True):
        np.testing.assert_array_equal(got, want)


def test_the_interfaces_far_from_junctions_cut_beside_their_fit_join_the_others(monkeypatch):
    """The mixed voxels far from every junction are cut while the junctions are fitted,
    the others after: the regions' boundaries are the same surfaces, watertight where the
    regions do not meet the image's border, with the same measures, as one partition of
    every mixed voxel."""
    from ndboundary.pipeline import result as result_module

    labels = _voronoi((40, 44, 48), 5, (1.0, 1.0, 1.0), seed=3)
    joined = relax_image(labels)
    joined.region_values()
    assert "_cut_beside" in joined.__dict__  # some mixed voxels lie far from the junctions
    assert isinstance(joined._cut()[0], result_module._JoinedCut)
    monkeypatch.setattr(result_module, "BESIDE_FIT_REACH", np.inf)
    one = relax_image(labels)
    assert not isinstance(one._cut()[0], result_module._JoinedCut)
    np.testing.assert_allclose(joined.region_measures(), one.region_measures(), rtol=1e-12)
    assert joined.region_measures().sum() == pytest.approx(labels.size, rel=1e-12)
    lo, hi = np.zeros(3) - 0.5, np.array(labels.shape) - 0.5
    for r in range(joined.classes.size):
        a, b = joined.region_boundary(r), one.region_boundary(r)
        assert a.simplices.shape == b.simplices.shape
        assert a.measure() == pytest.approx(b.measure(), rel=1e-12)
        T = a.simplices
        edges = np.sort(np.concatenate([T[:, [0, 1]], T[:, [1, 2]], T[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert counts.max() == 2  # no edge is shared by more than two triangles
        rim = np.unique(edges, axis=0)[counts == 1]
        x = a.points[rim.ravel()]
        assert (np.isclose(x, lo) | np.isclose(x, hi)).any(axis=1).all()  # open only on the image's border
    faces = joined.interfaces()
    assert len(faces) == len(one.interfaces())
    assert faces.measure() == pytest.approx(one.interfaces().measure(), rel=1e-12)
    # elements so near the junctions that their fit moves vertices of them: cut after it
    monkeypatch.setattr(result_module, "BESIDE_FIT_REACH", -1.7)  # all but the elements at the junctions
    near = relax_image(labels)
    near.region_values()
    assert "_cut_beside" not in near.__dict__
    assert not isinstance(near._cut()[0], result_module._JoinedCut)
    np.testing.assert_allclose(near.region_measures(), one.region_measures(), rtol=1e-12)


def test_a_large_bands_integration_terms_after_its_field_change_nothing(monkeypatch):
    """A band beyond BESIDE_MAX_VERTICES builds its integration terms after its field, its
    own stiffness let go first, not beside it: the same functions, to the bit."""
    from ndboundary.pipeline import relaxer

    deferred = []

    class Spy(relaxer.Beside):
        def __init__(self, *args, defer=False):
            deferred.append(defer)
            super().__init__(*args, defer=defer)

    monkeypatch.setattr(relaxer, "Beside", Spy)
    labels = _voronoi((14, 16, 18), 5, (1.0, 1.0, 1.0), seed=1)
    beside = relax_image(labels, band=4.0).region_values().toarray()
    monkeypatch.setattr(relaxer, "BESIDE_MAX_VERTICES", 0)
    after = relax_image(labels, band=4.0).region_values().toarray()
    assert deferred == [False] * 5 + [True] * 5
    np.testing.assert_array_equal(after, beside)


def test_a_whole_voxel_grid_builds_its_tables_when_read(monkeypatch):
    """A VoxelGrid holds no table of its voxels' corners, coordinates or volumes until one
    is read: its largest corner values, a slab of voxels at a time, are the table's. A
    partition relaxed region by region on their bands and cut region by region (beyond
    PARTITION_BY_REGION_SIMPLICES, an atlas's size) reads none of them, from the
    relaxation to every region's boundary and measure."""
    from ndboundary.domains import image
    from ndboundary.pipeline import result as result_module

    tables = ("cell_vertices", "points", "_volumes")
    grid = ImageGrid((5, 6, 7), spacing=(1.0, 0.5, 2.0))
    assert not any(name in grid.__dict__ for name in tables)
    assert (grid.n_vertices, grid.n_elements, grid.dim) == (6 * 7 * 8, 5 * 6 * 7, 3)
    f = np.random.default_rng(0).normal(size=grid.n_vertices)
    monkeypatch.setattr(image, "SLAB_VOXELS", 50)  # slabs of one layer: 42 voxels
    by_slab = grid.element_max(f)
    assert not any(name in grid.__dict__ for name in tables)
    corners = grid.cell_vertices[1].reshape(-1, 8)
    np.testing.assert_array_equal(by_slab, f[corners].max(axis=1))
    np.testing.assert_array_equal(grid.element_max(f), by_slab)  # from the table, once read
    np.testing.assert_allclose(grid.element_centroids()[0], grid.points[corners[0]].mean(axis=0))
    assert grid.A.sum() == pytest.approx(5 * 3 * 14)

    labels = np.pad(_voronoi((16, 18, 20), 6, (1.0, 1.0, 1.0), seed=2), 1, constant_values=9)
    monkeypatch.setattr(result_module, "PARTITION_BY_REGION_SIMPLICES", 0)
    result = relax_image(labels, band=4.0)
    assert isinstance(result.domain, VoxelGrid)
    result.region_boundaries()
    assert result.region_measures().sum() == pytest.approx(labels.size, rel=1e-12)
    assert not any(name in result.domain.__dict__ for name in tables)
    assert result._mixed()[0][1].dtype == np.int32  # the mixed voxels' tetrahedra, held to the end


@pytest.mark.parametrize("band", [False, True])
def test_a_voxel_grids_gradient_and_divergence_need_no_matrix(band):
    """The gradient and weak divergence of voxels, computed from the box every voxel shares,
    are those of the gradient matrix to rounding, exact on linear functions and adjoint."""
    from ndboundary.domains.image import GridBand

    rng = np.random.default_rng(3)
    shape, spacing, direction = (9, 10, 11), (0.6, 1.0, 2.5), _rotation(3)
    if band:
        grid = GridBand(shape, np.flatnonzero(rng.uniform(size=int(np.prod(shape))) < 0.4), spacing=spacing)
    else:
        grid = ImageGrid(shape, spacing=spacing, direction=direction)
    f, X = rng.standard_normal(grid.n_vertices), rng.standard_normal((grid.n_elements, 3))
    G = grid.G
    np.testing.assert_allclose(grid.gradient(f), (G @ f).reshape(-1, 3), rtol=0, atol=1e-13)
    np.testing.assert_allclose(grid.div(X), G.T @ (X * grid.A[:, None]).reshape(-1), rtol=0, atol=1e-13)
    slope = np.array([1.0, -2.0, 0.5])
    np.testing.assert_allclose(grid.gradient(grid.points @ slope), np.tile(slope, (grid.n_elements, 1)), atol=1e-12)
    assert f @ grid.div(X) == pytest.approx(np.sum(grid.A * np.einsum("ij,ij->i", grid.gradient(f), X)), rel=1e-12)


def test_voxel_centroids_and_corner_maxima_are_the_means_and_maxima_of_their_corners():
    """The compiled passes over the voxels' corners give each voxel's centroid, for all of
    them or a few, and the largest corner value (NaN where a corner is NaN), as the mean
    and the maximum of its corners' rows."""
    from ndboundary.domains.image import GridBand

    rng = np.random.default_rng(0)
    band = GridBand((12, 9, 7), np.sort(rng.choice(756, 300, replace=False)), spacing=(0.6, 1.1, 3.0), origin=(1, 2, 3))
    corners = band.cell_vertices[1].reshape(band.n_elements, 8)
    np.testing.assert_allclose(band.element_centroids(), band.points[corners].mean(axis=1), rtol=0, atol=1e-12)
    some = rng.choice(band.n_elements, 20)
    np.testing.assert_array_equal(band.centroids_of(some), band.element_centroids()[some])
    f = rng.standard_normal(band.n_vertices)
    f[corners[5, 3]] = np.nan
    expected = f[corners].max(axis=1)
    np.testing.assert_array_equal(band.element_max(f), expected)
    assert np.isnan(band.element_max(f)[5])
    codes = rng.integers(0, 5, band.n_vertices).astype(np.int32)  # labels keep their type
    assert band.element_max(codes).dtype == np.int32
    np.testing.assert_array_equal(band.element_max(codes), codes[corners].max(axis=1))


def test_a_y_of_rays_on_pixels_is_fitted_with_its_junction(monkeypatch):
    """Three regions of a 96² label image parted by straight rays from an off-grid point:
    the interfaces, fitted with their junction, lie within a tenth of a pixel of the rays
    and the junction within a tenth of a pixel of the point, several times nearer than
    with the junction fitted to the pixels around it alone."""
    from ndboundary.pipeline import interface_fit

    n, centre, angles = 96, np.array([47.3, 48.6]), np.radians([95.0, 212.0, 331.0])
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)
    labels = (np.searchsorted(angles, np.arctan2(*(g - centre).T[::-1]) % (2 * np.pi)) % 3).reshape(n, n)
    errors = {}
    for fit in (True, False):
        monkeypatch.setattr(interface_fit, "INTERFACE_FIT", fit)
        faces = relax_image(labels).interfaces()
        x = faces.points[faces.simplices].mean(axis=1)
        to_rays = np.full(len(x), np.inf)
        for angle in angles:
            u = np.array([np.cos(angle), np.sin(angle)])
            along = np.clip((x - centre) @ u, 0.0, None)
            to_rays = np.minimum(to_rays, np.linalg.norm(x - centre - along[:, None] * u, axis=1))
        inner = np.abs(x - n / 2).max(axis=1) < n / 2 - 2  # away from the image's border
        j = faces.junctions()
        junction = np.linalg.norm(j.points[j.simplices[:, 0]] - centre, axis=1).min()
        errors[fit] = (to_rays[inner].mean(), to_rays[inner].max(), junction)
    assert max(errors[True]) < 0.1 and errors[True][1] < 0.5 * errors[False][1], errors
    assert errors[True][2] < 0.5 * errors[False][2], errors


def test_a_junction_the_pixels_around_it_misplace_is_moved_back_by_its_interfaces(monkeypatch):
    """A Y of rays on 64² pixels whose junction the fit to the pixels around it leaves half
    a pixel off (one of the 12 Y's of ``benchmarks/regions.py --cases image-y``): fitted
    with its three interfaces, which read the rays along their whole length, it lies
    within a tenth of a pixel of the truth, where holding it beyond half a pixel kept it
    off."""
    from ndboundary.pipeline import interface_fit

    n, centre, angles = 64, np.array([31.48583536, 31.88948783]), np.radians([115.873, 244.924, 357.307])
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)
    labels = (np.searchsorted(angles, np.arctan2(*(g - centre).T[::-1]) % (2 * np.pi)) % 3).reshape(n, n)

    def junction_error():
        j = relax_image(labels).interfaces().junctions()
        return np.linalg.norm(j.points[j.simplices[:, 0]] - centre, axis=1).min()

    moved = junction_error()
    monkeypatch.setattr(interface_fit, "JUNCTION_MAX", 0.5)
    held = junction_error()
    assert moved < 0.1 and held > 0.4, (moved, held)


def test_interfaces_on_pixels_are_read_as_arcs_where_the_labels_allow(monkeypatch):
    """Two nested circles parting three regions on 96² pixels: fitted with the stiffest
    prior on the change of curvature that parts their pixels, the interfaces lie within a
    fortieth of a pixel of the circles on average, and nearer than with the softest prior
    alone, which bends them into the gaps between the pixels: at most by half, on average by
    two fifths (the narrowed margins bring the softest fit nearer on average too)."""
    from ndboundary.pipeline import interface_fit

    n, centre, radii = 96, np.array([47.3, 44.8]), (14.3, 31.6)
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)
    r = np.linalg.norm(g - centre, axis=1)
    labels = np.searchsorted(radii, r).reshape(n, n)

    def errors():
        faces = relax_image(labels).interfaces()
        x = faces.points[faces.simplices].mean(axis=1)
        d = np.abs(np.linalg.norm(x - centre, axis=1) - np.take(radii, faces.pairs.min(axis=1)))
        return d.mean(), d.max()

    stiff = errors()
    monkeypatch.setattr(interface_fit, "STIFFNESS", (interface_fit.BETA,))
    soft = errors()
    assert stiff[0] < 0.025 and stiff[0] < 0.6 * soft[0] and stiff[1] < 0.5 * soft[1], (stiff, soft)


def test_a_curved_interface_between_junctions_is_not_fitted_across_its_pixels(monkeypatch):
    """A five-lobed flower cut in two by a line through it, on 128² pixels: its two curved
    interfaces run between the two junctions where the line meets it. The curvature prior
    of interfaces from fitted junctions, which holds straight ones straight, must not pull
    these across their pixels: fitted, they are no farther from the flower than as
    relaxed (the fit once doubled that distance)."""
    from scipy.spatial import cKDTree

    from ndboundary.pipeline import interface_fit

    n, centre = 128, np.array([63.3, 62.8])
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)
    v = g - centre
    radius = lambda t: 30.0 * (1.0 + 0.2 * np.cos(5.0 * t))  # noqa: E731
    inside = np.linalg.norm(v, axis=1) < radius(np.arctan2(v[:, 1], v[:, 0]))
    labels = np.where(inside, 0, np.where(v[:, 0] > 0.3 * v[:, 1], 1, 2)).reshape(n, n)
    t = np.linspace(0.0, 2.0 * np.pi, 20000)
    flower = cKDTree(centre + radius(t)[:, None] * np.stack([np.cos(t), np.sin(t)], axis=1))

    def mean_distance():
        faces = relax_image(labels).interfaces()
        x = faces.points[faces.simplices].mean(axis=1)
        return flower.query(x[faces.pairs.min(axis=1) == 0])[0].mean()

    fitted = mean_distance()
    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", False)
    relaxed = mean_distance()
    assert fitted < 1.05 * relaxed, (fitted, relaxed)


def test_an_arc_between_two_junctions_is_fitted_as_an_arc(monkeypatch):
    """A disc cut in two by a line, on 96² pixels: two T-junctions, each joined to the other
    by an arc. Fitted with their interfaces, the junctions lie within 0.15 pixel of the truth
    and the interfaces nearer it than as the junctions' fits leave them: the prior that
    holds an interface from a fitted junction straight gives way where it would hold the
    arc across its pixels."""
    from ndboundary.pipeline import interface_fit

    n, centre, radius = 96, np.array([47.3, 44.8]), 27.6
    u = np.array([np.cos(np.radians(70.0)), np.sin(np.radians(70.0))])
    normal = np.array([-u[1], u[0]])
    g = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="ij"), axis=-1).reshape(-1, 2).astype(float)
    outside = np.linalg.norm(g - centre, axis=1) > radius
    labels = np.where(outside, 1 + ((g - centre) @ normal > 0), 0).reshape(n, n)
    true = np.array([centre + radius * u, centre - radius * u])

    def errors():
        faces = relax_image(labels).interfaces()
        x = faces.points[faces.simplices].mean(axis=1)
        to_circle = np.abs(np.linalg.norm(x - centre, axis=1) - radius)
        d = np.where(faces.pairs.min(axis=1) == 0, to_circle, np.abs((x - centre) @ normal))
        inner = np.abs(x - n / 2).max(axis=1) < n / 2 - 2  # away from the image's border
        j = faces.junctions()
        found = j.points[j.simplices[:, 0]]
        return d[inner].mean(), np.linalg.norm(true[:, None] - found[None], axis=2).min(axis=1).max()

    fitted = errors()
    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", False)
    relaxed = errors()
    assert fitted[1] < 0.15 and fitted[0] < 0.7 * relaxed[0], (fitted, relaxed)


def test_the_field_is_smoothed_alike_along_every_axis_of_anisotropic_voxels(monkeypatch):
    """A ball on voxels three times as thick as they are wide: with every face neighbour
    weighing alike, a sweep smooths the field three times as far along the thick axis, and
    the surface bulges at the poles; weighed by the inverse square of their distance, the
    neighbours smooth it alike in every direction, and the surface lies at least twice as
    near the sphere at most."""
    from ndboundary.domains import image as image_module
    from ndboundary.metrics import sample_points

    n = 32
    shape, spacing = (n, n, n // 3 + 1), (1.0, 1.0, 3.0)
    centre, radius = np.array([0.085, -0.115, 0.155]), 0.32 * n
    origin = tuple(-(s - 1) / 2 * h for s, h in zip(shape, spacing, strict=True))
    x = np.indices(shape).reshape(3, -1).T * spacing + origin
    ball = (np.linalg.norm(x - centre, axis=1) < radius).reshape(shape)

    def errors():
        points = sample_points(relax_image(ball, spacing=spacing, origin=origin, fit=False).level_set())
        d = np.abs(np.linalg.norm(points - centre, axis=1) - radius)
        return d.mean(), d.max()

    alike = errors()
    monkeypatch.setattr(image_module, "anisotropic_smoothing", lambda domain, adjacency, passes: (adjacency, passes))
    uniform = errors()
    assert alike[1] < 0.5 * uniform[1] and alike[0] < 0.7 * uniform[0], (alike, uniform)


def _ball_volume(n, radius, centre):
    i, j, k = np.indices((n, n, n))
    return (i - centre[0]) ** 2 + (j - centre[1]) ** 2 + (k - centre[2]) ** 2 < radius**2


def test_a_surface_of_two_regions_is_fitted_to_its_voxels():
    """A ball of radius 10 on 28³ voxels: the relaxed surface moved to the one of least
    change of mean curvature that parts the voxel centres lies nearer the sphere than as
    relaxed (on average and at most), keeps the relaxed volume, and is the same surface
    when the two labels are swapped."""
    from ndboundary.metrics import sample_points

    centre, radius = np.array([13.63, 13.21, 13.87]), 10.0
    ball = _ball_volume(28, radius, centre)

    def errors(result):
        d = np.abs(np.linalg.norm(sample_points(result.level_set()) - centre, axis=1) - radius)
        return d.mean(), d.max()

    fitted, relaxed = relax_image(ball), relax_image(ball, fit=False)
    (mean, top), (mean0, top0) = errors(fitted), errors(relaxed)
    assert fitted.params["fitted_surface_vertices"] > 1000 and "fitted_surface_vertices" not in relaxed.params
    assert mean < 0.8 * mean0 and top < 0.7 * top0, (errors(fitted), errors(relaxed))
    np.testing.assert_allclose(fitted.region_measures(), relaxed.region_measures(), rtol=1e-5)
    swapped = relax_image(~ball)  # the same to the tolerance of the relaxation's iterative solves
    assert np.abs((swapped.phi - 0.5) + (fitted.phi - 0.5)).max() < 0.01


def test_surface_nets_of_a_sphere_are_closed_and_face_outwards():
    from ndboundary.pipeline.surface_fit import surface_mesh

    grid = ImageGrid((20, 40, 14), spacing=(1.0, 0.5, 1.5), origin=(2.0, -1.0, 0.5))
    c = grid.points.mean(axis=0)
    phi = 0.5 + 6.0 - np.linalg.norm(grid.points - c, axis=1)
    points, faces, normals, slopes = surface_mesh(grid, phi)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all() and points.shape[0] - counts.size + faces.shape[0] == 2  # closed, a sphere
    area = np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]])
    assert ((area * (points[faces].mean(axis=1) - c)).sum(axis=1) > 0).all()
    assert np.abs(np.linalg.norm(points - c, axis=1) - 6.0).max() < 0.15 and np.allclose(slopes, 1.0, atol=0.2)


def test_a_box_of_voxels_is_left_as_relaxed_and_fit_is_checked():
    """A box's edges turn sharper than a slowly changing curvature follows: its surface is
    not fitted. ``fit`` takes "auto", True or False only."""
    labels = np.zeros((20, 20, 20), dtype=bool)
    labels[5:15, 4:16, 6:13] = True
    result = relax_image(labels)
    assert "fitted_surface_vertices" not in result.params
    np.testing.assert_array_equal(result.phi, relax_image(labels, fit=False).phi)
    for bad in ("yes", 1, None):
        with pytest.raises(ValueError, match="fit must be"):
            relax_image(labels, fit=bad)
