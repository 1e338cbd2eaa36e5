"""The scorecard: data/reference (what the papers print) against data/results (what the
notebooks compute). A row that was reproduced must stay reproduced."""

import pytest

from pkmlib._results import DIFFERS, ERRATUM, REPRODUCED
from pkmlib.report import MARKDOWN, load_reference, load_results, markdown_table, score_row, scorecard

REFERENCE = load_reference()
RESULTS = load_results()
PAPERS = sorted(REFERENCE)


def test_every_paper_has_a_reference_and_results():
    assert PAPERS == ["p1", "p2", "p3", "p4", "p5"]
    assert set(PAPERS) <= set(RESULTS)


@pytest.mark.parametrize("paper", PAPERS)
def test_reference_and_results_name_the_same_quantities_with_the_same_paper_values(paper):
    ref = {e["quantity"]: e for e in REFERENCE[paper]["numbers"]}
    res = {r["quantity"]: r for r in RESULTS[paper]["reproduction"]}
    assert set(ref) == set(res), f"{paper}: notebook rows and reference differ: {set(ref) ^ set(res)}"
    for q, e in ref.items():
        assert res[q]["paper"] == e["paper"], f"{paper} {q}: the notebook compares with another paper value"
        assert e["source"], f"{paper} {q}: no source"
        assert e["tolerance_basis"], f"{paper} {q}: no tolerance basis"
        if e["expected_status"] == ERRATUM:
            assert e.get("erratum"), f"{paper} {q}: an erratum must say why"


@pytest.mark.parametrize("paper", PAPERS)
def test_no_row_falls_from_its_expected_status(paper):
    for row in scorecard(REFERENCE, RESULTS)[paper]:
        if row["expected_status"] == REPRODUCED:
            assert row["status"] == REPRODUCED, f"{paper} {row['quantity']}: {row['status']}, was reproduced"
        elif row["expected_status"] == ERRATUM:
            assert row["status"] in (ERRATUM, REPRODUCED), f"{paper} {row['quantity']}: {row['status']}"


def test_status_is_recomputed_from_the_reference_tolerance():
    ref = {"quantity": "q", "paper": 1.0, "printed": "1.0", "source": "s", "rel_tol": 0.0, "abs_tol": 0.05,
           "expected_status": REPRODUCED}
    assert score_row(ref, {"quantity": "q", "paper": 1.0, "ours": 1.04, "status": DIFFERS})["status"] == REPRODUCED
    assert score_row(ref, {"quantity": "q", "paper": 1.0, "ours": 1.06, "status": REPRODUCED})["status"] == DIFFERS
    assert score_row(ref | {"erratum": "why"}, {"quantity": "q", "paper": 1.0, "ours": 2.0,
                                                "status": DIFFERS})["status"] == ERRATUM
    assert score_row(ref, None)["status"] == "missing"


def test_markdown_table_is_current():
    assert MARKDOWN.read_text() == markdown_table(scorecard(REFERENCE, RESULTS), REFERENCE), \
        "run `python -m pkmlib.report`"


@pytest.mark.parametrize("paper", PAPERS)
def test_every_erratum_links_the_notebook_section_that_explains_it(paper):
    import json
    from pathlib import Path

    from pkmlib.report import section_anchor

    root = Path(__file__).resolve().parents[1]
    nb = json.loads((root / REFERENCE[paper]["notebook"]).read_text())
    headings = {line.lstrip("#").strip() for c in nb["cells"] if c["cell_type"] == "markdown"
                for line in "".join(c["source"]).splitlines() if line.startswith("#")}
    for e in REFERENCE[paper]["numbers"]:
        if e["expected_status"] == ERRATUM:
            assert e.get("section") in headings, f"{paper} {e['quantity']}: no section {e.get('section')!r}"
    assert section_anchor("The paper's numbers beside ours") == "the-papers-numbers-beside-ours"
    assert section_anchor("Singularities (section 2.3)") == "singularities-section-2.3"
