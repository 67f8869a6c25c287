"""The band: relax near zeta only, and a usable phi outside it."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from ndboundary import SimplicialComplex, relax
from ndboundary.datasets import ball, circle, flower, hex_grid, icosphere, kuhn_grid, label_by, voronoi_polygons


def level_set_gap(a, b, h):
    """Mean and max distance between two level sets, in units of h (both ways for the max)."""
    pa, pb = a.level_set().points, b.level_set().points
    ab, ba = cKDTree(pb).query(pa)[0] / h, cKDTree(pa).query(pb)[0] / h
    return ab.mean(), max(ab.max(), ba.max())


@pytest.mark.parametrize(
    "make",
    [
        lambda: (kuhn_grid(200, 2, jitter=0.25, random_state=0), flower),
        lambda: (icosphere(5), lambda x: x[:, 2] - 0.3),
        lambda: (voronoi_polygons(100, random_state=0), circle),
    ],
    ids=["triangles", "surface", "polygons"],
)
def test_band_matches_the_whole_domain(make):
    mesh, truth = make()
    labels = label_by(mesh, truth)
    whole = relax(mesh, labels, on="elements", band=None)
    band = relax(mesh, labels, on="elements")
    assert band.params["band_vertices"] < 0.9 * mesh.n_vertices
    mean, worst = level_set_gap(band, whole, mesh.mean_edge_length())
    assert mean <= 0.01 and worst <= 0.05
    assert band.level_set().n_components() == whole.level_set().n_components()


def test_phi_outside_the_band_is_a_signed_distance():
    mesh = kuhn_grid(80, 2, jitter=0.25, random_state=0)
    labels = label_by(mesh, circle)
    res = relax(mesh, labels, on="elements", band=6)
    phi, h = res.phi, mesh.mean_edge_length()
    assert np.isfinite(phi).all()
    inside = circle(mesh.points) < -6 * h
    outside = circle(mesh.points) > 6 * h
    assert (phi[inside] > 0.5).all() and (phi[outside] < 0.5).all()
    # continuous across the band's edge: neighbours differ by about their distance in h
    e = mesh.edges
    step = np.abs(phi[e[:, 0]] - phi[e[:, 1]]) - np.linalg.norm(mesh.points[e[:, 0]] - mesh.points[e[:, 1]], axis=1) / h
    assert step.max() < 1.0
    # grows away from zeta like the distance to the circle, in units of h
    far = np.abs(circle(mesh.points)) > 10 * h
    slope = np.polyfit(np.abs(circle(mesh.points[far])) / h, np.abs(phi[far] - 0.5), 1)[0]
    assert 0.8 < slope < 1.4


def test_band_covering_the_domain_is_the_whole_domain_solve():
    mesh = kuhn_grid(12, 3, jitter=0.2, random_state=0)
    labels = label_by(mesh, ball)
    np.testing.assert_array_equal(
        relax(mesh, labels, on="elements", band=1e3).phi, relax(mesh, labels, on="elements", band=None).phi
    )


def test_band_with_components_without_boundary_and_several_boundaries():
    a = kuhn_grid(30, 2)
    points = np.concatenate([a.points, a.points + [3.0, 0.0], a.points + [6.0, 0.0]])
    simplices = np.concatenate([a.simplices + i * a.n_vertices for i in range(3)])
    mesh = SimplicialComplex(points, simplices)
    c = mesh.element_centroids()
    labels = ((np.linalg.norm(c - [0.0, 0.0], axis=1) < 0.5) | (np.linalg.norm(c - [3.0, 0.0], axis=1) < 0.5)).astype(
        int
    )
    res = relax(mesh, labels, on="elements", band=5)
    assert np.isfinite(res.phi).all()
    third = points[:, 0] > 5.0  # no boundary there: region 0, below 1/2
    assert (res.phi[third] < 0.5).all()
    assert res.level_set().n_components() == 2


def test_band_on_vertex_labels_and_hexahedra():
    mesh = kuhn_grid(60, 2, jitter=0.2, random_state=1)
    labels = label_by(mesh, circle, on="vertices")
    whole, band = relax(mesh, labels, on="vertices", band=None), relax(mesh, labels, on="vertices", band=24)
    assert level_set_gap(band, whole, mesh.mean_edge_length())[0] <= 0.01
    hexes = hex_grid(16, jitter=0.2, random_state=0)
    res = relax(hexes, label_by(hexes, ball), on="elements", band=4)
    assert res.params["band_vertices"] < hexes.n_vertices and res.level_set().is_closed()


@pytest.mark.parametrize(
    ("band", "err", "match"),
    [("wide", ValueError, "band must be"), (-1.0, ValueError, "band"), ([3], TypeError, "band")],
)
def test_band_errors(band, err, match):
    mesh = kuhn_grid(8, 2)
    with pytest.raises(err, match=match):
        relax(mesh, label_by(mesh, circle), on="elements", band=band)
