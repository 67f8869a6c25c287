"""The command line: the demo, help and errors."""

import subprocess
import sys
from pathlib import Path

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
