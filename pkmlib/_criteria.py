"""Velocity and force criteria of Laryushkin et al., general in the number of actuators.

Output coordinates of different physical kinds (linear/angular velocity, force/moment, gripper)
are grouped and each group is normed separately (P1 eq (6), (8); P2 eq (4), (6)); the maximum
over all directions of a given magnitude in each group is then a sum of group norms of one row.

Gradients (``jax.grad``/``jax.jacfwd`` with respect to the pose or the parameters) are NaN-free
wherever the criteria are differentiable, and follow a stated choice where they are not:

* a group norm ``||M[k, g]||_2`` at a zero group (P1: the gripper column of chains 21, 22, where
  C2 does not depend on s) has the derivative 0, the subgradient of least norm (a plain
  ``sqrt(0)`` would give NaN);
* a maximum (minimum) over rows (P1 eq (6), (8), (13); P2 eq (4), (6)) takes the gradient of the
  active row, and at a tie of the first active row (lowest index), never an average;
* ``|e_k|`` at ``e_k = 0`` has the derivative 0;
* in eq (12) an actuator with ``e^hat_k = 0`` (not loaded by the gripper force) allows any
  gripper force: its ratio is +inf (-inf when it cannot hold the external load, the limit of
  eq (12)) and carries no gradient.
"""

from __future__ import annotations

import functools
from typing import Any, Sequence

import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._validation import _is_tracer, check_array, check_index, check_nonnegative, concrete, nan_unless_nonnegative

Array = Any
Groups = Sequence[Sequence[int]]

# Every function takes one pose's matrices, shape (rows, cols), or many poses' in structure-of-
# arrays form: arrays of shape (rows, cols, *batch), or nested tuples of rows of per-entry
# arrays (pkmlib.inverse_jacobian_rows). Entries are read as M[k][j]; results drop the row axis.


def _per_row(v: Array, like: Array) -> Array:
    """Broadcast a scalar or per-row ``(n,)`` value against ``like`` of shape ``(n, *batch)``."""
    v = jnp.asarray(v, dtype=jnp.float64)
    return v.reshape(v.shape + (1,) * (like.ndim - v.ndim)) if v.ndim else v


def row_group_norms(M: Array, groups: Groups, magnitudes: Sequence[float] | Array) -> Array:
    """``sum_g ||M[k, g]||_2 * m_g`` for every row ``k`` of ``M`` (shape ``(n, *batch)``).

    The maximum of ``|M[k] . v|`` over all ``v`` whose group ``g`` has Euclidean norm ``m_g``
    (P1 eq (5)-(6) and (7)-(8); P2 eq (4), (6)).
    """
    groups, magnitudes = _check_groups(M, groups, magnitudes, "magnitudes")
    return nan_unless_nonnegative(jnp.stack(_row_group_norms(M, groups, magnitudes)), *magnitudes)


def _check_groups(M, groups, magnitudes, name: str, matrix: str = "M") -> tuple[list, list]:
    """``groups`` as lists of column indices of ``M`` and ``magnitudes`` (called ``name``), one per
    group, each >= 0; ``ValueError`` naming the argument otherwise. A traced magnitude cannot be
    checked here: the criterion is NaN where it is negative (:func:`pkmlib._validation.nan_unless_nonnegative`)."""
    try:
        if isinstance(M, (str, bytes)) or isinstance(M[0], (str, bytes)):
            raise TypeError
        n_cols = len(M[0])
    except (TypeError, IndexError):
        shape = getattr(M, "shape", None)
        raise ValueError(
            f"{matrix} must be a matrix (rows, columns, *batch) or nested rows of entries, got "
            + (f"shape {tuple(shape)}" if shape is not None else repr(M))
        ) from None
    if isinstance(groups, (str, bytes)) or not hasattr(groups, "__iter__"):
        raise ValueError(f"groups must be a sequence of groups of column indices 0..{n_cols - 1}, got {groups!r}")
    groups = [tuple(g) if hasattr(g, "__iter__") else g for g in groups]
    if not groups:
        raise ValueError(f"groups must hold at least one group of column indices 0..{n_cols - 1}, got {groups!r}")
    for g in groups:
        if not isinstance(g, tuple) or not g:
            raise ValueError(f"groups must be non-empty sequences of column indices 0..{n_cols - 1}, got {groups!r}")
        for j in g:
            check_index("groups", j, n_cols, "a column of the matrix")
    columns = [int(j) for g in groups for j in g]
    if len(set(columns)) != len(columns):
        twice = sorted({j for j in columns if columns.count(j) > 1})
        raise ValueError(
            f"groups must not overlap (each column of the matrix in one group at most): column(s) "
            f"{twice} appear more than once in {groups!r}"
        )
    if isinstance(magnitudes, (str, bytes)) or not hasattr(magnitudes, "__iter__"):
        raise ValueError(f"{name} must be one number >= 0 per group ({len(groups)}), got {magnitudes!r}")
    magnitudes = list(magnitudes)
    if len(groups) != len(magnitudes):
        raise ValueError(f"{name} must be one number >= 0 per group: {len(groups)} groups but {len(magnitudes)} {name}")
    for m in magnitudes:
        if not _is_tracer(m):
            check_nonnegative(name, m, f"numbers >= 0, one per group (sizes, not signed values); got {magnitudes!r}")
    return groups, magnitudes


