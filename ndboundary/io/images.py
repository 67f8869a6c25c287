"""Label images and volumes: NIfTI, NRRD (3D Slicer's ``.seg.nrrd`` too), TIFF stacks and ``.npy``.

As in NIfTI, ITK and scikit-image, the array is indexed ``labels[i, j, k]`` (C-contiguous) and voxel ``index`` is
centred at ``origin + index * spacing``, in the file's world frame (NIfTI's RAS+, a NRRD's ``space``: 3D Slicer's
LPS; nothing is converted). The rules, the same for every format:

* **Flipped axes.** An axis that runs against its world axis (a negative diagonal entry of the affine, as in
  NIfTI's common LAS orientation) is reversed in the array, its spacing made positive and the origin moved to the
  voxel that becomes index 0: index grows with the coordinate and ``origin + index * spacing`` stays each voxel's
  centre. Writing keeps spacings positive, so a flipped file comes back unflipped, each voxel at its place.
* **Rotations.** An affine that rotates the grid is refused (``ValueError``: not axis-aligned) unless
  ``oblique=True``; then spacing is each axis's step length, the origin voxel 0's centre and
  :attr:`Image.direction` the rotation: centres are ``origin + direction @ (index * spacing)``. Shears are refused.
* **Single slices.** Axes of one voxel are dropped: a 3-D file of one slice is a 2-D image (the dropped axis's
  coordinate is lost). An image needs 2 or 3 axes of 2 voxels or more.
* **Labels.** Integers and booleans are kept as stored; floats must be finite integers and become ``int64``.
  ``labels=False`` reads any reals (a φ written by :func:`write_image`).

Formats, by suffix (case-insensitive): ``.npy`` (spacing 1, origin 0); ``.nii``, ``.nii.gz`` (nibabel's affine,
sform before qform, stored in single precision: each entry is read as the shortest decimal that rounds to it,
0.7 rather than 0.699999988); ``.nrrd``, ``.seg.nrrd`` and, to read, ``.nhdr`` (pynrrd: ``space directions`` and
``space origin``, else ``spacings``); ``.tif``, ``.tiff`` (tifffile). The three packages are optional:
``pip install 'ndboundary[imaging]'``.

3D Slicer's ``.seg.nrrd`` is one label map (3-D: the voxel values are the labels, ``SegmentN_LabelValue`` keys name
them) or layers (4-D, along the axis without a space direction), combined into one label map: segment N is the
voxels of layer ``SegmentN_Layer`` equal to ``SegmentN_LabelValue`` (defaults N and 1, Slicer's older format),
labelled with that value when all values differ, else numbered 1, 2, ... in the order of N. Overlapping segments
are refused. Slicer may crop the array to the segments' extent; the origin is then the crop's.

TIFF: the array is the image series as tifffile gives it (pages first: ``(z, y, x)``); colour, several series or
more than 3 axes are refused. Spacing and origin are those :func:`write_image` stores, when present; else X and Y
spacings are ``1 / XResolution`` and ``1 / YResolution`` in the file's unit (a 72 dpi scan gives 1/72), the stack
spacing is ImageJ's ``spacing`` and the origin ImageJ's ``xorigin``, ``yorigin``, ``zorigin`` (in pixels: origin
= -xorigin * spacing), each 1 or 0 when absent. Correct them with ``dataclasses.replace(image, spacing=...)``.
"""

from __future__ import annotations

import importlib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .common import existing_file

__all__ = ["IMAGE_READ_SUFFIXES", "IMAGE_WRITE_SUFFIXES", "Image", "read_image", "write_image"]

