"""Pictures draw what they are given."""

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")

from ndboundary import relax  # noqa: E402
from ndboundary.datasets import circle, icosphere, kuhn_grid, label_by  # noqa: E402
from ndboundary.plot import figure_relaxation, plot_domain, plot_relaxation  # noqa: E402


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
