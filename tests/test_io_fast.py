"""The compiled readers and writers of ndboundary.io against the line-by-line ones they stand for.

Every text file here is read twice through ``read_mesh``: by the scans (``FAST_MIN_BYTES`` set
to 0) and line by line (``FAST_MIN_BYTES`` above the file's size). Both must give the same
domain, or the same error with the same message; and where the scans read the file
themselves (no fallback), their points and cells must equal the line reader's.
"""

import decimal
import re
from pathlib import Path

import numpy as np
import pytest

from ndboundary import PolygonMesh, SimplicialComplex, read_mesh, write_mesh
from ndboundary import datasets as ds
from ndboundary.io import common
from ndboundary.io.common import flat_rows
from ndboundary.io.obj import read_obj_lines, scan_obj_bytes, write_obj
from ndboundary.io.meshio_formats import read_with_meshio
from ndboundary.io.off import read_off_lines, scan_off_bytes, write_off
from ndboundary.io.ply import scan_ply_bytes, write_ascii_ply
from ndboundary.io.text_format import points_text, rows_text
from ndboundary.io.text_numbers import fill_slow
from ndboundary.io.text_scan import float_rows

MESHES = Path(__file__).resolve().parents[2] / "shared" / "data" / "meshes"
SQ = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
SQ_OFF = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n"


def _compiled(monkeypatch, on=True):
    """Whether the compiled scans, formatting and edge counts run for inputs of any size, or for none."""
    monkeypatch.setattr(common, "FAST_MIN_BYTES", 0 if on else 1 << 62)
    monkeypatch.setattr(common, "FAST_MIN_VALUES", 0 if on else 1 << 62)


def _outcome(path, fast, monkeypatch):
    """``read_mesh(path)`` by the scans or line by line: the domain, or the error message."""
    _compiled(monkeypatch, fast)
    try:
        return read_mesh(path), None
    except ValueError as exc:
        return None, str(exc)


def _same_domain(a, b):
    assert type(a) is type(b)
    np.testing.assert_array_equal(a.points, b.points)
    if isinstance(a, SimplicialComplex):
        np.testing.assert_array_equal(a.simplices, b.simplices)
    else:
        np.testing.assert_array_equal(a.indices, b.indices)
        np.testing.assert_array_equal(a.offsets, b.offsets)
    assert (a.weld is None) == (b.weld is None)


def _normal(blocks):
    """The cells of blocks as (dimension, flat indices, sizes), whatever blocks and containers a reader used."""
    out = {}
    for kind, data in blocks:
        flat, sizes = flat_rows(data)
        dim = 1 if kind == "line" else 2
        out[dim] = (out.get(dim, ([], []))[0] + flat.tolist(), out.get(dim, ([], []))[1] + sizes.tolist())
    return sorted(out.items())


def assert_same_read(path, monkeypatch, domains=True):
    """The scans and the line reader agree on ``path`` (domain or error); returns whether the scans read it."""
    data = path.read_bytes().removeprefix(b"\xef\xbb\xbf")
    ext = path.suffix
    fast = {".obj": scan_obj_bytes, ".off": scan_off_bytes}[ext](data)
    if domains:
        (a, err_a), (b, err_b) = _outcome(path, True, monkeypatch), _outcome(path, False, monkeypatch)
        assert err_a == err_b
        if a is not None:
            _same_domain(a, b)
    if fast is not None:
        points, blocks = (read_obj_lines if ext == ".obj" else read_off_lines)(path)
        np.testing.assert_array_equal(fast[0], points)
        assert np.array_equal(np.signbit(fast[0]), np.signbit(points))
        assert _normal(fast[1]) == _normal(blocks)
    return fast is not None


