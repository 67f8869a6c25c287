"""The ``ndboundary`` command line: the parser, ``ndboundary relax`` and :func:`main`.

``ndboundary demo`` is in :mod:`ndboundary.cli_demo`; the checks and atomic writes of
the files in :mod:`ndboundary.cli_files`, those of several regions' outputs in
:mod:`ndboundary.cli_regions`.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from .cli_demo import DEMO_DIR, cmd_demo
from .cli_image import cmd_relax_image, is_image
from .cli_files import (
    BOUNDARY_EXTENSIONS,
    PHI_EXTENSIONS,
    CLIError,
    atomic_outputs,
    check_boundary_format,
    check_input,
    check_outputs,
    one_line,
    reading,
    writable_labels,
)
from .cli_regions import SURFACE_FORMATS, RegionProgress, check_folder, region_surface_paths

__all__ = ["main"]

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

    if args.labels is None:
        if is_image(args.mesh):
            check_input(args.mesh, "image")
            return cmd_relax_image(args)
        raise CLIError(f"{args.mesh} is a mesh: give its labels file too (MESH LABELS), or a label image alone")
    if is_image(args.mesh):
        raise CLIError(f"{args.mesh} is a label image, which holds its labels: give it alone")
    if not args.output:
        raise CLIError("-o OUT.vtu is needed for a mesh: where to write phi and the labels")
    if args.background is not None:
        raise CLIError("--background is for label images: a mesh's regions are all written")
    if args.fit != "auto":
        raise CLIError("--fit is for label images: a mesh's boundary is the relaxed one")
    check_input(args.mesh, "mesh")
    check_input(args.labels, "labels")
    wanted = [("-o", args.output, PHI_EXTENSIONS)]
    if args.boundary:
        wanted.append(("--boundary", args.boundary, BOUNDARY_EXTENSIONS))
    if args.partition:
        wanted.append(("--partition", args.partition, PHI_EXTENSIONS))
    inputs = [("the mesh", args.mesh), ("the labels", args.labels)]
    outputs = check_outputs(wanted, inputs)
    folders = check_folder("--region-surfaces", args.region_surfaces) if args.region_surfaces else []
    with reading(args.labels):
        labels = io.read_labels(args.labels)
    classes = np.unique(labels)
    if classes.size == 1 and not (classes.dtype.kind == "f" and np.isnan(classes[0])):  # NaN: relax says so
        raise CLIError(
            f"{args.labels}: the labels hold one class only ({classes[0].tolist()!r}); two or more are needed "
            "to have a boundary"
        )
    if args.region_surfaces:
        paths = region_surface_paths(args.region_surfaces, io.region_names(classes), args.surface_format)
        wanted = [("--region-surfaces", str(p), (f".{args.surface_format}",)) for p in paths]
        outputs += check_outputs(wanted, inputs + [(out.option, out.given) for out in outputs], folders)
    data = writable_labels(labels)  # what the VTK writers store: booleans and strings become region indices
    with reading(args.mesh):
        domain = io.read_mesh(args.mesh)
    on = _labels_on(args, domain, len(labels))
    if args.boundary and domain.element_dim < 2:
        raise CLIError(f"--boundary {args.boundary}: the boundary on a curve is points, which no format holds")
    if args.region_surfaces and domain.element_dim < 2:
        raise CLIError(
            f"--region-surfaces {args.region_surfaces}: the region boundaries on a curve are points, which no "
            "format holds"
        )
    if args.region_surfaces and args.surface_format == "stl" and domain.element_dim == 2:
        where = "a 2-D mesh" if domain.dim == 2 else "a surface"
        raise CLIError(
            f"--surface-format stl: STL holds triangles, and the region boundaries on {where} are curves; "
            "use obj, ply, vtk or vtp"
        )
    if args.region_surfaces and domain.element_dim > 3 and args.surface_format != "vtk":
        raise CLIError(
            f"--surface-format {args.surface_format}: the region boundaries of a 4-D mesh are tetrahedra; use vtk"
        )
    if args.boundary and domain.element_dim >= 2:
        check_boundary_format("--boundary", args.boundary, domain.element_dim)
    show = not args.quiet and sys.stderr.isatty() and domain.n_vertices >= PROGRESS_VERTICES
    kwargs = {}
    if args.lam is not None:
        kwargs["lam"] = args.lam
    if args.smoothing is not None:
        kwargs["smoothing"] = args.smoothing
    with RegionProgress([str(c) for c in classes.tolist()], enabled=show and classes.size > 2):
        res = relax(domain, labels, on=on, verbose=show, band=args.band, **kwargs)
    two = res.classes.size == 2
    ls = res.level_set() if two else None
    regional = not two or args.partition or args.region_surfaces  # the partition is made: report its regions
    pieces = {1: "points", 2: "segments", 3: "triangles", 4: "tetrahedra"}
    summaries = {}  # each region's boundary, as the report gives it (each written and let go)
    with atomic_outputs(outputs, folders) as temporary:  # every output written, or none
        io.write_phi(temporary[0], res, labels=data if on == "elements" else None)
        rest = iter(temporary[1:])
        if args.boundary:
            if two:
                io.write_level_set(next(rest), ls)
            else:
                io.write_interfaces(next(rest), res)
        if args.partition:
            io.write_partition(next(rest), res)
        paths = list(rest)  # one per region, with --region-surfaces
        for r, boundary in res.each_region_boundary() if regional else ():
            if paths:
                io.write_level_set(paths[r], boundary)
            k = boundary.simplices.shape[1]
            closed = "" if k < 2 else ", closed" if boundary.is_closed() else ", open"
            summaries[r] = f"boundary of {boundary.n_simplices} {pieces.get(k, 'simplices')}{closed}"
    t = res.timings
    lines = [f"{args.mesh}: {domain.n_vertices} vertices, {domain.n_elements} elements, labels on {on}"]
    if two:
        lines.append(
            f"jagged boundary: {res.boundary.S.shape[0]} points; relaxed boundary: {ls.n_points} points, "
            f"{ls.n_simplices} simplices, {ls.n_components()} component(s)"
        )
        banded = [res] if "band" in res.params else []
    else:
        lines[0] += f", {res.classes.size} regions"
        banded = [r for r in res.regions if "band" in r.params]
    measure = {1: "length", 2: "area", 3: "volume"}.get(domain.element_dim, "measure")
    for r, value in enumerate(res.region_measures() if regional else []):
        lines.append(f"region {r} ({res.classes[r]}): {measure} {value:.6g}, {summaries[r]}")
    if not two:
        faces = res.interfaces()
        n_pairs = np.unique(faces.pairs, axis=0).shape[0] if len(faces) else 0
        lines.append(
            f"relaxed interfaces: {faces.points.shape[0]} points, {len(faces)} simplices between {n_pairs} "
            f"pair(s) of regions"
        )
    widths = sorted({float(r.params["band"]) for r in banded})
    if not banded:
        where = " (on the whole mesh)"
    elif two:
        where = (
            f" (on the band of {widths[0]:.3g} h around the jagged boundary: {res.params['band_vertices']} vertices)"
        )
    else:
        span = f"{widths[0]:.3g}" if len(widths) == 1 else f"{widths[0]:.3g} to {widths[-1]:.3g}"
        where = f" ({len(banded)} of {res.classes.size} regions on a band of {span} h around their jagged boundary)"
    lines.append(
        f"time: heat {t['heat']:.3f} s, field {t['field']:.3f} s, smoothing {t['smoothing']:.3f} s, "
        f"integration {t['integration']:.3f} s, total {t['total']:.3f} s{where}"
    )
    written = [args.output] + [p for p in (args.boundary, args.partition) if p]
    if args.region_surfaces:
        written.append(f"{len(paths)} region boundaries to {args.region_surfaces}")
    lines.append("wrote " + (f"{', '.join(written[:-1])} and {written[-1]}" if len(written) > 1 else written[0]))
    print("\n".join(lines))
    return 0


def build_parser():
    parser = argparse.ArgumentParser(
        prog="ndboundary",
        description="Relax the jagged boundaries of a segmentation (a labelled mesh or a label image) into "
        "smooth ones.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    demo = sub.add_parser(
        "demo",
        help="relax built-in jagged segmentations with a known smooth truth and report fidelity",
        description="Relax built-in jagged segmentations (2-D flower, 3-D ball, 7 Voronoi regions) with default "
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
        help="relax the boundaries between the labelled regions of a mesh read from files",
        description="Read a mesh and one label per element (or per vertex), relax the boundaries "
        "between the regions of its two or more labels, write phi and the labels (VTU for ParaView), and "
        "optionally the smooth boundary, the exact partition into regions and each region's boundary. "
        "No output may be an input or another output; existing outputs are replaced, and all of them are "
        "written together, whole, or none.",
        usage="%(prog)s MESH LABELS -o OUT.vtu [--boundary OUT.obj] [--partition OUT.vtu] "
        "[--region-surfaces DIR] [options], or %(prog)s IMAGE [--surfaces DIR] [--boundary OUT.stl] "
        "[-o PHI.nii.gz] [--background LABEL] [options]",
        epilog="A label image (.nii, .nii.gz, .nrrd, .tif, .tiff, or .npy given alone) is relaxed on its "
        "pixel or voxel grid, in the file's physical coordinates (spacing and origin).",
    )
    rel.add_argument(
        "mesh",
        help="OBJ, OFF, PLY, STL, MEDIT .mesh, VTK/VTU, Gmsh .msh or .hedra file; or a label image "
        "(NIfTI, NRRD, TIFF, .npy) alone",
    )
    rel.add_argument(
        "labels",
        nargs="?",
        help="one label per line (optionally after 'SCALAR_FIELD n'), or .npy; two or more distinct labels "
        "(none for a label image)",
    )
    rel.add_argument(
        "-o",
        "--output",
        metavar="OUT.vtu",
        help="where to write phi and the labels (.vtu or .vtk; needed for a mesh): for two labels the point "
        "data phi; for more, one array phi_NAME per region (NAME: the label, made safe for names, or the "
        "region's index). For an image: phi at the pixel centres (.nii, .nii.gz, .nrrd, .tif, .npy); for three "
        "or more labels one channel per region, in the labels' order (a 4-D NIfTI, an NRRD list axis first, "
        "a last axis of .npy)",
    )
    rel.add_argument(
        "--boundary",
        metavar="OUT.obj",
        help="where to write the relaxed boundary (.obj, .ply, .stl, .vtk, .vtp or .vtu); for three or more labels "
        "the interfaces between the regions, each piece with its pair of regions: an OBJ group or an ASCII STL "
        "solid 'A|B' per pair, PLY face (or edge) properties and VTK cell data region_a and region_b",
    )
    rel.add_argument(
        "--partition",
        metavar="OUT.vtu",
        help="where to write the exact partition (.vtu or .vtk): the mesh refined along the relaxed "
        "boundaries, with cell data region (index) and label (the label, when labels are numbers)",
    )
    rel.add_argument(
        "--region-surfaces",
        "--surfaces",
        metavar="DIR",
        help="write each region's relaxed boundary, oriented outward, to DIR/region_NAME.FORMAT (DIR is made "
        "when missing); closed where the region does not touch the border of the mesh",
    )
    rel.add_argument(
        "--surface-format",
        choices=SURFACE_FORMATS,
        default="obj",
        help="format of --region-surfaces (default obj); stl (binary, for 3-D printing) holds triangles, so "
        "it needs a solid mesh: on 2-D meshes and surfaces the boundaries are curves; vtp is VTK's polygonal data",
    )
    rel.add_argument(
        "--background",
        metavar="LABEL",
        help="for a label image: the label whose boundary --surfaces leaves out (it stays a region); the image "
        "is framed by a layer of it, so that every other region's surface is closed",
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
        "outside without a solve (default auto: 8 mean edge lengths on simplices, 12 on quads, polygons and "
        "hexahedra, in every dimension, wider for a weak "
        "boundary term (small --lam) or few smoothing passes, the whole mesh when it is small or the band "
        "would hold most of it); none relaxes the whole mesh",
    )
    rel.add_argument(
        "--fit",
        choices=("auto", "yes", "no"),
        default="auto",
        help="for a label image of two labels: move the relaxed boundary to the smoothest one that parts the "
        "pixel centres (default auto: every curve, and surfaces of up to 60 000 vertices; yes: any surface)",
    )
    rel.add_argument(
        "--quiet", action="store_true", help="no progress display (shown per region and step on large meshes)"
    )
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
