"""Linear solvers for the two systems of the relaxation.

* Heat, ``(M + t K) u = b`` with ``t = h^2``: mass dominated, its conditioning does
  not grow with the mesh, so Jacobi-preconditioned conjugate gradients converge in a
  few dozen iterations at any size.
* Integration, ``Q phi = r`` with ``Q = K M^{-1} K + mu K + lam S^T S`` (a squared
  Laplacian). Two ways, chosen by the shape of ``K`` (``method="auto"``):

  - sparse rows (triangle meshes, surfaces: about 7 entries per row of ``K``) or small
    systems: a sparse Cholesky factorisation of ``Q`` itself (see :func:`factorize_spd`)
    by the fastest installed backend: CHOLMOD supernodal (package ``cvxopt``) below
    :data:`LARGE_SYSTEM` unknowns, MKL PARDISO (package ``pypardiso``: METIS ordering,
    30% less memory, reused by the next factorisation on the same mesh) from there, in
    single precision refined by conjugate gradients to ``rtol`` (half the factor's
    memory; 16 s instead of 22 s at 1M vertices), CHOLMOD of ``sksparse-minimal`` where
    neither has a wheel, else scipy's SuperLU (5-7x slower at 250K-1M vertices), with
    one :class:`SolverFallbackWarning` per process naming the cost;
  - denser rows (tetrahedra, higher dimensions, neighbour graphs): conjugate gradients
    preconditioned by ``(K + D) M^{-1} (K + D)``, ``D`` diagonal, ``(K + D)^{-1}``
    applied by one smoothed-aggregation AMG V-cycle (package ``pyamg``: linear cost,
    where any factorisation of a 3-D mesh fills in as n^2: 4 s instead of 40-275 s at
    118K vertices), else by a Cholesky factor, with one :class:`SolverFallbackWarning`
    per process naming the cost. The V-cycle (settings measured in ``_amg``) smooths
    with symmetric Gauss-Seidel on CSR levels, its prolongator by energy minimisation on
    meshes and by a Jacobi step on graphs (rows of more than :data:`AMG_DENSE_ROWS`
    entries): 1.4 s at 64K tetrahedral vertices, 6.9 s at 250K (rtol 1e-10), 12 s for
    a 100K-point neighbour graph (rtol 1e-6), against 2.7 s, 14.5 s and 16.5 s before.

Every solve reports its relative residual; an iteration that does not reach its
tolerance warns with the residual it reached (``method="pcg"``) or finishes with a
direct factorisation (``method="auto"``).

Solves run with one BLAS thread (threadpoolctl): OpenBLAS's threads spin on the short
vector operations of conjugate gradients and cost 1.5-4x the wall time on a 2-core
machine with any other load. A factorisation runs with :data:`FACTOR_THREADS` threads,
one by default (MKL's for PARDISO, set for that call only; OpenBLAS's for cvxopt, whose
factor time they do not change): on 2 cores a second PARDISO thread was 25-30% faster
at 60K-250K vertices while the other core was idle, and 10-40% slower while another
process used it.
"""

from __future__ import annotations

import contextlib
import os
import ctypes
import functools
import hashlib
import importlib
import threading
import time
import warnings
import weakref
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = [
    "SolveInfo",
    "SolverFallbackWarning",
    "available_backends",
    "FactorCache",
    "factorize_spd",
    "solve_heat",
    "solve_integration",
]