READ_BY_SCANS = {
    "triangles": SQ + "f 1 2 3\nf 1 3 4\n",
    "slashes": SQ + "vt 0 0\nvn 0 0 1\nf 1/1 2/1 3/1\nf 1//1 3//1 4//1\nf 2/1/1 3/x 4/\n",
    "relative": SQ + "f -4 -3 -2\nv 2 2 0\nf -1 -3 -4\n",
    "forward": "f 1 2 3\n" + SQ,
    "groups-comments": "# made by hand, é\n" + SQ + "g g\u00e9\no o\nusemtl m\ns 1\n\n# f 9 9 9\nf 1 2 3 4\n",
    "crlf": (SQ + "f 1 2 3 4\n").replace("\n", "\r\n"),
    "cr": (SQ + "f 1 2 3 4\n").replace("\n", "\r"),
    "blanks": SQ.replace(" ", "\t") + "f\t1\x0b2 \x0c3\x1c4  \n",
    "mixed-polygons": SQ + "v 2 0.5 0\nf 1 2 3 4\nf 2 5 3\n",
    "quads": SQ + "v 2 0 0\nv 2 1 0\nf 1 2 3 4\nf 2 5 6 3\n",
    "planar": "v 0 0\nv 1 0\nv 0 1\nf 1 2 3\n",
    "w-and-colours": "v 0 0 0 1\nv 1 0 0 1 0.5 0.5\nv 0 1 0 x y\nf 1 2 3\n",
    "polylines": SQ + "l 1 2 3\nl 4\nl\nl -1 -4\n",
    "faces-over-lines": SQ + "l 1 2\nf 1 2 3\n",
    "numbers": "v 1e-5 +2.5E+3 -.5\nv 5. 0.000 -0\nv 1.23456789012345678901234 1e1 1\nf +1 02 3\n",
    "no-newline": SQ + "f 1 2 3",
    "bom": "\ufeff" + SQ + "f 1 2 3\n",
    "lookalike-keys": SQ + "vv 1\nff 1 2\nF 1\nv\x00 9 9 9\nf 1 2 3\n",
    "off": SQ_OFF + "3 0 1 2\n3 0 2 3\n",
    "off-counts-on-keyword": "OFF 4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    "off-colours-comments": "COFF # colours\n\n4 1 0\n0 0 0 1 0 0\n1 0 0 é\n1 1 0#c\n0 1 0\n# face\n4 0 1 2 3 9 9 9\n",
    "off-crlf": (SQ_OFF + "3 0 1 2\n3 0 2 3\n\n").replace("\n", "\r\n"),
    "off-mixed": "OFF\n5 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0.5 0\n4 0 1 2 3\n3 1 4 2\n",
    "off-bom": "\ufeff" + SQ_OFF + "3 0 1 2\n3 0 2 3\n",
}
#: Files the scans leave to the line reader: errors (each with its line), and what they do not read.
LEFT_TO_LINES = {
    "bad-number": ("v 0 0 zero\n", r"line 1 is not valid OBJ: 'v 0 0 zero'"),
    "past": (SQ + "f 1 3 99\n", r"line 5: vertex index 99 is past the last vertex"),
    "zero": (SQ + "f 0 1 2\n", r"line 5: vertex index 0; OBJ vertex indices start at 1"),
    "before-first": (SQ + "f -1 -2 -5\n", r"line 5: relative vertex index -5 reaches before the first vertex"),
    "two-vertex-face": (SQ + "f 1 2\n", r"line 5: a face needs at least 3 vertices; got 2"),
    "mixed-width": ("v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", r"line 2: a vertex with 3 coordinates; line 1 has 2"),
    "comment-in-face": (SQ + "f 1 2 3 # c\n", r"line 5 is not valid OBJ: 'f 1 2 3 # c'"),
    "continuation": (SQ + "f 1 2 \\\n3\n", r"line 5 is not valid OBJ"),
    "huge-index": (SQ + "f 1 2 100000000000000000000000\n", r"line 5: vertex index 100000000000000000000000 is past"),
    "nan": (SQ.replace("v 1 1 0", "v 1 nan 0") + "f 1 2 3\n", r"line 3: vertex 3 has a non-finite coordinate"),
    "overflow": (SQ.replace("v 1 1 0", "v 1 1e400 0") + "f 1 2 3\n", r"line 3: vertex 3 has a non-finite coordinate"),
    "crlf-error": (SQ.replace("\n", "\r\n") + "f 1 2\r\n", r"line 5: a face needs at least 3 vertices"),
    "cr-error": (SQ.replace("\n", "\r") + "f 0 1 2\r", r"line 5: vertex index 0"),
    "underscore": (SQ + "f 1_0 2 3\n", r"line 5: vertex index 10 is past the last vertex"),
    "unicode-space": ("v\u00a00 0 0\n" + SQ + "f 2 3 4\n", None),
    "unicode-in-face": (SQ + "f 1/\u00e9 2 3\n", None),
    "off-not-off": ("NOT OFF\n", r"not an OFF file"),
    "off-short": ("OFF\n4 1 0\n0 0 0\n1 0 0\n", r"the OFF header announces 4 vertices and 1 face \(5 lines\), but"),
    "off-long": (SQ_OFF + "3 0 1 2\n3 0 2 3\n3 0 1 3\n", r"the OFF header announces 2 faces, but 3 lines follow"),
    "off-index": (SQ_OFF + "3 0 1 2\n3 0 2 4\n", r"line 8: vertex index 4 is outside the file's 4 vertices"),
    "off-negative": (SQ_OFF + "3 0 1 2\n3 0 2 -1\n", r"line 8: vertex index -1 is outside"),
    "off-size": (SQ_OFF + "3 0 1 2\n3.0 0 2 3\n", r"line 8: face size '3.0' is not an integer"),
    "off-few": (SQ_OFF + "3 0 1 2\n4 0 2 3\n", r"line 8: a face of 4 vertices lists 3"),
    "off-vertex": ("OFF\n3 1 0\n0 0 0\n1 0\n0 1 0\n3 0 1 2\n", r"line 4: a vertex needs 3 coordinates"),
    "off-inf": ("OFF\n3 1 0\n0 0 0\n1e999 0 0\n0 1 0\n3 0 1 2\n", r"line 4: vertex 1 has a non-finite coordinate"),
    "off-unicode-space": ("OFF\n3 1 0\n\u00a00 0 0\n1 0 0\n0 1 0\n3 0 1 2\n", None),
}


