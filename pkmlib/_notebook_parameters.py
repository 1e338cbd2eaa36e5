"""Checks of a notebook's ``parameters`` cell: one call in the cell after it.

Each notebook declares, for every name in its ``parameters`` cell, what is accepted and what the
paper used::

    paper_run = pkmlib.tools.check_parameters(globals(), {
        "phi_deg": pkmlib.tools.number(20.0, min=0.0, max=90.0, max_open=True, unit="deg"),
        "dx_D_m": pkmlib.tools.number(0.005, min=0.0, min_open=True, unit="m"),
        "branch": pkmlib.tools.signs([-1, 1, -1, 1]),
        "x_D_range_m": pkmlib.tools.numbers([0.2, 1.2], shape=(2,), increasing=True, unit="m"),
        "l3_is": pkmlib.tools.choice("circumradius", "circumradius", "side"),
        "results_path": pkmlib.tools.text("../data/results/p1.json", output=True),
    }, rules=[pkmlib.tools.not_all_zero("F_D_N", "T_N_m", "F_s_N")])

``rules`` are conditions on several parameters together: :func:`not_all_zero` (loads of a map),
:func:`less` (``q_min_m`` < ``q_max_m``).

A value that is not accepted raises ``ValueError`` naming the parameter, the value and what is
accepted, before any work is done. The return value says whether every input equals the paper's
(``output=True`` entries, where results are written, do not count): a run at other parameters
scores itself as "not the paper's parameters" instead of calling its own numbers errata.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ._validation import check_callable, check_choice, check_finite, check_flag, check_mapping, check_text

_KINDS = ("number", "numbers", "signs", "choice", "text", "flag")


class _NotASpec(ValueError, TypeError):
    """A spec entry that is not a ParameterSpec: a ValueError (bad input) and, as before, a TypeError."""


@dataclasses.dataclass(frozen=True)
class ParameterSpec:
    """What one notebook parameter accepts, and the paper's value."""

    kind: str  # "number", "numbers", "signs", "choice", "text", "flag"
    paper: Any
    min: float | None = None
    max: float | None = None
    min_open: bool = False
    max_open: bool = False
    integer: bool = False
    unit: str = ""
    shape: tuple[int | None, ...] | None = None
    increasing: bool | tuple[tuple[int, int], ...] = False
    choices: tuple[Any, ...] = ()
    output: bool = False

    def __post_init__(self):
        check_choice("kind", self.kind, _KINDS)
        for name in ("min", "max"):
            if getattr(self, name) is not None:
                check_finite(name, getattr(self, name))
        for name in ("min_open", "max_open", "integer", "output"):
            check_flag(name, getattr(self, name))
        if self.shape is not None and (
            not isinstance(self.shape, tuple)
            or not all(
                d is None or (isinstance(d, (int, np.integer)) and not isinstance(d, bool) and d >= 1)
                for d in self.shape
            )
        ):
            raise ValueError(
                f"shape must be None or a tuple of lengths (whole numbers >= 1, None for any length), got {self.shape!r}"
            )
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min must not exceed max, got min={self.min!r}, max={self.max!r}")
        if not isinstance(self.unit, str):
            raise ValueError(f"unit must be text (e.g. 'mm' or ''), got {self.unit!r}")
        if self.kind == "choice" and not self.choices:
            raise ValueError("options: a choice needs at least one option, got none")
        if self.paper is not None:  # None: a spec used only as a check, with no paper's value
            _check_paper_kind(self)  # its range and shape: check_parameters, naming the parameter

    def accepted(self) -> str:
        """What is accepted, in words (used in error messages)."""
        unit = f" {self.unit}" if self.unit else ""
        if self.kind == "choice":
            return "one of " + ", ".join(repr(c) for c in self.choices)
        if self.kind == "text":
            return "a string"
        if self.kind == "flag":
            return "True or False"
        if self.kind == "signs":
            return f"a list of {self.shape[0]} signs, each +1 or -1"
        what = "an integer" if self.integer else "a finite number"
        bounds = _bounds_text(self)
        if self.kind == "number":
            return f"{what}{bounds}{unit}"
        shape = "x".join("n" if s is None else str(s) for s in self.shape) if self.shape else "any length"
        if self.increasing is True:
            inc = ", increasing"
        elif self.increasing:
            inc = ", with " + " and ".join(f"entry {i} < entry {j}" for i, j in self.increasing)
        else:
            inc = ""
        unit = f", in {self.unit}" if self.unit else ""
        return f"a list ({shape}) of finite numbers{bounds}{unit}{inc}"


