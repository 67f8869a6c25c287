"""What every solver shares: the report of a solve, the fallback warning, optional
modules, BLAS thread limits, conjugate gradients and the relative residual.

Solves run with :data:`SOLVE_THREADS` BLAS threads (threadpoolctl): OpenBLAS's threads
spin on the short vector operations of conjugate gradients and multiply the wall time
on a machine with any other load. A sparse factorisation runs with
:data:`FACTOR_THREADS` threads: a second thread speeds PARDISO up while the other cores
are idle and slows it down while another process uses them, and does not change
cvxopt's factor time (measured by ``benchmarks/solvers.py --factor-threads``).
"""

from __future__ import annotations

import contextlib
import importlib
import sys
import threading
import warnings
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse.linalg as spla

__all__ = [
    "ConvergenceWarning",
    "FACTOR_THREADS",
    "SOLVE_THREADS",
    "SolveInfo",
    "SolverFallbackWarning",
    "blas_threads",
    "cg",
    "fallback_warning",
    "load_optional",
    "one_blas_thread",
    "relres",
    "warn_unconverged",
]

#: Threads given to a sparse factorisation (MKL's for PARDISO, set for that call only;
#: OpenBLAS's for cvxopt's CHOLMOD). One, because a second thread only pays on a machine
#: with idle cores. Read at each factorisation: set it here or, equivalently, as
#: ``ndboundary.solvers.FACTOR_THREADS``.
FACTOR_THREADS = 1
#: BLAS threads while conjugate gradients and triangular solves run; None leaves BLAS's
#: own setting. One, because these memory-bound vector operations gain nothing from
#: more threads and lose much when the cores are shared. Read at each solve.
SOLVE_THREADS = 1

#: Speed cost of the fallback when an optional package that "auto" relies on is missing,
#: as measured by ``benchmarks/solvers.py``.
_FALLBACK_COST = {
    "cholesky": (
        "neither cvxopt nor pypardiso is installed: the integration solve on triangle meshes "
        "falls back to scipy's SuperLU, about 5x slower at 250K vertices and 7x at 1M "
        "(pip install cvxopt pypardiso)"
    ),
    "pyamg": (
        "pyamg is not installed: the integration solve on tetrahedral (3-D) meshes falls back "
        "to a sparse factorisation, about 5x slower at 36K vertices and 10-20x at 120K "
        "(pip install pyamg)"
    ),
}
#: Names of the fallbacks already warned about in this process.
_warned: set = set()


class SolverFallbackWarning(UserWarning):
    """An optional fast solver package is missing; a slower pure-scipy path is used.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warnings.warn("pyamg is missing", SolverFallbackWarning)
    >>> issubclass(caught[0].category, UserWarning)
    True
    """


@dataclass
class SolveInfo:
    """What a solve did: its method, iteration count and the relative residual reached.

    ``setup_time`` and ``solve_time`` (seconds) split the wall time between building
    the factorisation or preconditioner and applying it; they do not take part in
    comparisons, which are about what was computed.

    Examples
    --------
    >>> info = SolveInfo("cg-jacobi", 12, 3e-11, setup_time=0.5)
    >>> info.method, info.iterations
    ('cg-jacobi', 12)
    >>> info == SolveInfo("cg-jacobi", 12, 3e-11)
    True
    """

    method: str
    iterations: int
    residual: float
    setup_time: float = field(default=0.0, compare=False)
    solve_time: float = field(default=0.0, compare=False)


def load_optional(name):
    """The optional module ``name``, or None when it cannot be imported.

    Any error counts as missing (an ImportError, or a broken binary wheel), so that a
    faulty optional package makes the solvers fall back instead of failing.

    Examples
    --------
    >>> load_optional("math").sqrt(4.0)
    2.0
    >>> load_optional("no_such_module_here") is None
    True
    """
    try:
        return importlib.import_module(name)
    except Exception:  # noqa: BLE001 - ImportError, or a broken binary wheel
        return None


def fallback_warning(name, stacklevel):
    """Warn, once per process, that a pure-scipy path replaces the missing package ``name``.

    ``name`` is ``"cholesky"`` (no fast sparse Cholesky) or ``"pyamg"``; ``stacklevel``
    counts frames as :func:`warnings.warn` does from this function, so that the warning
    points at the user's call whatever the depth of the solver that found the package
    missing.

    Examples
    --------
    >>> import warnings
    >>> saved = set(_warned)
    >>> _warned.clear()
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     fallback_warning("pyamg", stacklevel=2)
    ...     fallback_warning("pyamg", stacklevel=2)  # once per process
    >>> len(caught), caught[0].category.__name__
    (1, 'SolverFallbackWarning')
    >>> _warned.clear()
    >>> _warned.update(saved)
    """
    if name in _warned:
        return
    _warned.add(name)
    warnings.warn(_FALLBACK_COST[name], SolverFallbackWarning, stacklevel=stacklevel)


