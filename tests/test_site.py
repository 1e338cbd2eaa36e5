"""The Quarto site: its sources (pages, notebook cell options, bibliography, licence) and, above
all, the rendered HTML in _site/ as a reader sees it: figure numbers, captions, image widths,
tables, output lengths, verdict boxes, citations, source links, the build stamp, links.

The rendered tests need Quarto: `make test` renders the site first (scripts/render_site.sh, which
fails on any Quarto warning); run alone, the `site` fixture renders it when _site/ is missing or
older than its sources, and the tests skip, saying why, where no Quarto can be found.
"""

import json
import os
import re
import shutil
import struct
import subprocess
import tomllib
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest
import yaml

from pkmlib._papers import PAPERS, paper_of_notebook
from _site import wait_for_render

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "_site"
RENDER_LOG = SITE / ".render.log"
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
OPTION = re.compile(r"^#\|\s*([\w-]+):\s*(.*)$")
CITATION_KEYS = {key: paper.citation_key for key, paper in PAPERS.items()}  # the registry, pkmlib._papers
#: What a figure caption starts with: the paper's own number ("Fig 17 (P3). ", "Fig 6a (P1). ")
#: or "Extra figure (P3): " for a figure beyond the paper (REPORT_CONVENTIONS.md).
PAPER_CAPTION = re.compile(r"^(Fig \d+[a-z]? \((P\d)\)\. |Extra figure \((P\d)\): )")
TUTORIAL_CAPTION = re.compile(r"^(Tutorial|Extra figure)\b")  # notebooks beyond the papers (tutorial, design studies)
AUTOMATIC_NUMBER = re.compile(r"\b(Figure|Fig\.)\s+\d+\s*:")
MAX_OUTPUT_LINES = 30
#: Stored image widths: a figure at least 1.5 times as wide as high is read at full width, so it
#: is stored at least 640 px wide (e.g. figsize width >= 8 in at the inline backend's dpi); any
#: other figure (a scheme, a square map) at least 440 px.
MIN_FULL_WIDTH_PX, MIN_FIGURE_PX, FULL_WIDTH_ASPECT = 640, 440, 1.5


def is_paper(nb_path):
    """A paper's notebook (registered in pkmlib._papers); any other notebook is a tutorial or a study."""
    return paper_of_notebook(nb_path) is not None


def paper_of(nb_path):
    return paper_of_notebook(nb_path).key


def quarto():
    return yaml.safe_load((ROOT / "_quarto.yml").read_text())


def sidebar_pages(items):
    for item in items:
        if isinstance(item, str):
            yield item
        elif "href" in item:
            yield item["href"]
        if isinstance(item, dict) and "contents" in item:
            yield from sidebar_pages(item["contents"])


def cells(nb_path):
    return json.loads(nb_path.read_text())["cells"]


def cell_options(cell):
    """The leading `#| key: value` lines of a code cell (Quarto reads only those), read as YAML as
    Quarto reads them (so single- and double-quoted captions both come back as their text)."""
    lines = []
    for line in "".join(cell["source"]).splitlines():
        if not OPTION.match(line):
            break
        lines.append(line[2:].lstrip())
    if not lines:
        return {}
    opts = yaml.safe_load("\n".join(lines)) or {}
    return {str(k): ("" if v is None else str(v)) for k, v in opts.items()}


#: A figure saved by a cell: save_figure(fig..., f"{figures_dir}/<name>.png", ...) (the name the
#: site's scripts/figure_arrays.lua reads too).
SAVED_FIGURE = re.compile(r'save_figure\(\s*fig\w*\s*,\s*f"\{figures_dir\}/(\w+)\.png"')
#: A cell that draws a map over a grid (its arrays go beside the PNG, issue 20.7).
DRAWS_A_MAP = re.compile(r"\b(plot_map|plot_sign_map|pcolormesh|contourf|tricontourf|imshow)\(")


def figure_cells(nb_path):
    """(figure names, source) of every code cell of a notebook that saves a figure."""
    for c in cells(nb_path):
        if c["cell_type"] == "code":
            src = "".join(c["source"])
            names = SAVED_FIGURE.findall(src)
            if names:
                yield names, src


#: A caption states the values it is drawn at: a number with a unit ("$s = 0.14$ m", "20°",
#: "$\\varphi = 20^\\circ$", "5 kg", "-106.09 mm") once TeX's $ and braces are dropped, or it says
#: in words that it is drawn at the paper's values. "the values in the title" or "the study's s"
#: does neither: the reader has to look elsewhere for the inputs (issue 20.5).
NUMBER_WITH_UNIT = re.compile(
    r"(?<![\w.])[-+\u2212]?\d+(?:\.\d+)?\)?\s*(?:\\[,;]\s*)?"
    r"(?:°|\^\s*\\circ|deg\b|(?:mm|cm|m|rad|N\s?m|N|kg|s|Hz|%)(?:/[a-zA-Z]+(?:\^?2)?)?(?![A-Za-z]))"
)
AT_THE_PAPERS = re.compile(r"\bat the paper's (?:values|parameters|inputs|dimensions|pose|example pose)\b")


def states_its_values(caption):
    text = re.sub(r"[${}]", "", caption)
    return bool(NUMBER_WITH_UNIT.search(text) or AT_THE_PAPERS.search(text))


# --- sources -------------------------------------------------------------------------------------


#: A notebook tells the paper's story with calls to pkmlib: at most this many code lines (issue 22.4).
MAX_CODE_LINES = 300


def code_lines(nb_path):
    """The non-blank lines of a notebook's code cells (cell options and comments included)."""
    return sum(
        1
        for c in cells(nb_path)
        if c["cell_type"] == "code"
        for line in "".join(c["source"]).splitlines()
        if line.strip()
    )


