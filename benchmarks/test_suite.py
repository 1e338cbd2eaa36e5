"""How long ``make test`` takes, step by step, with a cold and a warm JAX compilation cache.

    python benchmarks/test_suite.py            # cold (an empty .jax_cache, the old one replaced) then warm;
                                               # writes benchmarks/results/tests.json
    python benchmarks/test_suite.py --warm     # only warm (reuses .jax_cache)

Each step of ``make test`` (lint, the unit tests with the site rendering beside them, nbval on
the notebooks) runs as the Makefile runs it, with the Makefile's environment, timed on the wall
clock and in CPU seconds of its children; the machine's 1-minute load average is sampled every
10 s (a shared machine's wall times are not the project's figures: the load says how much the run
was shared). The slowest tests come from pytest's ``--durations``; each pytest step also records
the seconds spent per file, read from its JUnit XML (``--dist loadfile`` keeps a file in one
process, so the largest files bound how well the workers share the run), and the unit-test step
the seconds its pytest processes spent compiling, tracing and lowering JAX programs per file
(benchmarks/_compile_profile.py: where a cold cache's time goes). Nothing under version
control is written but the results file (each step's output goes to
``build/test_suite_<step>.log``).
"""

from __future__ import annotations

import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _bench  # noqa: E402

ROOT = _bench.ROOT
BIN = ROOT / ".venv" / "bin"
PARALLEL = ["-n", os.environ.get("PYTEST_WORKERS", "3"), "--dist", "loadfile", "--no-loadscope-reorder"]
STEPS = {
    "lint": [
        [str(BIN / "ruff"), "check", "pkmlib", "tests", "benchmarks", "scripts"],
        [str(BIN / "ruff"), "format", "--check", "pkmlib", "tests", "benchmarks", "scripts"],
    ],
    # the site renders beside the unit tests, as the Makefile runs them (scripts/tests_beside_render.sh)
    # with the JAX profile of each test file (benchmarks/_compile_profile.py)
    "render_and_unit_tests": [
        [
            "bash",
            "scripts/tests_beside_render.sh",
            *PARALLEL,
            "-p",
            "benchmarks._compile_profile",
            "--durations=25",
            "-q",
            "tests",
        ]
    ],
    "nbval": [
        [
            str(BIN / "python"),
            "-m",
            "pytest",
            "--nbval",
            "--nbval-current-env",
            *PARALLEL,
            "--durations=10",
            "-q",
            "notebooks",
        ]
    ],
}


def per_file(junit: Path) -> list[dict]:
    """Seconds and test count per test file (or notebook) in a pytest JUnit XML file, largest first."""
    totals: dict[str, list] = {}
    for case in ET.parse(junit).iter("testcase"):
        name = case.get("file") or case.get("classname", "?")
        t = totals.setdefault(name, [0.0, 0])
        t[0] += float(case.get("time", 0.0))
        t[1] += 1
    rows = [{"file": k, "s": round(v[0], 1), "tests": v[1]} for k, v in totals.items()]
    return sorted(rows, key=lambda r: -r["s"])


