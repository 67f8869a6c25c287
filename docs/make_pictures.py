"""Make the README's pictures: the paper's Fig. 1 on a jittered grid and on a sphere.

Run: ``python docs/make_pictures.py`` (needs matplotlib); writes docs/flower.png and docs/sphere.png.
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from ndboundary import relax  # noqa: E402
from ndboundary.datasets import flower, icosphere, kuhn_grid, label_by  # noqa: E402
from ndboundary.plot import figure_relaxation  # noqa: E402

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


if __name__ == "__main__":
    main()
