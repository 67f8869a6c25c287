"""The command line: the demo, help and errors."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ndboundary.cli import main


def test_demo_writes_boundaries_and_reports_fidelity(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "relaxed" in out and "jagged" in out
    for name in ("flower2d_relaxed.obj", "flower2d_jagged.obj", "ball3d_relaxed.obj", "flower2d.png",
                 "flower2d_phi.vtu", "ball3d_phi.vtu"):
        assert (tmp_path / name).stat().st_size > 0
    lines = (tmp_path / "flower2d_relaxed.obj").read_text().splitlines()
    assert any(line.startswith("l ") for line in lines) and any(line.startswith("v ") for line in lines)
    assert any(line.startswith("f ") for line in (tmp_path / "ball3d_relaxed.obj").read_text().splitlines())


def test_demo_without_out_writes_to_ndboundary_demo(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    folder = tmp_path / "ndboundary-demo"
    for name in ("flower2d_relaxed.obj", "flower2d_jagged.obj", "ball3d_relaxed.obj", "ball3d_jagged.obj",
                 "flower2d.png", "flower2d_phi.vtu", "ball3d_phi.vtu"):
        assert (folder / name).stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ndboundary-demo"]  # nothing beside the folder
    assert f"to {Path('ndboundary-demo')}/" in out
    assert str(Path("ndboundary-demo") / "flower2d.png") in out


def test_no_command_prints_help(capsys):
    assert main([]) == 2
    assert "demo" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["--help"], ["demo", "--help"]])
def test_help(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0
    assert "usage" in capsys.readouterr().out


def test_entry_point_runs_as_module():
    proc = subprocess.run([sys.executable, "-m", "ndboundary.cli", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0 and "demo" in proc.stdout


def test_relax_command_round_trip(tmp_path, capsys):
    from ndboundary import io
    from ndboundary.datasets import circle, kuhn_grid, label_by

    dom = kuhn_grid(20, 2, jitter=0.2, random_state=0)
    io.write_mesh(tmp_path / "m.obj", dom)
    io.write_labels(tmp_path / "l.txt", label_by(dom, circle))
    argv = ["relax", str(tmp_path / "m.obj"), str(tmp_path / "l.txt"), "-o", str(tmp_path / "phi.vtu"),
            "--boundary", str(tmp_path / "b.obj"), "--smoothing", "20"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "800 elements" in out and "1 component" in out and "total" in out
    assert (tmp_path / "phi.vtu").stat().st_size > 0
    meshio = pytest.importorskip("meshio")
    back = meshio.read(tmp_path / "phi.vtu")
    assert back.point_data["phi"].shape == (dom.n_vertices,)
    assert "l " in (tmp_path / "b.obj").read_text()


@pytest.mark.parametrize(
    "files, message",
    [
        (("missing.obj", "l.txt"), "no such file"),
        (("m.obj", "short.txt"), "holds 3 labels but"),
        (("m.obj", "one.txt"), "one class only"),
        (("bad.xyz", "l.txt"), "xyz"),
    ],
)
def test_relax_command_errors_are_one_line(tmp_path, capsys, files, message):
    from ndboundary import io
    from ndboundary.datasets import kuhn_grid

    dom = kuhn_grid(4, 2)
    io.write_mesh(tmp_path / "m.obj", dom)
    (tmp_path / "bad.xyz").write_text("nothing")
    io.write_labels(tmp_path / "l.txt", (dom.element_centroids()[:, 0] > 0).astype(int))
    io.write_labels(tmp_path / "short.txt", [0, 1, 0])
    io.write_labels(tmp_path / "one.txt", [1] * dom.n_elements)
    code = main(["relax", str(tmp_path / files[0]), str(tmp_path / files[1]), "-o", str(tmp_path / "o.vtu")])
    err = capsys.readouterr().err
    assert code != 0
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


# -- ndboundary relax: files are never lost, errors are one line ----------------------------------------------


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A folder, made the current one, holding m.obj (8x8 quads: 81 vertices, 64 elements) and el.txt."""
    from ndboundary import io
    from ndboundary.datasets import quad_grid

    monkeypatch.chdir(tmp_path)
    grid = quad_grid(8)
    io.write_mesh("m.obj", grid)
    io.write_labels("el.txt", _region(grid).astype(int))
    return tmp_path


