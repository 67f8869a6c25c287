"""What the format modules share: the file and extension checks, comment-free text lines, 3-D points."""

from __future__ import annotations

import itertools
import os
from pathlib import Path

import numpy as np

__all__ = [
    "FAST_MIN_BYTES",
    "FAST_MIN_VALUES",
    "existing_file",
    "file_bytes",
    "float_tokens",
    "flat_rows",
    "format_suffix",
    "int_tokens",
    "non_finite_error",
    "plural",
    "points_3d",
    "uncommented_lines",
]

#: The largest magnitude :func:`int_tokens` keeps; larger integers are clipped to it (they index no mesh).
INT_CLIP = 2**62
#: Text mesh files of at least this many bytes are read by the compiled scans of
#: :mod:`.text_scan`; smaller ones line by line, in well under a second and without
#: loading (or, once per installation, compiling) the compiled code.
FAST_MIN_BYTES = 1 << 20
#: Arrays of at least this many values are formatted (:mod:`.text_format`) and their
#: edges counted (:func:`~.weld.open_edge_fraction`) by compiled loops; smaller ones by
#: numpy and Python, with the same result.
FAST_MIN_VALUES = 1 << 17


def existing_file(path) -> Path:
    """The path of a file that must exist, as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path : str or path-like

    Raises
    ------
    FileNotFoundError
        When ``path`` does not exist; the message quotes it.
    IsADirectoryError
        When ``path`` is a directory.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     open(os.path.join(tmp, "a.txt"), "w").close()
    ...     existing_file(os.path.join(tmp, "a.txt")).name
    'a.txt'
    >>> existing_file("no/such/file.obj")
    Traceback (most recent call last):
    ...
    FileNotFoundError: no such file: 'no/such/file.obj'
    >>> existing_file(tempfile.gettempdir())  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    IsADirectoryError: '...' is a directory, not a file
    """
    path = Path(os.fspath(path))
    if path.is_dir():
        raise IsADirectoryError(f"'{path}' is a directory, not a file")
    if not path.is_file():
        raise FileNotFoundError(f"no such file: '{path}'")
    return path


def format_suffix(path, allowed, what) -> str:
    """The lower-case extension of ``path``, checked against the formats a function handles.

    Parameters
    ----------
    path : str or path-like
    allowed : collection of str
        The accepted extensions, lower case with the dot (``".obj"``).
    what : str
        What the file holds (``"mesh"``, ``"level set"``), for the error message.

    Raises
    ------
    ValueError
        When the extension is not in ``allowed``; the message lists the accepted ones.

    Examples
    --------
    >>> format_suffix("Bunny.OBJ", {".obj", ".off"}, "mesh")
    '.obj'
    >>> format_suffix("bunny.xyz", {".obj", ".off"}, "mesh")
    Traceback (most recent call last):
    ...
    ValueError: bunny.xyz: unknown mesh format '.xyz'; expected one of .obj, .off
    """
    ext = Path(os.fspath(path)).suffix.lower()
    if ext not in allowed:
        raise ValueError(
            f"{os.fspath(path)}: unknown {what} format {ext or '(no extension)'!r}; "
            f"expected one of {', '.join(sorted(allowed))}"
        )
    return ext


def uncommented_lines(path) -> list:
    r"""The lines of a text file, each cut at its first ``#`` (a comment runs to the line's end).

    Parameters
    ----------
    path : str or path-like
        Read as UTF-8 (a leading byte-order mark is dropped); undecodable bytes are
        replaced, since they can only sit in comments of the number-only formats that
        use this.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "c.off")
    ...     with open(path, "w") as fh:
    ...         _ = fh.write("OFF # header\n3 1 0\n")
    ...     uncommented_lines(path)
    ['OFF ', '3 1 0\n']
    """
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        return [line.split("#", 1)[0] for line in fh]


def file_bytes(path) -> bytes:
    r"""The bytes of a file, without a leading UTF-8 byte-order mark (as ``utf-8-sig`` drops it).

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = os.path.join(tmp, "b.obj")
    ...     with open(path, "wb") as fh:
    ...         _ = fh.write(b"\xef\xbb\xbfv 0 0 0\n")
    ...     file_bytes(path)
    b'v 0 0 0\n'
    """
    with open(path, "rb") as fh:
        data = fh.read()
    return data[3:] if data[:3] == b"\xef\xbb\xbf" else data


def flat_rows(rows):
    """Index rows (a 2-D array or a list of sequences) as one flat int64 array and the row sizes.

    Raises
    ------
    ValueError
        When an entry is not an integer.

    Examples
    --------
    >>> flat, sizes = flat_rows([[0, 1, 2], [2, 1, 3, 4]])
    >>> flat.tolist(), sizes.tolist()
    ([0, 1, 2, 2, 1, 3, 4], [3, 4])
    """
    if isinstance(rows, np.ndarray) and rows.ndim == 2:
        if rows.size and rows.dtype.kind not in "iu":
            raise ValueError(f"cells hold {rows.dtype} values, not indices")
        return rows.astype(np.int64, copy=False).ravel(), np.full(rows.shape[0], rows.shape[1], dtype=np.int64)
    rows = list(rows)
    sizes = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
    try:
        flat = np.fromiter(itertools.chain.from_iterable(rows), dtype=np.int64, count=int(sizes.sum()))
    except (TypeError, ValueError, OverflowError):
        raise ValueError("cells hold values that are not vertex indices") from None
    return flat, sizes


