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
        raise ValueError(
            f"{name} must be a mapping of parameter names to values (a JSON object), got {type(d).__name__}: {d!r}"
        )
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


# --- arguments of the public functions (tests/test_public_api_validation.py walks every one) ------


def check_nonnegative(name: str, value: Any, accepted: str = "a finite number >= 0") -> float:
    """Return ``float(value)``; raise ``ValueError`` naming ``name`` unless it is finite and >= 0."""
    v = as_real(name, value, accepted)
    if not math.isfinite(v) or v < 0.0:
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return v


def check_index(name: str, value: Any, n: int, what: str = "") -> int:
    """Return ``int(value)``; raise ``ValueError`` naming ``name`` unless it is a whole number in
    ``0..n-1`` (``what`` says what is indexed, e.g. "an output coordinate")."""
    accepted = f"an index 0..{n - 1}" + (f" ({what})" if what else "")
    if isinstance(value, (bool, np.bool_)) or _is_tracer(value):
        raise ValueError(f"{name} must be {accepted} known before tracing, got {value!r}")
    try:
        v = as_real(name, value, accepted)
    except ValueError:
        raise ValueError(f"{name} must be {accepted}, got {value!r}") from None
    if v != math.floor(v) or not 0 <= v < n:
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return int(v)


def check_indices(name: str, values: Any, n: int, what: str = "") -> tuple[int, ...]:
    """Each of ``values`` (a sequence) by :func:`check_index`; returned as a tuple of ints."""
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise ValueError(f"{name} must be a sequence of indices 0..{n - 1}, got {values!r}")
    return tuple(check_index(f"{name}", v, n, what) for v in values)