@pytest.fixture
def write(tmp_path):
    def write(name, text, ext):
        path = tmp_path / f"{name}{ext}"
        path.write_bytes(text.encode("utf-8") if isinstance(text, str) else text)
        return path

    return write


@pytest.mark.parametrize("name", sorted(READ_BY_SCANS))
def test_scans_read_what_the_line_readers_read(write, monkeypatch, name):
    path = write(name, READ_BY_SCANS[name], ".off" if name.startswith("off") else ".obj")
    assert assert_same_read(path, monkeypatch), "read by the scans, not left to the line reader"


@pytest.mark.parametrize("name", sorted(LEFT_TO_LINES))
def test_left_to_the_line_readers_with_their_errors(write, monkeypatch, name):
    text, message = LEFT_TO_LINES[name]
    path = write(name, text, ".off" if name.startswith("off") else ".obj")
    assert not assert_same_read(path, monkeypatch)
    _compiled(monkeypatch)
    if message is None:
        read_mesh(path)
    else:
        with pytest.raises(ValueError, match=rf"{re.escape(path.name)}: {message}"):
            read_mesh(path)


def _meshes():
    tri = ds.kuhn_grid(6, 2, jitter=0.3, random_state=0)
    lifted = SimplicialComplex(np.c_[tri.points, np.sin(tri.points[:, 0]) * 1e-7], tri.simplices)
    return [tri, lifted, ds.quad_grid(5, jitter=0.2, random_state=1), ds.voronoi_polygons(4, random_state=2)]


@pytest.mark.parametrize("ext", [".obj", ".off"])
def test_written_meshes_read_alike(tmp_path, monkeypatch, ext):
    for i, mesh in enumerate(_meshes()):
        path = tmp_path / f"m{i}{ext}"
        write_mesh(path, mesh)
        assert assert_same_read(path, monkeypatch)


