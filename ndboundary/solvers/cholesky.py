"""Sparse Cholesky factorisation by the fastest installed backend: :func:`factorize_spd`.

The backends: CHOLMOD supernodal of cvxopt, MKL PARDISO (:mod:`.pardiso`), CHOLMOD of
sksparse-minimal (where neither has a wheel) and scipy's SuperLU, which is always
there. ``backend="auto"`` tries them in the order of :data:`BACKENDS`, PARDISO first
from :data:`LARGE_SYSTEM` unknowns (:func:`auto_order`); which one is fastest at which
size is measured by ``benchmarks/solvers.py``.
"""

from __future__ import annotations

import importlib
import threading

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import common
from . import pardiso
from .common import blas_threads, load_optional
from .pardiso import PardisoFactor

__all__ = [
    "BACKENDS",
    "DENSE_MAX",
    "DENSE_MIN",
    "DENSE_SHARE",
    "FACTORISERS",
    "LARGE_SYSTEM",
    "auto_order",
    "available_backends",
    "factorize_spd",
    "fast_cholesky_available",
]

#: From this many unknowns ``backend="auto"`` tries PARDISO before cvxopt: there its
#: METIS ordering makes it as fast with less memory, while below, cvxopt is faster
#: (a relaxation still factorises by PARDISO beside its field's steps, whose Python
#: work cvxopt would stop: :func:`~ndboundary.solvers.integration.integration_preconditioner`).
LARGE_SYSTEM = 500_000

#: Sparse Cholesky backends in the order ``backend="auto"`` tries them below
#: :data:`LARGE_SYSTEM` unknowns (the fastest first, as measured by
#: ``benchmarks/solvers.py``), with the module each one needs (None: scipy's own).
BACKENDS = {
    "cvxopt": "cvxopt.cholmod",
    "pardiso": "pypardiso",
    "cholmod": "sksparse_minimal",
    "superlu": None,
}


#: ``backend="auto"`` factorises a matrix of :data:`DENSE_MIN` to this many unknowns
#: whose nonzeros exceed :data:`DENSE_SHARE` of its entries as a dense one (LAPACK), at
#: most 8 n^2 bytes.
DENSE_MAX = 8000
#: See :data:`DENSE_MAX`: below, every backend is fast.
DENSE_MIN = 1000
#: See :data:`DENSE_MAX`. The squared operator of a neighbour graph couples 4-ring
#: neighbours: on a few thousand samples it is close to dense, where a sparse
#: factorisation spends seconds building its structure for the same dense fronts.
DENSE_SHARE = 0.2


def _dense(A):
    """LAPACK's Cholesky of the dense matrix (``scipy.linalg.cho_factor``)."""
    factor = sla.cho_factor(sp.csr_matrix(A).toarray(), lower=True, check_finite=False)

    def solve(b):
        return sla.cho_solve(factor, np.asarray(b, dtype=np.float64), check_finite=False)

    return solve