#: Rows of ``K`` with more entries than this on average count as "3-D like": the
#: integration then iterates instead of factorising ``Q`` (whose fill grows as n^2).
DENSE_ROW_THRESHOLD = 10.0
#: Below this many unknowns the integration system is always factorised.
SMALL_SYSTEM = 3000
#: Threads given to a sparse factorisation (MKL for PARDISO, OpenBLAS for cvxopt's CHOLMOD).
FACTOR_THREADS = 1
#: From this many unknowns ``backend="auto"`` tries PARDISO before cvxopt.
LARGE_SYSTEM = 500_000
#: From this many unknowns, ``method="auto"`` factorises the integration matrix of a
#: triangle mesh with PARDISO in single precision (half the factor's memory, about 35%
#: less factorisation time at 1M vertices) and refines the solution by conjugate
#: gradients preconditioned with that factor to ``rtol`` (8 iterations at 1M vertices);
#: if that takes more than :data:`SINGLE_REFINE_MAXITER` iterations, a double-precision
#: factor solves it instead.
SINGLE_PRECISION_MIN = LARGE_SYSTEM
SINGLE_REFINE_MAXITER = 30
#: Above this many unknowns, a system with denser rows whose iteration stalls is not
#: factorised (its factor fills in as n^2: 275 s at 118K tetrahedral-grid vertices, more
#: memory than the machine has at 1M); conjugate gradients go on for ``4 maxiter`` more
#: iterations instead, then warn with the residual reached.
DIRECT_FALLBACK_MAX = 120_000
#: Rows of the AMG operator ``K + D`` with more entries than this on average (neighbour
#: graphs) get a Jacobi-smoothed prolongator, sparser ones (meshes) an energy-minimising
#: one (see :func:`_amg`).
AMG_DENSE_ROWS = 40.0

#: Sparse Cholesky backends in the order ``backend="auto"`` tries them below
#: :data:`LARGE_SYSTEM` unknowns (the fastest first, as measured by
#: ``benchmarks/solvers.py``), with the module each one needs.
BACKENDS = {
    "cvxopt": "cvxopt.cholmod",
    "pardiso": "pypardiso",
    "cholmod": "sksparse_minimal",
    "superlu": None,
}

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
_warned: set = set()


class SolverFallbackWarning(UserWarning):
    """An optional fast solver package is missing; a slower pure-scipy path is used."""


@dataclass
class SolveInfo:
    """What a solve did: its method, iteration count and the relative residual reached.

    ``setup_time`` and ``solve_time`` (seconds) split the wall time between building
    the factorisation or preconditioner and applying it.
    """

    method: str
    iterations: int
    residual: float
    setup_time: float = field(default=0.0, compare=False)
    solve_time: float = field(default=0.0, compare=False)


# ----------------------------------------------------------------------------- helpers


def _load(name):
    """The optional module ``name``, or None when it cannot be imported."""
    try:
        return importlib.import_module(name)
    except Exception:  # noqa: BLE001 - ImportError, or a broken binary wheel
        return None


def _fallback_warning(name):
    """Warn, once per process, that a pure-scipy path replaces the missing package ``name``."""
    if name in _warned:
        return
    _warned.add(name)
    warnings.warn(_FALLBACK_COST[name], SolverFallbackWarning, stacklevel=4)


def available_backends():
    """Names of the factorisation / preconditioner backends importable here.

    The sparse Cholesky backends come first, in the order ``backend="auto"`` tries
    them, then ``"amg"`` when pyamg is installed.
    """
    out = [name for name, mod in BACKENDS.items() if mod is None or _load(mod) is not None]
    if _load("pyamg") is not None:
        out.append("amg")
    return out


def _one_blas_thread():
    return _blas_threads(1)


def _blas_threads(n):
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl ships with scikit-learn
        return contextlib.nullcontext()
    return threadpool_limits(limits=n, user_api="blas")


