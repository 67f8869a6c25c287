"""What the format modules share: the file and extension checks, comment-free text lines, 3-D points."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

__all__ = ["existing_file", "format_suffix", "points_3d", "uncommented_lines"]


def existing_file(path) -> Path:
    """The path of a file that must exist, as a :class:`~pathlib.Path`.

    Parameters
    ----------
    path : str or path-like

    Raises
    ------
    FileNotFoundError
        When ``path`` is not an existing file; the message quotes it.

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
    """
    path = Path(os.fspath(path))
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
        Read as UTF-8; undecodable bytes are replaced, since they can only sit in comments
        of the number-only formats that use this.

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
    with open(path, encoding="utf-8", errors="replace") as fh:
        return [line.split("#", 1)[0] for line in fh]


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
