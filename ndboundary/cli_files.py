"""The files of the ``ndboundary`` command: input and output checks, atomic writes, labels as data.

Everything here runs before the relaxation (the checks) or around the writing (the
temporary files, the folders made for them), so that a run either writes all its
outputs or leaves every file as it was. The outputs of several regions (the folder of
``--region-surfaces``, its file names, the progress per region) are in
:mod:`ndboundary.cli_regions`.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys
import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

__all__ = [
    "BOUNDARY_EXTENSIONS",
    "PHI_EXTENSIONS",
    "CLIError",
    "Output",
    "atomic_outputs",
    "one_line",
    "reading",
    "check_boundary_format",
    "check_input",
    "check_outputs",
    "writable_labels",
]

#: The extensions ``write_phi`` writes.
PHI_EXTENSIONS = (".vtk", ".vtu")
#: The extensions ``write_level_set`` and ``write_interfaces`` write.
BOUNDARY_EXTENSIONS = (".obj", ".ply", ".stl", ".vtk", ".vtp", ".vtu")
#: The extensions written through meshio.
_MESHIO_EXTENSIONS = (".vtk", ".vtu")


class CLIError(Exception):
    """An error reported as one line on stderr, with a non-zero exit status."""


def check_boundary_format(option, path, element_dim):
    """Check, before any work, that the file ``path`` can hold the boundaries of a domain
    of elements of dimension ``element_dim``: curves (2), surfaces (3) or solids (4).

    Raises
    ------
    CLIError
        For STL, which holds triangles only, or OBJ, PLY and VTP, which hold no solids.

    Examples
    --------
    >>> check_boundary_format("--boundary", "out.stl", 3)
    >>> check_boundary_format("--boundary", "out.stl", 2)
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: --boundary out.stl: STL holds triangles, and these boundaries are curves; ...
    """
    from .io.meshio_formats import SIMPLEX_KINDS, holds_simplices

    ext = os.path.splitext(os.fspath(path))[1].lower()
    kind = SIMPLEX_KINDS.get(element_dim, "tetra")
    if holds_simplices(ext, kind):
        return
    if ext == ".stl":
        what = "curves" if kind == "line" else "tetrahedra"
        raise CLIError(
            f"{option} {path}: STL holds triangles, and these boundaries are {what}; use .obj, .ply, .vtk, .vtp or .vtu"
        )
    raise CLIError(
        f"{option} {path}: a 4-D domain's boundaries are tetrahedra, which {ext} does not hold; use .vtk or .vtu"
    )


class Output(NamedTuple):
    """An output file: its option, the path as given, the resolved path written."""

    option: str
    given: str
    target: Path


def check_input(path, role):
    """Refuse an input that is missing, not a regular file, or unreadable.

    Examples
    --------
    >>> check_input("no/such/mesh.obj", "mesh")
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: no such file: no/such/mesh.obj
    >>> check_input(".", "mesh")
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: the mesh . is a directory, not a file
    """
    p = Path(path)
    if not p.exists():
        raise CLIError(f"no such file: {path}")
    if p.is_dir():
        raise CLIError(f"the {role} {path} is a directory, not a file")
    if not p.is_file():
        raise CLIError(f"the {role} {path} is not a regular file")
    if not os.access(p, os.R_OK):
        raise CLIError(f"cannot read the {role} {path}: permission denied")


def _same_file(a, b):
    if a == b:
        return True
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def check_outputs(outputs, inputs, folders=()):
    """Check the outputs before any work: known extension, writable folder, no clash.

    An existing output file is replaced (when the run succeeds), as long as it is not
    one of the inputs or another output.

    Parameters
    ----------
    outputs : list of (option, path, extensions)
        Each output's option (``"-o"``), path as given and accepted extensions.
    inputs : list of (role, path)
        The files read (``("the mesh", "m.obj")``), which no output may overwrite.
    folders : collection of Path, optional
        Folders that do not exist yet and are made before the writing (what
        :func:`~ndboundary.cli_regions.check_folder` returns): outputs in them need
        no existing folder.

    Returns
    -------
    list of Output

    Raises
    ------
    CLIError
        On an extension the writer refuses, a missing or read-only folder, an output
        that is a directory or a read-only file, or an output that is (after
        resolving symbolic links and ``.``) an input or another output.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     mesh = os.path.join(tmp, "m.obj")
    ...     open(mesh, "w").close()
    ...     check_outputs([("--boundary", mesh, BOUNDARY_EXTENSIONS)], [("the mesh", mesh)])
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: --boundary ... is the same file as the mesh ...; choose another output path
    >>> check_outputs([("-o", "phi.txt", PHI_EXTENSIONS)], [])
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: -o phi.txt: cannot write '.txt' files; use .vtk or .vtu
    """
    taken = [(role, str(path), Path(path).resolve()) for role, path in inputs]
    made = {Path(f) for f in folders}
    checked = []
    for option, path, extensions in outputs:
        path = str(path)
        ext = Path(path).suffix.lower()
        if ext not in extensions:
            known = f"{', '.join(extensions[:-1])} or {extensions[-1]}"
            raise CLIError(f"{option} {path}: cannot write {repr(ext) if ext else 'extension-less'} files; use {known}")
        if ext in _MESHIO_EXTENSIONS and importlib.util.find_spec("meshio") is None:
            raise CLIError(f"{option} {path}: writing {ext} needs meshio (pip install 'ndboundary[io]')")
        target = Path(path).resolve()
        folder = os.path.dirname(path) or "."
        if target.parent in made:
            pass  # made before the writing; nothing in it can exist yet
        elif not target.parent.is_dir():
            exists = target.parent.exists()
            raise CLIError(f"{option} {path}: {f'{folder} is not a folder' if exists else f'no such folder: {folder}'}")
        elif not os.access(target.parent, os.W_OK | os.X_OK):
            raise CLIError(f"{option} {path}: the folder {folder} is not writable")
        if target.is_dir():
            raise CLIError(f"{option} {path} is a directory")
        if target.exists() and not os.access(target, os.W_OK):
            raise CLIError(f"{option} {path}: the file exists and is read-only")
        for role, other, resolved in taken:
            if _same_file(target, resolved):
                raise CLIError(
                    f"{option} {path} is the same file as {role} {other} ({target}); choose another output path"
                )
        taken.append((option, path, target))
        checked.append(Output(option, path, target))
    return checked


@contextlib.contextmanager
def atomic_outputs(outputs, folders=()):
    r"""Temporary files beside the outputs, moved onto them when the block succeeds.

    Makes ``folders`` (outermost first, as :func:`~ndboundary.cli_regions.check_folder`
    gives them), then yields one temporary path per output, in the output's folder,
    named ``.NAME.tmp-RANDOM.EXT`` (the extension last, since the writers read the
    format from it). When the block ends normally every temporary replaces its output
    (``os.replace``); on any exception (``KeyboardInterrupt`` too) they are removed, the
    folders made are removed again, and no output is touched. Errors whose message
    names a temporary name the output.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     out = check_outputs([("-o", os.path.join(tmp, "a.obj"), BOUNDARY_EXTENSIONS)], [])
    ...     with atomic_outputs(out) as (path,):
    ...         _ = open(path, "w").write("v 0 0 0\n")
    ...     os.listdir(tmp)
    ['a.obj']
    """
    temps, made, done = [], [], False
    try:
        for folder in folders:
            try:
                Path(folder).mkdir()
                made.append(Path(folder))
            except FileExistsError:
                if not Path(folder).is_dir():
                    raise
        for out in outputs:
            suffix = ".nii.gz" if out.target.name.lower().endswith(".nii.gz") else out.target.suffix
            fd, name = tempfile.mkstemp(prefix=f".{out.target.name}.tmp-", suffix=suffix, dir=out.target.parent)
            os.close(fd)
            temps.append(Path(name))
        try:
            yield list(temps)
        except (CLIError, KeyboardInterrupt):
            raise
        except Exception as exc:
            message = one_line(exc)
            for tmp, out in zip(temps, outputs, strict=True):
                message = message.replace(str(tmp), out.given)
            raise CLIError(message) from exc
        umask = os.umask(0)
        os.umask(umask)
        for tmp, out in zip(temps, outputs, strict=True):
            mode = out.target.stat().st_mode & 0o7777 if out.target.exists() else 0o666 & ~umask
            os.chmod(tmp, mode)
        for tmp, out in zip(temps, outputs, strict=True):
            os.replace(tmp, out.target)
        done = True
    finally:
        for tmp in temps:
            with contextlib.suppress(OSError):
                tmp.unlink()
        if not done:
            for folder in reversed(made):
                with contextlib.suppress(OSError):
                    folder.rmdir()


def one_line(exc):
    r"""The message of an exception on one line; unexpected kinds are named.

    Examples
    --------
    >>> one_line(ValueError("bad.obj: line 3:\n  not a vertex"))
    'bad.obj: line 3: not a vertex'
    >>> one_line(KeyError("dtype"))
    "KeyError: 'dtype'"
    """
    message = " ".join(str(exc).split())
    if isinstance(exc, MemoryError):
        return "out of memory" + (f": {message}" if message else "")
    if isinstance(exc, (CLIError, ValueError, TypeError, OSError, ImportError)) and message:
        return message
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


@contextlib.contextmanager
def reading(path):
    """Read ``path`` quietly: what the block prints is held back, errors name the file.

    meshio prints to stdout and stderr before it fails: that text is dropped when the
    block fails (the exception says what went wrong, in one line) and passed on to
    stderr when it succeeds (stdout holds the report). An error whose message does not
    name ``path`` gets it in front.

    Examples
    --------
    >>> with reading("m.obj"):
    ...     print("noise")
    ...     raise IndexError("index 7 is out of bounds")
    Traceback (most recent call last):
    ...
    ndboundary.cli_files.CLIError: m.obj: IndexError: index 7 is out of bounds
    """
    held = io.StringIO()
    try:
        with contextlib.redirect_stdout(held), contextlib.redirect_stderr(held):
            yield
    except Exception as exc:
        message = one_line(exc)
        if str(path) in message:
            raise
        raise CLIError(f"{path}: {message}") from exc
    sys.stderr.write(held.getvalue())


def writable_labels(labels):
    """Labels in a form the VTK writers store: integers and floats as such, others as 0, 1, ...

    Integers keep their values (in native byte order), floats become float64;
    booleans, strings and any other kind become their index in ``np.unique(labels)``,
    which is the region number :func:`~ndboundary.relax` gives them (False, True: 0, 1).

    Examples
    --------
    >>> writable_labels(np.array([True, False, True])).tolist()
    [1, 0, 1]
    >>> writable_labels(np.array(["out", "in", "out"])).tolist()
    [1, 0, 1]
    >>> writable_labels(np.array([3, 7], dtype=">i2")).dtype
    dtype('int16')
    """
    arr = np.asarray(labels)
    if arr.dtype.kind in "iu":
        return arr.astype(arr.dtype.newbyteorder("="), copy=False)
    if arr.dtype.kind == "f":
        return arr.astype(np.float64, copy=False)
    return np.unique(arr.reshape(-1), return_inverse=True)[1].reshape(-1).astype(np.int64)