def test_corrupted_files_read_alike(tmp_path, monkeypatch):
    """Random byte edits of valid files: the scans and the line reader still agree."""
    rng = np.random.default_rng(7)
    texts = [(t.encode(), ".obj") for t in (SQ + "f 1 2 3\nf -1 -2 -3\nl 1 2\n", READ_BY_SCANS["slashes"])]
    texts += [((SQ_OFF + "3 0 1 2\n4 0 1 2 3\n").encode(), ".off")]
    pool = np.frombuffer(b"0123456789 -+.eE/#\n\r\t\x0bvfl\xc3\xa9x", dtype=np.uint8)
    for k in range(150):
        data, ext = texts[k % len(texts)]
        data = bytearray(data)
        for _ in range(rng.integers(1, 4)):
            at = int(rng.integers(0, len(data)))
            edit = rng.integers(0, 3)
            if edit == 0:
                del data[at]
            elif edit == 1:
                data.insert(at, int(rng.choice(pool)))
            else:
                data[at] = int(rng.choice(pool))
        path = tmp_path / f"c{k}{ext}"
        path.write_bytes(bytes(data))
        assert_same_read(path, monkeypatch)


@pytest.mark.skipif(not MESHES.is_dir(), reason="shared data folder ../shared/data absent")
@pytest.mark.parametrize(
    "name", [p.name for p in sorted(MESHES.glob("*.o*")) if p.stat().st_size < 2**20] if MESHES.is_dir() else []
)
def test_shared_meshes_read_alike(monkeypatch, name):
    assert assert_same_read(MESHES / name, monkeypatch, domains=False)  # test_io reads them into domains


