"""A benchmark that fails does not replace the measurements on record: ``benchmarks/notebooks.py``
and ``benchmarks/test_suite.py`` write their JSON only when every notebook / step succeeded, and
then atomically (through :func:`pkmlib.tools.write_results`)."""

import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load(name):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "benchmarks" / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return module


def test_a_failed_notebook_leaves_notebooks_json_as_it_was(tmp_path, capsys):
    nb = _load("notebooks")
    out = tmp_path / "notebooks.json"
    out.write_text('{"notebooks": {"p1": {"warm_s": 8.0}}}\n')
    before = out.read_bytes()
    failed = {"notebooks": {"p1": {"cold_s": 1.0, "warm_s": 1.0, "warm_error": "boom"}}}
    assert nb.record(failed, out, keep_others=True) == 1
    assert out.read_bytes() == before
    assert "boom" in capsys.readouterr().err
    ok = {"notebooks": {"p2": {"cold_s": 2.0, "warm_s": 1.5}}, "machine": {}}
    assert nb.record(ok, out, keep_others=True) == 0
    assert json.loads(out.read_text())["notebooks"] == {"p1": {"warm_s": 8.0}, "p2": {"cold_s": 2.0, "warm_s": 1.5}}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notebooks.json"]  # no temporary file left


def test_a_failed_step_leaves_tests_json_as_it_was(tmp_path, capsys):
    suite = _load("test_suite")
    path = tmp_path / "tests.json"
    path.write_text('{"warm_cache": {"wall_s": 100}}\n')
    before = path.read_bytes()
    results = {"warm_cache": {"steps": {"lint": {"rc": 0}, "nbval": {"rc": 1}}}}
    with pytest.raises(SystemExit) as e:
        suite.record(results, path)
    assert e.value.code == 1
    assert path.read_bytes() == before
    assert "warm_cache: nbval (rc 1" in capsys.readouterr().err
    results["warm_cache"]["steps"]["nbval"]["rc"] = 0
    suite.record(results, path)
    assert json.loads(path.read_text()) == results
