"""A pytest plugin for ``benchmarks/test_suite.py``: where the test processes spend their time in
JAX and on the CPU, per test file. ``jax.monitoring`` reports each tracing, each lowering to StableHLO and each
XLA compilation or load from the persistent cache (one per program: a ``jit`` or an eager
operation on new shapes) with its duration; this plugin sums them per test file and writes one
JSON file per pytest process into ``$PKMLIB_COMPILE_PROFILE_DIR`` when the session ends.

    PYTHONPATH=. python -m pytest -p benchmarks._compile_profile ...   (from the repository root)

Only the pytest processes are seen: the Python processes that tests start (benchmark smoke
runs, re-runs and their kernels, sharded sweeps) compile unseen.

Each file's CPU seconds are counted too, from the start of its first test to the end of its last
teardown: ``cpu_s``, the pytest process's own (user + system), and ``children_cpu_s``, those of
the processes its tests started and waited for (benchmark smoke runs, re-runs, sharded sweeps;
``getrusage(RUSAGE_CHILDREN)``; a process shared by the session, such as the tests' one Chromium,
counts for the file whose teardown ends it, and one that a file left running counts for the
file during which it is reaped). JAX's durations are wall seconds, which grow when
the processes share the cores; CPU seconds much less: they say which files are expensive.

With ``PKMLIB_COMPILE_SOURCES=1`` it also counts, per program name (``add``, ``_compiled``...), the
innermost line of the repository (``pkmlib/`` or ``tests/``) that asked for each compilation,
read from JAX's compile log (``jax_log_compiles``, kept out of the tests' own logs), and writes
them as JSON into ``<pid>.sources`` beside the profile: where the eager operations that each
compile a program of their own come from.
"""

from __future__ import annotations

import collections
import json
import logging
import os
import re
import resource
import time
import traceback
from pathlib import Path

EVENTS = {
    "/jax/core/compile/backend_compile_duration": "compile",
    "/jax/core/compile/jaxpr_trace_duration": "trace",
    "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
    "/jax/compilation_cache/cache_retrieval_time_sec": "cache_load",
}

_current = ["(outside tests)"]
_totals: dict = collections.defaultdict(lambda: collections.defaultdict(float))
_sources: collections.Counter = collections.Counter()
_ROOT = str(Path(__file__).resolve().parents[1]) + os.sep
_COMPILING = re.compile(r"Compiling (?:jit\()?([^) ]*)")


class _SourceCounter(logging.Handler):
    """Counts each "Compiling ..." record of JAX's compile log by program name and by the innermost
    frame of the repository's own code (not of .venv/) on the stack."""

    def emit(self, record: logging.LogRecord) -> None:
        m = _COMPILING.match(record.getMessage())
        if m is None:
            return
        where = "(no repository frame)"
        for frame in reversed(traceback.extract_stack()[:-1]):
            f = frame.filename
            if f.startswith(_ROOT) and f"{os.sep}.venv{os.sep}" not in f:
                where = f"{f[len(_ROOT) :]}:{frame.lineno}"
                break
        _sources[f"{m.group(1)} {where}"] += 1


def _count_sources() -> None:
    import jax

    jax.config.update("jax_log_compiles", True)
    for name in ("jax._src.interpreters.pxla", "jax._src.dispatch", "jax._src.compiler"):
        log = logging.getLogger(name)
        log.propagate = False  # JAX's compile log stays out of the tests' captured logs
        log.addHandler(_SourceCounter() if name.endswith("pxla") else logging.NullHandler())


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
    if os.environ.get("PKMLIB_COMPILE_SOURCES") == "1":
        _count_sources()


def _cpu() -> tuple[float, float]:
    """CPU seconds (user + system) of this process and of its waited-for children."""
    c = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time(), c.ru_utime + c.ru_stime


_started = [_cpu()]


def pytest_runtest_logstart(nodeid, location) -> None:
    _current[0] = nodeid.split("::")[0]
    _started[0] = _cpu()


def pytest_runtest_logfinish(nodeid, location) -> None:
    (own0, children0), (own, children) = _started[0], _cpu()
    row = _totals[nodeid.split("::")[0]]
    row["cpu_s"] += own - own0
    row["children_cpu_s"] += children - children0


def pytest_sessionfinish(session, exitstatus) -> None:
    out = os.environ.get("PKMLIB_COMPILE_PROFILE_DIR")
    if not out or not _totals:
        return
    rows = {k: {name: round(v, 3) for name, v in row.items()} for k, row in _totals.items()}
    path = Path(out) / f"{os.getpid()}.json"
    path.write_text(json.dumps(rows))
    if _sources:
        (Path(out) / f"{os.getpid()}.sources").write_text(json.dumps(dict(_sources.most_common()), indent=0))
