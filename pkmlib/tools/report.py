"""The scorecard: every checkable statement of the papers, ours beside it, and the status of each.

``data/reference/<paper>.json`` holds what a paper prints or states (value, the printed text with
its qualifiers, source, the tolerance its printed precision implies, the expected status, and for
an erratum why the printed value cannot be right). ``data/results/<paper>.json`` holds what its
notebook computed, with one ``reproduction`` row per reference quantity. ``python -m pkmlib.tools.report``
joins the two, recomputes each status from the reference row, prints one table per paper and
writes (atomically, and only when every input is sound):

- ``data/results/_reproduction.md``: the full scorecard, one captioned table per paper, included
  by ``scorecard.qmd``;
- ``data/results/_summary.md``: the counts per paper and the errata at a glance, included by the
  home page ``index.qmd``;
- ``data/results/_verdict_<paper>.md``: the verdict box of each paper page (its ``main`` claims,
  one line each, and the count line).

Statuses (README.md, "The scorecard"): *reproduced* (within the tolerance the printed precision
implies, or the printed digits are ours truncated: noted), *erratum* (the paper contradicts its own
geometry; the reference says why), *differs* (not explained), *consistency check* (our own check,
``kind: "consistency"``, never counted as a reproduction), *by construction* (our value was
inferred from the paper's numbers), *not the paper's parameters* (a re-run at other parameters).

A missing or corrupt results file, or a non-number where a number belongs, is an error naming the
file (exit status 1), and no file is written.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from decimal import ROUND_DOWN, ROUND_HALF_EVEN, Decimal, InvalidOperation
from pathlib import Path
from typing import Any

from .. import _results
from .._papers import PAPERS
from .._params import DATA_DIR
from .._reference import REFERENCE_DIR
from .._results import (
    BY_CONSTRUCTION,
    CONSISTENCY_CHECK,
    DIFFERS,
    ERRATUM,
    EXPLAINED_DIFFERENCE,
    MISSING,
    NOT_PAPER_PARAMETERS,
    REPRODUCED,
    _atomic_write_text,
    format_table,
    format_value,
)

RESULTS_DIR = DATA_DIR / "results"
MARKDOWN = RESULTS_DIR / "_reproduction.md"
SUMMARY = "_summary.md"
VERDICT = "_verdict_{paper}.md"

#: Every status, in the order the counts list them.
STATUSES = (
    REPRODUCED,
    ERRATUM,
    EXPLAINED_DIFFERENCE,
    DIFFERS,
    CONSISTENCY_CHECK,
    BY_CONSTRUCTION,
    NOT_PAPER_PARAMETERS,
    MISSING,
)
#: The statuses of what is not reproduced: each paper page's verdict box leads with these rows.
NOT_REPRODUCED = (ERRATUM, EXPLAINED_DIFFERENCE, DIFFERS)
#: What became of each of a paper's figures and tables (``figures`` of data/reference/<paper>.json).
FIGURE_STATUSES = ("reproduced", "substituted", "skipped", "input")
#: The note of a reproduced row whose printed digits are our value truncated.
TRUNCATED_NOTE = "printed value is truncated, not rounded"
#: Words that make a printed value approximate (the tolerance must reflect them).
QUALIFIERS = re.compile(r"около|примерно|порядка|приблизительно|about|approx|roughly|≈|~|∼|大约|约为|左右|近似", re.I)
#: The same in a paper's running text, where "~" also joins ranges ("图10b~10d") and is left out.
TEXT_QUALIFIERS = re.compile(r"около|примерно|порядка|приблизительно|about|approx|roughly|≈|大约|约为|左右|近似", re.I)
#: The citation key of each paper in references.bib (from the registry, :mod:`pkmlib._papers`).
CITATION_KEYS = {key: paper.citation_key for key, paper in PAPERS.items()}
#: What each paper is about, for the home page (a reference file's "mechanism" field wins).
MECHANISMS = {key: paper.topic for key, paper in PAPERS.items()}


class ReportError(ValueError):
    """An input of the report is missing or unusable; the message names the file."""


# --- loading -------------------------------------------------------------------------------------


def load_json(path: Path) -> dict:
    """One JSON file; a missing or invalid file is a ReportError naming it."""
    path = Path(path)
    if not path.is_file():
        raise ReportError(f"{path}: missing")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ReportError(f"{path}: not valid JSON ({e})") from None
    if not isinstance(data, dict):
        raise ReportError(f"{path}: expected a JSON object, found {type(data).__name__}")
    return data


def load_results(results_dir: Path = RESULTS_DIR) -> dict[str, dict]:
    """Every ``<paper>.json`` in ``results_dir``, by file stem, in name order."""
    return {p.stem: load_json(p) for p in sorted(Path(results_dir).glob("*.json"))}


def load_reference(reference_dir: Path = REFERENCE_DIR) -> dict[str, dict]:
    """Every ``<paper>.json`` in ``reference_dir``, by file stem, in name order."""
    return load_results(reference_dir)


# --- judging one row -----------------------------------------------------------------------------


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def printed_number(printed: str) -> str | None:
    """The first number of a printed text as written (``"-0,0725 м"`` -> ``"-0.0725"``), or None."""
    m = re.search(r"[-−+]?\d+(?:[.,]\d+)?", printed or "")
    return m.group(0).replace(",", ".").replace("−", "-") if m else None


def is_truncation(paper: float, ours: float, printed: str) -> bool:
    """True when the printed digits are ``ours`` truncated (not rounded) to the printed decimals
    and differ from ``ours`` rounded: the paper cut the number off instead of rounding it."""
    text = printed_number(printed)
    if text is None or not _is_number(paper) or not _is_number(ours):
        return False
    try:
        shown = Decimal(text)
        if shown != Decimal(repr(float(paper))):
            return False
        step = Decimal(1).scaleb(shown.as_tuple().exponent)
        ours_d = Decimal(repr(float(ours)))
        return ours_d.quantize(step, rounding=ROUND_DOWN) == shown != ours_d.quantize(step, rounding=ROUND_HALF_EVEN)
    except InvalidOperation:
        return False


def within_tolerance(ref: dict[str, Any], ours: float) -> bool:
    return _results.within_tolerance(ref["paper"], ours, rel_tol=ref.get("rel_tol"), abs_tol=ref.get("abs_tol"))


def score_row(
    ref: dict[str, Any], res_row: dict[str, Any] | None, *, source_file: str | Path = "results"
) -> dict[str, Any]:
    """One scorecard row: the reference quantity, our value from the results row, the status.

    Numbers are judged again here from the reference tolerance (a printed value that is our value
    truncated is reproduced, with a note); a qualitative statement keeps the verdict its notebook
    computed (it holds or not). ``kind: "consistency"`` rows become *consistency check*,
    ``by_construction`` rows *by construction*; an unmet claim is an *erratum* when the reference
    says why the paper is wrong, else *differs*. A results row whose ``ours`` is not a finite
    number is a ReportError naming ``source_file``.
    """
    q = ref["quantity"]
    row = {
        "quantity": q,
        "paper": ref["paper"],
        "printed": ref.get("printed", ""),
        "ours": None,
        "rel_error": None,
        "status": MISSING,
        "source": ref.get("source", ""),
        "section": ref.get("section", ""),
        "expected_status": ref.get("expected_status", ""),
        "main": bool(ref.get("main")),
        "kind": ref.get("kind", "claim"),
        "note": "",
        "rel_tol": float(ref.get("rel_tol") or 0.0),
        "abs_tol": float(ref.get("abs_tol") or 0.0),
        "tolerance_basis": ref.get("tolerance_basis", ""),
        "ours_says": ref.get("ours_says", ""),
        "holds": None,
    }
    if res_row is None:
        return row
    ours = res_row.get("ours")
    if not _is_number(ours):
        raise ReportError(f"{source_file}: row {q!r}: 'ours' is {json.dumps(ours)}, not a finite number")
    row["ours"] = float(ours)
    if isinstance(ref["paper"], str):  # the notebook judged the statement: any agreeing status holds
        agrees = res_row.get("status") in (REPRODUCED, CONSISTENCY_CHECK, BY_CONSTRUCTION)
    elif _is_number(ref["paper"]):
        paper = float(ref["paper"])
        row["rel_error"] = _results.relative_error(paper, row["ours"])
        agrees = within_tolerance(ref, row["ours"])
        if (
            not agrees
            and ref.get("rounding") == "truncated"
            and is_truncation(paper, row["ours"], ref.get("printed", ""))
        ):
            agrees, row["note"] = True, TRUNCATED_NOTE
    else:
        raise ReportError(
            f"reference row {q!r}: 'paper' is {json.dumps(ref['paper'])}, neither a number nor a statement"
        )
    row["holds"] = bool(agrees)
    if res_row.get("status") == NOT_PAPER_PARAMETERS:
        row["status"] = NOT_PAPER_PARAMETERS
    elif row["kind"] == "consistency":
        row["status"] = CONSISTENCY_CHECK if agrees else DIFFERS
        row["note"] = row["note"] or "our own check, not a statement of the paper"
    elif ref.get("by_construction") and agrees:
        row["status"], row["note"] = BY_CONSTRUCTION, str(ref["by_construction"])
    elif agrees:
        row["status"] = REPRODUCED
    elif ref.get("erratum"):
        row["status"], row["note"] = ERRATUM, str(ref["erratum"])
    elif ref.get("explained"):
        row["status"], row["note"] = EXPLAINED_DIFFERENCE, str(ref["explained"])
    else:
        row["status"] = DIFFERS
        row["note"] = str(ref.get("note") or ref.get("differs") or "")
    return row


def scorecard(
    reference: dict[str, dict] | None = None, results: dict[str, dict] | None = None, *, results_dir: Path = RESULTS_DIR
) -> dict[str, list]:
    """Scorecard rows per paper (the papers that have a reference file). A paper without results,
    or results without a ``reproduction`` list, is a ReportError naming the results file."""
    reference = load_reference() if reference is None else reference
    results = load_results(results_dir) if results is None else results
    card = {}
    for paper, ref in reference.items():
        path = Path(results_dir) / f"{paper}.json"
        if paper not in results:
            raise ReportError(f"{path}: missing (the results of {ref.get('notebook', paper)})")
        rows = results[paper].get("reproduction")
        if not isinstance(rows, list):
            raise ReportError(f"{path}: no 'reproduction' list")
        by_q = {}
        for r in rows:
            if not isinstance(r, dict) or "quantity" not in r:
                raise ReportError(f"{path}: a reproduction row without a quantity: {json.dumps(r)[:80]}")
            by_q[r["quantity"]] = r
        card[paper] = [score_row(e, by_q.get(e["quantity"]), source_file=path) for e in ref["numbers"]]
    return card


def count_statuses(rows: list[dict]) -> dict[str, int]:
    """How many rows have each status (every status, in STATUSES order, zeros included)."""
    counts = dict.fromkeys(STATUSES, 0)
    for r in rows:
        counts[r["status"]] += 1
    return counts


_PLURAL = {
    ERRATUM: ("erratum", "errata"),
    CONSISTENCY_CHECK: ("consistency check", "consistency checks"),
    DIFFERS: ("differs", "differ"),
    EXPLAINED_DIFFERENCE: ("explained difference", "explained differences"),
}


def count_line(counts: dict[str, int]) -> str:
    """ "3 reproduced, 1 erratum, 0 differ, 2 consistency checks": reproduced, errata and differs
    always, the other statuses when they occur."""
    parts = []
    for s in STATUSES:
        n = counts.get(s, 0)
        if n or s in (REPRODUCED, ERRATUM, DIFFERS):
            one, many = _PLURAL.get(s, (s, s))
            parts.append(f"{n} {one if n == 1 else many}")
    return ", ".join(parts)


# --- Markdown ------------------------------------------------------------------------------------


def section_anchor(heading: str) -> str:
    """Pandoc's automatic identifier of a heading (what Quarto links to with ``page#id``)."""
    text = re.sub(r"\$[^$]*\$", lambda m: m.group(0).strip("$"), heading)  # keep math text
    text = "".join(ch for ch in text.lower() if ch.isalnum() or ch in " -_.")
    return re.sub(r"\s+", "-", text.strip()).lstrip("0123456789-_.") or "section"


