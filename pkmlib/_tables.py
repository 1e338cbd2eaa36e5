"""Tables for the report: rows of numbers as Markdown, which Quarto renders as real tables.

In a notebook, a cell whose first lines are ``#| label: tbl-...`` and ``#| tbl-cap: "..."`` and
whose last expression is ``pk.tools.markdown_table(...)`` shows a captioned, numbered table on the
site and a formatted table in Jupyter (the value is an ``IPython.display.Markdown``).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

from ._validation import check_count


def format_cell(v: Any, digits: int = 4) -> str:
    """One cell: numbers with ``digits`` significant digits (``-`` for None, ``NaN`` for NaN),
    text as it is with ``|`` escaped."""
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return str(v)
    if isinstance(v, str):
        return v.replace("|", "\\|")
    try:
        f = float(v)
    except (TypeError, ValueError):
        return str(v).replace("|", "\\|")
    if math.isnan(f):
        return "NaN"
    return f"{f:.{digits}g}"


def markdown_table_text(
    rows: Sequence[Sequence[Any]] | Sequence[dict],
    headers: Sequence[str] | None = None,
    *,
    digits: int = 4,
    align: Sequence[str] | None = None,
) -> str:
    """The Markdown source of a table. ``rows`` are sequences (with ``headers``) or dicts (the
    keys of the first row are the headers unless given). ``align``: ``"l"``/``"r"``/``"c"`` per
    column (default: right for numbers, left for text, read from the first row)."""
    check_count("digits", digits, minimum=1, maximum=17)
    if isinstance(rows, (str, bytes, dict)) or not hasattr(rows, "__iter__"):
        raise ValueError(f"rows must be a sequence of rows (sequences or dicts), got {rows!r}")
    rows = list(rows)
    if rows and isinstance(rows[0], dict):
        if not all(isinstance(r, dict) for r in rows):
            raise ValueError(f"rows must all be dicts when the first is, got {rows!r}")
        headers = list(headers or rows[0].keys())
        rows = [[r.get(h) for h in headers] for r in rows]
    if headers is None:
        raise ValueError("headers: needed when rows are sequences")
    if isinstance(headers, (str, bytes)) or not hasattr(headers, "__iter__"):
        raise ValueError(f"headers must be a sequence of column titles, got {headers!r}")
    headers = list(headers)
    for i, r in enumerate(rows):
        if isinstance(r, (str, bytes, dict)) or not hasattr(r, "__len__"):
            raise ValueError(f"rows[{i}] must be a sequence of {len(headers)} cells, got {r!r}")
        if len(r) != len(headers):
            raise ValueError(f"rows[{i}] has {len(r)} cells but there are {len(headers)} headers")
    if align is None:
        first = rows[0] if rows else [""] * len(headers)
        align = ["l" if isinstance(v, str) or v is None else "r" for v in first]
    rule = {"l": ":---", "r": "---:", "c": ":---:"}
    align = list(align)
    if len(align) != len(headers) or any(a not in rule for a in align):
        raise ValueError(f"align must be one of 'l', 'r', 'c' per column ({len(headers)}), got {align!r}")
    lines = ["| " + " | ".join(format_cell(h) for h in headers) + " |", "|" + "|".join(rule[a] for a in align) + "|"]
    lines += ["| " + " | ".join(format_cell(v, digits) for v in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def markdown_table(rows, headers=None, *, digits: int = 4, align=None):
    """:func:`markdown_table_text` wrapped in ``IPython.display.Markdown`` (for a notebook cell's
    last expression); the text itself is ``.data``."""
    from IPython.display import Markdown

    return Markdown(markdown_table_text(rows, headers, digits=digits, align=align))
