"""The scorecard: data/reference (what the papers print) against data/results (what the notebooks
compute), and the rules that keep it honest (REPORT_CONVENTIONS.md, issue 10 item 6):

- the paper quoted exactly, qualifiers included; a printed "about" is a tolerance, not dropped;
- a printed value equal to ours truncated to its digits is reproduced (noted), never an erratum;
- one misprint is one row; our own consistency checks and agreement by construction have their
  own status and are not counted as reproductions;
- every row that is not reproduced links a section that exists in its notebook;
- every "ours" is a number in the results file; the committed Markdown is what the data give;
- `python -m pkmlib.tools.report` fails, naming the file, on a missing or corrupt results file or a
  non-number, and then leaves the committed files as they were (issue 11 item 6).
"""

import json
import math
import os
import re
import shutil
from pathlib import Path

import pytest

import pkmlib as pk
from pkmlib._papers import PAPERS as REGISTRY

from pkmlib._results import (
    BY_CONSTRUCTION,
    CONSISTENCY_CHECK,
    DIFFERS,
    ERRATUM,
    EXPLAINED_DIFFERENCE,
    MISSING,
    NOT_PAPER_PARAMETERS,
    REPRODUCED,
)
from pkmlib.tools.report import (
    CITATION_KEYS,
    CSV_NAME,
    JSON_NAME,
    NOT_REPRODUCED,
    MARKDOWN,
    QUALIFIERS,
    STATUSES,
    SUMMARY,
    TEXT_QUALIFIERS,
    TRUNCATED_NOTE,
    VERDICT,
    ReportError,
    build,
    count_line,
    count_statuses,
    is_truncation,
    load_reference,
    load_results,
    main,
    normalize_notebook,
    ours_form,
    printed_number,
    row_id,
    score_row,
    scorecard_records,
    statements,
    scorecard,
    section_anchor,
    within_tolerance,
)

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = load_reference()
RESULTS = load_results()
PAPERS = sorted(REFERENCE)
CARD = scorecard(REFERENCE, RESULTS)
#: The papers' texts (../shared/papers beside the repository, or $PKMLIB_PAPERS).
PAPER_TEXTS = Path(os.environ.get("PKMLIB_PAPERS", ROOT.parent / "shared" / "papers"))


def rows_of(paper):
    return [(e, r) for e, r in zip(REFERENCE[paper]["numbers"], CARD[paper])]


def notebook_headings(paper):
    nb = json.loads((ROOT / REFERENCE[paper]["notebook"]).read_text())
    return {
        line.lstrip("#").strip()
        for c in nb["cells"]
        if c["cell_type"] == "markdown"
        for line in "".join(c["source"]).splitlines()
        if re.match(r"#{1,6} ", line)
    }


# --- the data ------------------------------------------------------------------------------------


def test_every_paper_has_a_reference_and_results():
    assert PAPERS == sorted(REGISTRY), "data/reference/ and the registry pkmlib._papers name other papers"
    for paper in PAPERS:
        assert REFERENCE[paper]["notebook"] == REGISTRY[paper].notebook, paper
    assert set(PAPERS) <= set(RESULTS)


@pytest.mark.parametrize("paper", PAPERS)
def test_reference_and_results_name_the_same_quantities_with_the_same_paper_values(paper):
    ref = {e["quantity"]: e for e in REFERENCE[paper]["numbers"]}
    assert len(ref) == len(REFERENCE[paper]["numbers"]), f"{paper}: a quantity appears twice in data/reference"
    res = {r["quantity"]: r for r in RESULTS[paper]["reproduction"]}
    assert set(ref) == set(res), f"{paper}: notebook rows and reference differ: {sorted(set(ref) ^ set(res))}"
    for q, e in ref.items():
        assert res[q]["paper"] == e["paper"], f"{paper} {q}: the notebook compares with another paper value"
        assert e.get("source"), f"{paper} {q}: no source"
        assert e.get("tolerance_basis"), f"{paper} {q}: no tolerance basis"
        assert e.get("printed"), f"{paper} {q}: no printed text (quote the paper)"


@pytest.mark.parametrize("paper", PAPERS)
def test_every_ours_is_a_number_in_the_results_file(paper):
    """The report takes "ours" from the results JSON the notebook wrote; a missing, null or text
    value there is an error, not a row."""
    for r in RESULTS[paper]["reproduction"]:
        ours = r.get("ours")
        assert isinstance(ours, (int, float)) and not isinstance(ours, bool) and math.isfinite(ours), (
            f"data/results/{paper}.json {r['quantity']!r}: ours = {ours!r}"
        )


