"""Inputs that used to give a silently wrong answer: they now give the right one, or say why not."""

import warnings

import numpy as np
import pytest

from ndboundary import MeshQualityWarning, PolygonMesh, SimplicialComplex, relax
from ndboundary.datasets import flower, kuhn_grid, label_by
from ndboundary.solvers import ConvergenceWarning


def disc_in_rings(n, fan=False):
    """A central n-gon (or its fan) inside two rings of quads, on circles of radii 1, 2, 3;
    labels 0 on the n-gon and the inner ring, 1 on the outer ring: the truth is the circle r = 2."""
    th = 2 * np.pi * np.arange(n) / n
    points = np.concatenate([np.c_[r * np.cos(th), r * np.sin(th)] for r in (1, 2, 3)])
    polygons = []
    if fan:
        points = np.vstack([points, [0.0, 0.0]])
        polygons += [[len(points) - 1, i, (i + 1) % n] for i in range(n)]
    else:
        polygons.append(list(range(n)))
    for ring in (0, 1):
        a, b = ring * n, (ring + 1) * n
        polygons += [[a + i, a + (i + 1) % n, b + (i + 1) % n, b + i] for i in range(n)]
    inner = n if fan else 1
    return PolygonMesh(points, polygons), np.r_[np.zeros(inner + n, int), np.ones(n, int)]


@pytest.mark.parametrize("n", [20, 100])
@pytest.mark.parametrize("fan", [False, True])
def test_large_polygon_next_to_a_ring_of_small_cells(n, fan):
    mesh, labels = disc_in_rings(n, fan)
    res = relax(mesh, labels, on="elements")
    curve = res.level_set()
    polygon = 2 * n * 2 * np.sin(np.pi / n)  # the jagged boundary: the n-gon of radius 2
    assert curve.n_components() == 1 and curve.is_closed()
    assert curve.measure() == pytest.approx(polygon, rel=0.01)
    outer = np.arange(2 * n, 3 * n)
    assert res.phi[outer].min() > 0.5  # the outer ring lies in region 1 all around


def test_fan_and_polygon_agree():
    a = relax(*disc_in_rings(20), on="elements").level_set().measure()
    b = relax(*disc_in_rings(20, fan=True), on="elements").level_set().measure()
    assert a == pytest.approx(b, rel=0.01)


@pytest.mark.parametrize("squash", [1e-2, 1e-4, 1e-6])
def test_skinny_triangles_say_why_not(squash):
    grid = kuhn_grid(30, 2, jitter=0.25, random_state=0)
    labels = label_by(grid, flower)
    thin = SimplicialComplex(grid.points * [1, squash], grid.simplices)
    with pytest.warns(MeshQualityWarning, match=r"aspect ratio of .*Worst elements \(aspect ratio\): \d+ \(") as caught:
        res = relax(thin, labels, on="elements")
    assert np.all(np.isfinite(res.phi))
    assert [w.filename for w in caught if w.category is MeshQualityWarning] == [__file__]


def test_a_flat_element_in_the_band_is_named_by_its_index_in_the_mesh():
    grid = kuhn_grid(160, 2)  # enough vertices for relax to work on the band around zeta
    labels = label_by(grid, lambda x: np.linalg.norm(x, axis=1) - 0.5)
    c = grid.element_centroids()
    e = int(np.flatnonzero(np.abs(np.linalg.norm(c, axis=1) - 0.5) < 0.01)[0])  # on zeta
    a, b, d = grid.simplices[e]
    points = grid.points.copy()
    points[d] += (1 - 1e-7) * (0.5 * (points[a] + points[b]) - points[d])  # onto the opposite edge
    flat = SimplicialComplex(points, grid.simplices)
    worst = int(np.argmax(flat.aspect_ratios()))
    with pytest.warns(MeshQualityWarning, match=rf"Worst elements \(aspect ratio\): {worst} \(") as caught:
        res = relax(flat, labels, on="elements")
    assert res.params["band_vertices"] < flat.n_vertices
    # at the line that called relax, not inside the band's steps
    assert [w.filename for w in caught if w.category is MeshQualityWarning] == [__file__]


def test_well_shaped_meshes_do_not_warn():
    grid = kuhn_grid(24, 3, jitter=0.25, random_state=0)  # a few slivers among well-shaped tetrahedra
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        relax(grid, label_by(grid, lambda x: np.linalg.norm(x, axis=1) - 0.6), on="elements")


@pytest.mark.parametrize(("params", "step"), [({"t": 1e10}, "heat"), ({"rtol": 1e-30}, "heat")])
def test_unconverged_solves_warn_with_the_residual(params, step):
    grid = kuhn_grid(20, 2, jitter=0.25, random_state=0)
    with pytest.warns(ConvergenceWarning, match=rf"{step} \(step \d\) solve did not converge: relative residual \d"):
        res = relax(grid, label_by(grid, flower), on="elements", **params)
    assert res.solver[step].residual > 10 * params.get("rtol", 1e-10)
