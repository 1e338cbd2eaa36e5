"""Shared benchmark machinery: every case runs in its own subprocess (fresh JAX, fresh numba), so
its peak resident memory (``resource.getrusage(RUSAGE_SELF).ru_maxrss`` at the child's end) is its
own; times are the best of a few repeats after a first call that includes compilation.

A paper's script defines ``CASES = {name: make(size) -> (run, n_items, values)}`` and calls
:func:`main`. Run without arguments it is the parent: it runs each (case, size) in a child, checks
that every method gives the same values as the reference on the smallest size, and writes
``benchmarks/results/<paper>.json``. Figures are rates (items per second of wall time, and per CPU
second, which moves less when other jobs share the machine) and ratios between methods measured
in the same run; times on a shared 2-core machine vary by 2x between runs, ratios much less.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def machine() -> dict[str, Any]:
    """CPU model, cores, load and library versions of this run."""
    cpu = platform.processor()
    flags = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name") and cpu in ("", platform.processor()):
                cpu = line.split(":", 1)[1].strip()
            if line.startswith("flags") and not flags:
                flags = line
    except OSError:
        pass
    import jax
    import numpy as np

    info = {"cpu": cpu, "avx512f": "avx512f" in flags, "cores": os.cpu_count(),
            "load_average_1min_at_end": os.getloadavg()[0], "platform": platform.platform(),
            "python": platform.python_version(), "jax": jax.__version__, "numpy": np.__version__,
            "jax_devices": [str(d) for d in jax.devices()],
            # whether the persistent compilation cache was on (not its path: results stay machine-free)
            "jax_compilation_cache_dir": "set" if os.environ.get("JAX_COMPILATION_CACHE_DIR") else None}
    try:
        import numba

        info["numba"] = numba.__version__
    except ImportError:
        info["numba"] = None
    return info


def _child(cases: dict[str, Callable], case: str, size: int, repeats: int, save: str | None) -> None:
    make = cases[case]
    t0 = time.perf_counter()
    run, n_items, values = make(size)
    out = run()
    first = time.perf_counter() - t0
    best, best_cpu = float("inf"), float("inf")
    for _ in range(repeats):
        t, c = time.perf_counter(), time.process_time()
        out = run()
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
    if save:
        import numpy as np

        np.savez(save, **{k: np.asarray(v) for k, v in values(out).items()})
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB -> MiB on Linux
    print(json.dumps({"case": case, "size": size, "items": n_items, "first_call_s": first, "best_s": best,
                      "best_cpu_s": best_cpu, "items_per_s": n_items / best,
                      "items_per_cpu_s": n_items / max(best_cpu, 1e-9), "peak_rss_mib": rss}))


def run_case(script: str, case: str, size: int, repeats: int, save: str | None = None,
             env: dict | None = None) -> dict[str, Any]:
    """Run one case in a subprocess and return its measurements."""
    cmd = [sys.executable, script, "--case", case, "--size", str(size), "--repeats", str(repeats)]
    if save:
        cmd += ["--save", save]
    full_env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    full_env.update(env or {})
    res = subprocess.run(cmd, capture_output=True, text=True, env=full_env, timeout=900)
    if res.returncode != 0:
        raise RuntimeError(f"{case} size {size} failed:\n{res.stdout}\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def compare_saved(ref: str, other: str, rtol: float) -> dict[str, Any]:
    """Largest relative difference over finite values and the fraction of points whose NaN-ness
    differs (a pose on the workspace boundary can round either way)."""
    import numpy as np

    a, b = np.load(ref), np.load(other)
    worst, nan_mismatch = 0.0, 0.0
    for k in a.files:
        x, y = a[k], b[k]
        both = np.isfinite(x) & np.isfinite(y)
        nan_mismatch = max(nan_mismatch, float(np.mean(np.isnan(x) != np.isnan(y))))
        if both.any():
            scale = np.maximum(np.abs(x[both]), np.nanmax(np.abs(x[both])) * 1e-6)
            worst = max(worst, float(np.max(np.abs(x[both] - y[both]) / scale)))
    return {"max_rel_diff": worst, "nan_mismatch_fraction": nan_mismatch, "agree": worst <= rtol and nan_mismatch < 1e-3}


def main(paper: str, cases: dict[str, Callable], plan: list[tuple[str, list[int], int]],
         reference: dict[str, str], extra: Callable[[dict], dict] | None = None, rtol: float = 1e-9,
         notes: dict | None = None) -> None:
    """Parent or child, by the command line. ``plan``: ``(case, sizes, repeats)``; ``reference``:
    case -> the case whose values it must reproduce (checked on the case's smallest size)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--case")
    ap.add_argument("--size", type=int)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--save")
    a = ap.parse_args()
    if a.case:
        _child(cases, a.case, a.size, a.repeats, a.save)
        return
    script = str(Path(sys.argv[0]).resolve())
    t_start = time.perf_counter()
    results: dict[str, Any] = {"paper": paper, "cases": {}, "agreement": {}}
    with tempfile.TemporaryDirectory() as tmp:
        saved = {}
        for case, sizes, repeats in plan:
            rows = []
            for k, size in enumerate(sizes):
                save = os.path.join(tmp, f"{case}.npz") if k == 0 and (case in reference or case in reference.values()) else None
                r = run_case(script, case, size, repeats, save)
                if save:
                    saved[case] = save
                rows.append(r)
                print(f"{paper} {case:28s} size {size:>9d}: {r['items_per_s']:.3g}/s ({r['items_per_cpu_s']:.3g}/cpu-s), "
                      f"first call {r['first_call_s']:.2f} s, peak RSS {r['peak_rss_mib']:.0f} MiB", flush=True)
            results["cases"][case] = rows
        for case, ref in reference.items():
            if case in saved and ref in saved:
                results["agreement"][f"{case} vs {ref}"] = compare_saved(saved[ref], saved[case], rtol)
    if extra:
        results.update(extra(results["cases"]))
    results["notes"] = notes or {}
    results["machine"] = machine()
    results["benchmark_wall_s"] = time.perf_counter() - t_start
    RESULTS.mkdir(parents=True, exist_ok=True)
    out = RESULTS / f"{paper}.json"
    out.write_text(json.dumps(results, indent=2) + "\n")
    for k, v in results["agreement"].items():
        print(f"agreement {k}: {v}")
    print(f"wrote {out.relative_to(ROOT)} in {results['benchmark_wall_s']:.0f} s")


def rate(cases: dict, case: str, size: int | None = None, key: str = "items_per_s") -> float:
    """The rate of ``case`` at ``size`` (default: its largest size)."""
    rows = cases[case]
    row = rows[-1] if size is None else next(r for r in rows if r["size"] == size)
    return row[key]
