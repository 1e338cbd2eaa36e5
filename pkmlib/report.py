"""The scorecard: every number the papers print, ours beside it, and the status of each.

``data/reference/<paper>.json`` holds what a paper prints or states (value, printed text,
source, the tolerance its printed precision implies, the expected status, and for an erratum
why the printed value cannot be right). ``data/results/<paper>.json`` holds what its notebook
computed, with one ``reproduction`` row per reference quantity. ``python -m pkmlib.report``
joins the two, recomputes each status from the reference tolerance, prints one table per
paper and writes ``data/results/_reproduction.md``, which the Quarto home page includes.
``make report`` runs it after executing the notebooks.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

from ._params import DATA_DIR
from ._results import DIFFERS, ERRATUM, REPRODUCED, compare, format_table, format_value

RESULTS_DIR = DATA_DIR / "results"
REFERENCE_DIR = DATA_DIR / "reference"
MARKDOWN = RESULTS_DIR / "_reproduction.md"
MISSING = "missing"


def load_results(results_dir: Path = RESULTS_DIR) -> dict[str, dict]:
    """Every ``<paper>.json`` in ``results_dir``, by file stem, in name order."""
    return {p.stem: json.loads(p.read_text()) for p in sorted(results_dir.glob("*.json"))}


def load_reference(reference_dir: Path = REFERENCE_DIR) -> dict[str, dict]:
    """Every ``<paper>.json`` in ``reference_dir``, by file stem, in name order."""
    return load_results(reference_dir)


def score_row(ref: dict[str, Any], res_row: dict[str, Any] | None) -> dict[str, Any]:
    """One scorecard row: the reference quantity, our value from the results row, the status.

    Numbers are judged again here from the reference tolerance; a qualitative statement keeps the
    verdict its notebook computed (``reproduced`` or not), and becomes ``erratum`` when the
    reference explains why the paper is wrong.
    """
    if res_row is None:
        return {"quantity": ref["quantity"], "paper": ref["paper"], "ours": None, "rel_error": None,
                "status": MISSING, "source": ref.get("source", ""), "expected_status": ref["expected_status"]}
    if isinstance(ref["paper"], str):
        ok = res_row["status"] == REPRODUCED
        status = REPRODUCED if ok else (ERRATUM if ref.get("erratum") else DIFFERS)
        row = {"quantity": ref["quantity"], "paper": ref["paper"], "ours": res_row["ours"], "rel_error": None,
               "status": status, "source": ref.get("source", "")}
    else:
        row = compare(ref["quantity"], ref["paper"], res_row["ours"], rel_tol=ref.get("rel_tol", 0.0),
                      abs_tol=ref.get("abs_tol", 0.0), source=ref.get("source", ""), erratum=ref.get("erratum"))
    row["printed"] = ref.get("printed", "")
    row["section"] = ref.get("section", "")
    row["expected_status"] = ref["expected_status"]
    if ref.get("erratum") and row["status"] == ERRATUM:
        row["note"] = ref["erratum"]
    return row


def scorecard(reference: dict[str, dict] | None = None, results: dict[str, dict] | None = None) -> dict[str, list]:
    """Scorecard rows per paper (the papers that have a reference file)."""
    reference = load_reference() if reference is None else reference
    results = load_results() if results is None else results
    card = {}
    for paper, ref in reference.items():
        rows = {r["quantity"]: r for r in results.get(paper, {}).get("reproduction", [])}
        card[paper] = [score_row(e, rows.get(e["quantity"])) for e in ref["numbers"]]
    return card


def section_anchor(heading: str) -> str:
    """Pandoc's automatic identifier of a heading (what Quarto links to with ``page#id``)."""
    text = re.sub(r"\$[^$]*\$", lambda m: m.group(0).strip("$"), heading)  # keep math text
    text = "".join(ch for ch in text.lower() if ch.isalnum() or ch in " -_.")
    return re.sub(r"\s+", "-", text.strip()).lstrip("0123456789-_.") or "section"


def markdown_table(card: dict[str, list], reference: dict[str, dict]) -> str:
    """All scorecard rows as one Markdown table (paper, quantity, printed, ours, error, status)."""
    lines = ["| paper | quantity | paper value | ours | rel. error | status | source / why |",
             "|---|---|---|---|---|---|---|"]
    for paper, rows in card.items():
        page = reference[paper].get("notebook", "")
        for r in rows:
            err = "-" if r.get("rel_error") is None else f"{r['rel_error']:.2e}"
            why = r.get("note") or r.get("source", "")
            if r["status"] == ERRATUM and page:
                anchor = f"#{section_anchor(r['section'])}" if r.get("section") else ""
                why = f"{why} ([why]({page}{anchor}))"
            lines.append(f"| {paper.upper()} | {r['quantity']} | {r.get('printed') or format_value(r['paper'], 7)} | "
                         f"{format_value(r['ours'], 7)} | {err} | {r['status']} | {why} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    reference = load_reference()
    if not reference:
        print(f"no reference files in {REFERENCE_DIR.name}/")
        return 1
    card = scorecard(reference)
    for paper, rows in card.items():
        print(f"\n{paper.upper()}: {reference[paper].get('paper', '')}")
        print(format_table([r | {"paper": r.get("printed") or r["paper"]} for r in rows]))
    MARKDOWN.write_text(markdown_table(card, reference))
    counts: dict[str, int] = {}
    for rows in card.values():
        for r in rows:
            counts[r["status"]] = counts.get(r["status"], 0) + 1
    print("\n" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
