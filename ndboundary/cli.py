"""The ``ndboundary`` command line."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .cli_files import (
    BOUNDARY_EXTENSIONS,
    PHI_EXTENSIONS,
    CLIError,
    atomic_outputs,
    check_input,
    check_outputs,
    one_line,
    reading,
    writable_labels,
)

__all__ = ["main"]

#: Where ``ndboundary demo`` writes its files without ``--out``, relative to the current directory.
DEMO_DIR = "ndboundary-demo"
#: The largest ``--smoothing`` accepted (passes of the field smoothing).
MAX_SMOOTHING = 10_000
#: The largest ``--lam`` accepted (weight of the boundary term), as the messages write it.
MAX_LAM = "1e6"
#: Meshes with at least this many vertices show per-step progress on a terminal (unless ``--quiet``).
PROGRESS_VERTICES = 50_000


def _smoothing_passes(text):
    """``--smoothing``: an integer in [0, MAX_SMOOTHING].

    Examples
    --------
    >>> _smoothing_passes("20")
    20
    >>> _smoothing_passes("99999999999999999999999")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be an integer in [0, 10000], got '99999999999999999999999'
    """
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= MAX_SMOOTHING:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, {MAX_SMOOTHING}], got {text!r}")
    return value


def _band(text):
    """``--band``: ``auto``, ``none`` or a positive finite width in units of h.

    Examples
    --------
    >>> _band("auto"), _band("none"), _band("40")
    ('auto', None, 40.0)
    >>> _band("-1")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be 'auto', 'none' or a width in units of h above 0, got '-1'
    """
    if text.lower() in ("auto", "none"):
        return None if text.lower() == "none" else "auto"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be 'auto', 'none' or a width in units of h above 0, got {text!r}")
    return value


def _lam_weight(text):
    """``--lam``: a finite float in (0, MAX_LAM].

    Examples
    --------
    >>> _lam_weight("0.5")
    0.5
    >>> _lam_weight("nan")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: must be a finite number in (0, 1e6], got 'nan'
    """
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0 < value <= float(MAX_LAM)):
        raise argparse.ArgumentTypeError(f"must be a finite number in (0, {MAX_LAM}], got {text!r}")
    return value


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


def cmd_demo(args):
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
    print(f"wrote phi (VTU) and the jagged and relaxed boundaries (OBJ) to {out}/")
    for job in pictures:
        _save_picture(*job)
    return 0


def _labels_on(args, domain, n):
    """Whether the ``n`` labels are on elements or vertices: by ``--on``, else by their count."""
    counts = {"elements": domain.n_elements, "vertices": domain.n_vertices}
    fits = [on for on, count in counts.items() if count == n and args.on in ("auto", on)]
    if not fits:
        given = "" if args.on == "auto" else f" (--on {args.on})"
        raise CLIError(
            f"{args.labels} holds {n} labels but {args.mesh} has {domain.n_elements} elements and "
            f"{domain.n_vertices} vertices{given}"
        )
    if len(fits) > 1:
        raise CLIError(f"{args.mesh} has as many vertices as elements ({n}): say --on elements or --on vertices")
    return fits[0]


def cmd_relax(args):
    from . import io
    from .pipeline import relax

    check_input(args.mesh, "mesh")
    check_input(args.labels, "labels")
    wanted = [("-o", args.output, PHI_EXTENSIONS)]
    if args.boundary:
        wanted.append(("--boundary", args.boundary, BOUNDARY_EXTENSIONS))
    outputs = check_outputs(wanted, [("the mesh", args.mesh), ("the labels", args.labels)])
    with reading(args.labels):
        labels = io.read_labels(args.labels)
    n_classes = np.unique(labels).size
    if n_classes > 2:
        raise CLIError(
            f"{args.labels} holds {n_classes} classes; the command line relaxes two, and three or more "
            "are relaxed by ndboundary.relax in Python"
        )
    data = writable_labels(labels)  # what the VTK writers store: booleans and strings become 0/1
    with reading(args.mesh):
        domain = io.read_mesh(args.mesh)
    on = _labels_on(args, domain, len(labels))
    if args.boundary and domain.element_dim < 2:
        raise CLIError(f"--boundary {args.boundary}: the boundary on a curve is points, which no format holds")
    show = not args.quiet and sys.stderr.isatty() and domain.n_vertices >= PROGRESS_VERTICES
    kwargs = {}
    if args.lam is not None:
        kwargs["lam"] = args.lam
    if args.smoothing is not None:
        kwargs["smoothing"] = args.smoothing
    res = relax(domain, labels, on=on, verbose=show, band=args.band, **kwargs)
    ls = res.level_set()
    with atomic_outputs(outputs) as temporary:  # both outputs written, or neither
        io.write_phi(temporary[0], res, labels=data if on == "elements" else None)
        if args.boundary:
            io.write_level_set(temporary[1], ls)
    t = res.timings
    print(
        f"{args.mesh}: {domain.n_vertices} vertices, {domain.n_elements} elements, labels on {on}\n"
        f"jagged boundary: {res.boundary.S.shape[0]} points; relaxed boundary: {ls.n_points} points, "
        f"{ls.n_simplices} simplices, {ls.n_components()} component(s)\n"
        f"time: heat {t['heat']:.3f} s, field {t['field']:.3f} s, smoothing {t['smoothing']:.3f} s, "
        f"integration {t['integration']:.3f} s, total {t['total']:.3f} s"
        + (
            f" (on the band of {res.params['band']:.3g} h around the jagged boundary: "
            f"{res.params['band_vertices']} vertices)\n"
            if "band" in res.params
            else " (on the whole mesh)\n"
        )
        + f"wrote {args.output}"
        + (f" and {args.boundary}" if args.boundary else "")
    )
    return 0


def build_parser():
    parser = argparse.ArgumentParser(
        prog="ndboundary",
        description="Relax jagged boundaries between two labelled regions into smooth level sets.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser(
        "demo",
        help="relax built-in jagged segmentations with a known smooth truth and report fidelity",
        description="Relax built-in jagged segmentations (2-D flower, 3-D ball) with default "
        "parameters and print their distance to the known smooth truth.",
    )
    demo.add_argument(
        "--out",
        metavar="DIR",
        help="folder for phi (VTU), the jagged and relaxed boundaries (OBJ) and the picture "
        f"(default: ./{DEMO_DIR}, created if missing)",
    )
    demo.add_argument("--verbose", action="store_true", help="print per-step times")
    demo.set_defaults(func=cmd_demo)

    rel = sub.add_parser(
        "relax",
        help="relax the boundary of a labelled mesh read from files",
        description="Read a mesh and one label per element (or per vertex), relax the boundary "
        "between the two labels, write phi and the labels (VTU for ParaView) and the smooth boundary. "
        "No output may be an input; each is written whole or not at all.",
        usage="%(prog)s MESH LABELS -o OUT.vtu [--boundary OUT.obj] [options]",
    )
    rel.add_argument("mesh", help="OBJ, OFF, PLY, STL, MEDIT .mesh, VTK/VTU, Gmsh .msh or .hedra file")
    rel.add_argument("labels", help="one label per line (optionally after 'SCALAR_FIELD n'), or .npy")
    rel.add_argument(
        "-o", "--output", required=True, metavar="OUT.vtu", help="where to write phi and the labels (.vtu or .vtk)"
    )
    rel.add_argument(
        "--boundary", metavar="OUT.obj", help="where to write the relaxed boundary (.obj, .ply, .vtk or .vtu)"
    )
    rel.add_argument("--lam", type=_lam_weight, help=f"weight of the boundary term, in (0, {MAX_LAM}] (default 2.0)")
    rel.add_argument(
        "--smoothing", type=_smoothing_passes, help=f"field smoothing passes, 0 to {MAX_SMOOTHING} (default 60)"
    )
    rel.add_argument(
        "--on",
        choices=("auto", "elements", "vertices"),
        default="auto",
        help="what the labels are given on (default: by their count; required when the mesh has as many "
        "vertices as elements)",
    )
    rel.add_argument(
        "--band",
        type=_band,
        default="auto",
        metavar="{auto,none,WIDTH}",
        help="relax only within this graph distance of the jagged boundary, in mean edge lengths, and fill phi "
        "outside without a solve (default auto: 30 on surfaces, 16 on solids, the whole mesh when small); "
        "none relaxes the whole mesh",
    )
    rel.add_argument("--quiet", action="store_true", help="no progress display")
    rel.set_defaults(func=cmd_relax)
    return parser


def main(argv=None):
    """Run the ``ndboundary`` command with the arguments ``argv`` (default: the command line).

    Returns the exit status: 0 on success, 1 on an error (reported as one line on stderr,
    ``ndboundary: error: ...``), 2 when no command is given, 130 when interrupted (Ctrl-C;
    ``relax`` then leaves every file as it was). Arguments argparse refuses (an unknown
    option, ``--smoothing`` or ``--lam`` out of range) raise ``SystemExit(2)`` after a
    usage line and an error line.

    Examples
    --------
    >>> from ndboundary.cli import main
    >>> main(["relax", "no-such-mesh.obj", "labels.txt", "-o", "out.vtu"])
    1
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return args.func(args)
    except KeyboardInterrupt:
        print("ndboundary: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # anything a user can cause is reported as one line, never a traceback
        print(f"ndboundary: error: {one_line(exc)}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