def profile_per_file(folder: Path) -> dict:
    """The profile of the pytest processes (one JSON file each in ``folder``, written by
    benchmarks/_compile_profile.py): CPU seconds of the process and of the processes its tests
    waited for, seconds of XLA compilation, tracing, lowering and cache loads and the number of
    programs compiled or loaded from the cache, in all and per test file (most CPU first)."""
    rows: dict = {}
    for f in folder.glob("*.json"):
        for name, row in json.loads(f.read_text()).items():
            into = rows.setdefault(name, {})
            for k, v in row.items():
                into[k] = into.get(k, 0.0) + v
    keys = ("cpu_s", "children_cpu_s", "compile_s", "programs", "trace_s", "lower_s", "cache_load_s")
    total = {k: round(sum(r.get(k, 0.0) for r in rows.values()), 1) for k in keys}
    files = [{"file": name, **{k: round(r.get(k, 0.0), 1) for k in keys}} for name, r in rows.items()]
    for row in (total, *files):
        row["programs"] = int(row["programs"])
    return {"total": total, "per_file": sorted(files, key=lambda r: -(r["cpu_s"] + r["children_cpu_s"]))}


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_steps(cache: Path) -> dict:
    env = {
        **os.environ,
        "JAX_PLATFORMS": "cpu",
        "JAX_COMPILATION_CACHE_DIR": str(cache),
        "JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS": "0",
        "JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES": "0",
        "XLA_FLAGS": "--xla_cpu_max_isa=AVX2 --xla_cpu_multi_thread_eigen=false",
        "OPENBLAS_CORETYPE": "Haswell",
        "OPENBLAS_NUM_THREADS": "1",
    }
    out: dict = {"steps": {}}
    loads: list[float] = []
    stop = threading.Event()

    def sample():
        while not stop.is_set():
            loads.append(_bench.load_1min())
            stop.wait(10)

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    t_all = time.perf_counter()
    for name, commands in STEPS.items():
        t0, c0 = time.perf_counter(), _children_cpu()
        text, rc = "", 0
        junit = ROOT / "build" / f"test_suite_{name}.xml"
        junit.unlink(missing_ok=True)
        profile = Path(tempfile.mkdtemp(prefix="pkmlib-jax-profile-"))
        # benchmarks._compile_profile importable, the caller's PYTHONPATH kept after it
        path = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
        step_env = {**env, "PKMLIB_COMPILE_PROFILE_DIR": str(profile), "PYTHONPATH": path}
        for cmd in commands:
            if "pytest" in cmd or "scripts/tests_beside_render.sh" in cmd:
                cmd = [*cmd, f"--junitxml={junit}", "-o", "junit_family=xunit1"]
            r = subprocess.run(cmd, cwd=ROOT, env=step_env, capture_output=True, text=True)
            text += r.stdout + r.stderr
            rc = rc or r.returncode
        log = ROOT / "build" / f"test_suite_{name}.log"
        log.parent.mkdir(exist_ok=True)
        log.write_text(text)
        step = {"wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(_children_cpu() - c0, 1), "rc": rc}
        m = re.search(r"^=* ?(\d+ (?:passed|failed|error).*?) in [\d.]+s", text, flags=re.M)
        if m:
            step["summary"] = m.group(1)
        slow = re.findall(r"^([\d.]+)s (call|setup|teardown)\s+(\S+)", text, flags=re.M)
        if slow:
            step["slowest"] = [{"s": float(s), "when": w, "test": t} for s, w, t in slow]
        if junit.exists():
            step["per_file"] = per_file(junit)
        if any(profile.glob("*.json")):
            step["pytest_processes"] = profile_per_file(profile)
        shutil.rmtree(profile, ignore_errors=True)
        out["steps"][name] = step
        print(f"{name}: {step['wall_s']} s wall, {step['cpu_s']} CPU-s, rc {rc}", flush=True)
    stop.set()
    out["wall_s"] = round(time.perf_counter() - t_all, 1)
    out["cpu_s"] = round(sum(s["cpu_s"] for s in out["steps"].values()), 1)
    out["load_1min"] = {"min": min(loads), "max": max(loads), "mean": round(sum(loads) / len(loads), 2)}
    return out


def main() -> None:
    results: dict = {
        "what": "make test's steps as the Makefile runs them (lint; pytest tests with the site rendering beside it; "
        "pytest --nbval notebooks), "
        "timed by benchmarks/test_suite.py; cpu_s counts every child process",
        "target": {"cold_s": 300, "warm_s": 150},
        "machine": _bench.machine(),
    }
    cache = ROOT / ".jax_cache"
    if "--warm" not in sys.argv:
        # cold: an empty cache at the path the warm run reads. JAX's cache keys depend on the cache's
        # path (a program compiled with the cache in one folder is not found in a copy elsewhere), so a
        # cold run in a temporary folder copied over .jax_cache left the warm run compiling anew.
        # The cache there before is kept aside and given back if the cold run fails.
        with tempfile.TemporaryDirectory(prefix="pkmlib-jax-cache-before-", dir=ROOT) as aside:
            kept = Path(aside) / "jax_cache"
            if cache.exists():
                cache.rename(kept)
            try:
                results["cold_cache"] = run_steps(cache)
            except BaseException:
                shutil.rmtree(cache, ignore_errors=True)
                if kept.exists():
                    kept.rename(cache)
                raise
    results["warm_cache"] = run_steps(cache)
    record(results, _bench.RESULTS / "tests.json")


def record(results: dict, path: Path) -> None:
    """Write ``results`` to ``path`` (atomically). If any step failed, say which and leave
    ``path`` as it was (``SystemExit(1)``): a failed run does not replace the timing on record."""
    failed = [
        f"{run}: {name} (rc {step['rc']}, log build/test_suite_{name}.log)"
        for run in ("cold_cache", "warm_cache")
        for name, step in results.get(run, {}).get("steps", {}).items()
        if step["rc"] != 0
    ]
    if failed:
        print(f"failed, {path.name} left as it was: " + "; ".join(failed), file=sys.stderr)
        raise SystemExit(1)
    _bench.write_results(path, results)
    print(f"wrote {path.name}")


if __name__ == "__main__":
    main()
