"""Numeric results of a notebook: summary statistics, the paper-vs-ours table, JSON output."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ._atomic import atomic_write_text as _atomic_write_text
from ._validation import (
    as_real,
    check_choice,
    check_count,
    check_finite,
    check_flag,
    check_mapping,
    check_nonnegative,
    check_text,
)

#: Status words of a reproduction row.
REPRODUCED, DIFFERS, ERRATUM = "reproduced", "differs", "erratum"
#: Status of every row of a run at parameters other than the paper's (see pkmlib.tools.check_parameters).
NOT_PAPER_PARAMETERS = "not the paper's parameters"
#: Scorecard statuses that are not reproductions (set by ``pkmlib.tools.report`` from data/reference):
#: our own check (``kind: "consistency"``), agreement because our value was inferred from the
#: paper's numbers (``by_construction``), and a reference row without a results row.
CONSISTENCY_CHECK, BY_CONSTRUCTION, MISSING = "consistency check", "by construction", "missing"
#: A difference from the paper that the notebook explains (the reference row's ``explained`` says
#: how: e.g. the paper leaves a centre of mass open and the printed section needs another one);
#: "differs" is kept for what is not explained.
EXPLAINED_DIFFERENCE = "explained difference"


def summary(values: np.ndarray, stats: Iterable[str] = ("min", "median", "max")) -> dict[str, float]:
    """NaN-ignoring summary statistics of ``values`` (NaN marks poses outside the workspace).

    ``values`` may have any shape (a map over a grid, as :func:`pkmlib.sweep` returns): all its
    entries are pooled, and non-finite ones (NaN, inf) are left out."""
    funcs = {"min": np.min, "median": np.median, "mean": np.mean, "max": np.max}
    if isinstance(stats, str):
        raise ValueError(f"stats must be a sequence of statistic names {tuple(funcs)}, got {stats!r}")
    stats = [check_choice("stats", s, tuple(funcs)) for s in stats]
    try:
        v = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"values must be an array of real numbers, got {values!r}") from None
    v = v[np.isfinite(v)]
    return {s: (float(funcs[s](v)) if v.size else math.nan) for s in stats}


def within_tolerance(paper: float, ours: float, *, rel_tol: float = 0.0, abs_tol: float = 0.0) -> bool:
    """The tolerance rule of every reproduction row (notebooks and scorecard):
    ``|ours - paper| <= max(rel_tol * |paper|, abs_tol)``."""
    paper, ours = float(paper), float(ours)
    return abs(ours - paper) <= max(float(rel_tol or 0.0) * abs(paper), float(abs_tol or 0.0))


def relative_error(paper: float, ours: float) -> float:
    """``|ours - paper| / |paper|``, or ``|ours|`` when the paper prints 0."""
    paper, ours = float(paper), float(ours)
    return abs(ours - paper) / abs(paper) if paper != 0 else abs(ours)


def compare(
    quantity: str,
    paper: float,
    ours: float,
    *,
    rel_tol: float = 0.0,
    abs_tol: float = 0.0,
    source: str = "",
    erratum: str | None = None,
    explained: str | None = None,
    paper_run: bool = True,
) -> dict[str, Any]:
    """One row of a reproduction table.

    ``status`` is ``"reproduced"`` when ``|ours - paper| <= max(rel_tol * |paper|, abs_tol)``;
    otherwise ``"erratum"`` when ``erratum`` explains why the printed value cannot be right, else
    ``"explained difference"`` when ``explained`` says why ours differs (e.g. an input the paper
    leaves open), else ``"differs"``; the reason is the row's ``note``. The tolerances should be those
    the printed precision implies. With ``paper_run=False`` (a re-run at other parameters) the status
    is ``"not the paper's parameters"``.

    ``paper`` must be a finite number (a printed value: NaN or inf is refused, never a "differs"
    row); ``ours`` may be NaN or inf (a computation that failed, e.g. a pose outside the
    workspace), which gives ``"differs"`` (or the erratum / explained status).
    """
    check_text("quantity", quantity)
    _check_source(source)
    paper_f = check_finite("paper", paper)
    ours_f = as_real("ours", ours)
    rel_tol, abs_tol = check_nonnegative("rel_tol", rel_tol), check_nonnegative("abs_tol", abs_tol)
    _check_reason("erratum", erratum)
    _check_reason("explained", explained)
    check_flag("paper_run", paper_run)
    rel = relative_error(paper_f, ours_f)
    holds = within_tolerance(paper_f, ours_f, rel_tol=rel_tol, abs_tol=abs_tol)
    status, note = _status(holds, erratum, explained)
    if not paper_run:
        status = NOT_PAPER_PARAMETERS
    row = {
        "quantity": quantity,
        "paper": paper_f,
        "ours": ours_f,
        "rel_error": rel,
        "rel_tol": float(rel_tol),
        "abs_tol": float(abs_tol),
        "status": status,
        "source": source,
    }
    if note:
        row["note"] = note
    return row


def _check_source(source: Any) -> None:
    if not isinstance(source, str):
        raise ValueError(f"source must be text (where the paper prints the value, or ''), got {source!r}")


def _check_reason(name: str, reason: str | None) -> None:
    if reason is not None and not isinstance(reason, str):
        raise ValueError(f"{name} must be the reason as text or None, got {reason!r}")


def _status(holds: bool, erratum: str | None, explained: str | None) -> tuple[str, str | None]:
    """The status of a row and its reason: reproduced; else an erratum (the printed value cannot be
    right), an explained difference (ours differs for a stated reason), or differs (not explained).
    The same order as the scorecard's (``pkmlib.tools.report``)."""
    if holds:
        return REPRODUCED, erratum if erratum else None
    if erratum:
        return ERRATUM, erratum
    if explained:
        return EXPLAINED_DIFFERENCE, explained
    return DIFFERS, None


