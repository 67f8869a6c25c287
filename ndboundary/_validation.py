"""Input validation shared by every public entry point.

Errors are ``ValueError`` or ``TypeError`` whose message quotes what was
received, so that a user can see what to fix without reading a traceback
into scipy. Inputs are copied, never modified.
"""

from __future__ import annotations

import numbers

import numpy as np

from ._arrays import sort_rows

__all__ = [
    "check_points",
    "check_cells",
    "check_labels",
    "check_positive",
    "check_nonnegative_int",
    "check_ragged",
    "refuse_degenerate",
]


def check_points(points, *, name="points", min_dim=1):
    """Return ``points`` as a new C-contiguous float64 array of shape (n, dim)."""
    if isinstance(points, (str, bytes)) or points is None:
        raise TypeError(f"{name} must be an array of shape (n_points, dim), got {type(points).__name__}")
    try:
        arr = np.array(points, dtype=np.float64, copy=True)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a numeric array of shape (n_points, dim): {exc}") from None
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (n_points, dim), got an array of shape {arr.shape}")
    if arr.shape[1] < min_dim:
        raise ValueError(f"{name} has shape {arr.shape}; expected at least {min_dim} coordinate(s) per point")
    if arr.shape[0] == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    bad = ~np.isfinite(arr)
    if bad.any():
        row = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"{name} contains NaN or infinite coordinates (first at row {row}: {arr[row]})")
    return np.ascontiguousarray(arr)


def check_cells(cells, n_points, *, name="simplices", n_per_cell=None):
    """Return ``cells`` as a new int64 array of shape (n_cells, m) with valid indices."""
    if isinstance(cells, (str, bytes)) or cells is None:
        raise TypeError(f"{name} must be an integer array, got {type(cells).__name__}")
    raw = np.asarray(cells)
    if raw.dtype == object:
        raise ValueError(f"{name} must be a rectangular integer array; got ragged rows")
    if raw.dtype.kind == "b":
        raise TypeError(f"{name} must hold integer vertex indices, got booleans")
    if raw.dtype.kind == "f":
        if raw.size and not np.all(np.isfinite(raw) & (raw == np.round(raw))):
            raise TypeError(f"{name} must hold integer vertex indices, got non-integer values")
    elif raw.dtype.kind not in "iu":
        raise TypeError(f"{name} must hold integer vertex indices, got dtype {raw.dtype}")
    arr = np.array(raw, dtype=np.int64, copy=True)
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (n_cells, vertices_per_cell), got shape {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    if n_per_cell is not None and arr.shape[1] != n_per_cell:
        raise ValueError(f"{name} has shape {arr.shape}; expected {n_per_cell} vertices per cell")
    lo, hi = arr.min(), arr.max()
    if lo < 0 or hi >= n_points:
        bad = int(np.argwhere((arr < 0) | (arr >= n_points))[0, 0])
        raise ValueError(f"{name} row {bad} ({arr[bad].tolist()}) indexes a vertex outside 0..{n_points - 1}")
    m = arr.shape[1]
    if m <= 6:
        # few vertices per cell: compare every pair of columns rather than sort the rows
        rep = np.zeros(arr.shape[0], dtype=bool)
        for i in range(m):
            for j in range(i + 1, m):
                rep |= arr[:, i] == arr[:, j]
    else:
        srt = np.sort(arr, axis=1)
        rep = (srt[:, 1:] == srt[:, :-1]).any(axis=1)
    if rep.any():
        bad = int(np.flatnonzero(rep)[0])
        raise ValueError(f"{name} row {bad} ({arr[bad].tolist()}) repeats a vertex")
    return arr


def check_labels(labels, n_expected, *, what, many=False):
    """Validate a label array of two classes (or, with ``many``, of two or more).

    Returns
    -------
    classes : ndarray of shape (n_classes,)
        The distinct values, sorted as ``np.unique`` sorts them.
    region1 : ndarray of bool of shape (n_expected,)
        For two classes, True where the label equals ``classes[1]``; for more, the
        index into ``classes`` of every label (int).
    """
    if isinstance(labels, (str, bytes)) or labels is None:
        raise TypeError(f"labels must be an array with one label per {what}, got {type(labels).__name__}")
    arr = np.asarray(labels)
    if arr.ndim != 1:
        arr = arr.squeeze() if arr.ndim == 2 and 1 in arr.shape else arr
    if arr.ndim != 1:
        raise ValueError(f"labels must be one-dimensional, got an array of shape {np.shape(labels)}")
    if arr.shape[0] != n_expected:
        raise ValueError(
            f"labels has length {arr.shape[0]} but the domain has {n_expected} {what}s (labels are given on={what}s)"
        )
    if arr.dtype.kind == "f" and np.isnan(arr).any():
        raise ValueError(f"labels contain NaN (first at index {int(np.flatnonzero(np.isnan(arr))[0])})")
    if arr.dtype == object and any(v is None for v in arr):
        raise ValueError("labels contain None")
    classes = None
    if arr.dtype.kind in "biu" and arr.size:
        # integers and booleans: two classes are the minimum and the maximum, in linear time
        lo, hi = arr.min(), arr.max()
        region1 = arr == hi
        if lo != hi and np.count_nonzero(region1) + np.count_nonzero(arr == lo) == arr.size:
            return np.array([lo, hi], dtype=arr.dtype), region1
        if arr.dtype.kind != "b" and int(hi) - int(lo) < 4 * arr.size:
            # more classes in a short range: counted, not sorted
            offset = arr.astype(np.intp) - int(lo)
            present = np.bincount(offset) > 0
            classes = (np.flatnonzero(present) + int(lo)).astype(arr.dtype)
            inverse = (np.cumsum(present) - 1)[offset]
    if classes is None:
        classes, inverse = np.unique(arr, return_inverse=True)
    if classes.shape[0] == 1:
        raise ValueError(f"labels hold one class only ({classes[0]!r}); two are needed to have a boundary")
    if classes.shape[0] > 2 and many:
        return classes, inverse.reshape(-1)
    if classes.shape[0] > 2:
        shown = ", ".join(repr(c) for c in classes[:5])
        raise ValueError(
            f"labels hold {classes.shape[0]} classes ({shown}{', ...' if classes.shape[0] > 5 else ''}); "
            "relax separates exactly two"
        )
    return classes, inverse.reshape(-1) == 1


def check_positive(value, name, *, allow_zero=False):
    """Return ``value`` as a float, refusing non-numbers, NaN and (non-)positive values."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    value = float(value)
    if not np.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
    return value


def check_nonnegative_int(value, name):
    """Return ``value`` as an int >= 0."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0, got {value}")
    return int(value)


