"""Checks of user-supplied parameters, raising ``ValueError`` that names the parameter.

These run on concrete Python/NumPy values when parameters are built (outside ``jit``); inside
``jit``/``vmap`` a pose outside the workspace is signalled by NaN instead (see
:func:`pkmlib.within_limits`), and so is a traced branch whose signs are not +-1 (see
:meth:`pkmlib.Mechanism.inverse`).

Accepted as a real number: Python ``int``/``float``, NumPy integer/floating scalars and 0-d
real arrays (concrete JAX arrays included). Refused, with the parameter's name: ``bool``,
strings (even ``"1.5"``), ``None``, complex numbers, lists and arrays with axes.
"""

from __future__ import annotations

import math
import numbers
from typing import Any, Mapping, Sequence

import numpy as np


def _is_tracer(value: Any) -> bool:
    try:
        import jax

        return isinstance(value, jax.core.Tracer)
    except Exception:  # pragma: no cover
        return False


def as_real(name: str, value: Any, accepted: str = "a real number") -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless ``value`` is one real
    number (see the module docstring for what counts)."""
    if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    if isinstance(value, numbers.Real):
        return float(value)
    if _is_tracer(value):
        raise ValueError(f"{name} must be {accepted} known before jit/vmap tracing, got a traced value")
    try:
        arr = np.asarray(value)
    except Exception:
        raise ValueError(f"{name} must be {accepted}, got {value!r}") from None
    if arr.ndim != 0 or arr.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return float(arr)


def check_positive(name: str, value: Any) -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless it is finite and > 0."""
    accepted = "a finite positive number"
    v = as_real(name, value, accepted)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return v


def check_finite(name: str, value: Any) -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless it is finite."""
    accepted = "a finite number"
    v = as_real(name, value, accepted)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return v


def check_range(name: str, lo: Any, hi: Any) -> tuple[float, float]:
    """Return ``(lo, hi)`` as floats; raise ``ValueError`` naming ``name`` unless lo <= hi."""
    lo_f, hi_f = check_finite(f"{name} (min)", lo), check_finite(f"{name} (max)", hi)
    if lo_f > hi_f:
        raise ValueError(f"{name}: min {lo!r} is greater than max {hi!r}")
    return lo_f, hi_f


def check_count(name: str, value: Any, *, minimum: int = 1, maximum: int | None = None) -> int:
    """Return ``int(value)``; raise ``ValueError`` naming ``name`` unless it is a whole number in
    ``[minimum, maximum]`` (an integral float such as ``3.0`` is accepted, ``2.5`` is not)."""
    accepted = f"a whole number >= {minimum}" + (f" and <= {maximum:,}" if maximum is not None else "")
    v = as_real(name, value, accepted)
    if not math.isfinite(v) or v != math.floor(v) or v < minimum or (maximum is not None and v > maximum):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return int(v)


def check_tolerance(name: str, value: Any) -> float:
    """A bisection or convergence tolerance: a finite number > 0 (``tol=0`` would never end)."""
    return check_positive(name, value)


def check_branch(branch: Any, n: int, name: str = "branch") -> Any:
    """Check a branch (one sign per chain): ``n`` entries, each +1 or -1.

    Concrete values (lists, tuples, NumPy or concrete JAX arrays) are checked fully and returned as
    a tuple of floats. A branch traced by ``jit``/``vmap`` can only be checked for its shape; it is
    returned unchanged and :meth:`pkmlib.Mechanism.inverse` turns the pose into NaN where its
    signs are not +-1.
    """
    accepted = f"{n} signs, each +1 or -1"
    if _is_tracer(branch):
        shape = tuple(branch.shape)
        if shape[:1] != (n,):
            raise ValueError(f"{name} must hold {accepted}; got a traced array of shape {shape}")
        return branch
    if branch is None or isinstance(branch, (str, bytes, numbers.Number, np.bool_)):
        raise ValueError(f"{name} must be a sequence of {accepted}, got {branch!r}")
    try:
        arr = np.asarray(branch)
    except Exception:
        raise ValueError(f"{name} must be a sequence of {accepted}, got {branch!r}") from None
    items = branch if isinstance(branch, (list, tuple)) else ()
    if arr.dtype == object or arr.dtype.kind == "b" or any(isinstance(b, (bool, np.bool_)) for b in items):
        raise ValueError(f"{name} must hold {accepted} (numbers, not booleans or other objects); got {branch!r}")
    if arr.ndim != 1 or arr.shape[0] != n:
        raise ValueError(f"{name} must hold {accepted}; got {branch!r} (shape {arr.shape})")
    if arr.dtype.kind not in "iuf" or not np.all((arr == 1) | (arr == -1)):
        raise ValueError(f"{name} must hold {accepted}; got {branch!r}")
    return tuple(float(b) for b in arr)


def check_mapping(name: str, d: Any) -> Mapping:
    """Raise ``ValueError`` naming ``name`` unless ``d`` is a mapping (a JSON object)."""
    if not isinstance(d, Mapping):
        raise ValueError(f"{name} must be a mapping of parameter names to values (a JSON object), "
                         f"got {type(d).__name__}: {d!r}")
    return d


def check_keys(name: str, d: Mapping, required: Sequence[str], optional: Sequence[str] = ()) -> None:
    """Raise ``ValueError`` naming the missing and the unknown keys of ``d`` and the accepted ones."""
    missing = [k for k in required if k not in d]
    unknown = [k for k in d if k not in required and k not in optional]
    if missing or unknown:
        parts = []
        if missing:
            parts.append(f"missing {', '.join(missing)}")
        if unknown:
            parts.append(f"unknown {', '.join(map(repr, unknown))}")
        accepted = ", ".join(required) + (f" (optional: {', '.join(optional)})" if optional else "")
        raise ValueError(f"{name}: {'; '.join(parts)}; accepted keys: {accepted}")


def nan_unless_signs(q: Any, branch: Any) -> Any:
    """``q`` (``(n, *batch)``), or NaN where a traced ``branch`` has entries other than +-1.

    The under-``jit`` counterpart of :func:`check_branch` (which has already checked a concrete
    branch): no exception can be raised from traced values, so the pose is marked invalid instead.
    """
    if not _is_tracer(branch):
        return q  # concrete: check_branch has already refused anything but +-1
    import jax.numpy as jnp

    b = jnp.asarray(branch)
    valid = jnp.all((b == 1.0) | (b == -1.0), axis=0)
    return jnp.where(valid, q, jnp.nan)


def check_number(name: str, value: Any, *, unit: str = "", positive: bool = False) -> float:
    """``float(value)`` for one finite real number (``> 0`` if ``positive``): a Python or NumPy
    number or a 0-d NumPy/JAX array; else the ``ValueError`` of :func:`pkmlib.check_parameter`,
    naming ``name``, the value, what is accepted and ``unit``."""
    import jax

    from ._notebook_parameters import check_parameter, number

    if isinstance(value, (np.ndarray, jax.Array)) and value.shape == () and value.dtype.kind in "fi":
        value = value.item()
    check_parameter(name, value, number(None, min=0.0 if positive else None, min_open=positive, unit=unit))
    return float(value)