def _bounds_text(s: ParameterSpec) -> str:
    if s.min is None and s.max is None:
        return ""
    if s.max is None:
        return f" {'>' if s.min_open else '>='} {s.min:g}"
    if s.min is None:
        return f" {'<' if s.max_open else '<='} {s.max:g}"
    return f" in {'(' if s.min_open else '['}{s.min:g}, {s.max:g}{')' if s.max_open else ']'}"


def number(
    paper: float,
    *,
    min: float | None = None,
    max: float | None = None,
    min_open: bool = False,
    max_open: bool = False,
    integer: bool = False,
    unit: str = "",
) -> ParameterSpec:
    """A finite real (or integer) number within optional bounds."""
    return ParameterSpec("number", paper, min, max, min_open, max_open, integer, unit)


def numbers(
    paper: Sequence,
    *,
    shape: tuple[int | None, ...] | None = None,
    min: float | None = None,
    max: float | None = None,
    min_open: bool = False,
    max_open: bool = False,
    increasing: bool | Sequence[tuple[int, int]] = False,
    unit: str = "",
) -> ParameterSpec:
    """A list (or nested list) of finite numbers: ``shape`` (``None`` for any length), bounds on
    every entry, and ``increasing``: ``True`` for ranges such as ``[min, max]`` (strictly
    increasing along the last axis), or pairs of indices along the last axis that must increase,
    e.g. ``((0, 1), (2, 3))`` for a window ``[x_min, x_max, y_min, y_max]``."""
    if increasing is not True and increasing is not False:
        increasing = tuple((int(i), int(j)) for i, j in increasing)
    return ParameterSpec(
        "numbers", paper, min, max, min_open, max_open, False, unit, None if shape is None else tuple(shape), increasing
    )


def signs(paper: Sequence[int]) -> ParameterSpec:
    """A branch: a list of ``len(paper)`` signs, each +1 or -1 (not True/False, not 0.5)."""
    return ParameterSpec("signs", paper, shape=(len(paper),))


def choice(paper: Any, *options: Any) -> ParameterSpec:
    """One of ``options``."""
    return ParameterSpec("choice", paper, choices=tuple(options))


def text(paper: str, *, output: bool = False) -> ParameterSpec:
    """A string; ``output=True`` for where results go (not compared with the paper's run)."""
    return ParameterSpec("text", paper, output=output)


def flag(paper: bool) -> ParameterSpec:
    """True or False."""
    return ParameterSpec("flag", paper)


def _fail(name: str, value: Any, spec: ParameterSpec, why: str = "") -> None:
    why = f" ({why})" if why else ""
    raise ValueError(f"parameter {name!r} = {value!r}: expected {spec.accepted()}{why}")


