"""Labels files: one label per line (optionally after a ``SCALAR_FIELD n`` header), or ``.npy``."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .common import existing_file

__all__ = ["read_labels", "write_labels"]


def read_labels(path):
    r"""Read labels: one per line, optionally after a ``SCALAR_FIELD n`` header; or a ``.npy`` array.

    Blank lines and lines starting with ``#`` are skipped; text is read as UTF-8, a
    leading byte-order mark dropped.

    Parameters
    ----------
    path : str or path-like
        A ``.npy`` file is loaded as a NumPy array (pickles refused); any other
        extension is read as text.

    Returns
    -------
    ndarray of shape (n,)
        Booleans when every label is ``True`` or ``False`` (as :func:`write_labels` writes
        booleans), else integers when every label is an integer, else floats, else strings.

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist.
    ValueError
        On an empty file, a header whose count disagrees with the number of labels,
        or a ``.npy`` array that is not one-dimensional.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "labels.txt")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("SCALAR_FIELD 3\n0\n1\n1\n")
    ...     read_labels(path).tolist()
    [0, 1, 1]
    """
    path = existing_file(path)
    if path.suffix.lower() == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except Exception as exc:
            raise ValueError(f"{path}: could not read as .npy: {exc}") from None
        if arr.ndim != 1:
            raise ValueError(f"{path}: labels must be one-dimensional, got an array of shape {arr.shape}")
        return arr
    try:
        with open(path, encoding="utf-8-sig") as fh:
            tokens = [ln.strip() for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file of labels: {exc}") from None
    expected = None
    if tokens and tokens[0].upper().startswith("SCALAR_FIELD"):
        head = tokens.pop(0).split()
        try:
            expected = int(head[1])
        except (IndexError, ValueError):
            raise ValueError(f"{path}: malformed header {' '.join(head)!r}; expected 'SCALAR_FIELD n'") from None
    if not tokens:
        raise ValueError(f"{path}: no labels in the file")
    if expected is not None and expected != len(tokens):
        raise ValueError(f"{path}: the header announces {expected} labels but the file holds {len(tokens)}")
    if all(t in ("True", "False") for t in tokens):
        return np.array([t == "True" for t in tokens])
    for conv in (int, float):
        try:
            return np.array([conv(t) for t in tokens])
        except ValueError:
            continue
    return np.array(tokens)


def write_labels(path, labels, *, header=False):
    """Write labels one per line (``.npy``: a NumPy array file).

    Parameters
    ----------
    path : str or path-like
        A ``.npy`` path gets a NumPy array file, any other a text file.
    labels : array-like of shape (n,)
        Floats are written with 17 significant digits, so that they read back exactly;
        booleans as ``True`` and ``False``, which :func:`read_labels` reads as booleans.
    header : bool, default=False
        Precede the labels with ``SCALAR_FIELD n``, as the paper's reference code does;
        off by default, since a plain column is what :func:`numpy.loadtxt` and
        spreadsheets read as is (:func:`read_labels` reads both). Ignored for ``.npy``.

    Raises
    ------
    ValueError
        When ``labels`` is not one-dimensional or is empty.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "labels.txt")
    ...     write_labels(path, [0, 1, 1], header=True)
    ...     print(open(path).read(), end="")
    ...     read_labels(path).tolist()
    SCALAR_FIELD 3
    0
    1
    1
    [0, 1, 1]
    """
    arr = np.asarray(labels)
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(f"labels must be a non-empty one-dimensional array, got shape {arr.shape}")
    path = Path(os.fspath(path))
    if path.suffix.lower() == ".npy":
        np.save(path, arr)
        return
    fmt = "%.17g" if arr.dtype.kind == "f" else "%s"
    with open(path, "w", encoding="utf-8") as fh:
        if header:
            fh.write(f"SCALAR_FIELD {arr.size}\n")
        np.savetxt(fh, arr.astype(str) if fmt == "%s" else arr, fmt=fmt)
