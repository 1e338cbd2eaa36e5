"""Test configuration: float64, strict dtype and rank promotion (here and, through the
environment, in every Python process a test starts: benchmark smoke runs, sharded sweeps,
re-run kernels), and shared helpers. Warnings from pkmlib are errors (pyproject.toml)."""

import json
import os
from pathlib import Path

os.environ.setdefault("JAX_PLATFORMS", "cpu")

#: The unit tests compile with LLVM's optimisations off and with XLA:CPU's older elemental emitters
#: instead of its MLIR fusion emitters (here and in every process they start): XLA's compilation is
#: most of their CPU time, and most of it a fixed cost per program (eager operations each compile
#: one). ``-O0`` cut a cold-cache unit step by a third (783 s -> 544 s for pytest, 2 cores); the older
#: emitters halve each compilation again (an eager operation 38 -> 21 ms, a small jitted solve 428 ->
#: 218 ms at -O0; the unit step 794 s -> 518 s on a slower machine of the same kind). Warm, tracing
#: and lowering are what remain: wrapping a test's eager calls in one ``jit`` made it slower (its
#: trace is paid in every process, the eager operations' programs are cached). Nothing is timed in
#: them, and their numbers equal the optimised ones to rounding:
#: a comparison with a result stored by ``make report`` (compiled as users compile, ``Makefile``'s
#: ``XLA_FLAGS``) allows for the last bits. The notebooks (nbval), ``make report`` and
#: ``make benchmark`` compile with XLA's defaults; JAX's compilation cache keys hash ``XLA_FLAGS``,
#: so the two kinds of program never mix.
TEST_XLA_FLAGS = ("--xla_backend_optimization_level=0", "--xla_cpu_use_fusion_emitters=false")
for _flag in TEST_XLA_FLAGS:
    if _flag not in os.environ.get("XLA_FLAGS", "").split():
        os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " " + _flag).strip()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
jax.config.update("jax_numpy_dtype_promotion", "strict")

#: JAX's strict modes as environment variables, read by JAX in the processes tests start.
STRICT_ENV = {"JAX_ENABLE_X64": "1", "JAX_NUMPY_RANK_PROMOTION": "raise", "JAX_NUMPY_DTYPE_PROMOTION": "strict"}

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import pkmlib as pk  # noqa: E402
from pkmlib.mechanisms import gripper_4prr as m  # noqa: E402


@pytest.fixture(autouse=True)
def _strict_subprocesses(request, monkeypatch):
    """Processes started by a test (``subprocess``, papermill kernels) run as strictly as this one.
    Not for nbval's notebook cells: their kernel runs the notebooks as a reader would."""
    if isinstance(request.node, pytest.Function):
        for k, v in STRICT_ENV.items():
            monkeypatch.setenv(k, v)


def assert_close(actual, desired, rtol=1e-9, atol=0.0, err_msg=""):
    """``np.testing.assert_allclose`` that also fails on any NaN or inf in either argument."""
    actual = np.asarray(actual, dtype=np.float64)
    desired = np.asarray(desired, dtype=np.float64)
    assert np.all(np.isfinite(actual)), f"non-finite values in actual: {actual} {err_msg}"
    assert np.all(np.isfinite(desired)), f"non-finite values in desired: {desired} {err_msg}"
    np.testing.assert_allclose(actual, desired, rtol=rtol, atol=atol, err_msg=err_msg)


def central_difference(f, z, h=1e-6):
    """Jacobian of ``f`` at ``z`` by central differences with step ``h``, shape ``(len(f), len(z))``:
    the independent check of every autodiff Jacobian."""
    z = np.asarray(z, dtype=np.float64)
    cols = []
    for j in range(len(z)):
        dz = np.zeros_like(z)
        dz[j] = h
        cols.append((np.asarray(f(z + dz)) - np.asarray(f(z - dz))) / (2 * h))
    return np.stack(cols, axis=1)


def central_difference_batched(f, z, h=1e-6):
    """:func:`central_difference` of a JAX-traceable ``f`` (one vector in, an array out): the
    ``2 len(z)`` shifted points are evaluated in one ``jit(vmap(f))`` call, one compilation and no
    Python loop, instead of ``2 len(z)`` eager calls. Same shape ``(len(f), len(z))``."""
    z = np.asarray(z, dtype=np.float64)
    steps = h * np.eye(len(z))
    values = np.asarray(jax.jit(jax.vmap(lambda v: jax.numpy.atleast_1d(f(v))))(np.concatenate([z + steps, z - steps])))
    return ((values[: len(z)] - values[len(z) :]) / (2 * h)).T


