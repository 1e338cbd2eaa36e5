"""Checks of a notebook's ``parameters`` cell: one call in the cell after it.

Each notebook declares, for every name in its ``parameters`` cell, what is accepted and what the
paper used::

    paper_run = pkmlib.check_parameters(globals(), {
        "phi_deg": pkmlib.number(20.0, min=0.0, max=90.0, max_open=True, unit="deg"),
        "dx_D_m": pkmlib.number(0.005, min=0.0, min_open=True, unit="m"),
        "branch": pkmlib.signs([-1, 1, -1, 1]),
        "x_D_range_m": pkmlib.numbers([0.2, 1.2], shape=(2,), increasing=True, unit="m"),
        "l3_is": pkmlib.choice("circumradius", "circumradius", "side"),
        "results_path": pkmlib.text("../data/results/p1.json", output=True),
    })

A value that is not accepted raises ``ValueError`` naming the parameter, the value and what is
accepted, before any work is done. The return value says whether every input equals the paper's
(``output=True`` entries, where results are written, do not count): a run at other parameters
scores itself as "not the paper's parameters" instead of calling its own numbers errata.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Mapping, Sequence

import numpy as np


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
    increasing: bool = False
    choices: tuple[Any, ...] = ()
    output: bool = False

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
        inc = ", increasing" if self.increasing else ""
        return f"a list ({shape}) of finite numbers{bounds}{inc}{unit}"


def _bounds_text(s: ParameterSpec) -> str:
    if s.min is None and s.max is None:
        return ""
    if s.max is None:
        return f" {'>' if s.min_open else '>='} {s.min:g}"
    if s.min is None:
        return f" {'<' if s.max_open else '<='} {s.max:g}"
    return f" in {'(' if s.min_open else '['}{s.min:g}, {s.max:g}{')' if s.max_open else ']'}"


def number(paper: float, *, min: float | None = None, max: float | None = None, min_open: bool = False,
           max_open: bool = False, integer: bool = False, unit: str = "") -> ParameterSpec:
    """A finite real (or integer) number within optional bounds."""
    return ParameterSpec("number", paper, min, max, min_open, max_open, integer, unit)


def numbers(paper: Sequence, *, shape: tuple[int | None, ...] | None = None, min: float | None = None,
            max: float | None = None, min_open: bool = False, max_open: bool = False,
            increasing: bool = False, unit: str = "") -> ParameterSpec:
    """A list (or nested list) of finite numbers: ``shape`` (``None`` for any length), bounds on
    every entry, and ``increasing`` for ranges such as ``[min, max]`` (along the last axis)."""
    return ParameterSpec("numbers", paper, min, max, min_open, max_open, False, unit, shape, increasing)


def signs(paper: Sequence[int]) -> ParameterSpec:
    """A branch: a list of ``len(paper)`` signs, each +1 or -1."""
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


def _check_number(name: str, v: Any, spec: ParameterSpec, shown: Any) -> None:
    if not _is_real(v) or not math.isfinite(float(v)):
        _fail(name, shown, spec)
    if spec.integer and float(v) != int(v):
        _fail(name, shown, spec)
    x = float(v)
    if spec.min is not None and (x < spec.min or (spec.min_open and x == spec.min)):
        _fail(name, shown, spec)
    if spec.max is not None and (x > spec.max or (spec.max_open and x == spec.max)):
        _fail(name, shown, spec)


def check_parameter(name: str, value: Any, spec: ParameterSpec) -> None:
    """Raise ``ValueError`` naming ``name``, ``value`` and what ``spec`` accepts unless it fits."""
    if spec.kind == "number":
        _check_number(name, value, spec, value)
    elif spec.kind == "flag":
        if not isinstance(value, (bool, np.bool_)):
            _fail(name, value, spec)
    elif spec.kind == "text":
        if not isinstance(value, str) or not value:
            _fail(name, value, spec)
    elif spec.kind == "choice":
        if not any(type(value) is type(c) and value == c for c in spec.choices):
            _fail(name, value, spec)
    elif spec.kind == "signs":
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            _fail(name, value, spec)
        if len(value) != spec.shape[0]:
            _fail(name, value, spec, f"{len(value)} given")
        if any(not _is_real(s) or float(s) not in (1.0, -1.0) for s in value):
            _fail(name, value, spec)
    elif spec.kind == "numbers":
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple, np.ndarray)):
            _fail(name, value, spec)
        try:
            arr = np.asarray(value, dtype=object)
        except ValueError:
            _fail(name, value, spec, "ragged")
        if spec.shape is not None:
            if arr.ndim != len(spec.shape) or any(s is not None and s != n for s, n in zip(spec.shape, arr.shape)):
                _fail(name, value, spec, f"shape {arr.shape}")
        for v in arr.ravel():
            _check_number(name, v, spec, value)
        if spec.increasing and arr.size:
            a = arr.astype(np.float64)
            if np.any(np.diff(a, axis=-1) <= 0):
                _fail(name, value, spec, "not increasing")
    else:  # pragma: no cover
        raise ValueError(f"unknown parameter kind {spec.kind!r}")


def _equal(a: Any, b: Any) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    try:
        return bool(np.array_equal(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)))
    except (TypeError, ValueError):
        return a == b


def check_parameters(values: Mapping[str, Any], spec: Mapping[str, ParameterSpec]) -> bool:
    """Check every parameter named in ``spec`` (from ``values``, e.g. the notebook's ``globals()``).

    Raises ``ValueError`` naming the first parameter that is missing or not accepted. Returns
    True when every input parameter equals the paper's value (a paper run), else False.
    """
    missing = [k for k in spec if k not in values]
    if missing:
        raise ValueError(f"parameters {missing} are not defined (expected: {sorted(spec)})")
    for name, s in spec.items():
        check_parameter(name, values[name], s)
    return all(_equal(values[name], s.paper) for name, s in spec.items() if not s.output)
