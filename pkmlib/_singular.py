"""Singular curves: sign changes of a pointwise function (det(A)) on a grid, refined and checked.

P1 (text before Fig 5) and P2 locate type-2 singularities where det(A) changes sign between
neighbouring grid points; pkmlib refines each crossing by bisection on the function along the grid
segment, to a stated tolerance (1e-9 m by default), instead of reporting the cell.

A sign change is not always a root: det(A) also changes sign where the inverse position solution
jumps (P2: a chain folding onto its base joint, C_i = A_i, flips its elbow) or where the function
has a pole. Bisection converges to such points too, so every refined crossing is checked:

* **root**: ``max |f|`` at the ends of the bisection bracket shrinks with the bracket. Between two
  bracket sizes ``2^d`` apart (``d = 10``) it must fall by at least ``2^(d/2)`` (a simple root falls
  by ``2^d``, within a factor 2, since ``|f|`` at the ends of a bracket of length ``L`` around a simple
  root is between ``|f'| L / 2`` and ``|f'| L``);
* **pole**: it grows by at least a factor 2;
* **jump**: anything in between (``|f|`` tends to non-zero one-sided limits);
* **undefined**: ``f`` is NaN inside the segment although finite at its ends.

Exact zeros at grid nodes (no strict sign change on either side) are roots too. Two roots in one
segment, or a curve touching zero (a double root), give no sign change at all; they are listed
as *suspects*: along every grid line, each node where ``|f|`` has a local minimum that a parabola
through it and its neighbours extrapolates to (nearly) zero is followed by a minimisation of
``|f|`` (golden-section search of ``sign * f``) over its two segments: a negative minimum means two
sign changes in those segments (``"two_roots"``), a minimum below ``touch_rtol`` times the
neighbouring values a touching curve (``"touching"``).

:func:`singular_crossings` returns the roots only; :func:`classify_crossings` returns everything
(roots, the rejected poles and jumps, the suspects) as a :class:`Crossings`.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._grid import Grid
from ._validation import check_array, check_callable, check_flag, check_nonnegative, check_positive, check_tolerance

#: Bracket halvings between the two sizes compared by the root test.
CHECK_LEVELS = 10
#: Fewest bisection steps: the coarse bracket of the test is then at most 1/1024 of the segment.
MIN_ITERATIONS = 2 * CHECK_LEVELS
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def sign_change_segments(grid: Grid, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid segments whose two end values are finite and of strictly opposite sign.

    Returns ``(p0, p1, axis)``: end points, each ``(m, ndim)``, and the grid axis of each segment.
    Exact zeros at nodes are not sign changes here; see :func:`zero_nodes`.
    """
    values = _check_values(grid, values)
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


def zero_nodes(grid: Grid, values: np.ndarray) -> np.ndarray:
    """Grid nodes where ``values`` is exactly 0, ``(m, ndim)``: roots that no sign change brackets."""
    values = _check_values(grid, values)
    idx = np.argwhere(values == 0.0)
    axes = grid.axes
    return np.stack([axes[k][idx[:, k]] for k in range(grid.ndim)], axis=-1) if idx.size else np.empty((0, grid.ndim))


def _check_values(grid: Grid, values: np.ndarray) -> np.ndarray:
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a pkmlib.Grid, got {type(grid).__name__}")
    values = np.asarray(values)
    if values.shape != grid.shape:
        raise ValueError(f"values have shape {values.shape}, the grid {grid.shape}")
    if values.dtype.kind not in "iuf":
        raise ValueError(f"values must be real numbers (the function on the grid), got dtype {values.dtype}")
    return values


class Refinement(NamedTuple):
    """Result of :func:`refine_brackets`, one entry per segment."""

    x: np.ndarray  #: (m, ndim) midpoint of the final bracket
    kind: np.ndarray  #: (m,) "root", "pole", "jump" or "undefined"
    f_x: np.ndarray  #: (m,) f at x
    shrink: np.ndarray  #: (m,) max |f| at the bracket ends, fine over coarse (root: about 2^-CHECK_LEVELS)
    residual: np.ndarray  #: (m,) |f(x)| / max(|f(p0)|, |f(p1)|)

    @property
    def is_root(self) -> np.ndarray:
        return self.kind == "root"


def _segments(p0, p1):
    p0 = np.asarray(check_array("p0", p0, what="the segments' first ends"))
    p1 = np.asarray(check_array("p1", p1, what="the segments' second ends"))
    if p0.shape != p1.shape or p0.ndim != 2:
        raise ValueError(f"p0 and p1 must both have shape (m, ndim), got {p0.shape} and {p1.shape}")
    for name, p in (("p0", p0), ("p1", p1)):
        if not np.all(np.isfinite(p)):
            bad = np.argwhere(~np.all(np.isfinite(p), axis=1))[:, 0]
            raise ValueError(
                f"{name} must hold finite points (the ends of segments where fn changes sign), got NaN "
                f"or inf in rows {bad[:10].tolist()}"
            )
    return p0, p1


