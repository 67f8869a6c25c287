"""Make the README's pictures: the paper's Fig. 1 on a jittered grid and on a sphere, and the
demo's many-region case (a Voronoi partition by 7 sites), jagged beside relaxed.

Run: ``python docs/make_pictures.py`` (needs matplotlib); writes docs/flower.png, docs/sphere.png
and docs/regions.png.
"""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")

from ndboundary import relax, relax_image  # noqa: E402
from ndboundary.datasets import flower, icosphere, kuhn_grid, label_by  # noqa: E402
from ndboundary.plot import figure_partition, figure_relaxation  # noqa: E402

HERE = Path(__file__).resolve().parent


def voxels(path, n=32):
    """A torus voxelised on an n^3 grid: the voxels' staircase beside the relaxed surface."""
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    x, y, z = (np.indices((n, n, n)) - (n - 1) / 2) / (0.375 * n)
    torus = (np.sqrt(x**2 + y**2) - 0.75) ** 2 + z**2 < 0.33**2
    result = relax_image(torus)
    surface = result.level_set()
    fig = plt.figure(figsize=(10, 3.8))
    shown = (("voxel labels (staircase)", result.domain.points, result.boundary.facets),
             ("relaxed (default parameters)", surface.points, surface.simplices))
    for p, (title, points, triangles) in enumerate(shown):
        ax = fig.add_subplot(1, 2, p + 1, projection="3d")
        tri = points[triangles]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.linalg.norm(normal, axis=1, keepdims=True) + 1e-300
        light = np.clip(np.abs(normal @ np.array([0.4, -0.5, 0.77])), 0.15, 1.0)
        ax.add_collection3d(Poly3DCollection(tri, facecolors=plt.cm.Blues(0.35 + 0.6 * light), edgecolors="none"))
        lo, hi = tri.min(axis=(0, 1)), tri.max(axis=(0, 1))
        mid, half = (lo + hi) / 2, (hi - lo).max() / 2
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - 0.45 * half, mid[2] + 0.45 * half)
        ax.set_box_aspect((1, 1, 0.45), zoom=1.35)
        ax.view_init(elev=35, azim=-60)
        ax.set_axis_off()
        ax.set_title(title, y=0.92)
    fig.subplots_adjust(left=0, right=1, bottom=0, top=1, wspace=0)
    fig.savefig(path, dpi=80)


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

    voxels(HERE / "voxels.png")


if __name__ == "__main__":
    main()
