"""Checks of user-supplied parameters, raising ``ValueError`` that names the parameter.

These run on concrete Python/NumPy values when parameters are built (outside ``jit``); inside
``jit``/``vmap`` a pose outside the workspace is signalled by NaN instead (see
:func:`pkmlib.within_limits`).
"""

from __future__ import annotations

import math


def check_positive(name: str, value: float) -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless it is finite and > 0."""
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be a finite positive number, got {value!r}")
    return v


def check_finite(name: str, value: float) -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless it is finite."""
    v = float(value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def check_range(name: str, lo: float, hi: float) -> tuple[float, float]:
    """Return ``(lo, hi)`` as floats; raise ``ValueError`` naming ``name`` unless lo <= hi."""
    lo_f, hi_f = check_finite(f"{name} (min)", lo), check_finite(f"{name} (max)", hi)
    if lo_f > hi_f:
        raise ValueError(f"{name}: min {lo!r} is greater than max {hi!r}")
    return lo_f, hi_f