@pytest.mark.parametrize("nb", NOTEBOOKS, ids=[nb.stem for nb in NOTEBOOKS])
def test_notebooks_are_at_most_300_code_lines(nb):
    assert code_lines(nb) <= MAX_CODE_LINES, f"{nb.name}: {code_lines(nb)} code lines; move computations into pkmlib"


def test_site_is_a_website_with_every_page_present():
    q = quarto()
    assert q["project"]["type"] == "website"
    pages = list(sidebar_pages(q["website"]["sidebar"]["contents"]))
    assert {"index.qmd", "scorecard.qmd", "library.qmd"} <= set(pages)
    for page in pages:
        assert (ROOT / page).exists(), page
    for nb in NOTEBOOKS:  # every notebook is a page of the site
        assert f"notebooks/{nb.name}" in pages, nb.name
    assert any(not is_paper(nb) for nb in NOTEBOOKS), "the library guide's tutorial notebook is missing"
    assert "scorecard.qmd" in q["project"]["render"]


def test_library_guide_lists_the_tutorial_and_every_reference_page():
    q = quarto()
    guide = next(
        item
        for item in q["website"]["sidebar"]["contents"]
        if isinstance(item, dict) and item.get("section") == "Library guide"
    )
    pages = list(sidebar_pages(guide["contents"]))
    assert pages[0] == "library.qmd"
    every_page = list(sidebar_pages(q["website"]["sidebar"]["contents"]))
    for nb in NOTEBOOKS:
        if not is_paper(nb):  # the tutorial in the guide, the design studies beyond the papers
            assert f"notebooks/{nb.name}" in every_page, nb.name
    assert "notebooks/tutorial_bring_your_own_mechanism.ipynb" in pages
    reference = sorted((ROOT / q["quartodoc"]["dir"]).glob("*.qmd"))
    assert reference, "run `.venv/bin/quartodoc build`"
    for page in reference:
        assert f"{q['quartodoc']['dir']}/{page.name}" in pages, page.name
    assert "reference/*.qmd" in q["project"]["render"]


def test_no_qmd_clobbers_a_notebook():
    for nb in NOTEBOOKS:
        assert not nb.with_suffix(".qmd").exists()


def test_every_notebook_has_front_matter_and_a_parameters_cell():
    for nb in NOTEBOOKS:
        cs = cells(nb)
        assert cs[0]["cell_type"] == "raw" and "".join(cs[0]["source"]).startswith("---\ntitle:"), nb.name
        tagged = [c for c in cs if "parameters" in c.get("metadata", {}).get("tags", [])]
        assert len(tagged) == 1, nb.name
        first_code = next(c for c in cs if c["cell_type"] == "code")
        assert first_code is tagged[0], f"{nb.name}: the parameters cell must be the first code cell"


@pytest.mark.parametrize("nb", [n for n in NOTEBOOKS if is_paper(n)], ids=lambda n: n.stem)
def test_paper_notebook_opens_with_the_verdict_box(nb):
    cs = cells(nb)
    first_md = next(c for c in cs[1:] if c["cell_type"] == "markdown")
    src = "".join(first_md["source"])
    assert cs[1] is first_md, f"{nb.name}: the verdict cell must come right after the front matter"
    assert src.startswith("::: {.callout-note") and "## Verdict" in src, f"{nb.name}: first cell is not the verdict box"
    assert f"{{{{< include ../data/results/_verdict_{paper_of(nb)}.md >}}}}" in src, nb.name


def test_figure_cells_follow_the_conventions():
    """No automatic numbers: a figure cell has `#| fig-cap` naming the paper's figure and no
    `#| label: fig-`; no `@fig-` reference; the figure is saved under figures/ and stored."""
    for nb in NOTEBOOKS:
        captions = 0
        for c in cells(nb):
            src = "".join(c["source"])
            if c["cell_type"] == "markdown":
                assert not re.search(r"@fig-[\w-]+", src), (
                    f"{nb.name}: refer to figures by the paper's number, not @fig-"
                )
                continue
            if c["cell_type"] != "code":
                continue
            opts = cell_options(c)
            assert not opts.get("label", "").startswith("fig-"), (
                f"{nb.name}: `#| label: {opts['label']}` makes Quarto number the figure; drop the label"
            )
            if re.search(r"^#\|\s*(label|fig-cap|tbl-cap)\b", src, re.M) and not opts:
                raise AssertionError(f"{nb.name}: cell options must be the first lines of the cell")
            if "fig-cap" in opts:
                captions += 1
                cap = opts["fig-cap"]
                if is_paper(nb):
                    m = PAPER_CAPTION.match(cap)
                    assert m, f"{nb.name}: caption {cap[:60]!r} must start 'Fig N (Pn). ' or 'Extra figure (Pn): '"
                    assert (m.group(2) or m.group(3)) == paper_of(nb).upper(), (
                        f"{nb.name}: {cap[:40]!r} names another paper"
                    )
                else:
                    assert TUTORIAL_CAPTION.match(cap), f"{nb.name}: caption {cap[:60]!r} must start 'Tutorial'"
                # saved in the cell, or by a notebook helper the cell hands the file name to (P3 Figs 13-15)
                assert "save_figure(" in src or re.search(r'"\w+\.png"', src), (
                    f"{nb.name}: {cap[:40]!r} must be saved under figures/"
                )
                assert any(o.get("output_type") == "display_data" for o in c.get("outputs", [])), (
                    f"{nb.name}: {cap[:40]!r} has no stored figure output"
                )
            dpi = re.search(r"figure\.dpi['\"]\s*\]\s*=\s*(\d+)", src)
            assert not dpi or int(dpi.group(1)) >= 100, (
                f"{nb.name}: figure.dpi = {dpi.group(1)} shrinks the stored images"
            )
        assert captions, f"{nb.name}: no captioned figure"


