"""Solvers of the heat and integration systems: every method against a dense solve,
the pure-scipy fallback when the optional packages are missing, non-convergence."""

import sys
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import solvers
from ndboundary.datasets import ball, circle, kuhn_grid, label_by


def _system(n, dim):
    dom = kuhn_grid(n, dim, jitter=0.25, random_state=0)
    lab = label_by(dom, ball if dim == 3 else circle).astype(np.float64)
    # element labels: one constraint row (a single 1) per vertex touching both regions
    inc = sp.csr_matrix(dom.incidence)
    zeta = np.flatnonzero(((inc @ lab) > 0) & ((inc @ (1 - lab)) > 0))
    S = sp.csr_matrix(
        (np.ones(zeta.size), (np.arange(zeta.size), zeta)), shape=(zeta.size, dom.n_vertices)
    )
    h = dom.mean_edge_length()
    K = (dom.K * h ** (2 - dim)).tocsr()
    mass = dom.mass / h**dim
    return K, mass, S


@pytest.fixture(scope="module", params=[(12, 2), (6, 3)], ids=["2d", "3d"])
def system(request):
    K, mass, S = _system(*request.param)
    lam, mu = 2.0, 0.03
    Q = (K @ sp.diags(1 / mass) @ K + mu * K + lam * (S.T @ S)).toarray()
    rng = np.random.default_rng(0)
    rhs = rng.standard_normal(K.shape[0])
    exact = np.linalg.solve(Q, rhs)
    return K, mass, S, lam, mu, rhs, exact


@pytest.fixture(autouse=True)
def _fresh():
    solvers.clear_cache()
    saved = set(solvers._warned)
    yield
    solvers.clear_cache()
    solvers._warned.clear()
    solvers._warned.update(saved)


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


COMBOS = [
    {"method": "auto"},
    {"method": "direct", "backend": "superlu"},
    {"method": "direct", "backend": "cholmod"},
    {"method": "pcg", "preconditioner": "cholesky", "backend": "superlu"},
    {"method": "pcg", "preconditioner": "cholesky", "backend": "cholmod"},
    {"method": "pcg", "preconditioner": "amg"},
]


@pytest.mark.parametrize("kw", COMBOS, ids=lambda kw: "-".join(kw.values()))
def test_integration_matches_dense(system, kw):
    K, mass, S, lam, mu, rhs, exact = system
    if kw.get("backend") == "cholmod" and "cholmod" not in solvers.available_backends():
        pytest.skip("sksparse-minimal not installed")
    if kw.get("preconditioner") == "amg" and "amg" not in solvers.available_backends():
        pytest.skip("pyamg not installed")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, **kw)
    assert _rel(phi, exact) < 1e-8
    assert info.residual < 1e-9
    assert info.method in ("cholesky", "pcg-amg", "pcg-cholesky")


def test_auto_picks_by_row_density(monkeypatch):
    K2, m2, S2 = _system(12, 2)
    K3, m3, S3 = _system(6, 3)
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    _, info2 = solvers.solve_integration(K2, m2, S2, 2.0, np.ones(K2.shape[0]), mu=0.03)
    _, info3 = solvers.solve_integration(K3, m3, S3, 2.0, np.ones(K3.shape[0]), mu=0.03)
    assert info2.method == "cholesky"
    expected = "pcg-amg" if "amg" in solvers.available_backends() else "pcg-cholesky"
    assert info3.method == expected


def test_fallback_without_optional_packages(system, monkeypatch):
    K, mass, S, lam, mu, rhs, exact = system
    # the packages "missing": importing them raises ImportError
    monkeypatch.setitem(sys.modules, "sksparse_minimal", None)
    monkeypatch.setitem(sys.modules, "pyamg", None)
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    solvers._warned.clear()
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        phi, _info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu)
        phi2, _ = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu)
    rec = [w for w in rec if issubclass(w.category, solvers.SolverFallbackWarning)]
    if K.nnz / K.shape[0] > solvers.DENSE_ROW_THRESHOLD:  # 3-D: pyamg's absence costs time
        assert len(rec) == 1  # one line, once per process
        assert "slower" in str(rec[0].message) and "pyamg" in str(rec[0].message)
    else:  # triangles: SuperLU is the same direct solve, no warning
        assert not rec
    assert _rel(phi, exact) < 1e-8 and _rel(phi2, exact) < 1e-8
    assert solvers.available_backends() == ["superlu"]
    with pytest.raises(ImportError):
        solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="pcg", preconditioner="amg")
    with pytest.raises(ImportError):
        solvers.factorize_spd(sp.identity(3, format="csc"), backend="cholmod")


def test_nonconvergence_warns_with_residual(system):
    K, mass, S, lam, mu, rhs, _exact = system
    with pytest.warns(
        RuntimeWarning, match=r"did not converge in 2 iterations \(relative residual"
    ):
        _phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="pcg", maxiter=2)
    assert info.iterations == 2 and info.residual > 1e-9


def test_auto_falls_back_to_direct_when_pcg_stalls(system, monkeypatch):
    K, mass, S, lam, mu, rhs, exact = system
    monkeypatch.setattr(solvers, "SMALL_SYSTEM", 0)
    monkeypatch.setattr(solvers, "DENSE_ROW_THRESHOLD", 0.0)  # force the pcg path
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        phi, info = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, maxiter=2)
    assert info.method == "cholesky" and info.iterations == 2
    assert _rel(phi, exact) < 1e-8


def test_cache_reuses_and_is_correct(system):
    K, mass, S, lam, mu, rhs, exact = system
    _phi1, _ = solvers.solve_integration(K, mass, S, lam, rhs, mu=mu, method="direct")
    assert "entry" in solvers._cache
    phi2, _info = solvers.solve_integration(K, mass, S, lam, 2 * rhs, mu=mu, method="direct")
    assert _rel(phi2, 2 * exact) < 1e-8
    # a different matrix must not hit the cache
    phi3, _ = solvers.solve_integration(K, mass, S, 2 * lam, rhs, mu=mu, method="direct")
    Q3 = (K @ sp.diags(1 / mass) @ K + mu * K + 2 * lam * (S.T @ S)).toarray()
    assert _rel(phi3, np.linalg.solve(Q3, rhs)) < 1e-8
    solvers.clear_cache()
    assert not solvers._cache


def test_heat_matches_dense(system):
    K, mass, *_ = system
    b = np.random.default_rng(1).random(K.shape[0])
    u, info = solvers.solve_heat(mass, K, 1.0, b)
    A = (sp.diags(mass) + K).toarray()
    assert _rel(u, np.linalg.solve(A, b)) < 1e-8
    assert info.method == "cg-jacobi"


def test_factorize_spd_backends():
    A = sp.random(40, 40, density=0.1, random_state=0)
    A = (A @ A.T + 40 * sp.identity(40)).tocsc()
    b = np.arange(40.0)
    for backend in ["superlu"] + (["cholmod"] if "cholmod" in solvers.available_backends() else []):
        x = solvers.factorize_spd(A, backend=backend)(b)
        assert _rel(x, np.linalg.solve(A.toarray(), b)) < 1e-10
    with pytest.raises(ValueError):
        solvers.factorize_spd(A, backend="nope")
