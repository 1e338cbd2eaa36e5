"""Run every paper's benchmark (``make benchmark``): benchmarks/p1.py, p2.py, p3.py, p4_*.py, p5.py,
and the design studies' (design.py), each in its own process, writing ``benchmarks/results/<name>.json``. Notebook timings (cold and
warm compilation cache) are separate and slower: ``python benchmarks/notebooks.py``.

    python benchmarks/run_all.py            # all papers
    python benchmarks/run_all.py p1 p3      # some
    python benchmarks/run_all.py design     # the design studies
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def scripts(selected: list[str]) -> list[Path]:
    found = sorted(HERE.glob("p[0-9]*.py")) + [HERE / "design.py"]
    return [p for p in found if not selected or any(p.stem.startswith(s) for s in selected)]


def main() -> int:
    failed = []
    for script in scripts(sys.argv[1:]):
        t = time.perf_counter()
        print(f"== {script.name}", flush=True)
        if subprocess.run([sys.executable, str(script)]).returncode != 0:
            failed.append(script.name)
        print(f"== {script.name}: {time.perf_counter() - t:.0f} s", flush=True)
    if failed:
        print("failed: " + ", ".join(failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