def test_cell_options_are_valid_yaml():
    """Quarto reads `#| key: value` as YAML: a double-quoted caption with LaTeX (`"$\\dot x$"`) is an
    invalid escape that stops the render; single quotes (or doubled backslashes) are needed."""
    for nb in NOTEBOOKS:
        for c in cells(nb):
            if c["cell_type"] != "code":
                continue
            lines = []
            for line in "".join(c["source"]).splitlines():
                if not line.startswith("#|"):
                    break
                lines.append(line[2:].strip())
            try:
                yaml.safe_load("\n".join(lines))
            except yaml.YAMLError as e:
                raise AssertionError(f"{nb.name}: cell options are not valid YAML: {lines[0][:60]!r}...: {e}") from None


def test_table_cells_are_labelled_markdown_tables():
    for nb in NOTEBOOKS:
        for c in cells(nb):
            if c["cell_type"] != "code":
                continue
            opts = cell_options(c)
            if opts.get("label", "").startswith("tbl-") or "tbl-cap" in opts:
                assert opts.get("label", "").startswith("tbl-") and opts.get("tbl-cap"), (
                    f"{nb.name}: a table cell needs both `#| label: tbl-...` and `#| tbl-cap`"
                )
                kinds = {k for o in c.get("outputs", []) for k in o.get("data", {})}
                assert kinds & {"text/markdown", "text/html"}, (
                    f"{nb.name}: {opts['label']} must show a Markdown table (pk.tools.markdown_table(...)), not printed text"
                )


def test_saved_figures_exist_and_carry_paper_and_figure_number():
    for nb in NOTEBOOKS:
        paper = nb.stem.split("_")[0]  # p1 .. p5, or the first word of another notebook (tutorial_, design_)
        names = re.findall(
            r'save_figure\(fig\w*, f"\{figures_dir\}/([\w.]+)"',
            "".join("".join(c["source"]) for c in cells(nb) if c["cell_type"] == "code"),
        )
        assert names, nb.name
        for name in names:
            pattern = rf"{paper}_(fig\d+[a-z]?|extra)_\w+\.png$" if is_paper(nb) else rf"{paper}_\w+\.png$"
            assert re.match(pattern, name), name
            assert (ROOT / "figures" / name).exists(), name


def test_every_map_figure_saves_its_arrays():
    """A figure that draws a map over a grid saves the arrays behind it beside its PNG
    (save_figure(..., arrays=...) writes figures/<name>.npz, issue 20.7): numbers only, each array
    named with its unit, and the PNG beside it."""
    import numpy as np

    missing = []
    for nb in NOTEBOOKS:
        for names, src in figure_cells(nb):
            if not DRAWS_A_MAP.search(src):
                continue
            for name in names:
                npz = ROOT / "figures" / f"{name}.npz"
                if "arrays=" not in src or not npz.exists():
                    missing.append(f"{nb.name}: {name}")
                    continue
                with np.load(npz, allow_pickle=False) as z:
                    assert z.files, f"{npz.name}: empty"
                    for key in z.files:
                        assert z[key].dtype.kind in "biuf", f"{npz.name}: {key} is not numbers"
    assert not missing, (
        f"{len(missing)} map figures without their arrays (save_figure(..., arrays=...)):\n" + "\n".join(missing)
    )


def test_paper_figure_captions_state_the_values_they_are_drawn_at():
    """Every figure caption of a paper's notebook states its inputs as the paper's captions do
    ("s = 0.14 m, phi = 20 deg"): at least one number with a unit, or "at the paper's values /
    parameters / ..." in words (states_its_values). A caption that sends the reader to "the values in
    the title" fails. (The titles name the run's own values, "not the paper's parameters" on a re-run.)"""
    assert states_its_values(r"Fig 2 (P1). $|\dot x_A|$ at $s = 0.14$ m, $\varphi = 20°$")
    assert states_its_values(r"at $\varphi = 20^\circ$") and states_its_values("a 5 kg payload")
    assert states_its_values("drawn at the paper's values") and states_its_values("0.05 m/N")
    assert not states_its_values("Fig 6a (P1). Gripper force for the drive force in the title.")
    assert not states_its_values("Fig 3 (P1). Workspace for the study's $s$ and $\\varphi$ (Fig 3, eq 6)")
    failing = []
    for nb in NOTEBOOKS:
        if not is_paper(nb):
            continue
        for c in cells(nb):
            cap = cell_options(c).get("fig-cap", "") if c["cell_type"] == "code" else ""
            if cap and not states_its_values(cap):
                failing.append(f"{nb.name}: {cap[:90]!r}")
    assert not failing, f"{len(failing)} captions state no value:\n" + "\n".join(failing)


def test_home_and_scorecard_pages_include_the_generated_markdown():
    assert "{{< include data/results/_summary.md >}}" in (ROOT / "index.qmd").read_text()
    assert "{{< include data/results/_reproduction.md >}}" in (ROOT / "scorecard.qmd").read_text()


def test_lock_does_not_need_quarto_and_publishing_uses_quarto_actions():
    assert not re.search(r"^quarto-cli", (ROOT / "environment.lock").read_text(), re.M | re.I)
    wf = (ROOT / ".github" / "workflows" / "publish.yml").read_text()
    assert "quarto-dev/quarto-actions/setup" in wf and "quarto-dev/quarto-actions/publish" in wf
    make = (ROOT / "Makefile").read_text()
    test_recipe = make[make.index("\ntest:") :].split("\n\n")[0]
    assert "scripts/tests_beside_render.sh" in test_recipe and " tests" in test_recipe, "make test must render the site"
    beside = (ROOT / "scripts" / "tests_beside_render.sh").read_text()
    assert "bash scripts/render_site.sh" in beside and "-m pytest" in beside, "the render beside the unit tests"