def _region(domain, on="elements"):
    x = (domain.element_centroids() if on == "elements" else domain.points)[:, 0]
    return x > 0.1


def _torus(n=12):
    """A closed torus of n x n quads: n*n vertices and n*n elements."""
    from ndboundary import PolygonMesh

    a, b = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    u, v = 2 * np.pi * a / n, 2 * np.pi * b / n
    points = np.c_[(2 + 0.7 * np.cos(v)) * np.cos(u), (2 + 0.7 * np.cos(v)) * np.sin(u), 0.7 * np.sin(v)]

    def idx(i, j):
        return (i % n) * n + j % n

    quads = [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)] for i in range(n) for j in range(n)]
    return PolygonMesh(points, quads)


def _ring(m=64):
    """A closed polyline of m segments around the unit circle: m vertices and m elements."""
    from ndboundary import SimplicialComplex

    t = 2 * np.pi * np.arange(m) / m
    return SimplicialComplex(np.c_[np.cos(t), np.sin(t)], [[k, (k + 1) % m] for k in range(m)])


def _snapshot(folder):
    """Every entry under ``folder``: its bytes (files), its target (symbolic links) or "dir"."""
    out = {}
    for p in sorted(Path(folder).rglob("*")):
        key = p.relative_to(folder).as_posix()
        out[key] = os.readlink(p) if p.is_symlink() else "dir" if p.is_dir() else p.read_bytes()
    return out


