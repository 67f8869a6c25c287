"""ndboundary.io.images: read_image / write_image round trips, geometry rules, 3D Slicer segmentations, errors."""

import sys

import numpy as np
import pytest

from ndboundary import read_image, write_image
from ndboundary.io import Image

nib = pytest.importorskip("nibabel")
nrrd = pytest.importorskip("nrrd")
tifffile = pytest.importorskip("tifffile")

SPACING = (0.6, 0.7, 4.0)
ORIGIN = (-98.25, 1.5, 30.125)
EXACT = {".nrrd": 0.0, ".nii": 1e-6, ".nii.gz": 1e-6, ".tif": 1e-9, ".tiff": 1e-9}  # NIfTI stores float32


def _labels(rng, shape, dtype):
    return rng.integers(0, 3, size=shape).astype(dtype)


def _rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


@pytest.mark.parametrize("suffix", [".nii", ".nii.gz", ".nrrd", ".tif", ".tiff"])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int32, np.int64])
@pytest.mark.parametrize("ndim", [2, 3])
def test_round_trip_keeps_labels_spacing_and_origin(tmp_path, rng, suffix, dtype, ndim):
    labels = _labels(rng, (5, 6, 7)[:ndim], dtype)
    path = tmp_path / f"labels{suffix}"
    write_image(path, labels, spacing=SPACING[:ndim], origin=ORIGIN[:ndim])
    image = read_image(path)
    assert image.labels.dtype == labels.dtype and np.array_equal(image.labels, labels)
    assert image.labels.flags.c_contiguous
    assert image.spacing == pytest.approx(SPACING[:ndim], rel=EXACT[suffix], abs=1e-12)
    assert image.origin == pytest.approx(ORIGIN[:ndim], rel=EXACT[suffix], abs=1e-12)
    assert image.direction is None and image.path == str(path)
    assert all(type(v) is float for v in image.spacing + image.origin)


@pytest.mark.parametrize("suffix", [".nii", ".nrrd", ".tif"])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_round_trip_of_a_float_volume(tmp_path, rng, suffix, dtype):
    phi = rng.normal(size=(4, 5, 6)).astype(dtype)
    path = tmp_path / f"phi{suffix}"
    write_image(path, phi, spacing=SPACING, origin=ORIGIN)
    image = read_image(path, labels=False)
    assert image.labels.dtype == dtype and np.array_equal(image.labels, phi)
    assert image.spacing == pytest.approx(SPACING, rel=EXACT[suffix])
    with pytest.raises(ValueError, match="fractional"):
        read_image(path)


@pytest.mark.parametrize("suffix", [".nii", ".nrrd", ".tif"])
def test_booleans_round_trip_as_zeros_and_ones(tmp_path, rng, suffix):
    mask = rng.random((4, 5, 6)) < 0.5
    write_image(tmp_path / f"mask{suffix}", mask, spacing=SPACING)
    assert np.array_equal(read_image(tmp_path / f"mask{suffix}").labels, mask)


def test_npy_round_trip_and_it_refuses_geometry(tmp_path, rng):
    labels = _labels(rng, (4, 5, 6), np.int16)
    write_image(tmp_path / "a.npy", labels)
    image = read_image(tmp_path / "a.npy")
    assert np.array_equal(image.labels, labels) and image.spacing == (1.0,) * 3 and image.origin == (0.0,) * 3
    with pytest.raises(ValueError, match="no spacing or origin"):
        write_image(tmp_path / "b.npy", labels, spacing=SPACING)


def test_rotated_affine_is_refused_unless_oblique(tmp_path, rng):
    labels = _labels(rng, (4, 5, 6), np.uint8)
    rot = _rotation(0.3)
    path = tmp_path / "oblique.nii.gz"
    write_image(path, labels, spacing=SPACING, origin=ORIGIN, direction=rot)
    with pytest.raises(ValueError, match=r"oblique\.nii\.gz.*not axis-aligned"):
        read_image(path)
    image = read_image(path, oblique=True)
    assert np.array_equal(image.labels, labels)
    assert np.allclose(image.direction, rot, atol=1e-6)
    assert image.spacing == pytest.approx(SPACING, rel=1e-6)
    index = np.array([1, 2, 3])
    assert np.allclose(image.centre(index), np.asarray(ORIGIN) + rot @ (index * SPACING), atol=1e-4)


def test_sheared_affine_is_refused_even_when_oblique(tmp_path):
    affine = np.diag([1.0, 1.0, 1.0, 1.0])
    affine[0, 1] = 0.5
    nib.save(nib.Nifti1Image(np.zeros((3, 4, 5), np.uint8), affine), tmp_path / "shear.nii")
    with pytest.raises(ValueError, match="not axis-aligned"):
        read_image(tmp_path / "shear.nii")
    with pytest.raises(ValueError, match=r"shear\.nii.*shears"):
        read_image(tmp_path / "shear.nii", oblique=True)


