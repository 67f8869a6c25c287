import pickle

import numpy as np
import pytest
from sklearn.datasets import load_iris, make_moons
from sklearn.inspection import DecisionBoundaryDisplay
from sklearn.model_selection import GridSearchCV, cross_val_score
from sklearn.neighbors import KNeighborsClassifier
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

from ndboundary.classifier import LevelSetClassifier


@parametrize_with_checks([LevelSetClassifier()])
def test_sklearn_compatible(estimator, check):
    check(estimator)


@pytest.fixture(scope="module")
def moons():
    X, y = make_moons(400, noise=0.25, random_state=0)
    return X[:200], y[:200], X[200:], y[200:]


def test_binary_decision_function(moons):
    X, y, Xt, yt = moons
    clf = LevelSetClassifier().fit(X, y)
    d = clf.decision_function(Xt)
    assert d.shape == (200,)
    assert np.array_equal(clf.predict(Xt), clf.classes_[(d > 0).astype(int)])
    p = clf.predict_proba(Xt)
    assert np.allclose(p.sum(axis=1), 1) and np.all(np.diff(p[np.argsort(d), 1]) >= -1e-12)


def test_prediction_independent_of_batch(moons):
    X, y, Xt, _ = moons
    clf = LevelSetClassifier().fit(X, y)
    whole = clf.decision_function(Xt)
    one = np.array([clf.decision_function(Xt[i : i + 1])[0] for i in range(10)])
    assert np.allclose(whole[:10], one)


def test_accuracy_comparable_to_knn(moons):
    X, y, Xt, yt = moons
    ours = make_pipeline(StandardScaler(), LevelSetClassifier()).fit(X, y).score(Xt, yt)
    knn = make_pipeline(StandardScaler(), KNeighborsClassifier(15)).fit(X, y).score(Xt, yt)
    assert ours >= knn - 0.03


def test_pipeline_grid_search_cross_val(moons):
    X, y, _, _ = moons
    pipe = make_pipeline(StandardScaler(), LevelSetClassifier())
    scores = cross_val_score(pipe, X, y, cv=3)
    assert scores.mean() > 0.85
    gs = GridSearchCV(pipe, {"levelsetclassifier__lam": [0.5, 2.0]}, cv=2).fit(X, y)
    assert gs.best_score_ > 0.85


def test_decision_boundary_display(moons):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    X, y, _, _ = moons
    clf = LevelSetClassifier().fit(X, y)
    disp = DecisionBoundaryDisplay.from_estimator(clf, X, response_method="predict", grid_resolution=50)
    assert disp.surface_ is not None
    plt.close("all")


def test_pickle_round_trip(moons):
    X, y, Xt, _ = moons
    clf = LevelSetClassifier().fit(X, y)
    clone = pickle.loads(pickle.dumps(clf))
    assert np.array_equal(clf.decision_function(Xt), clone.decision_function(Xt))


def test_multiclass():
    X, y = load_iris(return_X_y=True)
    names = np.array(["setosa", "versicolor", "virginica"])[y]
    clf = make_pipeline(StandardScaler(), LevelSetClassifier()).fit(X[::2], names[::2])
    assert clf.score(X[1::2], names[1::2]) > 0.85
    d = clf.decision_function(X[1::2])
    assert d.shape == (75, 3)
    assert np.array_equal(clf.predict(X[1::2]), clf.classes_[np.argmax(d, axis=1)])


def test_semi_supervised(moons):
    X, y, Xt, yt = moons
    yl = y.copy()
    yl[np.random.default_rng(0).random(200) > 0.15] = -1
    clf = LevelSetClassifier(unlabeled=-1).fit(X, yl)
    assert list(clf.classes_) == [0, 1]
    assert (clf.transduction_ == y).mean() > 0.8
    assert clf.score(Xt, yt) > 0.8


def test_disconnected_training_data():
    rng = np.random.default_rng(0)
    X = np.concatenate([rng.normal(size=(50, 2)), rng.normal(size=(50, 2)) + 50])
    y = np.r_[np.zeros(50, int), np.ones(50, int)]
    clf = LevelSetClassifier().fit(X, y)
    assert clf.score(X, y) == 1.0
    assert np.all(np.isfinite(clf.decision_function(X)))


@pytest.mark.parametrize(
    ("params", "err", "match"),
    [
        ({"graph": "grid"}, ValueError, "graph must be"),
        ({"n_neighbors": 1}, ValueError, "n_neighbors must be >= 2"),
        ({"n_neighbors": 2.5}, TypeError, "n_neighbors must be an integer"),
        ({"vote_threshold": 1.5}, ValueError, "vote_threshold must be in"),
        ({"extension_neighbors": 0}, ValueError, "extension_neighbors must be >= 1"),
        ({"vote_threshold": "half"}, TypeError, "vote_threshold must be a number"),
        ({"tol": 0.0}, ValueError, "tol must be in"),
        ({"tol": "1e-6"}, TypeError, "tol must be a number"),
    ],
)
def test_bad_parameters(moons, params, err, match):
    X, y, _, _ = moons
    with pytest.raises(err, match=match):
        LevelSetClassifier(**params).fit(X, y)


def test_no_labels_error(moons):
    X, _, _, _ = moons
    with pytest.raises(ValueError, match="no labelled sample"):
        LevelSetClassifier(unlabeled=-1).fit(X, -np.ones(200, int))


def test_solver_tolerance_does_not_move_decisions(moons):
    X, y, Xt, _ = moons
    loose = LevelSetClassifier().fit(X, y)
    tight = LevelSetClassifier(tol=1e-10).fit(X, y)
    np.testing.assert_allclose(loose.decision_function(Xt), tight.decision_function(Xt), atol=1e-3)
    np.testing.assert_array_equal(loose.predict(Xt), tight.predict(Xt))