def _relax(capsys, *argv):
    code = main(["relax", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def _one_error(err, *parts):
    assert err.startswith("ndboundary: error: ") and err.endswith("\n") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for part in parts:
        assert part in err, err


def _spy(monkeypatch, module, name):
    """Record the calls of ``module.name`` (passing them through)."""
    calls = []
    real = getattr(module, name)

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, spy)
    return calls


# 1. no output may be an input or another output (resolved paths: ./, .., symbolic and hard links)


def _clash_setup(folder):
    (folder / "link.obj").symlink_to("m.obj")
    os.link(folder / "m.obj", folder / "hard.obj")
    (folder / "sub").mkdir()
    (folder / "l.vtu").write_text((folder / "el.txt").read_text())  # labels read as text, whatever the extension


@pytest.mark.parametrize(
    "outputs, message",
    [
        (["-o", "o.vtu", "--boundary", "m.obj"], "--boundary m.obj is the same file as the mesh m.obj ({m})"),
        (["-o", "X.vtu", "--boundary", "X.vtu"], "--boundary X.vtu is the same file as -o X.vtu ({X})"),
        (["-o", "X.vtu", "--boundary", "./X.vtu"], "--boundary ./X.vtu is the same file as -o X.vtu ({X})"),
        (["-o", "X.vtu", "--boundary", "sub/../X.vtu"], "--boundary sub/../X.vtu is the same file as -o X.vtu"),
        (["-o", "o.vtu", "--boundary", "./m.obj"], "--boundary ./m.obj is the same file as the mesh m.obj"),
        (["-o", "o.vtu", "--boundary", "link.obj"], "--boundary link.obj is the same file as the mesh m.obj ({m})"),
        (["-o", "o.vtu", "--boundary", "hard.obj"], "--boundary hard.obj is the same file as the mesh m.obj"),
        (["-o", "l.vtu"], "-o l.vtu is the same file as the labels l.vtu"),
    ],
    ids=["boundary-is-mesh", "boundary-is-phi", "dot-slash", "dot-dot", "dot-slash-mesh", "symlink-to-mesh",
         "hard-link-to-mesh", "phi-is-labels"],
)
def test_relax_refuses_an_output_that_is_an_input(work, capsys, monkeypatch, outputs, message):
    _clash_setup(work)
    labels = "l.vtu" if "l.vtu" in outputs else "el.txt"
    before = _snapshot(work)
    relaxed = _spy(monkeypatch, __import__("ndboundary.pipeline").pipeline, "relax")
    code, out, err = _relax(capsys, "m.obj", labels, *outputs)
    assert code == 1 and out == ""
    _one_error(err, message.format(m=work.resolve() / "m.obj", X=work.resolve() / "X.vtu"), "choose another output")
    assert _snapshot(work) == before and not relaxed  # nothing written, nothing relaxed


# 2. each output is written to a temporary beside it, then moved onto it; a failure leaves no file


def test_relax_writes_through_a_temporary_beside_the_output(work, capsys, monkeypatch):
    from ndboundary import io

    calls = _spy(monkeypatch, io, "write_phi")
    boundary_calls = _spy(monkeypatch, io, "write_level_set")
    code, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--boundary", "b.obj")
    assert code == 0 and err == "" and "wrote o.vtu and b.obj" in out
    tmp_phi, tmp_boundary = Path(calls[-1][0][0]), Path(boundary_calls[-1][0][0])
    assert tmp_phi.parent == work.resolve() and tmp_phi.name.startswith(".o.vtu.tmp-") and tmp_phi.suffix == ".vtu"
    assert tmp_boundary.name.startswith(".b.obj.tmp-") and tmp_boundary.suffix == ".obj"
    assert sorted(_snapshot(work)) == ["b.obj", "el.txt", "m.obj", "o.vtu"]  # the temporaries are gone
    umask = os.umask(0)
    os.umask(umask)
    assert (work / "o.vtu").stat().st_mode & 0o777 == 0o666 & ~umask  # not mkstemp's 0o600


def test_relax_replacing_an_output_keeps_its_permissions(work, capsys):
    (work / "o.vtu").write_text("old")
    (work / "o.vtu").chmod(0o640)
    code, _, _ = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert code == 0 and (work / "o.vtu").read_bytes().startswith(b"<")
    assert (work / "o.vtu").stat().st_mode & 0o777 == 0o640


def test_relax_output_through_a_symbolic_link_writes_the_linked_file(work, capsys):
    (work / "real").mkdir()
    (work / "real" / "phi.vtu").write_text("old")
    (work / "link.vtu").symlink_to("real/phi.vtu")
    code, _, _ = _relax(capsys, "m.obj", "el.txt", "-o", "link.vtu")
    assert code == 0 and (work / "link.vtu").is_symlink()
    assert (work / "real" / "phi.vtu").read_bytes().startswith(b"<")


def _fail_midway(exc):
    def write(path, *args, **kwargs):
        Path(path).write_text("<VTKFile half-written")
        raise exc(path) if callable(exc) else exc

    return write


@pytest.mark.parametrize(
    "writer, error, code, message",
    [
        ("write_phi", lambda p: OSError(28, "No space left on device", str(p)), 1, "No space left on device: 'o.vtu'"),
        ("write_phi", lambda p: ValueError(f"{p}: could not write: KeyError: 'x'"), 1, "o.vtu: could not write"),
        ("write_level_set", lambda p: ValueError(f"{p}: cannot write"), 1, "b.obj: cannot write"),
        ("write_phi", lambda p: KeyboardInterrupt(), 130, None),
        ("write_level_set", lambda p: KeyboardInterrupt(), 130, None),
    ],
    ids=["phi-disk-full", "phi-writer-error", "boundary-fails-after-phi", "interrupt-in-phi", "interrupt-in-boundary"],
)
@pytest.mark.parametrize("existing", [False, True], ids=["new", "existing"])
def test_relax_failure_while_writing_leaves_no_file(work, capsys, monkeypatch, writer, error, code, message, existing):
    from ndboundary import io

    if existing:
        (work / "o.vtu").write_text("old phi")
        (work / "b.obj").write_text("old boundary")
    before = _snapshot(work)
    monkeypatch.setattr(io, writer, _fail_midway(error))
    got, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--boundary", "b.obj")
    assert got == code and out == ""
    if message is None:
        assert err == "ndboundary: interrupted\n"
    else:
        _one_error(err, message)
        assert ".tmp-" not in err  # the message names the output, not its temporary
    assert _snapshot(work) == before  # no output, no temporary, old outputs intact


def test_relax_interrupted_while_relaxing_writes_nothing(work, capsys, monkeypatch):
    import ndboundary.pipeline

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(ndboundary.pipeline, "relax", interrupted)
    before = _snapshot(work)
    code, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--boundary", "b.obj")
    assert code == 130 and out == "" and err == "ndboundary: interrupted\n"
    assert _snapshot(work) == before


# 3. the outputs are checked before the mesh is read and relaxed


def _denied_folder(monkeypatch, folder):
    real = os.access

    def access(path, mode, **kwargs):
        if Path(path).resolve() == Path(folder).resolve() and mode & os.W_OK:
            return False
        return real(path, mode, **kwargs)

    monkeypatch.setattr(os, "access", access)


@pytest.mark.parametrize(
    "outputs, message",
    [
        (["-o", "nodir/o.vtu"], "-o nodir/o.vtu: no such folder: nodir"),
        (["-o", "o.vtu", "--boundary", "nodir/sub/b.obj"], "--boundary nodir/sub/b.obj: no such folder: nodir/sub"),
        (["-o", "m.obj/o.vtu"], "-o m.obj/o.vtu: m.obj is not a folder"),
        (["-o", "locked/o.vtu"], "-o locked/o.vtu: the folder locked is not writable"),
        (["-o", "o.vtu", "--boundary", "locked/b.obj"], "--boundary locked/b.obj: the folder locked is not writable"),
        (["-o", "o.obj"], "-o o.obj: cannot write '.obj' files; use .vtk or .vtu"),
        (["-o", "phi"], "-o phi: cannot write extension-less files; use .vtk or .vtu"),
        (["-o", "o.vtu", "--boundary", "b.xyz"],
         "--boundary b.xyz: cannot write '.xyz' files; use .obj, .ply, .vtk or .vtu"),
        (["-o", "o.vtu", "--boundary", "b.stl"], "--boundary b.stl: cannot write '.stl' files"),
        (["-o", "folder.vtu"], "-o folder.vtu is a directory"),
    ],
    ids=["missing-folder", "missing-boundary-folder", "folder-is-a-file", "read-only-folder",
         "read-only-boundary-folder", "phi-extension", "no-extension", "boundary-extension", "boundary-stl",
         "output-is-a-directory"],
)
def test_relax_checks_the_outputs_before_reading_the_mesh(work, capsys, monkeypatch, outputs, message):
    import ndboundary.pipeline
    from ndboundary import io

    (work / "locked").mkdir()
    (work / "folder.vtu").mkdir()
    _denied_folder(monkeypatch, work / "locked")
    before = _snapshot(work)
    reads = _spy(monkeypatch, io, "read_mesh")
    relaxed = _spy(monkeypatch, ndboundary.pipeline, "relax")
    code, out, err = _relax(capsys, "m.obj", "el.txt", *outputs)
    assert code == 1 and out == ""
    _one_error(err, message)
    assert not reads and not relaxed and _snapshot(work) == before


def test_relax_refuses_a_read_only_output_file(work, capsys, monkeypatch):
    (work / "o.vtu").write_text("keep me")
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m, **k: False if Path(p).name == "o.vtu" else real(p, m, **k))
    code, _, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert code == 1 and (work / "o.vtu").read_text() == "keep me"
    _one_error(err, "-o o.vtu: the file exists and is read-only")