def _row_group_norms(M, groups, magnitudes) -> list[Array]:
    norms = []
    for k in range(len(M)):
        row = M[k]
        total = 0.0
        for g, m in zip(groups, magnitudes):
            total = total + _safe_norm([row[j] for j in g]) * m
        norms.append(total)
    return norms


def _safe_norm(components: Sequence[Array]) -> Array:
    """Euclidean norm of a group of entries whose derivative at the zero vector is 0 (the
    subgradient of least norm) instead of ``sqrt(0)``'s NaN; exact elsewhere, NaN in -> NaN out.
    One entry: ``|c|``, with the derivative 0 at 0 too (``sqrt(c^2)`` equals it in
    binary floating point wherever ``c^2`` neither overflows nor underflows, and costs a root: P1's
    eq (6) map took 16 per point instead of numba's 8)."""
    if len(components) == 1:
        c = components[0]
        return jnp.where(c != 0.0, jnp.abs(c), 0.0 * c)  # abs alone has the derivative 1 at 0
    s = sum(c * c for c in components)
    positive = s > 0.0
    return jnp.where(positive, jnp.sqrt(jnp.where(positive, s, 1.0)), 0.0 * s)


def _abs(v: Array) -> Array:
    """``|v|`` with the derivative 0 at ``v = 0`` (see the module docstring)."""
    return _safe_norm([v])


def _first_max(a: Array, b: Array) -> Array:
    # b only where strictly larger (or NaN): a tie keeps the earlier row, and so does its gradient.
    return jnp.where(jnp.isnan(b) | (b > a), b, a)


def _first_min(a: Array, b: Array) -> Array:
    return jnp.where(jnp.isnan(b) | (b < a), b, a)


def _max_over_rows(values: list[Array]) -> Array:
    # Elementwise, not a reduction: it propagates NaN (outside the workspace) on every backend
    # (XLA's CPU reductions have been seen to drop NaN), and its gradient is the active row's.
    return functools.reduce(_first_max, values)


def max_actuator_velocity(J_inv: Array, groups: Groups, speeds: Sequence[float] | Array) -> Array:
    """Largest actuator speed for output speeds of given size and unknown direction.

    ``|q'|_max = max_k sum_g ||j^-1_{k,g}|| * v_g`` (P1 eq (6); P2 eq (4)). For P1, groups
    ``((0, 1), (2,), (3,))`` with speeds ``(v_D, omega, v_s)``.
    """
    groups, speeds = _check_groups(J_inv, groups, speeds, "speeds", "J_inv")
    return nan_unless_nonnegative(_max_over_rows(_row_group_norms(J_inv, groups, speeds)), *speeds)


def max_actuator_effort(J: Array, groups: Groups, loads: Sequence[float] | Array) -> Array:
    """Largest actuator effort for external loads of given size and unknown direction.

    The efforts are ``e = -J^T P`` (P1 eq (6) second / (9); P2 eq (5)), so
    ``|e|_max = max_k sum_g ||j^T_{k,g}|| * P_g`` with ``j^T_k`` the rows of ``J^T``
    (P1 eq (8); P2 eq (6)).
    """
    J = check_array("J", J, min_ndim=2)
    # The rows of J^T as nested entries, not a transposed array: XLA then reads J's entries where
    # they are, where a transpose became a copy of J points first (P1's seven maps under vmap:
    # 16 numbers per point written and read again).
    JT = [[J[j, k] for j in range(J.shape[0])] for k in range(J.shape[1])]
    groups, loads = _check_groups(JT, groups, loads, "loads")
    return nan_unless_nonnegative(_max_over_rows(_row_group_norms(JT, groups, loads)), *loads)


