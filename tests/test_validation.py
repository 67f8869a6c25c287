"""Every bad-input path names what was wrong; inputs are never modified."""

import numpy as np
import pytest

from ndboundary import SimplicialComplex, relax
from ndboundary.datasets import circle, kuhn_grid, label_by

TRI = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
CELLS = np.array([[0, 1, 2], [1, 3, 2]])


@pytest.mark.parametrize(
    "points, simplices, exc, match",
    [
        (np.array([[0.0, np.nan], [1, 0], [0, 1]]), [[0, 1, 2]], ValueError, "NaN or infinite"),
        (np.array([[0.0, np.inf], [1, 0], [0, 1]]), [[0, 1, 2]], ValueError, "NaN or infinite"),
        (np.zeros(6), [[0, 1, 2]], ValueError, r"shape \(n_points, dim\)"),
        ("abc", [[0, 1, 2]], TypeError, "points must be"),
        ([["a", "b"], ["c", "d"]], [[0, 1]], TypeError, "numeric"),
        (np.zeros((0, 2)), [[0, 1, 2]], ValueError, "empty"),
        (TRI, [[0, 1, 7]], ValueError, r"indexes a vertex outside 0\.\.3"),
        (TRI, [[0, -1, 2]], ValueError, "outside"),
        (TRI, [[0.0, 1.5, 2.0]], TypeError, "non-integer"),
        (TRI, [[True, False, True]], TypeError, "booleans"),
        (TRI, [0, 1, 2], ValueError, r"shape \(n_cells"),
        (TRI, np.zeros((0, 3), dtype=int), ValueError, "empty"),
        (TRI, [[0, 1, 1]], ValueError, "repeats a vertex"),
        (TRI, [[0, 1, 2, 3]], ValueError, "expected at most 3 vertices per simplex"),
        (TRI, [[0]], ValueError, "at least 2 vertices"),
        ([[0.0, 0], [1, 1], [2, 2]], [[0, 1, 2]], ValueError, "simplex 0 .* degenerate: zero area"),
        (np.vstack([np.zeros(3), np.eye(3)[:2], [1.0, 1.0, 0.0]]), [[0, 1, 2, 3]], ValueError, "zero volume"),
        ([[0.0, 0], [0, 0]], [[0, 1]], ValueError, "zero length"),
        (TRI, [[0, 1, 2], [1, 2, 1]], ValueError, "row 1 .* repeats"),
    ],
)
def test_bad_domains(points, simplices, exc, match):
    with pytest.raises(exc, match=match):
        SimplicialComplex(points, simplices)


def test_float_indices_that_are_integers_are_accepted():
    dom = SimplicialComplex(TRI, CELLS.astype(float))
    assert dom.simplices.dtype == np.int64


@pytest.fixture(scope="module")
def grid():
    dom = kuhn_grid(10, 2, jitter=0.2, random_state=0)
    return dom, label_by(dom, circle)


@pytest.mark.parametrize(
    "labels, kwargs, exc, match",
    [
        (np.zeros(5), {"on": "elements"}, ValueError, r"labels has length 5 but the domain has 200 elements"),
        (None, {"on": "vertices"}, ValueError, r"length 200 but the domain has 121 vertices"),
        (np.zeros(200), {"on": "elements"}, ValueError, "one class only"),
        (None, {"on": "faces"}, ValueError, "on must be 'elements' or 'vertices'"),
        (None, {"on": "elements", "lam": -1.0}, ValueError, "lam must be a finite positive"),
        (None, {"on": "elements", "lam": np.nan}, ValueError, "lam"),
        (None, {"on": "elements", "lam": "big"}, TypeError, "lam must be a real number"),
        (None, {"on": "elements", "smoothing": -2}, ValueError, "smoothing must be >= 0"),
        (None, {"on": "elements", "smoothing": 2.5}, TypeError, "smoothing must be an integer"),
        (None, {"on": "elements", "t": 0.0}, ValueError, "t must be"),
        (None, {"on": "elements", "form": "squared"}, ValueError, "form must be"),
        (None, {"on": "elements", "solver": "magic"}, ValueError, "solver must be"),
        (np.r_[np.full(199, 1.0), np.nan], {"on": "elements"}, ValueError, "NaN"),
        (np.zeros((200, 2)), {"on": "elements"}, ValueError, "one-dimensional"),
    ],
)
def test_bad_relax_arguments(grid, labels, kwargs, exc, match):
    dom, good = grid
    with pytest.raises(exc, match=match):
        relax(dom, good if labels is None else labels, **kwargs)


def test_on_is_required(grid):
    dom, labels = grid
    with pytest.raises(TypeError, match="on"):
        relax(dom, labels)


def test_domain_must_be_a_domain(grid):
    _, labels = grid
    with pytest.raises(TypeError, match="domain must be an ndboundary domain"):
        relax(np.zeros((3, 2)), labels, on="elements")


def test_labels_that_never_meet():
    # two triangles in two separate components, one label each
    pts = [[0, 0], [1, 0], [0, 1], [5, 5], [6, 5], [5, 6]]
    dom = SimplicialComplex(pts, [[0, 1, 2], [3, 4, 5]])
    with pytest.raises(ValueError, match="never meet"):
        relax(dom, [0, 1], on="elements")


def test_inputs_are_not_modified():
    dom0 = kuhn_grid(8, 2, jitter=0.2, random_state=0)
    points, simplices = dom0.points.copy(), dom0.simplices.copy()
    p_arg, s_arg = points.copy(), simplices.copy()
    dom = SimplicialComplex(p_arg, s_arg)
    labels = label_by(dom, circle)
    l_arg = labels.copy()
    relax(dom, l_arg, on="elements")
    np.testing.assert_array_equal(p_arg, points)
    np.testing.assert_array_equal(s_arg, simplices)
    np.testing.assert_array_equal(l_arg, labels)
    # the domain holds copies: changing the caller's arrays afterwards changes nothing
    p_arg[:] = 0
    assert np.array_equal(dom.points, points)
