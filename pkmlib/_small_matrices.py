"""Closed-form determinants and inverses of 2x2, 3x3 and 4x4 matrices, structure of arrays.

A matrix is an array of shape ``(n, n, *batch)`` (batch axes last, as everywhere in pkmlib's
Jacobians) or a nested sequence of rows of per-entry arrays; every entry is an array over the
batch. The formulas are written out entry by entry (cofactor expansion for 2x2 and 3x3; for 4x4
the expansion in complementary 2x2 minors, Laplace's theorem), so a whole map of matrices is a
few dozen elementwise multiplications and one division per point: XLA fuses them into one
vectorised loop, where batched LAPACK (``getrf``/``getri`` per point) runs a call per matrix.
The inverse is ``adj(M) / det(M)``: its error is of the order of ``cond(M)`` times machine
precision, like an LU solve; a singular matrix gives inf/NaN entries, NaN entries give NaN.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)

Array = Any

#: Matrices up to this size are inverted in closed form by :func:`pkmlib.matrix_inverse` and
#: friends; larger ones go to ``jnp.linalg``.
MAX_CLOSED_FORM = 4


def _size(M: Any) -> int:
    n = len(M)
    if n < 1 or any(len(row) != n for row in M):
        shape = getattr(M, "shape", None)
        raise ValueError(f"expected a square (n, n, *batch) matrix, got shape {shape or (n, '?')}")
    return n


def _check_small(name: str, M: Any) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``M`` is a square ``(n, n, *batch)`` matrix
    (array or nested rows) with ``n`` = 1..4."""
    try:
        n = _size(M)
    except (TypeError, ValueError):
        n = None
    if n is None or n > MAX_CLOSED_FORM:
        shape = getattr(M, "shape", None)
        raise ValueError(
            f"{name} must be a square (n, n, *batch) matrix, 1x1 to {MAX_CLOSED_FORM}x{MAX_CLOSED_FORM}, "
            f"got {'shape ' + str(tuple(shape)) if shape is not None else repr(M)}"
        )


def _entries(M: Any) -> list[list[Array]]:
    if isinstance(M, np.ndarray):
        M = jax.device_put(M)  # not jnp.asarray: that compiles a program per shape (jaxlib 0.10)
    n = _size(M)
    return [[M[i][j] for j in range(n)] for i in range(n)]


def _minors2(a, r0: int, r1: int) -> dict[tuple[int, int], Array]:
    """All 2x2 minors of rows ``r0, r1`` of a 4x4 matrix, keyed by their column pair."""
    return {(j, k): a[r0][j] * a[r1][k] - a[r1][j] * a[r0][k] for j in range(4) for k in range(j + 1, 4)}


def _det4_parts(a):
    s = _minors2(a, 0, 1)  # rows 0, 1
    c = _minors2(a, 2, 3)  # rows 2, 3
    det = (
        s[0, 1] * c[2, 3]
        - s[0, 2] * c[1, 3]
        + s[0, 3] * c[1, 2]
        + s[1, 2] * c[0, 3]
        - s[1, 3] * c[0, 2]
        + s[2, 3] * c[0, 1]
    )
    return s, c, det


def det_small(M: Any) -> Array:
    """``det(M)`` for ``M`` of shape ``(n, n, *batch)``, ``n`` = 1..4, written out; shape ``batch``."""
    _check_small("M", M)
    a = _entries(M)
    n = len(a)
    if n == 1:
        return jnp.asarray(a[0][0])
    if n == 2:
        return a[0][0] * a[1][1] - a[0][1] * a[1][0]
    if n == 3:
        return (
            a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
        )
    if n == 4:
        return _det4_parts(a)[2]
    raise ValueError(f"det_small: closed forms for 1x1 to 4x4 matrices, got {n}x{n}")


