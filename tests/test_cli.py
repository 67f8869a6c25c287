"""The command line: the demo, help and errors."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from _checks import obj_groups
from ndboundary.cli import main


def test_demo_writes_boundaries_and_reports_fidelity(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "relaxed" in out and "jagged" in out
    for name in ("flower2d_relaxed.obj", "flower2d_jagged.obj", "ball3d_relaxed.obj", "flower2d.png",
                 "flower2d_phi.vtu", "ball3d_phi.vtu", "regions2d_interfaces.obj", "regions2d_phi.vtu",
                 "regions2d.png"):
        assert (tmp_path / name).stat().st_size > 0
    lines = (tmp_path / "flower2d_relaxed.obj").read_text().splitlines()
    assert any(line.startswith("l ") for line in lines) and any(line.startswith("v ") for line in lines)
    assert any(line.startswith("f ") for line in (tmp_path / "ball3d_relaxed.obj").read_text().splitlines())
    assert any(line.startswith("l ") for line in (tmp_path / "regions2d_interfaces.obj").read_text().splitlines())
    # the many-region case: interfaces near the true bisectors, every true junction found, areas close
    (line,) = [line for line in out.splitlines() if line.startswith("7 Voronoi regions")]
    mean, worst = (float(x) for x in re.search(r"interfaces ([\d.]+) h .*max ([\d.]+) h", line).groups())
    found, true = (int(x) for x in re.search(r"junctions (\d+) found, (\d+) true", line).groups())
    area = float(re.search(r"areas within ([\d.]+)%", line).group(1))
    assert mean < 0.12 and worst < 0.5 and found == true == 7 and area < 0.5
    assert str(tmp_path / "regions2d.png") in out


def test_demo_without_out_writes_to_ndboundary_demo(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    folder = tmp_path / "ndboundary-demo"
    for name in ("flower2d_relaxed.obj", "flower2d_jagged.obj", "ball3d_relaxed.obj", "ball3d_jagged.obj",
                 "flower2d.png", "flower2d_phi.vtu", "ball3d_phi.vtu", "regions2d_interfaces.obj", "regions2d_phi.vtu",
                 "regions2d.png"):
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
         "--boundary b.xyz: cannot write '.xyz' files; use .obj, .ply, .stl, .vtk, .vtp or .vtu"),
        (["-o", "folder.vtu"], "-o folder.vtu is a directory"),
    ],
    ids=["missing-folder", "missing-boundary-folder", "folder-is-a-file", "read-only-folder",
         "read-only-boundary-folder", "phi-extension", "no-extension", "boundary-extension",
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


def test_relax_refuses_stl_for_the_curves_of_a_2d_mesh_before_relaxing(work, capsys, monkeypatch):
    """STL holds triangles: the boundary of a 2-D mesh is curves, known once the mesh is read."""
    import ndboundary.pipeline

    before = _snapshot(work)
    relaxed = _spy(monkeypatch, ndboundary.pipeline, "relax")
    code, _, err = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--boundary", "b.stl")
    assert code == 1 and not relaxed and _snapshot(work) == before
    _one_error(err, "--boundary b.stl: STL holds triangles, and these boundaries are curves; use .obj, .ply, .vtk")


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
        ("m.obj", "one.txt", _write("one.txt", "7\n" * 64), "one.txt: the labels hold one class only (7); two or more"),
        ("m.obj", "nan.txt", _write("nan.txt", "nan\n" + "1.0\n" * 63), "labels contain NaN"),
        ("m.obj", "bin.txt", _write("bin.txt", b"\xff\xfe\x00\x81" * 16), "bin.txt: not a text file of labels"),
        ("bad.vtu", "el.txt", _write("bad.vtu", "not xml"), "bad.vtu"),
        ("bad.obj", "el.txt", _write("bad.obj", "v 0 0 0\nf 1 2 3\n"), "bad.obj"),
        ("bin.obj", "el.txt", _write("bin.obj", b"\xff\xfe\x00\x81" * 16), "bin.obj"),
        ("m.xyz", "el.txt", _write("m.xyz", "v 0 0 0\n"), "unknown mesh format '.xyz'"),
    ],
    ids=["mesh-is-dot", "mesh-is-a-directory", "labels-is-a-directory", "empty-labels", "comment-only-labels",
         "empty-npy", "wrong-count", "one-class", "nan-labels", "binary-labels", "corrupt-vtu", "bad-obj-index",
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


# 9. three or more labels: phi per region, the interfaces, the partition and every region's boundary


def _sector_labels(domain, names):
    """Three sectors around the origin, by element centroid, labelled ``names``."""
    c = domain.element_centroids()
    sector = np.floor((np.arctan2(c[:, 1], c[:, 0]) + np.pi) / (2 * np.pi / 3)).astype(int) % 3
    return np.asarray(names)[sector]


def _ball_in_halves(domain):
    """A ball (label 2) inside the two halves x < 0 (label 0) and x > 0 (label 1), by element centroid."""
    c = domain.element_centroids()
    return np.where(np.linalg.norm(c, axis=1) < 0.5, 2, np.where(c[:, 0] < 0, 0, 1))


def _every_edge_twice(triangles):
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    return bool(np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2))


def _enclosed_volume(points, triangles):
    p = points[triangles]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6)


def _triangle_areas(points, triangles):
    (x0, y0), (x1, y1), (x2, y2) = (points[triangles[:, i]].T for i in range(3))
    return 0.5 * np.abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0))


def _region_lines(out):
    return [line for line in out.splitlines() if line.startswith("region ")]


@pytest.fixture
def regions(tmp_path, monkeypatch):
    """A folder, made the current one, holding m.obj (jittered triangles 30x30 of [-1, 1]^2) with tissue.txt
    (three sectors: air, soft tissue, bone), and m3.vtu (jittered tetrahedra 10^3) with ball.txt (a ball
    inside two halves).
    """
    pytest.importorskip("meshio")
    from ndboundary import io
    from ndboundary.datasets import kuhn_grid

    monkeypatch.chdir(tmp_path)
    grid = kuhn_grid(30, 2, jitter=0.2, random_state=0)
    io.write_mesh("m.obj", grid)
    io.write_labels("tissue.txt", _sector_labels(grid, ["air", "soft tissue", "bone"]))
    solid = kuhn_grid(10, 3, jitter=0.2, random_state=0)
    io.write_mesh("m3.vtu", solid)
    io.write_labels("ball.txt", _ball_in_halves(solid))
    return tmp_path


def test_relax_three_labels_writes_phi_interfaces_partition_and_region_boundaries(regions, capsys):
    import meshio

    from ndboundary import read_labels, read_mesh, relax

    code, out, err = _relax(capsys, "m.obj", "tissue.txt", "-o", "phi.vtu", "--boundary", "b.obj",
                            "--partition", "p.vtu", "--region-surfaces", "new/out")
    assert code == 0 and err == ""
    res = relax(read_mesh("m.obj"), read_labels("tissue.txt"), on="elements")
    names = ["air", "bone", "soft_tissue"]  # the classes in order, made safe for names
    # -o: one phi per region, the labels as their region index
    back = meshio.read("phi.vtu")
    assert sorted(back.point_data) == [f"phi_{n}" for n in names]
    for r, name in enumerate(names):
        np.testing.assert_allclose(back.point_data[f"phi_{name}"], res.phi[:, r], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.cell_data["labels"][0], np.searchsorted(res.classes, read_labels("tissue.txt")))
    # --partition: the refined cells, whose measures per region sum to the domain's
    part = meshio.read("p.vtu")
    tri = part.cells[0].data
    area = _triangle_areas(part.points[:, :2], tri)
    by_region = np.bincount(part.cell_data["region"][0], weights=area, minlength=3)
    np.testing.assert_allclose(by_region, res.region_measures(), rtol=1e-9)
    assert by_region.sum() == pytest.approx(4.0, rel=1e-12)  # the square [-1, 1]^2
    # --boundary: one OBJ group per pair of regions, named after the two classes
    pairs, counts = np.unique(res.interfaces().pairs, axis=0, return_counts=True)
    assert obj_groups("b.obj") == [(f"{names[i]}|{names[j]}", int(n)) for (i, j), n in zip(pairs, counts, strict=True)]
    # --region-surfaces: one curve per region, in the folder made for them
    assert sorted(os.listdir("new/out")) == [f"region_{n}.obj" for n in names]
    for r, name in enumerate(names):
        curve, boundary = read_mesh(f"new/out/region_{name}.obj"), res.region_boundary(r)
        assert curve.simplex_dim == 1 and curve.n_elements == boundary.n_simplices
        assert curve.A.sum() == pytest.approx(boundary.measure(), rel=1e-12)
    assert "961 vertices, 1800 elements, labels on elements, 3 regions" in out
    lines = _region_lines(out)
    assert [line.split(":")[0] for line in lines] == ["region 0 (air)", "region 1 (bone)", "region 2 (soft tissue)"]
    assert all(line.endswith(", open") for line in lines)  # every sector meets the border of the square
    for line, measure in zip(lines, res.region_measures(), strict=True):
        assert float(line.split("area ")[1].split(",")[0]) == pytest.approx(measure, rel=1e-5)
    assert "wrote phi.vtu, b.obj, p.vtu and 3 region boundaries to new/out" in out


def test_relax_three_labels_on_a_solid_region_surfaces_are_closed_and_enclose_their_volume(regions, capsys):
    from ndboundary import read_labels, read_mesh, relax

    code, out, err = _relax(capsys, "m3.vtu", "ball.txt", "-o", "phi.vtu", "--boundary", "b.obj",
                            "--region-surfaces", "obj")
    assert code == 0 and err == ""
    res = relax(read_mesh("m3.vtu"), read_labels("ball.txt"), on="elements")
    volumes = res.region_measures()
    ball = read_mesh("obj/region_2.obj")
    assert ball.simplex_dim == 2 and _every_edge_twice(ball.simplices)
    assert _enclosed_volume(ball.points, ball.simplices) == pytest.approx(volumes[2], rel=1e-9)  # outward
    for r in (0, 1):  # the halves meet the border of the cube: their boundaries are open
        assert not _every_edge_twice(read_mesh(f"obj/region_{r}.obj").simplices)
    lines = _region_lines(out)
    assert lines[2].startswith("region 2 (2): volume ") and lines[2].endswith(", closed")
    assert lines[0].endswith(", open") and lines[1].endswith(", open")
    pairs, counts = np.unique(res.interfaces().pairs, axis=0, return_counts=True)
    assert obj_groups("b.obj") == [(f"{i}|{j}", int(n)) for (i, j), n in zip(pairs, counts, strict=True)]
    # STL, for 3-D printing: binary float32 corners, welded on reading into the same closed surface
    code, _, _ = _relax(capsys, "m3.vtu", "ball.txt", "-o", "phi.vtu", "--region-surfaces", "stl",
                        "--surface-format", "stl")
    assert code == 0 and sorted(os.listdir("stl")) == ["region_0.stl", "region_1.stl", "region_2.stl"]
    printed = read_mesh("stl/region_2.stl")
    assert printed.n_elements == ball.n_elements and _every_edge_twice(printed.simplices)
    assert _enclosed_volume(printed.points, printed.simplices) == pytest.approx(volumes[2], rel=1e-6)


@pytest.mark.parametrize("fmt", ["ply", "vtk"])
def test_relax_region_surfaces_in_other_formats(regions, capsys, fmt):
    import meshio

    code, _, _ = _relax(capsys, "m3.vtu", "ball.txt", "-o", "phi.vtu", "--region-surfaces", "s",
                        "--surface-format", fmt)
    assert code == 0 and sorted(os.listdir("s")) == [f"region_{r}.{fmt}" for r in range(3)]
    assert meshio.read(f"s/region_2.{fmt}").cells[0].type == "triangle"


def test_relax_two_labels_writes_the_partition_and_both_region_boundaries(work, capsys):
    import meshio

    code, out, _ = _relax(capsys, "m.obj", "el.txt", "-o", "o.vtu", "--boundary", "b.obj", "--partition", "p.vtu",
                          "--region-surfaces", "out")
    assert code == 0 and "1 component" in out and len(_region_lines(out)) == 2
    assert sorted(os.listdir("out")) == ["region_0.obj", "region_1.obj"]
    part = meshio.read("p.vtu")
    tri = part.cells[0].data
    assert _triangle_areas(part.points[:, :2], tri).sum() == pytest.approx(4.0, rel=1e-12)
    assert set(part.cell_data["region"][0]) == {0, 1}
    assert "g " not in (work / "b.obj").read_text()  # two labels: the relaxed level set, as before


def _copy(src, dst):
    def setup(folder):
        (folder / dst).parent.mkdir(parents=True, exist_ok=True)
        (folder / dst).write_bytes((folder / src).read_bytes())

    return setup


@pytest.mark.parametrize(
    "mesh, extra, setup, message",
    [
        ("m.obj", ["--region-surfaces", "out", "--surface-format", "stl"], None,
         "--surface-format stl: STL holds triangles, and the region boundaries on a 2-D mesh are curves; use obj"),
        ("out/region_air.obj", ["--region-surfaces", "out"], _copy("m.obj", "out/region_air.obj"),
         "--region-surfaces out/region_air.obj is the same file as the mesh out/region_air.obj"),
        ("m.obj", ["--region-surfaces", "out"], lambda f: (f / "out" / "region_bone.obj").mkdir(parents=True),
         "--region-surfaces out/region_bone.obj is a directory"),
        ("m.obj", ["--region-surfaces", "tissue.txt"], None, ("--region-surfaces tissue.txt: ", "is not a folder")),
        ("m.obj", ["--boundary", "out/region_air.obj", "--region-surfaces", "out"], lambda f: (f / "out").mkdir(),
         "--region-surfaces out/region_air.obj is the same file as --boundary out/region_air.obj"),
        ("m.obj", ["--region-surfaces", "out", "--surface-format", "vtk", "--partition", "p.obj"], None,
         "--partition p.obj: cannot write '.obj' files; use .vtk or .vtu"),
    ],
    ids=["stl-in-2d", "region-file-is-the-mesh", "region-file-is-a-folder", "folder-is-a-file",
         "region-file-is-the-boundary", "partition-extension"],
)
def test_relax_region_surfaces_errors_write_nothing(regions, capsys, monkeypatch, mesh, extra, setup, message):
    import ndboundary.pipeline

    if setup:
        setup(regions)
    before = _snapshot(regions)
    relaxed = _spy(monkeypatch, ndboundary.pipeline, "relax")
    code, out, err = _relax(capsys, mesh, "tissue.txt", "-o", "o.vtu", *extra)
    assert code == 1 and out == "" and not relaxed
    _one_error(err, *([message] if isinstance(message, str) else message))
    assert _snapshot(regions) == before  # no file, no folder made


def test_relax_region_surfaces_of_a_curve_are_points(tmp_path, capsys, monkeypatch):
    from ndboundary import io

    monkeypatch.chdir(tmp_path)
    ring = _ring()
    io.write_mesh("ring.obj", ring)
    io.write_labels("v.txt", np.digitize(ring.points[:, 0], [-0.3, 0.3]))
    code, _, err = _relax(capsys, "ring.obj", "v.txt", "-o", "o.vtu", "--on", "vertices", "--region-surfaces", "out")
    assert code == 1 and sorted(os.listdir(tmp_path)) == ["ring.obj", "v.txt"]
    _one_error(err, "--region-surfaces out: the region boundaries on a curve are points, which no format holds")


def test_relax_region_surfaces_replace_existing_files_like_every_output(regions, capsys):
    (regions / "out").mkdir()
    (regions / "out" / "region_air.obj").write_text("old")
    (regions / "out" / "notes.txt").write_text("mine")
    code, _, _ = _relax(capsys, "m.obj", "tissue.txt", "-o", "o.vtu", "--region-surfaces", "out")
    assert code == 0
    assert (regions / "out" / "region_air.obj").read_text().startswith("# written by ndboundary")
    assert sorted(os.listdir(regions / "out")) == ["notes.txt", "region_air.obj", "region_bone.obj",
                                                   "region_soft_tissue.obj"]


@pytest.mark.parametrize("error, code", [(lambda p: ValueError(f"{p}: cannot write"), 1),
                                         (lambda p: KeyboardInterrupt(), 130)], ids=["error", "interrupt"])
def test_relax_failure_while_writing_a_region_boundary_leaves_nothing(regions, capsys, monkeypatch, error, code):
    from ndboundary import io

    before = _snapshot(regions)
    monkeypatch.setattr(io, "write_level_set", _fail_midway(error))
    got, out, err = _relax(capsys, "m.obj", "tissue.txt", "-o", "o.vtu", "--boundary", "b.obj",
                           "--partition", "p.vtu", "--region-surfaces", "a/b")
    assert got == code and out == ""
    if code == 1:
        _one_error(err, "a/b/region_air.obj: cannot write")
    assert _snapshot(regions) == before  # no output, no temporary, and the folders made for them removed


@pytest.mark.parametrize("band", ["auto", "3"])
def test_relax_three_labels_progress_per_region(regions, capsys, monkeypatch, band):
    import ndboundary.cli

    monkeypatch.setattr(ndboundary.cli, "PROGRESS_VERTICES", 50)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    code, _, err = _relax(capsys, "m.obj", "tissue.txt", "-o", "o.vtu", "--band", band)
    assert code == 0
    chunks = re.split(r"\[ndboundary\] region (\d)/3: (.*)\n", err)
    assert chunks[0] == "" and chunks[1::3] == ["1", "2", "3"] and chunks[2::3] == ["air", "bone", "soft tissue"]
    for steps in chunks[3::3]:  # each region's own steps, up to its total (and, on a band, its fill)
        assert steps.count("[ndboundary] heat") == 1 and steps.count("[ndboundary] total") == 1
        assert ("[ndboundary] fill" in steps) == (band == "3")


def test_relax_help_states_the_auto_band(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["relax", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert exc.value.code == 0 and "--region-surfaces DIR" in text and "--partition OUT.vtu" in text
    assert (
        "default auto: 8 mean edge lengths on simplices, 12 on quads, polygons and hexahedra, in every "
        "dimension, wider for a weak boundary term" in text
    )
    assert "30 on surfaces" not in text
