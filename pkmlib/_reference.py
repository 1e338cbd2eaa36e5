"""What the papers print: ``data/reference/<paper>.json``, the one source notebooks read from."""

from __future__ import annotations

import json
from typing import Any

from ._params import DATA_DIR

REFERENCE_DIR = DATA_DIR / "reference"


def load_reference_file(paper: str) -> dict[str, Any]:
    """``data/reference/<paper>.json`` (``paper`` is ``"p1"`` .. ``"p5"``)."""
    path = REFERENCE_DIR / f"{paper}.json"
    if not path.is_file():
        known = sorted(p.stem for p in REFERENCE_DIR.glob("*.json"))
        raise ValueError(f"paper {paper!r}: no {path.name} in data/reference (known: {known})")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: invalid JSON ({e})") from None


def reference_row(paper: str, quantity: str) -> dict[str, Any]:
    """The reference row of ``quantity``: ``paper`` (value or statement), ``printed``, ``source``,
    tolerances, expected status."""
    rows = load_reference_file(paper)["numbers"]
    for r in rows:
        if r["quantity"] == quantity:
            return r
    raise ValueError(f"quantity {quantity!r} is not in data/reference/{paper}.json")


def paper_value(paper: str, quantity: str) -> Any:
    """The value the paper prints for ``quantity`` (as stored in ``data/reference/<paper>.json``)."""
    return reference_row(paper, quantity)["paper"]


def compare_reference(paper: str, quantity: str, ours: float, *, paper_run: bool = True) -> dict[str, Any]:
    """One scorecard row: our number against the value ``paper`` prints for ``quantity``, with the
    tolerances, source, erratum and explanation (``explained``: an "explained difference" when ours
    differs) stored in ``data/reference/<paper>.json`` (:func:`pkmlib.tools.compare` on :func:`reference_row`)."""
    from ._results import compare

    ref = reference_row(paper, quantity)
    return compare(
        quantity,
        ref["paper"],
        ours,
        rel_tol=ref.get("rel_tol", 0.0),
        abs_tol=ref.get("abs_tol", 0.0),
        source=ref["source"],
        erratum=ref.get("erratum"),
        explained=ref.get("explained"),
        paper_run=paper_run,
    )


def claim_reference(paper: str, quantity: str, ours: float, holds: bool, *, paper_run: bool = True) -> dict[str, Any]:
    """One scorecard row for a statement of the paper (``data/reference/<paper>.json``'s
    ``quantity``), checked on our number ``ours`` (:func:`pkmlib.tools.claim` on :func:`reference_row`,
    with the row's ``erratum`` and ``explained``: an "explained difference" when the claim fails for
    the reason the row states)."""
    from ._results import claim

    ref = reference_row(paper, quantity)
    return claim(
        quantity,
        ref["paper"],
        ours,
        holds,
        source=ref["source"],
        erratum=ref.get("erratum"),
        explained=ref.get("explained"),
        paper_run=paper_run,
    )
