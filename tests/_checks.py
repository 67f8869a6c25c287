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