_READ = {".npy": "npy", ".nii": "nifti", ".nii.gz": "nifti", ".nrrd": "nrrd", ".seg.nrrd": "nrrd", ".nhdr": "nrrd"}
_READ |= {".tif": "tiff", ".tiff": "tiff"}
IMAGE_READ_SUFFIXES = tuple(_READ)  #: The suffixes :func:`read_image` reads.
IMAGE_WRITE_SUFFIXES = (".npy", ".nii", ".nii.gz", ".nrrd", ".tif", ".tiff")  #: What :func:`write_image` writes.
_ALIGNED = 1e-5  # off-diagonal size of a unit direction still taken as axis-aligned (NIfTI stores float32)
_ORTHOGONAL = 1e-4  # departure from orthonormal of a rotation read with oblique=True
_IMAGEJ_TYPES = (np.uint8, np.uint16, np.int16, np.float32)


@dataclass(frozen=True, eq=False)
class Image:
    """A label image or volume and its geometry, as :func:`read_image` returns it.

    Attributes
    ----------
    labels : ndarray
        2-D or 3-D, C-contiguous; integers or booleans (any reals when read with ``labels=False``).
    spacing : tuple of float
        The positive distance between neighbouring voxel centres along each axis.
    origin : tuple of float
        The centre of voxel ``(0, 0[, 0])``.
    path : str
        The file read (empty for an image made in memory).
    direction : tuple of tuples of float, or None
        None for an axis-aligned image, whose voxel ``index`` is centred at ``origin + index * spacing``; else the
        rotation (unit columns, one per axis) of an oblique one: ``origin + direction @ (index * spacing)``.

    Examples
    --------
    >>> import numpy as np
    >>> image = Image(np.zeros((4, 5), dtype=np.uint8), (0.5, 2.0), (10.0, 0.0))
    >>> image.centre((2, 1)).tolist()
    [11.0, 2.0]
    """

    labels: np.ndarray
    spacing: tuple[float, ...]
    origin: tuple[float, ...]
    path: str = ""
    direction: tuple[tuple[float, ...], ...] | None = None

    def centre(self, index) -> np.ndarray:
        """The world coordinates of the centres of voxels ``index`` (shape ``(..., ndim)``)."""
        steps = np.asarray(index, dtype=float) * np.asarray(self.spacing)
        rotation = np.eye(len(self.spacing)) if self.direction is None else np.asarray(self.direction)
        return np.asarray(self.origin) + steps @ rotation.T


def _suffix(path: Path) -> str:
    name = path.name.lower()
    return next((s for s in (".seg.nrrd", ".nii.gz") if name.endswith(s)), path.suffix.lower())


def _require(module: str, path):
    try:
        return importlib.import_module(module)
    except ImportError:
        package = "pynrrd" if module == "nrrd" else module
        raise ImportError(f"{path}: this format needs {package}: pip install 'ndboundary[imaging]'") from None


def read_image(path, *, oblique: bool = False, labels: bool = True) -> Image:
    """Read a label image or volume and its geometry (see :mod:`ndboundary.io.images` for the rules).

    Parameters
    ----------
    path : str or path-like
        ``.npy``, ``.nii``, ``.nii.gz``, ``.nrrd``, ``.seg.nrrd``, ``.nhdr``, ``.tif`` or ``.tiff``.
    oblique : bool, default False
        Read an image whose affine rotates the voxel grid, with the rotation in :attr:`Image.direction`.
    labels : bool, default True
        Require labels: integers, booleans, or floats of integer value (read as ``int64``). False reads any reals.

    Returns
    -------
    Image

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    ValueError
        Naming the file: an unknown suffix; an affine that is not axis-aligned (unless ``oblique``) or that shears;
        fewer than 2 or more than 3 axes of more than one voxel; labels fractional, NaN or not numbers; overlaps.
    ImportError
        When the format's optional package is missing.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "labels.npy")
    ...     np.save(path, np.array([[[0, 1, 1], [0, 0, 1]]]))
    ...     image = read_image(path)
    >>> image.labels.shape, image.spacing, image.origin
    ((2, 3), (1.0, 1.0), (0.0, 0.0))
    """
    path = existing_file(path)
    kind = _READ.get(_suffix(path))
    if kind is None:
        raise ValueError(f"{path}: unknown image format {_suffix(path)!r}; expected one of {', '.join(_READ)}")
    data, cols, origin = {"npy": _read_npy, "nifti": _read_nifti, "nrrd": _read_nrrd, "tiff": _read_tiff}[kind](path)
    return _finish(path, data, cols, origin, oblique, labels)


