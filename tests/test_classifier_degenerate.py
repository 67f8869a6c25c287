"""LevelSetClassifier on degenerate inputs: extreme feature scales, tiny training sets, a
class of one sample.
"""

import warnings

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components
from sklearn.datasets import make_moons
from sklearn.neighbors import KNeighborsClassifier

from ndboundary import LevelSetClassifier


@pytest.fixture(scope="module")
def moons():
    X, y = make_moons(200, noise=0.2, random_state=0)
    return X, y, LevelSetClassifier().fit(X, y).predict(X)


@pytest.mark.parametrize("s", [1e-200, 1e-100, 1.0, 1e100, 1e200])
def test_predictions_do_not_depend_on_a_global_feature_scale(moons, s):
    X, y, expected = moons
    Xs = X * s
    Xs_before, y_before = Xs.copy(), y.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        clf = LevelSetClassifier().fit(Xs, y)
        pred = clf.predict(Xs)
        proba = clf.predict_proba(Xs)
    np.testing.assert_array_equal(pred, expected)
    assert np.all(np.isfinite(proba))
    assert np.array_equal(Xs, Xs_before) and np.array_equal(y, y_before)  # inputs are not modified
    # one power-of-two scale for all features, of the order of the data's spread
    assert np.log2(clf.scale_) == np.round(np.log2(clf.scale_))
    assert 0.25 < clf.scale_ / s < 4.0
    assert clf.center_.shape == (2,)


def test_scales_that_cannot_be_held_raise_a_clear_error():
    X, y = make_moons(100, noise=0.2, random_state=0)
    clf = LevelSetClassifier().fit(X * 1e-300, y)
    with pytest.raises(ValueError, match="too far from the training data"):
        clf.predict(np.array([[1e300, 0.0]]))


def test_a_translated_copy_predicts_the_same(moons):
    X, y, expected = moons
    shift = np.array([1e6, -3e5])
    clf = LevelSetClassifier().fit(X + shift, y)
    assert (clf.predict(X + shift) == expected).mean() == 1.0


def _tiny_draws(n_draws, n_classes, seed):
    rng = np.random.default_rng(seed)
    while n_draws:
        n = int(rng.integers(3, 7))
        X = rng.normal(size=(n, 2))
        y = rng.integers(0, n_classes, n)
        if np.unique(y).size < 2:
            continue
        n_draws -= 1
        yield X, y


@pytest.mark.parametrize(("n_classes", "n_draws"), [(2, 80), (3, 20)])
def test_tiny_training_sets_predict_their_own_samples(n_classes, n_draws):
    for X, y in _tiny_draws(n_draws, n_classes, seed=n_classes):
        one_nn = KNeighborsClassifier(n_neighbors=1).fit(X, y).predict(X)
        assert np.array_equal(one_nn, y)  # distinct samples: 1-NN reproduces them
        clf = LevelSetClassifier().fit(X, y)
        np.testing.assert_array_equal(clf.predict(X), y, err_msg=f"X={X.tolist()}, y={y.tolist()}")
        assert clf.extension_power_ > 0  # a neighbourhood of every sample is no local average


def _rays(x0, radius, n_rays=72, n_steps=400):
    a = np.linspace(0.0, 2 * np.pi, n_rays, endpoint=False)
    t = np.linspace(0.0, radius, n_steps)
    u = np.stack([np.cos(a), np.sin(a)], axis=1)
    return x0 + t[None, :, None] * u[:, None, :]  # (n_rays, n_steps, 2)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_single_positive_is_predicted_monotonically(seed):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(1000, 2))
    y = np.zeros(1000, dtype=int)
    y[0] = 1
    clf = LevelSetClassifier().fit(X, y)
    assert clf.predict(X[:1])[0] == 1
    # no other training sample is positive: the peaks the relaxation left around the
    # positive (none of them holding a positive sample) are cut down
    assert np.flatnonzero(clf.predict(X)).tolist() == [0]
    assert np.flatnonzero(clf.phi_[:, 0] > 0.5).tolist() == [0]

    dist = np.sort(np.linalg.norm(X[1:] - X[0], axis=1))
    # out to the nearest other sample, the decision falls strictly along every ray
    near = _rays(X[0], dist[0])
    d = clf.decision_function(near.reshape(-1, 2)).reshape(near.shape[:2])
    assert np.diff(d, axis=1).max() <= 1e-9
    # out into the data, a ray that has left the positive region never comes back to it
    far = _rays(X[0], 2.0)
    pos = clf.predict(far.reshape(-1, 2)).reshape(far.shape[:2]) == 1
    assert pos[:, 0].all()
    assert np.all(np.cumsum(~pos, axis=1)[pos] == 0)


def test_relaxed_regions_hold_a_sample_of_their_class():
    # every connected part of phi > 1/2 over the graph holds a positive sample, and
    # every part of phi < 1/2 a negative one
    X, y = make_moons(300, noise=0.35, random_state=3)
    clf = LevelSetClassifier().fit(X, y)
    dom, phi = clf.domain_, clf.phi_[:, 0]
    for side, label in ((phi > 0.5, 1), (phi < 0.5, 0)):
        keep = side[dom.edges[:, 0]] & side[dom.edges[:, 1]]
        graph = dom.edge_graph(keep.astype(float))
        graph.eliminate_zeros()
        _, comp = connected_components(graph, directed=False)
        for c in np.unique(comp[side]):
            assert np.any((comp == c) & side & (y == label))


def test_extension_stays_within_the_range_of_phi_far_from_the_data(moons):
    X, y, _ = moons
    clf = LevelSetClassifier(extension_power=2.0).fit(X, y)
    far = np.array([[50.0, 0.0], [0.0, -80.0], [-30.0, 40.0]])
    d = clf.decision_function(far)
    assert np.all(d >= clf.phi_.min() - 0.5) and np.all(d <= clf.phi_.max() - 0.5)


def _reconstruction(edges, phi, markers):
    """Reconstruction by dilation, by relaxing every edge until nothing changes."""
    psi = np.where(markers, phi, -np.inf)
    while True:
        before = psi.copy()
        for a, b in edges:
            psi[b] = max(psi[b], min(psi[a], phi[b]))
            psi[a] = max(psi[a], min(psi[b], phi[a]))
        if np.array_equal(psi, before):
            return np.where(np.isfinite(psi), psi, phi)


def test_extrema_are_imposed_as_the_reconstruction_by_relaxing_every_edge():
    """On a kNN graph of two clusters (one without any region-1 vertex), with ties in
    phi: the compiled flood gives what relaxing the edges to a fixed point gives."""
    from ndboundary import PointCloud
    from ndboundary.learn.extrema import impose_extrema

    rng = np.random.default_rng(3)
    X = np.concatenate([rng.normal(size=(60, 3)), rng.normal(size=(40, 3)) + 30.0])
    cloud = PointCloud(X, n_neighbors=6)
    phi = np.round(rng.normal(size=100), 1)  # ties
    region1 = (rng.random(100) < 0.2) & (np.arange(100) < 60)
    edges = np.asarray(cloud.edges)
    expected = -_reconstruction(edges, -_reconstruction(edges, phi, region1), ~region1)
    got = impose_extrema(cloud, phi, region1)
    np.testing.assert_array_equal(got, expected)
    assert not np.array_equal(got, phi)  # peaks and pits were cut
