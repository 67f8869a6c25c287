"""Make the README's pictures: the paper's Fig. 1 on a jittered grid and on a sphere, and the
demo's many-region case (a Voronoi partition by 7 sites), jagged beside relaxed.

Run: ``python docs/make_pictures.py`` (needs matplotlib); writes docs/flower.png, docs/sphere.png
and docs/regions.png.
"""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")

from ndboundary import relax  # noqa: E402
from ndboundary.datasets import flower, icosphere, kuhn_grid, label_by  # noqa: E402
from ndboundary.plot import figure_partition, figure_relaxation  # noqa: E402

HERE = Path(__file__).resolve().parent


def main():
    grid = kuhn_grid(80, 2, jitter=0.25, random_state=0)
    labels = label_by(grid, flower)
    fig = figure_relaxation(relax(grid, labels, on="elements"), labels, zoom=(-0.75, 0.75, -0.75, 0.75),
                            title="five-lobed flower on a jittered 80 x 80 triangle grid (default parameters)")
    fig.savefig(HERE / "flower.png", dpi=90)

    sphere = icosphere(4)
    labels = label_by(sphere, lambda x: x[:, 2] - 0.3 + 0.3 * x[:, 0] ** 2)
    fig = figure_relaxation(relax(sphere, labels, on="elements"), labels, title="a curve on a sphere (2 562 vertices)")
    fig.savefig(HERE / "sphere.png", dpi=80)

    # the case of `ndboundary demo`: each element labelled by the site nearest its centroid
    sites = np.random.default_rng(0).uniform(-0.8, 0.8, (7, 2))
    c = grid.element_centroids()
    labels = np.argmin(((c[:, None, :] - sites[None]) ** 2).sum(axis=2), axis=1)
    fig = figure_partition(relax(grid, labels, on="elements"), labels,
                           title="7 Voronoi regions on a jittered 80 x 80 triangle grid (default parameters)")
    fig.savefig(HERE / "regions.png", dpi=85)


if __name__ == "__main__":
    main()
