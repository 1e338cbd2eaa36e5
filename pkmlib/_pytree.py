"""One way to declare a parameter class a JAX pytree: a decorator on its frozen dataclass."""

from __future__ import annotations

import dataclasses
from typing import Callable, Sequence, TypeVar

import jax

T = TypeVar("T", bound=type)


def pytree_dataclass(cls: T | None = None, *, meta_fields: Sequence[str] = ()) -> T | Callable[[T], T]:
    """Register a frozen dataclass with ``jax.tree_util.register_dataclass``; stack it over
    ``@dataclasses.dataclass(frozen=True)`` (which stays visible, so that the reference pages
    show the fields)::

        @pytree_dataclass(meta_fields=("base",))
        @dataclasses.dataclass(frozen=True)
        class Params: ...

    Every field is a leaf (traced by ``jit``, differentiated by ``grad``) except ``meta_fields``,
    which are static: hashed into the compiled code's key, so they must be hashable (tuples, not
    lists).

    JAX rebuilds the class from its leaves without calling ``__init__``: its placeholders,
    gradients, tangents and ``vmap`` axis numbers are not the class's values, so a
    ``__post_init__`` check runs only on a class built by a caller (``Params(...)``,
    ``dataclasses.replace``).
    """

    def wrap(c: T) -> T:
        if not dataclasses.is_dataclass(c) or not c.__dataclass_params__.frozen:
            raise TypeError(f"pytree_dataclass: put @dataclasses.dataclass(frozen=True) under it on {c.__name__}")
        names = [f.name for f in dataclasses.fields(c)]
        unknown = [m for m in meta_fields if m not in names]
        if unknown:
            raise ValueError(f"meta_fields {unknown} are not fields of {c.__name__} ({names})")
        data = [n for n in names if n not in meta_fields]
        meta = list(meta_fields)

        def flatten_with_keys(obj):
            return [(jax.tree_util.GetAttrKey(n), getattr(obj, n)) for n in data], tuple(getattr(obj, n) for n in meta)

        def flatten(obj):
            return [getattr(obj, n) for n in data], tuple(getattr(obj, n) for n in meta)

        def unflatten(aux, children):
            obj = object.__new__(c)
            for n, v in (*zip(data, children), *zip(meta, aux)):
                object.__setattr__(obj, n, v)
            return obj

        jax.tree_util.register_pytree_with_keys(c, flatten_with_keys, unflatten, flatten)
        return c

    return wrap if cls is None else wrap(cls)