def _read_npy(path):
    try:
        data = np.load(path, allow_pickle=False)
    except Exception as exc:
        raise ValueError(f"{path}: could not read as .npy: {exc}") from None
    return data, np.eye(data.ndim), np.zeros(data.ndim)


def _read_nifti(path):
    nib = _require("nibabel", path)
    try:
        img = nib.load(str(path))
        data = np.asanyarray(img.dataobj)
    except Exception as exc:
        raise ValueError(f"{path}: could not read as NIfTI: {exc}") from None
    if data.ndim > 3 and max(data.shape[3:]) > 1:
        raise ValueError(f"{path}: an image must have 2 or 3 axes, got a NIfTI of shape {data.shape}")
    data = data.reshape(data.shape[:3] + (1,) * (3 - data.ndim))
    affine = np.array([float(str(v)) for v in np.float32(img.affine).ravel()]).reshape(4, 4)  # 0.7, not 0.699999988
    return data, affine[:3, :3], affine[:3, 3]


def _read_nrrd(path):
    nrrd = _require("nrrd", path)
    try:
        data, header = nrrd.read(str(path))  # index order F: data[i, j, k] as the header's axes
    except Exception as exc:
        raise ValueError(f"{path}: could not read as NRRD: {exc}") from None
    if header.get("space directions") is None:
        spacings = np.nan_to_num(np.asarray(header.get("spacings", np.ones(data.ndim)), dtype=float), nan=1.0)
        return data, np.diag(spacings), np.zeros(data.ndim)
    rows = np.asarray(header["space directions"], dtype=float)
    spatial = ~np.isnan(rows).all(axis=1)
    if not spatial.all():
        segments = sorted({int(m[1]) for key in header if (m := re.fullmatch(r"Segment(\d+)_\w+", key))})
        if (~spatial).sum() == 1 and segments:
            data = _combine_layers(path, np.moveaxis(data, int(np.flatnonzero(~spatial)[0]), 0), header, segments)
        elif all(data.shape[i] == 1 for i in np.flatnonzero(~spatial)):
            data = data.reshape([n for n, s in zip(data.shape, spatial, strict=True) if s])
        else:
            msg = "only 3D Slicer's segment layers can be combined into one label map"
            raise ValueError(f"{path}: the NRRD has {(~spatial).sum()} non-spatial axes of more than one voxel; {msg}")
        rows = rows[spatial]
    if rows.shape[0] != rows.shape[1]:
        raise ValueError(f"{path}: {rows.shape[0]} spatial axes in a space of dimension {rows.shape[1]}")
    return data, rows.T, np.asarray(header.get("space origin", np.zeros(rows.shape[1])), dtype=float)


def _combine_layers(path, layers, header, segments):
    """One label map from 3D Slicer's segment layers (``layers[l]`` is layer ``l``)."""
    layer = [int(header.get(f"Segment{n}_Layer", n)) for n in segments]
    value = [int(header.get(f"Segment{n}_LabelValue", 1)) for n in segments]
    name = [header.get(f"Segment{n}_Name", f"Segment{n}") for n in segments]
    label = value if len(set(value)) == len(value) and min(value) > 0 else list(range(1, len(segments) + 1))
    out = np.zeros(layers.shape[1:], dtype=np.min_scalar_type(max(label)))
    for s, (lay, val, lab) in enumerate(zip(layer, value, label, strict=True)):
        if not 0 <= lay < layers.shape[0]:
            raise ValueError(f"{path}: segment {name[s]!r} is in layer {lay}, but the file has {layers.shape[0]}")
        mask = layers[lay] == val
        taken = out[mask]
        if taken.any():
            other = name[label.index(int(taken[taken != 0][0]))]
            msg = "one label map cannot hold both; remove the overlap in 3D Slicer, or read the layers with pynrrd"
            raise ValueError(f"{path}: segments {other!r} and {name[s]!r} overlap, and {msg}")
        out[mask] = lab
    return out


