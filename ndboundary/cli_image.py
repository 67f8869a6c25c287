"""``ndboundary relax IMAGE``: a label image or volume relaxed from the shell.

A NIfTI, NRRD, TIFF or ``.npy`` file given without a labels file is a label map
(:func:`ndboundary.io.read_image`): it is relaxed on its pixel or voxel grid
(:func:`ndboundary.relax_image`), in the file's physical coordinates, and its region
boundaries, interfaces and phi are written as :mod:`ndboundary.cli` writes a mesh's.
"""

from __future__ import annotations

import sys

import numpy as np

from .cli_files import BOUNDARY_EXTENSIONS, CLIError, atomic_outputs, check_boundary_format, check_outputs, reading
from .cli_regions import RegionProgress, check_folder, region_surface_paths
from .io.images import IMAGE_READ_SUFFIXES, IMAGE_WRITE_SUFFIXES

__all__ = ["PHI_IMAGE_EXTENSIONS", "cmd_relax_image", "is_image"]

#: What ``-o`` writes phi to for an image: the last suffix of each (``.gz``: ``.nii.gz``).
PHI_IMAGE_EXTENSIONS = tuple(dict.fromkeys("." + s.rsplit(".", 1)[1] for s in IMAGE_WRITE_SUFFIXES))
#: Images with at least this many pixels show per-step progress on a terminal.
PROGRESS_PIXELS = 100_000


def is_image(path):
    """Whether ``path`` names a label image by its suffix (one :func:`~ndboundary.io.read_image` reads).

    Examples
    --------
    >>> is_image("scan.nii.gz"), is_image("seg.SEG.NRRD"), is_image("mesh.obj")
    (True, True, False)
    """
    return str(path).lower().endswith(IMAGE_READ_SUFFIXES)


def voxel_values(result, labels):
    """Phi of the relaxation of the image ``labels`` at the pixel centres: the mean of each
    pixel's corners (phi is linear along the grid's edges). Shape ``labels.shape`` for two
    regions, ``labels.shape + (n_regions,)`` for more, one function per region in
    ``result.classes`` order.

    On the band of a large image (:class:`~ndboundary.domains.image.GridBand`), the pixels
    outside it get their region's side of 1/2 (each function's), ``1/2 -/+ c`` with ``c``
    one more than the largest ``|phi - 1/2|`` on the band: the level sets ``phi = 1/2``
    are the band's, and the whole grid's phi is never built.
    """
    from .domains.image import GridBand

    domain = result.domain
    corners = tuple(n + 1 for n in domain.shape)
    phi = np.asarray(result.phi, dtype=np.float64)
    columns = phi.reshape(phi.shape[0], -1)
    if phi.ndim == 1:  # two regions: the function of the second
        sides = np.asarray(labels == result.classes[1]).reshape(-1, 1)
    else:
        sides = np.asarray(labels).reshape(-1, 1) == np.asarray(result.classes).reshape(1, -1)
    if isinstance(domain, GridBand):
        c = float(np.abs(columns - 0.5).max()) + 1.0
        out = np.where(sides, 0.5 + c, 0.5 - c)
        full = np.zeros((int(np.prod(corners)), columns.shape[1]))
        full[domain.corners] = columns
        columns = full
    grid = columns.reshape(corners + (-1,))
    mean = np.zeros(domain.shape + (columns.shape[1],))
    for corner in np.ndindex(*(2,) * len(domain.shape)):
        mean += grid[tuple(slice(c, c + n) for c, n in zip(corner, domain.shape, strict=True))]
    mean /= 2 ** len(domain.shape)
    if isinstance(domain, GridBand):
        flat = mean.reshape(-1, columns.shape[1])
        out[domain.pixels] = flat[domain.pixels]
        mean = out.reshape(mean.shape)
    return mean[..., 0] if phi.ndim == 1 else mean