def test_qmd_pages_have_front_matter_and_resolvable_references():
    """Every .qmd page of the site (the reference pages included): a title, and each @fig-/@tbl- reference labelled on the same
    page (Quarto resolves cross-references within a page of a website); links to local files exist."""
    pages = [p for p in sidebar_pages(quarto()["website"]["sidebar"]["contents"]) if p.endswith(".qmd")]
    assert pages
    for page in pages:
        text = (ROOT / page).read_text()
        titled = (text.startswith("---\n") and "\ntitle:" in text.split("---")[1]) or text.startswith("# ")
        assert titled, f"{page}: no title (front matter or a leading '# ' heading, as quartodoc writes)"
        refs = set(re.findall(r"@((?:fig|tbl)-[\w-]+)", text))
        labels = set(re.findall(r"#\|\s*label:\s*((?:fig|tbl)-[\w-]+)", text)) | set(
            re.findall(r"\{#((?:fig|tbl)-[\w-]+)", text)
        )
        assert refs <= labels, f"{page}: unresolved {refs - labels}"
        for link in re.findall(r"\]\(([^)#\s]+\.(?:qmd|ipynb|md|png))", text):
            assert (ROOT / Path(page).parent / link).exists(), f"{page}: broken link {link}"


def bib_entries():
    text = (ROOT / "references.bib").read_text()
    entries = {}
    for m in re.finditer(r"@(\w+)\{(\w+),(.*?)\n\}", text, re.S):
        entries[m.group(2)] = dict(re.findall(r"(\w+)\s*=\s*\{(.*?)\},?\s*\n", m.group(3) + "\n"))
    return entries


def test_bibliography_has_the_five_papers():
    assert quarto()["bibliography"] == "references.bib"
    entries = bib_entries()
    assert set(entries) == set(CITATION_KEYS.values())
    for key, e in entries.items():
        for field in ("author", "title", "journal", "year", "pages"):
            assert e.get(field), f"{key}: no {field}"
        assert e.get("doi") or e.get("url", "").startswith("https://"), f"{key}: no DOI or URL"
    # the only paper whose text prints neither a DOI nor a URL: its link is its journal's page, and its note says so
    assert "prints no DOI" in entries["kheylo2022"]["note"] and "journal's page" in entries["kheylo2022"]["note"]


def test_licence_and_citation_file():
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    licence = (ROOT / "LICENSE").read_text()
    assert licence.startswith("MIT License") and "pkmlib developers" in licence
    assert "WITHOUT WARRANTY OF ANY KIND" in licence
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["cff-version"] == "1.2.0" and cff["message"]
    assert cff["title"] == "pkmlib" and cff["license"] == "MIT" and str(cff["version"]) == version
    assert cff["authors"] == [{"name": "pkmlib developers"}]
    assert cff.get("type", "software") == "software"


