"""The kernels built at install: every one is there, a first run compiles none of them, and
the built code computes what numba's own compilation of the same source computes, bit for bit."""

import importlib
import json
import os
import shutil
import sysconfig
import textwrap

import numpy as np
import pytest
from _background import BackgroundRun

from ndboundary import _kernels
from ndboundary.datasets import kuhn_grid


def _why_not_built():
    if os.environ.get("NDBOUNDARY_NO_AOT", "") not in ("", "0"):
        return "the install was asked not to build the kernels"
    if os.environ.get("NDBOUNDARY_JIT", "") not in ("", "0"):
        return "NDBOUNDARY_JIT=1: the built kernels are not used"
    compiler = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if _kernels.aot_module() is None and shutil.which(compiler) is None:
        return f"no C compiler ({compiler}) to build the kernels at install"
    return None


pytestmark = pytest.mark.skipif(_why_not_built() is not None, reason=str(_why_not_built()))

# one of each kind of run: tetrahedra (AMG), triangles in the plane above the size where the
# compiled passes take over (Cholesky), a surface, and the OBJ, OFF and PLY readers and writers
WORKLOAD = textwrap.dedent(
    """
    import json, sys, tempfile, time, os
    import numpy as np
    from numba.core import event

    compiled = []

    class Compiles(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f.__module__ + "." + f.__qualname__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Compiles())
    from ndboundary import read_mesh, relax, write_mesh
    from ndboundary.datasets import icosphere, kuhn_grid, label_by

    out = {}
    tets = kuhn_grid(12, 3, jitter=0.25, random_state=0)
    out["tets"] = relax(tets, label_by(tets, lambda x: np.linalg.norm(x - 0.5, axis=1) - 0.3), on="elements").phi
    plane = kuhn_grid(320, 2, jitter=0.2, random_state=1)
    out["plane"] = relax(plane, label_by(plane, lambda x: np.linalg.norm(x - 0.5, axis=1) - 0.3), on="elements").phi
    sphere = icosphere(4)
    out["sphere"] = relax(sphere, label_by(sphere, lambda x: x[:, 2] - 0.2), on="elements").phi
    folder = tempfile.mkdtemp()
    for ext in ("obj", "off", "ply"):
        path = os.path.join(folder, "mesh." + ext)
        write_mesh(path, plane)
        back = read_mesh(path)
        out[ext] = np.concatenate([back.points.ravel(), back.simplices.ravel().astype(float)])
    ours = sorted({name for name in compiled if name.startswith("ndboundary")})
    np.savez(os.path.join(sys.argv[1], "out.npz"), **out)
    print(json.dumps(ours))
    """
)


def _result(run):
    folder = run.wait()
    return json.loads(run.stdout.strip().splitlines()[-1]), dict(np.load(folder / "out.npz"))


# started with the session, beside the other tests: the run without the built module
# compiles every kernel it reaches, which takes a minute
BACKGROUND = [] if _why_not_built() else [BackgroundRun(WORKLOAD), BackgroundRun(WORKLOAD, NDBOUNDARY_JIT="1")]


@pytest.fixture(scope="module")
def runs():
    return tuple(_result(run) for run in BACKGROUND)


def test_every_kernel_signature_is_built():
    module = _kernels.aot_module()
    assert module is not None, "the install did not build ndboundary._kernels_aot"
    for name in _kernels.KERNEL_MODULES:
        importlib.import_module(name)
    assert len(_kernels.REGISTRY) >= 30
    for k in _kernels.REGISTRY:
        for i in range(len(k.signatures)):
            assert hasattr(module, _kernels.export_name(k.module, k.name, i)), (k, i)


def test_the_module_knows_the_sources_it_was_built_from():
    recorded = _kernels.aot_module().built_from()
    paths = [part.split("=", 1)[0] for part in recorded.split(";")]
    assert {"ndboundary/_kernels.py", "ndboundary/_compiled_mesh.py", "ndboundary/io/text_numbers.py"} <= set(paths)
    assert _kernels.sources_digest(paths) == recorded


def test_a_module_built_from_other_sources_is_not_used(monkeypatch):
    class Stale:
        @staticmethod
        def built_from():
            return "ndboundary/_kernels.py=" + "0" * 64

    real = importlib.import_module
    monkeypatch.setattr(importlib, "import_module", lambda name: Stale if name.endswith("_kernels_aot") else real(name))
    _kernels.aot_module.cache_clear()
    try:
        with pytest.warns(RuntimeWarning, match="older than their source"):
            assert _kernels.aot_module() is None
    finally:
        monkeypatch.undo()
        _kernels.aot_module.cache_clear()
    assert _kernels.aot_module() is not None


@pytest.mark.background_run
def test_a_first_run_compiles_no_kernel_of_ours(runs):
    (built_compiled, _), (jit_compiled, _) = runs
    assert built_compiled == []
    # the same run without the built module compiles them: the workload reaches the kernels
    assert len(jit_compiled) >= 20, jit_compiled


@pytest.mark.background_run
def test_built_kernels_compute_what_numba_computes_bit_for_bit(runs):
    (_, built), (_, jit) = runs
    assert built.keys() == jit.keys()
    for key in built:
        assert np.isfinite(built[key]).all()
        np.testing.assert_array_equal(built[key], jit[key], err_msg=key)


def test_other_argument_types_fall_back_to_numba():
    from ndboundary._compiled_geometry import _longest

    tets = kuhn_grid(3, 3)
    points, simplices = np.ascontiguousarray(tets.points), np.ascontiguousarray(tets.simplices, dtype=np.int64)
    assert _longest.built(points, simplices, np.empty(len(simplices))) is not None
    narrow = simplices.astype(np.int32)  # not a built signature
    strided = np.asfortranarray(points)  # the signature asks for C order
    assert _longest.built(points, narrow, np.empty(len(simplices))) is None
    assert _longest.built(strided, simplices, np.empty(len(simplices))) is None
    expected, narrowed = np.empty(len(simplices)), np.empty(len(simplices))
    _longest(points, simplices, expected)
    _longest(points, narrow, narrowed)
    np.testing.assert_array_equal(expected, narrowed)
    assert expected.min() > 0


@pytest.mark.parametrize("weighted", [False, True])
def test_smoothing_in_blocks_on_threads_is_the_same_bit_for_bit(monkeypatch, weighted):
    from ndboundary import _compiled

    plane = kuhn_grid(60, 2, jitter=0.2, random_state=2)
    W = plane.adjacency.tocsr()
    if weighted:
        W.data = np.random.default_rng(0).uniform(0.5, 1.5, W.nnz)
    X = np.random.default_rng(1).normal(size=(W.shape[0], 3))
    one = _compiled.smooth_rows_compiled(W, X, 7, plus_identity=True)
    monkeypatch.setattr(_compiled, "MIN_ROWS_PER_THREAD", 50)
    monkeypatch.setattr(_compiled, "available_threads", lambda: 5)
    assert len(_compiled.row_blocks(W.indptr)) == 6
    np.testing.assert_array_equal(_compiled.smooth_rows_compiled(W, X, 7, plus_identity=True), one)
    np.testing.assert_allclose(np.linalg.norm(one, axis=1), 1.0)
