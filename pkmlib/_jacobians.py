"""Jacobians of a mechanism's constraint equations, by automatic differentiation.

Differentiating F(x, q) = 0 in time gives ``A x' + B q' = 0`` with ``A = dF/dx`` and
``B = dF/dq`` (P1 eq (2), P2 eq (2)), hence the inverse Jacobian ``J^-1 = -B^-1 A`` with
``q' = J^-1 x'`` (P1 eq (3)-(4), P2 eq (3)) and the forward Jacobian ``J = (J^-1)^-1``.

Every function here takes one pose (``x`` of shape ``(n_x,)``, ``q`` of shape ``(n,)``) or,
in "structure of arrays" form, many poses at once (``x`` of shape ``(n_x, *batch)``, ``q`` of
shape ``(n, *batch)``), provided the mechanism's constraint function broadcasts over trailing
axes as pkmlib's do. Matrices then have shape ``(rows, cols, *batch)``. Columns of A and B are
taken one forward-mode JVP at a time (an unrolled loop over the few coordinates, never over
points), so every operation is elementwise over whole arrays of points: this is what makes
4-million-point maps fast (see ``benchmarks/``).
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._mechanism import Mechanism
from ._small_matrices import MAX_CLOSED_FORM, det_small, inverse_small, solve_small
from ._validation import _is_tracer, check_first_axis, check_mechanism, check_square

Array = Any


def _check_pose(mech: Mechanism, x: Array, q: Array) -> None:
    """Raise ``ValueError`` naming ``mech``, ``x`` or ``q`` unless ``mech`` is a Mechanism and ``x``,
    ``q`` have its numbers of output and actuator coordinates on their first axis (the shapes are
    known under ``jit``/``vmap`` too)."""
    check_mechanism("mech", mech)
    for name, v, n, what in (
        ("x", x, len(mech.output_names), mech.output_names),
        ("q", q, mech.n_actuators, mech.actuator_names),
    ):
        check_first_axis(name, v, n, f"coordinates {tuple(what)} of {mech.name}")


def _jvp_columns(f, z: Array) -> Array:
    """``df/dz`` as an ``(m, len(z), *batch)`` array, one forward-mode JVP per coordinate of ``z``."""
    cols = []
    for j in range(z.shape[0]):
        if _is_tracer(z):
            tangent = jnp.zeros_like(z).at[j].set(1.0)
        else:  # built in NumPy: no eager programs (zeros, scatter) compiled for each shape of z
            tangent = np.zeros(z.shape, dtype=z.dtype)
            tangent[j] = 1.0
            tangent = jax.device_put(tangent)
        cols.append(jax.jvp(f, (z,), (tangent,))[1])
    return jnp.stack(cols, axis=1)


def _last(M: Array) -> Array:
    """``(r, c, *batch) -> (*batch, r, c)`` for ``jnp.linalg``."""
    return jnp.moveaxis(M, (0, 1), (-2, -1))


def _first(M: Array) -> Array:
    """``(*batch, r, c) -> (r, c, *batch)``, the inverse of :func:`_last`."""
    return jnp.moveaxis(M, (-2, -1), (0, 1))


def _components(x: Array) -> tuple[Array, ...]:
    return x if isinstance(x, tuple) else tuple(x[j] for j in range(len(x)))


def _unit_tangent(xs: tuple[Array, ...], j: int) -> tuple[Array, ...]:
    return tuple(jnp.ones_like(c) if i == j else jnp.zeros_like(c) for i, c in enumerate(xs))


def inverse_jacobian_rows(mech: Mechanism, x: Array, q: Array, params: Any) -> tuple[tuple[Array, ...], ...]:
    """Rows of ``J^-1`` of a chainwise mechanism, as nested tuples of per-entry arrays.

    Row ``i`` is ``-(dF_i/dx) / (dF_i/dq_i)`` (P1, the matrix after eq (2); P2 eq (3)): one
    forward-mode JVP per output coordinate and one for ``q_i``, each over whole arrays of points.
    Nothing is stacked into per-point matrices, so XLA fuses a whole map into one loop; the
    criteria of :mod:`pkmlib._criteria` accept these rows as they accept matrices.
    """
    _check_pose(mech, x, q)
    if not mech.chainwise:
        raise ValueError(f"{mech.name}: J^-1 row by row needs a chainwise mechanism")
    xs = _components(x)
    rows = []
    for i in range(mech.n_actuators):
        q_i = q[i]
        F_i = mech.chain_constraint
        b_ii = jax.jvp(lambda qi: F_i(i, xs, qi, params), (q_i,), (jnp.ones_like(q_i),))[1]
        a_i = [jax.jvp(lambda x_: F_i(i, x_, q_i, params), (xs,), (_unit_tangent(xs, j),))[1] for j in range(len(xs))]
        minus_inv_b = -1.0 / b_ii  # one division per row, not one per entry (the divider bounds maps)
        rows.append(tuple(a_ij * minus_inv_b for a_ij in a_i))
    return tuple(rows)


def A_matrix(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """``A = dF/dx`` (P1 eq (2); P2 eq (2)), shape ``(n, n_x)``."""
    _check_pose(mech, x, q)
    return _jvp_columns(lambda x_: mech.constraints(x_, q, params), x)


def B_matrix(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """``B = dF/dq`` (P1 eq (2); P2 eq (2)), shape ``(n, n)``.

    For a chainwise mechanism this is ``diag(B_diagonal(...))``.
    """
    _check_pose(mech, x, q)
    if mech.chainwise:
        b = B_diagonal(mech, x, q, params)
        eye = jnp.eye(b.shape[0], dtype=b.dtype).reshape((b.shape[0],) * 2 + (1,) * (b.ndim - 1))
        return eye * b[None]
    return _jvp_columns(lambda q_: mech.constraints(x, q_, params), q)


def B_diagonal(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """Diagonal of ``B`` for a chainwise mechanism (each ``F_i`` depends on ``q_i`` only).

    One JVP of each chain's equation in its own ``q_i`` (P1 eq (2): B is diagonal).
    """
    _check_pose(mech, x, q)
    if not mech.chainwise:
        raise ValueError(f"{mech.name}: B is not diagonal (chainwise=False)")
    xs = _components(x)
    return jnp.stack(
        [
            jax.jvp(lambda qi: mech.chain_constraint(i, xs, qi, params), (q[i],), (jnp.ones_like(q[i]),))[1]
            for i in range(mech.n_actuators)
        ]
    )


def inverse_jacobian(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """``J^-1 = -B^-1 A`` (P1 eq (3)-(4); P2 eq (3)), shape ``(n, n_x, *batch)``.

    Chainwise mechanisms divide each row of A by the matching diagonal entry of B
    (:func:`inverse_jacobian_rows`); others solve with the full B.
    """
    _check_pose(mech, x, q)
    if mech.chainwise:
        return jnp.stack([jnp.stack(row) for row in inverse_jacobian_rows(mech, x, q, params)])
    A = A_matrix(mech, x, q, params)
    B = B_matrix(mech, x, q, params)
    if B.shape[0] <= MAX_CLOSED_FORM:
        return -solve_small(B, A)
    return -_first(jnp.linalg.solve(_last(B), _last(A)))


def matrix_inverse(M: Array) -> Array:
    """Inverse of ``(n, n)`` or ``(n, n, *batch)`` matrices.

    Up to 4x4 in closed form (:mod:`pkmlib._small_matrices`: adjugate over determinant,
    elementwise over the batch), larger ones by ``jnp.linalg.inv``.
    """
    M = check_square("M", M)
    if M.shape[0] <= MAX_CLOSED_FORM:
        return inverse_small(M)
    return _first(jnp.linalg.inv(_last(M)))


def _det(M: Array) -> Array:
    if M.shape[0] <= MAX_CLOSED_FORM:
        return det_small(M)
    return jnp.linalg.det(_last(M))


def jacobian(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """Forward Jacobian ``J = (J^-1)^-1`` (P1 eq (6) second, ``e = -J^T P``), ``x' = J q'``."""
    _check_pose(mech, x, q)
    return matrix_inverse(inverse_jacobian(mech, x, q, params))


def det_A(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """``det(A)``: zero at type-2 ("loss of control") singularities (P1, text before Fig 5)."""
    _check_pose(mech, x, q)
    return _det(A_matrix(mech, x, q, params))


def det_B(mech: Mechanism, x: Array, q: Array, params: Any) -> Array:
    """``det(B)``: zero at type-1 singularities (workspace boundary, P1 text after Fig 2)."""
    _check_pose(mech, x, q)
    if mech.chainwise:
        return jnp.prod(B_diagonal(mech, x, q, params), axis=0)
    return _det(B_matrix(mech, x, q, params))
