"""A size guard: work whose estimated memory exceeds a budget fails at once, naming what sets it."""

from __future__ import annotations

import math
import os

from ._validation import as_real, check_text

#: Fraction of the machine's memory a single sweep or simulation may use by default.
DEFAULT_FRACTION = 0.5
#: Environment variable overriding the budget, in bytes (e.g. ``PKMLIB_MEMORY_BUDGET=4e9``).
BUDGET_ENV = "PKMLIB_MEMORY_BUDGET"


def machine_memory() -> int:
    """Physical memory of this machine in bytes."""
    return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def memory_budget(budget: float | None = None) -> int:
    """The budget in bytes: ``budget`` if given, else ``$PKMLIB_MEMORY_BUDGET``, else half the
    machine's memory."""
    if budget is None:
        env = os.environ.get(BUDGET_ENV)
        if env:
            try:
                budget = float(env)
            except ValueError:
                budget = None
            if budget is None or not (budget > 0 and math.isfinite(budget)):
                raise ValueError(f"{BUDGET_ENV} must be a finite positive number of bytes, got {env!r}")
        else:
            budget = DEFAULT_FRACTION * machine_memory()
    budget = as_real("budget", budget, "a positive number of bytes")
    if not (budget > 0 and math.isfinite(budget)):
        raise ValueError(f"budget (memory_budget) must be a finite positive number of bytes, got {budget!r}")
    return int(budget)


def _gib(n: float) -> str:
    return f"{n / 2**30:.3g} GiB"


class MemoryBudgetError(ValueError, MemoryError):
    """Work that would need more memory than the budget (a bad size parameter, usually)."""


def _budget_source(budget: float | None) -> str:
    if budget is not None:
        return "the memory_budget given"
    if os.environ.get(BUDGET_ENV):
        return f"${BUDGET_ENV}"
    return f"{DEFAULT_FRACTION:g} of this machine's {_gib(machine_memory())}; set ${BUDGET_ENV} (bytes) to change it"


def check_memory(nbytes: float, *, what: str, parameter: str | None = None, budget: float | None = None) -> None:
    """Raise :class:`MemoryBudgetError` (a ``ValueError``) before anything is allocated when
    ``nbytes`` exceeds the budget (:func:`memory_budget`).

    ``what`` says what would be allocated ("a sweep of 7.1e8 points"); ``parameter`` names the
    parameter that sets its size (``"step_m"``), so a typo such as ``step_m = 2.5e-5`` fails at
    once with a message naming it, instead of meeting the kernel's out-of-memory killer.
    """
    check_text("what", what)
    if parameter is not None:
        check_text("parameter", parameter)
    limit = memory_budget(budget)
    nbytes = as_real("nbytes", nbytes, "a number of bytes >= 0")
    if nbytes < 0:
        raise ValueError(f"nbytes must be a number of bytes >= 0, got {nbytes!r}")
    by = f", set by {parameter}" if parameter else ""
    if math.isnan(nbytes):  # a size computed from a NaN parameter: refused, as a size over the budget is
        raise MemoryBudgetError(f"nbytes must be a number of bytes >= 0, got nan: the size of {what}{by}")
    if not nbytes <= limit:
        raise MemoryBudgetError(
            f"{what} needs about {_gib(nbytes)}{by}: more than the memory budget of {_gib(limit)} "
            f"({_budget_source(budget)})"
        )
