"""Issue 22 item 3, the layout: the kinematics stay at ``pkmlib.*``; stiffness, dynamics, design
and the report/re-run tooling are subpackages. Every name that moved still works for one release
from its old place, as the same object, with a ``DeprecationWarning`` naming the new place
(``pkmlib/_moved.py``); ``dir(pkmlib)`` and ``pkmlib.__all__`` are the new, small surface; and
nothing in the repository uses an old name (scripts/rename_moved_names.py rewrites them)."""

import importlib
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

import pkmlib
from pkmlib._moved import MOVED, MOVED_MODULES

ROOT = Path(__file__).resolve().parents[1]
SUBPACKAGES = ("stiffness", "dynamics", "design", "tools")


@pytest.mark.parametrize("name", sorted(MOVED))
def test_an_old_name_warns_naming_its_new_place_and_is_the_same_object(name):
    new = importlib.import_module(MOVED[name])
    with pytest.warns(DeprecationWarning, match=re.escape(f"pkmlib.{name} moved to {MOVED[name]}.{name}")):
        old = getattr(pkmlib, name)
    assert old is getattr(new, name)
    assert name in new.__all__
    assert name not in pkmlib.__all__ and name not in dir(pkmlib)


def test_from_pkmlib_import_an_old_name_warns_too():
    with pytest.warns(DeprecationWarning, match="pkmlib.condense moved to pkmlib.stiffness.condense"):
        from pkmlib import condense
    assert condense is pkmlib.stiffness.condense


def test_an_unknown_name_is_still_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_name"):
        pkmlib.no_such_name  # noqa: B018


def test_the_moved_table_is_exactly_the_subpackages_surface():
    exported = {f"pkmlib.{sub}": set(importlib.import_module(f"pkmlib.{sub}").__all__) for sub in SUBPACKAGES}
    for new, names in exported.items():
        assert {n for n, where in MOVED.items() if where == new} == names, new
    for sub in SUBPACKAGES:
        module = getattr(pkmlib, sub)
        for name in module.__all__:
            assert hasattr(module, name), f"{module.__name__}.__all__ names {name}, which it lacks"


def test_dir_and_all_are_the_new_small_surface():
    assert len(pkmlib.__all__) == len(set(pkmlib.__all__)) < 70
    assert not set(pkmlib.__all__) & set(MOVED)
    shown = set(dir(pkmlib))
    assert set(pkmlib.__all__) <= shown
    assert set(SUBPACKAGES) | {"mechanisms", "description", "plotting"} <= shown
    assert not [n for n in shown if n.startswith("_") and n != "__version__"], "private modules are not shown"
    for name in pkmlib.__all__:
        getattr(pkmlib, name)  # no warning: pyproject turns pkmlib's warnings into errors


@pytest.mark.parametrize("old, new", sorted(MOVED_MODULES.items()))
def test_an_old_module_path_warns_and_is_the_new_module(old, new):
    """In a fresh interpreter: the first import warns (once), and the old path is the new module."""
    code = (
        "import importlib, warnings\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        f"    old = importlib.import_module({old!r})\n"
        f"    again = importlib.import_module({old!r})\n"
        f"new = importlib.import_module({new!r})\n"
        "moved = [str(x.message) for x in w if issubclass(x.category, DeprecationWarning) and 'moved to' in str(x.message)]\n"
        "print(old is new and again is new, moved)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, run.stderr
    same, moved = run.stdout.strip().split(" ", 1)
    assert same == "True", run.stdout
    assert eval(moved) == [
        f"{old} moved to {new}; the old name works for one more release (see the README, 'What moved')"
    ]


def test_the_old_commands_still_run_with_a_warning():
    run = subprocess.run(
        [sys.executable, "-m", "pkmlib.rerun", "--help"], capture_output=True, text=True, cwd=ROOT, timeout=300
    )
    assert "pkmlib.rerun moved to pkmlib.tools.rerun" in run.stderr
    assert "usage: python -m pkmlib.tools.rerun" in run.stdout + run.stderr


OLD_NAME = re.compile(r"(?<![\w.])(?:pk|pkmlib)\.(" + "|".join(sorted(MOVED, key=len, reverse=True)) + r")\b")
OLD_MODULE = re.compile(
    r"\bpkmlib\.(?:report|rerun|design_studies)\b"
    r"|from pkmlib import [^\n]*\b(?:report|rerun|design_studies)\b"
    r"|from \.+ import [^\n]*\b(?:report|rerun|design_studies)\b|from \.+(?:report|rerun|design_studies) import"
)
# the files that name the old spellings on purpose: the table of moves, its shims, this test,
# the rewriting script and the README's "What moved" table
ON_PURPOSE = {
    "pkmlib/_moved.py",
    "pkmlib/__init__.py",
    "pkmlib/report.py",
    "pkmlib/rerun.py",
    "pkmlib/design_studies.py",
    "tests/test_moved_names.py",
    "scripts/rename_moved_names.py",
    "README.md",
}


def tracked(*patterns):
    out = subprocess.run(["git", "ls-files", *patterns], capture_output=True, text=True, cwd=ROOT, check=True)
    return [p for p in out.stdout.split() if p not in ON_PURPOSE]


def code_of(path):
    text = (ROOT / path).read_text()
    if path.endswith(".ipynb"):
        cells = json.loads(text)["cells"]
        return "\n".join("".join(c["source"]) for c in cells)  # code and Markdown, not outputs
    return text


def test_no_code_in_the_repository_uses_an_old_name():
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    found = []
    files = tracked("*.py", "*.ipynb", "*.qmd", "Makefile", "*.sh", "*.lua", ".ci/*", "pyproject.toml", "_quarto.yml")
    for path in [p for p in files if not p.startswith("reference/")]:  # reference/: from the docstrings
        code = code_of(path)
        if path.startswith("pkmlib/") and path.endswith(".py"):
            code = re.sub(r'"""[\s\S]*?"""|#[^\n]*', "", code)  # the library's code, not its prose
        found += [f"{path}: {m[0]}" for m in OLD_NAME.finditer(code)]
        found += [f"{path}: {m[0]}" for m in OLD_MODULE.finditer(code)]
    assert not found, "old names (run scripts/rename_moved_names.py on these files):\n" + "\n".join(found)