def test_relax_refuses_a_boundary_file_for_a_curve_before_relaxing(tmp_path, capsys, monkeypatch):
    import ndboundary.pipeline
    from ndboundary import io

    monkeypatch.chdir(tmp_path)
    ring = _ring()
    io.write_mesh("ring.obj", ring)
    io.write_labels("v.txt", _region(ring, "vertices").astype(int))
    relaxed = _spy(monkeypatch, ndboundary.pipeline, "relax")
    code, _, err = _relax(capsys, "ring.obj", "v.txt", "-o", "o.vtu", "--on", "vertices", "--boundary", "b.obj")
    assert code == 1 and not relaxed
    _one_error(err, "--boundary b.obj: the boundary on a curve is points, which no format holds")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ring.obj", "v.txt"]


# 4. labels of every dtype relax accepts reach the VTU file (booleans and strings as region indices 0/1)


@pytest.mark.parametrize(
    "name, make, expected",
    [
        ("lab.npy", lambda r: r, lambda r: r.astype(int)),
        ("lab.npy", lambda r: np.where(r, 5, -3).astype(np.int8), lambda r: np.where(r, 5, -3)),
        ("lab.npy", lambda r: np.where(r, 0.75, 0.25), lambda r: np.where(r, 0.75, 0.25)),
        ("lab.npy", lambda r: np.where(r, 0.75, 0.25).astype(np.float16), lambda r: np.where(r, 0.75, 0.25)),
        ("lab.npy", lambda r: np.where(r, 2, 1).astype(">i4"), lambda r: np.where(r, 2, 1)),
        ("lab.npy", lambda r: np.where(r, 2, 1).astype(np.uint64), lambda r: np.where(r, 2, 1)),
        ("lab.npy", lambda r: np.where(r, "tumour", "healthy"), lambda r: r.astype(int)),
        ("lab.txt", lambda r: np.where(r, "tumour", "healthy"), lambda r: r.astype(int)),
        ("lab.txt", lambda r: np.where(r, "True", "False"), lambda r: r.astype(int)),
        ("lab.txt", lambda r: np.where(r, 1.5, -0.5), lambda r: np.where(r, 1.5, -0.5)),
    ],
    ids=["bool-npy", "int8-npy", "float-npy", "float16-npy", "big-endian-int-npy", "uint64-npy", "string-npy",
         "string-txt", "bool-words-txt", "float-txt"],
)
def test_relax_writes_labels_of_every_dtype(work, capsys, name, make, expected):
    from ndboundary import io
    from ndboundary.datasets import quad_grid

    meshio = pytest.importorskip("meshio")
    region = _region(quad_grid(8))
    if name.endswith(".npy"):
        np.save(name, make(region))
    else:
        io.write_labels(name, make(region))
    code, out, err = _relax(capsys, "m.obj", name, "-o", "o.vtu", "--boundary", "b.obj")
    assert code == 0 and err == "" and "labels on elements" in out
    written = meshio.read(work / "o.vtu").cell_data["labels"][0]
    np.testing.assert_array_equal(written, expected(region))
    assert "l " in (work / "b.obj").read_text()