def _superlu(A):
    lu = spla.splu(
        sp.csc_matrix(A),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve


def _cholmod(A):
    mod = _load("sksparse_minimal")
    A = sp.csc_matrix(A)
    A.sort_indices()
    A = sp.csc_matrix(
        (A.data.astype(np.float64), A.indices.astype(np.int32), A.indptr.astype(np.int32)),
        shape=A.shape,
    )
    factor = mod.SparseCholesky(A)
    return factor.solve_A


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
    saved = dict(cholmod.options)
    cholmod.options.update(supernodal=2, postorder=True)
    try:
        with _blas_threads(FACTOR_THREADS):
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


class _Pardiso:
    """Cholesky factor of a sparse SPD matrix by MKL PARDISO (matrix type 2).

    The upper triangle is passed in CSR form with zero-based indices; METIS nested
    dissection orders it, and the ordering is kept for the next matrix with the same
    sparsity pattern (the integration matrix of a mesh has one pattern whatever the
    labels and parameters), which skips most of the analysis phase. The factorisation
    runs with :data:`FACTOR_THREADS` MKL threads, the triangular solves with one (they
    are memory bound, and may be called from inside an iteration). The MKL memory of the
    factor is released when the object is garbage collected.

    With ``single=True`` the factorisation and the triangular solves run in single
    precision (half the memory, a faster factorisation); ``solve`` still takes and
    returns double precision, for use as a preconditioner.
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

    def __init__(self, A, single=False, orderings=None):
        self._pardiso, self._set_threads = _mkl_functions()
        self._dtype = np.float32 if single else np.float64
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
        self._iparm[1] = 2  # METIS nested dissection ordering
        self._iparm[17] = -1  # report the number of non-zeros of the factor
        self._iparm[27] = int(single)  # single-precision factor and solves
        self._iparm[34] = 1  # zero-based indices
        pattern = _digest("pattern", self._ia, self._ja)
        known = None if orderings is None else orderings.get("entry")
        if known is not None and known[0] == pattern:
            self._perm = known[1]
            self._iparm[4] = 1  # use this ordering
        else:
            self._perm = np.zeros(self.n, dtype=np.int32)
            self._iparm[4] = 2  # return the ordering computed
        self.reused_ordering = bool(self._iparm[4] == 1)
        self._lock = threading.Lock()
        self._call(12, threads=FACTOR_THREADS)  # analysis and numerical factorisation
        self._finalizer = weakref.finalize(
            self, _Pardiso._release, self._pardiso, self._pt, self._iparm
        )
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
                _Pardiso._release(self._pardiso, self._pt, self._iparm)
            raise RuntimeError(f"PARDISO failed in phase {phase} with error {err.value}")

    @property
    def factor_nnz(self):
        """Number of non-zeros of the Cholesky factor."""
        return int(self._iparm[17])

    def solve(self, b):
        """Solve ``A x = b`` for a vector or a matrix of right-hand sides."""
        b = np.asarray(b, dtype=np.float64)
        B = np.asfortranarray(b.reshape(self.n, -1), dtype=self._dtype)
        X = np.empty_like(B, order="F")
        self._call(33, B, X, nrhs=B.shape[1])
        return X.reshape(b.shape).astype(np.float64, copy=False)


@functools.lru_cache(maxsize=1)
def _mkl_functions():
    """MKL's ``pardiso`` and ``MKL_Set_Num_Threads_Local``, from the library pypardiso finds."""
    pypardiso = importlib.import_module("pypardiso")
    lib = pypardiso.PyPardisoSolver(mtype=2).libmkl
    pardiso = ctypes.CFUNCTYPE(None, *_Pardiso._ARGTYPES)(("pardiso", lib))
    set_threads = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int)(("MKL_Set_Num_Threads_Local", lib))
    return pardiso, set_threads


def _pardiso(A, orderings=None):
    return _Pardiso(A, orderings=orderings).solve