def _is_real(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _not_a_number_why(v: Any) -> str:
    """Why ``v`` is not a real number, in words (for the error message)."""
    if isinstance(v, (bool, np.bool_)):
        return "a boolean, not a number"
    if isinstance(v, str):
        try:
            float(v)
        except ValueError:
            return "a string"
        return "a string, not a number: leave out the quotes"
    if v is None:
        return "None"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "a list, not a single number"
    return f"a {type(v).__name__}"


def _number_problem(v: Any, spec: ParameterSpec) -> str | None:
    """What is wrong with one number ``v`` under ``spec`` (None if nothing)."""
    if not _is_real(v):
        return _not_a_number_why(v)
    x = float(v)
    if not math.isfinite(x):
        return "not finite"
    if spec.integer and not isinstance(v, (int, np.integer)):
        return "not an integer" if x != int(x) else f"write it as an integer, {int(x)}"
    if spec.min is not None and (x < spec.min or (spec.min_open and x == spec.min)):
        return "too small"
    if spec.max is not None and (x > spec.max or (spec.max_open and x == spec.max)):
        return "too large"
    return None


def _check_number(name: str, v: Any, spec: ParameterSpec, shown: Any, where: str = "") -> None:
    why = _number_problem(v, spec)
    if why is not None:
        _fail(name, shown, spec, f"{where}{why}")


def _check_list(name: str, value: Any, spec: ParameterSpec) -> None:
    if isinstance(value, (str, bytes)):
        _fail(name, value, spec, "a string, not a list: write it as a list such as [0.2, 1.2]")
    if not isinstance(value, (list, tuple, np.ndarray)):
        _fail(name, value, spec, _not_a_number_why(value) if not _is_real(value) else "a single number, not a list")


def _is_sign(s: Any) -> bool:
    return _is_real(s) and float(s) in (1.0, -1.0)


def check_parameter(name: str, value: Any, spec: ParameterSpec) -> None:
    """Raise ``ValueError`` naming ``name``, ``value`` and what ``spec`` accepts unless it fits."""
    if not isinstance(spec, ParameterSpec):
        raise ValueError(f"spec must be made by pkmlib.tools.number/numbers/signs/choice/text/flag, got {spec!r}")
    check_text("name", name)
    if spec.kind == "number":
        _check_number(name, value, spec, value)
    elif spec.kind == "flag":
        if not isinstance(value, (bool, np.bool_)):
            _fail(name, value, spec)
    elif spec.kind == "text":
        if not isinstance(value, str):
            _fail(name, value, spec, _not_a_number_why(value).replace(", not a single number", ""))
        if not value.strip():
            _fail(name, value, spec, "empty")
    elif spec.kind == "choice":
        if not any(type(value) is type(c) and value == c for c in spec.choices):
            _fail(name, value, spec)
    elif spec.kind == "signs":
        _check_list(name, value, spec)
        if len(value) != spec.shape[0]:
            _fail(name, value, spec, f"{len(value)} given")
        for i, s in enumerate(value):
            if not _is_sign(s):
                _fail(name, value, spec, f"entry {i} is {s!r}")
    elif spec.kind == "numbers":
        _check_list(name, value, spec)
        try:
            arr = np.asarray(value, dtype=object)
        except ValueError:
            _fail(name, value, spec, "rows of different lengths")
        if arr.ndim and any(isinstance(v, (list, tuple, np.ndarray)) for v in arr.ravel()):
            _fail(name, value, spec, "rows of different lengths")
        if spec.shape is not None:
            if arr.ndim != len(spec.shape) or any(s is not None and s != n for s, n in zip(spec.shape, arr.shape)):
                _fail(name, value, spec, f"shape {arr.shape}" if arr.ndim else "a single number, not a list")
        elif arr.ndim == 0:
            _fail(name, value, spec, "a single number, not a list")
        for index, v in np.ndenumerate(arr):
            where = f"entry {index[0] if len(index) == 1 else list(index)}: " if arr.size > 1 else ""
            _check_number(name, v, spec, value, where)
        if spec.increasing and arr.size:
            a = arr.astype(np.float64).reshape(-1, arr.shape[-1]) if arr.ndim else arr.astype(np.float64)
            if spec.increasing is True:
                if np.any(np.diff(a, axis=-1) <= 0):
                    _fail(name, value, spec, "not increasing")
            else:
                for i, j in spec.increasing:
                    if np.any(a[:, i] >= a[:, j]):
                        _fail(name, value, spec, f"entry {i} is not below entry {j}")
    else:  # pragma: no cover
        raise ValueError(f"unknown parameter kind {spec.kind!r}")


@dataclasses.dataclass(frozen=True)
class ParameterRule:
    """A condition on several parameters together (``names``), e.g. "not all loads zero"."""

    names: tuple[str, ...]
    test: Callable[..., bool]
    accepted: str

    def __post_init__(self):
        if not isinstance(self.names, tuple) or not self.names:
            raise ValueError(f"names must be a non-empty tuple of parameter names, got {self.names!r}")
        for n in self.names:
            if not isinstance(n, str) or not n:
                raise ValueError(f"names must be parameter names (strings), got {self.names!r}")
        check_callable("test", self.test, "a function of the named parameters returning True or False")
        if not isinstance(self.accepted, str):
            raise ValueError(f"accepted must be a string (what is accepted, in words), got {self.accepted!r}")

    def check(self, values: Mapping[str, Any]) -> None:
        args = [values[n] for n in self.names]
        if not self.test(*args):
            shown = ", ".join(f"{n} = {v!r}" for n, v in zip(self.names, args))
            raise ValueError(f"parameters {shown}: expected {self.accepted}")


def not_all_zero(*names: str) -> ParameterRule:
    """At least one of ``names`` is nonzero (e.g. the loads of a force map: all zero gives an
    all-zero map)."""
    if not names or not all(isinstance(n, str) and n for n in names):
        raise ValueError(f"names must be one or more parameter names (strings), got {names!r}")
    return ParameterRule(
        tuple(names),
        lambda *v: any(np.any(np.asarray(x, dtype=np.float64) != 0) for x in v),
        f"at least one of {', '.join(names)} nonzero (all zero leave nothing to map)",
    )


def less(smaller: str, larger: str, *, why: str = "") -> ParameterRule:
    """``smaller`` < ``larger`` (e.g. ``q_min_m`` < ``q_max_m``, ``sim_dt_s`` < ``sim_duration_s``)."""
    check_text("smaller", smaller)
    check_text("larger", larger)
    why = f" ({why})" if why else ""
    return ParameterRule((smaller, larger), lambda a, b: float(a) < float(b), f"{smaller} < {larger}{why}")


def _check_paper_kind(spec: ParameterSpec) -> None:
    """The paper's value is of the spec's kind (a number for ``number``, numbers for ``numbers``,
    +-1 for ``signs``, a string, a bool, one of the choices): ``ValueError`` naming ``paper``."""
    v, kind = spec.paper, spec.kind
    if kind == "number":
        ok = _is_real(v)
    elif kind == "numbers":
        try:
            ok = not isinstance(v, (str, bytes)) and np.asarray(v).dtype.kind in "iuf" and np.asarray(v).ndim >= 1
        except Exception:
            ok = False
    elif kind == "signs":
        ok = isinstance(v, (list, tuple)) and all(_is_sign(x) for x in v)
    elif kind == "text":
        ok = isinstance(v, str)
    elif kind == "flag":
        ok = isinstance(v, (bool, np.bool_))
    else:  # choice
        ok = any(_equal(v, c) for c in spec.choices)
    if not ok:
        raise ValueError(f"paper (the paper's value of a {kind} parameter) must be {spec.accepted()}, got {v!r}")


def _spec_self_check(name: str, spec: ParameterSpec) -> None:
    """The paper's value must pass its own spec: a spec that rejects it is a bug in the notebook."""
    if spec.kind == "text" and spec.output:
        return
    try:
        check_parameter(name, spec.paper, spec)
    except ValueError as e:
        raise ValueError(f"the check of {name!r} rejects the paper's own value: fix the spec ({e})") from None


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    try:
        return bool(np.array_equal(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)))
    except (TypeError, ValueError):
        return a == b