# 5. --on is required when the mesh has as many vertices as elements


@pytest.mark.parametrize(
    "mesh, on, labels_on, code, message",
    [
        ("torus", None, "elements", 1,
         "torus.obj has as many vertices as elements (144): say --on elements or --on vertices"),
        ("torus", "auto", "vertices", 1, "torus.obj has as many vertices as elements (144): say --on elements or"),
        ("torus", "elements", "elements", 0, "labels on elements"),
        ("torus", "vertices", "vertices", 0, "labels on vertices"),
        ("ring", None, "vertices", 1,
         "ring.obj has as many vertices as elements (64): say --on elements or --on vertices"),
        ("ring", "vertices", "vertices", 0, "labels on vertices"),
        ("ring", "elements", "elements", 0, "labels on elements"),
        ("grid", None, "elements", 0, "labels on elements"),
        ("grid", None, "vertices", 0, "labels on vertices"),
        ("grid", "vertices", "elements", 1,
         "holds 64 labels but grid.obj has 64 elements and 81 vertices (--on vertices)"),
    ],
    ids=["torus-auto", "torus-explicit-auto", "torus-elements", "torus-vertices", "polyline-auto",
         "polyline-vertices", "polyline-elements", "grid-auto-elements", "grid-auto-vertices", "grid-wrong-on"],
)
def test_relax_on_is_required_when_the_counts_are_equal(tmp_path, capsys, monkeypatch, mesh, on, labels_on, code,
                                                        message):
    from ndboundary import io
    from ndboundary.datasets import quad_grid

    monkeypatch.chdir(tmp_path)
    domain = {"torus": _torus, "ring": _ring, "grid": lambda: quad_grid(8)}[mesh]()
    io.write_mesh(f"{mesh}.obj", domain)
    io.write_labels("lab.txt", _region(domain, labels_on).astype(int))
    got, out, err = _relax(capsys, f"{mesh}.obj", "lab.txt", "-o", "o.vtu", *(["--on", on] if on else []))
    assert got == code
    if code:
        _one_error(err, message)
        assert not (tmp_path / "o.vtu").exists()
    else:
        assert message in out and (tmp_path / "o.vtu").stat().st_size > 0