def _iterations(p0, p1, tol) -> int:
    length = float(np.max(np.linalg.norm(p1 - p0, axis=-1)))
    return max(1, math.ceil(math.log2(length / tol)) + 1) if length > 0 else 1


def refine_brackets(fn: Callable, p0: np.ndarray, p1: np.ndarray, tol: float = 1e-9) -> Refinement:
    """Bisection of ``fn`` along each segment ``p0 -> p1`` (shorter than ``tol`` at the end), and
    the test that tells a root from a pole or a jump (module docstring).

    ``fn`` maps one point ``(ndim,)`` to a scalar and must change sign between the ends; ``tol``
    is a finite positive length. At least :data:`MIN_ITERATIONS` halvings are made, so a segment may
    be refined below ``tol``. All segments at once (``vmap`` of ``lax.fori_loop``).
    """
    check_callable("fn", fn, "a function of one point (d,) returning a number")
    tol = check_tolerance("tol", tol)
    p0, p1 = _segments(p0, p1)
    m = len(p0)
    if m == 0:
        empty = np.empty((0,))
        return Refinement(p0.copy(), np.empty((0,), dtype="<U9"), empty, empty.copy(), empty.copy())
    n_iter = max(_iterations(p0, p1, tol), MIN_ITERATIONS)
    # The test compares two bracket sizes CHECK_LEVELS halvings apart, the finer one at least
    # 2^10 float spacings long (tiny tolerances must not turn rounding noise into a "jump").
    length = np.linalg.norm(p1 - p0, axis=-1)
    ulp = np.linalg.norm(np.spacing(np.maximum(np.abs(p0), np.abs(p1))), axis=-1)
    with np.errstate(divide="ignore"):
        resolvable = np.floor(np.log2(np.maximum(length, 1e-300) / (1024.0 * ulp)))
    k2 = np.clip(resolvable, 0, n_iter).astype(np.int64)
    k1 = np.maximum(k2 - CHECK_LEVELS, 0)

    def one(a, b, k1, k2):
        fa, fb = fn(a), fn(b)
        top = jnp.maximum(jnp.abs(fa), jnp.abs(fb))
        rec1 = jnp.where(k1 == 0, top, jnp.nan)
        rec2 = jnp.where(k2 == 0, top, jnp.nan)

        def body(i, state):
            a, b, fa, fb, rec1, rec2 = state
            m = 0.5 * (a + b)
            fm = fn(m)
            same = jnp.sign(fm) == jnp.sign(fa)
            a, b = jnp.where(same, m, a), jnp.where(same, b, m)
            fa, fb = jnp.where(same, fm, fa), jnp.where(same, fb, fm)
            size = jnp.maximum(jnp.abs(fa), jnp.abs(fb))
            rec1 = jnp.where(i + 1 == k1, size, rec1)
            rec2 = jnp.where(i + 1 == k2, size, rec2)
            return a, b, fa, fb, rec1, rec2

        a, b, _, _, rec1, rec2 = jax.lax.fori_loop(0, n_iter, body, (a, b, fa, fb, rec1, rec2))
        x = 0.5 * (a + b)
        # an infinite value at the fine bracket is a pole whatever the coarse one was (inf / inf)
        return x, fn(x), jnp.where(jnp.isinf(rec2), jnp.inf, rec2 / rec1), top

    x, f_x, shrink, top = (
        np.asarray(v) for v in jax.jit(jax.vmap(one))(*(jax.device_put(a) for a in (p0, p1, k1, k2)))
    )
    d = (k2 - k1).astype(np.float64)
    with np.errstate(invalid="ignore"):
        kind = np.where(
            np.isnan(shrink) | (np.isnan(f_x) & ~np.isinf(shrink)),
            "undefined",
            np.where((d < 4) | (shrink <= 2.0 ** (-d / 2)), "root", np.where(shrink >= 2.0, "pole", "jump")),
        )
        residual = np.abs(f_x) / top
    return Refinement(x, kind.astype("<U9"), f_x, shrink, residual)


