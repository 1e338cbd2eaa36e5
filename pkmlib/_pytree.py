"""One way to declare a parameter class: a frozen dataclass that is also a JAX pytree."""

from __future__ import annotations

import dataclasses
from typing import Callable, Sequence, TypeVar

import jax

T = TypeVar("T", bound=type)


def pytree_dataclass(cls: T | None = None, *, meta_fields: Sequence[str] = ()) -> T | Callable[[T], T]:
    """``@dataclasses.dataclass(frozen=True)`` registered with ``jax.tree_util.register_dataclass``.

    Every field is a leaf (traced by ``jit``, differentiated by ``grad``) except ``meta_fields``,
    which are static: hashed into the compiled code's key, so they must be hashable (tuples, not
    lists). Use as ``@pytree_dataclass`` or ``@pytree_dataclass(meta_fields=("base",))``.
    """

    def wrap(c: T) -> T:
        c = dataclasses.dataclass(frozen=True)(c)
        names = [f.name for f in dataclasses.fields(c)]
        unknown = [m for m in meta_fields if m not in names]
        if unknown:
            raise ValueError(f"meta_fields {unknown} are not fields of {c.__name__} ({names})")
        jax.tree_util.register_dataclass(c, data_fields=[n for n in names if n not in meta_fields],
                                         meta_fields=list(meta_fields))
        return c

    return wrap if cls is None else wrap(cls)
