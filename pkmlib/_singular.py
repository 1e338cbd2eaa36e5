"""Singular curves: sign changes of a pointwise function (det(A)) on a grid, refined.

P1 (text before Fig 5) and P2 locate type-2 singularities where det(A) changes sign between
neighbouring grid points; pkmlib then refines each crossing by bisection on the function along
the grid segment, to a stated tolerance (1e-9 m by default), instead of reporting the cell.
"""

from __future__ import annotations

import math
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._grid import Grid


def sign_change_segments(grid: Grid, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid segments whose two end values are finite and of strictly opposite sign.

    Returns ``(p0, p1, axis)``: end points, each ``(m, ndim)``, and the grid axis of each segment.
    """
    values = np.asarray(values)
    if values.shape != grid.shape:
        raise ValueError(f"values have shape {values.shape}, the grid {grid.shape}")
    axes = grid.axes
    p0s, p1s, dirs = [], [], []
    for a in range(grid.ndim):
        lo = [slice(None)] * grid.ndim
        hi = [slice(None)] * grid.ndim
        lo[a], hi[a] = slice(None, -1), slice(1, None)
        v0, v1 = values[tuple(lo)], values[tuple(hi)]
        idx = np.argwhere(np.isfinite(v0) & np.isfinite(v1) & (v0 * v1 < 0))
        if idx.size == 0:
            continue
        start = np.stack([axes[k][idx[:, k]] for k in range(grid.ndim)], axis=-1)
        end = start.copy()
        end[:, a] = axes[a][idx[:, a] + 1]
        p0s.append(start)
        p1s.append(end)
        dirs.append(np.full(len(idx), a))
    if not p0s:
        empty = np.empty((0, grid.ndim))
        return empty, empty.copy(), np.empty((0,), dtype=int)
    return np.concatenate(p0s), np.concatenate(p1s), np.concatenate(dirs)


def refine_roots(fn: Callable, p0: np.ndarray, p1: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Bisection of ``fn`` along each segment ``p0 -> p1`` until it is shorter than ``tol``.

    ``fn`` must change sign between the ends. Returns the midpoints of the final brackets,
    within ``tol / 2`` of a root along each segment. All segments are refined at once
    (``vmap`` of a ``lax.fori_loop``).
    """
    p0 = np.asarray(p0, dtype=np.float64)
    p1 = np.asarray(p1, dtype=np.float64)
    if len(p0) == 0:
        return p0.copy()
    length = float(np.max(np.linalg.norm(p1 - p0, axis=-1)))
    n_iter = max(1, math.ceil(math.log2(length / tol)) + 1)

    def one(a, b):
        fa = fn(a)

        def body(_, ab):
            a, b, fa = ab
            m = 0.5 * (a + b)
            fm = fn(m)
            same = jnp.sign(fm) == jnp.sign(fa)
            return jnp.where(same, m, a), jnp.where(same, b, m), jnp.where(same, fm, fa)

        a, b, _ = jax.lax.fori_loop(0, n_iter, body, (a, b, fa))
        return 0.5 * (a + b)

    return np.asarray(jax.jit(jax.vmap(one))(jnp.asarray(p0), jnp.asarray(p1)))


def singular_crossings(fn: Callable, grid: Grid, values: np.ndarray, tol: float = 1e-9):
    """Refined zeros of ``fn`` on every grid segment where ``values`` (``fn`` on the grid) change sign.

    Returns ``(roots, axis)``: the refined points ``(m, ndim)`` and the grid axis along which each
    crossing was found.
    """
    p0, p1, axis = sign_change_segments(grid, values)
    return refine_roots(fn, p0, p1, tol), axis


def cluster_levels(values: np.ndarray, atol: float) -> np.ndarray:
    """Sorted representative values (means) of groups of values closer than ``atol`` to a neighbour.

    Used to turn the refined crossings of a straight singular line into the line's position.
    """
    v = np.sort(np.asarray(values, dtype=np.float64).ravel())
    if v.size == 0:
        return v
    breaks = np.flatnonzero(np.diff(v) > atol) + 1
    return np.array([g.mean() for g in np.split(v, breaks)])


def null_direction(M: np.ndarray) -> np.ndarray:
    """Unit right singular vector of the smallest singular value of ``M`` (one pose).

    At a type-2 singularity (det(A) = 0) this is the uncontrolled output motion ``x'`` with
    ``A x' = 0`` (P1 text after Fig 5); its sign is fixed so that its largest entry is positive.
    """
    _, _, vt = np.linalg.svd(np.asarray(M, dtype=np.float64))
    v = vt[-1]
    return v * np.sign(v[np.argmax(np.abs(v))])
