"""Point junctions fitted to the labels: nearer the truth, with the partition still exact."""

import numpy as np
import pytest

from ndboundary import relax, relax_image
from ndboundary.datasets import icosphere, kuhn_grid
from ndboundary.pipeline import interface_fit, junctions
from ndboundary.pipeline.junctions import BLEND, fit_y, y_gradients


def sectors_of(points, centre, angles):
    """The sector (0, 1, 2) of each point: counter-clockwise from ray q to ray q + 1."""
    a = (np.arctan2(points[:, 1] - centre[1], points[:, 0] - centre[0]) - angles[0]) % (2 * np.pi)
    return np.searchsorted((np.asarray(angles) - angles[0]) % (2 * np.pi), a, side="right") - 1


@pytest.mark.parametrize("seed", range(5))
def test_linear_functions_part_the_plane_at_the_rays(seed):
    rng = np.random.default_rng(seed)
    spans = rng.dirichlet([4, 4, 4]) * 2 * np.pi
    while spans.max() >= np.pi:
        spans = rng.dirichlet([4, 4, 4]) * 2 * np.pi
    angles = rng.uniform(0, 2 * np.pi) + np.concatenate([[0.0], np.cumsum(spans[:2])])
    grads = y_gradients(angles)
    x = rng.normal(size=(500, 2))
    np.testing.assert_array_equal(np.argmax(x @ grads.T, axis=1), sectors_of(x, (0.0, 0.0), angles))
    for q in range(3):  # on ray q the functions of its two sectors tie, above the third
        on_ray = np.array([np.cos(angles[q]), np.sin(angles[q])]) * 0.7
        f = grads @ on_ray
        assert f[q] == pytest.approx(f[q - 1], abs=1e-12) and f[q] > f[q - 2]


def test_no_linear_functions_part_a_sector_of_half_a_turn():
    assert y_gradients(np.radians([0.0, 90.0, 180.0])) is None
    assert y_gradients(np.radians([0.0, 60.0, 120.0])) is None


@pytest.mark.parametrize("seed", range(4))
def test_fit_y_finds_the_centre_of_labelled_sites(seed):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(-0.5, 0.5, 2)
    angles = np.radians([20.0, 150.0, 260.0]) + rng.uniform(-0.3, 0.3, 3)
    sites = rng.uniform(-6, 6, (300, 2))  # in units of h: about two sites per h^2, as triangles
    sites = sites[np.linalg.norm(sites, axis=1) < 6]
    sector = sectors_of(sites, centre, angles)
    for off in (0.2, 0.5):  # from near, and with many sites far on the wrong side of a ray
        found, fitted = fit_y(sites, sector, angles + rng.uniform(-off, off, 3))
        assert np.linalg.norm(found - centre) < 0.25
        assert np.abs(fitted - angles).max() < np.radians(8)


