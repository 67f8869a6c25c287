"""The README's Python examples run as written."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    assert len(blocks) == 2
    spaces = []
    for code in blocks:
        namespace = {}
        exec(compile(code, str(README), "exec"), namespace)
        spaces.append(namespace)
    mesh, data = spaces
    assert mesh["curve"].is_closed()
    assert (data["labels"] == data["y"][300:]).mean() > 0.85
    assert np.array_equal(data["labels"], data["clf"].classes_[(data["phi"] > 0).astype(int)])