def md_text(text: Any) -> str:
    """Plain text made safe inside Markdown (and a table cell): Markdown's special characters
    escaped, so ``10^3`` or ``y_D`` or ``@`` print as they are."""
    s = format_value(text, 6) if not isinstance(text, str) else text
    s = re.sub(r"([\\`*_\[\]<>^~$@#|])", r"\\\1", s)
    return s.replace("\n", " ")


def _title_attr(text: str) -> str:
    return text.replace("\\", "").replace('"', "'").replace("\n", " ")


def short(text: str, limit: int = 60) -> str:
    """The first clause of ``text`` (up to ';' or ':'), cut at a word before ``limit`` characters."""
    first = re.split(r"[;:](?:\s|$)", text, maxsplit=1)[0].strip()
    if len(first) <= limit:
        return first
    cut = first[:limit].rsplit(" ", 1)[0]
    return cut.rstrip(",.") + "…"


def row_link(row: dict, page: str) -> str:
    """``page#section`` of a row (its explanation), or '' without a section."""
    return f"{page}#{section_anchor(row['section'])}" if row.get("section") and page else ""


def ours_text(row: dict) -> str:
    """Our value for a table cell: two decimals more than the paper prints when the printed text
    is the paper's number (so 238.9192 is shown beside 238.919200, not 238.919), else 6 digits."""
    if row["ours"] is None:
        return "-"
    shown = printed_number(row.get("printed", ""))
    if shown is not None and _is_number(row["paper"]):
        try:
            if Decimal(shown) == Decimal(repr(float(row["paper"]))):
                decimals = max(-Decimal(shown).as_tuple().exponent, 0) + 2
                if abs(row["ours"]) < 1e12 and (row["ours"] == 0 or abs(row["ours"]) >= 10**-decimals):
                    return f"{row['ours']:.{decimals}f}"
        except InvalidOperation:
            pass
    return format_value(row["ours"], 6)