def _marked(shape, index):
    labels = np.zeros(shape, np.uint8)
    labels[index] = 7
    return labels


def test_flipped_nifti_axis_is_reversed_so_that_origin_plus_index_times_spacing_holds(tmp_path):
    shape, index = (4, 5, 6), (1, 2, 3)
    affine = np.diag([-0.5, 0.7, 2.0, 1.0])
    affine[:3, 3] = (10.0, -3.0, 1.0)
    nib.save(nib.Nifti1Image(_marked(shape, index), affine), tmp_path / "las.nii")
    world = (affine @ (*index, 1))[:3]
    image = read_image(tmp_path / "las.nii")
    assert image.spacing == pytest.approx((0.5, 0.7, 2.0)) and image.direction is None
    assert image.origin == pytest.approx((10.0 - 3 * 0.5, -3.0, 1.0))
    found = np.argwhere(image.labels == 7)[0]
    assert tuple(found) == (shape[0] - 1 - index[0], index[1], index[2])
    assert np.allclose(np.asarray(image.origin) + found * np.asarray(image.spacing), world)
    assert np.allclose(image.centre(found), world)


def test_flipped_nrrd_axis_is_reversed_too(tmp_path):
    shape, index = (4, 5, 6), (1, 2, 3)
    header = {"space": "left-posterior-superior", "space directions": np.diag([0.5, -0.7, 2.0])}
    header["space origin"] = np.array([10.0, -3.0, 1.0])
    nrrd.write(str(tmp_path / "flip.nrrd"), _marked(shape, index), header)
    world = header["space origin"] + np.diag(header["space directions"]) * index
    image = read_image(tmp_path / "flip.nrrd")
    found = np.argwhere(image.labels == 7)[0]
    assert tuple(found) == (index[0], shape[1] - 1 - index[1], index[2])
    assert image.spacing == pytest.approx((0.5, 0.7, 2.0))
    assert np.allclose(np.asarray(image.origin) + found * np.asarray(image.spacing), world)


def test_float_labels_with_fractions_or_nan_are_refused(tmp_path):
    np.save(tmp_path / "frac.npy", np.array([[0.0, 1.5], [1.0, 2.0]]))
    with pytest.raises(ValueError, match=r"frac\.npy.*fractional values such as 1\.5"):
        read_image(tmp_path / "frac.npy")
    np.save(tmp_path / "nan.npy", np.array([[0.0, np.nan], [1.0, 2.0]]))
    with pytest.raises(ValueError, match=r"nan\.npy.*NaN"):
        read_image(tmp_path / "nan.npy")
    np.save(tmp_path / "whole.npy", np.array([[0.0, 1.0], [1.0, 2.0]]))
    image = read_image(tmp_path / "whole.npy")
    assert image.labels.dtype == np.int64 and image.labels.tolist() == [[0, 1], [1, 2]]
    assert read_image(tmp_path / "frac.npy", labels=False).labels.dtype == np.float64
    np.save(tmp_path / "text.npy", np.array([["a", "b"], ["c", "d"]]))
    with pytest.raises(ValueError, match="dtype"):
        read_image(tmp_path / "text.npy")


def test_unknown_suffix_is_refused(tmp_path):
    (tmp_path / "labels.png").write_bytes(b"\x89PNG")
    with pytest.raises(ValueError, match=r"labels\.png.*unknown image format '\.png'"):
        read_image(tmp_path / "labels.png")
    with pytest.raises(ValueError, match="cannot write"):
        write_image(tmp_path / "labels.png", np.zeros((2, 2)))
    with pytest.raises(ValueError, match="cannot write"):
        write_image(tmp_path / "labels.seg.nrrd", np.zeros((2, 2)))


def test_dimensions_single_slices_become_2d(tmp_path):
    np.save(tmp_path / "line.npy", np.zeros((1, 5, 1)))
    with pytest.raises(ValueError, match=r"line\.npy.*2 or 3 axes"):
        read_image(tmp_path / "line.npy")
    np.save(tmp_path / "four.npy", np.zeros((2, 3, 4, 5)))
    with pytest.raises(ValueError, match=r"four\.npy.*2 or 3 axes"):
        read_image(tmp_path / "four.npy")
    affine = np.diag([0.5, 0.7, 3.0, 1.0])
    affine[:3, 3] = (1.0, 2.0, 9.0)
    nib.save(nib.Nifti1Image(np.ones((4, 5, 1), np.uint8), affine), tmp_path / "slice.nii")
    image = read_image(tmp_path / "slice.nii")
    assert image.labels.shape == (4, 5) and image.spacing == (0.5, 0.7) and image.origin == (1.0, 2.0)
    nib.save(nib.Nifti1Image(np.ones((4, 5, 6, 2), np.uint8), np.eye(4)), tmp_path / "time.nii")
    with pytest.raises(ValueError, match=r"time\.nii.*2 or 3 axes"):
        read_image(tmp_path / "time.nii")