@pytest.mark.parametrize("paper", PAPERS)
def test_schema_fields_have_known_values(paper):
    allowed = set(STATUSES) - {MISSING, NOT_PAPER_PARAMETERS}
    for e in REFERENCE[paper]["numbers"]:
        q = e["quantity"]
        assert e["expected_status"] in allowed, f"{paper} {q}: expected_status {e['expected_status']!r}"
        assert e.get("kind", "claim") in ("claim", "consistency"), f"{paper} {q}: kind {e.get('kind')!r}"
        assert e.get("rounding") in (None, "truncated"), f"{paper} {q}: rounding {e.get('rounding')!r}"
        assert isinstance(e.get("main", False), bool), f"{paper} {q}: main must be true or false"
        if e.get("kind") == "consistency":
            assert e["expected_status"] == CONSISTENCY_CHECK and not e.get("by_construction") and not e.get("main"), (
                f"{paper} {q}: a consistency check is expected as {CONSISTENCY_CHECK!r}, not a main claim"
            )
        if e.get("by_construction"):
            assert e["expected_status"] == BY_CONSTRUCTION, (
                f"{paper} {q}: by_construction row expected {e['expected_status']!r}"
            )
        if e["expected_status"] == ERRATUM:
            assert e.get("erratum"), f"{paper} {q}: an erratum must say why"
        if e["expected_status"] == EXPLAINED_DIFFERENCE:
            assert e.get("explained") and not e.get("erratum"), f"{paper} {q}: an explained difference must say how"
        if e["expected_status"] == DIFFERS:  # "differs" is what is not explained (issue 20 item 4)
            assert not (e.get("explained") or e.get("note") or e.get("differs")), (
                f"{paper} {q}: differs but explained: make it an explained difference"
            )
        if e["expected_status"] in (CONSISTENCY_CHECK, BY_CONSTRUCTION):
            assert e.get("kind") == "consistency" or e.get("by_construction"), (
                f"{paper} {q}: status {e['expected_status']!r} needs kind: consistency or by_construction: <why>"
            )


@pytest.mark.parametrize("paper", PAPERS)
def test_every_row_has_its_expected_status(paper):
    for e, row in rows_of(paper):
        assert row["status"] == e["expected_status"], (
            f"{paper} {e['quantity']}: {row['status']} (ours {row['ours']}), expected {e['expected_status']}"
        )


@pytest.mark.parametrize("paper", PAPERS)
def test_a_printed_qualifier_is_a_tolerance(paper):
    """ "about 0.0475", "≈ 10^3": the tolerance reflects the qualifier, and the row is an erratum
    only beyond it."""
    for e, row in rows_of(paper):
        if isinstance(e["paper"], str) or not QUALIFIERS.search(e.get("printed", "")):
            continue
        assert (e.get("rel_tol") or 0) > 0 or (e.get("abs_tol") or 0) > 0, (
            f"{paper} {e['quantity']}: printed {e['printed']!r} is approximate but the tolerance is zero"
        )
        if row["status"] == ERRATUM:
            assert not within_tolerance(e, row["ours"]), f"{paper} {e['quantity']}: erratum within the tolerance"


def _paper_text(paper):
    author = re.match(r"[a-z]+", CITATION_KEYS[paper]).group(0)
    files = sorted(PAPER_TEXTS.glob(f"{author}-*.md"))
    if not files:
        pytest.skip(f"the papers' texts are not in {PAPER_TEXTS} (set PKMLIB_PAPERS)")
    lines = [ln for ln in files[0].read_text().splitlines() if not re.match(r"\s*(Рис\.|图|Fig\.)\s*\d", ln)]
    text = " ".join(lines).replace("$", "").replace("−", "-")  # math as text, captions out of the flow
    return re.sub(r"\s+", " ", text)


