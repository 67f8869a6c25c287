"""``ndboundary relax IMAGE``: label images and volumes from the shell."""

import numpy as np
import pytest

from _checks import read_vtp, stl_solids
from ndboundary import read_mesh
from ndboundary.cli import main


def _two_balls(n=32):
    """Background 0 with a ball of label 1 and a smaller one of label 2, apart."""
    i, j, k = np.indices((n, n, n)) * (32 / n)
    labels = np.zeros((n, n, n), dtype=np.int16)
    labels[(i - 9) ** 2 + (j - 15.5) ** 2 + (k - 15.5) ** 2 < 49] = 1
    labels[(i - 23) ** 2 + (j - 15.5) ** 2 + (k - 15.5) ** 2 < 36] = 2
    return labels


def _enclosed_volume(mesh):
    """The volume a closed, outward triangle surface encloses (divergence theorem)."""
    tri = mesh.points[mesh.simplices]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def _run(capsys, *argv):
    code = main(["relax", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_volume_surfaces_per_region_without_the_background(tmp_path, capsys):
    labels = _two_balls()
    np.save(tmp_path / "seg.npy", labels)
    code, out, err = _run(capsys, tmp_path / "seg.npy", "--surfaces", tmp_path / "parts", "--background", "0")
    assert code == 0, err
    files = sorted(p.name for p in (tmp_path / "parts").iterdir())
    assert files == ["region_1.obj", "region_2.obj"]  # no surface for the background
    for r, name in ((1, "region_1.obj"), (2, "region_2.obj")):
        volume = _enclosed_volume(read_mesh(tmp_path / "parts" / name))  # closed and outward
        assert volume == pytest.approx(float((labels == r).sum()), rel=0.015)
    assert "boundary closed" in out and "wrote 2 region boundaries" in out


def test_surfaces_written_show_their_progress_on_a_terminal(tmp_path, capsys, monkeypatch):
    """A large image relaxed on a terminal reports each region's relaxation, then each
    surface as it is written; off a terminal (a log) it reports neither."""
    import sys

    import ndboundary.cli_image

    np.save(tmp_path / "seg.npy", _two_balls())
    monkeypatch.setattr(ndboundary.cli_image, "PROGRESS_PIXELS", 1000)
    for tty in (True, False):
        monkeypatch.setattr(sys.stderr, "isatty", lambda tty=tty: tty)
        code, _, err = _run(capsys, tmp_path / "seg.npy", "--surfaces", tmp_path / f"parts{tty}", "--background", "0")
        assert code == 0
        lines = [line for line in err.splitlines() if line.startswith("[ndboundary] surface ")]
        assert ("[ndboundary] region 2/3: 1" in err) == tty
        if tty:
            assert [line.split(",")[0] for line in lines] == ["[ndboundary] surface 1/2: 1", "[ndboundary] surface 2/2: 2"]
            assert all(line.endswith(" triangles") for line in lines)
        else:
            assert lines == []


def test_volume_interfaces_as_stl_solids_and_surfaces_as_vtp(tmp_path, capsys):
    """``--boundary OUT.stl`` on a volume of three labels: one named solid per pair of
    regions that meet; ``--surface-format vtp``: each region's closed surface as VTK
    polygonal data."""
    labels = _two_balls()
    np.save(tmp_path / "seg.npy", labels)
    code, out, err = _run(
        capsys, tmp_path / "seg.npy", "--boundary", tmp_path / "i.stl", "--surfaces", tmp_path / "parts",
        "--surface-format", "vtp", "--background", "0",
    )  # fmt: skip
    assert code == 0, err
    solids = stl_solids(tmp_path / "i.stl")
    assert [name for name, _, _ in solids] == ["0|1", "0|2"]  # the balls are apart: no 1|2
    assert all(len(corners) > 100 for _, _, corners in solids)
    for r in (1, 2):
        back = read_vtp(tmp_path / "parts" / f"region_{r}.vtp")
        tri = back["Polys"]["connectivity"].reshape(-1, 3)
        p = back["Points"][""][tri]
        volume = float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)
        assert volume == pytest.approx(float((labels == r).sum()), rel=0.03)  # closed and outward


def test_two_label_image_phi_at_the_pixel_centres(tmp_path, capsys):
    i, j = np.indices((40, 30))
    disc = ((i - 19.5) ** 2 + (j - 14.5) ** 2 < 100).astype(np.uint8)
    np.save(tmp_path / "disc.npy", disc)
    code, out, err = _run(capsys, tmp_path / "disc.npy", "-o", tmp_path / "phi.npy", "--boundary", tmp_path / "b.obj")
    assert code == 0, err
    phi = np.load(tmp_path / "phi.npy")
    assert phi.shape == disc.shape and phi.dtype == np.float32
    r = np.hypot(i - 19.5, j - 14.5)
    assert (phi[r < 8] > 0.5).all() and (phi[r > 12] < 0.5).all()
    curve = read_mesh(tmp_path / "b.obj")
    assert curve.n_elements > 0


@pytest.mark.parametrize("band", ["auto", "none"])
def test_phi_of_three_labels_one_channel_per_region(tmp_path, capsys, band):
    """Three labels: -o writes one function per region at the pixel centres, in the labels'
    order; the largest is the pixel's own label, well inside each region above 1/2 and
    below it elsewhere. On the band (``auto``: a small disc and a strip on a large image)
    the pixels outside it are on their own region's side of every function, as the whole
    grid's are."""
    i, j = np.indices((300, 240))
    labels = np.where((i - 100.3) ** 2 + (j - 120.6) ** 2 < 15.0**2, 7, np.where(i > 250, 3, 0)).astype(np.int16)
    np.save(tmp_path / "seg.npy", labels)
    code, out, err = _run(capsys, tmp_path / "seg.npy", "-o", tmp_path / "phi.npy", "--band", band)
    assert code == 0, err
    phi = np.load(tmp_path / "phi.npy")
    assert phi.shape == labels.shape + (3,) and phi.dtype == np.float32 and np.isfinite(phi).all()
    classes = np.array([0, 3, 7])
    assert (classes[np.argmax(phi, axis=-1)] == labels).mean() > 0.999  # the partition at the pixel centres
    own = phi[..., [0, 1, 2]][labels[..., None] == classes]  # each pixel's own function
    far = (np.hypot(i - 100.3, j - 120.6) > 20) & (np.abs(i - 250) > 5) | (np.hypot(i - 100.3, j - 120.6) < 10)
    assert (own.reshape(labels.shape)[far] > 0.5).all()
    others = np.where(labels[..., None] == classes, -np.inf, phi).max(axis=-1)
    assert (others[far] < 0.5).all()


def test_phi_of_a_large_image_relaxed_on_its_band_covers_every_pixel(tmp_path, capsys):
    """A small disc on a large image is relaxed on its band: phi is written for every pixel,
    the band's own values there, and outside it its side of 1/2."""
    i, j = np.indices((300, 200))
    disc = ((i - 150.3) ** 2 + (j - 99.6) ** 2 < 15.0**2).astype(np.uint8)
    np.save(tmp_path / "disc.npy", disc)
    for band, name in (("auto", "phi.npy"), ("none", "whole.npy")):
        code, out, err = _run(capsys, tmp_path / "disc.npy", "-o", tmp_path / name, "--band", band)
        assert code == 0, err
    phi, whole = np.load(tmp_path / "phi.npy"), np.load(tmp_path / "whole.npy")
    assert phi.shape == disc.shape and np.isfinite(phi).all()
    np.testing.assert_array_equal(phi > 0.5, whole > 0.5)
    r = np.hypot(i - 150.3, j - 99.6)
    assert (phi[r > 60] < -1.0).all()  # outside the band: below every value of the band


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["seg.npy", "labels.txt", "-o", "o.vtu"], "a label image, which holds its labels"),
        (["m.obj"], "give its labels file too"),
        (["seg.npy", "-o", "phi.tif"], "TIFF is written without channels"),
        (["seg.npy", "--surfaces", "out", "--background", "7"], "not one of the labels"),
        (["flat.npy", "--surfaces", "out", "--surface-format", "stl"], "STL holds triangles"),
        (["flat.npy", "--boundary", "b.stl"], "STL holds triangles, and these boundaries are curves"),
        (["m.obj", "labels.txt", "-o", "o.vtu", "--fit", "no"], "--fit is for label images"),
    ],
)
def test_image_errors_write_nothing(tmp_path, capsys, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    np.save("seg.npy", _two_balls(12))
    np.save("flat.npy", np.eye(8, dtype=int))
    (tmp_path / "labels.txt").write_text("0\n1\n")
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    code, out, err = _run(capsys, *argv)
    assert code == 1 and message in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_background_frames_the_image_so_that_surfaces_close(tmp_path, capsys):
    """A region that meets the image's border: with --background its surface is closed by
    the frame; it encloses a volume between its voxels' and the smooth cylinder's."""
    labels = np.zeros((20, 20, 12), dtype=np.uint8)
    i, j, k = np.indices(labels.shape)
    labels[((i - 9.5) ** 2 + (j - 9.5) ** 2 < 30) & (k < 8)] = 1  # a cylinder standing on the border k = 0
    np.save(tmp_path / "c.npy", labels)
    code, out, err = _run(capsys, tmp_path / "c.npy", "--surfaces", tmp_path / "s", "--background", "0")
    assert code == 0, err
    surface = read_mesh(tmp_path / "s" / "region_1.obj")
    assert "boundary closed" in out
    assert labels.sum() < _enclosed_volume(surface) < np.pi * 30 * 8  # the voxels of the cylinder hold 6.6 % less


def test_fit_no_writes_the_relaxed_surface_of_two_labels(tmp_path, capsys):
    """A ball of two labels: by default its surface is fitted to the voxels, nearer the
    sphere than the relaxed one ``--fit no`` writes; both are closed and hold its volume."""
    i, j, k = np.indices((24, 24, 24))
    centre, radius = np.array([11.71, 11.38, 11.56]), 8.0
    ball = (i - centre[0]) ** 2 + (j - centre[1]) ** 2 + (k - centre[2]) ** 2 < radius**2
    np.save(tmp_path / "ball.npy", ball.astype(np.uint8))
    off = {}
    for fit in ("auto", "no"):
        code, out, err = _run(capsys, tmp_path / "ball.npy", "--boundary", tmp_path / f"{fit}.obj", "--fit", fit)
        assert code == 0, err
        surface = read_mesh(tmp_path / f"{fit}.obj")
        off[fit] = np.abs(np.linalg.norm(surface.points - centre, axis=1) - radius).max()
        assert abs(_enclosed_volume(surface)) == pytest.approx(4 / 3 * np.pi * radius**3, rel=0.01)  # closed
    assert off["auto"] < 0.8 * off["no"], off