_FACTORISE = {"pardiso": _pardiso, "cvxopt": _cvxopt, "cholmod": _cholmod, "superlu": _superlu}
_PACKAGE = {"pardiso": "pypardiso", "cvxopt": "cvxopt", "cholmod": "sksparse-minimal"}


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
        missing runtime library, a pivot that is not positive) moves on to the next.
    orderings : dict, optional
        Where PARDISO keeps its METIS ordering for the next matrix of the same sparsity
        pattern (:attr:`FactorCache.orderings`); None computes it afresh.

    Returns
    -------
    solve : callable
        ``solve(b)`` returns ``x`` with the shape of ``b`` (a vector, or a matrix whose
        columns are right-hand sides).

    Raises
    ------
    ImportError
        If the named backend's package is not installed.
    """
    if backend != "auto" and backend not in BACKENDS:
        names = "', '".join(["auto", *BACKENDS])
        raise ValueError(f"backend must be one of '{names}', got {backend!r}")
    if backend != "auto":
        mod = BACKENDS[backend]
        if mod is not None and _load(mod) is None:
            raise ImportError(f"backend={backend!r} needs the package {_PACKAGE[backend]}")
        return _factorise(backend, A, orderings)
    for name in _auto_order(A.shape[0]):
        mod = BACKENDS[name]
        if mod is None or _load(mod) is None:
            continue
        try:
            return _factorise(name, A, orderings)
        except Exception:  # noqa: BLE001, S112 - a failing optional backend: try the next
            continue
    return _superlu(A)


def _factorise(name, A, orderings):
    return _FACTORISE[name](A, orderings=orderings) if name == "pardiso" else _FACTORISE[name](A)


def _auto_order(n):
    """Backend names in the order ``backend="auto"`` tries them for ``n`` unknowns."""
    order = list(BACKENDS)
    if n >= LARGE_SYSTEM and "pardiso" in order and "cvxopt" in order:
        i, j = order.index("cvxopt"), order.index("pardiso")
        if j > i:
            order.insert(i, order.pop(j))
    return order


def _fast_cholesky_available():
    return any(mod is not None and _load(mod) is not None for mod in BACKENDS.values())


def _amg(A):
    """One smoothed-aggregation V-cycle approximating ``A^{-1}`` (package pyamg).

    The settings were chosen by the wall time (setup plus conjugate gradients) of
    :func:`solve_integration` on two cores, on tetrahedral Kuhn grids of 64K and 250K
    vertices (rtol 1e-10, 12 entries per row of ``A``) and on the neighbour graph of
    100K points (15 neighbours, 93 entries per row, rtol 1e-6):

    ========================  ==================  ==================  =================
    settings                  64K tetrahedra      250K tetrahedra     100K-point graph
    ========================  ==================  ==================  =================
    earlier (energy, BSR)     0.35+2.28 s, 48 it  1.4+12.9 s, 69 it   7.5+9.0 s, 20 it
    these                     0.34+1.04 s, 46 it  1.3+5.6 s, 62 it    2.4+10.1 s, 23 it
    ========================  ==================  ==================  =================

    At 1M tetrahedral vertices: 7.1+29.1 s, 70 iterations, against 7.8+66.3 s, 78.

    * Symmetric Gauss-Seidel, two sweeps before and after, on every level. One sweep
      needed 1.5-2x the iterations, for 10-15% more time at 64K vertices and 0-5% less
      on the graph; Chebyshev (degree 3) needed 2.6x the iterations (179 at 250K
      vertices, near the default limit of 200); a W-cycle took 1.45x the time for the
      same iterations.
    * Every level in CSR format. pyamg builds the coarse operators in BSR format with
      1x1 blocks, where Gauss-Seidel took twice as long as on the finer CSR level five
      times their size: the conversion halves the cost of a V-cycle on meshes.
    * No improvement of the constant candidate vector (the null space of ``K``) by
      block Gauss-Seidel: without it, 2-8 fewer iterations and a shorter setup.
    * The tentative prolongator smoothed by energy minimisation when the rows of ``A``
      have at most :data:`AMG_DENSE_ROWS` entries on average (meshes: 18-23% fewer
      iterations and 30% less time than one Jacobi step), by one Jacobi step on denser
      rows (neighbour graphs: the energy minimisation took 5.3-5.8 s of setup at 100K
      points against 2.0-2.4 s, for 18 iterations against 23, 10% more time in all).
      Plain aggregation (no smoothing) needed 2.5x the iterations on meshes and 1.3x
      on the graph, where its cheaper setup did not make it faster.
    * Strength of connection with ``theta = 0`` and ``max_coarse = 500``. A threshold of
      0.05-0.1 built deeper and denser hierarchies (operator complexity 1.5 on meshes,
      4 on the graph, where the setup took a minute) that cost more than the iterations
      they saved; 0.25 left two levels and 3.7x the iterations. The coarsest level is
      solved by a dense pseudo-inverse: ``max_coarse = 5000`` made the 64K solve 13x
      slower.

    Parameters
    ----------
    A : sparse matrix of shape (n, n)
        Symmetric positive definite, with the constants close to its null space.

    Returns
    -------
    apply : callable
        ``apply(r)`` returns the V-cycle applied to ``r``: a symmetric positive definite
        operator (the smoothers are symmetric).
    """
    pyamg = _load("pyamg")
    A = sp.csr_matrix(A)
    dense = A.nnz / max(A.shape[0], 1) > AMG_DENSE_ROWS
    smoother = ("gauss_seidel", {"sweep": "symmetric", "iterations": 2})
    ml = pyamg.smoothed_aggregation_solver(
        A,
        symmetry="symmetric",
        strength="symmetric",
        smooth="jacobi" if dense else "energy",
        improve_candidates=None,
        presmoother=smoother,
        postsmoother=smoother,
        max_coarse=500,
    )
    for level in ml.levels:
        for name in ("A", "P", "R"):
            M = getattr(level, name, None)
            if M is not None and sp.issparse(M) and M.format != "csr":
                setattr(level, name, M.tocsr())
    return ml.aspreconditioner(cycle="V").matvec


class FactorCache:
    """The last factorisation or preconditioner of a solve, kept for the next one.

    One entry, keyed by the content of the matrix it factorises (so a changed matrix is
    never solved with a stale factor), and the last METIS ordering PARDISO computed,
    keyed by the sparsity pattern it orders (the integration matrix of a mesh has one
    pattern whatever the labels and parameters). A :class:`~ndboundary.Relaxer` owns one;
    nothing is kept between solves without it.

    Attributes
    ----------
    nbytes : int
        Memory the kept entry holds: the factor's entries where the backend reports them,
        else the resident memory its construction added (Linux), else 0.

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> from ndboundary.solvers import FactorCache, solve_integration
    >>> cache = FactorCache()
    >>> K = sp.csr_matrix([[1.0, -1.0], [-1.0, 1.0]])
    >>> S = sp.csr_matrix([[1.0, 0.0]])
    >>> phi, info = solve_integration(K, [1.0, 1.0], S, 1.0, [0.5, 0.0], cache=cache)
    >>> len(cache) == 1 and cache.nbytes >= 0
    True
    """

    def __init__(self):
        self._entry = None
        self.orderings = {}
        self.nbytes = 0

    def __len__(self):
        return int(self._entry is not None)

    def get(self, kind, A, build):
        """The cached value for ``(kind, A)``, or ``build(A)`` cached in its place."""
        key = _key(kind, A)
        entry = self._entry  # one (key, value) tuple: safe to read from any thread
        if entry is not None and entry[0] == key:
            return entry[1]
        self.clear(orderings=False)  # free the old one before building the new one
        before = _resident_bytes()
        value = build(A)
        self.nbytes = _factor_bytes(value, max(0, _resident_bytes() - before))
        self._entry = (key, value)
        return value

    def clear(self, orderings=True):
        """Free the kept factorisation (and, by default, the kept ordering)."""
        self._entry = None
        self.nbytes = 0
        if orderings:
            self.orderings.clear()


def _resident_bytes():
    """Resident memory of this process (Linux), else 0."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError, AttributeError):
        return 0