# 6. numeric options are bounded; out of range is an argparse error: exit 2, one usage line, one error line


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--smoothing", "99999999999999999999999", "must be an integer in [0, 10000], got '99999999999999999999999'"),
        ("--smoothing", "10001", "must be an integer in [0, 10000], got '10001'"),
        ("--smoothing", "-1", "must be an integer in [0, 10000], got '-1'"),
        ("--smoothing", "2.5", "must be an integer in [0, 10000], got '2.5'"),
        ("--smoothing", "9" * 5000, "must be an integer in [0, 10000]"),
        ("--lam", "0", "must be a finite number in (0, 1e6], got '0'"),
        ("--lam", "-2", "must be a finite number in (0, 1e6], got '-2'"),
        ("--lam", "nan", "must be a finite number in (0, 1e6], got 'nan'"),
        ("--lam", "inf", "must be a finite number in (0, 1e6], got 'inf'"),
        ("--lam", "1e400", "must be a finite number in (0, 1e6], got '1e400'"),
        ("--lam", "1e7", "must be a finite number in (0, 1e6], got '1e7'"),
        ("--lam", "two", "must be a finite number in (0, 1e6], got 'two'"),
        ("--band", "0", "must be 'auto', 'none' or a width in units of h above 0, got '0'"),
        ("--band", "wide", "must be 'auto', 'none' or a width in units of h above 0, got 'wide'"),
        ("--band", "nan", "must be 'auto', 'none' or a width in units of h above 0, got 'nan'"),
    ],
    ids=["smoothing-huge", "smoothing-above", "smoothing-negative", "smoothing-float", "smoothing-5000-digits",
         "lam-zero", "lam-negative", "lam-nan", "lam-inf", "lam-overflow", "lam-above", "lam-word", "band-zero",
         "band-word", "band-nan"],
)
def test_relax_numeric_options_are_bounded(work, capsys, monkeypatch, option, value, message):
    from ndboundary import io

    reads = _spy(monkeypatch, io, "read_mesh")
    with pytest.raises(SystemExit) as exc:
        main(["relax", "m.obj", "el.txt", "-o", "o.vtu", f"{option}={value}"])
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert exc.value.code == 2 and out == "" and not reads and not (work / "o.vtu").exists()
    assert len(lines) == 2 and lines[0].startswith("usage: ndboundary relax")
    assert lines[1].startswith(f"ndboundary relax: error: argument {option}: ") and message in lines[1]


@pytest.mark.parametrize("option, value", [("--smoothing", "0"), ("--smoothing", "10000"), ("--lam", "1e6"),
                                           ("--lam", "1e-3")], ids=["smoothing-0", "smoothing-max", "lam-max",
                                                                    "lam-small"])
def test_relax_numeric_options_at_their_bounds_run(work, capsys, option, value):
    code, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", option, value)
    assert code == 0 and err == "" and "wrote o.vtu" in out


# 7. anything a user can type gives one line, never a traceback


def _write(name, content):
    def setup(folder):
        path = folder / name
        path.write_bytes(content) if isinstance(content, bytes) else path.write_text(content)

    return setup


@pytest.mark.parametrize(
    "mesh, labels, setup, message",
    [
        (".", "el.txt", None, "the mesh . is a directory, not a file"),
        ("d.obj", "el.txt", lambda f: (f / "d.obj").mkdir(), "the mesh d.obj is a directory, not a file"),
        ("m.obj", "d.txt", lambda f: (f / "d.txt").mkdir(), "the labels d.txt is a directory, not a file"),
        ("m.obj", "empty.txt", _write("empty.txt", ""), "empty.txt: no labels in the file"),
        ("m.obj", "comments.txt", _write("comments.txt", "# nothing\n\n"), "comments.txt: no labels in the file"),
        ("m.obj", "empty.npy", _write("empty.npy", b""), "empty.npy: could not read as .npy"),
        ("m.obj", "short.txt", _write("short.txt", "0\n1\n0\n"), "short.txt holds 3 labels but m.obj has 64 elements"),
        ("m.obj", "three.txt", _write("three.txt", "0\n1\n2\n" * 21 + "0\n"), "holds 3 classes; the command line relaxes two"),
        ("m.obj", "nan.txt", _write("nan.txt", "nan\n" + "1.0\n" * 63), "labels contain NaN"),
        ("m.obj", "bin.txt", _write("bin.txt", b"\xff\xfe\x00\x81" * 16), "bin.txt: not a text file of labels"),
        ("bad.vtu", "el.txt", _write("bad.vtu", "not xml"), "bad.vtu"),
        ("bad.obj", "el.txt", _write("bad.obj", "v 0 0 0\nf 1 2 3\n"), "bad.obj"),
        ("bin.obj", "el.txt", _write("bin.obj", b"\xff\xfe\x00\x81" * 16), "bin.obj"),
        ("m.xyz", "el.txt", _write("m.xyz", "v 0 0 0\n"), "unknown mesh format '.xyz'"),
    ],
    ids=["mesh-is-dot", "mesh-is-a-directory", "labels-is-a-directory", "empty-labels", "comment-only-labels",
         "empty-npy", "wrong-count", "three-classes", "nan-labels", "binary-labels", "corrupt-vtu", "bad-obj-index",
         "binary-obj", "unknown-mesh-format"],
)
def test_relax_user_errors_are_one_line(work, capsys, mesh, labels, setup, message):
    if setup:
        setup(work)
    before = _snapshot(work)
    code, out, err = _relax(capsys, mesh, labels, "-o", "o.vtu", "--boundary", "b.obj")
    assert code == 1 and out == ""
    _one_error(err, message)
    assert _snapshot(work) == before


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads every file")
@pytest.mark.parametrize("which", ["mesh", "labels"])
def test_relax_unreadable_input_chmod(work, capsys, which):
    path = work / ("m.obj" if which == "mesh" else "el.txt")
    path.chmod(0)
    code, _, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert code == 1 and not (work / "o.vtu").exists()
    _one_error(err, f"cannot read the {which} {path.name}: permission denied")