def actuator_efforts(J: Array, P: Array) -> Array:
    """Actuator efforts balancing the external load ``P`` on the output: ``e = -J^T P`` (P1 eq (9))."""
    J = check_array("J", J, min_ndim=2)
    P = check_array("P", P, (J.shape[0],), what="one load per output coordinate of J")
    # A sum over the output coordinates, elementwise over the batch, so that XLA fuses it into the
    # loops around it: as an einsum with an unbatched P it became a matrix product of a transposed
    # copy of J, outside them (P1's seven maps: 31 -> 28 fused loops, 1.4x the points per second).
    # The batch axes of J (after its two matrix axes) and of P (after its one) broadcast as
    # einsum's ``ij...,i...->j...`` would: aligned on the right.
    k = max(J.ndim - 2, P.ndim - 1)
    J = J.reshape(J.shape[:2] + (1,) * (k - (J.ndim - 2)) + J.shape[2:])
    P = P.reshape(P.shape[:1] + (1,) * (k + 1 - (P.ndim - 1)) + P.shape[1:])
    return -functools.reduce(jnp.add, [J[i] * P[i] for i in range(J.shape[0])])


def max_gripper_force(J: Array, F_pr: float | Array, external_load: Array, gripper_index: int) -> Array:
    """Largest gripper force the actuators can develop under an external load.

    Splits the efforts as ``e = e^ext + F_s e^hat`` (P1 eq (10)-(11)) with
    ``e^ext = -J^T (P with gripper component 0)`` and ``e^hat = -J^T u`` for the unit gripper
    load ``u``; each actuator allows ``(F_pr_k - |e^ext_k|) / |e^hat_k|`` (eq (12)) and the
    mechanism the smallest of these (eq (13)).

    Returns NaN where the actuators cannot hold the external load even with no gripper force
    (eq (13) negative: the "gap" of P1 Fig 6b), and NaN outside the workspace.
    """
    J, gripper_index = _check_load(J, F_pr, external_load, gripper_index)
    reserve = _load_reserve(J, F_pr, external_load, gripper_index)
    e_hat = _abs(-J[gripper_index])  # |-J^T u|, u = unit vector of the gripper coordinate
    unloaded = e_hat == 0.0  # actuator k does not feel the gripper force: no limit from it (sign of reserve)
    ratio = jnp.where(unloaded, jnp.where(reserve >= 0.0, jnp.inf, -jnp.inf), reserve / jnp.where(unloaded, 1.0, e_hat))
    f = _min_over_rows(ratio)
    return nan_unless_nonnegative(jnp.where(f >= 0.0, f, jnp.nan), F_pr)


def _check_load(J, F_pr, external_load, gripper_index):
    """The arguments of :func:`max_gripper_force` / :func:`load_reserve`, checked: ``J`` a matrix
    (output coordinates x actuators), ``gripper_index`` one of its rows, ``external_load`` one
    entry per row, ``F_pr`` >= 0 (one number, or one per actuator; NaN results where traced and
    negative)."""
    J = check_array("J", J, min_ndim=2)
    gripper_index = check_index(
        "gripper_index", gripper_index, J.shape[0], "the gripper's output coordinate, a row of J"
    )
    check_array("external_load", external_load, (J.shape[0],), what="one load per output coordinate of J")
    check_array("F_pr", F_pr)
    f = concrete(F_pr)
    if f is not None:
        if f.ndim > 1 or (f.ndim == 1 and f.shape[0] != J.shape[1]) or not np.all(f >= 0.0):
            raise ValueError(
                f"F_pr must be an actuator force limit >= 0, one number or one per actuator "
                f"({J.shape[1]}), got {F_pr!r}"
            )
    return J, gripper_index


def _load_reserve(J: Array, F_pr, external_load: Array, gripper_index: int) -> Array:
    P_ext = jnp.asarray(external_load, dtype=jnp.float64).at[gripper_index].set(0.0)
    e_ext = actuator_efforts(J, P_ext)
    return _per_row(F_pr, e_ext) - _abs(e_ext)


def load_reserve(J: Array, F_pr: float | Array, external_load: Array, gripper_index: int) -> Array:
    """Smallest actuator force reserve ``min_k (F_pr_k - |e^ext_k|)`` under the external load
    (the numerator of P1 eq (12)); negative where the actuators cannot hold the load."""
    J, gripper_index = _check_load(J, F_pr, external_load, gripper_index)
    return nan_unless_nonnegative(_min_over_rows(_load_reserve(J, F_pr, external_load, gripper_index)), F_pr)


def _min_over_rows(M: Array) -> Array:
    # An elementwise minimum over the rows, not a reduction: it propagates NaN (outside the
    # workspace) on every backend; its gradient is the active row's (the first at a tie).
    return functools.reduce(_first_min, [M[k] for k in range(M.shape[0])])