def test_float_tokens_are_correctly_rounded():
    """The scans' decimal conversion equals Python's ``float`` on random and hard tokens."""
    rng = np.random.default_rng(3)
    n = 6000
    mantissas = rng.integers(0, 10**18, n).astype(str)
    cuts = rng.integers(0, 19, n)
    tokens = [f"{m[:c]}.{m[c:]}e{e}" for m, c, e in zip(mantissas, cuts, rng.integers(-330, 320, n), strict=True)]
    tokens += [format(v, ".17g") for v in rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n)]
    doubles = rng.standard_normal(300) * 10.0 ** rng.integers(-300, 300, 300)
    with decimal.localcontext(prec=800):  # exactly halfway between two doubles, and next to it
        halves = [(decimal.Decimal(a) + decimal.Decimal(np.nextafter(a, np.inf))) / 2 for a in doubles]
        tokens += [str(h) for h in halves] + [str(h.next_plus()) for h in halves[:100]]
    tokens += ["0", "-0", ".5", "5.", "-.5e-3", "+1", "1e308", "1.7976931348623159e308", "4.9e-324", "1e-400", "1" * 25]
    tokens += ["2.2250738585072011e-308", "9007199254740993", "123456789012345678901"]
    tokens = tokens[: 3 * (len(tokens) // 3)]
    data = "\n".join(" ".join(tokens[i : i + 3]) for i in range(0, len(tokens), 3)).encode()
    status, coords, _ = float_rows(np.frombuffer(data, dtype=np.uint8), 0, len(tokens) // 3, 3, False)
    assert status == 0
    values, expected = fill_slow(coords, data), np.array([float(t) for t in tokens])
    np.testing.assert_array_equal(values, expected)
    assert np.array_equal(np.signbit(values), np.signbit(expected))


def test_points_text_is_percent_17g(monkeypatch):
    _compiled(monkeypatch)
    rng = np.random.default_rng(4)
    n = 3000
    values = np.concatenate(
        [
            rng.standard_normal(n) * 10.0 ** rng.integers(-12, 20, n),
            rng.integers(0, 2**53, n) / 2.0 ** rng.integers(0, 60, n),  # exact binary fractions: ties
            np.nextafter(10.0 ** rng.integers(-12, 17, n), 0.0),
            [0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, 1e-9, 2.0**49, -(2.0**49) + 1, 123456789012345.125],
        ]
    )
    rows = values[: 3 * (values.size // 3)].reshape(-1, 3)
    for line in ("v %.17g %.17g %.17g\n", "%.17g %.17g %.17g\n"):
        assert points_text(rows, line) == (line * rows.shape[0]) % tuple(rows.ravel().tolist())


def test_rows_text_is_the_join_loop(monkeypatch):
    _compiled(monkeypatch)
    rows = [[0, 1, 2], [5, 6, 7, 8], [10**12, 3, 0], []]
    for base, prefix, size in [(1, "f ", False), (0, "", True), (1, "l ", False)]:
        expected = "".join(
            prefix + (f"{len(r)} " if size else "") + " ".join(str(int(i) + base) for i in r) + "\n" for r in rows
        )
        assert rows_text(rows, base=base, prefix=prefix, with_size=size) == expected
    assert rows_text(np.array([[0, 1, 2]]), base=1, prefix="f ") == "f 1 2 3\n"
    assert rows_text([[0.0, 1.7, 2]], base=1, prefix="f ") == "f 1 2 3\n"  # int() of every value, as before


def _old_obj(path, points, blocks):
    """The writer as it was: ``np.savetxt`` for the points, a join per row."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("# written by ndboundary\n")
        np.savetxt(fh, common.points_3d(points), fmt="v %.17g %.17g %.17g")
        for kind, rows in blocks:
            for r in rows:
                fh.write(("l" if kind == "line" else "f") + " " + " ".join(str(int(i) + 1) for i in r) + "\n")


def _old_off(path, points, blocks):
    pts, rows = common.points_3d(points), [r for _, b in blocks for r in b]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(f"OFF\n{pts.shape[0]} {len(rows)} 0\n")
        np.savetxt(fh, pts, fmt="%.17g")
        for r in rows:
            fh.write(f"{len(r)} " + " ".join(str(int(i)) for i in r) + "\n")


def _old_ply(path, points, blocks):
    pts, simplices = common.points_3d(points), np.asarray(blocks[0][1])
    segments = simplices.shape[1] == 2
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("ply\nformat ascii 1.0\ncomment written by ndboundary\n")
        fh.write(f"element vertex {pts.shape[0]}\nproperty double x\nproperty double y\nproperty double z\n")
        if segments:
            fh.write(f"element edge {simplices.shape[0]}\nproperty int vertex1\nproperty int vertex2\n")
        else:
            fh.write(f"element face {simplices.shape[0]}\nproperty list uchar int vertex_indices\n")
        fh.write("end_header\n")
        np.savetxt(fh, pts, fmt="%.17g")
        if segments:
            np.savetxt(fh, simplices, fmt="%d")
        else:
            np.savetxt(fh, np.concatenate([np.full((simplices.shape[0], 1), 3), simplices], axis=1), fmt="%d")


def _new_ply(path, points, blocks):
    write_ascii_ply(path, points, np.asarray(blocks[0][1]))


@pytest.mark.parametrize(
    ("ext", "new", "old"), [(".obj", write_obj, _old_obj), (".off", write_off, _old_off), (".ply", _new_ply, _old_ply)]
)
def test_writers_write_the_same_bytes(tmp_path, monkeypatch, ext, new, old):
    _compiled(monkeypatch)
    poly = ds.voronoi_polygons(4, random_state=2)
    cases = [(m.points, [("triangle", m.simplices)]) for m in _meshes()[:2]]
    cases += [(poly.points * 1e20, [("polygon", [list(map(int, p)) for p in poly.polygons])])]
    cases += [(np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 1e-12]]), [("line", np.array([[0, 1], [1, 2]]))])]
    for i, (points, blocks) in enumerate(cases):
        if (ext == ".off" and blocks[0][0] == "line") or (ext == ".ply" and blocks[0][0] == "polygon"):
            continue
        new(tmp_path / f"new{i}{ext}", points, blocks)
        old(tmp_path / f"old{i}{ext}", points, blocks)
        assert (tmp_path / f"new{i}{ext}").read_bytes() == (tmp_path / f"old{i}{ext}").read_bytes()


def test_read_mesh_uses_arrays_for_uniform_faces(write, monkeypatch):
    _compiled(monkeypatch)
    quads = read_mesh(write("q", READ_BY_SCANS["quads"], ".obj"))
    assert isinstance(quads, PolygonMesh) and quads.sizes.tolist() == [4, 4]
    mixed = read_mesh(write("m", READ_BY_SCANS["off-mixed"], ".off"))
    assert isinstance(mixed, PolygonMesh) and mixed.sizes.tolist() == [4, 3]


# -- PLY: the common layouts without meshio, the rest through it -----------------------------------

meshio = pytest.importorskip("meshio")
PLY_POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0]], dtype=np.float64)
PLY_TYPES = {"double": "f8", "float": "f4", "int": "i4", "uchar": "i1", "uint": "u4", "short": "i2"}


def _ply(fmt="binary_little_endian", props=("double x", "double y", "double z"), face="list uchar int", rows=None):
    """A PLY file of a square's two triangles (``rows``: the face lines of an ASCII file instead)."""
    head = (
        f"ply\nformat {fmt} 1.0\ncomment c\nelement vertex 4\n"
        + "".join(f"property {p}\n" for p in props)
        + f"element face 2\nproperty {face} vertex_indices\nend_header\n"
    ).encode()
    names = [p.split()[-1] for p in props]
    values = np.column_stack([PLY_POINTS[:, "xyz".index(n)] if n in "xyz" else np.full(4, 0.25) for n in names])
    if fmt == "ascii":
        rows = "3 0 1 2\n3 0 2 3\n" if rows is None else rows
        return head + "".join(" ".join(map(repr, v)) + "\n" for v in values.tolist()).encode() + rows.encode()
    order = "<" if fmt == "binary_little_endian" else ">"
    vertex = np.zeros(4, dtype=[(n, order + PLY_TYPES[p.split()[0]]) for p, n in zip(props, names, strict=True)])
    for j, n in enumerate(names):
        vertex[n] = values[:, j]
    count, index = face.split()[1:]
    faces = np.zeros(2, dtype=[("c", order + PLY_TYPES[count]), ("i", order + PLY_TYPES[index], (3,))])
    faces["c"], faces["i"] = 3, [[0, 1, 2], [0, 2, 3]]
    return head + vertex.tobytes() + faces.tobytes()


PLY_FAST = {
    "binary-le": _ply(),
    "binary-be": _ply("binary_big_endian"),
    "binary-float-extra": _ply(props=("float x", "float y", "float z", "uchar red", "float nx")),
    "binary-uint": _ply(face="list uchar uint"),
    "ascii": _ply("ascii"),
    "ascii-float-extra": _ply("ascii", props=("float x", "float y", "float z", "double nx")),
    "ascii-crlf": _ply("ascii").replace(b"\n", b"\r\n"),
    "ascii-mixed": _ply("ascii", rows="3 0 1 2\n4 0 1 2 3\n"),
}
PLY_TO_MESHIO = {
    "ascii-index": _ply("ascii", rows="3 0 1 2\n3 0 2 4\n"),
    "ascii-nan": _ply("ascii").replace(b"0.5", b"nan"),
    "ascii-int-property": _ply("ascii", props=("double x", "double y", "double z", "uchar red")),
    "ascii-comment": _ply("ascii", rows="3 0 1 2\n# c\n3 0 2 3\n"),
    "binary-short": _ply()[:-3],
    "binary-trailing": _ply() + b"\n",
    "binary-unknown-type": _ply(props=("double x", "double y", "double z", "short s")),
    "binary-index-sign": _ply(face="list uchar uchar").replace(b"\x02\x03", b"\x02\xfd"),
    "no-z": _ply("ascii", props=("double x", "double y", "double w")),
    "float-indices": _ply("ascii", face="list uchar float"),
    "not-ply": b"plyx\n" + _ply()[4:],
}


@pytest.fixture
def all_sizes(monkeypatch):
    """The compiled scans for files of any size (ASCII PLY files below ``FAST_MIN_BYTES`` go to meshio)."""
    _compiled(monkeypatch)


@pytest.mark.usefixtures("all_sizes")
@pytest.mark.parametrize("name", sorted(PLY_FAST) + sorted(PLY_TO_MESHIO))
def test_ply_reads_as_meshio_reads(tmp_path, name):
    data = PLY_FAST.get(name, PLY_TO_MESHIO.get(name))
    path = tmp_path / f"{name}.ply"
    path.write_bytes(data)
    fast = scan_ply_bytes(data)
    assert (fast is not None) == (name in PLY_FAST)
    try:
        points, blocks = read_with_meshio(path)
    except ValueError as exc:
        with pytest.raises(ValueError, match=re.escape(str(exc))):
            read_mesh(path)
        return
    if fast is not None:
        np.testing.assert_array_equal(fast[0], points)
        assert _normal(fast[1]) == _normal(blocks)
    read_mesh(path)


@pytest.mark.usefixtures("all_sizes")
@pytest.mark.parametrize("binary", [True, False])
def test_ply_files_of_meshio_and_ours(tmp_path, binary):
    tri, lifted, quads, _ = _meshes()
    files = [(tri, "triangle", tri.simplices), (lifted, "triangle", lifted.simplices)]
    files += [(quads, "quad", np.array(quads.polygons))]
    for i, (mesh, kind, cells) in enumerate(files):
        path = tmp_path / f"m{i}.ply"
        meshio.write(path, meshio.Mesh(common.points_3d(mesh.points), [(kind, cells)]), binary=binary)
        if not binary and kind == "triangle":
            write_ascii_ply(tmp_path / f"ours{i}.ply", mesh.points, cells)
            assert scan_ply_bytes((tmp_path / f"ours{i}.ply").read_bytes()) is not None
        fast = scan_ply_bytes(path.read_bytes())
        points, blocks = read_with_meshio(path)
        np.testing.assert_array_equal(fast[0], points)
        assert _normal(fast[1]) == _normal(blocks)


@pytest.mark.parametrize("compiled", [True, False])
def test_open_edge_fraction_counts_as_the_sort_did(monkeypatch, compiled):
    """The edge counts (compiled, or by a linear-time sort) equal those of ``np.unique`` over the edge keys."""
    from ndboundary.io.weld import open_edge_fraction

    _compiled(monkeypatch, compiled)
    rng = np.random.default_rng(5)
    for _ in range(100):
        sizes = rng.integers(1, 7, rng.integers(1, 40))
        flat = rng.integers(0, rng.integers(1, 30), sizes.sum())
        nxt = np.arange(flat.size) + 1
        nxt[np.cumsum(sizes) - 1] = np.cumsum(sizes) - sizes
        lo, hi = np.minimum(flat, flat[nxt]), np.maximum(flat, flat[nxt])
        _, counts = np.unique(lo * (hi.max() + 1) + hi, return_counts=True)
        rows = [r.tolist() for r in np.split(flat, np.cumsum(sizes)[:-1])]
        assert open_edge_fraction([("polygon", rows)]) == np.count_nonzero(counts == 1) / counts.size


def test_small_files_are_read_line_by_line(write, monkeypatch):
    """Below ``FAST_MIN_BYTES`` the compiled scans are neither run nor loaded."""
    import ndboundary.io.obj as obj

    def refuse(data):
        raise AssertionError("the compiled scan ran")

    monkeypatch.setattr(obj, "scan_obj_bytes", refuse)
    assert read_mesh(write("small", READ_BY_SCANS["triangles"], ".obj")).n_elements == 2


VTU_DOMAINS = {
    "triangles": ds.kuhn_grid(5, 2, jitter=0.2, random_state=0),
    "tetrahedra": ds.kuhn_grid(3, 3, jitter=0.1, random_state=0),
    "quads": ds.quad_grid(4, jitter=0.2, random_state=0),
    "polygons": ds.voronoi_polygons(12, random_state=0),  # blocks of several polygon sizes
    "hexahedra": ds.hex_grid(3, jitter=0.2, random_state=0),
}


@pytest.mark.parametrize("block_bytes", [None, 64, 8 * 6])  # 48: the points' rows end blocks exactly
@pytest.mark.parametrize("name", sorted(VTU_DOMAINS))
def test_vtu_files_of_meshio_and_ours(tmp_path, monkeypatch, name, block_bytes):
    import meshio

    from ndboundary.io import vtu
    from ndboundary.io.cell_blocks import blocks_from_domain
    from ndboundary.io.meshio_formats import write_with_meshio

    if block_bytes is not None:
        monkeypatch.setattr(vtu, "BLOCK_BYTES", block_bytes)
    domain = VTU_DOMAINS[name]
    rng = np.random.default_rng(0)
    point_data = {"phi": rng.random(domain.n_vertices), "flag": rng.random(domain.n_vertices) > 0.5}
    cell_data = {"labels": rng.integers(-3, 3, domain.n_elements).astype(np.int32),
                 "field": rng.random((domain.n_elements, 3))}  # fmt: skip
    write_mesh(tmp_path / "ours.vtu", domain, point_data=point_data, cell_data=cell_data)
    blocks, order = blocks_from_domain(domain)
    as_uint8 = {**point_data, "flag": point_data["flag"].astype(np.uint8)}  # meshio takes no booleans
    path = tmp_path / "meshio.vtu"
    write_with_meshio(path, domain.points, blocks, order=order, point_data=as_uint8, cell_data=cell_data)
    ours, theirs = meshio.read(tmp_path / "ours.vtu"), meshio.read(tmp_path / "meshio.vtu")
    np.testing.assert_array_equal(ours.points, theirs.points)
    assert [c.type for c in ours.cells] == [c.type for c in theirs.cells] and len(ours.cells) >= 1
    for a, b in zip(ours.cells, theirs.cells, strict=True):
        np.testing.assert_array_equal(a.data, b.data)
    for key in point_data:
        np.testing.assert_array_equal(ours.point_data[key], theirs.point_data[key])
    assert ours.point_data["flag"].dtype == np.uint8  # booleans as VTK holds them
    for key in cell_data:
        for a, b in zip(ours.cell_data[key], theirs.cell_data[key], strict=True):
            np.testing.assert_array_equal(a, b)
    back = read_mesh(tmp_path / "ours.vtu")
    assert (back.n_vertices, back.n_elements) == (domain.n_vertices, domain.n_elements)


def test_vtu_writer_refuses_what_vtk_cannot_hold(tmp_path):
    from ndboundary.io.vtu import write_vtu

    square = [[0, 0], [1, 0], [1, 1], [0, 1]]
    with pytest.raises(ValueError, match="holds no numbers"):
        write_vtu(tmp_path / "s.vtu", square, [("quad", [[0, 1, 2, 3]])], point_data={"name": np.array(list("abcd"))})
    with pytest.raises(ValueError, match=r"cells of fixed size .* got \['polyhedron8'\]"):
        write_vtu(tmp_path / "s.vtu", square, [("polyhedron8", [[0, 1, 2, 3]])])
    two = [("triangle", [[0, 1, 2]]), ("quad", [[0, 1, 2, 3]])]
    with pytest.raises(ValueError, match="cell_data on 2 blocks needs their order"):
        write_vtu(tmp_path / "s.vtu", square, two, cell_data={"label": np.array([1, 2])})
    assert not (tmp_path / "s.vtu").exists()
    write_vtu(tmp_path / "s.vtu", square, [("quad", [[0, 1, 2, 3]])], cell_data={"label": np.array([5])})
    assert read_mesh(tmp_path / "s.vtu").n_elements == 1