def paper_text(row: dict) -> str:
    return row.get("printed") or format_value(row["paper"], 6)


def paper_text_english(row: dict, limit: int = 0) -> str:
    """The printed text for a short line: of ``"<original> (<English>)"`` with a Russian or Chinese
    original, the English (qualifiers included: "about 0.0475 m"); cut to ``limit`` characters."""
    text = paper_text(row)
    m = re.match(r"^(.*?\S)\s+\((.+)\)$", text)
    if m and re.search(r"[^\x00-\x7f]", m.group(1)) and not re.search(r"[\u0400-\u04ff\u3000-\u9fff]", m.group(2)):
        text = m.group(2)
    if limit and len(text) > limit:
        text = text[:limit].rsplit(" ", 1)[0].rstrip(",.;:") + "…"
    return text


def row_id(paper: str, quantity: str) -> str:
    """The permalink id of a scorecard row (``scorecard.html#<id>``): the paper and the quantity
    as lower-case words joined by hyphens (``p3-a-table-1-row-1-x``; signs as words: ``m=-1`` ->
    ``m-minus-1``)."""
    text = re.sub(r"(?<![\w.])[-−](?=\d)", " minus ", quantity.lower()).replace("+", " plus ")
    slug = re.sub(r"[^a-z0-9]+", "-", text).strip("-")
    return f"{paper}-{slug}"


