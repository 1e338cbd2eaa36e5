"""Time every notebook end to end, cold and warm: each is executed twice with papermill in a fresh
process, first with an empty JAX persistent compilation cache (cold: everything compiles), then with
the cache the first run filled (warm: what ``make test`` / ``make report`` see the second time).
Outputs, results and figures go to a temporary directory (the repository's notebooks, data/ and
figures/ are not touched). Writes ``benchmarks/results/notebooks.json``.

    python benchmarks/notebooks.py                   # all notebooks
    python benchmarks/notebooks.py p1 tutorial       # some
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench import machine, write_results  # noqa: E402

TARGET_WARM_S = 20.0
RESULTS_PATH = ROOT / "benchmarks" / "results" / "notebooks.json"


def run_notebook(nb: Path, out_dir: Path, cache_dir: Path, label: str) -> dict:
    out_dir.mkdir(parents=True, exist_ok=True)
    env = dict(
        os.environ,
        JAX_PLATFORMS=os.environ.get("JAX_PLATFORMS", "cpu"),
        JAX_COMPILATION_CACHE_DIR=str(cache_dir),
        JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0",
        JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES="0",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    cmd = [
        sys.executable,
        "-m",
        "papermill",
        "--no-progress-bar",
        "-k",
        "python3",
        str(nb),
        str(out_dir / f"{nb.stem}_{label}.ipynb"),
        "-p",
        "results_path",
        str(out_dir / f"results_{label}.json"),
        "-p",
        "figures_dir",
        str(out_dir / f"fig_{label}"),
    ]
    t = time.perf_counter()
    res = subprocess.run(cmd, cwd=nb.parent, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - t
    if res.returncode != 0:
        return {"seconds": seconds, "error": res.stderr[-2000:]}
    return {"seconds": seconds}


def main() -> int:
    selected = sys.argv[1:]
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    notebooks = [nb for nb in notebooks if not selected or any(nb.stem.startswith(s) for s in selected)]
    results = {
        "notebooks": {},
        "target_warm_s": TARGET_WARM_S,
        "method": "papermill in a fresh process; cold: empty JAX compilation cache; warm: the cache of "
        "the cold run (process start, imports and plotting included)",
    }
    with tempfile.TemporaryDirectory() as tmp:
        for nb in notebooks:
            cache = Path(tmp) / f"cache_{nb.stem}"
            out = Path(tmp) / nb.stem
            cold = run_notebook(nb, out, cache, "cold")
            warm = run_notebook(nb, out, cache, "warm")
            row = {
                "cold_s": cold["seconds"],
                "warm_s": warm["seconds"],
                "warm_under_target": warm["seconds"] < TARGET_WARM_S,
            }
            for k, r in (("cold_error", cold), ("warm_error", warm)):
                if "error" in r:
                    row[k] = r["error"]
            results["notebooks"][nb.stem] = row
            print(
                f"{nb.stem:45s} cold {row['cold_s']:6.1f} s  warm {row['warm_s']:6.1f} s"
                + ("  ERROR" if "cold_error" in row or "warm_error" in row else ""),
                flush=True,
            )
    results["machine"] = machine()
    return record(results, RESULTS_PATH, keep_others=bool(selected))


def record(results: dict, out: Path, keep_others: bool) -> int:
    """Write ``results`` to ``out`` (atomically), keeping the rows of the notebooks not run when
    ``keep_others``; 0. If any notebook failed, print why and leave ``out`` as it was: 1."""
    failed = [k for k, row in results["notebooks"].items() if "cold_error" in row or "warm_error" in row]
    if failed:
        for k in failed:
            row = results["notebooks"][k]
            print(f"{k} failed:\n{row.get('cold_error') or row.get('warm_error')}", file=sys.stderr)
        print(f"{out.name} left as it was", file=sys.stderr)
        return 1
    if keep_others and out.exists():
        old = json.loads(out.read_text())
        old["notebooks"].update(results["notebooks"])
        results["notebooks"] = old["notebooks"]
    write_results(out, results)
    print(f"wrote {out.name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