def cmd_relax_image(args):
    """Run ``ndboundary relax IMAGE [-o PHI] [--boundary OUT] [--surfaces DIR] [--background L]``.

    With ``--background`` (and no ``-o``) the image is framed by one layer of background
    first, so that every other region's surface is closed, also where the region meets
    the image's border.
    """
    from . import io
    from .images import relax_image

    wanted = []
    if args.output:
        wanted.append(("-o", args.output, PHI_IMAGE_EXTENSIONS))
    if args.boundary:
        wanted.append(("--boundary", args.boundary, BOUNDARY_EXTENSIONS))
    if args.partition:
        raise CLIError("--partition writes a mesh's refined cells; for an image use --surfaces or --boundary")
    inputs = [("the image", args.mesh)]
    outputs = check_outputs(wanted, inputs)
    folders = check_folder("--surfaces", args.region_surfaces) if args.region_surfaces else []
    with reading(args.mesh):
        image = io.read_image(args.mesh, oblique=True)  # a tilted scan is relaxed in its world coordinates
    labels = image.labels
    if args.boundary:
        check_boundary_format("--boundary", args.boundary, labels.ndim)
    classes = np.unique(labels)
    if classes.size < 2:
        raise CLIError(f"{args.mesh}: the image holds one label only ({classes.tolist()}); two or more are needed")
    background = None
    if args.background is not None:
        matches = [c for c in classes.tolist() if str(c) == args.background]
        if not matches:
            raise CLIError(f"--background {args.background}: not one of the labels {classes.tolist()}")
        background = matches[0]
    if args.output and classes.size > 2 and args.output.lower().endswith((".tif", ".tiff")):
        raise CLIError(
            f"-o {args.output}: {args.mesh} holds {classes.size} labels, whose functions phi are written as "
            "the channels of a .nii, .nii.gz, .nrrd or .npy file; TIFF is written without channels"
        )
    surfaces = [r for r in range(classes.size) if classes[r] != background]
    if args.region_surfaces:
        if args.surface_format == "stl" and labels.ndim == 2:
            raise CLIError("--surface-format stl: STL holds triangles, and a 2-D image's boundaries are curves")
        names = io.region_names(classes)
        paths = region_surface_paths(args.region_surfaces, [names[r] for r in surfaces], args.surface_format)
        more = [("--surfaces", str(p), (f".{args.surface_format}",)) for p in paths]
        outputs += check_outputs(more, inputs + [(out.option, out.given) for out in outputs], folders)
    origin = np.asarray(image.origin, dtype=np.float64)
    if background is not None and not args.output:
        # a layer of background around the image closes every other region's surface where
        # it meets the image's border (phi, written per pixel, keeps the image's own grid)
        labels = np.pad(labels, 1, constant_values=background)
        step = np.asarray(image.spacing)
        origin = origin - (step if image.direction is None else image.direction @ step)
    show = not args.quiet and sys.stderr.isatty() and labels.size >= PROGRESS_PIXELS
    kwargs = {k: v for k, v in (("lam", args.lam), ("smoothing", args.smoothing)) if v is not None}
    with RegionProgress([str(c) for c in classes.tolist()], enabled=show and classes.size > 2):
        res = relax_image(
            labels, spacing=image.spacing, origin=origin, direction=image.direction, background=background,
            band=args.band, verbose=show, fit={"auto": "auto", "yes": True, "no": False}[args.fit], **kwargs,
        )  # fmt: skip
    closed = {}  # whether each region's written boundary is closed
    with atomic_outputs(outputs, folders) as temporary:  # every output written, or none
        rest = iter(temporary)
        if args.output:
            io.write_image(next(rest), voxel_values(res, labels).astype(np.float32), spacing=image.spacing,
                           origin=image.origin, direction=image.direction, overwrite=True,
                           channels=classes.size > 2)  # fmt: skip
        if args.boundary:
            if classes.size == 2:
                io.write_level_set(next(rest), res.level_set())
            else:
                io.write_interfaces(next(rest), res)
        if args.region_surfaces:  # each written and let go: an atlas's would not fit in memory together
            paths = dict(zip(surfaces, rest, strict=True))
            pieces = "triangles" if labels.ndim == 3 else "segments"
            for done, (r, boundary) in enumerate(res.each_region_boundary(surfaces), start=1):
                io.write_level_set(paths[r], boundary)
                closed[r] = boundary.is_closed()
                if show:
                    line = f"surface {done}/{len(surfaces)}: {names[r]}, {boundary.n_simplices} {pieces}"
                    print(f"[ndboundary] {line}", file=sys.stderr, flush=True)
    _report(args, image, labels, res, classes, closed)
    return 0


def _report(args, image, labels, res, classes, closed):
    """The summary lines: the image, each region's measure against that of its pixels in the
    ``labels`` relaxed (the image, framed by a layer of background), whether each written
    boundary (``closed``, by region) is closed, the time.
    """
    measure = "area" if image.labels.ndim == 2 else "volume"
    pixel = float(np.prod(image.spacing))
    lines = [
        f"{args.mesh}: {' x '.join(map(str, image.labels.shape))} pixels of "
        f"{' x '.join(f'{s:.4g}' for s in image.spacing)}, {classes.size} labels"
    ]
    counts = {c: int(n) for c, n in zip(*np.unique(labels, return_counts=True), strict=True)}
    for r, value in enumerate(res.region_measures()):
        given = counts[classes[r]] * pixel
        state = ""
        if r in closed:
            state = ", boundary closed" if closed[r] else ", boundary open (meets the image's border)"
        framed = labels.shape != image.labels.shape and r == res.params.get("background")
        framed = " (background, framed by one layer)" if framed else ""
        lines.append(
            f"region {r} ({classes[r]}){framed}: {measure} {value:.6g} against {given:.6g} for its pixels "
            f"({100 * (value / given - 1):+.3f} %){state}"
        )
    lines.append(f"time: {res.timings['total']:.2f} s")
    written = [p for p in (args.output, args.boundary) if p]
    if closed:
        written.append(f"{len(closed)} region boundaries to {args.region_surfaces}")
    if written:
        lines.append("wrote " + ", ".join(written))
    print("\n".join(lines))
