"""Assertions and readers shared by the test modules."""

from pathlib import Path

import numpy as np


def assert_stiffness_kernel_is_constants(K):
    """K is symmetric, positive semidefinite, and its null space is the constants only."""
    K = K.toarray()
    np.testing.assert_allclose(K, K.T, atol=1e-12)
    assert np.abs(K @ np.ones(K.shape[0])).max() < 1e-10
    w = np.linalg.eigvalsh(K)
    assert w[0] > -1e-10 * w[-1]
    assert w[1] > 1e-8 * w[-1]


def obj_groups(path):
    """The groups of an OBJ file and how many ``f`` or ``l`` lines each holds, in file order."""
    groups = []
    for line in Path(path).read_text().splitlines():
        if line.startswith("g "):
            groups.append([line.split()[1], 0])
        elif line.startswith(("f ", "l ")):
            groups[-1][1] += 1
    return [tuple(g) for g in groups]


def read_vtp(path):
    """The arrays of a ``.vtp`` file in VTK's compressed appended layout (what
    ``ndboundary.io`` writes), read by the format's description rather than by the writer:
    ``{section: {name: array}}``, the piece's attributes under ``"Piece"``.
    """
    import xml.etree.ElementTree as ET
    import zlib

    data = Path(path).read_bytes()
    start = data.index(b'<AppendedData encoding="raw">')
    raw = data[data.index(b"_", start) + 1 :]
    root = ET.fromstring(data[:start].decode() + "</VTKFile>")
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64"
    assert root.get("compressor") == "vtkZLibDataCompressor" and root.get("byte_order") == "LittleEndian"
    piece = root.find("PolyData/Piece")
    out = {"Piece": {k: int(v) for k, v in piece.attrib.items()}}
    for section in piece:
        arrays = out.setdefault(section.tag, {})
        for array in section:
            at = int(array.get("offset"))
            n_blocks = int(np.frombuffer(raw[at : at + 8], "<u8")[0])
            header = np.frombuffer(raw[at : at + 8 * (3 + n_blocks)], "<u8")
            at += 8 * (3 + n_blocks)
            chunks = []
            for size in header[3:]:
                chunks.append(zlib.decompress(raw[at : at + int(size)]))
                at += int(size)
            values = np.frombuffer(b"".join(chunks), dtype=np.dtype(array.get("type").lower()).newbyteorder("<"))
            components = int(array.get("NumberOfComponents", 1))
            arrays[array.get("Name", "")] = values.reshape(-1, components) if components > 1 else values
    return out


def stl_solids(path):
    """The solids of an ASCII STL file: ``[(name, normals (n, 3), corners (n, 3, 3))]``, in file order."""
    solids = []
    for line in Path(path).read_text().splitlines():
        words = line.split()
        if words[0] == "solid":
            solids.append((words[1], [], []))
        elif words[0] == "facet":
            solids[-1][1].append([float(w) for w in words[2:5]])
        elif words[0] == "vertex":
            solids[-1][2].append([float(w) for w in words[1:4]])
        elif words[0] == "endsolid":
            assert words[1] == solids[-1][0]
    return [(name, np.array(n).reshape(-1, 3), np.array(c).reshape(-1, 3, 3)) for name, n, c in solids]