def check_parameters(
    values: Mapping[str, Any], spec: Mapping[str, ParameterSpec], rules: Sequence[ParameterRule] = ()
) -> bool:
    """Check every parameter named in ``spec`` (from ``values``, e.g. the notebook's ``globals()``),
    then every rule on several parameters together (:func:`not_all_zero`, :func:`less`).

    Raises ``ValueError`` naming the first parameter that is missing or not accepted, its value and
    what is accepted. Returns True when every input parameter equals the paper's value (a paper
    run), else False.
    """
    check_mapping("values", values)
    check_mapping("spec", spec)
    for r in rules:
        if not isinstance(r, ParameterRule):
            raise ValueError(
                f"rules must be made by pkmlib.tools.less / pkmlib.tools.not_all_zero (ParameterRule), got {r!r}"
            )
    for name, s in spec.items():
        if not isinstance(s, ParameterSpec):
            raise _NotASpec(
                f"spec of {name!r} must be made by pkmlib.tools.number/numbers/signs/choice/text/flag, got {s!r}"
            )
        _spec_self_check(name, s)
    missing = [k for k in spec if k not in values]
    if missing:
        raise ValueError(f"parameters {missing} are not defined (expected: {sorted(spec)})")
    for name, s in spec.items():
        check_parameter(name, values[name], s)
    for rule in rules:
        unknown = [n for n in rule.names if n not in spec]
        if unknown:
            raise ValueError(f"rule on {unknown}: not in the spec {sorted(spec)}")
        rule.check(values)
    return all(_equal(values[name], s.paper) for name, s in spec.items() if not s.output)
