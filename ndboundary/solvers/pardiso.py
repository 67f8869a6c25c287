"""A ctypes binding to the sparse Cholesky factorisation of MKL PARDISO.

The package pypardiso brings MKL's runtime library (``mkl_rt``), which
:func:`mkl_library` finds next to the interpreter, as pypardiso would, without importing
pypardiso: that import and pypardiso's search of every folder of the environment took
over a second of a process's first factorisation, where loading MKL takes milliseconds.
:class:`PardisoFactor` calls PARDISO itself, to keep one factor per object (released
with it), to hand the ordering of one matrix to the next matrix of the same sparsity
pattern, and to set the number of threads of each phase. Its calls release the GIL
(ctypes does so around every foreign call), so that a factorisation on one thread lets
Python work on another go on.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import importlib
import importlib.util
import os
import site
import sys
import threading
import time
import weakref

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import common
from .cache import cached, digest, orderings_of

__all__ = ["MINIMUM_DEGREE_MAX", "PardisoFactor", "available", "mkl_library", "refined_single"]

#: Below this many unknowns PARDISO orders the matrix by minimum degree, from there by
#: METIS nested dissection: on the integration matrices of triangle meshes minimum
#: degree factorises faster up to about 10^5 unknowns, METIS beyond
#: (``benchmarks/solvers.py --methods
#: pardiso-md-direct,pardiso-metis-direct,cvxopt-direct``).
MINIMUM_DEGREE_MAX = 100_000


class PardisoFactor:
    """Cholesky factor of a sparse SPD matrix by MKL PARDISO (matrix type 2).

    The upper triangle is passed in CSR form with zero-based indices; minimum degree or
    METIS nested dissection orders it (:data:`MINIMUM_DEGREE_MAX`), and the ordering is
    kept for the next matrix with the same sparsity pattern (the integration matrix of a
    mesh has one pattern whatever the labels and parameters), which skips most of the
    analysis phase. The factorisation runs with
    :data:`~ndboundary.solvers.common.FACTOR_THREADS` MKL threads (read when the factor is
    built), the triangular solves with one (they are memory bound, and may be called from
    inside an iteration). The MKL memory of the factor is released when
    the object is garbage collected.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite; only its upper triangle is read.
    single : bool, default=False
        Factorise and solve in single precision: half the memory and a faster
        factorisation, for use as a preconditioner (:meth:`solve` still takes and
        returns double precision). Off by default, because a direct solve needs the
        double-precision factor to reach a small residual.
    orderings : dict, optional
        Where the ordering is kept (key ``"entry"``) for the next matrix of the same
        sparsity pattern, and where a kept one is looked up
        (:attr:`~ndboundary.solvers.FactorCache.orderings`). None, the default, orders
        every matrix afresh and keeps nothing. The ordering is minimum degree below
        :data:`MINIMUM_DEGREE_MAX` unknowns, METIS nested dissection from there.
    upper : bool, default=False
        ``A`` is the upper triangle already, in CSR form with sorted columns and no
        duplicates (:func:`~ndboundary._compiled.squared_upper` builds it so): taken as
        it is, without the copies that extract and sort it.

    Attributes
    ----------
    n : int
        Number of unknowns.
    reused_ordering : bool
        Whether the ordering came from ``orderings`` instead of PARDISO's analysis.

    Raises
    ------
    RuntimeError
        If PARDISO fails (for example on a matrix that is not positive definite).

    Examples
    --------
    >>> import numpy as np
    >>> import scipy.sparse as sp
    >>> from ndboundary.solvers.common import load_optional
    >>> A = sp.csr_matrix([[4.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 4.0]])
    >>> b = np.array([1.0, 2.0, 3.0])
    >>> if load_optional("pypardiso") is not None:  # MKL ships for Linux x86-64 and Windows
    ...     x = PardisoFactor(A).solve(b)
    ... else:
    ...     x = np.linalg.solve(A.toarray(), b)
    >>> bool(np.allclose(A @ x, b))
    True
    """

    _ARGTYPES = (
        [ctypes.c_void_p]  # pt
        + [ctypes.POINTER(ctypes.c_int32)] * 5  # maxfct, mnum, mtype, phase, n
        + [ctypes.c_void_p] * 3  # a, ia, ja
        + [ctypes.c_void_p]  # perm
        + [ctypes.POINTER(ctypes.c_int32)] * 3  # nrhs, iparm, msglvl
        + [ctypes.c_void_p] * 2  # b, x
        + [ctypes.POINTER(ctypes.c_int32)]  # error
    )

    def __init__(self, A, single=False, orderings=None, upper=False):
        self._pardiso, self._set_threads = _mkl_functions()
        self._dtype = np.float32 if single else np.float64
        if upper:  # the caller's upper triangle, as it is
            U = sp.csr_matrix(A)
        else:
            U = sp.triu(sp.csr_matrix(A), format="csr")
            U.sum_duplicates()
            U.sort_indices()
        self.n = U.shape[0]
        self._a = np.ascontiguousarray(U.data, dtype=self._dtype)
        self._ia = np.ascontiguousarray(U.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(U.indices, dtype=np.int32)
        del U
        self._pt = np.zeros(64, dtype=np.int64)  # PARDISO's handle
        self._iparm = np.zeros(64, dtype=np.int32)
        self._iparm[0] = 1  # these parameters, not the defaults
        self._iparm[1] = 0 if self.n < MINIMUM_DEGREE_MAX else 2  # minimum degree, or METIS
        self._iparm[17] = -1  # report the number of non-zeros of the factor
        self._iparm[27] = int(single)  # single-precision factor and solves
        self._iparm[34] = 1  # zero-based indices
        pattern = digest("pattern", self._ia, self._ja)
        known = None if orderings is None else orderings.get("entry")
        if known is not None and known[0] == pattern:
            self._perm = known[1]
            self._iparm[4] = 1  # use this ordering
        else:
            self._perm = np.zeros(self.n, dtype=np.int32)
            self._iparm[4] = 2  # return the ordering computed
        self.reused_ordering = bool(self._iparm[4] == 1)
        self._lock = threading.Lock()
        self._call(12, threads=common.FACTOR_THREADS)  # analysis and numerical factorisation
        self._finalizer = weakref.finalize(self, PardisoFactor._release, self._pardiso, self._pt, self._iparm)
        if orderings is not None and not self.reused_ordering:
            orderings["entry"] = (pattern, self._perm)

    @staticmethod
    def _release(func, pt, iparm):
        one = ctypes.c_int32(1)
        dummy = np.zeros(1)
        idx = np.zeros(1, dtype=np.int32)
        err = ctypes.c_int32(0)
        func(
            pt.ctypes.data, ctypes.byref(one), ctypes.byref(one), ctypes.byref(ctypes.c_int32(2)),
            ctypes.byref(ctypes.c_int32(-1)), ctypes.byref(ctypes.c_int32(0)), dummy.ctypes.data,
            idx.ctypes.data, idx.ctypes.data, None, ctypes.byref(one),
            iparm.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)), ctypes.byref(ctypes.c_int32(0)),
            dummy.ctypes.data, dummy.ctypes.data, ctypes.byref(err),
        )  # fmt: skip

    def _call(self, phase, b=None, x=None, nrhs=1, threads=1):
        b = np.zeros(1) if b is None else b
        x = np.zeros(1) if x is None else x
        err = ctypes.c_int32(0)
        one = ctypes.c_int32(1)
        with self._lock:
            previous = self._set_threads(threads)
            try:
                self._pardiso(
                    self._pt.ctypes.data, ctypes.byref(one), ctypes.byref(one),
                    ctypes.byref(ctypes.c_int32(2)), ctypes.byref(ctypes.c_int32(phase)),
                    ctypes.byref(ctypes.c_int32(self.n)), self._a.ctypes.data,
                    self._ia.ctypes.data, self._ja.ctypes.data, self._perm.ctypes.data,
                    ctypes.byref(ctypes.c_int32(nrhs)),
                    self._iparm.ctypes.data_as(ctypes.POINTER(ctypes.c_int32)),
                    ctypes.byref(ctypes.c_int32(0)), b.ctypes.data, x.ctypes.data,
                    ctypes.byref(err),
                )  # fmt: skip
            finally:
                self._set_threads(previous)
        if err.value != 0:
            if phase == 12:
                PardisoFactor._release(self._pardiso, self._pt, self._iparm)
            raise RuntimeError(f"PARDISO failed in phase {phase} with error {err.value}")

    @property
    def factor_nnz(self):
        """Number of non-zeros of the Cholesky factor."""
        return int(self._iparm[17])

    @property
    def factor_nbytes(self):
        """Bytes of the factor: its non-zeros and their 4-byte indices."""
        return self.factor_nnz * (self._dtype().itemsize + 4)

    def solve(self, b):
        """Solve ``A x = b`` for a vector or a matrix of right-hand sides."""
        b = np.asarray(b, dtype=np.float64)
        B = np.asfortranarray(b.reshape(self.n, -1), dtype=self._dtype)
        X = np.empty_like(B, order="F")
        self._call(33, B, X, nrhs=B.shape[1])
        return X.reshape(b.shape).astype(np.float64, copy=False)


def mkl_library():
    """The path of MKL's runtime library that pypardiso would load, or None.

    Looked for where pypardiso looks, in its order, but without its search of every
    folder below the environment's: the file named by ``PYPARDISO_MKL_RT``, then
    ``lib/libmkl_rt.so*`` (``lib/libmkl_rt*.dylib``, ``Library/bin/mkl_rt*.dll``) of the
    environment and of the user's site; None where none is found there.

    Examples
    --------
    >>> path = mkl_library()
    >>> path is None or "mkl_rt" in path
    True
    """
    return _mkl_library()


@functools.lru_cache(maxsize=1)
def _mkl_library():
    named = os.environ.get("PYPARDISO_MKL_RT")
    if named:
        return named
    patterns = ("lib/libmkl_rt.so*", "lib/libmkl_rt*.dylib", "Library/bin/mkl_rt*.dll")
    for root in (sys.prefix, site.USER_BASE or ""):
        for pattern in patterns:
            found = sorted(glob.glob(os.path.join(root, pattern)), key=len)
            if found:
                return found[0]
    return None


def available():
    """Whether PARDISO can run: pypardiso is installed (whose presence makes PARDISO a
    backend; it is not imported) and MKL's library loads.

    Examples
    --------
    >>> available() in (True, False)
    True
    """
    try:
        if sys.modules["pypardiso"] is None:  # marked missing
            return False
    except KeyError:
        try:
            if importlib.util.find_spec("pypardiso") is None:
                return False
        except (ImportError, ValueError):
            return False
    try:
        _mkl_functions()
    except Exception:  # noqa: BLE001 - no pypardiso, or an MKL that does not load
        return False
    return True


@functools.lru_cache(maxsize=1)
def _mkl_functions():
    """MKL's ``pardiso`` and ``MKL_Set_Num_Threads_Local``, from :func:`mkl_library`
    (from the library pypardiso finds, where that finds none).
    """
    path = _mkl_library()
    if path is not None:
        lib = ctypes.CDLL(path)
    else:  # pypardiso's own search: the conda layouts, and find_library's
        lib = importlib.import_module("pypardiso").PyPardisoSolver(mtype=2).libmkl
    pardiso = ctypes.CFUNCTYPE(None, *PardisoFactor._ARGTYPES)(("pardiso", lib))
    set_threads = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int)(("MKL_Set_Num_Threads_Local", lib))
    return pardiso, set_threads


def refined_single(Q, rhs, rtol, cache, maxiter):
    """Solve ``Q phi = rhs`` by conjugate gradients preconditioned with a single-precision
    PARDISO factor of ``Q``: ``(phi, SolveInfo)``, or None when that factorisation fails
    or the iteration does not reach ``rtol`` within ``maxiter`` iterations.
    """
    t0 = time.perf_counter()
    try:
        with common.one_blas_thread():
            solve = cached(
                ("direct", "pardiso-single"), Q,
                lambda A: PardisoFactor(A, single=True, orderings=orderings_of(cache)).solve, cache,
            )  # fmt: skip
    except Exception:  # noqa: BLE001 - any failure of the optional path: factorise in double
        return None
    t1 = time.perf_counter()
    n = Q.shape[0]
    P = spla.LinearOperator((n, n), matvec=solve, dtype=np.float64)
    phi, iters, _ = common.cg(Q, rhs, P, rtol, maxiter)
    res = common.relres(Q, phi, rhs)
    if not res <= 10 * rtol:
        return None
    return phi, common.SolveInfo("cholesky-single+cg", iters, res, t1 - t0, time.perf_counter() - t1)
