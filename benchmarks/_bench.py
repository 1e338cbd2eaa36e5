"""Shared benchmark machinery: every case runs in its own subprocess (fresh JAX, fresh numba), so
its peak resident memory (``resource.getrusage(RUSAGE_SELF).ru_maxrss`` at the child's end) is its
own; times are the best of a few repeats after a first call that includes compilation.

A paper's script defines ``CASES = {name: make(size) -> (run, n_items, values)}`` and calls
:func:`main`. Run without arguments it is the parent: it runs each (case, size) in a child, checks
that every method gives the same values as the reference on the smallest size, and writes
``benchmarks/results/<paper>.json``. Figures are rates (items per second of wall time, and per CPU
second, which moves less when other jobs share the machine) and ratios between methods measured
in the same run; times on a shared 2-core machine vary by 2x between runs, ratios much less.
Every figure carries the machine's 1-minute load average when it was taken.

``interleave``: ``(label, [baseline case, other cases...], size)``: the cases alternate in one
child process, round after round, until the ratio of their best times has been stable (within
``INTERLEAVED_RTOL`` over the last ``INTERLEAVED_STABLE_ROUNDS`` rounds): both see the same load,
so their ratio is the fairest this machine gives (``results["interleaved"][label]``).

``--smoke`` (CI, ``python benchmarks/run_all.py --smoke``): every case once at its smallest size
in this process, the values checked against their reference case, every interleaved pair one
round at its smallest size; no timing is judged and nothing is written.
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
#: Interleaved rounds: at least MIN, at most MAX; stable when the ratios of the last STABLE rounds
#: differ by less than RTOL (relative) from the last one.
INTERLEAVED_MIN_ROUNDS, INTERLEAVED_MAX_ROUNDS, INTERLEAVED_STABLE_ROUNDS, INTERLEAVED_RTOL = 5, 40, 4, 0.03


def write_results(path: Path, results: dict[str, Any]) -> Path:
    """Write a benchmark's results with :func:`pkmlib.tools.write_results` (atomically: an
    interrupted or failed run leaves the file it would replace). Imported here, not at the top, so
    that the timed child processes of the numba cases do not load JAX."""
    from pkmlib.tools import write_results as write

    return write(path, results)


def load_1min() -> float:
    """The machine's 1-minute load average (runnable processes; above the core count, jobs queue)."""
    return os.getloadavg()[0]


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

    info = {
        "cpu": cpu,
        "avx512f": "avx512f" in flags,
        "cores": os.cpu_count(),
        "load_average_1min_at_end": os.getloadavg()[0],
        "platform": platform.platform(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "numpy": np.__version__,
        "jax_devices": [str(d) for d in jax.devices()],
        # whether the persistent compilation cache was on (not its path: results stay machine-free)
        "jax_compilation_cache_dir": "set" if os.environ.get("JAX_COMPILATION_CACHE_DIR") else None,
    }
    try:
        import numba

        info["numba"] = numba.__version__
    except ImportError:
        info["numba"] = None
    return info


def _child(cases: dict[str, Callable], case: str, size: int, repeats: int, save: str | None) -> None:
    make = cases[case]
    load_start = load_1min()
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
    print(
        json.dumps(
            {
                "case": case,
                "size": size,
                "items": n_items,
                "first_call_s": first,
                "best_s": best,
                "best_cpu_s": best_cpu,
                "items_per_s": n_items / best,
                "items_per_cpu_s": n_items / max(best_cpu, 1e-9),
                "peak_rss_mib": rss,
                "load_1min_start": load_start,
                "load_1min_end": load_1min(),
            }
        )
    )


def interleaved(
    cases: dict[str, Callable],
    names: list[str],
    size: int,
    *,
    min_rounds: int | None = None,
    max_rounds: int | None = None,
) -> dict[str, Any]:
    """``names`` alternately in this process, best time of each so far, round after round until
    the ratio of every case's best time to the first one's (the baseline) is stable; each
    round's ratios and load average are kept. Round counts default to the module's
    ``INTERLEAVED_*_ROUNDS`` when called (a script may raise them for its own sets)."""
    min_rounds = INTERLEAVED_MIN_ROUNDS if min_rounds is None else min_rounds
    max_rounds = INTERLEAVED_MAX_ROUNDS if max_rounds is None else max_rounds
    runs = {}
    for n in names:
        run, items, _ = cases[n](size)
        run()  # compile
        runs[n] = run
    best = {n: float("inf") for n in names}
    best_cpu = {n: float("inf") for n in names}
    history: list[dict[str, Any]] = []
    stable = False
    for k in range(max_rounds):
        load = load_1min()
        for n in names:
            t, c = time.perf_counter(), time.process_time()
            runs[n]()
            best[n] = min(best[n], time.perf_counter() - t)
            best_cpu[n] = min(best_cpu[n], time.process_time() - c)
        ratios = {n: best[n] / best[names[0]] for n in names[1:]}
        history.append({"round": k, "load_1min": load, "time_over_baseline": ratios})
        last = history[-INTERLEAVED_STABLE_ROUNDS:]
        if (
            k + 1 >= min_rounds
            and len(last) == INTERLEAVED_STABLE_ROUNDS
            and all(abs(h["time_over_baseline"][n] / ratios[n] - 1.0) < INTERLEAVED_RTOL for h in last for n in ratios)
        ):
            stable = True
            break
    loads = [h["load_1min"] for h in history]
    return {
        "cases": names,
        "size": size,
        "items": items,
        "rounds": len(history),
        "stable": stable,
        "items_per_s": {n: items / best[n] for n in names},
        "items_per_cpu_s": {n: items / max(best_cpu[n], 1e-9) for n in names},
        f"{names[0]}_over": {n: best[n] / best[names[0]] for n in names[1:]},
        "load_1min_range": [min(loads), max(loads)],
        "rounds_history": history,
    }


def _interleaved_child(script: str, names: list[str], size: int, env: dict | None = None) -> dict[str, Any]:
    cmd = [sys.executable, script, "--interleaved", ",".join(names), "--size", str(size)]
    full_env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    full_env.update(env or {})
    res = subprocess.run(cmd, capture_output=True, text=True, env=full_env, timeout=1800)
    if res.returncode != 0:
        raise RuntimeError(f"interleaved {names} size {size} failed:\n{res.stdout}\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def run_case(
    script: str, case: str, size: int, repeats: int, save: str | None = None, env: dict | None = None
) -> dict[str, Any]:
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


def wrapped_angles(q):
    """Angles in (-pi, pi], as the methods' revolute joint angles are compared: atan2 may give one
    method's angle 2 pi from another's (the same joint position), as the rounding falls."""
    import numpy as np

    return np.angle(np.exp(1j * np.asarray(q)))


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
    return {
        "max_rel_diff": worst,
        "nan_mismatch_fraction": nan_mismatch,
        "agree": worst <= rtol and nan_mismatch < 1e-3,
    }


def smoke(
    paper: str,
    cases: dict[str, Callable],
    plan: list[tuple[str, list[int], int]],
    reference: dict[str, str],
    rtol: float,
    interleave: list = (),
    sizes: dict[str, int] | None = None,
) -> None:
    """Every case once at its smallest size (or its size in ``sizes``), here; values checked
    against the reference case's; every interleaved set one round at its smallest size. Raises
    on a disagreement."""
    smallest = {case: (sizes or {}).get(case, min(s)) for case, s, _ in plan}
    import numpy as np

    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        saved = {}
        for case, _, _ in plan:
            run, n_items, values = cases[case](smallest[case])
            out = run()
            saved[case] = os.path.join(tmp, f"{case}.npz")
            np.savez(saved[case], **{k: np.asarray(v) for k, v in values(out).items()})
            print(f"{paper} smoke {case:28s} size {smallest[case]:>9d}: {n_items} items", flush=True)
        bad = {}
        for case, ref in reference.items():
            agreement = compare_saved(saved[ref], saved[case], rtol)
            if not agreement["agree"]:
                bad[f"{case} vs {ref}"] = agreement
    for label, names, *_ in interleave:
        r = interleaved(cases, names, min(smallest[n] for n in names), min_rounds=1, max_rounds=1)
        print(f"{paper} smoke interleaved {label}: {r['rounds']} round at size {r['size']}", flush=True)
    if bad:
        raise SystemExit(f"{paper} smoke: values disagree: {json.dumps(bad)}")
    print(f"{paper} smoke: {len(plan)} cases agree ({time.perf_counter() - t_start:.0f} s)")


def main(
    paper: str,
    cases: dict[str, Callable],
    plan: list[tuple[str, list[int], int]],
    reference: dict[str, str],
    extra: Callable[[dict], dict] | None = None,
    rtol: float = 1e-9,
    notes: dict | None = None,
    interleave: list = (),
    smoke_sizes: dict[str, int] | None = None,
) -> None:
    """Parent or child, by the command line. ``plan``: ``(case, sizes, repeats)``; ``reference``:
    case -> the case whose values it must reproduce (checked on the case's smallest size);
    ``interleave``: ``(label, [baseline, others...], size)`` or ``(label, names, size, env)``."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--case")
    ap.add_argument("--interleaved", help="comma-separated cases, the baseline first")
    ap.add_argument("--size", type=int)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--save")
    ap.add_argument("--smoke", action="store_true", help="each case once at its smallest size, nothing written")
    a = ap.parse_args()
    if a.case:
        _child(cases, a.case, a.size, a.repeats, a.save)
        return
    if a.interleaved:
        print(json.dumps(interleaved(cases, a.interleaved.split(","), a.size)))
        return
    if a.smoke:
        smoke(paper, cases, plan, reference, rtol, interleave, smoke_sizes)
        return
    script = str(Path(sys.argv[0]).resolve())
    t_start = time.perf_counter()
    results: dict[str, Any] = {"paper": paper, "cases": {}, "agreement": {}}
    with tempfile.TemporaryDirectory() as tmp:
        saved = {}
        for case, sizes, repeats in plan:
            rows = []
            for k, size in enumerate(sizes):
                save = (
                    os.path.join(tmp, f"{case}.npz")
                    if k == 0 and (case in reference or case in reference.values())
                    else None
                )
                r = run_case(script, case, size, repeats, save)
                if save:
                    saved[case] = save
                rows.append(r)
                print(
                    f"{paper} {case:28s} size {size:>9d}: {r['items_per_s']:.3g}/s ({r['items_per_cpu_s']:.3g}/cpu-s), "
                    f"first call {r['first_call_s']:.2f} s, peak RSS {r['peak_rss_mib']:.0f} MiB",
                    flush=True,
                )
            results["cases"][case] = rows
        for case, ref in reference.items():
            if case in saved and ref in saved:
                results["agreement"][f"{case} vs {ref}"] = compare_saved(saved[ref], saved[case], rtol)
    results["interleaved"] = {}
    for label, names, size, *env in interleave:
        r = _interleaved_child(script, names, size, env[0] if env else None)
        results["interleaved"][label] = r
        others = ", ".join(
            f"{n} {r['items_per_s'][n]:.3g}/s ({v:.2f}x the time)" for n, v in r[f"{names[0]}_over"].items()
        )
        print(
            f"{paper} interleaved {label}: {names[0]} {r['items_per_s'][names[0]]:.3g}/s; {others}; "
            f"{r['rounds']} rounds, stable: {r['stable']}, load {r['load_1min_range']}",
            flush=True,
        )
    if extra:
        results.update(extra(results["cases"], results["interleaved"]) if interleave else extra(results["cases"]))
    results["notes"] = notes or {}
    results["machine"] = machine()
    results["benchmark_wall_s"] = time.perf_counter() - t_start
    out = write_results(RESULTS / f"{paper}.json", results)
    for k, v in results["agreement"].items():
        print(f"agreement {k}: {v}")
    print(f"wrote {out.relative_to(ROOT)} in {results['benchmark_wall_s']:.0f} s")


#: The elementwise ops that cost most per point, as named in XLA's optimised HLO: the
#: transcendentals (tens of ns each in float64) and square roots and divisions (a few ns each,
#: against about 1 ns for a multiply). ``acos`` appears as ``atan2``, which is how XLA lowers it.
COSTLY_OPS = ("atan2", "cosine", "sine", "exponential", "log", "power", "tanh", "sqrt", "divide")


def ops_per_point(fn: Callable, *args: Any) -> dict[str, int]:
    """What XLA evaluates per point in ``jit(fn)(*args)`` (``args`` traced, as :func:`pkmlib.sweep`
    traces its points and ``args``), read off the optimised HLO: ``fused_loops``, the loops over
    the points, each reading its inputs from memory and writing its outputs (a hand-written
    per-point loop is one), and how many times each of :data:`COSTLY_OPS` runs per point. Every
    fused loop of a structure-of-arrays map is elementwise over the points, so each op written
    in a fused computation (or outside one) runs once per point and per loop that holds it.
    XLA's CPU fusion recomputes a producer inside each consumer loop unless it judges it
    expensive, instead of writing it to memory once, so a quantity several maps share is
    evaluated once per map that reads it: the counts show that duplication."""
    import re

    import jax

    text = jax.jit(fn).lower(*args).compile().as_text()
    # loops over arrays only: a scalar (shape []) fusion or op runs once per call, not per point
    loops = [ln for ln in text.splitlines() if "kind=kLoop" in ln and not re.search(r"= \w+\[\] fusion\(", ln)]
    counts = {"fused_loops": len(loops)}
    for op in COSTLY_OPS:
        counts[op] = len(re.findall(rf"= f64\[[^\]]+\]\{{[^}}]*\}} {op}\(", text))
    return counts


def rate(cases: dict, case: str, size: int | None = None, key: str = "items_per_s") -> float:
    """The rate of ``case`` at ``size`` (default: its largest size)."""
    rows = cases[case]
    row = rows[-1] if size is None else next(r for r in rows if r["size"] == size)
    return row[key]