def blas_threads(n):
    """A context limiting BLAS to ``n`` threads (threadpoolctl); None sets no limit.

    The limit is the process's, and threads share it: the context entered last among
    those still open sets it, and the limits found before the first are restored when the
    last one closes (for a library loaded while one was open, the threads it had when
    first seen). (threadpoolctl's own contexts, entered and left on two threads at
    once, would each restore what the other had found: the relaxation builds its
    integration's preconditioner on a second thread while conjugate gradients run.)
    OpenBLAS takes a raised thread count only from the thread that lowered it, so the
    first context should close last, on its own thread: work on another thread should
    run inside a context of the thread that waits for it.

    Examples
    --------
    >>> import numpy as np
    >>> with blas_threads(1):
    ...     float(np.ones(3) @ np.ones(3))
    3.0
    """
    controller = None if n is None else _threadpools()
    if controller is None:  # threadpoolctl ships with scikit-learn
        return contextlib.nullcontext()
    return _shared_limit(controller, n)


#: The open :func:`blas_threads` contexts (newest last), and the threads each BLAS library
#: (by its file) ran before the first of them, or before it was loaded while one was open;
#: changed under the lock.
_open_limits, _original_threads, _limits_lock = [], {}, threading.Lock()


def _blas_libraries(controller):
    return [lib for lib in controller.lib_controllers if lib.user_api == "blas"]


@contextlib.contextmanager
def _shared_limit(controller, n):
    token = object()
    with _limits_lock:
        for lib in _blas_libraries(controller):  # a library loaded since: its own threads
            _original_threads.setdefault(lib.filepath, lib.num_threads)
        controller.limit(limits=n, user_api="blas")
        _open_limits.append((token, controller, n))
    try:
        yield
    finally:
        with _limits_lock:
            _open_limits[:] = [entry for entry in _open_limits if entry[0] is not token]
            if _open_limits:
                _, newest, limit = _open_limits[-1]
                newest.limit(limits=limit, user_api="blas")
            else:  # every library this process has loaded (some, maybe, since this one opened)
                for lib in _blas_libraries(_threadpools() or controller):
                    if lib.filepath in _original_threads:
                        lib.set_num_threads(_original_threads[lib.filepath])
                _original_threads.clear()


_controller = [None, -1]


def _threadpools():
    """The process's thread pools (a ``threadpoolctl.ThreadpoolController``), found again
    only when modules were imported since: each search lists every loaded library, which
    cost 4 ms a solve, many times over for a partition of many regions.
    """
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl ships with scikit-learn
        return None
    if _controller[1] != len(sys.modules):  # a new module may have brought its own BLAS
        _controller[:] = ThreadpoolController(), len(sys.modules)
    return _controller[0]


def one_blas_thread():
    """A context limiting BLAS to :data:`SOLVE_THREADS` threads (one by default).

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     float(np.ones(3) @ np.ones(3))
    3.0
    """
    return blas_threads(SOLVE_THREADS)


def relres(A, x, b):
    """Relative residual ``|A x - b| / |b|`` (0 for ``b = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[2.0, 0.0], [0.0, 4.0]])
    >>> relres(A, np.array([0.5, 0.25]), np.array([1.0, 1.0]))
    0.0
    >>> relres(A, np.zeros(2), np.zeros(2))
    0.0
    """
    nb = np.linalg.norm(b)
    return float(np.linalg.norm(A @ x - b) / nb) if nb > 0 else 0.0


def cg(A, b, M, rtol, maxiter, x0=None):
    """Conjugate gradients on ``A x = b`` preconditioned by ``M``, with one BLAS thread.

    ``rtol`` is relative to ``|b|`` (no absolute tolerance, so that the tolerance means
    the same at any scale of the system).

    Returns
    -------
    x : ndarray
    iterations : int
        Iterations run.
    info : int
        scipy's convergence flag: 0 when ``rtol`` was reached.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[4.0, 1.0], [1.0, 3.0]])
    >>> x, iterations, info = cg(A, np.array([1.0, 2.0]), None, 1e-12, 10)
    >>> bool(np.allclose(A @ x, [1.0, 2.0])), iterations <= 2, info
    (True, True, 0)
    """
    it = [0]

    def count(_):
        it[0] += 1

    with one_blas_thread():
        x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=maxiter, M=M, callback=count)
    return x, it[0], info


class ConvergenceWarning(RuntimeWarning):
    """A linear solve of the relaxation ended above its tolerance: the result may be wrong.

    The message names the step (heat or integration), the relative residual reached and the
    tolerance asked for.
    """


def warn_unconverged(step, info, rtol, hint="", stacklevel=3):
    """Warn that the solve of ``step`` reached only ``info.residual`` against ``rtol``.

    Examples
    --------
    >>> import warnings
    >>> from ndboundary.solvers.common import SolveInfo, warn_unconverged
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn_unconverged("heat (step 1)", SolveInfo("cg-jacobi", 2000, 3e-5), 1e-10)
    >>> print(caught[0].message)
    heat (step 1) solve did not converge: relative residual 3.00e-05 after 2000 iterations of cg-jacobi, target 1e-10
    """
    warnings.warn(
        f"{step} solve did not converge: relative residual {info.residual:.2e} after "
        f"{info.iterations} iterations of {info.method}, target {rtol:.0e}{hint}",
        ConvergenceWarning,
        stacklevel=stacklevel,
    )