@pytest.mark.parametrize("which", ["mesh", "labels"])
def test_relax_unreadable_input(work, capsys, monkeypatch, which):
    name = "m.obj" if which == "mesh" else "el.txt"
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m, **k: False if Path(p).name == name else real(p, m, **k))
    code, _, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert code == 1 and not (work / "o.vtu").exists()
    _one_error(err, f"cannot read the {which} {name}: permission denied")


@pytest.mark.parametrize(
    "reader, exc, code, message",
    [
        ("read_mesh", PermissionError(13, "Permission denied", "m.obj"), 1, "[Errno 13] Permission denied: 'm.obj'"),
        ("read_labels", PermissionError(13, "Permission denied", "el.txt"), 1, "Permission denied: 'el.txt'"),
        ("read_mesh", RuntimeError("reader broke\non two lines"), 1, "RuntimeError: reader broke on two lines"),
        ("read_mesh", KeyError("CELLS"), 1, "KeyError: 'CELLS'"),
        ("read_mesh", MemoryError(), 1, "out of memory"),
        ("read_mesh", KeyboardInterrupt(), 130, None),
    ],
    ids=["mesh-permission-denied", "labels-permission-denied", "unexpected-error", "key-error", "out-of-memory",
         "interrupt-while-reading"],
)
def test_relax_errors_while_reading_are_one_line(work, capsys, monkeypatch, reader, exc, code, message):
    from ndboundary import io

    def fail(*args, **kwargs):
        raise exc

    monkeypatch.setattr(io, reader, fail)
    got, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert got == code and out == "" and not (work / "o.vtu").exists()
    if message is None:
        assert err == "ndboundary: interrupted\n"
    else:
        _one_error(err, message)


# 8. progress per step on a terminal, for large meshes, unless --quiet


@pytest.mark.parametrize(
    "tty, quiet, shown", [(True, False, True), (True, True, False), (False, False, False)],
    ids=["tty", "tty-quiet", "not-a-tty"],
)
def test_relax_progress_on_a_terminal(work, capsys, monkeypatch, tty, quiet, shown):
    import ndboundary.cli

    monkeypatch.setattr(ndboundary.cli, "PROGRESS_VERTICES", 50)  # the 8x8 grid counts as large
    monkeypatch.setattr(sys.stderr, "isatty", lambda: tty)
    code, out, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", *(["--quiet"] if quiet else []))
    assert code == 0 and "wrote o.vtu" in out
    assert ("[ndboundary] heat" in err and "[ndboundary] total" in err) == shown
    assert ("[ndboundary]" in err) == shown


def test_relax_without_meshio_fails_before_reading(work, capsys, monkeypatch):
    import importlib.util

    from ndboundary import io

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "meshio" else real(name, *a))
    reads = _spy(monkeypatch, io, "read_mesh")
    code, _, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu")
    assert code == 1 and not reads and not (work / "o.vtu").exists()
    _one_error(err, "-o o.vtu: writing .vtu needs meshio (pip install 'ndboundary[io]')")


def test_relax_band_option_reaches_relax_and_the_report(work, capsys):
    code, out, _ = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--band", "2")
    assert code == 0 and "on the band of 2 h around the jagged boundary" in out
    code, out, _ = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--band", "none")
    assert code == 0 and "(on the whole mesh)" in out
