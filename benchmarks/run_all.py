"""Run every paper's benchmark (``make benchmark``): benchmarks/p1.py, p2.py, p3.py, p4_*.py, p5.py,
and the design studies' (design.py), each in its own process, writing ``benchmarks/results/<name>.json``. Notebook timings (cold and
warm compilation cache) are separate and slower: ``python benchmarks/notebooks.py``.

    python benchmarks/run_all.py            # all papers
    python benchmarks/run_all.py p1 p3      # some
    python benchmarks/run_all.py design     # the design studies
    python benchmarks/run_all.py --smoke    # CI: each benchmark once at its smallest size, no
                                            # timing judged, nothing written
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def scripts(selected: list[str]) -> list[Path]:
    found = sorted(HERE.glob("p[0-9]*.py")) + [HERE / "design.py", HERE / "mechanisms.py"]
    return [p for p in found if not selected or any(p.stem.startswith(s) for s in selected)]


def main() -> int:
    args = sys.argv[1:]
    smoke = "--smoke" in args
    selected = [a for a in args if a != "--smoke"]
    failed = []
    for script in scripts(selected):
        t = time.perf_counter()
        print(f"== {script.name}", flush=True)
        if subprocess.run([sys.executable, str(script)] + (["--smoke"] if smoke else [])).returncode != 0:
            failed.append(script.name)
        print(f"== {script.name}: {time.perf_counter() - t:.0f} s", flush=True)
    if failed:
        print("failed: " + ", ".join(failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