def status_link(paper: str, quantity: str, status: str) -> str:
    """A row's status as a Markdown link to its one place, its permalink on the scorecard
    (a paper page's tables link their rows there instead of repeating them; issue 20.9)."""
    return f"[{status}](../scorecard.qmd#{row_id(paper, quantity)})"


def _html(text: Any) -> str:
    return (
        str(text)
        .replace("&", "&amp;")
        .replace("<", "&lt;")
        .replace(">", "&gt;")
        .replace('"', "&quot;")
        .replace("\n", " ")
    )


_NUMBER = re.compile(r"[-+±−]?\d[\d.,]*(?:e[-+]?\d+)?(?:\^[-+]?[\d.]+)?")


def _html_numbers(text: Any) -> str:
    """HTML of ``text`` with every number in a span that never wraps (5.14754e-16 stays whole)."""
    out, last = [], 0
    s = str(text)
    for m in _NUMBER.finditer(s):
        out += [_html(s[last : m.start()]), f'<span class="nowrap">{_html(m.group(0))}</span>']
        last = m.end()
    return "".join(out) + _html(s[last:])


def _num(x: float, digits: int = 3) -> str:
    """A compact number: ``digits`` significant digits, scientific outside 1e-3..1e6."""
    if x == 0:
        return "0"
    return f"{x:.{digits}g}" if 1e-3 <= abs(x) < 1e6 else f"{x:.{max(digits - 1, 0)}e}"


def is_log10(row: dict) -> bool:
    """A row whose value is a decimal logarithm (the paper prints the number itself, 10^3 or 100000)."""
    return row["quantity"].startswith("log10 of")


def ours_form(row: dict) -> str:
    """Ours in the form and units the paper prints it: a number as the paper writes it (two more
    decimals), a log10 as the power of ten it stands for, a statement as the statement it makes
    (the reference's ``ours_says``, else whether the paper's statement holds, with our measure)."""
    if row["ours"] is None:
        return "-"
    if isinstance(row["paper"], str):
        if row.get("ours_says"):
            return row["ours_says"]
        return f"{'holds' if row.get('holds') else 'does not hold'} ({format_value(row['ours'], 4)})"
    if is_log10(row):
        return f"10^{row['ours']:.2f} = {_num(10 ** row['ours'])}"
    return ours_text(row)


def difference_text(row: dict) -> str:
    """Ours minus the paper (in decades for a log10), '-' for a statement."""
    if row["ours"] is None or isinstance(row["paper"], str):
        return "-"
    d = row["ours"] - float(row["paper"])
    return f"{'+' if d > 0 else ''}{_num(d)}" + (" decades" if is_log10(row) else "")


def tolerance_text(row: dict) -> str:
    """The tolerance as a number (the larger of the relative and absolute one), '-' for a statement."""
    if isinstance(row["paper"], str):
        return "-"
    tol = max(row.get("rel_tol", 0.0) * abs(float(row["paper"])), row.get("abs_tol", 0.0))
    return f"±{_num(tol)}" + (" decades" if is_log10(row) else "")