def check_flag(name: str, value: Any) -> bool:
    """Return ``bool(value)``; raise ``ValueError`` naming ``name`` unless it is ``True`` or
    ``False`` (a Python, NumPy or concrete 0-d JAX boolean; not 1, "yes" or None)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if (
        not _is_tracer(value)
        and hasattr(value, "dtype")
        and getattr(value, "shape", None) == ()
        and np.asarray(value).dtype == np.bool_
    ):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def check_text(name: str, value: Any) -> str:
    """Return ``value``; raise ``ValueError`` naming ``name`` unless it is a non-empty string."""
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")
    return value


def check_callable(name: str, value: Any, accepted: str = "a function") -> Any:
    """Return ``value``; raise ``ValueError`` naming ``name`` unless it can be called."""
    if not callable(value):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return value


def check_positive_values(name: str, value: Any, accepted: str = "a finite positive number") -> Any:
    """``value`` unchanged; ``ValueError`` naming ``name`` unless it is a real number or a
    concrete array of them, each finite and > 0. A traced value is returned unchecked."""
    if _is_tracer(value):
        return value
    if value is None or isinstance(value, (str, bytes, bool, np.bool_, complex, np.complexfloating)):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    a = concrete(value)
    if a is None or a.size == 0 or not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ValueError(f"{name} must be {accepted}, got {value!r}")
    return value


def check_mechanism(name: str, value: Any) -> Any:
    """Return ``value``; raise ``ValueError`` naming ``name`` unless it is a :class:`pkmlib.Mechanism`."""
    from ._mechanism import Mechanism

    if not isinstance(value, Mechanism):
        raise ValueError(f"{name} must be a pkmlib.Mechanism, got {type(value).__name__}: {value!r}")
    return value


def check_choice(name: str, value: Any, options: Sequence[Any]) -> Any:
    """Return ``value``; raise ``ValueError`` naming ``name`` and the options unless it is one."""
    if isinstance(value, (list, dict, set)) or value not in tuple(options):
        raise ValueError(f"{name} must be one of {tuple(options)!r}, got {value!r}")
    return value


def check_array(
    name: str,
    value: Any,
    shape: Sequence[int | None] | None = None,
    *,
    ndim: int | None = None,
    min_ndim: int | None = None,
    what: str = "",
) -> Any:
    """``value`` as a float64 JAX array (traced values included: their shape is known); raise
    ``ValueError`` naming ``name`` unless it holds real numbers of the given ``shape`` (``None``:
    any length on that axis; a shorter ``shape`` than the array's checks its leading axes, the
    rest being batch axes), ``ndim`` or at least ``min_ndim`` axes."""
    import jax.numpy as jnp

    label = f"{name}" + (f" ({what})" if what else "")
    if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
        raise ValueError(f"{label} must be an array of real numbers, got {value!r}")
    if not _is_tracer(value):
        try:
            arr = np.asarray(value)
        except Exception:  # e.g. a list holding traced values: jnp.asarray below takes it
            arr = None
        if arr is not None and arr.dtype.kind not in "iuf":
            raise ValueError(f"{label} must be an array of real numbers, got {value!r}")
    try:
        out = jnp.asarray(value, dtype=jnp.float64)
    except Exception:
        raise ValueError(f"{label} must be an array of real numbers, got {value!r}") from None
    if ndim is not None and out.ndim != ndim:
        raise ValueError(f"{label} must have {ndim} axes, got shape {out.shape}")
    if min_ndim is not None and out.ndim < min_ndim:
        raise ValueError(f"{label} must have at least {min_ndim} axes, got shape {out.shape}")
    if shape is not None:
        shape = tuple(shape)
        lead = out.shape[: len(shape)]
        if len(lead) != len(shape) or any(s is not None and s != d for s, d in zip(shape, lead)):
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + (",)" if len(shape) == 1 else ")")
            raise ValueError(
                f"{label} must have shape {want}"
                + (" (then batch axes)" if ndim is None else "")
                + f", got shape {out.shape}"
            )
    return out


def check_square(name: str, value: Any, sizes: Sequence[int] | None = None, what: str = "") -> Any:
    """A square matrix ``(n, n)`` (then batch axes), ``n`` in ``sizes`` if given, as a float64 array."""
    out = check_array(name, value, min_ndim=2, what=what)
    n = out.shape[0]
    if out.shape[1] != n or (sizes is not None and n not in tuple(sizes)):
        accepted = "a square matrix (n, n)" + (f" with n in {tuple(sizes)}" if sizes is not None else "")
        raise ValueError(f"{name} must be {accepted}, got shape {out.shape}")
    return out


def nan_unless_nonnegative(result: Any, *values: Any) -> Any:
    """``result``, or NaN where any of the traced ``values`` is negative or NaN: the under-``jit``
    counterpart of :func:`check_nonnegative` (already applied to concrete values) in per-pose
    functions, where no exception can be raised without a host callback in every fused loop."""
    traced = [v for v in values if _is_tracer(v)]
    if not traced:
        return result
    import jax.numpy as jnp

    ok = jnp.all(jnp.stack([jnp.all(jnp.asarray(v) >= 0.0) for v in traced]))
    return jnp.where(ok, result, jnp.nan)


def check_positive_traced(name: str, value: Any, accepted: str = "a finite positive number") -> Any:
    """Concrete: :func:`check_positive` (``ValueError``). Traced (inside ``jit``/``vmap``):
    ``equinox.error_if`` on ``value`` with the same message, raised when the compiled program runs
    (JAX reports it as its runtime error, the message included). Returns ``value``."""
    if not _is_tracer(value):
        v = as_real(name, value, accepted)
        if not math.isfinite(v) or v <= 0.0:
            raise ValueError(f"{name} must be {accepted}, got {value!r}")
        return value
    import equinox as eqx
    import jax.numpy as jnp

    bad = ~(jnp.isfinite(value) & (value > 0.0))
    return eqx.error_if(value, bad, f"{name} must be {accepted}")


def check_last_axis(name: str, value: Any, n: int, what: str = "") -> Any:
    """``value`` as a float64 array whose last axis has length ``n`` (leading axes: a batch);
    ``ValueError`` naming ``name`` otherwise (a 2-vector where 3 coordinates are meant)."""
    out = check_array(name, value, what=what)
    if out.ndim < 1 or out.shape[-1] != n:
        raise ValueError(
            f"{name}" + (f" ({what})" if what else "") + f" must have {n} entries on its last axis "
            f"(shape (..., {n})), got shape {out.shape}"
        )
    return out


def check_last_axes(name: str, value: Any, shape: Sequence[int], what: str = "") -> Any:
    """``value`` as a float64 array whose last axes have ``shape`` (e.g. ``(3, 3)`` matrices, leading axes a batch)."""
    out = check_array(name, value, what=what)
    k = len(shape)
    if out.ndim < k or tuple(out.shape[-k:]) != tuple(shape):
        want = ", ".join(map(str, shape))
        raise ValueError(
            f"{name}" + (f" ({what})" if what else "") + f" must have shape (..., {want}), got shape {out.shape}"
        )
    return out


def positive_or_nan(name: str, value: Any, accepted: str = "a finite positive number") -> Any:
    """Concrete ``value`` (one number or an array): ``ValueError`` naming ``name`` unless every
    entry is finite and > 0. Traced: NaN where it is not (the result of a formula divided by a
    negative mass is then NaN, never a finite wrong number). Returns ``value`` as a float64 array."""
    import jax.numpy as jnp

    out = check_array(name, value)
    a = concrete(value)
    if a is not None:
        if not np.all(np.isfinite(a)) or np.any(a <= 0):
            raise ValueError(f"{name} must be {accepted}, got {value!r}")
        return out
    return jnp.where(jnp.isfinite(out) & (out > 0), out, jnp.nan)


def concrete(value: Any) -> np.ndarray | None:
    """``value`` as a NumPy array when it is known now (not traced by ``jit``/``vmap``), else None.
    Checks of values use this, not ``jnp`` operations: inside ``jit`` even a ``jnp`` operation on
    a constant is traced and cannot be turned into a Python bool."""
    if _is_tracer(value):
        return None
    try:
        return np.asarray(value, dtype=np.float64)
    except Exception:
        return None


def check_number(name: str, value: Any, *, unit: str = "", positive: bool = False) -> float:
    """``float(value)`` for one finite real number (``> 0`` if ``positive``): a Python or NumPy
    number or a 0-d NumPy/JAX array; else the ``ValueError`` of :func:`pkmlib.tools.check_parameter`,
    naming ``name``, the value, what is accepted and ``unit``."""
    import jax

    from ._notebook_parameters import check_parameter, number

    if isinstance(value, (np.ndarray, jax.Array)) and value.shape == () and value.dtype.kind in "fi":
        value = value.item()
    check_parameter(name, value, number(None, min=0.0 if positive else None, min_open=positive, unit=unit))
    return float(value)


def check_first_axis(name: str, value: Any, n: int, what: str = "") -> None:
    """Raise ``ValueError`` naming ``name`` unless ``value`` (an array, traced or not, a tuple or a
    list) holds ``n`` entries on its first axis (then batch axes): a 3-vector where a mechanism
    has 4 coordinates was read as its first entries (or indexed past them). Nothing is converted."""
    label = f"{name}" + (f" ({what})" if what else "")
    if isinstance(value, (tuple, list)):
        m = len(value)
    else:
        shape = getattr(value, "shape", None)
        if shape is None:
            try:
                shape = np.shape(np.asarray(value, dtype=np.float64))
            except (TypeError, ValueError):
                raise ValueError(f"{label} must be an array of real numbers, got {value!r}") from None
        m = shape[0] if len(shape) else None
    if m != n:
        raise ValueError(
            f"{label} must hold {n} entries on its first axis (then batch axes), got {'a scalar' if m is None else m}"
        )
