"""The README's Python examples run as written."""

import re
from pathlib import Path

import numpy as np

from ndboundary import relax

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_python_blocks_run():
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.DOTALL)
    assert len(blocks) == 5
    spaces = []
    for code in blocks:
        namespace = {}
        exec(compile(code, str(README), "exec"), namespace)
        spaces.append(namespace)
    mesh, image, reuse, data, scaled = spaces
    assert mesh["curve"].is_closed()
    assert image["surface"].is_closed() and image["surface"].n_components() == 1
    # the relaxer's first result is the one-shot result; the memory it holds is freed on request
    np.testing.assert_array_equal(reuse["smooth"].phi, relax(reuse["mesh"], reuse["labels"], on="elements").phi)
    assert reuse["relaxer"].nbytes > 0
    reuse["relaxer"].clear()
    assert reuse["relaxer"].nbytes == 0
    assert (data["labels"] == data["y"][300:]).mean() > 0.85
    assert np.array_equal(data["labels"], data["clf"].classes_[(data["phi"] > 0).astype(int)])
    assert scaled["clf"].landmarks_.size == 2000 and scaled["accuracy"] > 0.9