def check_ragged(cells, n_points, *, name, min_size, what="vertex"):
    """Validate polygons given as an (n, m) array or as a sequence of index sequences.

    Returns
    -------
    indices : ndarray of int64 of shape (n_corners,)
        The flat concatenation of the rows.
    offsets : ndarray of int64 of shape (n_cells + 1,)
        Row ``i`` is ``indices[offsets[i]:offsets[i + 1]]``.
    """
    if isinstance(cells, (str, bytes)) or cells is None:
        raise TypeError(f"{name} must be an integer array or a sequence of index sequences, got {type(cells).__name__}")
    rows = None
    if isinstance(cells, np.ndarray) and cells.dtype != object:
        if cells.ndim != 2:
            raise ValueError(f"{name} must have shape (n_cells, {what}s_per_cell), got shape {cells.shape}")
        rows_arr = cells
        sizes = np.full(cells.shape[0], cells.shape[1], dtype=np.int64)
    else:
        try:
            rows = [np.asarray(r) for r in cells]
        except TypeError:
            raise TypeError(f"{name} must be an integer array or a sequence of index sequences") from None
        for i, r in enumerate(rows):
            if r.ndim != 1:
                raise ValueError(f"{name} row {i} must be a flat sequence of {what} indices, got shape {r.shape}")
        sizes = np.array([r.size for r in rows], dtype=np.int64)
        rows_arr = np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64)
    if sizes.size == 0:
        raise ValueError(f"{name} is empty")
    raw = np.asarray(rows_arr)
    if raw.dtype.kind == "b":
        raise TypeError(f"{name} must hold integer {what} indices, got booleans")
    if raw.dtype.kind == "f":
        if raw.size and not np.all(np.isfinite(raw) & (raw == np.round(raw))):
            raise TypeError(f"{name} must hold integer {what} indices, got non-integer values")
    elif raw.dtype.kind not in "iu" and raw.size:
        raise TypeError(f"{name} must hold integer {what} indices, got dtype {raw.dtype}")
    indices = np.array(raw, dtype=np.int64).reshape(-1)
    offsets = np.zeros(sizes.size + 1, dtype=np.int64)
    np.cumsum(sizes, out=offsets[1:])
    short = np.flatnonzero(sizes < min_size)
    if short.size:
        i = int(short[0])
        raise ValueError(
            f"{name} row {i} ({indices[offsets[i] : offsets[i + 1]].tolist()}) has {sizes[i]} "
            f"{what}(s); at least {min_size} are needed"
        )
    bad = (indices < 0) | (indices >= n_points)
    if bad.any():
        i = int(np.searchsorted(offsets, np.flatnonzero(bad)[0], side="right") - 1)
        raise ValueError(
            f"{name} row {i} ({indices[offsets[i] : offsets[i + 1]].tolist()}) indexes a {what} "
            f"outside 0..{n_points - 1}"
        )
    owner = np.repeat(np.arange(sizes.size), sizes)
    order, _ = sort_rows(np.stack([owner, indices], axis=1))
    srt_i, srt_o = indices[order], owner[order]
    rep = (srt_i[1:] == srt_i[:-1]) & (srt_o[1:] == srt_o[:-1])
    if rep.any():
        i = int(srt_o[1:][rep][0])
        raise ValueError(f"{name} row {i} ({indices[offsets[i] : offsets[i + 1]].tolist()}) repeats a {what}")
    return indices, offsets


def refuse_degenerate(bad, noun, members, measure, plural=None):
    """Raise a ``ValueError`` naming the first element flagged in ``bad``, if any.

    Parameters
    ----------
    bad : ndarray of bool of shape (n_elements,)
        The degenerate elements.
    noun : str
        What an element is called (``"simplex"``, ``"polygon"``, ...).
    members : callable
        ``members(e)``: the text naming element ``e``'s vertices or faces.
    measure : str
        The measure that vanishes (``"area"``, ``"volume"``, ...).
    plural : str, optional
        The plural of ``noun``: with it the message also counts the degenerate elements.

    Examples
    --------
    >>> import numpy as np
    >>> from ndboundary._validation import refuse_degenerate
    >>> bad = np.array([False, True, True])
    >>> refuse_degenerate(bad, "polygon", lambda e: f"vertices {[e, e + 1]}", "area", "polygons")
    Traceback (most recent call last):
    ...
    ValueError: polygon 1 (vertices [1, 2]) is degenerate: zero area (2 degenerate polygons in all)
    """
    if not bad.any():
        return
    e = int(np.flatnonzero(bad)[0])
    more = "" if plural is None or bad.sum() == 1 else f" ({int(bad.sum())} degenerate {plural} in all)"
    raise ValueError(f"{noun} {e} ({members(e)}) is degenerate: zero {measure}{more}")
