"""The ``ndboundary demo`` command: built-in jagged segmentations relaxed against their known truth.

:func:`cmd_demo` relaxes a 2-D flower, a 3-D ball and a partition of the plane into 7
Voronoi regions with the default parameters, prints each one's distance to the exact
boundaries (in units of h) and writes phi (VTU), the jagged and relaxed boundaries, the
regions' interfaces (OBJ) and pictures (PNG) to :data:`DEMO_DIR` or ``--out``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

__all__ = ["DEMO_DIR", "cmd_demo"]

#: Where ``ndboundary demo`` writes its files without ``--out``, relative to the current directory.
DEMO_DIR = "ndboundary-demo"


def _demo_cases():
    from . import datasets as ds

    yield "2-D flower, jittered triangles 80x80", ds.kuhn_grid(80, 2, jitter=0.25, random_state=0), ds.flower, 2 / 80
    yield "3-D ball, jittered tetrahedra 24^3", ds.kuhn_grid(24, 3, jitter=0.25, random_state=0), ds.ball, 2 / 24


def _flower_truth():
    """Distance to the flower curve and the curve's length."""
    from .datasets import flower_curve
    from .metrics import closed_curve_length, curve_distance

    c = flower_curve()
    return curve_distance(c), closed_curve_length(c)


def _write_files(out, stem, result, labels, relaxed, jagged):
    from . import io

    io.write_level_set(out / f"{stem}_relaxed.obj", relaxed)
    io.write_level_set(out / f"{stem}_jagged.obj", jagged)
    try:
        io.write_phi(out / f"{stem}_phi.vtu", result, labels=labels)
    except ImportError:
        print("meshio is not installed: no VTU file (pip install 'ndboundary[io]')", file=sys.stderr)


def _save_picture(result, labels, path):
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        print("matplotlib is not installed: no picture (pip install 'ndboundary[plot]')", file=sys.stderr)
        return
    from .plot import figure_relaxation

    fig = figure_relaxation(result, labels, zoom=(-0.75, 0.75, -0.75, 0.75))
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def _regions_case():
    """The many-region case: a Voronoi partition of [-1, 1]^2 by 7 fixed sites, labelled by
    element centroid, whose true interfaces are the sites' bisectors.
    """
    from . import datasets as ds

    mesh = ds.kuhn_grid(80, 2, jitter=0.25, random_state=0)
    sites = np.random.default_rng(0).uniform(-0.8, 0.8, (7, 2))
    c = mesh.element_centroids()
    labels = np.argmin(((c[:, None, :] - sites[None]) ** 2).sum(axis=2), axis=1)
    return "7 Voronoi regions, triangles 80x80", mesh, sites, labels


def _voronoi_fidelity(result, sites):
    """How far the relaxed partition is from the exact Voronoi diagram of ``sites`` (one site per
    class of ``result``, in order): the interface points' distance to their pair's bisector in
    units of h (mean, max), the junctions found and the true ones, and the largest relative
    error of a region's area in %.

    The truth is the exact partition of the domain by the linear functions ``2 x . s - |s|^2``
    (the largest is the nearest site's), so it holds the true junctions inside the domain and
    the true region areas.
    """
    from .partition import partition

    dom = result.domain
    h = dom.mean_edge_length()
    faces = result.interfaces()
    a, b = sites[faces.pairs[:, 0]], sites[faces.pairs[:, 1]]
    normal = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    corners = faces.points[faces.simplices]  # (n, 2, 2): the two ends of every interface segment
    dist = np.abs(((corners - 0.5 * (a + b)[:, None, :]) * normal[:, None, :]).sum(axis=2)) / h
    points, simplices, _ = dom.level_set_complex(np.zeros(dom.n_vertices))
    exact = partition(points, simplices, 2 * points @ sites.T - (sites**2).sum(axis=1))
    area_err = 100 * np.abs(result.region_measures() / exact.region_measures() - 1)
    return {
        "mean": float(dist.mean()),
        "max": float(dist.max()),
        "junctions": len(faces.junctions()),
        "true_junctions": len(exact.interfaces().junctions()),
        "area_err": float(area_err.max()),
    }


def _demo_regions(out, verbose):
    """Relax the many-region case, print its fidelity line and write its region functions (VTU,
    when meshio is installed: its absence is reported by the other cases) and its interfaces (OBJ).

    Returns the result and the labels, for the picture.
    """
    from . import io
    from .pipeline import relax

    name, mesh, sites, labels = _regions_case()
    res = relax(mesh, labels, on="elements", verbose=verbose)
    f = _voronoi_fidelity(res, sites[res.classes])
    print(
        f"{name}: interfaces {f['mean']:.3f} h from the true bisectors (max {f['max']:.3f} h, h = mean edge "
        f"length), junctions {f['junctions']} found, {f['true_junctions']} true, areas within {f['area_err']:.2f}%, "
        f"{res.timings['total']:.2f}s"
    )
    io.write_level_set(out / "regions2d_interfaces.obj", res.interfaces())
    try:
        io.write_phi(out / "regions2d_phi.vtu", res, labels=labels)
    except ImportError:
        pass
    return res, labels


def _save_partition_picture(result, labels, path):
    """The regions' picture (:func:`ndboundary.plot.figure_partition`); without matplotlib none,
    which the flower's picture has already reported.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
    except ImportError:
        return
    from .plot import figure_partition

    import matplotlib.pyplot as plt

    fig = figure_partition(result, labels)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    print(f"wrote {path}")


def cmd_demo(args):
    """``ndboundary demo``: relax the built-in cases, print their fidelity and write their files to ``args.out``."""
    from . import datasets as ds
    from .metrics import as_complex, fidelity
    from .pipeline import relax

    out = Path(args.out) if args.out else Path(DEMO_DIR)
    out.mkdir(parents=True, exist_ok=True)
    pictures = []
    print(f"{'case':<38s} {'':>9s} {'mean/h':>7s} {'max/h':>7s} {'excess':>8s} {'time':>7s}")
    for name, dom, truth, s in _demo_cases():
        labels = ds.label_by(dom, truth)
        res = relax(dom, labels, on="elements", verbose=args.verbose)
        ls = res.level_set()
        jag = as_complex(dom.points, res.boundary.facets)
        if truth is ds.flower:
            dist, true_measure = _flower_truth()
        else:
            dist, true_measure = truth, 4 * np.pi * 0.6**2
        for tag, cx in (("jagged", jag), ("relaxed", ls)):
            f = fidelity(cx, dist, s)
            excess = 100 * (cx.measure() / true_measure - 1)
            t = f"{res.timings['total']:6.2f}s" if tag == "relaxed" else ""
            print(
                f"{name if tag == 'jagged' else '':<38s} {tag:>9s} {f['mean']:7.3f} {f['max']:7.3f} "
                f"{excess:+7.2f}% {t:>7s}"
            )
        stem = "flower2d" if dom.dim == 2 else "ball3d"
        _write_files(out, stem, res, labels, ls, jag)
        if dom.dim == 2:
            pictures.append((res, labels, out / f"{stem}.png"))
    print("h = grid cell size; excess = length (2-D) or area (3-D) over the true boundary's")
    regions = _demo_regions(out, args.verbose)
    print(f"wrote phi (VTU), the jagged and relaxed boundaries and the regions' interfaces (OBJ) to {out}/")
    for job in pictures:
        _save_picture(*job)
    _save_partition_picture(*regions, out / "regions2d.png")
    return 0