def jvp_and_central_difference(f, z, directions, h):
    """``f``'s forward-mode derivative (``jax.jvp``) at ``z`` along each row ``v`` of
    ``directions`` ``(n, len(z))``, and the central differences ``(f(z + h v) - f(z - h v)) / 2h``
    along the same rows, ``h`` a scalar or one step per row: ``(J v, fd)``, each ``(n, len(f))``.
    All ``3 n`` evaluations (``n`` JVPs at ``z``, ``2 n`` shifted values) are one ``jit(vmap)``
    program: one compilation, instead of a full ``jax.jacrev`` plus an eager ``f``, for an ``f``
    slow to compile (the Lagrange dynamics: a ``jacrev`` of its forces compiles in 25 s, this in 18)."""
    z = np.asarray(z, dtype=np.float64)
    v = np.asarray(directions, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != z.shape[0]:
        raise ValueError(f"directions must be (n, {z.shape[0]}), got {v.shape}")
    h = np.asarray(h, dtype=np.float64)
    if h.shape not in ((), (v.shape[0],)):
        raise ValueError(f"h must be a scalar or ({v.shape[0]},), got {h.shape}")
    h = np.broadcast_to(h, (v.shape[0],))[:, None]
    primals = np.concatenate([np.broadcast_to(z, v.shape), z + h * v, z - h * v])
    values, derivatives = jax.jit(jax.vmap(lambda x, t: jax.jvp(f, (x,), (t,))))(primals, np.concatenate([v, v, v]))
    n = v.shape[0]
    values = np.asarray(values)
    return np.asarray(derivatives[:n]), (values[n : 2 * n] - values[2 * n :]) / (2 * h)


@pytest.fixture(scope="session")
def p1_params():
    return m.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])


@pytest.fixture(scope="session")
def p1_poses(p1_params):
    """Random poses inside P1's workspace (varied phi and s), away from the singular lines."""
    rng = np.random.default_rng(0)
    poses = []
    while len(poses) < 20:
        x = np.array(
            [rng.uniform(0.35, 1.0), rng.uniform(-0.12, 0.1), np.deg2rad(rng.uniform(5, 35)), rng.uniform(0.08, 0.2)]
        )
        q = np.asarray(m.mechanism.inverse(x, p1_params))
        up, lo = m.type2_lines_y(x[2], x[3], p1_params)
        if np.all(np.isfinite(q)) and min(abs(x[1] - up), abs(x[1] - lo)) > 5e-3:
            poses.append(x)
    return np.array(poses)


@pytest.fixture(scope="session")
def p1_pose_batch(p1_params, p1_poses):
    """:func:`p1_poses` as one batch ``(4, N)`` (pkmlib's batch axes on the right) and its q, for
    the tests that check every pose in one call."""
    x = jax.numpy.asarray(p1_poses.T)
    return x, m.mechanism.inverse(x, p1_params)


#: What `make test` last measured per test file (benchmarks/test_suite.py writes it): the order
#: the files start in.
_ROOT = Path(__file__).resolve().parents[1]
_MEASURED = _ROOT / "benchmarks" / "results" / "tests.json"


def _measured_seconds() -> dict:
    """Seconds per test file (``tests/test_x.py``), the cold and the warm run of tests.json added;
    {} without the file."""
    try:
        record = json.loads(_MEASURED.read_text())
    except (OSError, ValueError):
        return {}
    seconds: dict = {}
    for run in ("cold_cache", "warm_cache"):
        for row in record.get(run, {}).get("steps", {}).get("render_and_unit_tests", {}).get("per_file", []):
            seconds[row["file"]] = seconds.get(row["file"], 0.0) + float(row["s"])
    return seconds


def pytest_collection_modifyitems(session, config, items):
    """The longest test files first, as `make test` last measured them, so that no long file starts
    last while the other processes have finished (`--dist loadfile --no-loadscope-reorder`: each
    file runs whole in one process, the files in this order). The sort is stable: a file not
    measured yet runs after them, each file's tests stay together and in the file's own order."""
    seconds = _measured_seconds()
    items.sort(key=lambda item: -seconds.get(item.path.relative_to(_ROOT).as_posix(), 0.0))
