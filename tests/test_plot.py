"""Pictures draw what they are given."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from ndboundary import relax  # noqa: E402
from ndboundary.datasets import circle, icosphere, kuhn_grid, label_by  # noqa: E402
from ndboundary.plot import (  # noqa: E402
    figure_partition,
    figure_relaxation,
    plot_domain,
    plot_partition,
    plot_relaxation,
)


def test_planar_figure(tmp_path):
    dom = kuhn_grid(12, 2, jitter=0.2, random_state=0)
    labels = label_by(dom, circle)
    res = relax(dom, labels, on="elements")
    fig = figure_relaxation(res, labels, title="circle")
    assert len(fig.axes) == 3
    # the relaxed panel holds the triangles, the jagged boundary and the level set
    assert len(fig.axes[2].collections) == 3
    fig.savefig(tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000


def test_surface_and_single_axes():
    dom = icosphere(2)
    res = relax(dom, label_by(dom, lambda x: x[:, 2]), on="elements")
    ax = plot_relaxation(res)
    assert ax.name == "3d"
    assert len(ax.collections) == 3


def test_refuses_solids():
    dom = kuhn_grid(2, 3)
    with pytest.raises(ValueError, match="triangles or polygons"):
        plot_domain(dom, phi=np.zeros(dom.n_vertices))


def _three_regions(n=16):
    dom = kuhn_grid(n, 2, jitter=0.2, random_state=0)
    c = dom.element_centroids()
    labels = np.where(c[:, 0] < 0, 0, np.where(c[:, 1] < -0.2, 1, 2))  # a T of three regions
    return dom, labels, relax(dom, labels, on="elements")


def _by_gid(ax, gid):
    (coll,) = [c for c in ax.collections if c.get_gid() == gid]
    return coll


def test_partition_figure_marks_every_junction(tmp_path):
    dom = kuhn_grid(20, 2, jitter=0.2, random_state=1)
    sites = np.random.default_rng(0).uniform(-0.8, 0.8, (5, 2))
    c = dom.element_centroids()
    labels = np.argmin(((c[:, None, :] - sites[None]) ** 2).sum(axis=2), axis=1)
    res = relax(dom, labels, on="elements")
    n_junctions = len(res.interfaces().junctions())
    assert n_junctions >= 2
    fig = figure_partition(res, labels, title="five regions", zoom=(-1, 1, -1, 1))
    assert len(fig.axes) == 2
    assert len(_by_gid(fig.axes[1], "junctions").get_offsets()) == n_junctions
    assert not [c for c in fig.axes[0].collections if c.get_gid() == "junctions"]
    fig.savefig(tmp_path / "p.png")
    assert (tmp_path / "p.png").stat().st_size > 1000


def test_partition_panels_colour_a_region_alike():
    dom, labels, res = _three_regions()
    fig = figure_partition(res, labels)
    elements = _by_gid(fig.axes[0], "elements").get_facecolors()
    cells = _by_gid(fig.axes[1], "cells").get_facecolors()
    regions = res.partition().cells.regions
    for r in range(3):
        mine = np.unique(elements[labels == r], axis=0)
        assert len(mine) == 1
        np.testing.assert_array_equal(np.unique(cells[regions == r], axis=0), mine)
    # and different regions differ
    assert len(np.unique(elements, axis=0)) == 3


def test_partition_of_two_regions_and_single_axes():
    dom = kuhn_grid(12, 2, jitter=0.2, random_state=0)
    labels = label_by(dom, circle)
    res = relax(dom, labels, on="elements")
    fig = figure_partition(res, labels)
    assert len(_by_gid(fig.axes[1], "junctions").get_offsets()) == 0
    ax = plot_partition(res)
    assert [c.get_gid() for c in ax.collections] == ["cells", "interfaces", "junctions"]


def test_partition_refuses_surfaces_and_foreign_labels():
    dom = icosphere(2)
    labels = label_by(dom, lambda x: x[:, 2])
    res = relax(dom, labels, on="elements")
    with pytest.raises(ValueError, match="planar domain"):
        figure_partition(res, labels)
    with pytest.raises(ValueError, match="planar domain"):
        plot_partition(res)
    _, labels, res = _three_regions(8)
    with pytest.raises(ValueError, match="not one of the result's classes"):
        figure_partition(res, np.where(labels == 2, 7, labels))
    with pytest.raises(ValueError, match="one label per element"):
        figure_partition(res, labels[:-1])
