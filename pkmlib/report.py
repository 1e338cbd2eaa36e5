"""Print (and write as Markdown) the reproduction table of every paper's results.

``python -m pkmlib.report`` reads ``data/results/*.json``, prints one table per paper (paper
value, ours, relative error, status) and writes ``data/results/_reproduction.md``, which the
Quarto home page includes. ``make report`` runs it after executing the notebooks.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ._params import DATA_DIR
from ._results import format_table, format_value

RESULTS_DIR = DATA_DIR / "results"
MARKDOWN = RESULTS_DIR / "_reproduction.md"


def load_results(results_dir: Path = RESULTS_DIR) -> dict[str, dict]:
    """Every ``<paper>.json`` in ``results_dir``, by file stem, in name order."""
    return {p.stem: json.loads(p.read_text()) for p in sorted(results_dir.glob("*.json"))}


def markdown_table(results: dict[str, dict]) -> str:
    """All reproduction rows as one Markdown table (paper, quantity, paper value, ours, error, status)."""
    lines = ["| paper | quantity | paper value | ours | rel. error | status | source / note |",
             "|---|---|---|---|---|---|---|"]
    for name, res in results.items():
        for r in res.get("reproduction", []):
            note = r.get("note") or r.get("source", "")
            err = "-" if r.get("rel_error") is None else f"{r['rel_error']:.2e}"
            lines.append(f"| {name.upper()} | {r['quantity']} | {format_value(r['paper'], 7)} | "
                         f"{format_value(r['ours'], 7)} | {err} | {r['status']} | {note} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    results = load_results()
    if not results:
        print(f"no results in {RESULTS_DIR.name}/: run the notebooks first (make report)")
        return 1
    for name, res in results.items():
        print(f"\n{name.upper()}: {res.get('paper', '')}")
        print(format_table(res.get("reproduction", [])))
    MARKDOWN.write_text(markdown_table(results))
    counts: dict[str, int] = {}
    for res in results.values():
        for r in res.get("reproduction", []):
            counts[r["status"]] = counts.get(r["status"], 0) + 1
    print("\n" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