def _superlu(A):
    """SuperLU (scipy) in symmetric mode: minimum degree on ``A + A^T``, diagonal pivots."""
    lu = spla.splu(
        sp.csc_matrix(A),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve


def _cholmod(A):
    """CHOLMOD of sksparse-minimal, which takes 32-bit indices and float64 entries only."""
    mod = load_optional("sksparse_minimal")
    A = sp.csc_matrix(A)
    A.sort_indices()
    A = sp.csc_matrix(
        (A.data.astype(np.float64), A.indices.astype(np.int32), A.indptr.astype(np.int32)),
        shape=A.shape,
    )
    factor = mod.SparseCholesky(A)
    return factor.solve_A


#: Held while cvxopt's factorisation sets its module's options, so that factorisations on
#: two threads (one built beside a relaxation's field) do not restore each other's.
_CVXOPT_OPTIONS = threading.Lock()


def _cvxopt(A):
    """Supernodal CHOLMOD of cvxopt (AMD ordering, the wheel's own OpenBLAS)."""
    cvxopt = importlib.import_module("cvxopt")
    cholmod = importlib.import_module("cvxopt.cholmod")
    n = A.shape[0]
    L = sp.tril(A, format="coo")
    Ac = cvxopt.spmatrix(
        np.ascontiguousarray(L.data, dtype=np.float64),
        L.row.astype(np.int64),
        L.col.astype(np.int64),
        (n, n),
    )
    del L
    with _CVXOPT_OPTIONS:  # the options are the module's: one factorisation sets them at a time
        saved = dict(cholmod.options)
        cholmod.options.update(supernodal=2, postorder=True)
        try:
            with blas_threads(common.FACTOR_THREADS):
                F = cholmod.symbolic(Ac, uplo="L")
                cholmod.numeric(Ac, F)
        finally:
            cholmod.options.clear()
            cholmod.options.update(saved)
    del Ac
    lock = threading.Lock()

    def solve(b):
        b = np.asarray(b, dtype=np.float64)
        x = cvxopt.matrix(np.asfortranarray(b.reshape(n, -1)))
        with lock:
            cholmod.solve(F, x)
        return np.asarray(x).reshape(b.shape)

    return solve


def _pardiso(A, orderings=None):
    return PardisoFactor(A, orderings=orderings).solve


#: The factorisation of each backend of :data:`BACKENDS`: ``FACTORISERS[name](A)``
#: returns a solve function (PARDISO's also takes ``orderings=``).
FACTORISERS = {"pardiso": _pardiso, "cvxopt": _cvxopt, "cholmod": _cholmod, "superlu": _superlu}

_PACKAGE = {"pardiso": "pypardiso", "cvxopt": "cvxopt", "cholmod": "sksparse-minimal"}


def _installed(name):
    """Whether the backend ``name`` of :data:`BACKENDS` can run here (PARDISO's runtime
    is found without importing pypardiso, whose import alone takes about a second).
    """
    if name == "pardiso":
        return pardiso.available()
    mod = BACKENDS[name]
    return mod is None or load_optional(mod) is not None


def factorize_spd(A, backend="auto", orderings=None):
    """Return a function solving ``A x = b`` for a sparse symmetric positive definite ``A``.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite; both triangles are given (each backend reads the
        one it needs).
    backend : {"auto", "pardiso", "cvxopt", "cholmod", "superlu"}, default="auto"
        ``"pardiso"``: MKL PARDISO's Cholesky with METIS ordering (package
        ``pypardiso``); ``"cvxopt"``: CHOLMOD supernodal Cholesky with AMD ordering
        (package ``cvxopt``); ``"cholmod"``: CHOLMOD from package ``sksparse-minimal``;
        ``"superlu"``: scipy's SuperLU in symmetric mode (minimum degree on ``A + A^T``,
        diagonal pivots). ``"auto"``: the first backend that is installed and accepts
        the matrix, in the order of :data:`BACKENDS` (cvxopt, pardiso, cholmod, superlu),
        PARDISO first from :data:`LARGE_SYSTEM` unknowns; an error of one backend (a
        missing runtime library, a pivot that is not positive) moves on to the next. A
        matrix of :data:`DENSE_MIN` to :data:`DENSE_MAX` unknowns with more than
        :data:`DENSE_SHARE` of its entries nonzero is factorised dense, by LAPACK, first.
    orderings : dict, optional
        Where PARDISO keeps its METIS ordering for the next matrix of the same sparsity
        pattern, and finds the one kept (:attr:`~ndboundary.solvers.FactorCache.orderings`).
        None, the default, orders every matrix afresh: nothing is kept unless the caller
        owns the place to keep it.

    Returns
    -------
    solve : callable
        ``solve(b)`` returns ``x`` with the shape of ``b`` (a vector, or a matrix whose
        columns are right-hand sides).

    Raises
    ------
    ImportError
        If the named backend's package is not installed.

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> A = sp.csr_matrix([[4.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 4.0]])
    >>> solve = factorize_spd(A)
    >>> b = np.array([1.0, 2.0, 3.0])
    >>> bool(np.allclose(A @ solve(b), b))
    True
    >>> B = np.eye(3)  # the columns of a matrix are right-hand sides
    >>> bool(np.allclose(A @ factorize_spd(A, backend="superlu")(B), B))
    True
    """
    if backend != "auto" and backend not in BACKENDS:
        names = "', '".join(["auto", *BACKENDS])
        raise ValueError(f"backend must be one of '{names}', got {backend!r}")
    if backend != "auto":
        if not _installed(backend):
            raise ImportError(f"backend={backend!r} needs the package {_PACKAGE[backend]}")
        return _factorise(backend, A, orderings)
    n = A.shape[0]
    if DENSE_MIN <= n <= DENSE_MAX and A.nnz > DENSE_SHARE * n * n:
        try:
            return _dense(A)
        except np.linalg.LinAlgError:  # not numerically positive definite: the sparse backends decide
            pass
    for name in auto_order(A.shape[0]):
        if BACKENDS[name] is None or not _installed(name):
            continue
        try:
            return _factorise(name, A, orderings)
        except Exception:  # noqa: BLE001, S112 - a failing optional backend: try the next
            continue
    return _superlu(A)


def _factorise(name, A, orderings):
    return FACTORISERS[name](A, orderings=orderings) if name == "pardiso" else FACTORISERS[name](A)


def auto_order(n):
    """Backend names in the order ``backend="auto"`` tries them for ``n`` unknowns.

    The order of :data:`BACKENDS`, with PARDISO moved before cvxopt from
    :data:`LARGE_SYSTEM` unknowns; backends that are not installed are listed too
    (:func:`factorize_spd` skips them).

    Examples
    --------
    >>> small, large = auto_order(1000), auto_order(LARGE_SYSTEM)
    >>> small.index("cvxopt") < small.index("pardiso"), large.index("pardiso") < large.index("cvxopt")
    (True, True)
    >>> small[-1] == large[-1] == "superlu"
    True
    """
    order = list(BACKENDS)
    if n >= LARGE_SYSTEM and "pardiso" in order and "cvxopt" in order:
        i, j = order.index("cvxopt"), order.index("pardiso")
        if j > i:
            order.insert(i, order.pop(j))
    return order


def fast_cholesky_available():
    """Whether a backend other than scipy's SuperLU is installed.

    Examples
    --------
    >>> fast_cholesky_available() == any(b in available_backends() for b in ("cvxopt", "pardiso", "cholmod"))
    True
    """
    return any(mod is not None and _installed(name) for name, mod in BACKENDS.items())


def available_backends():
    """Names of the factorisation / preconditioner backends importable here.

    The sparse Cholesky backends come first, in the order of :data:`BACKENDS`, then
    ``"amg"`` when pyamg is installed.

    Examples
    --------
    >>> names = available_backends()
    >>> "superlu" in names  # scipy's, always there
    True
    >>> [b for b in names if b != "amg"] == [b for b in BACKENDS if b in names]
    True
    """
    out = [name for name in BACKENDS if _installed(name)]
    if load_optional("pyamg") is not None:
        out.append("amg")
    return out