def _read_tiff(path):
    tifffile = _require("tifffile", path)
    try:
        with tifffile.TiffFile(str(path)) as tif:
            count = len(tif.series)
            if count == 1:
                series, page = tif.series[0], tif.pages[0]
                axes, data = series.axes, series.asarray()
                ours = (tif.shaped_metadata or ({},))[0]
                imagej = tif.imagej_metadata or {}
                res = {c: page.tags[f"{c}Resolution"].value for c in "XY" if f"{c}Resolution" in page.tags}
    except Exception as exc:
        raise ValueError(f"{path}: could not read as TIFF: {exc}") from None
    if count != 1:
        raise ValueError(f"{path}: the TIFF holds {count} image series; expected one")
    if "S" in axes and data.shape[axes.index("S")] > 1:
        raise ValueError(f"{path}: a colour image (axes {axes}, shape {data.shape}); labels need one value per pixel")
    if len(ours.get("spacing", ())) == data.ndim == len(ours.get("origin", ())):
        return data, np.diag(np.asarray(ours["spacing"], dtype=float)), np.asarray(ours["origin"], dtype=float)
    spacing, origin = np.ones(data.ndim), np.zeros(data.ndim)
    for i, axis in enumerate(axes):
        if axis in res and res[axis][0] > 0 and res[axis][1] > 0:
            spacing[i] = res[axis][1] / res[axis][0]
        elif axis not in "XY" and "spacing" in imagej:
            spacing[i] = float(imagej["spacing"])
        if f"{axis.lower()}origin" in imagej:
            origin[i] = -float(imagej[f"{axis.lower()}origin"]) * spacing[i]
    return data, np.diag(spacing), origin


def _finish(path, data, cols, origin, oblique, labels) -> Image:
    """Apply the rules of the module's docstring to an array and the columns of its affine."""
    shape, cols, origin = data.shape, np.asarray(cols, dtype=float), np.asarray(origin, dtype=float)
    if not (np.isfinite(cols).all() and np.isfinite(origin).all()):
        raise ValueError(f"{path}: the geometry holds NaN or infinite values")
    flat = (np.linalg.norm(cols, axis=0) == 0) & (np.array(shape) == 1)
    cols[:, flat] = np.eye(len(cols))[:, flat]  # a single slice may have no thickness
    spacing = np.linalg.norm(cols, axis=0)
    if (spacing == 0).any():
        raise ValueError(f"{path}: axis {int(np.argmin(spacing))} has zero spacing")
    unit = cols / spacing
    if np.abs(unit - np.diag(np.diag(unit))).max() <= _ALIGNED:
        spacing, unit = np.abs(np.diag(cols)), np.diag(np.sign(np.diag(unit)))
    elif not oblique:
        msg = "so origin + index * spacing is not the voxels' place; pass oblique=True to read it with its rotation"
        raise ValueError(f"{path}: the affine is not axis-aligned (unit axes {unit.T.round(4).tolist()}), {msg}")
    elif np.abs(unit.T @ unit - np.eye(len(unit))).max() > _ORTHOGONAL:
        raise ValueError(f"{path}: the affine shears the voxel grid (its axes are not orthogonal)")
    for i in np.flatnonzero(np.diag(unit) < 0):  # flip: index grows with the coordinate
        origin = origin + (data.shape[i] - 1) * spacing[i] * unit[:, i]
        unit[:, i] = -unit[:, i]
        data = np.flip(data, axis=i)
    keep = [i for i, n in enumerate(data.shape) if n != 1]
    for i in set(range(data.ndim)) - set(keep):
        if np.abs(np.r_[unit[:, i], unit[i]] - np.tile(np.eye(data.ndim)[i], 2)).max() > _ALIGNED:
            raise ValueError(f"{path}: a single slice at an angle to its world axes (shape {shape}) is not supported")
    data, unit = data.reshape([data.shape[i] for i in keep]), unit[np.ix_(keep, keep)]
    if data.ndim not in (2, 3):
        raise ValueError(f"{path}: an image needs 2 or 3 axes of more than one voxel, got shape {shape}")
    direction = None if np.array_equal(unit, np.eye(len(keep))) else tuple(tuple(map(float, r)) for r in unit)
    values = np.ascontiguousarray(_values(path, data, labels))
    return Image(values, tuple(map(float, spacing[keep])), tuple(map(float, origin[keep])), str(path), direction)


