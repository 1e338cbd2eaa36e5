"""The reproduction report's tooling: a notebook's parameters checked before any work, the
paper-vs-ours comparison and results files, the papers' printed values, Markdown tables; and the
two commands, ``python -m pkmlib.tools.report`` (the scorecard) and ``python -m pkmlib.tools.rerun``
(a notebook re-run with other parameters; :mod:`pkmlib.tools.rerun`, imported on demand).

Formerly at ``pkmlib.*``, ``pkmlib.report`` and ``pkmlib.rerun`` (those still work for one
release, with a ``DeprecationWarning``)."""

from .._notebook_parameters import (
    ParameterRule,
    ParameterSpec,
    check_parameter,
    check_parameters,
    choice,
    flag,
    less,
    not_all_zero,
    number,
    numbers,
    signs,
    text,
)
from .._reference import claim_reference, compare_reference, load_reference_file, paper_value, reference_row
from .._results import NOT_PAPER_PARAMETERS, claim, compare, format_table, summary, write_results
from .._tables import markdown_table, markdown_table_text

__all__ = [
    # a notebook's parameters
    "ParameterRule",
    "ParameterSpec",
    "check_parameter",
    "check_parameters",
    "choice",
    "flag",
    "less",
    "not_all_zero",
    "number",
    "numbers",
    "signs",
    "text",
    # results, the paper-vs-ours comparison and the papers' printed values
    "NOT_PAPER_PARAMETERS",
    "claim",
    "claim_reference",
    "compare",
    "compare_reference",
    "format_table",
    "load_reference_file",
    "paper_value",
    "reference_row",
    "summary",
    "write_results",
    # tables
    "markdown_table",
    "markdown_table_text",
]