def test_many_junctions_are_fitted_on_every_core_as_on_one(monkeypatch):
    """Beyond SPLIT_MIN_SITES sites the junctions are split between threads: each fit is
    its own, and comes out the same to the bit, in the same order."""
    rng = np.random.default_rng(0)
    problems = []
    for _ in range(7):
        centre, angles = rng.uniform(-0.5, 0.5, 2), np.radians([20.0, 150.0, 260.0]) + rng.uniform(-0.3, 0.3, 3)
        sites = rng.uniform(-6, 6, (rng.integers(50, 300), 2))
        problems.append((sites, sectors_of(sites, centre, angles), angles + rng.uniform(-0.2, 0.2, 3)))
    alone = junctions.fit_ys(problems)
    monkeypatch.setattr(junctions, "available_threads", lambda: 3)
    monkeypatch.setattr(junctions, "SPLIT_MIN_SITES", 0)
    runs = []
    single = junctions._fit_ys
    monkeypatch.setattr(junctions, "_fit_ys", lambda run, *args: runs.append(len(run)) or single(run, *args))
    split = junctions.fit_ys(problems)
    assert sorted(runs) != [7] and sum(runs) == 7
    for a, b in zip(alone, split, strict=True):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def voronoi_junctions(mesh, sites, on="elements", fit=True, monkeypatch=None, interfaces=False):
    """Relax the Voronoi labels of ``sites``, the junctions fitted or not (``fit``), the
    interfaces and the junctions with them not fitted unless ``interfaces``; the distance
    (h) from each true Voronoi vertex inside the square to the nearest found junction,
    whether that vertex lies 3 h or more from every other, and the result."""
    from scipy.spatial import Voronoi

    monkeypatch.setattr(junctions, "JUNCTION_FIT", fit)
    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", interfaces)
    where = mesh.element_centroids() if on == "elements" else mesh.points
    labels = np.argmin(((where[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)
    res = relax(mesh, labels, on=on)
    h = mesh.mean_edge_length()
    true = Voronoi(sites).vertices
    true = true[np.abs(true).max(axis=1) < 0.9]
    apart = np.sort(np.linalg.norm(true[:, None] - true[None], axis=2), axis=1)[:, 1] >= 3 * h
    j = res.interfaces().junctions()
    found = j.points[j.simplices[:, 0]]
    d = np.linalg.norm(true[:, None] - found[None], axis=2).min(axis=1)
    return d / h, apart, res


@pytest.mark.parametrize("on", ["elements", "vertices"])
def test_fitted_junctions_lie_nearer_the_true_ones(on, monkeypatch):
    """The junctions fitted to the sites around them, and the defaults (refitted with
    their interfaces where they lie alone), lie nearer to the true Voronoi vertices than
    the relaxed ones."""
    mesh = kuhn_grid(50, 2, jitter=0.25, random_state=0)
    arms = {"relaxed": (False, False), "fitted": (True, False), "defaults": (True, True)}
    errors, alone = {arm: [] for arm in arms}, []
    for seed in range(3):
        sites = np.random.default_rng(seed).uniform(-0.7, 0.7, (6, 2))
        for arm, (fit, interfaces) in arms.items():
            d, apart, res = voronoi_junctions(mesh, sites, on, fit, monkeypatch, interfaces)
            errors[arm].append(d)
            if fit:
                assert res.params["fitted_junctions"] >= 2
            if arm == "defaults":
                assert res.params["refitted_junctions"] >= 1
                alone.append(apart)
    assert not np.concatenate(alone).all()  # the draws hold pairs of junctions nearer than 3 h
    d = {arm: np.concatenate(e) for arm, e in errors.items()}
    for arm in ("fitted", "defaults"):
        assert d[arm].mean() < 0.6 * d["relaxed"].mean() and d[arm].max() < 0.35, (arm, d[arm], d["relaxed"])


def test_the_fit_changes_the_partition_near_junctions_only(monkeypatch):
    monkeypatch.setattr(interface_fit, "INTERFACE_FIT", False)  # the interfaces' fit reaches along them
    mesh = kuhn_grid(40, 2, jitter=0.25, random_state=1)
    sites = np.array([[-0.5, -0.4], [0.5, -0.5], [0.1, 0.6], [-0.6, 0.5]])
    plain = voronoi_junctions(mesh, sites, fit=False, monkeypatch=monkeypatch)[2]
    fitted = voronoi_junctions(mesh, sites, fit=True, monkeypatch=monkeypatch)[2]
    # exact: no gap, no overlap
    assert fitted.region_measures().sum() == pytest.approx(mesh.A.sum(), rel=1e-9)
    # each region keeps its own relaxation; phi differs within BLEND h of a junction only
    for a, b in zip(plain.regions, fitted.regions, strict=True):
        np.testing.assert_array_equal(a.phi, b.phi)
    changed = np.flatnonzero(np.any(plain.phi != fitted.phi, axis=1))
    j = fitted.interfaces().junctions()
    centres = j.points[j.simplices[:, 0]]
    assert changed.size > 0
    reach = np.linalg.norm(mesh.points[changed][:, None] - centres[None], axis=2).min(axis=1)
    border = 1.0 - np.abs(mesh.points[changed]).max(axis=1)  # where interfaces meet the square's side
    assert np.minimum(reach, border).max() < (BLEND + 1.6) * mesh.mean_edge_length()
    # the filled phi and the sparse band values give the same partition, in either order
    labels = np.argmin(((mesh.element_centroids()[:, None] - sites) ** 2).sum(axis=2), axis=1)
    again = relax(mesh, labels, on="elements")
    np.testing.assert_allclose(again.phi, fitted.phi)
    np.testing.assert_allclose(again.region_measures(), fitted.region_measures(), rtol=1e-12)


def test_junctions_on_a_surface_are_fitted_in_its_tangent_plane(monkeypatch):
    sphere = icosphere(4)
    c = sphere.element_centroids()
    azimuth = np.arctan2(c[:, 1], c[:, 0]) % (2 * np.pi)
    labels = np.searchsorted(np.radians([0.0, 100.0, 230.0]), azimuth, side="right") - 1
    h = sphere.mean_edge_length()
    errors = {}
    for fit in (True, False):
        monkeypatch.setattr(junctions, "JUNCTION_FIT", fit)
        res = relax(sphere, labels, on="elements")
        j = res.interfaces().junctions()
        found = j.points[j.simplices[:, 0]]
        poles = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
        errors[fit] = np.linalg.norm(poles[:, None] - found[None], axis=2).min(axis=1) / h
        assert res.region_measures().sum() == pytest.approx(sphere.A.sum(), rel=1e-9)
        if fit:
            assert res.params["fitted_junctions"] == 2
    assert errors[True].max() < 0.5


def test_the_junctions_of_a_label_image_are_fitted(monkeypatch):
    from scipy.spatial import Voronoi, cKDTree

    sites = np.random.default_rng(2).uniform(0, 160, (8, 2))
    labels = cKDTree(sites).query(np.indices((160, 160)).reshape(2, -1).T)[1].reshape(160, 160)
    true = Voronoi(sites).vertices
    true = true[((true > 5) & (true < 154)).all(axis=1)]
    errors = {}
    for fit in (True, False):
        monkeypatch.setattr(junctions, "JUNCTION_FIT", fit)
        res = relax_image(labels)
        j = res.interfaces().junctions()
        errors[fit] = np.linalg.norm(true[:, None] - j.points[j.simplices[:, 0]][None], axis=2).min(axis=1)
        assert res.region_measures().sum() == pytest.approx(160 * 160, rel=1e-9)
    assert true.shape[0] >= 5
    assert errors[True].mean() < 0.7 * errors[False].mean() and errors[True].max() < 0.5


def test_a_pairs_linear_functions_tie_on_its_rays_and_short_interface():
    from ndboundary.pipeline.junctions import _pair_functions

    ends = np.array([[-1.0, 0.1], [0.9, -0.2]])
    angles = np.radians([140.0, 215.0, 35.0, 320.0])  # x|p, x|q from the first, y|p, y|q from the second
    linear = _pair_functions(ends, angles)

    def top_two(point):
        g = linear[:, :2] @ point + linear[:, 2]
        order = np.argsort(g)[::-1]
        return set(order[:2].tolist()), g[order[0]] - g[order[1]], g[order[1]] - g[order[2]]

    for end, rays in ((0, ((0, (2, 0)), (1, (2, 1)))), (1, ((2, (3, 0)), (3, (3, 1))))):
        for ray, pair in rays:
            point = ends[end] + 2.0 * np.array([np.cos(angles[ray]), np.sin(angles[ray])])
            regions, tie, lead = top_two(point)
            assert regions == set(pair) and tie == pytest.approx(0, abs=1e-12) and lead > 0
    regions, tie, lead = top_two(ends.mean(axis=0))  # the short interface parts p and q
    assert regions == {0, 1} and tie == pytest.approx(0, abs=1e-12) and lead > 0


@pytest.mark.parametrize("on", ["elements", "vertices"])
def test_interfaces_meet_the_border_nearer_the_truth(on, monkeypatch):
    """Where interfaces meet the square's side, the junctions' crossing fit (the
    interfaces' fit off) and the defaults (both fits, the interfaces' ends sliding along
    the border) each put them nearer to the true bisectors than the relaxation does."""
    mesh = kuhn_grid(50, 2, jitter=0.25, random_state=0)
    arms = {"relaxed": (False, False), "crossings": (True, False), "defaults": (True, True)}
    errors = {arm: [] for arm in arms}
    for seed in range(4):
        sites = np.random.default_rng(seed).uniform(-0.7, 0.7, (6, 2))
        where = mesh.element_centroids() if on == "elements" else mesh.points
        labels = np.argmin(((where[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)
        for arm, (crossings, interfaces) in arms.items():
            monkeypatch.setattr(junctions, "JUNCTION_FIT", crossings)
            monkeypatch.setattr(interface_fit, "INTERFACE_FIT", interfaces)
            faces = relax(mesh, labels, on=on).interfaces()
            x = faces.points[np.abs(faces.points).max(axis=1) > 1 - 1e-9]  # on the square's side
            a, b = np.argsort(((x[:, None] - sites[None]) ** 2).sum(axis=2), axis=1)[:, :2].T
            n = (sites[b] - sites[a]) / np.linalg.norm(sites[b] - sites[a], axis=1)[:, None]
            errors[arm].append(np.abs(((x - (sites[a] + sites[b]) / 2) * n).sum(axis=1)))
    mean = {arm: np.concatenate(e).mean() for arm, e in errors.items()}
    assert np.concatenate(errors["relaxed"]).size >= 12
    assert mean["crossings"] < 0.8 * mean["relaxed"] and mean["defaults"] < 0.8 * mean["relaxed"], mean