def plural(n, noun) -> str:
    """``n`` and the noun, in the plural unless ``n`` is 1 (``vertex``: ``vertices``).

    Examples
    --------
    >>> plural(1, "face"), plural(4, "vertex"), plural(0, "cell")
    ('1 face', '4 vertices', '0 cells')
    """
    if n == 1:
        return f"{n} {noun}"
    return f"{n} {noun[:-2] + 'ices' if noun.endswith('ex') else noun + 's'}"


def _first_bad(tokens, lines, convert):
    """The index of the first token ``convert`` refuses (ValueError), with its line number."""
    for i, tok in enumerate(tokens):
        try:
            convert(tok)
        except ValueError:
            return i, int(lines[i])
    raise AssertionError("unreachable: every token converts")  # pragma: no cover


def int_tokens(tokens, lines, path, what) -> np.ndarray:
    """Integer tokens of a text file as an int64 array, integers beyond int64 clipped to +-``INT_CLIP``.

    Parameters
    ----------
    tokens : list of str
    lines : array-like of int
        The line number of every token, for the error message.
    path : path-like
        Named in the error message.
    what : str
        What the tokens are (``"vertex index"``), for the error message.

    Raises
    ------
    ValueError
        On a token that is not an integer; the message names the file, the line and the token.

    Examples
    --------
    >>> int_tokens(["1", "-2", "100000000000000000000000"], [1, 1, 2], "a.off", "vertex index").tolist()
    [1, -2, 4611686018427387904]
    >>> int_tokens(["1", "2.5"], [3, 4], "a.off", "vertex index")
    Traceback (most recent call last):
    ...
    ValueError: a.off: line 4: vertex index '2.5' is not an integer
    """
    try:
        try:
            return np.array(tokens, dtype=np.int64).reshape(-1)
        except OverflowError:
            return np.array([max(-INT_CLIP, min(INT_CLIP, int(t))) for t in tokens], dtype=np.int64).reshape(-1)
    except ValueError:
        i, line = _first_bad(tokens, lines, int)
        raise ValueError(f"{path}: line {line}: {what} {tokens[i][:40]!r} is not an integer") from None


def float_tokens(tokens, lines, path, what) -> np.ndarray:
    """Number tokens of a text file as a float64 array.

    Parameters
    ----------
    tokens : list of str
    lines : array-like of int
        The line number of every token, for the error message.
    path : path-like
        Named in the error message.
    what : str
        What the tokens are (``"coordinate"``), for the error message.

    Raises
    ------
    ValueError
        On a token that is not a number; the message names the file, the line and the token.

    Examples
    --------
    >>> float_tokens(["1", "2.5e1"], [1, 1], "a.off", "coordinate").tolist()
    [1.0, 25.0]
    >>> float_tokens(["1", "x"], [1, 2], "a.off", "coordinate")
    Traceback (most recent call last):
    ...
    ValueError: a.off: line 2: coordinate 'x' is not a number
    """
    try:
        return np.array(tokens, dtype=np.float64).reshape(-1)
    except ValueError:
        i, line = _first_bad(tokens, lines, float)
        raise ValueError(f"{path}: line {line}: {what} {tokens[i][:40]!r} is not a number") from None


def non_finite_error(path, points, name, where=None):
    """A ValueError naming the first vertex with a NaN or infinite coordinate, or None when all are finite.

    Parameters
    ----------
    path : path-like
        Named in the message.
    points : ndarray of shape (n, d)
    name : callable
        ``name(i)`` says which vertex row ``i`` is in the file's own terms (``"vertex 3"``).
    where : callable, optional
        ``where(i)`` gives the line number of row ``i``, when the format is line based.

    Examples
    --------
    >>> import numpy as np
    >>> print(non_finite_error("a.obj", np.array([[0.0, 1.0], [np.nan, 2.0]]), lambda i: f"vertex {i + 1}"))
    a.obj: vertex 2 has a non-finite coordinate: [nan, 2.0]
    """
    bad = ~np.isfinite(points)
    if not bad.any():
        return None
    i = int(np.argwhere(bad)[0, 0])
    at = f"line {where(i)}: " if where is not None else ""
    return ValueError(f"{path}: {at}{name(i)} has a non-finite coordinate: {points[i].tolist()}")


def points_3d(points) -> np.ndarray:
    """Points with three coordinates, as mesh files store them: 1-D and 2-D points get zeros appended.

    Parameters
    ----------
    points : array-like of shape (n, d), d <= 3

    Raises
    ------
    ValueError
        When the points have more than three coordinates.

    Examples
    --------
    >>> points_3d([[1.0, 2.0], [3.0, 4.0]]).tolist()
    [[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]]
    """
    points = np.asarray(points, dtype=np.float64)
    if points.shape[1] == 3:
        return points
    if points.shape[1] > 3:
        raise ValueError(f"points are {points.shape[1]}-dimensional; mesh files hold at most 3 coordinates")
    return np.concatenate([points, np.zeros((points.shape[0], 3 - points.shape[1]))], axis=1)
