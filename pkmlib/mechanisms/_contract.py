"""Helpers shared by the mechanism modules to keep the contract of :mod:`pkmlib.mechanisms`:
the pose vector, the loader of the paper's parameters, the sign patterns of the branches and the
old names kept for one release."""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path
from typing import Any, Callable, Mapping

import jax.numpy as jnp

from .. import _config  # noqa: F401  (float64)
from .._papers import PAPERS
from .._params import load_params as _load_file

Array = Any


def stack_pose(*coordinates: Array) -> Array:
    """The output vector ``x`` from its coordinates (scalars or arrays of one shape, broadcast):
    ``(n,)`` or ``(n, *batch)``, float64."""
    return jnp.stack(jnp.broadcast_arrays(*(jnp.asarray(v, dtype=jnp.float64) for v in coordinates)))


def sign_branches(n: int) -> tuple[tuple[float, ...], ...]:
    """Every branch of ``n`` signs, ``(+1, ..., +1)`` first, in the order of ``itertools.product``
    over ``(+1, -1)`` (the branches a mechanism of :attr:`pkmlib.Mechanism.branch_size` ``n`` has;
    ``((),)`` for ``n = 0``)."""
    return tuple(itertools.product((1.0, -1.0), repeat=n))


def load_paper_params(
    paper: str,
    from_dict: Mapping[str, Callable[[Any], Any]],
    key: str | None,
    source: str | Path | Mapping[str, Any] | None,
) -> Any:
    """The checked parameters of mechanism ``key`` of paper ``paper`` from ``source``: the whole
    ``data/params/<paper>.json`` by default, another name or path as :func:`pkmlib.load_params`
    takes it, or a dict of that file's layout. ``from_dict`` maps each mechanism key to its params
    class's ``from_dict``; ``key`` may be omitted when there is one."""
    keys = list(from_dict)
    if key is None:
        if len(keys) != 1:
            raise ValueError(f"key: {PAPERS[paper].module} has the mechanisms {keys}; name one, got None")
        key = keys[0]
    if key not in from_dict:
        raise ValueError(f"key must be one of {keys} (the mechanisms of {PAPERS[paper].module}), got {key!r}")
    data = source if isinstance(source, Mapping) else _load_file(paper if source is None else source)
    return from_dict[key](data)


def deprecated_names(module: str, renamed: Mapping[str, tuple[str, Callable[[], Any]]]) -> Callable[[str], Any]:
    """A module-level ``__getattr__`` serving old names: ``renamed[old] = (new name, value getter)``.
    Each use warns with a ``DeprecationWarning`` naming the new name (kept for one release)."""

    def __getattr__(name: str) -> Any:
        if name in renamed:
            new, value = renamed[name]
            warnings.warn(
                f"{module}.{name} is deprecated; use {new} (the mechanism contract, pkmlib.mechanisms)",
                DeprecationWarning,
                stacklevel=2,
            )
            return value()
        raise AttributeError(f"module {module!r} has no attribute {name!r}")

    return __getattr__