def cut(text: str, limit: int) -> str:
    """``text`` shortened at a word boundary to at most ``limit`` characters, with '…'."""
    text = " ".join(str(text).split())
    if len(text) <= limit:
        return text
    head = text[: limit + 1].rsplit(" ", 1)[0] if " " in text[: limit + 1] else text[:limit]
    return head.rstrip(",.;:—-") + "…"


def _details(text: str, limit: int, what: str = "full text") -> str:
    """HTML: ``text`` shortened at a word boundary, the whole of it one click away (<details>)."""
    text = " ".join(str(text).split())
    if len(text) <= limit:
        return _html(text)
    return f'{_html(cut(text, limit))} <details class="quote-full"><summary>{what}</summary>{_html(text)}</details>'


def _page_html(page: str) -> str:
    return str(Path(page).with_suffix(".html")) if page else ""


def scorecard_records(card: dict[str, list], reference: dict[str, dict]) -> list[dict]:
    """Every scorecard row as a flat record (the CSV and JSON downloads, the HTML table)."""
    out = []
    for paper, rows in card.items():
        page = reference[paper].get("notebook", "")
        for r in rows:
            out.append(
                {
                    "id": row_id(paper, r["quantity"]),
                    "paper": paper.upper(),
                    "quantity": r["quantity"],
                    "source": r.get("source", ""),
                    "paper_printed": paper_text(r),
                    "paper_value": r["paper"],
                    "ours": ours_form(r),
                    "ours_value": r["ours"],
                    "difference": difference_text(r),
                    "tolerance": tolerance_text(r),
                    "tolerance_basis": r.get("tolerance_basis", ""),
                    "status": r["status"],
                    "reason": r.get("note", ""),
                    "section": (f"{_page_html(page)}#{section_anchor(r['section'])}" if r.get("section") else ""),
                }
            )
    return out


CSV_NAME, JSON_NAME = "_scorecard.csv", "_scorecard.json"