def test_build_stamp_names_the_commit_when_only_ignored_or_unrelated_files_differ(tmp_path):
    """A clean tree, or one where only ignored files (_site/, .jax_cache/) or files the site is not
    built from (tests/) differ, is stamped with the commit alone; a changed source names the file."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("site_build", ROOT / "scripts" / "site_build.py")
    sb = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(sb)
    git = shutil.which("git")
    if git is None:
        pytest.skip("no git")
    repo = tmp_path / "repo"
    (repo / "data").mkdir(parents=True)
    (repo / "tests").mkdir()
    (repo / "data" / "x.json").write_text("{}\n")
    (repo / "tests" / "t.py").write_text("a\n")
    (repo / ".gitignore").write_text("_site/\n")
    env = {
        "GIT_AUTHOR_NAME": "t",
        "GIT_AUTHOR_EMAIL": "t@t",
        "GIT_COMMITTER_NAME": "t",
        "GIT_COMMITTER_EMAIL": "t@t",
        "PATH": str(Path(git).parent),
        "HOME": str(tmp_path),
    }
    for args in (["init", "-q"], ["add", "-A"], ["commit", "-qm", "x"]):
        subprocess.run([git, *args], cwd=repo, check=True, env=env, capture_output=True)
    sb.ROOT = repo
    head = subprocess.run(
        [git, "rev-parse", "--short=12", "HEAD"], cwd=repo, capture_output=True, text=True, check=True
    ).stdout.strip()
    assert sb.commit() == head
    (repo / "_site").mkdir()
    (repo / "_site" / "index.html").write_text("x")
    (repo / "tests" / "t.py").write_text("b\n")
    assert sb.commit() == head, "ignored or non-site files made the stamp say +modified"
    (repo / "data" / "x.json").write_text('{"a": 1}\n')
    assert sb.commit() == f"{head}+modified (data/x.json)"


def test_build_outputs_are_git_ignored():
    ignored = (ROOT / ".gitignore").read_text().splitlines()
    for entry in ("/_variables.yml", ".quarto-tools", "/.quarto/", "_site/", "/.nbexec/"):
        assert entry in ignored, entry


# --- the rendered site ---------------------------------------------------------------------------


def _quarto_available():
    return (
        (ROOT.parent / "shared" / "quarto").is_dir()
        or (ROOT / ".quarto-tools" / "bin" / "quarto").exists()
        or shutil.which("quarto") is not None
    )


def _sources():
    globs = [
        "notebooks/*.ipynb",
        "*.qmd",
        "reference/*.qmd",
        "_quarto.yml",
        "references.bib",
        "data/results/*.md",
        "figures/*.png",
        "figures/*.npz",
        "scripts/*",
    ]
    return [p for g in globs for p in ROOT.glob(g)]


class Site:
    def __init__(self, root):
        self.root = root
        self._cache = {}
        self._ids = {}

    def page(self, rel):
        from bs4 import BeautifulSoup

        rel = str(rel)
        if rel not in self._cache:
            path = self.root / rel
            assert path.exists(), f"{rel} was not rendered"
            self._cache[rel] = BeautifulSoup(path.read_text(encoding="utf-8"), "html.parser")
        return self._cache[rel]

    def ids(self, rel):
        """The ids of the elements of page ``rel``, read once per page (a page's links point into
        a few pages, hundreds of times)."""
        rel = str(rel)
        if rel not in self._ids:
            self._ids[rel] = frozenset(el["id"] for el in self.page(rel).find_all(id=True))
        return self._ids[rel]

    def pages(self):
        return sorted(str(p.relative_to(self.root)) for p in self.root.rglob("*.html") if "site_libs" not in p.parts)


@pytest.fixture(scope="module")
def site():
    wait_for_render()  # make test renders beside the unit tests (tests/_site.py)
    if not _quarto_available():
        pytest.skip(
            "Quarto not found (neither ../shared/quarto, .quarto-tools/bin/quarto nor `quarto` on PATH): "
            "the rendered-site tests need it; install it from https://quarto.org/docs/get-started/"
        )
    # a bare pytest renders a stale _site/ first; under make test the render beside the tests is the
    # one (a second would remove the pages, and the render's status, that other workers are reading)
    newest = max(p.stat().st_mtime for p in _sources())
    beside = bool(os.environ.get("PKMLIB_RENDER_STATUS"))
    if not beside and (not RENDER_LOG.exists() or RENDER_LOG.stat().st_mtime < newest):
        run = subprocess.run(["bash", "scripts/render_site.sh"], cwd=ROOT, capture_output=True, text=True)
        if run.returncode == 3:
            pytest.skip(f"no Quarto: {run.stderr.strip()}")
        assert run.returncode == 0, f"quarto render failed or warned:\n{run.stderr[-4000:]}"
    return Site(SITE)


def html_of(page):
    """The rendered HTML path of a source page (notebooks/p1.ipynb -> notebooks/p1.html)."""
    return str(Path(page).with_suffix(".html"))


PAPER_PAGES = [f"notebooks/{nb.stem}.html" for nb in NOTEBOOKS if is_paper(nb)]
NOTEBOOK_PAGES = [f"notebooks/{nb.stem}.html" for nb in NOTEBOOKS]


def main_of(soup):
    return soup.find("main") or soup


def test_render_printed_no_warning(site):
    log = RENDER_LOG.read_text()
    assert "Output created" in log
    bad = [ln for ln in log.splitlines() if re.search(r"WARN|\[WARNING\]|ERROR|Unable to resolve", ln)]
    assert not bad, "quarto render warned:\n" + "\n".join(bad)


def test_every_page_is_rendered_without_unresolved_references(site):
    for page in sidebar_pages(quarto()["website"]["sidebar"]["contents"]):
        soup = site.page(html_of(page))
        text = main_of(soup).get_text(" ")
        assert "?@" not in text, f"{page}: unresolved cross-reference"
        assert not soup.select(".quarto-unresolved-ref"), f"{page}: unresolved cross-reference"
        assert "?var:" not in soup.get_text(" "), f"{page}: unresolved {{< var >}}"
        assert not re.search(r"\?\?|\[@\w+\]|\{\{<", text), f"{page}: an unprocessed citation or shortcode"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES + ["index.html", "scorecard.html"])
def test_no_automatic_figure_numbers(site, page):
    soup = site.page(page)
    for cap in main_of(soup).find_all("figcaption"):
        assert not AUTOMATIC_NUMBER.search(cap.get_text(" ")), (
            f"{page}: Quarto numbered a figure: {cap.get_text()[:80]!r}"
        )
    numbered = [
        el.get("id")
        for el in main_of(soup).find_all(id=re.compile(r"^fig-"))
        if el.name not in ("section", "h1", "h2", "h3", "h4", "h5", "h6")
    ]  # a heading "Fig 1: ..." is fine
    assert not numbered, f"{page}: figures with crossref ids (numbered by Quarto): {numbered[:5]}"
    assert not re.search(r"\bFigure\s\d+", main_of(soup).get_text(" ")), f"{page}: 'Figure N' in the text"


def figure_images(soup):
    return [img for img in main_of(soup).find_all("img") if "figure-html" in img.get("src", "")]


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_every_figure_carries_the_papers_number(site, page):
    soup = site.page(page)
    paper = Path(page).name[:2].upper()
    images = figure_images(soup)
    assert images, f"{page}: no figure"
    for img in images:
        fig = img.find_parent("figure")
        cap = fig.find("figcaption") if fig else None
        assert cap is not None, f"{page}: {img['src']} has no caption"
        text = " ".join(cap.get_text(" ").split())
        if page.startswith("notebooks/p"):
            m = PAPER_CAPTION.match(text)
            assert m and (m.group(2) or m.group(3)) == paper, f"{page}: caption {text[:70]!r} lacks 'Fig N ({paper}).'"
        else:
            assert TUTORIAL_CAPTION.match(text), f"{page}: caption {text[:70]!r}"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_every_figure_links_the_arrays_behind_it(site, page):
    """Each figure cell on the page is marked with the figures it saves (scripts/figure_arrays.lua);
    a figure whose figures/<name>.npz exists has the link "arrays (.npz)" under it, in its cell, and
    the file is published in _site/figures/ as it is in the repository; one without has no link."""
    nb = ROOT / "notebooks" / Path(page).with_suffix(".ipynb").name
    main = main_of(site.page(page))
    for names, _src in figure_cells(nb):
        for name in names:
            cell = main.find("div", class_="cell", attrs={"data-figures": re.compile(rf"(^| ){name}( |$)")})
            assert cell is not None, f"{page}: no cell marked as saving {name} (scripts/figure_arrays.lua)"
            assert cell.find("img"), f"{page}: the cell saving {name} shows no image"
            npz = ROOT / "figures" / f"{name}.npz"
            link = cell.find("a", class_="figure-arrays", href=f"../figures/{name}.npz")
            if npz.exists():
                assert link is not None and "arrays (.npz)" in link.get_text(), f"{page}: {name}: no arrays link"
                published = SITE / "figures" / f"{name}.npz"
                assert published.exists() and published.read_bytes() == npz.read_bytes(), (
                    f"_site/figures/{name}.npz is not figures/{name}.npz"
                )
            else:
                assert link is None, f"{page}: {name}: a link to arrays that do not exist"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_every_figure_is_stored_at_a_legible_size(site, page):
    for img in figure_images(site.page(page)):
        png = (SITE / Path(page).parent / unquote(img["src"])).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n", f"{page}: {img['src']} is not a PNG"
        width, height = struct.unpack(">II", png[16:24])
        least = MIN_FULL_WIDTH_PX if width >= FULL_WIDTH_ASPECT * height else MIN_FIGURE_PX
        assert width >= least, f"{page}: {img['src']} is {width} x {height} px (< {least} px wide): too small to read"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES + ["index.html", "scorecard.html"])
def test_every_table_has_a_caption_and_a_tbl_id(site, page):
    soup = site.page(page)
    tables = main_of(soup).find_all("table")
    if page.startswith("notebooks/"):
        tables = [t for t in tables if t.find_parent("div", class_="cell-output")]
    for t in tables:
        holder = t.find_parent(id=re.compile(r"^tbl-"))
        head = " ".join(t.get_text(" ").split())[:60]
        assert holder is not None, f"{page}: a table without a tbl- id: {head!r}"
        cap = holder.find(["figcaption", "caption"])
        assert cap is not None and cap.get_text(strip=True), f"{page}: table {holder['id']} has no caption"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_no_output_block_is_longer_than_30_lines(site, page):
    for pre in main_of(site.page(page)).select("div.cell-output pre"):
        lines = pre.get_text().rstrip("\n").splitlines()
        assert len(lines) <= MAX_OUTPUT_LINES, (
            f"{page}: an output of {len(lines)} lines (make it a table or shorten it): {lines[0][:60]!r}"
        )
        rules = [ln for ln in lines if re.match(r"^\s*-{3,}(\s+-{3,})+\s*$", ln)]
        assert not rules, (
            f"{page}: a printed text table (make it pk.tools.markdown_table with a tbl- label): {lines[0][:60]!r}"
        )


def _check_link(site, page, href):
    parts = urlsplit(href)
    if parts.scheme or parts.netloc or href.startswith("mailto:"):
        return
    target = (Path(page).parent / unquote(parts.path)) if parts.path else Path(page)
    target = Path(*[p for p in target.parts])  # keep relative
    resolved = (SITE / target).resolve()
    assert resolved.exists(), f"{page}: broken link {href}"
    if parts.fragment and resolved.suffix == ".html":
        rel = resolved.relative_to(SITE.resolve())
        assert parts.fragment in site.ids(rel), f"{page}: link {href}: no #{parts.fragment} in {rel}"


@pytest.mark.parametrize("page", NOTEBOOK_PAGES + ["index.html", "scorecard.html"])
def test_every_link_in_the_content_resolves(site, page):
    for a in main_of(site.page(page)).find_all("a", href=True):
        _check_link(site, page, a["href"])


@pytest.mark.parametrize("page", PAPER_PAGES)
def test_paper_page_opens_with_a_verdict_box(site, page):
    main = main_of(site.page(page))
    callout = main.select_one("div.callout")
    assert callout is not None and "Verdict" in callout.get_text(" "), f"{page}: no verdict box"
    first_heading = main.find("h2")
    assert first_heading is None or callout.sourceline < first_heading.sourceline, (
        f"{page}: the verdict box must come before the first section"
    )
    text = " ".join(callout.get_text(" ").split())
    assert re.search(r"\d+ reproduced, \d+ errat", text), f"{page}: the verdict box has no count line"
    failures = callout.select(".verdict-failures li")
    claims = callout.select(".verdict-main li")
    assert 1 <= len(claims) <= 8, f"{page}: {len(claims)} main claims in the verdict box"
    if failures:  # what is not reproduced comes first
        assert failures[0].sourceline < claims[0].sourceline, f"{page}: the failures must lead the verdict box"
    for li in failures + claims:
        line = " ".join(li.get_text(" ").split())
        assert re.search(
            r"paper .+, ours .+: (reproduced|erratum|explained difference|differs|consistency check|"
            r"by construction)",
            line,
        ), line
        assert li.find("a", href=re.compile(r"scorecard\.html#p\d-")), (
            f"{page}: verdict line without its scorecard row: {line[:60]!r}"
        )
    for li in failures:
        line = " ".join(li.get_text(" ").split())
        assert re.search(r": (erratum|explained difference|differs)\b", line), line
    for summary in callout.select("details summary"):  # a shortened quote: the whole of it one click away
        full = summary.find_parent("details").get_text(" ")
        assert len(full) > len(summary.get_text()), page
    for a in callout.find_all("a", href=True):
        _check_link(site, page, a["href"])


@pytest.mark.parametrize("page", PAPER_PAGES)
def test_paper_page_cites_its_paper(site, page):
    soup = site.page(page)
    key = CITATION_KEYS[Path(page).name[:2]]
    entry = soup.select_one(f"#refs #ref-{key}")
    assert entry is not None, f"{page}: no bibliography entry for {key} (cite [@{key}] in the introduction)"
    assert soup.select_one(f'a[href="#ref-{key}"]'), f"{page}: the text never cites [@{key}]"
    assert entry.find("a", href=re.compile(r"^https?://")), f"{page}: the reference to {key} has no DOI or URL link"
    header = soup.select_one("div.source-links a.paper-link[href]")
    assert header is not None and header["href"].startswith("https://"), (
        f"{page}: the page header does not link the paper"
    )


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_notebook_page_links_its_source(site, page):
    link = site.page(page).select_one("a.notebook-source")
    assert link is not None, f"{page}: no link to the notebook source"
    name = Path(page).with_suffix(".ipynb").name
    assert Path(link["href"]).name == name, link["href"]
    copied = (SITE / Path(page).parent / link["href"]).resolve()
    assert copied.read_bytes() == (ROOT / "notebooks" / name).read_bytes(), (
        f"{page}: the linked notebook is not the source"
    )


def test_every_page_carries_the_build_stamp(site):
    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    pages = site.pages()
    assert len(pages) >= len(NOTEBOOKS) + 3
    for page in pages:
        footer = site.page(page).select_one("footer .nav-footer")
        assert footer is not None, f"{page}: no footer"
        text = " ".join(footer.get_text(" ").split())
        m = re.search(
            r"Built from commit ([0-9a-f]{7,}(\+modified \([^)]+\))?|unknown[^)]*\)) on (\d{4}-\d\d-\d\d \d\d:\d\d UTC) "
            r"with pkmlib (\S+) and JAX (\d[\w.]*)",
            text,
        )
        assert m, f"{page}: no build stamp in the footer: {text[:120]!r}"
        assert m.group(4) == version, f"{page}: stamp says pkmlib {m.group(4)}, pyproject {version}"


def test_home_page_shows_counts_thumbnails_and_links(site):
    from pkmlib.tools.report import load_reference, load_results, scorecard

    soup = site.page("index.html")
    main = main_of(soup)
    table = main.select_one("#tbl-home-counts table")
    assert table is not None, "index: no counts table"
    from pkmlib.tools.report import STATUSES, statements

    card = scorecard(load_reference(), load_results())
    heads = [th.get_text(strip=True) for th in table.select("thead th")]
    assert heads[-2:] == ["statements", "rows (numbers)"], heads
    rows = {
        tr.find("td").find("a").get_text(strip=True): [td.get_text(strip=True) for td in tr.find_all("td")]
        for tr in table.select("tbody tr")
        if tr.find("td").find("a")
    }
    columns = {
        "reproduced": "reproduced",
        "errata": "erratum",
        "explained differences": "explained difference",
        "differs": "differs",
        "consistency checks": "consistency check",
        "by construction": "by construction",
    }
    for paper, prows in card.items():
        st = statements(prows)
        counts = dict.fromkeys(STATUSES, 0)
        for _, status, _ in st:
            counts[status] += 1
        cells = rows[paper.upper()]
        for i, head in enumerate(heads[1:-2], start=1):
            assert int(cells[i]) == counts[columns[head]], f"{paper}: {head}"
        assert int(cells[-2]) == len(st) and int(cells[-1]) == len(prows), paper
        assert sum(int(c) for c in cells[1:-2]) == len(st), paper
    thumbs = [a for a in main.find_all("a", href=True) if a.find("img")]
    targets = {Path(a["href"]).name for a in thumbs}
    assert {Path(p).name for p in PAPER_PAGES} <= targets, f"index: a thumbnail per paper page, found {targets}"
    for a in thumbs:
        assert "figures/" in a.find("img")["src"]


def test_scorecard_page_has_every_row_with_a_permalink_and_a_visible_reason(site):
    from pkmlib.tools.report import load_reference, load_results, row_id, scorecard

    main = main_of(site.page("scorecard.html"))
    card = scorecard(load_reference(), load_results())
    for paper, rows in card.items():
        table = main.select_one(f"#tbl-scorecard-{paper} table")
        assert table is not None, f"scorecard: no table for {paper}"
        heads = [th.get_text(" ", strip=True) for th in table.select("thead th")]
        assert heads == [
            "#",
            "quantity",
            "paper, as printed",
            "ours, in the paper's form",
            "difference",
            "tolerance",
            "status",
            "reason",
        ], heads
        trs = table.select("tbody tr")
        assert [tr["id"] for tr in trs] == [row_id(paper, r["quantity"]) for r in rows], f"{paper}: rows or ids"
        for tr, r in zip(trs, rows):
            tds = tr.find_all("td")
            assert tds[0].find("a", href=f"#{tr['id']}"), f"{paper}: row {tr['id']} has no permalink"
            status, reason = tds[6].get_text(strip=True), tds[7]
            assert status == r["status"]
            if status not in ("reproduced",):
                link = reason.find("a", href=True)
                assert link is not None and ".html#" in link["href"], (
                    f"scorecard {paper}: {r['quantity']!r} ({status}) links no section"
                )
            if r.get("note"):
                assert r["note"][:40] in " ".join(reason.get_text(" ").split()), f"{paper}: the reason is not visible"
            assert "title" not in (reason.find("a") or {}).attrs if reason.find("a") else True
    assert (SITE / "data" / "results" / "_scorecard.csv").exists() and (
        SITE / "data" / "results" / "_scorecard.json"
    ).exists()
    assert main.find("a", href="data/results/_scorecard.csv") and main.find("a", href="data/results/_scorecard.json")


def test_reference_and_results_are_published(site):
    for folder in ("reference", "results"):
        for src in (ROOT / "data" / folder).glob("*.json"):
            assert (SITE / "data" / folder / src.name).read_bytes() == src.read_bytes(), f"data/{folder}/{src.name}"


def test_render_script_without_quarto_says_so_and_exits_3(tmp_path):
    """Where no Quarto can be found, scripts/render_site.sh renders nothing, removes the
    'rendered' marker (so the site tests skip instead of reading a stale _site) and exits 3."""
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "render_site.sh", tmp_path / "scripts")
    (tmp_path / "_site").mkdir()
    (tmp_path / "_site" / ".render.log").write_text("old\n")
    bash = shutil.which("bash")
    run = subprocess.run(
        [bash, "scripts/render_site.sh"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={"PATH": str(Path(bash).parent), "HOME": str(tmp_path)},
    )
    if (tmp_path.parent / "shared" / "quarto").exists() or "quarto" in run.stdout:
        pytest.skip("a Quarto is reachable from the temporary folder")
    assert run.returncode == 3, run.stderr
    assert "no Quarto" in run.stderr
    assert not (tmp_path / "_site" / ".render.log").exists()


@pytest.mark.parametrize("page", PAPER_PAGES)
def test_a_papers_table_keeps_its_number(site, page):
    """Quarto numbers tables per page; a table that is the paper's own ("P3 Table 2. ...") must be
    that table on the page too ("Table 2: P3 Table 2. ..."), so the reader sees one number."""
    for holder in main_of(site.page(page)).select('div[id^="tbl-"]'):
        cap = " ".join(holder.find("figcaption").get_text(" ").split()) if holder.find("figcaption") else ""
        m = re.match(r"^Table\s(\d+):\sP\d Table (\d+)\.", cap)
        if m:
            assert m.group(1) == m.group(2), (
                f"{page}: {cap[:50]!r}: the paper's Table {m.group(2)} is numbered {m.group(1)}"
            )


@pytest.mark.parametrize("page", PAPER_PAGES)
def test_each_scorecard_row_lives_on_the_scorecard_page_only(site, page):
    """Issue 20.9: a paper page links its scorecard rows and repeats none of them. The page's
    reproductions of the paper's tables (paper beside ours) may show a row's status only as a link
    to that row's permalink on the scorecard; no element of the page carries a row's id, and the
    page links its full scorecard. (The list of the paper's figures, ``details.figure-list``, has
    statuses of its own: figures, not scorecard rows.)"""
    from pkmlib.tools.report import STATUSES, load_reference, load_results, row_id, scorecard

    main = main_of(site.page(page))
    paper = Path(page).name[:2]
    rows = scorecard(load_reference(), load_results())[paper]
    own = {row_id(paper, r["quantity"]) for r in rows}
    assert own, paper
    figure_list = main.select_one("details.figure-list")
    for table in main.find_all("table"):
        if figure_list is not None and table in figure_list.find_all("table"):
            continue
        for td in table.find_all(["td", "th"]):
            text = " ".join(td.get_text(" ").split())
            if text.split(" (")[0] not in STATUSES:
                continue
            link = td.find("a", href=True)
            assert link is not None, (
                f"{page}: a table repeats a scorecard row's status ({text!r}): link the row instead"
            )
            target = urlsplit(link["href"])
            assert target.path.endswith("scorecard.html") and target.fragment in own, (
                f"{page}: a status links {link['href']!r}, not one of {paper}'s scorecard rows"
            )
    ids = {tag["id"] for tag in main.find_all(id=True)}
    assert not ids & own, f"{page}: scorecard rows repeated on the page: {sorted(ids & own)[:3]}"
    assert main.find("a", href=re.compile(rf"scorecard\.html#{paper}$")), f"{page}: no link to its full scorecard"


@pytest.mark.parametrize(
    "render_rc, pytest_ok, want_rc, said",
    [
        (0, True, 0, "rendered"),
        (0, False, 1, "rendered"),
        (3, True, 0, "no Quarto: the rendered-site tests skipped"),
        (1, True, 1, "render_site.sh failed (exit 1)"),
    ],
)
def test_the_render_beside_the_unit_tests_fails_the_step_when_it_fails(tmp_path, render_rc, pytest_ok, want_rc, said):
    """scripts/tests_beside_render.sh (make test's unit-test step): its exit status is pytest's
    unless the render failed, which fails the step and prints the render's output; the tests saw
    the render's exit status in the file PKMLIB_RENDER_STATUS names."""
    (tmp_path / "scripts").mkdir()
    shutil.copy(ROOT / "scripts" / "tests_beside_render.sh", tmp_path / "scripts")
    (tmp_path / "scripts" / "render_site.sh").write_text(
        f"sleep 0.5; echo 'render output'; echo rendered; exit {render_rc}\n"
    )
    fake = tmp_path / "fake_python"  # stands for pytest: records the status the tests would read
    fake.write_text(
        '#!/usr/bin/env bash\nwhile [ ! -f "$PKMLIB_RENDER_STATUS" ]; do sleep 0.1; done\n'
        f'cat "$PKMLIB_RENDER_STATUS" > seen_status; exit {0 if pytest_ok else 1}\n'
    )
    fake.chmod(0o755)
    run = subprocess.run(
        ["bash", "scripts/tests_beside_render.sh", "tests"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHON": str(fake)},
        timeout=60,
    )
    assert run.returncode == want_rc, (run.stdout, run.stderr)
    assert said in run.stdout + run.stderr
    assert (tmp_path / "seen_status").read_text().strip() == str(render_rc)
    if render_rc not in (0, 3):
        assert "render output" in run.stderr  # the render's own words, for the reader of the log


@pytest.mark.parametrize("rc", [0, 3, 1])
def test_site_tests_wait_for_the_render_and_read_its_status(tmp_path, monkeypatch, rc):
    """tests/_site.py: returns once the status file says 0, skips on 3 (no Quarto), fails with the
    render's output otherwise, and fails when no status comes in time."""
    from _site import wait_for_render

    status = tmp_path / ".render.status"
    monkeypatch.setenv("PKMLIB_RENDER_STATUS", str(status))
    with pytest.raises(pytest.fail.Exception, match="did not end"):
        wait_for_render(timeout=0.2)
    (tmp_path / ".render.out").write_text("quarto said: WARN something\n")
    status.write_text(f"{rc}\n")
    if rc == 0:
        assert wait_for_render(timeout=1.0) is None
    elif rc == 3:
        with pytest.raises(pytest.skip.Exception, match="no Quarto: quarto said"):
            wait_for_render(timeout=1.0)
    else:
        with pytest.raises(pytest.fail.Exception, match="(?s)exit 1.*quarto said: WARN"):
            wait_for_render(timeout=1.0)