def _factor_bytes(solve, measured):
    """Bytes held by a factor's solve function: the factor's entries where known."""
    owner = getattr(solve, "__self__", None)
    if isinstance(owner, _Pardiso):
        return owner.factor_nnz * (owner._dtype().itemsize + 4)
    return measured


def _digest(tag, *arrays):
    """A content key of ``arrays`` (their sizes and bytes) and the hashable ``tag``."""
    h = hashlib.blake2b(digest_size=16)
    h.update(repr((tag, [a.size for a in arrays])).encode())
    for arr in arrays:
        h.update(np.ascontiguousarray(arr).view(np.uint8))
    return h.hexdigest()


def _key(kind, A):
    A = sp.csr_matrix(A)
    return _digest((kind, A.shape), A.indptr, A.indices, A.data)


def _cached(kind, A, build, cache):
    return build(A) if cache is None else cache.get(kind, A, build)


def _orderings_of(cache):
    return None if cache is None else cache.orderings


def _relres(A, x, b):
    nb = np.linalg.norm(b)
    return float(np.linalg.norm(A @ x - b) / nb) if nb > 0 else 0.0


def _cg(A, b, M, rtol, maxiter, x0=None):
    it = [0]

    def count(_):
        it[0] += 1

    with _one_blas_thread():
        x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=maxiter, M=M, callback=count)
    return x, it[0], info


