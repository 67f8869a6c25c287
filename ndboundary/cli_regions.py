"""The outputs of several regions for the ``ndboundary`` command: ``--region-surfaces`` and progress.

:func:`check_folder` checks (before any work) the folder ``--region-surfaces`` writes to,
:func:`region_surface_paths` names the file of every region's boundary in it, and
:class:`RegionProgress` heads the progress lines of a relaxation of several regions
with the region they belong to. The folders are made, and the files written, by
:func:`ndboundary.cli_files.atomic_outputs`.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from .cli_files import CLIError

__all__ = ["SURFACE_FORMATS", "RegionProgress", "check_folder", "region_surface_paths"]

#: The formats of ``--surface-format``: the region boundaries ``write_level_set`` writes.
SURFACE_FORMATS = ("obj", "stl", "ply", "vtk", "vtp")


def check_folder(option, folder):
    """Check a folder of outputs before any work: an existing writable folder, or one that can be made.

    Parameters
    ----------
    option : str
        The option that names the folder (``"--region-surfaces"``), for the messages.
    folder : str or path-like
        The folder as given.

    Returns
    -------
    list of Path
        The folders to make, resolved, outermost first: none when ``folder`` exists,
        else ``folder`` and its missing parents.
        :func:`~ndboundary.cli_files.atomic_outputs` makes them, and removes them
        again when the writing fails.

    Raises
    ------
    CLIError
        When ``folder`` (or its nearest existing parent) is not a folder or is not
        writable.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     [p.name for p in check_folder("--region-surfaces", os.path.join(tmp, "a", "b"))]
    ['a', 'b']
    >>> with tempfile.NamedTemporaryFile() as fh:
    ...     check_folder("--region-surfaces", fh.name)
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: --region-surfaces ...: ... is not a folder
    """
    target = Path(folder).resolve()
    missing = []
    while not target.exists():
        if target.is_symlink():
            raise CLIError(f"{option} {folder}: {target} is a broken symbolic link")
        missing.append(target)
        target = target.parent
    if not target.is_dir():
        raise CLIError(f"{option} {folder}: {target} is not a folder")
    if not os.access(target, os.W_OK | os.X_OK):
        raise CLIError(f"{option} {folder}: the folder {target} is not writable")
    return missing[::-1]


def region_surface_paths(folder, names, fmt):
    """The region boundary files of ``--region-surfaces``: ``FOLDER/region_<name>.<fmt>`` per region.

    The names are those of :func:`ndboundary.io.region_names` (letters, digits and
    ``_ . + -`` only), behind ``region_`` so that no file is hidden or named like a
    device.

    Examples
    --------
    >>> [p.as_posix() for p in region_surface_paths("out", ["air", "bone"], "stl")]
    ['out/region_air.stl', 'out/region_bone.stl']
    """
    return [Path(folder) / f"region_{name}.{fmt}" for name in names]


class RegionProgress:
    r"""While active, stderr with the progress of a relaxation of several regions headed by region.

    :func:`~ndboundary.relax` of three or more regions relaxes them one after the other,
    each printing its steps with ``verbose`` (``[ndboundary] heat 0.012 s``) up to its
    ``total`` (and, on a band, a ``fill`` after it). Within the ``with`` block, the first
    step line of every region is preceded by ``[ndboundary] region i/n: NAME``; every
    line is passed on unchanged.

    Parameters
    ----------
    names : list of str
        The regions, in the order they are relaxed (``result.classes``).
    enabled : bool, default=True
        False leaves stderr as it is.

    Examples
    --------
    >>> import contextlib, io, sys
    >>> err = io.StringIO()
    >>> with contextlib.redirect_stderr(err), RegionProgress(["air", "bone"]):
    ...     for _ in range(2):
    ...         print("[ndboundary] heat    0.1 s", file=sys.stderr)
    ...         print("[ndboundary] total   0.2 s", file=sys.stderr)
    >>> print(err.getvalue(), end="")
    [ndboundary] region 1/2: air
    [ndboundary] heat    0.1 s
    [ndboundary] total   0.2 s
    [ndboundary] region 2/2: bone
    [ndboundary] heat    0.1 s
    [ndboundary] total   0.2 s
    """

    def __init__(self, names, enabled=True):
        self.names = [str(n) for n in names]
        self.enabled = bool(enabled)
        self._stream = None
        self._pending = ""
        self._region = 0
        self._starting = True

    def __enter__(self):
        if self.enabled:
            self._stream = sys.stderr
            sys.stderr = self
        return self

    def __exit__(self, *exc):
        if self._stream is not None:
            sys.stderr = self._stream
            if self._pending:
                self._stream.write(self._pending)
            self._stream, self._pending = None, ""
        return False

    def write(self, text):
        """Pass ``text`` on, a line at a time, heading the first line of every region."""
        lines = (self._pending + text).split("\n")
        self._pending = lines.pop()
        for line in lines:
            words = line.split()
            step = words[1] if len(words) > 1 and words[0] == "[ndboundary]" else None
            if step is not None and step != "fill" and self._starting and self._region < len(self.names):
                self._stream.write(
                    f"[ndboundary] region {self._region + 1}/{len(self.names)}: {self.names[self._region]}\n"
                )
                self._region += 1
                self._starting = False
            if step == "total":
                self._starting = True
            self._stream.write(line + "\n")
        return len(text)

    def flush(self):
        """Flush the stream passed on to."""
        self._stream.flush()

    def isatty(self):
        """Whether the stream passed on to is a terminal."""
        return self._stream.isatty()