def scorecard_csv(records: list[dict]) -> str:
    import csv
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(records[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(records)
    return buf.getvalue()


def scorecard_json(records: list[dict]) -> str:
    return (
        json.dumps(
            {
                "description": "pkmlib scorecard: every checkable statement of the five papers, as "
                "printed, beside ours (python -m pkmlib.tools.report)",
                "rows": records,
            },
            indent=1,
            ensure_ascii=False,
        )
        + "\n"
    )


_HEADS = (
    ("quantity", "text"),
    ("paper, as printed", "text"),
    ("ours, in the paper's form", "text"),
    ("difference", "num"),
    ("tolerance", "num"),
    ("status", "text"),
    ("reason", "text"),
)


def markdown_table(card: dict[str, list], reference: dict[str, dict]) -> str:
    """The full scorecard (``_reproduction.md``): per paper a heading, its count line and one
    table (raw HTML, so each row has its permalink id and each cell its class): quantity and
    source, the paper as printed (long quotes shortened, the whole quote one click away), ours in
    the paper's form, the difference, the tolerance and where it comes from, the status and the
    reason (visible, with a link to the notebook section)."""
    records = {rec["id"]: rec for rec in scorecard_records(card, reference)}
    out = []
    for paper, rows in card.items():
        ref = reference[paper]
        page = ref.get("notebook", "")
        key = CITATION_KEYS.get(paper)
        cite = f" [@{key}]" if key else ""
        out.append(f"## {paper.upper()}: {md_text(ref.get('mechanism') or MECHANISMS.get(paper, ''))} {{#{paper}}}\n")
        out.append(
            f"{md_text(ref.get('paper', ''))}{cite}. [Notebook]({page}). **{count_line(count_statuses(rows))}.**\n"
        )
        html = [
            f'<figure id="tbl-scorecard-{paper}" class="scorecard-holder">',
            (
                f'<figcaption class="small text-muted">{paper.upper()}: every checkable statement of the paper, as '
                "printed, beside ours (click a heading to sort; # is the row's permalink)</figcaption>"
            ),
            '<div class="table-scroll">',
            f'<table class="table table-sm scorecard" data-paper="{paper.upper()}">',
            "<thead><tr><th>#</th>"
            + "".join(f'<th data-sort="{kind}">{h}</th>' for h, kind in _HEADS)
            + "</tr></thead>",
            "<tbody>",
        ]
        for r in rows:
            rec = records[row_id(paper, r["quantity"])]
            reason = _html(rec["reason"])
            if rec["section"]:
                reason += (" " if reason else "") + f'<a href="{_html(rec["section"])}">section</a>'
            html.append(
                f'<tr id="{rec["id"]}" data-status="{_html(r["status"])}">'
                f'<td><a class="permalink" href="#{rec["id"]}" title="permalink">#</a></td>'
                f'<td class="quantity">{_html(r["quantity"])}<br><small class="text-muted">{_html(rec["source"])}</small></td>'
                f'<td class="printed">{_details(rec["paper_printed"], 90, "full quote")}</td>'
                f'<td class="ours">{_html_numbers(rec["ours"])}</td>'
                f'<td class="num">{_html_numbers(rec["difference"])}</td>'
                f'<td class="tolerance">{_html_numbers(rec["tolerance"])}'
                f'<br><small class="text-muted">{_details(rec["tolerance_basis"], 60, "why")}</small></td>'
                f'<td class="status status-{r["status"].split()[0].replace(chr(39), "")}">{_html(r["status"])}</td>'
                f'<td class="reason">{reason}</td></tr>'
            )
        html += ["</tbody></table></div></figure>"]
        out.append("::: {.column-page-right .small}\n\n```{=html}\n" + "\n".join(html) + "\n```\n\n:::\n")
    return "\n".join(out)


#: A component at the end of a quantity ("A_1^b x", "linear acceleration magnitude", "A Table 1 row 1
#: alpha"): rows that differ only in it are one printed statement (a vector, a table row).
_COMPONENT = re.compile(r"\s+(x|y|z|alpha|x1|x2|x3|xi|eta|zeta|magnitude)$")
#: Of a statement's rows, the first status in this order is the statement's.
_SEVERITY = (
    ERRATUM,
    EXPLAINED_DIFFERENCE,
    DIFFERS,
    MISSING,
    NOT_PAPER_PARAMETERS,
    BY_CONSTRUCTION,
    CONSISTENCY_CHECK,
    REPRODUCED,
)


def statements(rows: list[dict]) -> list[tuple[str, str, list[dict]]]:
    """The printed statements of a paper's rows, in order: (statement, status, rows). A printed
    vector or table row is one statement (rows differing only in their last component); its
    status is the most severe of its rows' (an erratum in one component makes it an erratum)."""
    groups: dict[str, list[dict]] = {}
    for r in rows:
        groups.setdefault(_COMPONENT.sub("", r["quantity"]), []).append(r)
    out = []
    for key, members in groups.items():
        status = next(s for s in _SEVERITY if any(m["status"] == s for m in members))
        out.append((key, status, members))
    return out


def summary_markdown(card: dict[str, list], reference: dict[str, dict]) -> str:
    """The home page's glance (``_summary.md``): per paper the printed statements by status (a
    printed vector or table row is one statement), the number of scorecard rows (one per printed
    number), and what is not reproduced, each with its reason and permalink."""
    cols = (REPRODUCED, ERRATUM, EXPLAINED_DIFFERENCE, DIFFERS, CONSISTENCY_CHECK, BY_CONSTRUCTION)
    extra = [
        s for s in (NOT_PAPER_PARAMETERS, MISSING) if any(r["status"] == s for rows in card.values() for r in rows)
    ]
    heads = (
        ["paper", "reproduced", "errata", "explained differences", "differs", "consistency checks", "by construction"]
        + extra
        + ["statements", "rows (numbers)"]
    )
    out = ["::: {.column-page-right .small}\n", "| " + " | ".join(heads) + " |", "|:--|" + "--:|" * (len(heads) - 1)]
    total = dict.fromkeys(STATUSES, 0)
    n_statements = n_rows = 0
    for paper, rows in card.items():
        ref = reference[paper]
        st = statements(rows)
        counts = dict.fromkeys(STATUSES, 0)
        for _, status, _ in st:
            counts[status] += 1
            total[status] += 1
        n_statements += len(st)
        n_rows += len(rows)
        cells = [
            f"[{paper.upper()}]({ref.get('notebook', '')}) {md_text(ref.get('mechanism') or MECHANISMS.get(paper, ''))}"
        ]
        cells += [str(counts[s]) for s in (*cols, *extra)]
        cells += [str(len(st)), f"[{len(rows)}](scorecard.qmd#{paper})"]
        out.append("| " + " | ".join(cells) + " |")
    out.append(
        "| **all** | "
        + " | ".join(f"**{total[s]}**" for s in (*cols, *extra))
        + f" | **{n_statements}** | [**{n_rows}**](scorecard.qmd) |"
    )
    out.append(
        "\n: What each paper reproduced, counted per printed statement: a printed vector or table row is "
        "one statement, with the status of its worst component; the last column counts the scorecard's rows, "
        "one per printed number (consistency checks and agreement by construction are not reproductions) "
        "{#tbl-home-counts}\n\n:::\n"
    )
    failures = [(p, r) for p, rows in card.items() for r in rows if r["status"] in NOT_REPRODUCED]
    if failures:
        out.append(
            "**What the papers got wrong, and what we could not reproduce** (each row links its scorecard "
            "row; the reason is the scorecard's):\n"
        )
        for paper, r in failures:
            link = f"scorecard.qmd#{row_id(paper, r['quantity'])}"
            reason = f": {md_text(cut(r['note'], 140))}" if r.get("note") else ""
            out.append(
                f"- **{paper.upper()}** [{md_text(r['quantity'])}]({link}): printed "
                f"{md_text(paper_text_english(r, 60))}, ours {md_text(cut(ours_form(r), 60))}, "
                f"*{r['status']}*{reason}"
            )
        out.append("")
    return "\n".join(out)


def verdict_markdown(paper: str, rows: list[dict], reference: dict) -> str:
    """A paper page's verdict box (``_verdict_<paper>.md``, included by its first markdown cell):
    the count line; then every row that is not reproduced (errata, explained differences,
    differs), each with its one-line reason; then the paper's ``main`` claims that are
    reproduced. Each line links its scorecard row (its permalink) and the section that shows it
    (links are relative to the notebook page); quotes are shortened at word boundaries with the
    whole quote one click away."""
    counts = count_statuses(rows)
    lines = [
        (
            f"**{count_line(counts)}** of {len(rows)} checked numbers and statements "
            f"([full scorecard](../scorecard.qmd#{paper})).\n"
        )
    ]

    def links(r):
        out = [f"[scorecard](../scorecard.qmd#{row_id(paper, r['quantity'])})"]
        if r.get("section"):
            out.append(f"[section](#{section_anchor(r['section'])})")
        return ", ".join(out)

    def quote(r):
        return md_text(cut(paper_text_english(r), 80))

    def full_quote(r):  # after the line's links: the whole quote, one click away, when it was cut
        if cut(paper_text_english(r), 80) == " ".join(paper_text_english(r).split()):
            return ""
        return f' <details class="quote-full"><summary>full quote</summary>{_html(paper_text(r))}</details>'

    failures = [r for r in rows if r["status"] in NOT_REPRODUCED]
    if failures:
        lines.append(f"**Not reproduced ({len(failures)}):**\n\n::: {{.verdict-failures}}\n")
        for r in failures:
            reason = f": {md_text(cut(r['note'], 160))}" if r.get("note") else ""
            lines.append(
                f"- {md_text(r['quantity'])}: paper {quote(r)}, ours {md_text(cut(ours_form(r), 60))}: "
                f"**{r['status']}**{reason} ({links(r)}){full_quote(r)}"
            )
        lines.append("\n:::\n")
    mains = [r for r in rows if r["main"] and r["status"] not in NOT_REPRODUCED]
    lines.append("**Main claims:**\n\n::: {.verdict-main}\n")
    for r in mains:
        note = f" ({md_text(r['note'])})" if r["note"] and r["status"] == REPRODUCED else ""
        lines.append(
            f"- {md_text(r['quantity'])}: paper {quote(r)}, ours {md_text(cut(ours_form(r), 60))}: "
            f"**{r['status']}**{note} ({links(r)}){full_quote(r)}"
        )
    if not mains:
        lines.append("- (no main claims marked in data/reference yet)")
    lines.append("\n:::")
    figures = reference.get("figures") or []
    if figures:
        n = {k: sum(f["status"] == k for f in figures) for k in FIGURE_STATUSES}
        counts_ = ", ".join(f"{v} {k}" for k, v in n.items() if v)
        lines.append(f'\n<details class="figure-list"><summary>The paper\'s figures and tables: {counts_}</summary>\n')
        lines.append("| figure or table | here | why |\n|:--|:--|:----|")
        for f in figures:
            lines.append(f"| {md_text(f['item'])} | {f['status']} | {md_text(f['why'])} |")
        lines.append(
            "\n*substituted*: drawn from our model, or our second method in place of the paper's "
            "simulation · *input*: data the computation starts from (no table number of its own here, so "
            "the page keeps the paper's table numbers)\n\n</details>"
        )
    return "\n".join(lines) + "\n"


# --- executed notebooks without volatile content --------------------------------------------------


def _joined(text: str | list[str]) -> str:
    return "".join(text) if isinstance(text, list) else text


def normalize_notebook(nb: dict) -> dict:
    """An executed notebook without what changes from run to run though the results do not:
    consecutive stream outputs of one name merged (the kernel may split one print in two),
    execution timing metadata dropped."""
    for cell in nb.get("cells", []):
        meta = cell.get("metadata", {})
        meta.pop("execution", None)
        meta.pop("papermill", None)
        outs, merged = cell.get("outputs", []), []
        for o in outs:
            if (
                o.get("output_type") == "stream"
                and merged
                and merged[-1].get("output_type") == "stream"
                and merged[-1].get("name") == o.get("name")
            ):
                merged[-1]["text"] = _joined(merged[-1]["text"]) + _joined(o["text"])
            else:
                merged.append(o)
        for o in merged:  # store stream text as nbformat does: a list of lines
            if o.get("output_type") == "stream" and isinstance(o.get("text"), str):
                o["text"] = o["text"].splitlines(keepends=True)
        if "outputs" in cell:
            cell["outputs"] = merged
    nb.get("metadata", {}).pop("papermill", None)
    return nb


def install_notebooks(src_dir: Path, dest_dir: Path) -> list[Path]:
    """Normalize every executed notebook of ``src_dir`` and write it over its namesake in
    ``dest_dir``, atomically, in nbformat's own layout (sorted keys, indent 1)."""
    written = []
    for src in sorted(Path(src_dir).glob("*.ipynb")):
        nb = normalize_notebook(load_json(src))
        text = json.dumps(nb, sort_keys=True, indent=1, ensure_ascii=False) + "\n"
        written.append(_atomic_write_text(Path(dest_dir) / src.name, text))
    return written


# --- command line --------------------------------------------------------------------------------


def build(reference_dir: Path = REFERENCE_DIR, results_dir: Path = RESULTS_DIR) -> tuple[dict, dict, dict[Path, str]]:
    """Everything the report writes, computed before anything is written: (reference, card,
    {path: text}). Raises ReportError naming the file at the first unusable input."""
    reference = load_reference(reference_dir)
    if not reference:
        raise ReportError(f"{reference_dir}: no reference files")
    results = {p: load_json(Path(results_dir) / f"{p}.json") for p in reference}
    card = scorecard(reference, results, results_dir=results_dir)
    missing = [f"{p}: {r['quantity']!r}" for p, rows in card.items() for r in rows if r["status"] == MISSING]
    if missing:
        files = sorted({str(Path(results_dir) / f"{m.split(':')[0]}.json") for m in missing})
        raise ReportError(
            f"{', '.join(files)}: no results row for {'; '.join(missing[:5])}"
            + (f" and {len(missing) - 5} more" if len(missing) > 5 else "")
        )
    out = {
        Path(results_dir) / MARKDOWN.name: markdown_table(card, reference),
        Path(results_dir) / SUMMARY: summary_markdown(card, reference),
    }
    for paper, rows in card.items():
        out[Path(results_dir) / VERDICT.format(paper=paper)] = verdict_markdown(paper, rows, reference[paper])
    records = scorecard_records(card, reference)
    out[Path(results_dir) / CSV_NAME] = scorecard_csv(records)
    out[Path(results_dir) / JSON_NAME] = scorecard_json(records)
    return reference, card, out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pkmlib.tools.report", description=__doc__.split("\n\n")[0])
    ap.add_argument("--reference-dir", type=Path, default=REFERENCE_DIR)
    ap.add_argument(
        "--results-dir",
        type=Path,
        default=RESULTS_DIR,
        help="the notebooks' results; the Markdown files are written here too",
    )
    ap.add_argument(
        "--notebooks-from",
        type=Path,
        metavar="DIR",
        help="first install the executed notebooks of DIR into notebooks/ (normalized, atomically)",
    )
    ap.add_argument("--notebooks-dir", type=Path, default=DATA_DIR.parent / "notebooks")
    ap.add_argument("--quiet", action="store_true", help="print only the count line")
    args = ap.parse_args(argv)
    try:
        if args.notebooks_from is not None:
            for p in install_notebooks(args.notebooks_from, args.notebooks_dir):
                print(f"installed {p}")
        reference, card, out = build(args.reference_dir, args.results_dir)
    except ReportError as e:
        print(
            f"pkmlib.tools.report: error: {e}; the scorecard files were left as they were (nothing written)",
            file=sys.stderr,
        )
        return 1
    if not args.quiet:
        for paper, rows in card.items():
            print(f"\n{paper.upper()}: {reference[paper].get('paper', '')}")
            print(format_table([r | {"paper": r.get("printed") or r["paper"]} for r in rows]))
    for path, text in out.items():
        _atomic_write_text(path, text)
    total = count_statuses([r for rows in card.values() for r in rows])
    print("\n" + count_line(total))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
