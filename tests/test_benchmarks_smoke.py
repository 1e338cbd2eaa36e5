"""Every benchmark runs to its end at its smallest size (``--smoke``: each case once, the values
of every method checked against the reference method's, nothing written, no timing judged), so
``make benchmark`` cannot break unnoticed. The speed itself is measured by ``make benchmark``,
never asserted in tests.

The smoke runs share one process (``benchmarks/run_all.py --smoke``: each script as its own
``__main__``), which saves each one's start and the traces the later ones share with the earlier."""

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.name for p in (ROOT / "benchmarks").glob("p[0-9]*.py")) + ["design.py", "mechanisms.py"]


def _run_all():
    spec = importlib.util.spec_from_file_location("run_all", ROOT / "benchmarks" / "run_all.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_every_benchmark_runs_to_its_end_at_its_smallest_size(tmp_path):
    results = sorted((ROOT / "benchmarks" / "results").glob("*.json"))
    before = {p: p.read_bytes() for p in results}
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "run_all.py"), "--smoke"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert [s.removesuffix(".py") for s in SCRIPTS] == [s.name.removesuffix(".py") for s in _run_all().scripts([])]
    for script in SCRIPTS:
        assert re.search(rf"^== {re.escape(script)}: passed: \d+ s$", r.stdout, flags=re.M), script
        assert f"{script.split('_')[0].removesuffix('.py')} smoke" in r.stdout, script  # its own smoke lines
    assert {p: p.read_bytes() for p in results} == before  # nothing written


@pytest.mark.parametrize(
    "body, ok",
    [
        ("print('ran')", True),
        ("raise SystemExit(0)", True),
        ("raise SystemExit('p9 smoke: values disagree')", False),
        ("raise SystemExit(2)", False),
        ("raise RuntimeError('boom')", False),
        ("import sys\nassert sys.argv[1:] == ['--smoke'], sys.argv", True),
    ],
)
def test_a_smoke_run_in_the_shared_process_reports_its_own_verdict(tmp_path, capsys, body, ok):
    script = tmp_path / "p9.py"
    script.write_text("if __name__ == '__main__':\n    " + body.replace("\n", "\n    ") + "\n")
    argv = list(sys.argv)
    assert _run_all().smoke_here(script) is ok
    assert sys.argv == argv  # the caller's command line is given back
    if not ok:
        err = capsys.readouterr().err
        assert "values disagree" in err or "exit status 2" in err or "boom" in err, err
