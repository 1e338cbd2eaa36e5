"""Numerical forward position solution: Newton's method on the constraint equations."""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._jacobians import A_matrix
from ._mechanism import Mechanism
from ._validation import check_array, check_count, check_mechanism, check_nonnegative, check_tolerance

Array = Any


class ForwardSolution(NamedTuple):
    """Result of :func:`solve_forward_position`."""

    x: Array
    converged: Array
    residual: Array
    iterations: Array


def solve_forward_position(
    mech: Mechanism, q: Array, params: Any, x0: Array, *, tol: float = 1e-14, max_iter: int = 50
) -> ForwardSolution:
    """Newton's method on ``F(x, q) = 0`` for ``x`` with ``q`` fixed, from the guess ``x0``.

    ``x_{k+1} = x_k - A^{-1} F(x_k, q)`` with ``A = dF/dx`` by autodiff (P1 eq (2), P2 eq (2)).
    Works under ``jit``/``vmap``: it never raises when Newton fails, and reports ``converged`` (``max |F| < tol``),
    the final residual and the iterations used. The solution found is the assembly mode
    nearest ``x0`` in Newton's sense; :func:`forward_position` raises when it fails.

    ``tol``: a finite number >= 0 (0: run all ``max_iter`` iterations); ``max_iter``: a whole
    number >= 0; ``q`` ``(n,)`` (one per actuator), ``x0`` ``(n_x,)`` (one per output coordinate);
    ``ValueError`` naming the argument otherwise. A ``tol`` or ``max_iter`` traced by ``jit`` or
    ``vmap`` is checked by ``equinox.error_if`` (raised when the compiled call runs).
    """
    check_mechanism("mech", mech)
    tol = _traced_or(check_nonnegative, "tol", tol, "a finite number >= 0", lambda v: jnp.isfinite(v) & (v >= 0))
    max_iter = _traced_or(
        lambda n, v, a: check_count(n, v, minimum=0), "max_iter", max_iter, "a whole number >= 0", lambda v: v >= 0
    )
    x0 = check_array("x0", x0, (mech.n_outputs,), ndim=1, what=", ".join(mech.output_names))
    q = check_array("q", q, (mech.n_actuators,), ndim=1, what=", ".join(mech.actuator_names))
    return _newton(mech, q, params, x0, tol, max_iter)


def _traced_or(check, name, value, accepted, ok):
    """Concrete ``value``: ``check(name, value, accepted)`` (``ValueError``); traced:
    ``equinox.error_if`` with the same words."""
    if isinstance(value, jax.core.Tracer):
        return eqx.error_if(value, ~ok(value), f"{name} must be {accepted}")
    return check(name, value, accepted)


def _newton(mech, q, params, x0, tol, max_iter):
    """The iteration of :func:`solve_forward_position` on checked arguments."""

    def residual(x):
        return jnp.max(jnp.abs(mech.constraints(x, q, params)))

    def cond(state):
        x, k = state
        r = residual(x)
        return (k < max_iter) & ~(r < tol) & jnp.isfinite(r)

    def body(state):
        x, k = state
        F = mech.constraints(x, q, params)
        return x - jnp.linalg.solve(A_matrix(mech, x, q, params), F), k + 1

    x, k = jax.lax.while_loop(cond, body, (x0, jnp.asarray(0)))
    r = residual(x)
    return ForwardSolution(x, r < tol, r, k)


def forward_position(
    mech: Mechanism, q: Array, params: Any, x0: Array, *, tol: float = 1e-14, max_iter: int = 50
) -> np.ndarray:
    """Forward position solution from the guess ``x0``; raises ``RuntimeError`` if Newton fails.

    See :func:`solve_forward_position` for the method and for a version usable under ``vmap``.
    The solver is compiled once per mechanism (``jax.jit``, cached on ``mech``) with ``q``,
    ``params``, ``x0``, ``tol`` and ``max_iter`` as run-time arguments, so repeated calls cost
    microseconds instead of an eager while-loop's tenths of a second. Parameters that JAX cannot
    trace (not a pytree of arrays) fall back to the eager solver. ``q`` must have one entry per
    actuator and ``x0`` one per output coordinate (``ValueError`` naming them otherwise).
    """
    check_mechanism("mech", mech)
    tol = check_tolerance("tol", tol)
    max_iter = check_count("max_iter", max_iter, minimum=1)
    q = _vector("q", q, mech.n_actuators, mech.actuator_names)
    x0 = _vector("x0", x0, mech.n_outputs, mech.output_names)
    solver = _compiled_solver(mech)
    try:
        sol = solver(q, params, x0, tol, max_iter)
    except (TypeError, jax.errors.ConcretizationTypeError, jax.errors.TracerBoolConversionError):
        sol = _newton(mech, jnp.asarray(q), params, jnp.asarray(x0), tol, max_iter)
    if not bool(sol.converged):
        raise RuntimeError(
            f"{mech.name}: forward position did not converge from x0={np.asarray(x0)} for q={np.asarray(q)} "
            f"(max |F| = {float(sol.residual):.3e} after {int(sol.iterations)} iterations; tol {tol:g}). "
            "Try a guess closer to the wanted assembly mode, or check that q is reachable."
        )
    return np.asarray(sol.x)


def _vector(name: str, v: Array, n: int, names) -> np.ndarray:
    try:
        arr = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {n} real numbers ({', '.join(names)}), got {v!r}") from None
    if arr.shape != (n,):
        raise ValueError(f"{name} must be {n} real numbers ({', '.join(names)}), got shape {arr.shape}")
    return arr


@functools.lru_cache(maxsize=64)
def _compiled_solver(mech: Mechanism):
    """``solve_forward_position`` for ``mech``, jitted once; everything else is a run-time argument."""

    def solve(q, params, x0, tol, max_iter):  # checked by forward_position
        return _newton(
            mech, jnp.asarray(q, dtype=jnp.float64), params, jnp.asarray(x0, dtype=jnp.float64), tol, max_iter
        )

    return jax.jit(solve)
