"""What can be checked of the Quarto site without Quarto: pages, labels, cross-references,
figure captions, parameters cells, and that the stored results and figures are there."""

import json
import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
OPTION = re.compile(r"^#\|\s*([\w-]+):\s*(.*)$")
PAPER_NOTEBOOK = re.compile(r"p\d_")  # pN_<name>.ipynb; any other notebook is a tutorial


def is_paper(nb_path):
    return bool(PAPER_NOTEBOOK.match(nb_path.name))


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
    """The leading `#| key: value` lines of a code cell (Quarto reads only those)."""
    opts = {}
    for line in "".join(cell["source"]).splitlines():
        m = OPTION.match(line)
        if not m:
            break
        opts[m.group(1)] = m.group(2)
    return opts


def test_site_is_a_website_with_every_page_present():
    q = quarto()
    assert q["project"]["type"] == "website"
    pages = list(sidebar_pages(q["website"]["sidebar"]["contents"]))
    assert "index.qmd" in pages and "library.qmd" in pages
    for page in pages:
        assert (ROOT / page).exists(), page
    for nb in NOTEBOOKS:  # every notebook is a page of the site
        assert f"notebooks/{nb.name}" in pages, nb.name
    assert any(not is_paper(nb) for nb in NOTEBOOKS), "the library guide's tutorial notebook is missing"


def test_library_guide_lists_the_tutorial_and_every_reference_page():
    q = quarto()
    guide = next(item for item in q["website"]["sidebar"]["contents"]
                 if isinstance(item, dict) and item.get("section") == "Library guide")
    pages = list(sidebar_pages(guide["contents"]))
    assert pages[0] == "library.qmd"
    for nb in NOTEBOOKS:
        if not is_paper(nb):
            assert f"notebooks/{nb.name}" in pages, nb.name
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


def test_figure_labels_captions_and_cross_references():
    for nb in NOTEBOOKS:
        labels, refs = set(), set()
        for c in cells(nb):
            src = "".join(c["source"])
            if c["cell_type"] == "markdown":
                refs |= set(re.findall(r"@(fig-[\w-]+)", src))
            elif c["cell_type"] == "code":
                opts = cell_options(c)
                assert "fig-" not in src.split("\n")[0] or "label" in opts
                if opts.get("label", "").startswith("fig-"):
                    label = opts["label"]
                    assert label not in labels, f"{nb.name}: duplicate {label}"
                    labels.add(label)
                    cap = opts.get("fig-cap", "")
                    if is_paper(nb):
                        assert re.search(r"P\d (Fig \d+[a-z]?|beyond the paper)\.", cap), \
                            f"{nb.name}: {label} caption must name the paper's figure (or say 'beyond the paper')"
                    else:
                        assert label.startswith("fig-tutorial-"), f"{nb.name}: {label} must start with fig-tutorial-"
                        assert cap.strip('"').startswith("Tutorial. "), f"{nb.name}: {label} caption must start with 'Tutorial.'"
                    assert "save_figure(" in src, f"{nb.name}: {label} must be saved under figures/"
                    assert any(o.get("output_type") == "display_data" for o in c.get("outputs", [])), \
                        f"{nb.name}: {label} has no stored figure output"
                elif "#| label" in src or "#| fig-cap" in src:
                    raise AssertionError(f"{nb.name}: cell options must be the first lines of the cell")
        assert labels, nb.name
        assert refs <= labels, f"{nb.name}: references without a label: {refs - labels}"
        assert labels <= refs, f"{nb.name}: figures never referenced in the text: {labels - refs}"


def test_saved_figures_exist_and_carry_paper_and_figure_number():
    for nb in NOTEBOOKS:
        paper = nb.stem.split("_")[0]
        names = re.findall(r'save_figure\(fig, f"\{figures_dir\}/([\w.]+)"', "".join(
            "".join(c["source"]) for c in cells(nb) if c["cell_type"] == "code"))
        assert names
        for name in names:
            pattern = rf"{paper}_(fig\d+[a-z]?|extra)_\w+\.png$" if is_paper(nb) else r"tutorial_\w+\.png$"
            assert re.match(pattern, name), name
            assert (ROOT / "figures" / name).exists(), name


def test_home_page_includes_the_reproduction_table():
    assert "{{< include data/results/_reproduction.md >}}" in (ROOT / "index.qmd").read_text()


def test_ci_and_lock_do_not_need_quarto():
    assert "quarto" not in (ROOT / ".ci" / "run").read_text()
    assert not re.search(r"^quarto-cli", (ROOT / "environment.lock").read_text(), re.M | re.I)
    wf = (ROOT / ".github" / "workflows" / "publish.yml").read_text()
    assert "quarto-dev/quarto-actions/setup" in wf and "quarto-dev/quarto-actions/publish" in wf


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
        labels = set(re.findall(r"#\|\s*label:\s*((?:fig|tbl)-[\w-]+)", text)) | set(re.findall(r"\{#((?:fig|tbl)-[\w-]+)", text))
        assert refs <= labels, f"{page}: unresolved {refs - labels}"
        for link in re.findall(r"\]\(([^)#\s]+\.(?:qmd|ipynb|md))", text):
            assert (ROOT / Path(page).parent / link).exists(), f"{page}: broken link {link}"