@pytest.mark.parametrize("paper", PAPERS)
def test_printed_keeps_the_papers_qualifiers(paper):
    """A number the paper only ever states with "около" / "about" / "≈" before it ("около 0,0475 и
    -0,0725 м") keeps the qualifier in its printed text; so does one whose source quotes it."""
    text = _paper_text(paper)
    for e in REFERENCE[paper]["numbers"]:
        printed = e.get("printed", "")
        if QUALIFIERS.search(printed):
            continue
        assert not TEXT_QUALIFIERS.search(e.get("source", "")), (
            f"{paper} {e['quantity']}: the source quotes {e['source']!r}, the printed {printed!r} drops the qualifier"
        )
        num = re.search(r"\d+(?:[.,]\d+)?", printed)
        if not num or len(re.sub(r"\D", "", num.group(0))) < 2:
            continue
        contexts = []
        for form in {num.group(0), num.group(0).replace(".", ","), num.group(0).replace(",", ".")}:
            for occ in re.finditer(r"(?<![\d.,])" + re.escape(form) + r"(?!\d)", text):
                contexts.append(re.split(r"[.!?;:]\s", text[max(0, occ.start() - 40) : occ.start()])[-1] + form)
        assert not contexts or not all(TEXT_QUALIFIERS.search(c) for c in contexts), (
            f"{paper} {e['quantity']}: the paper says only {contexts[0]!r}..., printed {printed!r} drops the qualifier"
        )


@pytest.mark.parametrize("paper", PAPERS)
def test_truncation_is_reproduced_and_noted_never_an_erratum(paper):
    for e, row in rows_of(paper):
        if isinstance(e["paper"], str):
            continue
        truncated = is_truncation(e["paper"], row["ours"], e.get("printed", ""))
        if truncated and not within_tolerance(e, row["ours"]):
            assert e.get("rounding") == "truncated" and row["status"] == REPRODUCED and row["note"] == TRUNCATED_NOTE, (
                f"{paper} {e['quantity']}: printed {e['printed']!r} is ours ({row['ours']}) truncated: "
                "set rounding: truncated (reproduced, noted), not an erratum"
            )
        if e.get("rounding") == "truncated":
            assert truncated, (
                f"{paper} {e['quantity']}: rounding: truncated, but {e['printed']!r} is not ours truncated"
            )


def test_one_finding_is_one_row():
    """Several rows with one erratum text are one misprint counted several times."""
    seen = {}
    for paper in PAPERS:
        for e in REFERENCE[paper]["numbers"]:
            if e.get("erratum"):
                key = re.sub(r"\s+", " ", e["erratum"].strip().lower())
                assert key not in seen, f"{paper} {e['quantity']} and {seen[key]}: one finding, two erratum rows"
                seen[key] = f"{paper} {e['quantity']}"


@pytest.mark.parametrize("paper", PAPERS)
def test_every_row_not_reproduced_has_a_section_in_its_notebook(paper):
    headings = notebook_headings(paper)
    for e, row in rows_of(paper):
        if row["status"] != REPRODUCED:
            assert e.get("section"), f"{paper} {e['quantity']}: {row['status']} without a section"
            assert e["section"] in headings, (
                f"{paper} {e['quantity']}: section {e['section']!r} is not a heading of {REFERENCE[paper]['notebook']}"
            )


@pytest.mark.parametrize("paper", PAPERS)
def test_each_paper_marks_three_to_eight_main_claims(paper):
    main_rows = [e for e in REFERENCE[paper]["numbers"] if e.get("main")]
    assert 3 <= len(main_rows) <= 8, f"{paper}: {len(main_rows)} rows with main: true (3-8 make the verdict box)"


def test_committed_markdown_is_what_the_data_give():
    _, _, out = build()
    for path, text in out.items():
        assert path.exists() and path.read_text() == text, f"{path.name} is stale: run `python -m pkmlib.tools.report`"
    assert {p.name for p in out} == {MARKDOWN.name, SUMMARY, CSV_NAME, JSON_NAME} | {
        VERDICT.format(paper=p) for p in PAPERS
    }


# --- the rules on made-up rows -------------------------------------------------------------------

REF = {
    "quantity": "q",
    "paper": 1.0,
    "printed": "1.0",
    "source": "s",
    "rel_tol": 0.0,
    "abs_tol": 0.05,
    "expected_status": REPRODUCED,
}


def res(ours, status=DIFFERS):
    return {"quantity": "q", "paper": 1.0, "ours": ours, "status": status}


