"""Build ndboundary's compiled kernels ahead of time, so that a first run does not compile.

Everything else about the package is in ``pyproject.toml``. The kernels
(:mod:`ndboundary._kernels`) are compiled by numba's ahead-of-time compiler into the
extension module ``ndboundary._kernels_aot``, for the CPU of the machine that builds
(``NDBOUNDARY_AOT_CPU`` names another, ``generic`` for a portable build). Where that
cannot be done (no C compiler, or a numba without ``numba.pycc``), the build says why and
goes on without the module: numba then compiles each kernel on its first call, as it
always could. ``NDBOUNDARY_NO_AOT=1`` skips the module on purpose. A build that finds
the module already where it would put it, built from the same sources for the same CPU by
the same numba and this same file (a second ``pip install -e .`` of a checkout), keeps it
instead of compiling again.
"""

import hashlib
import importlib.util
import os
import shutil
import sys
import tempfile
import types

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = os.path.dirname(os.path.abspath(__file__))
PACKAGES = ("ndboundary", "ndboundary.io", "ndboundary.solvers")


def load_kernels():
    """Import the kernel modules alone: the packages' ``__init__`` files import the whole
    library, while the kernels need numpy, scipy and numba only.
    """
    import importlib

    for name in PACKAGES:
        package = types.ModuleType(name)
        package.__path__ = [os.path.join(HERE, *name.split("."))]
        sys.modules[name] = package
    kernels = importlib.import_module("ndboundary._kernels")
    for name in kernels.KERNEL_MODULES:
        importlib.import_module(name)
    return kernels


def compiler(kernels):
    """Numba's ahead-of-time compiler with every signature of every kernel exported.

    Each kernel compiles with flags of its own, with the GIL released around each call as
    ``nogil=True`` does for numba's dispatchers. numba's compiler shares one set of flags
    among a module's functions, and inlining a function turns SSA off in the flags it is
    given, so that every kernel after the first to inline one would be typed without SSA.
    """
    import numba.pycc.compiler as aot
    from numba.core import sigutils
    from numba.pycc import CC

    shared = aot.compile_extra

    def compile_one(typingctx, targetctx, func, args, return_type, flags, locals, **kwargs):
        own = flags.copy()
        own.release_gil = True
        return shared(typingctx, targetctx, func, args, return_type, own, locals, **kwargs)

    aot.compile_extra = compile_one
    cc = CC("_kernels_aot", source_module="ndboundary._kernels")
    cc.target_cpu = os.environ.get("NDBOUNDARY_AOT_CPU", "host")
    target = build_target(cc.target_cpu)
    namespace = {}
    exec(f"def built_for():\n    return {target!r}\n", namespace)
    cc.export("built_for", "unicode_type()")(namespace["built_for"])
    # the sources the kernels were compiled from, so that a changed file retires the module
    # (Python files only: not a module built before, which a reinstall has imported)
    sources = sorted(
        os.path.relpath(m.__file__, HERE).replace(os.sep, "/")
        for name, m in sys.modules.items()
        if name.startswith("ndboundary.") and str(getattr(m, "__file__", None)).endswith(".py")
    )
    exec(f"def built_from():\n    return {kernels.sources_digest(sources)!r}\n", namespace)
    cc.export("built_from", "unicode_type()")(namespace["built_from"])
    for k in kernels.REGISTRY:
        for i, sig in enumerate(k.signatures):
            # the arguments only: numba infers the result, as its dispatcher does (a result
            # type given beforehand changes how literals in the body unify)
            args, _ = sigutils.normalize_signature(sig)
            cc.export(kernels.export_name(k.module, k.name, i), args)(k.jit.py_func)
    return cc


def build_target(cpu):
    """What besides the kernels' sources a built module depends on: the CPU it was built
    for (the host's name and features for ``host``), numba's version and this file.
    """
    import numba

    if cpu == "host":
        from llvmlite import binding

        cpu = f"{binding.get_host_cpu_name()} {binding.get_host_cpu_features().flatten()}"
    with open(os.path.join(HERE, "setup.py"), "rb") as file:
        recipe = hashlib.sha256(file.read()).hexdigest()
    return f"{cpu}; numba {numba.__version__}; setup.py {recipe}"


def up_to_date(path, kernels):
    """Whether the kernels' module at ``path`` was built from the current sources, for
    the CPU a build now targets, by the same numba and recipe: then a new build (the
    second ``pip install -e .`` of a checkout) reuses it instead of compiling again.
    """
    if not os.path.isfile(path):
        return False
    try:
        spec = importlib.util.spec_from_file_location(AOT_MODULE, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        recorded, target = module.built_from(), module.built_for()
    except Exception:  # noqa: BLE001 - a module that does not load, or an older one, is rebuilt
        return False
    paths = [part.split("=", 1)[0] for part in recorded.split(";") if part]
    cpu = os.environ.get("NDBOUNDARY_AOT_CPU", "host")
    return bool(paths) and kernels.sources_digest(paths) == recorded and target == build_target(cpu)


class BuildKernels(build_ext):
    """``build_ext`` that builds the kernels' module, or says why it could not and goes on."""

    def run(self):
        """Compile the kernels' module first; leave it out of the build if that fails."""
        self._kernels_built = self._kernels_dir = None
        if os.environ.get("NDBOUNDARY_NO_AOT", "") in ("", "0"):
            try:
                kernels = load_kernels()
                built = self.get_ext_fullpath(AOT_MODULE)
                if up_to_date(built, kernels):
                    self._kernels_built = built
                else:
                    cc = compiler(kernels)
                    cc.output_dir = self._kernels_dir = tempfile.mkdtemp(prefix="ndboundary-kernels-")
                    cc.compile()
                    self._kernels_built = os.path.join(cc.output_dir, cc.output_file)
            except Exception as exc:  # noqa: BLE001 - any failure leaves numba's own compilation
                self.warn(f"kernels not built ahead of time ({exc!r}); numba compiles them on first use")
        if self._kernels_built is None:
            self.extensions = [e for e in self.extensions if e.name != AOT_MODULE]
            stale = os.path.join(self.build_lib, self.get_ext_filename(AOT_MODULE))
            if os.path.exists(stale):  # an earlier build's module must not ship with this one
                os.remove(stale)
        try:
            super().run()
        finally:
            if self._kernels_dir is not None:
                shutil.rmtree(self._kernels_dir, ignore_errors=True)

    def build_extension(self, ext):
        """Build ``ext``; the kernels' module is already compiled and only copied."""
        if ext.name != AOT_MODULE:
            return super().build_extension(ext)
        target = self.get_ext_fullpath(ext.name)
        if os.path.abspath(target) == os.path.abspath(self._kernels_built):
            return None  # the module there is up to date
        os.makedirs(os.path.dirname(target), exist_ok=True)
        # a new file renamed over the old one: processes that have the old one loaded keep it
        partial = f"{target}.partial"
        shutil.copyfile(self._kernels_built, partial)
        os.replace(partial, target)
        return None


AOT_MODULE = "ndboundary._kernels_aot"
setup(cmdclass={"build_ext": BuildKernels}, ext_modules=[Extension(AOT_MODULE, sources=[])])
