"""The command line: the demo, help and errors."""

import subprocess
import sys

import pytest

from ndboundary.cli import main


def test_demo_writes_boundaries_and_reports_fidelity(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "relaxed" in out and "jagged" in out
    for name in ("flower2d_relaxed.obj", "flower2d_jagged.obj", "ball3d_relaxed.obj", "flower2d.png"):
        assert (tmp_path / name).stat().st_size > 0
    lines = (tmp_path / "flower2d_relaxed.obj").read_text().splitlines()
    assert any(line.startswith("l ") for line in lines) and any(line.startswith("v ") for line in lines)
    assert any(line.startswith("f ") for line in (tmp_path / "ball3d_relaxed.obj").read_text().splitlines())


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
