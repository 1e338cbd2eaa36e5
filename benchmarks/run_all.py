"""Run every paper's benchmark (``make benchmark``): benchmarks/p1.py, p2.py, p3.py, p4_*.py, p5.py,
the design studies' (design.py) and the mechanism descriptions' (mechanisms.py), each in its own
process, writing ``benchmarks/results/<name>.json``. Notebook timings (cold and warm compilation
cache) are separate and slower: ``python benchmarks/notebooks.py``.

    python benchmarks/run_all.py            # all papers
    python benchmarks/run_all.py p1 p3      # some
    python benchmarks/run_all.py design     # the design studies
    python benchmarks/run_all.py --smoke    # CI: each benchmark once at its smallest size, no
                                            # timing judged, nothing written

``--smoke`` runs the scripts one after another in this one process (``runpy``, each as its own
``__main__`` with ``--smoke`` on its command line), which saves each one's start (Python, JAX,
pkmlib) and lets the later ones reuse what the earlier ones traced; a failing script is reported
and the others still run. It prints ``== <script>: passed`` or ``== <script>: failed`` per script.
No timing is judged, so sharing the process changes nothing the smoke run checks.
"""

from __future__ import annotations

import runpy
import subprocess
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent


def scripts(selected: list[str]) -> list[Path]:
    found = sorted(HERE.glob("p[0-9]*.py")) + [HERE / "design.py", HERE / "mechanisms.py"]
    return [p for p in found if not selected or any(p.stem.startswith(s) for s in selected)]


def smoke_here(script: Path) -> bool:
    """``python <script> --smoke`` in this process; True when it ran to its end."""
    argv = sys.argv
    sys.argv = [str(script), "--smoke"]
    try:
        runpy.run_path(str(script), run_name="__main__")
        return True
    except SystemExit as e:  # a script's own verdict: 0 / None is success
        if e.code in (0, None):
            return True
        print(e.code if isinstance(e.code, str) else f"exit status {e.code}", file=sys.stderr, flush=True)
        return False
    except Exception:
        traceback.print_exc()
        return False
    finally:
        sys.argv = argv


def main() -> int:
    args = sys.argv[1:]
    smoke = "--smoke" in args
    selected = [a for a in args if a != "--smoke"]
    failed = []
    for script in scripts(selected):
        t = time.perf_counter()
        print(f"== {script.name}", flush=True)
        if smoke:
            ok = smoke_here(script)
        else:
            ok = subprocess.run([sys.executable, str(script)]).returncode == 0
        if not ok:
            failed.append(script.name)
        verdict = f"{'passed' if ok else 'failed'}: " if smoke else ""
        print(f"== {script.name}: {verdict}{time.perf_counter() - t:.0f} s", flush=True)
    if failed:
        print("failed: " + ", ".join(failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
