"""Relaxer: factor once, solve many, and never a stale result."""

import numpy as np
import pytest

from ndboundary import Relaxer, relax
from ndboundary.datasets import ball, circle, flower, kuhn_grid, label_by


@pytest.fixture(scope="module")
def mesh():
    return kuhn_grid(40, 2, jitter=0.25, random_state=0)


def test_relaxer_gives_the_one_shot_result(mesh):
    relaxer = Relaxer(mesh)
    labels = label_by(mesh, flower)
    for params in ({}, {"smoothing": 5}, {"lam": 0.5}, {"form": "plain", "mu": 0.0}, {"t": 2.0}):
        np.testing.assert_array_equal(
            relaxer.relax(labels, on="elements", **params).phi, relax(mesh, labels, on="elements", **params).phi
        )


def test_relaxer_follows_new_labels(mesh):
    relaxer = Relaxer(mesh)
    a, b = label_by(mesh, flower), label_by(mesh, circle)
    relaxer.relax(a, on="elements")
    np.testing.assert_array_equal(relaxer.relax(b, on="elements").phi, relax(mesh, b, on="elements").phi)
    # the same labels on vertices are another problem
    v = label_by(mesh, circle, on="vertices")
    np.testing.assert_array_equal(relaxer.relax(v, on="vertices").phi, relax(mesh, v, on="vertices").phi)


def test_relaxer_reuses_the_field_for_other_smoothing(mesh):
    relaxer = Relaxer(mesh)
    labels = label_by(mesh, flower)
    first = relaxer.relax(labels, on="elements")
    second = relaxer.relax(labels, on="elements", smoothing=10)
    assert second.field is first.field  # steps 1-2 were not redone
    assert second.solver["heat"] is first.solver["heat"]


def test_relaxer_memory_is_reported_and_freed(mesh):
    relaxer = Relaxer(mesh)
    assert relaxer.nbytes == 0
    relaxer.relax(label_by(mesh, flower), on="elements")
    held = relaxer.nbytes
    assert held > mesh.n_vertices * 8  # at least the heat
    relaxer.clear()
    assert relaxer.nbytes == 0


def test_relaxer_on_tetrahedra():
    tets = kuhn_grid(8, 3, jitter=0.2, random_state=0)
    labels = label_by(tets, ball)
    relaxer = Relaxer(tets)
    relaxer.relax(labels, on="elements")
    np.testing.assert_allclose(
        relaxer.relax(labels, on="elements", smoothing=3).phi, relax(tets, labels, on="elements", smoothing=3).phi, atol=1e-12
    )


def test_relaxer_refuses_what_is_not_a_domain():
    with pytest.raises(TypeError, match="ndboundary domain"):
        Relaxer(np.zeros((3, 2)))