# ----------------------------------------------------------------------------- heat


def solve_heat(mass, K, t, b, *, rtol=1e-10, maxiter=2000):
    """Solve ``(diag(mass) + t K) u = b`` by Jacobi-preconditioned conjugate gradients."""
    t0 = time.perf_counter()
    A = (sp.diags(mass) + t * K).tocsr()
    dinv = 1.0 / A.diagonal()
    P = spla.LinearOperator(A.shape, matvec=lambda r: dinv * r, dtype=np.float64)
    t1 = time.perf_counter()
    u, iters, info = _cg(A, b, P, rtol, maxiter)
    res = _relres(A, u, b)
    if info != 0 and res > 10 * rtol:
        with _one_blas_thread():
            u = factorize_spd(A)(b)
        res2 = _relres(A, u, b)
        return u, SolveInfo("cholesky", iters, res2, t1 - t0, time.perf_counter() - t1)
    return u, SolveInfo("cg-jacobi", iters, res, t1 - t0, time.perf_counter() - t1)


# ----------------------------------------------------------------------------- integration


def _is_sparse_rows(K):
    n = K.shape[0]
    return n <= SMALL_SYSTEM or K.nnz / max(n, 1) <= DENSE_ROW_THRESHOLD


def _refined_single(Q, rhs, rtol, cache):
    """Solve ``Q phi = rhs`` by conjugate gradients preconditioned with a single-precision
    PARDISO factor of ``Q``; None when that factorisation fails or the iteration does not
    reach ``rtol`` within :data:`SINGLE_REFINE_MAXITER` iterations."""
    t0 = time.perf_counter()
    try:
        with _one_blas_thread():
            solve = _cached(("direct", "pardiso-single"), Q, lambda A: _Pardiso(A, single=True, orderings=_orderings_of(cache)).solve, cache)
    except Exception:  # noqa: BLE001 - any failure of the optional path: factorise in double
        return None
    t1 = time.perf_counter()
    n = Q.shape[0]
    P = spla.LinearOperator((n, n), matvec=solve, dtype=np.float64)
    phi, iters, _ = _cg(Q, rhs, P, rtol, SINGLE_REFINE_MAXITER)
    res = _relres(Q, phi, rhs)
    if not res <= 10 * rtol:
        return None
    return phi, SolveInfo("cholesky-single+cg", iters, res, t1 - t0, time.perf_counter() - t1)


