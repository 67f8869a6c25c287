"""Linear solvers for the two systems of the relaxation.

* :mod:`~ndboundary.solvers.heat`: :func:`solve_heat`, the heat system ``(M + t K) u = b``
  by Jacobi-preconditioned conjugate gradients;
* :mod:`~ndboundary.solvers.integration`: :func:`solve_integration`, the squared
  Laplacian ``(K M^{-1} K + mu K + lam S^T S) phi = r``, factorised on sparse rows,
  by preconditioned conjugate gradients on denser ones; and
  :func:`solve_gradient_integration`, its first-order form ``(K + lam S^T S) phi = r``;
* :mod:`~ndboundary.solvers.cholesky`: :func:`factorize_spd` by the fastest installed
  sparse Cholesky backend (:data:`BACKENDS`), :func:`available_backends`;
* :mod:`~ndboundary.solvers.pardiso`: the ctypes binding to MKL PARDISO;
* :mod:`~ndboundary.solvers.amg`: the smoothed-aggregation AMG V-cycle;
* :mod:`~ndboundary.solvers.cache`: :class:`FactorCache`, a factorisation kept for the
  next solve;
* :mod:`~ndboundary.solvers.common`: :class:`SolveInfo`, :class:`SolverFallbackWarning`,
  BLAS thread limits, conjugate gradients.

The tuning constants (:data:`FACTOR_THREADS`, :data:`SMALL_SYSTEM`, ...) live in the
module that uses them, which reads them at each call. This package forwards reads and
writes of them to that module: ``ndboundary.solvers.FACTOR_THREADS = 2`` and
``ndboundary.solvers.common.FACTOR_THREADS = 2`` do the same.

Examples
--------
>>> from ndboundary import solvers
>>> saved = solvers.FACTOR_THREADS
>>> solvers.FACTOR_THREADS = 2
>>> solvers.common.FACTOR_THREADS  # where the factorisations read it
2
>>> solvers.FACTOR_THREADS = saved
"""

from __future__ import annotations

import sys
import types

from . import amg, cholesky, common, integration
from .cache import FactorCache
from .cholesky import available_backends, factorize_spd
from .common import ConvergenceWarning, SolveInfo, SolverFallbackWarning
from .heat import solve_heat
from .integration import solve_gradient_integration, solve_integration

__all__ = [
    "SolveInfo",
    "SolverFallbackWarning",
    "ConvergenceWarning",
    "available_backends",
    "FactorCache",
    "factorize_spd",
    "solve_heat",
    "solve_gradient_integration",
    "solve_integration",
]

#: The module each tuning constant lives in (and is read from at call time).
_TUNING = {
    "DENSE_ROW_THRESHOLD": integration,
    "SMALL_SYSTEM": integration,
    "PCG_FACTOR_MAX": integration,
    "PCG_FACTOR_MAX_GRAPHS": integration,
    "SINGLE_PRECISION_MIN": integration,
    "SINGLE_REFINE_MAXITER": integration,
    "DIRECT_FALLBACK_MAX": integration,
    "FACTOR_THREADS": common,
    "LARGE_SYSTEM": cholesky,
    "BACKENDS": cholesky,
    "AMG_DENSE_ROWS": amg,
    "LIGHT_VERTEX_SHARE": amg,
}


def _forwarded(name, home):
    """A property reading and writing ``home.name``."""

    def get(module):
        return getattr(home, name)

    def set_(module, value):
        setattr(home, name, value)

    return property(get, set_, doc=f"Forwarded to ``{home.__name__}.{name}``, read there at call time.")


class _SolversPackage(types.ModuleType):
    """The solvers package, with its tuning constants forwarded to the modules that read them."""

    def __dir__(self):
        return sorted({*super().__dir__(), *_TUNING})


for _name, _home in _TUNING.items():
    setattr(_SolversPackage, _name, _forwarded(_name, _home))
del _name, _home

sys.modules[__name__].__class__ = _SolversPackage