def test_scorecard_sets_ours_in_the_papers_form():
    """A log10 is shown as the power of ten the paper prints; a statement as what ours says (or
    whether it holds), never a bare number against words; numbers carry a difference and a tolerance."""
    records = {(rec["paper"], rec["quantity"]): rec for rec in scorecard_records(CARD, REFERENCE)}
    assert len({rec["id"] for rec in records.values()}) == len(records), "two rows share a permalink"
    for paper in PAPERS:
        for e, _row in rows_of(paper):
            rec = records[(paper.upper(), e["quantity"])]
            assert rec["id"] == row_id(paper, e["quantity"]) and re.fullmatch(r"p\d-[a-z0-9-]+", rec["id"])
            if isinstance(e["paper"], str):
                assert not re.fullmatch(r"[-+\d.e]+", rec["ours"]), (
                    f"{paper} {e['quantity']}: ours {rec['ours']!r} against words"
                )
                assert rec["difference"] == "-" and rec["tolerance"] == "-"
            else:
                assert rec["difference"] != "-" and rec["tolerance"].startswith("±"), e["quantity"]
            if e["quantity"].startswith("log10 of"):
                assert rec["ours"].startswith("10^") and "decades" in rec["difference"], rec
    row = score_row(
        REF | {"quantity": "log10 of the largest force", "paper": 3.0, "printed": "10^3"},
        {"quantity": "q", "ours": 3.17, "status": REPRODUCED},
    )
    assert ours_form(row) == "10^3.17 = 1.48e+03" or ours_form(row).startswith("10^3.17 = 1.48")


def test_a_printed_vector_is_one_statement():
    rows = [score_row(REF | {"quantity": f"A_1^b {c}"}, res(v)) for c, v in (("x", 1.0), ("y", 1.0), ("z", 3.0))]
    rows.append(score_row(REF | {"quantity": "mom(R_1, xi)"}, res(1.0)))
    st = statements(rows)
    assert [(k, s) for k, s, _ in st] == [("A_1^b", DIFFERS), ("mom(R_1, xi)", REPRODUCED)]
    assert sum(len(m) for _, _, m in st) == 4


def test_explained_differences_are_not_reproductions_and_say_how():
    row = score_row(REF | {"explained": "the paper's section needs another centre"}, res(2.0))
    assert row["status"] == EXPLAINED_DIFFERENCE and row["note"].startswith("the paper's")
    assert EXPLAINED_DIFFERENCE in NOT_REPRODUCED and REPRODUCED not in NOT_REPRODUCED
    assert score_row(REF | {"explained": "x"}, res(1.0))["status"] == REPRODUCED  # within tolerance: reproduced


def test_status_is_recomputed_from_the_reference_tolerance():
    assert score_row(REF, res(1.04))["status"] == REPRODUCED
    assert score_row(REF, res(1.06, REPRODUCED))["status"] == DIFFERS
    assert score_row(REF | {"erratum": "why"}, res(2.0))["status"] == ERRATUM
    assert score_row(REF | {"erratum": "why"}, res(2.0))["note"] == "why"
    assert score_row(REF, None)["status"] == MISSING
    assert score_row(REF, res(1.0, NOT_PAPER_PARAMETERS))["status"] == NOT_PAPER_PARAMETERS


def test_consistency_checks_and_agreement_by_construction_are_not_reproductions():
    assert score_row(REF | {"kind": "consistency"}, res(1.0))["status"] == CONSISTENCY_CHECK
    assert score_row(REF | {"kind": "consistency"}, res(3.0))["status"] == DIFFERS  # a failed check is not hidden
    row = score_row(REF | {"by_construction": "J inferred from these accelerations"}, res(1.0))
    assert row["status"] == BY_CONSTRUCTION and row["note"].startswith("J inferred")
    rows = [
        score_row(REF | {"kind": "consistency"}, res(1.0)),
        score_row(REF, res(1.0)),
        score_row(REF | {"by_construction": "x"}, res(1.0)),
    ]
    counts = count_statuses(rows)
    assert counts[REPRODUCED] == 1 and counts[CONSISTENCY_CHECK] == 1 and counts[BY_CONSTRUCTION] == 1
    assert count_line(counts) == "1 reproduced, 0 errata, 0 differ, 1 consistency check, 1 by construction"


