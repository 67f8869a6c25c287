"""Compiled kernels, built ahead of time where the install could, compiled by numba otherwise.

A kernel is a numba function with the signatures the library calls it with. Installing the
package compiles those signatures into one extension module, ``ndboundary._kernels_aot``
(numba's ahead-of-time compiler, run by ``setup.py``), so that a first run does not wait
for numba to compile them. A call whose arguments match a built signature runs
the built code, with the GIL released as ``nogil`` would; any other call, or every call
where the module is absent (no C compiler at install, or ``NDBOUNDARY_JIT=1``), goes to
numba's dispatcher, which compiles and caches as before. Both compile the same source; the
module records the hashes of the files it was built from, and is not used once one changes.

Kernels called only from other compiled code stay plain numba functions: the build
compiles them into their callers.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import os
import warnings
from pathlib import Path

import numpy as np

__all__ = ["Kernel", "kernel", "KERNEL_MODULES", "REGISTRY", "aot_module", "export_name", "sources_digest"]

#: the modules that define kernels; the build imports these and nothing else of the package
KERNEL_MODULES = (
    "ndboundary._compiled",
    "ndboundary._compiled_geometry",
    "ndboundary._compiled_mesh",
    "ndboundary._compiled_partition",
    "ndboundary._compiled_walk",
    "ndboundary.solvers.amg_hierarchy",
    "ndboundary.solvers.amg_sweeps",
    "ndboundary.io.text_format",
    "ndboundary.io.text_scan",
    "ndboundary.io.weld",
)

#: every kernel defined so far, in definition order
REGISTRY: list[Kernel] = []


def export_name(module, name, i):
    """The name the extension module gives signature ``i`` of kernel ``module.name``."""
    return f"{module.rsplit('.', 1)[-1].lstrip('_')}__{name.lstrip('_')}__{i}"


def sources_digest(paths):
    """``path=sha256;...`` of the package's source files ``paths`` (relative to the
    package's parent folder), a file that is missing hashing as ``-``.
    """
    root = Path(__file__).resolve().parent.parent
    parts = []
    for path in paths:
        file = root / path
        parts.append(f"{path}={hashlib.sha256(file.read_bytes()).hexdigest() if file.is_file() else '-'}")
    return ";".join(parts)


@functools.cache
def aot_module():
    """The extension module the install built, or None: absent, ``NDBOUNDARY_JIT=1``, or
    built from sources that have changed since (with a warning: numba compiles instead).
    """
    if os.environ.get("NDBOUNDARY_JIT", "") not in ("", "0"):
        return None
    try:
        module = importlib.import_module("ndboundary._kernels_aot")
    except ImportError:
        return None
    recorded = module.built_from() if hasattr(module, "built_from") else ""
    paths = [part.split("=", 1)[0] for part in recorded.split(";") if part]
    if not paths or sources_digest(paths) != recorded:
        warnings.warn(
            "ndboundary's built kernels are older than their source; numba compiles them on first use "
            "instead (reinstall the package to build them again)",
            RuntimeWarning,
            stacklevel=2,
        )
        return None
    return module


def _arg_check(t):
    """A test of one Python argument against numba type ``t`` of a built signature."""
    from numba.core import types

    if isinstance(t, types.Array):
        dtype, ndim, contiguous = np.dtype(str(t.dtype)), t.ndim, t.layout == "C"

        def check(a):
            return (
                isinstance(a, np.ndarray)
                and a.dtype == dtype
                and a.ndim == ndim
                and (not contiguous or a.flags.c_contiguous)
                and a.dtype.isnative
            )

        return check
    if isinstance(t, types.Boolean):
        return lambda a: isinstance(a, (bool, np.bool_))
    if isinstance(t, types.Integer):
        return lambda a: isinstance(a, (int, np.integer)) and not isinstance(a, (bool, np.bool_))
    if isinstance(t, types.Float):
        return lambda a: isinstance(a, (float, np.floating))
    raise TypeError(f"kernel signatures take arrays, integers, floats and booleans, not {t}")


class Kernel:
    """A numba dispatcher and the signatures built ahead of time for it.

    Calling it runs the built code for the first signature its arguments match exactly
    (dtype, dimensions, C order where the signature asks for it), and numba's dispatcher
    otherwise. ``jit`` is the dispatcher.
    """

    def __init__(self, dispatcher, signatures):
        self.jit = dispatcher
        self.signatures = tuple(signatures)
        self.module = dispatcher.py_func.__module__
        self.name = dispatcher.py_func.__name__
        functools.update_wrapper(self, dispatcher.py_func)
        self._built = None

    def _resolve(self):
        built = []
        module = aot_module()
        if module is not None:
            from numba.core import sigutils

            for i, sig in enumerate(self.signatures):
                fn = getattr(module, export_name(self.module, self.name, i), None)
                if fn is not None:
                    args, _ = sigutils.normalize_signature(sig)
                    built.append((tuple(_arg_check(t) for t in args), fn))
        self._built = built
        return built

    def built(self, *args):
        """The built function that would run for ``args``, or None."""
        for checks, fn in self._resolve() if self._built is None else self._built:
            if len(checks) == len(args) and all(c(a) for c, a in zip(checks, args, strict=True)):
                return fn
        return None

    def __call__(self, *args):
        fn = self.built(*args)
        return self.jit(*args) if fn is None else fn(*args)

    def __repr__(self):
        return f"Kernel({self.module}.{self.name}, {len(self.signatures)} signatures)"


def kernel(*signatures):
    """Decorate a numba dispatcher as a :class:`Kernel` built for ``signatures``
    (numba signature strings, return type included).
    """

    def wrap(dispatcher):
        k = Kernel(dispatcher, signatures)
        REGISTRY.append(k)
        return k

    return wrap