def claim(
    quantity: str,
    statement: str,
    ours: float,
    holds: bool,
    *,
    source: str = "",
    erratum: str | None = None,
    explained: str | None = None,
    paper_run: bool = True,
) -> dict[str, Any]:
    """One row of a reproduction table for a qualitative claim of the paper (``statement``,
    e.g. "always >= 0"), checked on our number ``ours``: ``"reproduced"`` if ``holds``, else
    ``"erratum"`` when ``erratum`` says why the geometry contradicts the claim, else
    ``"explained difference"`` when ``explained`` says why ours differs, else ``"differs"`` (the
    reason is the row's ``note``); ``"not the paper's parameters"`` with ``paper_run=False``."""
    check_text("quantity", quantity)
    if not isinstance(statement, str):
        raise ValueError(f"statement must be the paper's claim as text, got {statement!r}")
    _check_source(source)
    ours = as_real("ours", ours)
    check_flag("holds", holds)
    _check_reason("erratum", erratum)
    _check_reason("explained", explained)
    check_flag("paper_run", paper_run)
    status, note = _status(holds, erratum, explained)
    if holds:
        note = None  # a claim that holds carries no erratum
    row = {
        "quantity": quantity,
        "paper": statement,
        "ours": float(ours),
        "rel_error": None,
        "status": status if paper_run else NOT_PAPER_PARAMETERS,
        "source": source,
    }
    if note:
        row["note"] = note
    return row


def format_value(v: Any, digits: int = 4) -> str:
    """A table cell: numbers with ``digits`` significant digits, text as it is, None as '-'."""
    if v is None:
        return "-"
    if isinstance(v, str):
        return v
    return f"{v:.{digits}g}"


def format_table(rows: list[dict[str, Any]], digits: int = 4) -> str:
    """Plain-text table of reproduction rows with a fixed number of significant digits."""
    check_count("digits", digits, minimum=1, maximum=17)
    if isinstance(rows, (str, bytes, dict)) or not all(isinstance(r, dict) for r in rows):
        raise ValueError(
            f"rows must be a list of result rows (dicts made by pkmlib.tools.compare / pkmlib.tools.claim), got {rows!r}"
        )
    for i, r in enumerate(rows):
        missing = [k for k in ("quantity", "paper", "ours", "rel_error", "status") if k not in r]
        if missing:
            raise ValueError(
                f"rows[{i}] is not a result row (made by pkmlib.tools.compare / pkmlib.tools.claim): missing {missing}"
            )
    header = ("quantity", "paper", "ours", "rel. error", "status")
    body = [
        (
            r["quantity"],
            format_value(r["paper"], digits),
            format_value(r["ours"], digits),
            "-" if r["rel_error"] is None else f"{r['rel_error']:.2e}",
            r["status"],
        )
        for r in rows
    ]
    widths = [max(len(str(c)) for c in col) for col in zip(header, *body)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths)).rstrip()  # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths])] + [line(b) for b in body])


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray) or hasattr(obj, "__array__"):
        return _jsonable(np.asarray(obj).tolist())
    if isinstance(obj, (float, np.floating)):
        f = float(obj)
        return f if math.isfinite(f) else None  # JSON has no NaN: null marks "outside / undefined"
    return obj


def write_results(path: str | Path, results: dict[str, Any]) -> Path:
    """Write ``results`` as JSON (NaN and inf become ``null``), creating the folder; atomically
    (temporary file in the same folder, then rename), so an interrupted run leaves the old file."""
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise ValueError(f"path must be the path (a str or pathlib.Path) of the JSON file to write, got {path!r}")
    check_mapping("results", results)
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"path must be the path of a JSON file, got the folder {str(path)!r}")
    try:
        text = json.dumps(_jsonable(results), indent=2, sort_keys=False) + "\n"
    except (TypeError, ValueError) as e:
        raise ValueError(
            f"results must hold only numbers, text, booleans, None, lists, mappings and arrays (JSON), but {e}"
        ) from None
    path.parent.mkdir(parents=True, exist_ok=True)
    return _atomic_write_text(path, text)