def test_statement_rows_keep_the_notebooks_verdict():
    ref = REF | {"paper": "always >= 0", "printed": "always >= 0"}
    assert score_row(ref, res(0.1, REPRODUCED))["status"] == REPRODUCED
    assert score_row(ref, res(-0.1, DIFFERS))["status"] == DIFFERS
    assert score_row(ref | {"kind": "consistency"}, res(1e-16, CONSISTENCY_CHECK))["status"] == CONSISTENCY_CHECK
    assert score_row(ref | {"kind": "consistency"}, res(1e-16, DIFFERS))["status"] == DIFFERS
    assert score_row(ref | {"erratum": "geometry says no"}, res(-0.1, ERRATUM))["status"] == ERRATUM


def test_truncated_digits_are_reproduced_with_a_note():
    assert printed_number("-0,0725 м (-0.0725 m)") == "-0.0725" and printed_number("≈ 10^3") == "10"
    assert is_truncation(-0.25, -0.259151, "-0.25")  # rounded would be -0.26
    assert is_truncation(0.0069, 0.00669873, "0.0069") is False  # 0.0066 truncated: a real difference
    assert is_truncation(0.016, 0.0158494, "0.016") is False  # that is rounding
    assert is_truncation(-0.21, -0.216506, "-0.21")
    ref = REF | {"paper": -0.25, "printed": "-0.25", "abs_tol": 0.005, "erratum": "digits"}
    assert score_row(ref, res(-0.259151))["status"] == ERRATUM  # without rounding: truncated it stays judged
    row = score_row(ref | {"rounding": "truncated"}, res(-0.259151))
    assert row["status"] == REPRODUCED and row["note"] == TRUNCATED_NOTE
    assert score_row(ref | {"rounding": "truncated"}, res(-0.27))["status"] == ERRATUM


def test_a_non_number_is_an_error_naming_the_file():
    for bad in (None, "0.3", True, float("nan")):
        with pytest.raises(ReportError, match=r"p9\.json.*'q'.*not a finite number"):
            score_row(REF, res(bad), source_file="data/results/p9.json")


def test_section_anchor_matches_pandoc():
    assert section_anchor("The paper's numbers beside ours") == "the-papers-numbers-beside-ours"
    assert section_anchor("Singularities (section 2.3)") == "singularities-section-2.3"
    assert section_anchor("Fig 5: sign of $\\det(\\mathbf{A})$ and more") == "fig-5-sign-of-detmathbfa-and-more"


# --- python -m pkmlib.tools.report on broken inputs (issue 11 item 6) ----------------------------------


@pytest.fixture
def data(tmp_path):
    """A copy of data/reference and data/results in a temporary folder, the Markdown included."""
    ref, out = tmp_path / "reference", tmp_path / "results"
    shutil.copytree(ROOT / "data" / "reference", ref)
    shutil.copytree(ROOT / "data" / "results", out)
    return ref, out


