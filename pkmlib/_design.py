"""Dimensional synthesis by gradients through whole workspace maps, and performance atlases.

The papers analyse given dimensions; choosing them is what their readers do next (P4, conclusion:
"the approach can be used to optimise the geometric parameters by maximising the effective
workspace"). The measures the papers use are indicators (a pose is in the workspace or not, a
criterion is under a bound or not) summed over a grid: piecewise constant in the dimensions, so
their gradient is zero almost everywhere. Here each has a smooth version whose sharpness is a
parameter and which converges to the exact measure as the smoothing goes to zero:

- :func:`soft_indicator`: ``sigmoid(g / width)`` for ``1[g >= 0]``;
- :func:`soft_area`: the sum of soft indicators times the cell area, for the area (volume) of
  ``{g >= 0}`` on a grid;
- :func:`soft_min`, :func:`soft_max`: ``-/+ width * logsumexp(-/+ v / width)`` for the minimum /
  maximum of a criterion over a task region (exact as ``width -> 0``; NaN entries are left out);
- :func:`near_singularity`: the soft fraction of grid points where ``|det| < eps`` (a penalty for
  approaching det(A) = 0 or det(B) = 0).

:func:`maximise` runs SciPy's L-BFGS-B on a JAX objective with its exact gradient (forward or
reverse mode, whichever is measured faster for the objective). Why L-BFGS-B: the design vectors
are small (2-6 dimensions), the dimensions have box bounds (which L-BFGS-B handles natively,
unlike optax's unconstrained first-order steps or optimistix's minimisers), the objective is
deterministic and smooth after smoothing, and a quasi-Newton method needs tens of evaluations
where a swarm needs thousands. The design is mapped affinely onto the unit box first, since
L-BFGS-B is not invariant to the scale of its variables (millimetres beside fractions).

:func:`maximise_min` solves the max-min problems of the papers' readers (the largest *smallest*
stiffness over a task region) exactly, without smoothing, in their epigraph form
``max t  s.t.  v_i(design) >= t, m_j(design) >= 0`` by SciPy's SLSQP (sequential quadratic
programming, the method of P4's reference [13]) fed the exact constraint Jacobian from JAX. A
smoothed minimum (:func:`soft_min`) under L-BFGS-B also works, but the kinks of the minimum
(where the pose that attains it switches) stall a quasi-Newton method on it, so it needs many
starts; the epigraph form turns the kinks into active constraints.

:func:`atlas` evaluates a criterion over a grid of designs x a grid of poses in one compiled,
chunked call (``vmap`` over designs, the poses inside), with a progress bar: the performance atlas
of Liu and Wang as one JAX program.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from typing import Any, Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._grid import Grid
from ._memory import check_memory
from ._validation import check_array, check_callable, check_count, check_positive, check_tolerance
from ._validation import check_nonnegative as check_nonnegative_tol

Array = Any


def soft_indicator(g: Array, width: float) -> Array:
    """Smooth ``1[g >= 0]``: ``sigmoid(g / width)``; ``width > 0`` in the units of ``g``.

    Converges to the indicator (1/2 at ``g = 0``) as ``width -> 0``. NaN ``g`` (outside the
    workspace) gives 0, with a zero gradient.
    """
    check_positive("width", width)
    g = check_array("g", g, what="the margins, NaN outside the workspace")
    ok = jnp.isfinite(g)
    return jnp.where(ok, jax.nn.sigmoid(jnp.where(ok, g, 0.0) / width), 0.0)


def soft_area(g: Array, cell_area: float, width: float) -> Array:
    """Smooth area (volume) of ``{g >= 0}`` sampled on a grid: ``sum soft_indicator(g) * cell_area``."""
    check_positive("cell_area", cell_area)
    check_positive("width", width)
    return jnp.sum(soft_indicator(g, width)) * cell_area


def exact_area(g: Array, cell_area: float) -> float:
    """The exact counterpart of :func:`soft_area`: ``count(g >= 0) * cell_area`` (NaN counts as outside)."""
    cell_area = check_positive("cell_area", cell_area)
    try:
        g = np.asarray(g, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"g must be an array of real numbers (NaN outside), got {g!r}") from None
    return float(np.count_nonzero(np.isfinite(g) & (g >= 0.0)) * cell_area)


def _finite_or(v: Array, fill: float) -> tuple[Array, Array]:
    ok = jnp.isfinite(v)
    return jnp.where(ok, v, fill), ok


def soft_max(v: Array, width: float) -> Array:
    """Smooth maximum ``width * log(mean(exp(v / width)))`` over all entries of ``v``; NaN left out.

    Lies within ``width * log(N)`` below the exact maximum and converges to it as ``width -> 0``.
    Its gradient is the softmax weights (the exact maximum's gradient at a unique maximiser in
    the limit).
    """
    check_positive("width", width)
    v = check_array("v", v, what="the values, NaN outside the workspace").ravel()
    if v.size == 0:
        raise ValueError(f"v must hold at least one number, got shape {v.shape}")
    vv, ok = _finite_or(v, -jnp.inf)
    n = jnp.sum(ok.astype(jnp.float64))
    return width * (jax.scipy.special.logsumexp(vv / width, b=ok.astype(jnp.float64)) - jnp.log(n))


def soft_min(v: Array, width: float) -> Array:
    """Smooth minimum ``-soft_max(-v)``; NaN entries left out. Lies above the exact minimum by at
    most ``width * log(N)``."""
    return -soft_max(-check_array("v", v, what="the values, NaN outside the workspace"), width)


def near_singularity(det: Array, eps: float, width: float) -> Array:
    """Soft fraction of the finite entries of ``det`` with ``|det| < eps``: a penalty for
    approaching det(A) = 0 (type 2) or det(B) = 0 (type 1). Exact as ``width -> 0``."""
    check_positive("eps", eps)
    check_positive("width", width)
    det = check_array("det", det, what="the determinants, NaN outside the workspace")
    ok = jnp.isfinite(det)
    s = soft_indicator(jnp.where(ok, eps - jnp.abs(det), -jnp.inf), width)
    return jnp.sum(jnp.where(ok, s, 0.0)) / jnp.maximum(jnp.sum(ok.astype(jnp.float64)), 1.0)


@dataclasses.dataclass(frozen=True)
class DesignResult:
    """The outcome of :func:`maximise`, :func:`maximise_min` or :func:`maximise_derivative_free`:
    the design, its objective, the work it took.

    ``seconds`` is the optimisation itself; ``setup_seconds`` the compilation before it (and, for
    ``derivatives="auto"``, the timing of both derivative modes), kept apart because a compiled
    objective is reused across runs (and the persistent compilation cache keeps it across
    sessions). ``derivatives`` is the mode used (``"forward"``, ``"reverse"``, or ``"none"``).
    ``start_objectives`` is the objective reached from each start of a multi-start, in order (NaN
    where :func:`maximise_min` ended infeasible).
    """

    design: np.ndarray
    objective: float
    evaluations: int
    seconds: float
    success: bool
    message: str
    history: tuple[float, ...]
    setup_seconds: float = 0.0
    derivatives: str = "none"
    start_objectives: tuple[float, ...] = ()


def _check_bounds(bounds, n: int) -> np.ndarray:
    try:
        b = np.asarray(bounds, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"bounds must be one (low, high) pair of numbers per design variable, got {bounds!r}"
        ) from None
    if b.shape != (n, 2):
        raise ValueError(f"bounds must have shape ({n}, 2) (one (low, high) per design variable), got {b.shape}")
    if not np.all(np.isfinite(b)) or np.any(b[:, 0] >= b[:, 1]):
        raise ValueError(f"bounds must be finite with low < high, got {b.tolist()}")
    return b


class _UnitBox:
    """The affine map of the box ``bounds`` onto the unit box: ``design = low + z (high - low)``."""

    def __init__(self, bounds: np.ndarray):
        self.low, self.span = bounds[:, 0], bounds[:, 1] - bounds[:, 0]

    def design(self, z) -> Array:  # traced or concrete z in [0, 1]^n
        return jnp.asarray(self.low) + z * jnp.asarray(self.span)

    def to_unit(self, design: np.ndarray) -> np.ndarray:
        return np.clip((np.asarray(design, dtype=np.float64) - self.low) / self.span, 0.0, 1.0)

    def to_design(self, z: np.ndarray) -> np.ndarray:
        return np.clip(self.low + np.asarray(z, dtype=np.float64) * self.span, self.low, self.low + self.span)


_DERIVATIVES = ("auto", "forward", "reverse")


def _check_scalar_objective(
    name: str, f: Callable, x: Array, accepted: str = "a JAX function of the design returning one number"
) -> None:
    """Raise ``ValueError`` naming ``name`` unless ``f(x)`` traces to one real number (checked by
    ``jax.eval_shape``: nothing is computed); SciPy would otherwise fail later with its own words."""
    check_callable(name, f, accepted)
    try:
        out = jax.eval_shape(f, jnp.asarray(x, dtype=jnp.float64))
    except Exception as e:  # the user's function failed while being traced
        raise ValueError(
            f"{name} must be {accepted}; calling it on a design of shape {np.shape(x)} failed: "
            f"{type(e).__name__}: {str(e)[:300]}"
        ) from e
    if getattr(out, "shape", None) != () or not jnp.issubdtype(out.dtype, jnp.floating):
        raise ValueError(f"{name} must be {accepted}; it returns shape {getattr(out, 'shape', type(out).__name__)}")


def _check_derivatives(derivatives: str) -> str:
    if derivatives not in _DERIVATIVES:
        raise ValueError(f"derivatives must be one of {_DERIVATIVES}, got {derivatives!r}")
    return derivatives


def _best_seconds(f: Callable, x: Array, repeats: int = 3) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(f(x))
        best = min(best, time.perf_counter() - t)
    return best


def _derivative_modes(f: Callable[[Array], Array], n: int) -> dict[str, Callable]:
    """``f`` and its gradient, compiled, by forward mode (``n`` JVPs batched with ``vmap``) and by
    reverse mode (``jax.value_and_grad``)."""

    def forward(z):
        return jax.vmap(lambda e: jax.jvp(f, (z,), (e,)), out_axes=(None, 0))(jnp.eye(n, dtype=jnp.float64))

    return {"forward": jax.jit(forward), "reverse": jax.jit(jax.value_and_grad(f))}


def _value_and_gradient(f: Callable[[Array], Array], x: Array, derivatives: str) -> tuple[Callable, str]:
    """``f`` and its gradient in one compiled call, by forward mode (``n`` JVPs batched with
    ``vmap``) or reverse mode (``jax.value_and_grad``); ``"auto"`` compiles both, times each (best
    of 3 calls at ``x``) and keeps the faster. Which is faster depends on the objective, not only
    on ``n``: forward mode was 2.1x faster on the P2 study (3 variables, 7.8k poses), reverse mode
    1.7x faster on the P4 study (5 variables, a 15x15 condensation per pose)."""
    modes = _derivative_modes(f, int(np.shape(x)[0]))
    if derivatives != "auto":
        jax.block_until_ready(modes[derivatives](x))
        return modes[derivatives], derivatives
    for vg in modes.values():
        jax.block_until_ready(vg(x))  # compile
    best = min(modes, key=lambda m: _best_seconds(modes[m], x))
    return modes[best], best


def _starts(x0, b: np.ndarray) -> np.ndarray:
    try:
        starts = np.atleast_2d(np.asarray(x0, dtype=np.float64))
    except (TypeError, ValueError):
        raise ValueError(f"x0 must be one design of {b.shape[0]} numbers or an array of them, got {x0!r}") from None
    if starts.ndim != 2 or starts.shape[1] != b.shape[0] or starts.shape[0] == 0:
        raise ValueError(
            f"x0 must be one design of {b.shape[0]} values or an array of them (k, {b.shape[0]}), "
            f"got shape {np.shape(x0)}"
        )
    if not np.all((starts >= b[:, 0]) & (starts <= b[:, 1])):  # NaN is outside too
        raise ValueError(f"x0 {starts.tolist()} is outside the bounds {b.tolist()}")
    return starts


def latin_hypercube_starts(bounds: Sequence[Sequence[float]], n: int, *, seed: int = 0) -> np.ndarray:
    """``n`` start designs spread over the box ``bounds`` (SciPy's Latin hypercube), ``(n, d)``."""
    from scipy.stats import qmc

    b = _check_bounds(bounds, _n_bounds(bounds))
    n = check_count("n", n, minimum=1)
    seed = check_count("seed", seed, minimum=0)
    # the samples, their permutations and the scaled copy: about three (n, d) arrays of 8 bytes
    check_memory(3.0 * n * len(b) * 8, what=f"{n:.3g} Latin hypercube starts in {len(b)} dimensions", parameter="n")
    return qmc.scale(qmc.LatinHypercube(d=len(b), seed=seed).random(n), b[:, 0], b[:, 1])


def _n_bounds(bounds) -> int:
    try:
        return len(bounds)
    except TypeError:
        raise ValueError(f"bounds must be one (low, high) pair per design variable, got {bounds!r}") from None


def maximise(
    objective: Callable[[Array], Array],
    x0: Sequence[float] | Sequence[Sequence[float]],
    bounds: Sequence[Sequence[float]],
    *,
    max_iterations: int = 200,
    tol: float = 1e-9,
    derivatives: str = "auto",
) -> DesignResult:
    """Maximise a JAX ``objective(design) -> scalar`` within box ``bounds`` by L-BFGS-B with the
    exact gradient (automatic differentiation, compiled once).

    The design is optimised in the unit box (``design = low + z (high - low)``), so variables in
    millimetres and in fractions take comparable steps.

    Args:
        objective: smooth function of the design vector (use the soft measures of this module).
        x0: start design, inside the bounds; or several, ``(k, d)`` (a multi-start for
            multimodal objectives, e.g. the paper's design plus :func:`latin_hypercube_starts`):
            each is run to convergence and the best kept.
        bounds: ``(low, high)`` per design variable.
        max_iterations: L-BFGS-B iterations per start.
        tol: ``ftol`` of L-BFGS-B (relative change of the objective).
        derivatives: ``"forward"``, ``"reverse"`` or ``"auto"`` (time both once, keep the faster).
            The two modes agree to rounding, so ``"auto"`` can end a few ulps apart on machines
            that pick differently: pin the mode for bit-reproducible runs (the notebooks do).

    Returns:
        :class:`DesignResult` (``evaluations`` counts objective-and-gradient evaluations over all
        starts, ``seconds`` their total time, ``history`` the objective at each evaluation).
    """
    from scipy.optimize import minimize

    _check_derivatives(derivatives)
    max_iterations = check_count("max_iterations", max_iterations, minimum=1)
    tol = check_tolerance("tol", tol)
    b = _check_bounds(bounds, _n_bounds(bounds))
    starts = _starts(x0, b)
    _check_scalar_objective("objective", objective, starts[0])
    box = _UnitBox(b)
    t_setup = time.perf_counter()
    vg, mode = _value_and_gradient(
        lambda z: -objective(box.design(z)), jnp.asarray(box.to_unit(starts[0])), derivatives
    )
    setup = time.perf_counter() - t_setup
    history: list[float] = []

    def fun(z):
        v, g = jax.device_get(vg(jnp.asarray(z)))
        history.append(-float(v))
        return float(v), np.asarray(g, dtype=np.float64)

    t0 = time.perf_counter()
    best, reached = None, []
    for start in starts:
        res = minimize(
            fun,
            box.to_unit(start),
            jac=True,
            method="L-BFGS-B",
            bounds=[(0.0, 1.0)] * len(b),
            options={"maxiter": int(max_iterations), "ftol": tol, "gtol": 1e-12},
        )
        reached.append(-float(res.fun))
        if best is None or res.fun < best.fun:
            best = res
    seconds = time.perf_counter() - t0
    return DesignResult(
        box.to_design(best.x),
        -float(best.fun),
        len(history),
        seconds,
        bool(best.success),
        str(best.message),
        tuple(history),
        setup,
        mode,
        tuple(reached),
    )


def maximise_min(
    values: Callable[[Array], Array],
    x0: Sequence[float] | Sequence[Sequence[float]],
    bounds: Sequence[Sequence[float]],
    *,
    margins: Callable[[Array], Array] | None = None,
    max_iterations: int = 200,
    tol: float = 1e-9,
) -> DesignResult:
    """Maximise the smallest of ``values(design)`` (``(m,)``, e.g. a criterion over the poses of a
    task region) subject to ``margins(design) >= 0`` (``(p,)``, e.g. workspace margins at those
    poses), within box ``bounds``: exactly, in the epigraph form

        max t  over (design, t)  s.t.  values_i(design) - t >= 0,  margins_j(design) >= 0,

    by SciPy's SLSQP with the exact constraint Jacobian from JAX (forward mode when the design has
    fewer variables than there are constraints, reverse mode otherwise), compiled once. The design
    is optimised in the unit box, as in :func:`maximise`.

    Args:
        values: JAX function of the design whose minimum is maximised; finite where ``margins``
            hold (compute it on clipped poses outside, as :mod:`pkmlib.design_studies` does).
        x0: start design, or several ``(k, d)`` (each run to convergence, the best feasible kept).
        bounds: ``(low, high)`` per design variable.
        margins: JAX function of the design that must be ``>= 0`` at the optimum (none: no
            constraint beyond the bounds).
        max_iterations: SLSQP iterations per start.
        tol: SLSQP's ``ftol`` (precision goal on the objective).

    Returns:
        :class:`DesignResult`: ``objective`` is ``min(values)`` at the design (exact, no
        smoothing), ``success`` also requires every margin ``>= -1e-9``; ``evaluations`` counts
        the compiled calls (values alone in SLSQP's line search, values with their Jacobian at
        its iterates), ``history`` the smallest value at each.
    """
    from scipy.optimize import minimize

    max_iterations = check_count("max_iterations", max_iterations, minimum=1)
    tol = check_tolerance("tol", tol)
    b = _check_bounds(bounds, _n_bounds(bounds))
    starts = _starts(x0, b)
    _check_vector_function("values", values, starts[0])
    if margins is not None:
        _check_vector_function("margins", margins, starts[0])
    box = _UnitBox(b)
    n = len(b)

    def g(z):  # every constraint but -t: (values, margins) of the design at unit-box point z
        d = box.design(z)
        v = jnp.ravel(jnp.asarray(values(d), dtype=jnp.float64))
        m = jnp.zeros((0,), jnp.float64) if margins is None else jnp.ravel(jnp.asarray(margins(d), dtype=jnp.float64))
        return jnp.concatenate([v, m])

    t_setup = time.perf_counter()
    z_start = jnp.asarray(box.to_unit(starts[0]))
    m_values = int(np.size(jax.eval_shape(lambda z: values(box.design(z)), z_start)))
    n_out = int(jax.eval_shape(g, z_start).shape[0])
    mode = "forward" if n <= n_out else "reverse"
    jac = jax.jacfwd(g) if mode == "forward" else jax.jacrev(g)
    value_only = jax.jit(g)
    value_jac = jax.jit(lambda z: (g(z), jac(z)))
    jax.block_until_ready(value_only(z_start))
    jax.block_until_ready(value_jac(z_start))
    setup = time.perf_counter() - t_setup
    history: list[float] = []
    cache: dict[str, tuple] = {}
    t_rows = np.concatenate([-np.ones(m_values), np.zeros(n_out - m_values)])[:, None]

    def evaluate(y, with_jacobian):
        z = np.asarray(y[:n], dtype=np.float64)
        key = "jac" if with_jacobian else "val"
        hit = cache.get(key)
        if hit is not None and np.array_equal(hit[0], z):
            return hit[1]
        if not with_jacobian and "jac" in cache and np.array_equal(cache["jac"][0], z):
            return cache["jac"][1]
        out = jax.device_get(value_jac(jnp.asarray(z)) if with_jacobian else (value_only(jnp.asarray(z)), None))
        history.append(float(np.min(out[0][:m_values])))
        cache[key] = (z.copy(), out)
        return out

    def constraint(y):
        return np.asarray(evaluate(y, False)[0], dtype=np.float64) - np.concatenate(
            [np.full(m_values, y[n]), np.zeros(n_out - m_values)]
        )

    def constraint_jacobian(y):
        J = np.asarray(evaluate(y, True)[1], dtype=np.float64)
        return np.hstack([J, t_rows])

    c_objective = np.zeros(n + 1)
    c_objective[n] = -1.0
    t0 = time.perf_counter()
    best, reached = None, []
    for start in starts:
        z0 = box.to_unit(start)
        v0 = np.asarray(evaluate(np.append(z0, 0.0), False)[0])
        y0 = np.append(z0, float(np.min(v0[:m_values])))
        res = minimize(
            lambda y: -y[n],
            y0,
            jac=lambda y: c_objective,
            method="SLSQP",
            bounds=[(0.0, 1.0)] * n + [(None, None)],
            constraints=[{"type": "ineq", "fun": constraint, "jac": constraint_jacobian}],
            options={"maxiter": int(max_iterations), "ftol": tol},
        )
        out = np.asarray(evaluate(res.x, False)[0])
        feasible = bool(np.all(out[m_values:] >= -1e-9)) and bool(np.all(np.isfinite(out)))
        score = float(np.min(out[:m_values])) if feasible else -np.inf
        reached.append(score if feasible else float("nan"))
        if best is None or score > best[0]:
            best = (score, res, feasible)
    seconds = time.perf_counter() - t0
    score, res, feasible = best
    message = str(res.message) if feasible else f"{res.message} (a margin is negative: infeasible)"
    return DesignResult(
        box.to_design(res.x[:n]),
        score if feasible else float("nan"),
        len(history),
        seconds,
        bool(res.success) and feasible,
        message,
        tuple(history),
        setup,
        mode,
        tuple(reached),
    )


def _check_vector_function(name: str, f: Callable, x: Array) -> None:
    accepted = "a JAX function of the design returning a vector (m,) of numbers"
    check_callable(name, f, accepted)
    try:
        out = jax.eval_shape(f, jnp.asarray(x, dtype=jnp.float64))
    except Exception as e:
        raise ValueError(
            f"{name} must be {accepted}; calling it on a design of shape {np.shape(x)} failed: "
            f"{type(e).__name__}: {str(e)[:300]}"
        ) from e
    shape = getattr(out, "shape", None)
    if shape is None or len(shape) > 1 or not jnp.issubdtype(out.dtype, jnp.floating):
        raise ValueError(f"{name} must be {accepted}; it returns shape {shape}")


def penalised_min(values: Array, margins: Array | None = None, penalty: float = 100.0) -> Array:
    """The exact-penalty form of :func:`maximise_min`'s problem as one number, for optimisers that
    take a scalar (:func:`maximise_derivative_free`): ``min(values) - penalty * sum(max(-margins, 0))``.
    Non-smooth (a minimum and a hinge), which a derivative-free method does not mind."""
    check_positive("penalty", penalty)
    values = check_array("values", values, what="the values whose minimum is taken")
    if values.size == 0:
        raise ValueError(f"values must hold at least one number, got shape {values.shape}")
    v = jnp.min(values)
    if margins is None:
        return v
    if callable(margins):
        raise ValueError(
            "margins must be the margins' values (an array, one per constraint), not a function "
            "(maximise_min takes functions; penalised_min takes their values)"
        )
    margins = check_array("margins", margins, what="one value per constraint, >= 0 where it holds")
    return v - penalty * jnp.sum(jnp.maximum(-margins, 0.0))


def atlas(
    criterion: Callable[..., Array],
    designs: Grid,
    poses: Grid,
    *,
    args: tuple = (),
    reduce: Callable[[Array], Array] | None = None,
    chunk_designs: int | None = None,
    max_pairs_per_call: int = 1 << 22,
    progress: bool | None = None,
) -> np.ndarray:
    """A criterion over a grid of designs x a grid of poses, in one compiled, chunked call.

    ``criterion(design, poses, *args)`` takes one design vector (``(designs.ndim,)``, in the order
    of ``designs.names``) and all poses in structure-of-arrays form (``(poses.ndim, N)``), and
    returns values per pose (``(N,)``); ``reduce`` (default: none) maps those to one number per
    design (an area, a minimum). The designs are evaluated ``chunk_designs`` at a time by one
    ``jit(vmap(...))`` over designs (the pose block is built once, inside).

    Returns an array of shape ``designs.shape`` (with ``reduce``) or ``designs.shape + poses.shape``.
    """
    check_callable("criterion", criterion, "a function criterion(design, poses, *args) -> values per pose")
    for name, g in (("designs", designs), ("poses", poses)):
        if not isinstance(g, Grid):
            raise ValueError(f"{name} must be a pkmlib.Grid, got {type(g).__name__}: {g!r}")
    if not isinstance(args, tuple):
        raise ValueError(f"args must be a tuple (passed as criterion(design, poses, *args)), got {type(args).__name__}")
    if reduce is not None:
        check_callable("reduce", reduce, "a function of the values per pose returning one number")
    max_pairs_per_call = check_count("max_pairs_per_call", max_pairs_per_call, minimum=1)
    if progress is not None and not isinstance(progress, bool):
        raise ValueError(f"progress must be True, False or None, got {progress!r}")
    pose_pts = jnp.asarray(poses.points().reshape(-1, poses.ndim).T)
    n_poses = pose_pts.shape[1]
    if chunk_designs is None:
        chunk_designs = max(1, max_pairs_per_call // n_poses)
    chunk_designs = check_count("chunk_designs", chunk_designs, minimum=1)
    design_pts = designs.points().reshape(-1, designs.ndim)
    n_designs = design_pts.shape[0]
    chunk_designs = min(chunk_designs, n_designs)
    one = (
        (lambda d, *a: reduce(criterion(d, pose_pts, *a)))
        if reduce is not None
        else (lambda d, *a: criterion(d, pose_pts, *a))
    )
    want = () if reduce is not None else (n_poses,)
    try:
        got = jax.eval_shape(one, jnp.asarray(design_pts[0]), *args)
    except Exception as e:
        raise ValueError(
            f"criterion must be criterion(design ({designs.ndim},), poses ({poses.ndim}, N), *args) -> "
            f"values (N,); calling it failed: {type(e).__name__}: {str(e)[:300]}"
        ) from e
    if getattr(got, "shape", None) != want:
        raise ValueError(
            f"criterion must return {'one value per pose, shape ' + str(want) if reduce is None else 'values that reduce maps to one number'}; "
            f"got shape {getattr(got, 'shape', type(got).__name__)}"
        )
    run = jax.jit(jax.vmap(one, in_axes=(0,) + (None,) * len(args)))
    n_chunks = math.ceil(n_designs / chunk_designs)
    pad = n_chunks * chunk_designs - n_designs
    padded = np.concatenate([design_pts, np.repeat(design_pts[-1:], pad, axis=0)])
    if progress is None:
        progress = n_designs * n_poses > 10_000_000
    chunks = range(n_chunks)
    if progress:
        from tqdm import tqdm

        chunks = tqdm(chunks, desc=f"atlas {n_designs} designs x {n_poses} poses", unit="chunk", file=sys.stderr)
    out = []
    for c in chunks:
        out.append(np.asarray(run(jnp.asarray(padded[c * chunk_designs : (c + 1) * chunk_designs]), *args)))
    values = np.concatenate(out)[:n_designs]
    tail = () if reduce is not None else poses.shape
    return values.reshape(designs.shape + tail)


def maximise_derivative_free(
    objective: Callable[[Array], Array],
    bounds: Sequence[Sequence[float]],
    *,
    seed: int = 0,
    popsize: int = 15,
    tol: float = 0.01,
    max_generations: int = 1000,
    vectorized: bool = False,
) -> DesignResult:
    """The derivative-free baseline on the same objective: SciPy's ``differential_evolution``
    (the standard stand-in for the particle swarms of synthesis toolboxes), with SciPy's default
    population and tolerance, no gradient-based polishing, the objective compiled once.

    ``vectorized=True`` evaluates each generation in one compiled ``vmap`` call (SciPy's
    ``vectorized`` with ``updating="deferred"``, a slightly different algorithm: the population
    is replaced once per generation) instead of one call per individual.

    ``evaluations`` counts objective evaluations (values only).
    """
    from scipy.optimize import differential_evolution

    b = _check_bounds(bounds, _n_bounds(bounds))
    seed = check_count("seed", seed, minimum=0)
    popsize = check_count("popsize", popsize, minimum=1)
    tol = check_nonnegative_tol("tol", tol)
    max_generations = check_count("max_generations", max_generations, minimum=1)
    # SciPy's population, its trial vectors and energies: popsize * d members of d numbers each
    check_memory(
        4.0 * 8.0 * popsize * len(b) * (len(b) + 2),
        what=f"a population of {popsize * len(b):.3g} members in {len(b)} dimensions",
        parameter="popsize",
    )
    if not isinstance(vectorized, bool):
        raise ValueError(f"vectorized must be True or False, got {vectorized!r}")
    _check_scalar_objective("objective", objective, b.mean(axis=1))
    t_setup = time.perf_counter()
    history: list[float] = []
    if vectorized:
        f = jax.jit(jax.vmap(lambda z: -objective(z)))
        f(jnp.asarray(np.repeat(b.mean(axis=1)[None], 2, axis=0))).block_until_ready()

        def fun(zs):  # SciPy passes (d, S)
            v = np.asarray(f(jnp.asarray(np.asarray(zs, dtype=np.float64).T)))
            history.extend((-v).tolist())
            return v

        extra = {"vectorized": True, "updating": "deferred"}
    else:
        f = jax.jit(lambda z: -objective(z))
        f(jnp.asarray(b.mean(axis=1))).block_until_ready()  # compile outside the timing

        def fun(z):
            v = float(f(jnp.asarray(z)))
            history.append(-v)
            return v

        extra = {}
    setup = time.perf_counter() - t_setup
    t0 = time.perf_counter()
    res = differential_evolution(
        fun, [tuple(r) for r in b], seed=seed, popsize=popsize, tol=tol, maxiter=max_generations, polish=False, **extra
    )
    seconds = time.perf_counter() - t0
    return DesignResult(
        np.asarray(res.x),
        -float(res.fun),
        len(history),
        seconds,
        bool(res.success),
        str(res.message),
        tuple(history),
        setup,
        "none",
    )