def _direct(Q, rhs, backend, cache, iters=0):
    t0 = time.perf_counter()
    with _one_blas_thread():
        solve = _cached(
            ("direct", backend), Q, lambda A: factorize_spd(A, backend=backend, orderings=_orderings_of(cache)), cache
        )
        t1 = time.perf_counter()
        phi = solve(rhs)
    t2 = time.perf_counter()
    return phi, SolveInfo("cholesky", iters, _relres(Q, phi, rhs), t1 - t0, t2 - t1)


def solve_integration(
    K,
    mass,
    S,
    lam,
    rhs,
    *,
    mu=0.0,
    rtol=1e-10,
    maxiter=200,
    method="auto",
    backend="auto",
    preconditioner="auto",
    cache=None,
):
    """Solve ``(K M^{-1} K + mu K + lam S^T S) phi = rhs``.

    Parameters
    ----------
    K : sparse matrix of shape (n, n)
    mass : ndarray of shape (n,)
    S : sparse matrix of shape (m, n)
    lam : float
    rhs : ndarray of shape (n,)
    mu : float, default=0
    rtol : float, default=1e-10
        Relative residual to reach.
    maxiter : int, default=200
        Iterations allowed to conjugate gradients.
    method : {"auto", "pcg", "direct"}, default="auto"
        ``"direct"``: Cholesky factorisation of the whole matrix. ``"pcg"``: conjugate
        gradients preconditioned by ``(K + D) M^{-1} (K + D)``; warns if it does not
        converge in ``maxiter`` iterations. ``"auto"``: direct on meshes with sparse rows
        (about 7 entries per row of ``K``: triangles, surfaces) or small systems (from
        :data:`SINGLE_PRECISION_MIN` unknowns with PARDISO, a single-precision factor
        refined by conjugate gradients to ``rtol``: method ``"cholesky-single+cg"``), pcg
        elsewhere (tetrahedra, higher dimensions, graphs), falling back to direct when
        pcg does not converge (up to :data:`DIRECT_FALLBACK_MAX` unknowns; beyond, pcg
        goes on for ``4 maxiter`` more iterations and warns if that is not enough).
    backend : {"auto", "pardiso", "cvxopt", "cholmod", "superlu"}, default="auto"
        Sparse Cholesky used by the direct solve and the factorised preconditioner
        (see :func:`factorize_spd`). With ``"auto"`` and none of the optional backends
        installed, a direct solve of more than :data:`SMALL_SYSTEM` unknowns warns
        once per process (:class:`SolverFallbackWarning`).
    preconditioner : {"auto", "amg", "cholesky"}, default="auto"
        How pcg applies ``(K + D)^{-1}``: one AMG V-cycle (package ``pyamg``) or a
        sparse Cholesky factor. ``"auto"``: amg on meshes with denser rows when pyamg
        is installed, cholesky otherwise.
    cache : FactorCache, optional
        Where to keep the factorisation / AMG hierarchy for the next solve of the same
        matrix (compared by content) and PARDISO's ordering for the same pattern. None
        keeps nothing.

    Returns
    -------
    phi : ndarray of shape (n,)
    info : SolveInfo
        ``method`` is ``"cholesky"``, ``"cholesky-single+cg"`` or ``"pcg-amg"`` /
        ``"pcg-cholesky"``.
    """
    if method not in ("auto", "pcg", "direct"):
        raise ValueError(f"method must be 'auto', 'pcg' or 'direct', got {method!r}")
    if preconditioner not in ("auto", "amg", "cholesky"):
        raise ValueError(
            f"preconditioner must be 'auto', 'amg' or 'cholesky', got {preconditioner!r}"
        )
    K = sp.csr_matrix(K)
    mass = np.asarray(mass, dtype=np.float64)
    S = sp.csr_matrix(S)
    rhs = np.asarray(rhs, dtype=np.float64)

    def assemble():
        Q = (K @ sp.diags(1.0 / mass) @ K + mu * K + lam * (S.T @ S)).tocsr()
        return ((Q + Q.T) * 0.5).tocsr()

    sparse_rows = _is_sparse_rows(K)
    if method == "direct" or (method == "auto" and sparse_rows):
        if backend == "auto" and K.shape[0] > SMALL_SYSTEM and not _fast_cholesky_available():
            _fallback_warning("cholesky")
        t0 = time.perf_counter()
        Q = assemble()
        single = None
        if (
            method == "auto"
            and backend in ("auto", "pardiso")
            and Q.shape[0] >= SINGLE_PRECISION_MIN
            and _load("pypardiso") is not None
        ):
            single = _refined_single(Q, rhs, rtol, cache)
        phi, info = single if single is not None else _direct(Q, rhs, backend, cache)
        info.setup_time = time.perf_counter() - t0 - info.solve_time  # with the assembly
        return phi, info

    # (K + D) M^{-1} (K + D), D = mu/2 M + C, C M^{-1} C = lam diag(S^T S): mu K and the
    # constraint's diagonal are matched exactly, the squared Laplacian exactly off it.
    t0 = time.perf_counter()
    sts = np.asarray(abs(S).T @ abs(S) @ np.ones(S.shape[1])).ravel()
    d = 0.5 * mu * mass + np.sqrt(lam * sts * mass)
    A = (K + sp.diags(d)).tocsr()
    if preconditioner == "auto":
        use_amg = not sparse_rows
        if use_amg and _load("pyamg") is None:
            _fallback_warning("pyamg")
            use_amg = False
    elif preconditioner == "amg":
        if _load("pyamg") is None:
            raise ImportError("preconditioner='amg' needs the package pyamg")
        use_amg = True
    else:
        use_amg = False
    name = "pcg-amg" if use_amg else "pcg-cholesky"
    with _one_blas_thread():
        if use_amg:
            solve = _cached("amg", A, _amg, cache)
        else:
            solve = _cached(
                ("factor", backend), A, lambda B: factorize_spd(B, backend=backend, orderings=_orderings_of(cache)), cache
            )

    def apply(r):
        return solve(mass * solve(r))

    # Q applied as K M^{-1} K + mu K + lam S^T S, never assembled: two products with K
    # cost less than one with Q (2-ring stencil), and the sparse product is skipped.
    minv = 1.0 / mass
    St = S.T.tocsr()

    def qmul(x):
        Kx = K @ x
        return K @ (minv * Kx) + mu * Kx + lam * (St @ (S @ x))

    n = K.shape[0]
    Q = spla.LinearOperator((n, n), matvec=qmul, dtype=np.float64)
    P = spla.LinearOperator((n, n), matvec=apply, dtype=np.float64)
    t1 = time.perf_counter()
    phi, iters, info = _cg(Q, rhs, P, rtol, maxiter)
    res = _relres(Q, phi, rhs)
    t2 = time.perf_counter()
    if info != 0 and res > 10 * rtol:
        if method == "pcg":
            warnings.warn(
                f"integration solve did not converge in {iters} iterations "
                f"(relative residual {res:.2e}, target {rtol:.0e})",
                RuntimeWarning,
                stacklevel=2,
            )
            return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)
        if sparse_rows or n <= DIRECT_FALLBACK_MAX:
            phi, info2 = _direct(assemble(), rhs, backend, cache, iters)
            info2.setup_time += t2 - t0
            return phi, info2
        # too large to factorise: iterate on from where conjugate gradients stopped
        phi, more, _ = _cg(Q, rhs, P, rtol, 4 * maxiter, x0=phi)
        iters += more
        res = _relres(Q, phi, rhs)
        t2 = time.perf_counter()
        if res > 10 * rtol:
            warnings.warn(
                f"integration solve did not converge in {iters} iterations (relative residual "
                f"{res:.2e}, target {rtol:.0e}); {n} unknowns with {K.nnz / n:.0f} entries per "
                "row are too many to factorise instead",
                RuntimeWarning,
                stacklevel=2,
            )
    return phi, SolveInfo(name, iters, res, t1 - t0, t2 - t1)