def snapshot(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def run_report(ref, out, capsys):
    rc = main(["--reference-dir", str(ref), "--results-dir", str(out), "--quiet"])
    return rc, capsys.readouterr()


def test_report_writes_every_file_atomically(data, capsys):
    ref, out = data
    for p in out.glob("_*.md"):
        p.unlink()
    rc, io = run_report(ref, out, capsys)
    assert rc == 0, io.err
    assert (out / "_reproduction.md").read_text() == MARKDOWN.read_text()
    assert all((out / VERDICT.format(paper=p)).exists() for p in PAPERS) and (out / SUMMARY).exists()
    assert not list(out.glob(".*tmp")), "temporary files left behind"
    before = snapshot(out)
    assert run_report(ref, out, capsys)[0] == 0 and snapshot(out) == before, "a second run changed files"


@pytest.mark.parametrize(
    "breakage, message",
    [
        ("missing", r"p3\.json: missing"),
        ("corrupt", r"p3\.json: not valid JSON"),
        ("null", r"p3\.json: row .*'ours' is null, not a finite number"),
        ("text", r"p3\.json: row .*'ours' is \"37\.79\", not a finite number"),
        ("no row", r"p3\.json: no results row for p3: 'A Table 1 row 1 x'"),
        ("not a list", r"p3\.json: no 'reproduction' list"),
    ],
)
def test_report_fails_naming_the_file_and_writes_nothing(data, capsys, breakage, message):
    ref, out = data
    path = out / "p3.json"
    results = json.loads(path.read_text())
    if breakage == "missing":
        path.unlink()
    elif breakage == "corrupt":
        path.write_text(path.read_text()[:5000])
    elif breakage == "null":
        results["reproduction"][0]["ours"] = None
    elif breakage == "text":
        results["reproduction"][0]["ours"] = "37.79"
    elif breakage == "no row":
        del results["reproduction"][0]
    elif breakage == "not a list":
        results["reproduction"] = {}
    if breakage not in ("missing", "corrupt"):
        path.write_text(json.dumps(results))
    before = snapshot(out)
    rc, io = run_report(ref, out, capsys)
    assert rc == 1
    assert re.search(message, io.err), io.err
    assert "nothing written" in io.err
    assert snapshot(out) == before, "the committed scorecard changed although the report failed"


def test_normalized_notebook_merges_split_streams_and_drops_timing():
    nb = {
        "metadata": {"papermill": {"x": 1}},
        "cells": [
            {
                "cell_type": "code",
                "metadata": {"execution": {"iopub.execute_input": "2026"}},
                "source": [],
                "outputs": [
                    {"output_type": "stream", "name": "stdout", "text": ["a = 1\n", "b"]},
                    {"output_type": "stream", "name": "stdout", "text": [" = 2\n"]},
                    {"output_type": "stream", "name": "stderr", "text": "warn\n"},
                    {"output_type": "display_data", "data": {}, "metadata": {}},
                ],
            }
        ],
    }
    out = normalize_notebook(json.loads(json.dumps(nb)))
    cell = out["cells"][0]
    assert cell["outputs"][0]["text"] == ["a = 1\n", "b = 2\n"]
    assert [o.get("name") for o in cell["outputs"]] == ["stdout", "stderr", None]
    assert "execution" not in cell["metadata"] and "papermill" not in out["metadata"]
    assert normalize_notebook(json.loads(json.dumps(out))) == out


def test_installed_notebooks_are_normalized_atomically_and_stable(tmp_path, capsys):
    """`make report` executes into .nbexec/ and installs with --notebooks-from: the committed
    layout is kept byte for byte (nbformat's), split prints merged, so a second run changes nothing."""
    src, dest = tmp_path / "exec", tmp_path / "notebooks"
    src.mkdir(), dest.mkdir()
    original = (ROOT / "notebooks" / "tutorial_bring_your_own_mechanism.ipynb").read_text(encoding="utf-8")
    nb = json.loads(original)
    code = next(
        c for c in nb["cells"] if c["cell_type"] == "code" and any(o["output_type"] == "stream" for o in c["outputs"])
    )
    stream = next(o for o in code["outputs"] if o["output_type"] == "stream")
    text = "".join(stream["text"])
    cut = len(text) // 2
    i = code["outputs"].index(stream)
    code["outputs"][i : i + 1] = [dict(stream, text=[text[:cut]]), dict(stream, text=[text[cut:]])]  # a split print
    code["metadata"]["execution"] = {"iopub.status.busy": "2026-01-01T00:00:00Z"}
    (src / "tutorial_bring_your_own_mechanism.ipynb").write_text(json.dumps(nb, indent=1, ensure_ascii=False))
    results = tmp_path / "results"  # the scorecard files it writes besides: not into data/results/
    shutil.copytree(ROOT / "data" / "results", results)
    args = ["--notebooks-from", str(src), "--notebooks-dir", str(dest), "--results-dir", str(results), "--quiet"]
    assert main(args) == 0, capsys.readouterr().err
    installed = (dest / "tutorial_bring_your_own_mechanism.ipynb").read_text(encoding="utf-8")
    assert installed == original, "the installed notebook differs from the committed one"
    assert (
        main(args) == 0 and (dest / "tutorial_bring_your_own_mechanism.ipynb").read_text(encoding="utf-8") == original
    )
    assert not list(dest.glob(".*tmp"))


def test_atomic_write_keeps_permissions(tmp_path):
    from pkmlib._results import _atomic_write_text

    path = tmp_path / "x.md"
    _atomic_write_text(path, "a\n")
    assert path.stat().st_mode & 0o777 == 0o666 & ~_umask()
    path.chmod(0o640)
    _atomic_write_text(path, "b\n")
    assert path.read_text() == "b\n" and path.stat().st_mode & 0o777 == 0o640


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m


def test_make_report_installs_normalized_notebooks_and_stops_on_a_bad_scorecard():
    make = (ROOT / "Makefile").read_text()
    recipe = make[make.index("\nreport:") :].split("\n\n")[0]
    assert "--inplace" not in recipe, "executing in place writes half a notebook when interrupted"
    assert "--output-dir .nbexec" in recipe and "pkmlib.tools.report --notebooks-from .nbexec" in recipe
    assert recipe.index("pkmlib.tools.report") < recipe.index("render_site.sh"), (
        "the site must render the new scorecard"
    )


def test_compare_and_claim_reference_read_the_row_and_its_tolerance():
    """pk.tools.compare_reference / pk.tools.claim_reference score our number with the tolerance, source and
    erratum of the reference row (P4's "about 100 N/mm" mean stiffness, a tolerance of 10 %)."""
    q = "mean stiffness in the worst direction, N/mm"
    ref = pk.tools.reference_row("p4", q)
    assert ref.get("rel_tol", 0.0) > 0 or ref.get("abs_tol", 0.0) > 0
    row = pk.tools.compare_reference("p4", q, ref["paper"])
    assert row["status"] == "reproduced" and row["source"] == ref["source"] and row["paper"] == ref["paper"]
    far = pk.tools.compare_reference("p4", q, 10 * ref["paper"])
    assert far["status"] == "differs"
    assert (
        pk.tools.compare_reference("p4", q, 10 * ref["paper"], paper_run=False)["status"]
        == "not the paper's parameters"
    )
    c = "mean / stiffness 5 mm above the singular point"
    assert pk.tools.claim_reference("p4", c, 12.0, True)["status"] == "reproduced"
    assert pk.tools.claim_reference("p4", c, 2.0, False)["status"] in ("differs", "erratum")
    with pytest.raises(ValueError, match="not in data/reference/p4.json"):
        pk.tools.compare_reference("p4", "no such quantity", 1.0)


def test_a_notebooks_row_has_the_status_and_reason_the_scorecard_gives():
    """pk.tools.compare_reference / pk.tools.claim_reference carry the reference row's ``erratum`` and
    ``explained``: a row that does not hold gets, in the notebook, the status and reason that the
    scorecard (pkmlib.tools.report.score_row) gives it: erratum, explained difference or differs. Over
    every row of every paper that is not a consistency check or agreement by construction (statuses
    only the scorecard gives)."""
    explained = 0
    for paper in PAPERS:
        for e in REFERENCE[paper]["numbers"]:
            if e.get("kind") == "consistency" or e.get("by_construction"):
                continue
            q = e["quantity"]
            if isinstance(e["paper"], str):
                ours = pk.tools.claim_reference(paper, q, 0.0, False)
            else:
                ours = pk.tools.compare_reference(paper, q, 10 * float(e["paper"]) + 1.0)
            card = score_row(e, ours)
            assert ours["status"] == card["status"] != REPRODUCED, (paper, q, ours["status"], card["status"])
            assert ours.get("note", "") == (card["note"] if card["status"] != DIFFERS else ""), (paper, q)
            explained += ours["status"] == EXPLAINED_DIFFERENCE
            holds = pk.tools.claim_reference(paper, q, 0.0, True) if isinstance(e["paper"], str) else None
            assert holds is None or (holds["status"] == REPRODUCED and "note" not in holds), (paper, q)
    assert explained >= 1, "no reference row is an explained difference: the test checks nothing"


def test_compare_and_claim_say_an_explained_difference_and_why():
    row = pk.tools.compare("q", 1.0, 2.0, rel_tol=0.05, explained="the paper leaves the centre of mass open")
    assert row["status"] == EXPLAINED_DIFFERENCE and row["note"].startswith("the paper leaves")
    assert pk.tools.compare("q", 1.0, 1.01, rel_tol=0.05, explained="x")["status"] == REPRODUCED
    assert pk.tools.compare("q", 1.0, 2.0, erratum="misprint", explained="x")["status"] == ERRATUM  # an erratum first
    assert pk.tools.compare("q", 1.0, 2.0, explained="x", paper_run=False)["status"] == NOT_PAPER_PARAMETERS
    row = pk.tools.claim("q", "always >= 0", -1.0, False, explained="another branch")
    assert row["status"] == EXPLAINED_DIFFERENCE and row["note"] == "another branch"
    assert "note" not in pk.tools.claim("q", "always >= 0", 1.0, True, explained="another branch")
    with pytest.raises(ValueError, match="explained"):
        pk.tools.compare("q", 1.0, 2.0, explained=3)
    with pytest.raises(ValueError, match="explained"):
        pk.tools.claim("q", "s", 1.0, False, explained=["x"])