def _values(path, data: np.ndarray, labels: bool) -> np.ndarray:
    kind = data.dtype.kind
    if kind in "biu" or (kind == "f" and not labels):
        return data
    if kind != "f":
        raise ValueError(f"{path}: an image must hold integers, booleans or floats, got dtype {data.dtype}")
    if not np.isfinite(data).all():
        raise ValueError(f"{path}: labels must be integers, but the image holds NaN or infinite values")
    fractional = data[data != np.round(data)]
    if fractional.size:
        msg = f"fractional values such as {float(fractional[0])!r}; pass labels=False to read values"
        raise ValueError(f"{path}: labels must be integers, but the image holds {msg}")
    return data.astype(np.int64)


def write_image(
    path, array, *, spacing=1.0, origin=0.0, direction=None, overwrite: bool = False, channels: bool = False
) -> None:
    """Write labels or values (such as φ) and their geometry, the inverse of :func:`read_image`.

    Parameters
    ----------
    path : str or path-like
        ``.npy``, ``.nii``, ``.nii.gz``, ``.nrrd``, ``.tif`` or ``.tiff``. TIFF is written in ImageJ's format for
        uint8, uint16, int16 and float32 (Fiji reads its spacing), else with tifffile's JSON metadata (both with
        X and Y resolution tags); NIfTI and NRRD write booleans as uint8, and keep other types.
    array : array_like, 2-D or 3-D (with ``channels``, one axis more, last)
        Booleans, integers or floats, indexed as :attr:`Image.labels`.
    spacing, origin : float or sequence of float
        One per axis, or one for all; spacing positive. A ``.npy`` file keeps neither: it takes only 1 and 0.
    direction : (ndim, ndim) array_like, optional
        The rotation of an oblique image (:attr:`Image.direction`); NIfTI and NRRD only.
    overwrite : bool, default False
        Replace an existing file; without it, an existing file is an error.
    channels : bool, default False
        The last axis of ``array`` holds several values per pixel (one function per
        region), not a spatial axis: NIfTI gets a 4-D image (x, y, z, channel; a 2-D
        image as x, y, 1, channel), NRRD a ``list`` axis first, ``.npy`` the array as
        given. TIFF is refused.

    Raises
    ------
    FileExistsError
        When ``path`` exists and ``overwrite`` is False.
    ValueError
        On an unknown suffix, an array that is not 2-D or 3-D numbers, or geometry the format cannot hold.
    ImportError
        When the format's optional package is missing.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "labels.npy")
    ...     write_image(path, np.eye(3, dtype=np.uint8))
    ...     try:
    ...         write_image(path, np.zeros((3, 3)))
    ...     except FileExistsError:
    ...         print("not overwritten")
    ...     int(read_image(path).labels.sum())
    not overwritten
    3
    """
    path = Path(path)
    suffix = _suffix(path)
    if suffix not in IMAGE_WRITE_SUFFIXES:
        raise ValueError(f"{path}: cannot write images as {suffix!r}; use one of {', '.join(IMAGE_WRITE_SUFFIXES)}")
    arr = np.asarray(array)
    ndim = arr.ndim - bool(channels)  # the spatial axes
    if ndim not in (2, 3) or arr.size == 0 or arr.dtype.kind not in "biuf":
        what = "2-D or 3-D array, and one axis of channels," if channels else "2-D or 3-D array"
        raise ValueError(f"{path}: expected a non-empty {what} of numbers, got {arr.dtype} {arr.shape}")
    if channels and suffix in (".tif", ".tiff"):
        raise ValueError(f"{path}: a {suffix} file is written without channels; write .nii, .nii.gz, .nrrd or .npy")
    try:
        sp = np.broadcast_to(np.asarray(spacing, dtype=float), (ndim,)).copy()
        og = np.broadcast_to(np.asarray(origin, dtype=float), (ndim,)).copy()
    except ValueError:
        raise ValueError(f"{path}: spacing and origin need one value or {ndim}") from None
    if not (np.isfinite(sp).all() and (sp > 0).all() and np.isfinite(og).all()):
        raise ValueError(f"{path}: spacing must be positive and finite and origin finite, got {sp} and {og}")
    rot = np.eye(ndim) if direction is None else np.asarray(direction, dtype=float)
    if rot.shape != (ndim, ndim) or np.abs(rot.T @ rot - np.eye(ndim)).max() > _ORTHOGONAL:
        raise ValueError(f"{path}: direction must be a {ndim} x {ndim} rotation")
    if suffix in (".npy", ".tif", ".tiff") and not np.array_equal(rot, np.eye(ndim)):
        raise ValueError(f"{path}: a {suffix} file cannot hold a direction; write .nii or .nrrd")
    if suffix == ".npy" and ((sp != 1).any() or (og != 0).any()):
        raise ValueError(f"{path}: a .npy file holds no spacing or origin; write .nii, .nrrd or .tif to keep them")
    if path.exists() and not overwrite:
        raise FileExistsError(f"{path}: the file exists; pass overwrite=True to replace it")
    if arr.dtype == bool and suffix in (".nii", ".nii.gz", ".nrrd"):
        arr = arr.astype(np.uint8)
    if suffix == ".npy":
        with open(path, "wb") as fh:
            np.save(fh, arr, allow_pickle=False)
    elif suffix in (".nii", ".nii.gz"):
        nib = _require("nibabel", path)
        affine = np.eye(4)
        affine[:ndim, :ndim], affine[:ndim, 3] = rot * sp, og
        if channels and ndim == 2:  # NIfTI's fourth axis follows three spatial ones
            arr = arr[:, :, None, :]
        img = nib.Nifti1Image(arr, affine, dtype=arr.dtype)
        img.set_qform(affine, code=1)  # scanner coordinates, in both forms
        img.set_sform(affine, code=1)
        nib.save(img, str(path))
    elif suffix == ".nrrd":
        nrrd = _require("nrrd", path)
        header = {"space dimension": ndim, "space directions": (rot * sp).T, "space origin": og}
        if channels:  # NRRD's convention: the list of values per pixel on the first axis
            arr = np.moveaxis(arr, -1, 0)
            header["space directions"] = np.vstack([np.full((1, ndim), np.nan), header["space directions"]])
            header["kinds"] = ["list"] + ["domain"] * ndim
        nrrd.write(str(path), arr, header)
    else:
        _write_tiff(path, arr, sp, og)


def _write_tiff(path, arr, sp, og):
    tifffile = _require("tifffile", path)
    resolution = (1 / sp[-1], 1 / sp[-2])  # X is the last axis, Y the one before
    if arr.dtype not in _IMAGEJ_TYPES:
        meta = {"spacing": sp.tolist(), "origin": og.tolist()}
        tifffile.imwrite(path, arr, photometric="minisblack", resolution=resolution, resolutionunit=1, metadata=meta)
        return
    axes = "ZYX"[3 - arr.ndim :]
    meta = {"axes": axes, **({"spacing": float(sp[0])} if arr.ndim == 3 else {})}
    meta |= {f"{a.lower()}origin": -float(o) / float(s) for a, s, o in zip(axes, sp, og, strict=True) if o != 0}
    tifffile.imwrite(path, arr, imagej=True, resolution=resolution, metadata=meta)
