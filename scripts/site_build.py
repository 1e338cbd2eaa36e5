"""Quarto pre-/post-render script of the site (see `project:` in _quarto.yml). Standard library only.

    python scripts/site_build.py pre   # write _variables.yml: the build stamp every page's footer shows
    python scripts/site_build.py post  # copy notebooks/*.ipynb, figures/*.npz and MathJax (to vendor/) into <output-dir>

The build stamp is the commit (with "+modified (paths)" when a tracked source of the site differs
from it; ignored and untracked files, tests and benchmarks do not count), the date of
the build (UTC) and the versions of pkmlib (pyproject.toml) and JAX (the Python that Quarto runs
this script with, QUARTO_PYTHON; `make test` and `make report` point it at .venv; else the version
pinned in environment.lock, marked "(lock)"). _variables.yml is git-ignored: it describes a build,
not the sources. The copied notebooks are what each page's "notebook source" link downloads; MathJax
(node_modules/mathjax/es5, installed by `npm ci` from package-lock.json) is served from
<output-dir>/vendor/mathjax, so the maths renders without a network.
"""

from __future__ import annotations

import datetime as _dt
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The script tag of pandoc's ES6 polyfill for MathJax (from a CDN), removed from every page.
POLYFILL = re.compile(r'[ \t]*<script src="https://cdnjs\.cloudflare\.com/polyfill/[^"]*"></script>\n?')


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


#: What the site is built from: a change elsewhere (tests/, benchmarks/, an ignored build folder)
#: leaves the pages as the commit makes them, and the stamp names the commit alone.
SITE_SOURCES = (
    "notebooks",
    "data",
    "figures",
    "reference",
    "scripts",
    "assets",
    "index.qmd",
    "scorecard.qmd",
    "library.qmd",
    "_quarto.yml",
    "styles.css",
    "references.bib",
    "package.json",
    "package-lock.json",
    "pyproject.toml",
)


def commit() -> str:
    """The commit the site is built from; "+modified (paths)" when a tracked source of the site
    differs from it (ignored and untracked files do not count)."""
    head = _git("rev-parse", "--short=12", "HEAD")
    if not head:
        return "unknown (not a git checkout)"
    changed = _git("diff", "--name-only", "HEAD", "--", *SITE_SOURCES).splitlines()
    if not changed:
        return head
    shown = ", ".join(changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3 else "")
    return f"{head}+modified ({shown})"


def pkmlib_version() -> str:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]


def jax_version() -> str:
    try:
        from importlib.metadata import PackageNotFoundError, version

        return version("jax")
    except PackageNotFoundError:
        m = re.search(r"^jax==([\w.]+)", (ROOT / "environment.lock").read_text(), re.M)
        return f"{m.group(1)} (lock)" if m else "unknown"


def stamp() -> dict[str, str]:
    return {
        "commit": commit(),
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "pkmlib": pkmlib_version(),
        "jax": jax_version(),
    }


def _yaml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def pre() -> None:
    text = "# Written by scripts/site_build.py (Quarto pre-render); git-ignored.\nbuild:\n"
    text += "".join(f"  {k}: {_yaml_str(v)}\n" for k, v in stamp().items())
    (ROOT / "_variables.yml").write_text(text)


def post() -> None:
    out = Path(os.environ.get("QUARTO_PROJECT_OUTPUT_DIR") or ROOT / "_site")
    out = out if out.is_absolute() else ROOT / out
    dest = out / "notebooks"
    dest.mkdir(parents=True, exist_ok=True)
    for nb in sorted((ROOT / "notebooks").glob("*.ipynb")):
        shutil.copyfile(nb, dest / nb.name)
    # the arrays behind the figures (pkmlib.plotting.save_figure(..., arrays=...)), which
    # scripts/figure_arrays.lua links under each figure
    (out / "figures").mkdir(parents=True, exist_ok=True)
    for npz in sorted((ROOT / "figures").glob("*.npz")):
        shutil.copyfile(npz, out / "figures" / npz.name)
    mathjax = ROOT / "node_modules" / "mathjax" / "es5"
    if not (mathjax / "tex-chtml-full.js").exists():
        sys.exit("site_build.py post: node_modules/mathjax is missing: run `npm ci` (scripts/render_site.sh does)")
    shutil.rmtree(out / "vendor" / "mathjax", ignore_errors=True)
    shutil.copytree(mathjax, out / "vendor" / "mathjax")
    # pandoc puts an ES6 polyfill from a CDN before MathJax: every browser that runs the site has ES6,
    # and nothing of the site may come from the network
    for page in out.rglob("*.html"):
        html = page.read_text(encoding="utf-8")
        cleaned = POLYFILL.sub("", html)
        if cleaned != html:
            page.write_text(cleaned, encoding="utf-8")


if __name__ == "__main__":
    steps = {"pre": pre, "post": post}
    if len(sys.argv) != 2 or sys.argv[1] not in steps:
        sys.exit(f"usage: {sys.argv[0]} pre|post")
    steps[sys.argv[1]]()
