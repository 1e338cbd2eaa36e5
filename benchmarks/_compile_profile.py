"""A pytest plugin for ``benchmarks/test_suite.py``: where the test processes spend their time in
JAX, per test file. ``jax.monitoring`` reports each tracing, each lowering to StableHLO and each
XLA compilation or load from the persistent cache (one per program: a ``jit`` or an eager
operation on new shapes) with its duration; this plugin sums them per test file and writes one
JSON file per pytest process into ``$PKMLIB_COMPILE_PROFILE_DIR`` when the session ends.

    PYTHONPATH=. python -m pytest -p benchmarks._compile_profile ...   (from the repository root)

Only the pytest processes are seen: the Python processes that tests start (benchmark smoke
runs, re-runs and their kernels, sharded sweeps) compile unseen.
"""

from __future__ import annotations

import collections
import json
import os
from pathlib import Path

EVENTS = {
    "/jax/core/compile/backend_compile_duration": "compile",
    "/jax/core/compile/jaxpr_trace_duration": "trace",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
    "/jax/compilation_cache/cache_retrieval_time_sec": "cache_load",
}

_current = ["(outside tests)"]
_totals: dict = collections.defaultdict(lambda: collections.defaultdict(float))


def _listener(event: str, duration: float, **_kwargs) -> None:
    kind = EVENTS.get(event)
    if kind is None:
        return
    row = _totals[_current[0]]
    row[f"{kind}_s"] += duration
    if kind == "compile":
        row["programs"] += 1


def pytest_configure(config) -> None:
    # after the initial conftest (which sets JAX's modes): importing jax here changes nothing
    import jax.monitoring

    jax.monitoring.register_event_duration_secs_listener(_listener)


def pytest_runtest_logstart(nodeid, location) -> None:
    _current[0] = nodeid.split("::")[0]


def pytest_sessionfinish(session, exitstatus) -> None:
    out = os.environ.get("PKMLIB_COMPILE_PROFILE_DIR")
    if not out or not _totals:
        return
    rows = {k: {name: round(v, 3) for name, v in row.items()} for k, row in _totals.items()}
    path = Path(out) / f"{os.getpid()}.json"
    path.write_text(json.dumps(rows))
