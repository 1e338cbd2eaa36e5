"""The library guide's reference pages: `quartodoc build` (no Quarto needed) works on a copy of
the project, writes a page for every section of the `quartodoc:` config in `_quarto.yml`, the
committed pages under reference/ are that build's output, and every public name is documented."""

import inspect
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import pkmlib
import pkmlib.plotting
from pkmlib import mechanisms

ROOT = Path(__file__).resolve().parents[1]
REBUILD = "run `.venv/bin/quartodoc build` and commit reference/"


def config():
    return yaml.safe_load((ROOT / "_quarto.yml").read_text())["quartodoc"]


def expected_pages(cfg):
    """Page files the config asks for: one per `kind: page` entry or per documented module."""
    pages = {"index.qmd"}
    for section in cfg["sections"]:
        for item in section["contents"]:
            if isinstance(item, dict) and item.get("kind") == "page":
                pages.add(f"{item['path']}.qmd")
            else:
                pages.add(f"{item if isinstance(item, str) else item['name']}.qmd")
    return pages


@pytest.fixture(scope="module")
def fresh_build(tmp_path_factory):
    """`quartodoc build` in a temporary copy holding only _quarto.yml and pkmlib/."""
    tmp = tmp_path_factory.mktemp("guide")
    shutil.copy(ROOT / "_quarto.yml", tmp / "_quarto.yml")
    shutil.copytree(ROOT / "pkmlib", tmp / "pkmlib", ignore=shutil.ignore_patterns("__pycache__"))
    run = subprocess.run(
        [sys.executable, "-m", "quartodoc", "build"], cwd=tmp, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stdout + run.stderr
    return tmp / config()["dir"]


def test_config_has_a_section_per_area_of_pkmlib():
    cfg = config()
    assert cfg["package"] == "pkmlib"
    titles = [s["title"] for s in cfg["sections"]]
    for area in (
        "Jacobians and criteria",
        "Sweeps, grids and singular curves",
        "Position solutions",
        "Screws and rotations",
        "Stiffness: pkmlib.stiffness",
        "Dynamics: pkmlib.dynamics",
        "Results and plotting: pkmlib.tools, pkmlib.plotting",
        "Re-runs and notebook parameters: pkmlib.tools",
        "Design synthesis and atlases: pkmlib.design",
        "Mechanisms",
    ):
        assert area in titles, area
    mechanism_pages = {f"mechanisms.{name}.qmd" for name in mechanisms.__all__}
    assert mechanism_pages <= expected_pages(cfg)


def test_build_writes_a_page_for_every_section(fresh_build):
    written = {p.name for p in fresh_build.glob("*.qmd")}
    assert written == expected_pages(config())
    index = (fresh_build / "index.qmd").read_text()
    for section in config()["sections"]:
        assert f"## {section['title']}" in index, section["title"]
    for page in written:  # every page documents something: a heading with an anchor
        assert re.search(r"^# .+\{ #pkmlib\.", (fresh_build / page).read_text(), re.M) or page == "index.qmd", page


def test_committed_reference_pages_are_a_fresh_build(fresh_build):
    committed = ROOT / config()["dir"]
    assert committed.is_dir(), REBUILD
    fresh = {p.name: p.read_text() for p in fresh_build.glob("*.qmd")}
    ours = {p.name: p.read_text() for p in committed.glob("*.qmd")}
    assert sorted(ours) == sorted(fresh), REBUILD
    for name, text in fresh.items():
        assert ours[name] == text, f"reference/{name} is stale: {REBUILD}"


def test_every_public_name_is_documented():
    text = "\n".join(p.read_text() for p in (ROOT / config()["dir"]).glob("*.qmd"))
    anchors = set(re.findall(r"\{ #(pkmlib[\w.]*) \}", text))
    for name in pkmlib.__all__:
        assert f"pkmlib.{name}" in anchors, f"pkmlib.{name} has no reference entry: add it to _quarto.yml"
    for sub in ("stiffness", "dynamics", "design", "tools"):  # the subpackages, each under its own name
        for name in getattr(pkmlib, sub).__all__:
            assert f"pkmlib.{sub}.{name}" in anchors, (
                f"pkmlib.{sub}.{name} has no reference entry: add it to _quarto.yml"
            )
    for module in ("pkmlib.design.studies", "pkmlib.tools.rerun"):
        assert module in anchors, module
    for name in pkmlib.plotting.__all__:
        if name != "plt":  # matplotlib's pyplot, re-exported for the notebooks
            assert f"pkmlib.plotting.{name}" in anchors, f"pkmlib.plotting.{name}"
    for module in mechanisms.__all__:
        mod = getattr(mechanisms, module)
        public = getattr(mod, "__all__", None) or [
            n
            for n, o in vars(mod).items()
            if not n.startswith("_") and getattr(o, "__module__", None) == mod.__name__ and callable(o)
        ]
        for name in public:
            if callable(getattr(mod, name)):
                assert f"pkmlib.mechanisms.{module}.{name}" in anchors, f"{module}.{name}"


def test_classes_list_the_methods_they_inherit_from_pkmlib():
    """A mechanism class's reference entry lists every public method it has, also those from a pkmlib
    base class (P3's ParamsA and ParamsB take from_dict from their actuator-box base)."""
    text = "\n".join(p.read_text() for p in (ROOT / config()["dir"]).glob("*.qmd"))
    anchors = set(re.findall(r"\{ #(pkmlib[\w.]*) \}", text))
    checked = 0
    for module in mechanisms.__all__:
        mod = getattr(mechanisms, module)
        for cname, cls in vars(mod).items():
            path = f"pkmlib.mechanisms.{module}.{cname}"
            if not isinstance(cls, type) or path not in anchors:
                continue
            for name in dir(cls):
                member = inspect.getattr_static(cls, name)
                func = getattr(member, "__func__", member)  # classmethods and staticmethods
                if name.startswith("_") or not inspect.isfunction(func) or not func.__doc__:
                    continue
                if not func.__module__.startswith("pkmlib"):
                    continue
                assert f"{path}.{name}" in anchors, f"{path}.{name} is not in the reference"
                checked += 1
    assert checked > 0