def _adjugate_and_det(a) -> tuple[list[list[Array]], Array]:
    n = len(a)
    if n == 1:
        return [[jnp.ones_like(a[0][0])]], a[0][0]
    if n == 2:
        return [[a[1][1], -a[0][1]], [-a[1][0], a[0][0]]], a[0][0] * a[1][1] - a[0][1] * a[1][0]
    if n == 3:
        c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1]
        c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2]
        c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0]
        adj = [
            [c00, a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][1] * a[1][2] - a[0][2] * a[1][1]],
            [c01, a[0][0] * a[2][2] - a[0][2] * a[2][0], a[0][2] * a[1][0] - a[0][0] * a[1][2]],
            [c02, a[0][1] * a[2][0] - a[0][0] * a[2][1], a[0][0] * a[1][1] - a[0][1] * a[1][0]],
        ]
        return adj, a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02
    if n == 4:
        s, c, det = _det4_parts(a)
        adj = [
            [
                a[1][1] * c[2, 3] - a[1][2] * c[1, 3] + a[1][3] * c[1, 2],
                -a[0][1] * c[2, 3] + a[0][2] * c[1, 3] - a[0][3] * c[1, 2],
                a[3][1] * s[2, 3] - a[3][2] * s[1, 3] + a[3][3] * s[1, 2],
                -a[2][1] * s[2, 3] + a[2][2] * s[1, 3] - a[2][3] * s[1, 2],
            ],
            [
                -a[1][0] * c[2, 3] + a[1][2] * c[0, 3] - a[1][3] * c[0, 2],
                a[0][0] * c[2, 3] - a[0][2] * c[0, 3] + a[0][3] * c[0, 2],
                -a[3][0] * s[2, 3] + a[3][2] * s[0, 3] - a[3][3] * s[0, 2],
                a[2][0] * s[2, 3] - a[2][2] * s[0, 3] + a[2][3] * s[0, 2],
            ],
            [
                a[1][0] * c[1, 3] - a[1][1] * c[0, 3] + a[1][3] * c[0, 1],
                -a[0][0] * c[1, 3] + a[0][1] * c[0, 3] - a[0][3] * c[0, 1],
                a[3][0] * s[1, 3] - a[3][1] * s[0, 3] + a[3][3] * s[0, 1],
                -a[2][0] * s[1, 3] + a[2][1] * s[0, 3] - a[2][3] * s[0, 1],
            ],
            [
                -a[1][0] * c[1, 2] + a[1][1] * c[0, 2] - a[1][2] * c[0, 1],
                a[0][0] * c[1, 2] - a[0][1] * c[0, 2] + a[0][2] * c[0, 1],
                -a[3][0] * s[1, 2] + a[3][1] * s[0, 2] - a[3][2] * s[0, 1],
                a[2][0] * s[1, 2] - a[2][1] * s[0, 2] + a[2][2] * s[0, 1],
            ],
        ]
        return adj, det
    raise ValueError(f"inverse_small: closed forms for 1x1 to 4x4 matrices, got {n}x{n}")


def inverse_small(M: Any) -> Array:
    """``M^-1 = adj(M) / det(M)`` for ``M`` of shape ``(n, n, *batch)``, ``n`` = 1..4; same shape.

    One division per matrix (``1 / det``), the rest multiplications and additions.
    """
    _check_small("M", M)
    adj, det = _adjugate_and_det(_entries(M))
    r = 1.0 / det
    return jnp.stack([jnp.stack([e * r for e in row]) for row in adj])


def solve_small(B: Any, A: Any) -> Array:
    """``B^-1 A`` for ``B`` of shape ``(n, n, *batch)`` (``n`` = 1..4) and ``A`` of shape
    ``(n, m, *batch)``, written out; shape ``(n, m, *batch)``."""
    _check_small("B", B)
    adj, det = _adjugate_and_det(_entries(B))
    n = len(adj)
    accepted = f"A must be an (n, m, *batch) matrix with as many rows as B ({n})"
    if isinstance(A, np.ndarray):
        A = jax.device_put(A)
    try:
        if isinstance(A, (str, bytes)) or any(isinstance(row, (str, bytes)) for row in A):
            raise TypeError
        shape = getattr(A, "shape", None)
        if shape is not None and len(shape) < 2:
            raise TypeError
        rows = [shape[1]] * shape[0] if shape is not None else [len(row) for row in A]
    except TypeError:
        raise ValueError(
            f"{accepted}, got {'shape ' + str(tuple(A.shape)) if hasattr(A, 'shape') else repr(A)}"
        ) from None
    if len(rows) != n:
        raise ValueError(f"{accepted}, got {len(rows)} rows")
    m = rows[0]
    if m < 1 or any(r != m for r in rows):
        raise ValueError(f"{accepted}: every row of A must have the same number m >= 1 of columns, got {rows}")
    try:
        np.broadcast_shapes(jnp.shape(det), jnp.shape(A[0][0]))
    except ValueError:
        raise ValueError(f"A's batch axes {jnp.shape(A[0][0])} do not broadcast against B's {jnp.shape(det)}") from None
    r = 1.0 / det
    return jnp.stack([jnp.stack([sum(adj[i][k] * A[k][j] for k in range(n)) * r for j in range(m)]) for i in range(n)])
