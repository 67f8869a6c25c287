"""The kernel fits of the relaxed functions that carry the classifier's decision where
the samples are sparse for their dimension."""

import numpy as np
import pytest
from sklearn.datasets import make_gaussian_quantiles
from sklearn.svm import SVC

from ndboundary import LevelSetClassifier
from ndboundary.learn.kernel_extension import KernelExtension, PairwiseKernelExtension


def test_the_fit_settles_at_the_outer_class_far_from_the_samples():
    """An inner ball against the rest, a quarter of the samples outside: far out, where
    every kernel vanishes, the fit's constant carries the outer class rather than the
    samples' mean, which would side with the inner one."""
    X = np.random.default_rng(0).normal(size=(300, 6))
    phi = (np.linalg.norm(X, axis=1) > 2.8).astype(float)[:, None]
    assert phi.mean() < 0.5
    far = np.zeros((3, 6))
    far[:, 0] = [4.0, 6.0, 20.0]
    assert (KernelExtension(X, phi)(far) > 0.9).all()


def test_nested_classes_are_fitted_pair_by_pair():
    """Three classes nested by radius: the middle shell's indicator rises and falls, which
    one fit per class against the rest follows poorly; the pairs' fits each see one
    boundary."""
    X, y = make_gaussian_quantiles(n_samples=600, n_features=6, n_classes=3, random_state=0)
    phi = np.eye(3)[y[:300]]
    pairwise = PairwiseKernelExtension(X[:300], phi, y[:300])
    against_rest = KernelExtension(X[:300], phi)
    right = (pairwise(X[300:]).argmax(axis=1) == y[300:]).mean()
    assert right > (against_rest(X[300:]).argmax(axis=1) == y[300:]).mean() + 0.05
    # the class functions cross 1/2 where the classes change: exactly one above it
    above = (pairwise(X[300:]) > 0.5).sum(axis=1)
    assert (above <= 1).all() and (above == 1).mean() > 0.95


def test_the_classifier_separates_nested_classes_as_well_as_svc():
    X, y = make_gaussian_quantiles(n_samples=600, n_features=6, n_classes=3, random_state=0)
    ours = LevelSetClassifier().fit(X[:300], y[:300])
    assert ours.score(X[300:], y[300:]) >= SVC().fit(X[:300], y[:300]).score(X[300:], y[300:]) - 0.02


def test_pairwise_values_do_not_depend_on_the_rows_beside_them():
    X, y = make_gaussian_quantiles(n_samples=400, n_features=5, n_classes=4, random_state=1)
    ext = PairwiseKernelExtension(X[:200], np.eye(4)[y[:200]], y[:200])
    whole = ext(X[200:])
    assert np.array_equal(whole[17:91], ext(X[200:][17:91]))
    lean = ext.for_queries()
    assert lean.fitted is None and np.array_equal(lean(X[200:]), whole)


def test_values_at_new_points_are_the_kernel_sums_and_do_not_depend_on_the_rows_beside_them():
    """New points are evaluated a run of rows at a time with one distance buffer: the
    values are those of the kernel sums over the landmarks, and each row's are the same
    to the bit whatever rows come with it, across the runs' edges."""
    X, y = make_gaussian_quantiles(n_samples=700, n_features=5, n_classes=2, random_state=4)
    ext = KernelExtension(X[:300], y[:300].astype(float)[:, None])
    new = X[300:]
    whole = ext(new)
    L, fit = ext._landmarks, ext._fit
    d = ((new[:, None, :] - L[None]) ** 2).sum(axis=2)
    np.testing.assert_allclose(whole, np.exp(-fit.gamma * d) @ fit.weights + fit.offset, rtol=1e-10, atol=1e-12)
    for rows in (slice(0, 1), slice(100, 300), slice(127, 129), slice(5, 400)):
        assert np.array_equal(ext(new[rows]), whole[rows])


def test_pairwise_fit_refuses_a_class_without_samples():
    X = np.random.default_rng(0).normal(size=(40, 3))
    with pytest.raises(ValueError, match="every class"):
        PairwiseKernelExtension(X, np.zeros((40, 3)), np.repeat([0, 2], 20))


def test_compiled_distances_to_the_landmarks_equal_the_direct_sums():
    from ndboundary._compiled import squared_distances

    rng = np.random.default_rng(3)
    X, L = rng.normal(size=(57, 9)), rng.normal(size=(13, 9))
    out = np.empty((57, 13))
    squared_distances(X, np.ascontiguousarray(L.T), out)
    np.testing.assert_allclose(out, ((X[:, None, :] - L[None]) ** 2).sum(axis=2), rtol=1e-13)
    part = np.empty((20, 13))
    squared_distances(np.ascontiguousarray(X[30:50]), np.ascontiguousarray(L.T), part)
    assert np.array_equal(part, out[30:50])  # each row summed alike, whatever rows come with it


def test_the_widths_fitted_on_threads_equal_those_fitted_one_at_a_time(monkeypatch):
    import ndboundary.learn.kernel_extension as kx

    X, y = make_gaussian_quantiles(n_samples=500, n_features=4, n_classes=2, random_state=2)
    phi = y.astype(float)[:, None]
    threaded = KernelExtension(X, phi)
    monkeypatch.setattr(kx, "BLAS_THREADED_SAMPLES", 0)
    one_by_one = KernelExtension(X, phi)
    assert (threaded.gamma, threaded.ridge) == (one_by_one.gamma, one_by_one.ridge)
    np.testing.assert_allclose(threaded.fitted, one_by_one.fitted, atol=1e-9)
    Q = np.random.default_rng(0).normal(size=(100, 4))
    np.testing.assert_allclose(threaded(Q), one_by_one(Q), atol=1e-9)


@pytest.mark.parametrize("n_classes", [2, 3])
def test_one_basis_fits_any_function_as_a_fit_from_scratch(n_classes):
    """The basis holds nothing of the functions: fitted to two different ones in turn, it
    gives each the extension built for it alone, to the bit."""
    from ndboundary.learn.kernel_extension import kernel_basis, kernel_extension

    X, y = make_gaussian_quantiles(n_samples=400, n_features=5, n_classes=n_classes, random_state=1)
    rng = np.random.default_rng(2)
    columns = 1 if n_classes == 2 else n_classes
    phis = [np.eye(n_classes)[y][:, -columns:], rng.uniform(size=(400, columns))]
    basis = kernel_basis(X, y, columns)
    Q = rng.normal(size=(50, 5))
    for phi in phis:
        alone, shared = kernel_extension(X, phi, y), basis.fit(phi)
        assert type(shared) is (KernelExtension if n_classes == 2 else PairwiseKernelExtension)
        np.testing.assert_array_equal(shared(Q), alone(Q))
        np.testing.assert_array_equal(shared.fitted, alone.fitted)
        np.testing.assert_array_equal(shared.leave_one_out(np.arange(400)), alone.leave_one_out(np.arange(400)))
