"""Every benchmark runs to its end at its smallest size (``--smoke``: each case once, the values
of every method checked against the reference method's, nothing written, no timing judged), so
``make benchmark`` cannot break unnoticed. The speed itself is measured by ``make benchmark``,
never asserted in tests."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.name for p in (ROOT / "benchmarks").glob("p[0-9]*.py")) + ["mechanisms.py", "design.py"]


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS)
def test_the_benchmark_runs_to_its_end_at_its_smallest_size(script, tmp_path):
    results = sorted((ROOT / "benchmarks" / "results").glob("*.json"))
    before = {p: p.read_bytes() for p in results}
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), "--smoke"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert "smoke" in r.stdout
    assert {p: p.read_bytes() for p in results} == before  # nothing written
