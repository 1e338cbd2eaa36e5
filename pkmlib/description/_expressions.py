"""Safe arithmetic expressions of a mechanism description, compiled to JAX functions.

An expression (a placement, a derived parameter, the output pose) is parsed with Python's
:mod:`ast` module and turned into a closure over the parse tree: nothing is passed to ``eval``,
no attribute, subscript, call of an unknown name or keyword is accepted, and every name must be a
symbol the description declares. The compiled function takes an environment ``{symbol: value}``
(parameters, derived values, output coordinates, joint variables) and returns a JAX value, so it
works under ``jit``, ``vmap`` and ``grad`` and broadcasts over arrays of points.
"""

from __future__ import annotations

import ast
import dataclasses
import math
import numbers
from collections.abc import Callable, Mapping
from typing import Any

import jax.numpy as jnp

from .. import _config  # noqa: F401  (float64)

#: Functions an expression may call, with their number of arguments.
FUNCTIONS: dict[str, tuple[Callable, int]] = {
    "sin": (jnp.sin, 1),
    "cos": (jnp.cos, 1),
    "tan": (jnp.tan, 1),
    "sqrt": (jnp.sqrt, 1),
    "asin": (jnp.arcsin, 1),
    "acos": (jnp.arccos, 1),
    "atan": (jnp.arctan, 1),
    "atan2": (jnp.arctan2, 2),
    "abs": (jnp.abs, 1),
}
#: Named constants.
CONSTANTS = {"pi": math.pi}

_BINARY = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
    ast.Pow: lambda a, b: a**b,
}
_UNARY = {ast.USub: lambda a: -a, ast.UAdd: lambda a: a}
ACCEPTED = "numbers, the declared symbols, pi, + - * / ** (unary minus, parentheses) and the functions " + ", ".join(
    FUNCTIONS
)


@dataclasses.dataclass(frozen=True)
class Expression:
    """A compiled expression: ``source`` as written, ``names`` the symbols it reads, and
    ``__call__(env)`` its value (``env`` maps every name in ``names`` to a number or array)."""

    source: str
    names: frozenset[str]
    _fn: Callable[[Mapping[str, Any]], Any] = dataclasses.field(repr=False)

    def __call__(self, env: Mapping[str, Any]) -> Any:
        return self._fn(env)

    @property
    def constant(self) -> bool:
        return not self.names


def compile_expression(value: Any, key: str, symbols: frozenset[str] | set[str]) -> Expression:
    """Compile ``value`` (a number or a string) found at ``key`` of the description.

    ``symbols`` are the names it may use. Raises ``ValueError`` naming ``key`` for anything else:
    syntax errors, unknown names (listing the accepted ones), attributes, subscripts, keywords,
    comprehensions, strings, calls of anything but :data:`FUNCTIONS` or with the wrong number of
    arguments.
    """
    if isinstance(value, bool):
        raise ValueError(f"{key}: expected a number or an expression ({ACCEPTED}), got {value!r}")
    if isinstance(value, numbers.Real):
        v = float(value)
        if not math.isfinite(v):
            raise ValueError(f"{key}: expected a finite number, got {value!r}")
        return Expression(repr(v), frozenset(), lambda env: v)
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{key}: expected a number or an expression ({ACCEPTED}), got {value!r}")
    try:
        tree = ast.parse(value.strip(), mode="eval")
    except SyntaxError as e:
        raise ValueError(f"{key}: cannot parse the expression {value!r} ({e.msg}); accepted: {ACCEPTED}") from None
    names: set[str] = set()
    fn = _compile(tree.body, key, value, frozenset(symbols), names)
    return Expression(value.strip(), frozenset(names), fn)


def _compile(node: ast.AST, key: str, src: str, symbols: frozenset[str], names: set[str]):
    def bad(what: str):
        return ValueError(f"{key}: {what} is not allowed in the expression {src!r}; accepted: {ACCEPTED}")

    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise bad(f"the constant {node.value!r}")
        v = float(node.value)
        return lambda env: v
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            c = CONSTANTS[node.id]
            return lambda env: c
        if node.id not in symbols:
            known = ", ".join(sorted(symbols)) or "none"
            raise ValueError(
                f"{key}: unknown symbol {node.id!r} in the expression {src!r}; the symbols "
                f"declared here are: {known} (and the constant pi)"
            )
        names.add(node.id)
        name = node.id
        return lambda env: env[name]
    if isinstance(node, ast.BinOp):
        op = _BINARY.get(type(node.op))
        if op is None:
            raise bad(f"the operator {type(node.op).__name__}")
        a = _compile(node.left, key, src, symbols, names)
        b = _compile(node.right, key, src, symbols, names)
        return lambda env: op(a(env), b(env))
    if isinstance(node, ast.UnaryOp):
        op = _UNARY.get(type(node.op))
        if op is None:
            raise bad(f"the operator {type(node.op).__name__}")
        a = _compile(node.operand, key, src, symbols, names)
        return lambda env: op(a(env))
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            what = node.func.id if isinstance(node.func, ast.Name) else ast.unparse(node.func)
            raise bad(f"calling {what!r}")
        if node.keywords:
            raise bad("a keyword argument")
        f, n_args = FUNCTIONS[node.func.id]
        if len(node.args) != n_args:
            raise ValueError(f"{key}: {node.func.id} takes {n_args} argument(s), got {len(node.args)} in {src!r}")
        args = [_compile(a, key, src, symbols, names) for a in node.args]
        return lambda env: f(*(a(env) for a in args))
    raise bad(f"{type(node).__name__} ({ast.unparse(node)!r})")