@pytest.mark.parametrize("suffix", [".npy", ".nii", ".nrrd", ".tif"])
def test_no_overwrite_without_overwrite_true(tmp_path, suffix):
    path = tmp_path / f"labels{suffix}"
    write_image(path, np.ones((3, 4), np.uint8))
    before = path.read_bytes()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_image(path, np.zeros((3, 4), np.uint8))
    assert path.read_bytes() == before
    write_image(path, np.zeros((3, 4), np.uint8), overwrite=True)
    assert not read_image(path).labels.any()


def test_missing_package_says_how_to_install(tmp_path, monkeypatch):
    write_image(tmp_path / "a.nii", np.ones((3, 4), np.uint8))
    monkeypatch.setitem(sys.modules, "nibabel", None)
    with pytest.raises(ImportError, match=r"pip install 'ndboundary\[imaging\]'"):
        read_image(tmp_path / "a.nii")
    with pytest.raises(ImportError, match="nibabel"):
        write_image(tmp_path / "b.nii", np.ones((3, 4), np.uint8))


def _segment_keys(values, layers):
    header = {}
    for n, (value, layer) in enumerate(zip(values, layers, strict=True)):
        header |= {f"Segment{n}_ID": f"Segment_{n}", f"Segment{n}_Name": f"organ {n}"}
        header |= {f"Segment{n}_LabelValue": str(value), f"Segment{n}_Layer": str(layer)}
    return header


def test_seg_nrrd_label_map_keeps_its_values(tmp_path, rng):
    labels = rng.choice([0, 3, 5], size=(4, 5, 6)).astype(np.uint8)
    header = {"space": "left-posterior-superior", "space directions": np.diag(SPACING), "space origin": ORIGIN}
    nrrd.write(str(tmp_path / "a.seg.nrrd"), labels, header | _segment_keys([3, 5], [0, 0]))
    image = read_image(tmp_path / "a.seg.nrrd")
    assert np.array_equal(image.labels, labels) and image.spacing == SPACING and image.origin == ORIGIN


def _layered(tmp_path, layers, values, name="layers.seg.nrrd"):
    rows = np.vstack([np.full(3, np.nan), np.diag(SPACING)])
    header = {"space": "left-posterior-superior", "space directions": rows, "space origin": ORIGIN}
    header["kinds"] = ["list", "domain", "domain", "domain"]
    nrrd.write(str(tmp_path / name), np.stack(layers), header | _segment_keys(values, range(len(layers))))
    return tmp_path / name


def test_seg_nrrd_layers_are_combined_when_they_do_not_overlap(tmp_path):
    a, b = np.zeros((2, 4, 5, 6), np.uint8)
    a[0, :2], b[1, 2:] = 1, 1
    image = read_image(_layered(tmp_path, [a, b], [1, 1]))  # Slicer's older format: one segment per layer
    assert image.labels.shape == (4, 5, 6) and image.spacing == SPACING and image.origin == ORIGIN
    assert np.array_equal(image.labels, a + 2 * b)
    image = read_image(_layered(tmp_path, [a * 4, b * 9], [4, 9], "kept.seg.nrrd"))
    assert np.array_equal(image.labels, 4 * a + 9 * b)


def test_seg_nrrd_overlapping_layers_are_refused(tmp_path):
    a, b = np.zeros((2, 4, 5, 6), np.uint8)
    a[:, :3], b[:, 2:] = 1, 1
    with pytest.raises(ValueError, match=r"layers\.seg\.nrrd: segments 'organ 0' and 'organ 1' overlap"):
        read_image(_layered(tmp_path, [a, b], [1, 1]))


def test_tiff_spacing_from_imagej_metadata_and_resolution(tmp_path):
    labels = np.arange(3 * 4 * 5, dtype=np.uint16).reshape(3, 4, 5)
    meta = {"spacing": 2.5, "unit": "um", "axes": "ZYX", "xorigin": 10.0}
    tifffile.imwrite(tmp_path / "fiji.tif", labels, imagej=True, resolution=(1 / 0.25, 1 / 0.5), metadata=meta)
    image = read_image(tmp_path / "fiji.tif")
    assert np.array_equal(image.labels, labels)
    assert image.spacing == pytest.approx((2.5, 0.5, 0.25)) and image.origin == pytest.approx((0.0, 0.0, -2.5))
    tifffile.imwrite(tmp_path / "plain.tif", labels, photometric="minisblack", metadata=None)
    assert read_image(tmp_path / "plain.tif").spacing == (1.0, 1.0, 1.0)