def refine_roots(fn: Callable, p0: np.ndarray, p1: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Bisection of ``fn`` along each segment ``p0 -> p1`` until it is shorter than ``tol``.

    ``fn`` must change sign between the ends. Returns the midpoints of the final brackets,
    within ``tol / 2`` of the sign change along each segment, for every segment, **without**
    telling roots from poles or jumps: :func:`refine_brackets` does (and :func:`singular_crossings`
    keeps only roots). ``tol`` must be a finite positive number.
    """
    check_callable("fn", fn, "a function of one point (d,) returning a number")
    tol = check_tolerance("tol", tol)
    p0, p1 = _segments(p0, p1)
    if len(p0) == 0:
        return p0.copy()
    n_iter = _iterations(p0, p1, tol)

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


@dataclasses.dataclass(frozen=True)
class Crossings:
    """Everything :func:`classify_crossings` found; arrays of points have shape ``(m, ndim)``.

    Attributes:
        roots: verified roots: refined sign changes that pass the root test, then exact zeros at
            grid nodes.
        axis: grid axis of the segment of each root; -1 for a zero at a node.
        rejected: refined sign changes that are not roots.
        rejected_axis: their grid axes.
        rejected_kind: ``"pole"``, ``"jump"`` or ``"undefined"`` for each.
        rejected_value: ``f`` at each rejected point (a jump's one-sided value).
        suspects: minimisers of ``|f|`` along grid lines where a double root or two roots in one
            segment are suspected (no sign change brackets them).
        suspect_axis: the grid axis of the line searched.
        suspect_kind: ``"two_roots"`` (``f`` changes sign twice across the two segments) or
            ``"touching"`` (``|f|`` dips to ``touch_rtol`` of its neighbours without a sign change).
        suspect_value: ``f`` at each suspect.
    """

    roots: np.ndarray
    axis: np.ndarray
    rejected: np.ndarray
    rejected_axis: np.ndarray
    rejected_kind: np.ndarray
    rejected_value: np.ndarray
    suspects: np.ndarray
    suspect_axis: np.ndarray
    suspect_kind: np.ndarray
    suspect_value: np.ndarray

    def summary(self) -> str:
        """One line: how many roots, rejected crossings by kind, suspects by kind."""

        def count(kinds):
            names, n = np.unique(kinds, return_counts=True)
            return ", ".join(f"{c} {k}" for k, c in zip(names, n)) or "none"

        nodes = int(np.sum(self.axis == -1))
        return (
            f"{len(self.roots)} roots ({nodes} at grid nodes); rejected sign changes: "
            f"{count(self.rejected_kind)}; suspected double roots: {count(self.suspect_kind)}"
        )


def classify_crossings(
    fn: Callable, grid: Grid, values: np.ndarray, tol: float = 1e-9, *, suspects: bool = True, touch_rtol: float = 1e-6
) -> Crossings:
    """Refined zeros of ``fn`` on the grid, checked, with the rejected crossings and the suspects.

    ``values`` is ``fn`` on the grid (``pkmlib.sweep(fn, grid)``); ``fn`` maps one point to a
    scalar. Sign changes are refined by :func:`refine_brackets` to ``tol`` and kept as roots only
    when they pass the root test; exact zeros at nodes are added (axis -1). With ``suspects=True``
    the grid lines are searched for double roots and two roots in one segment (module docstring),
    ``touch_rtol`` being the relative depth of a touching curve.
    """
    tol = check_tolerance("tol", tol)
    touch_rtol = check_positive("touch_rtol", touch_rtol)
    suspects = check_flag("suspects", suspects)
    values = _check_values(grid, values)
    p0, p1, axis = sign_change_segments(grid, values)
    ref = refine_brackets(fn, p0, p1, tol)
    ok = ref.is_root
    nodes = zero_nodes(grid, values)
    roots = np.concatenate([ref.x[ok], nodes]) if len(nodes) else ref.x[ok]
    root_axis = np.concatenate([axis[ok], np.full(len(nodes), -1, dtype=int)])
    if suspects:
        s_x, s_axis, s_kind, s_val = _suspects(fn, grid, values, tol, touch_rtol)
    else:
        s_x, s_axis, s_kind, s_val = (
            np.empty((0, grid.ndim)),
            np.empty((0,), dtype=int),
            np.empty((0,), dtype="<U9"),
            np.empty((0,)),
        )
    return Crossings(roots, root_axis, ref.x[~ok], axis[~ok], ref.kind[~ok], ref.f_x[~ok], s_x, s_axis, s_kind, s_val)


def singular_crossings(fn: Callable, grid: Grid, values: np.ndarray, tol: float = 1e-9):
    """Refined zeros of ``fn`` on every grid segment where ``values`` (``fn`` on the grid) change sign.

    Returns ``(roots, axis)``: the refined points ``(m, ndim)`` and the grid axis along which each
    crossing was found. Only crossings that pass the root test are returned (poles and jumps of
    ``fn`` are dropped), followed by exact zeros at grid nodes, with axis -1. For the dropped
    crossings and the suspected double roots use :func:`classify_crossings`.
    """
    c = classify_crossings(fn, grid, values, tol, suspects=False)
    return c.roots, c.axis


def _suspects(fn, grid, values, tol, touch_rtol):
    """Local minima of |f| along grid lines that may hide two roots or a double root (docstring)."""
    axes = grid.axes
    lefts, rights, dirs = [], [], []
    for a in range(grid.ndim):
        if grid.shape[a] < 3:
            continue
        sl = [[slice(None)] * grid.ndim for _ in range(3)]
        sl[0][a], sl[1][a], sl[2][a] = slice(None, -2), slice(1, -1), slice(2, None)
        v0, v1, v2 = (values[tuple(s)] for s in sl)
        with np.errstate(invalid="ignore", over="ignore"):
            same = np.isfinite(v0) & np.isfinite(v1) & np.isfinite(v2) & (v0 * v1 > 0) & (v1 * v2 > 0)
            a0, a1, a2 = np.abs(v0), np.abs(v1), np.abs(v2)
            dip = same & (a1 < a0) & (a1 < a2)
            # parabola through the three |f| values (node spacing 1): its minimum
            curv = a0 - 2 * a1 + a2
            predicted = a1 - (a2 - a0) ** 2 / (8 * np.where(curv > 0, curv, 1.0))
            candidate = dip & (predicted <= 0.1 * a1)
        idx = np.argwhere(candidate)
        if idx.size == 0:
            continue
        # idx[:, a] is the left neighbour of the dip along axis a (the sliced arrays start there)
        start = np.stack([axes[k][idx[:, k]] for k in range(grid.ndim)], axis=-1)
        end = start.copy()
        end[:, a] = axes[a][idx[:, a] + 2]
        lefts.append(start)
        rights.append(end)
        dirs.append(np.full(len(idx), a))
    if not lefts:
        return np.empty((0, grid.ndim)), np.empty((0,), dtype=int), np.empty((0,), dtype="<U9"), np.empty((0,))
    p0, p1, axis = np.concatenate(lefts), np.concatenate(rights), np.concatenate(dirs)
    length = float(np.max(np.linalg.norm(p1 - p0, axis=-1)))
    n_iter = max(1, math.ceil(math.log(length / tol) / math.log(1.0 / _GOLDEN)) + 1)

    def one(a, b):
        s = jnp.sign(fn(a))
        g = lambda t: s * fn(a + t * (b - a))  # noqa: E731

        def body(_, st):
            lo, hi = st
            t1, t2 = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
            left = g(t1) <= g(t2)
            return jnp.where(left, lo, t1), jnp.where(left, t2, hi)

        lo, hi = jax.lax.fori_loop(0, n_iter, body, (jnp.asarray(0.0), jnp.asarray(1.0)))
        t = 0.5 * (lo + hi)
        x = a + t * (b - a)
        return x, fn(x), s * fn(x), jnp.maximum(jnp.abs(fn(a)), jnp.abs(fn(b)))

    x, f_x, depth, scale = (np.asarray(v) for v in jax.jit(jax.vmap(one))(jnp.asarray(p0), jnp.asarray(p1)))
    kind = np.where(depth < 0, "two_roots", np.where(depth <= touch_rtol * scale, "touching", ""))
    keep = kind != ""
    return x[keep], axis[keep], kind[keep].astype("<U9"), f_x[keep]


def cluster_levels(values: np.ndarray, atol: float) -> np.ndarray:
    """Sorted representative values (means) of groups of values closer than ``atol`` to a neighbour.

    Used to turn the refined crossings of a straight singular line into the line's position.
    ``values`` is one coordinate of the points, ``(m,)`` finite numbers (pass ``roots[:, 1]``, not
    the ``(m, ndim)`` points themselves).
    """
    atol = check_nonnegative("atol", atol, "a finite distance >= 0")
    v = np.asarray(check_array("values", values, ndim=1, what="one coordinate of each point, (m,)"))
    if not np.all(np.isfinite(v)):
        raise ValueError(f"values must be finite numbers (drop NaN entries first), got {v.tolist()[:10]}")
    v = np.sort(v)
    if v.size == 0:
        return v
    breaks = np.flatnonzero(np.diff(v) > atol) + 1
    return np.array([g.mean() for g in np.split(v, breaks)])


def null_direction(M: np.ndarray) -> np.ndarray:
    """Unit right singular vector of the smallest singular value of ``M`` (one pose).

    At a type-2 singularity (det(A) = 0) this is the uncontrolled output motion ``x'`` with
    ``A x' = 0`` (P1 text after Fig 5); its sign is fixed so that its largest entry is positive.
    """
    M = np.asarray(check_array("M", M, ndim=2, what="one pose's matrix"))
    if M.size == 0:
        raise ValueError(f"M must have at least one row and one column, got shape {M.shape}")
    if not np.all(np.isfinite(M)):
        raise ValueError(
            "M must hold finite numbers (a pose inside the workspace: NaN marks one outside, where no "
            f"direction is defined), got {M.tolist()}"
        )
    _, _, vt = np.linalg.svd(M)
    v = vt[-1]
    return v * np.sign(v[np.argmax(np.abs(v))])