def test_tiff_colour_image_is_refused(tmp_path):
    tifffile.imwrite(tmp_path / "rgb.tif", np.zeros((4, 5, 3), np.uint8), photometric="rgb")
    with pytest.raises(ValueError, match=r"rgb\.tif.*colour"):
        read_image(tmp_path / "rgb.tif")


def test_image_centre_applies_spacing_origin_and_direction():
    rotation = tuple(map(tuple, _rotation(np.pi / 2)))
    image = Image(np.zeros((2, 3, 4), np.uint8), (1.0, 2.0, 3.0), (1.0, 1.0, 1.0), direction=rotation)
    assert np.allclose(image.centre([[1, 1, 1]]), [[2.0, -2.0, 3.0]])


def test_shared_prostate_mask(shared_data):
    path = shared_data / "volumes" / "prostate_mask_00.nii"
    if not path.is_file():
        pytest.skip(f"{path} is absent")
    with pytest.raises(ValueError, match="not axis-aligned"):  # the scan is tilted about its x axis
        read_image(path)
    image = read_image(path, oblique=True)
    assert image.labels.shape == (320, 320, 15) and image.labels.dtype == np.uint8
    assert image.spacing == pytest.approx((0.6, 0.6000004, 4.000002), rel=1e-6)
    assert image.spacing == pytest.approx(nib.load(path).header.get_zooms(), rel=1e-6)
    assert np.unique(image.labels).tolist() == [0, 1, 2]
    affine = nib.load(path).affine
    for index in [(0, 0, 0), (100, 200, 7), (319, 319, 14)]:
        assert np.allclose(image.centre(index), (affine @ (*index, 1))[:3], atol=1e-4)


def test_write_refuses_geometry_the_format_cannot_hold(tmp_path):
    labels = np.zeros((3, 4, 5), np.uint8)
    with pytest.raises(ValueError, match="positive"):
        write_image(tmp_path / "a.nii", labels, spacing=(1.0, -1.0, 1.0))
    with pytest.raises(ValueError, match="one value or 3"):
        write_image(tmp_path / "a.nii", labels, spacing=(1.0, 2.0))
    with pytest.raises(ValueError, match="cannot hold a direction"):
        write_image(tmp_path / "a.tif", labels, direction=_rotation(0.2))
    with pytest.raises(ValueError, match="2-D or 3-D"):
        write_image(tmp_path / "a.nii", np.zeros(4))
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("ndim", [2, 3])
def test_channels_are_written_beside_the_spatial_axes(tmp_path, rng, ndim):
    """One value per channel (a function per region) and pixel: NIfTI's fourth axis after
    three spatial ones, with the spatial geometry in the affine; NRRD's list axis first,
    with no direction; .npy as given; TIFF refused."""
    values = rng.random((4, 5, 6)[:ndim] + (3,)).astype(np.float32)
    spacing, origin = SPACING[:ndim], ORIGIN[:ndim]
    write_image(tmp_path / "phi.nii.gz", values, spacing=spacing, origin=origin, channels=True)
    img = nib.load(tmp_path / "phi.nii.gz")
    assert img.shape == ((4, 5, 6) if ndim == 3 else (4, 5, 1)) + (3,)
    np.testing.assert_array_equal(np.asarray(img.dataobj).reshape(values.shape), values)
    np.testing.assert_allclose(img.affine[:ndim, :ndim], np.diag(spacing), atol=1e-6)
    np.testing.assert_allclose(img.affine[:ndim, 3], origin, atol=1e-6)
    write_image(tmp_path / "phi.nrrd", values, spacing=spacing, origin=origin, channels=True)
    data, header = nrrd.read(str(tmp_path / "phi.nrrd"))
    np.testing.assert_array_equal(np.moveaxis(data, 0, -1), values)
    assert header["kinds"] == ["list"] + ["domain"] * ndim
    assert np.isnan(header["space directions"][0]).all()
    np.testing.assert_allclose(header["space directions"][1:], np.diag(spacing))
    write_image(tmp_path / "phi.npy", values, channels=True)
    np.testing.assert_array_equal(np.load(tmp_path / "phi.npy"), values)
    with pytest.raises(ValueError, match="written without channels"):
        write_image(tmp_path / "phi.tif", values, channels=True)
    with pytest.raises(ValueError, match="and one axis of channels"):
        write_image(tmp_path / "bad.nii", values[..., 0, 0], channels=True)
    assert not (tmp_path / "phi.tif").exists() and not (tmp_path / "bad.nii").exists()
