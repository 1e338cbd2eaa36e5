"""Numerical position solutions of any mechanism: inverse (x -> q) on a stated branch, and every
assembly mode of the forward problem (q -> x), batched, compiled once per mechanism, with
derivatives by the implicit function theorem.

Both solve the constraint equations ``F(x, q, params) = 0`` (P1 eq (1), P2 eq (1)) and nothing
else: no closed form is needed. Derivatives through a solution never go through the iterations:
differentiating ``F(x, q(x, p), p) = 0`` gives ``A dx + B dq + F_p dp = 0`` (P1 eq (2)), hence
``dq/dx = -B^-1 A = J^-1`` (P1 eq (3)-(4)) and ``dq/dp = -B^-1 F_p`` for the inverse problem and
``dx/dq = -A^-1 B = J`` for the forward one (:func:`_implicit`, a ``jax.custom_jvp``, so ``jvp``,
``grad``, ``jacfwd`` and ``jacrev`` all work).

**Inverse branch rule.** The branch of chain ``i`` is the sign of ``dF_i/dq_i`` at the solution
(the diagonal of ``B``; it changes only across a type-1 singularity, where ``B`` is singular). For
the papers' squared-distance closures it equals their signs: P1's ``x_A = C_x + sign sqrt(...)``
(``dF/dx_A = 2 (x_A - C_x)``), P2's and P4's ``theta = atan2(...) + sign acos(...)``
(tested in ``tests/test_positions.py``). Where the chain has no real solution of that sign, or an
actuator leaves its limits, the whole pose is NaN: never an exception, never a point of another
branch.

**Inverse method** (``structure``):

- ``"diagonal"`` (chainwise mechanisms, or any whose ``B`` is found diagonal): each ``F_i`` is a
  scalar function ``g(t) = F_i(x, q_i = t)``. Where ``g``'s operations (its jaxpr: sums,
  products, integer powers, divisions by what does not depend on ``t``) make it a polynomial of
  degree <= 2 in ``t`` for every pose and parameter value (a prismatic actuator in a distance
  closure: P1, the 3-RPR; :func:`_quadratic_chains`), its Taylor coefficients at the middle of
  the search interval (two nested forward-mode derivatives) are exactly ``g``'s, and the root of
  the requested slope sign is the cancellation-free quadratic formula, with no check, no
  polishing and no fallback: the same branch rule, the same NaN where the discriminant is
  negative, and a solve that fuses with what follows it under ``jit``. Otherwise ``g`` is fitted:
  for a distance closure it is exactly a first-degree trigonometric polynomial ``a cos t + b sin t + c`` (revolute actuator, units
  ``rad``) or a quadratic (prismatic), so three samples determine it and its root of the
  requested slope sign is explicit (``t = atan2(b, a) - sign acos(-c / hypot(a, b))``, or the
  cancellation-free quadratic formula); a fourth sample checks that the fit reproduces ``g``,
  one guarded Newton step on the true ``g`` polishes the root and the residual and the slope sign
  are checked. Where the fit does not reproduce ``g`` the chain falls back to *bracketing*:
  ``samples`` points over the search interval (a full turn for revolute actuators; the actuator
  limits, or ``search_interval``, for prismatic ones), the first segment in increasing ``t`` where
  ``g`` crosses zero with the requested slope sign, then ``iterations`` steps of safeguarded
  Newton/bisection (a fixed count, so it vmaps). The fallback is only computed when some pose of
  the batch needs it.
- ``"lower"`` (``B`` lower triangular, e.g. P3's mechanism B): the same scalar solve chain by
  chain in order, each with the actuators before it already solved.
- ``"general"``: Newton on all of ``q`` (:func:`pkmlib.solve_forward_position` on the mechanism
  with the roles of ``x`` and ``q`` swapped) from ``starts_per_axis ** n`` starts at the cell
  centres of the search box, in lexicographic order; the first converged start whose
  ``sign(diag B)`` is the branch is taken.

With ``structure=None`` a chainwise mechanism is ``"diagonal"``; for others the sparsity of ``B``
is probed once per mechanism (exact zeros of forward-mode derivatives at a few seeded random
points with the given concrete parameters; ``"general"`` when the parameters are traced).

Revolute actuators are periodic: results lie in ``[q_min, q_min + 2 pi)`` when the lower limit is
finite, else in ``[-pi, pi)``, and are NaN above ``q_max``.

**Forward assembly modes** (:func:`forward_positions`): Newton (:func:`pkmlib.solve_forward_position`)
from ``starts_per_axis ** n_x`` starts at the cell centres of a search box, converged solutions
inside the box (output angles, units ``rad``, wrapped into the box when it spans a full turn)
de-duplicated, and ordered by a reproducible rule: ``det(A) > 0`` first, then lexicographically by
``x``; NaN-padded to ``max_modes`` so it vmaps over a grid of inputs.
"""

from __future__ import annotations

import functools
import itertools
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._mechanism import Mechanism
from ._memory import check_memory
from ._position import solve_forward_position
from ._validation import (
    _is_tracer,
    check_branch,
    check_count,
    check_flag,
    check_mechanism,
    check_tolerance,
    nan_unless_signs,
)

Array = Any

STRUCTURES = ("diagonal", "lower", "general")
#: Relative size of the fit check and of the accepted root residual (of the scale of ``g``).
FIT_RTOL = 1e-8
#: A double root (on the type-1 boundary) missed by this relative rounding still counts as a root.
BOUNDARY_RTOL = 1e-12
#: Slope of the wrong sign accepted at a fitted root (relative to the fit's scale): a double root.
SLOPE_RTOL = 1e-6
#: Largest Newton polishing step, relative to the search interval's half-width (1 rad revolute).
POLISH_MAX = 1e-6


class InverseSolution(NamedTuple):
    """Result of :func:`inverse_positions` with ``residuals=True``."""

    q: Array  #: ``(n, *batch)``, NaN outside the workspace of the branch
    residual: Array  #: ``(*batch,)``: ``max_i |F_i(x, q)|`` (NaN where ``q`` is NaN)


class ForwardPositions(NamedTuple):
    """Every assembly mode found by :func:`forward_positions`, in the stated order."""

    x: Array  #: ``(max_modes, n_x, *batch)``, NaN-padded
    det_A_sign: Array  #: ``(max_modes, *batch)``: the sign of det(A) of each mode (NaN padding)
    residual: Array  #: ``(max_modes, *batch)``: ``max_i |F_i|`` of each mode
    count: Array  #: ``(*batch,)``: modes found (may exceed ``max_modes``; the rest are dropped)


# --------------------------------------------------------------------------- implicit derivatives
@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _implicit(G, z, y, params):
    """``z`` solving ``G(z, y, params) = 0`` (one point), differentiable by the implicit function
    theorem: ``dz = -(dG/dz)^-1 (dG/dy dy + dG/dp dp)`` (P1 eq (2)-(4)); ``z``'s own tangent is
    ignored (the solver's iterations are never differentiated)."""
    return z


@_implicit.defjvp
def _implicit_jvp(G, primals, tangents):
    z, y, params = primals
    _, y_dot, p_dot = tangents
    rhs = jax.jvp(lambda y_, p_: G(z, y_, p_), (y, params), (y_dot, p_dot))[1]
    G_z = jax.jacfwd(lambda z_: G(z_, y, params))(z)
    return z, -jnp.linalg.solve(G_z, rhs)


# --------------------------------------------------------------------------- scalar root finding
def _wrap(t, start):
    """``t`` moved by whole turns into ``[start, start + 2 pi)`` (by ``floor``: cheaper than
    ``jnp.mod``'s remainder)."""
    u = t - start
    u = u - (2.0 * jnp.pi) * jnp.floor(u * (0.5 / jnp.pi))
    return start + jnp.where(u >= 2.0 * jnp.pi, u - 2.0 * jnp.pi, jnp.maximum(u, 0.0))


def _fit_root(g, sigma, revolute: bool, lo, hi):
    """Root of ``g`` with slope sign ``sigma`` from its exact 3-sample fit (see the module
    docstring). Returns ``(t, fit_ok, scale)``; ``t`` is NaN where the fit has no such root and
    ``scale`` is the sum of the fit's coefficient magnitudes (for relative residual tests)."""
    if revolute:
        t0 = jnp.where(jnp.isfinite(lo), lo, -jnp.pi)
        ts = [t0 + k * (2.0 * jnp.pi / 3.0) for k in range(3)]
        # written out term by term (no stack and reduce over the samples): the whole fit is then
        # one elementwise loop over the poses instead of several reductions with stored temporaries
        t_check = t0 + jnp.pi
        # the four samples in one pass, stored: without the barrier XLA splits the rest of the
        # solve into several loops (at its divisions and square roots) that each recompute the
        # samples, and with them every sin and cos of x inside F_i
        g0, g1, g2, g3 = jax.lax.optimization_barrier(tuple(g(t) for t in ts + [t_check]))
        c_0, c_1, c_2 = (jnp.cos(t) for t in ts)  # per mechanism, not per pose
        s_0, s_1, s_2 = (jnp.sin(t) for t in ts)
        c0 = (g0 + g1 + g2) * (1.0 / 3.0)
        a = (2.0 / 3.0) * (g0 * c_0 + g1 * c_1 + g2 * c_2)
        b = (2.0 / 3.0) * (g0 * s_0 + g1 * s_1 + g2 * s_2)
        scale = jnp.abs(a) + jnp.abs(b) + jnp.abs(c0)
        fit_ok = jnp.abs(g3 - (a * jnp.cos(t_check) + b * jnp.sin(t_check) + c0)) <= FIT_RTOL * scale
        R = jnp.hypot(a, b)
        ratio = -c0 / R
        # a double root (|ratio| = 1, on the type-1 boundary) within rounding counts as a root
        ratio = jnp.where(jnp.abs(ratio) <= 1.0 + BOUNDARY_RTOL, jnp.clip(ratio, -1.0, 1.0), jnp.nan)
        t = jnp.arctan2(b, a) - sigma * jnp.arccos(ratio)  # wrapped by the caller, after polishing
        return t, fit_ok & jnp.isfinite(R), scale
    mid, h = 0.5 * (lo + hi), 0.5 * (hi - lo)
    g0, g1, g2, g3 = jax.lax.optimization_barrier((g(lo), g(mid), g(hi), g(mid + 0.5 * h)))  # as above
    C, B, A = g1, 0.5 * (g2 - g0), 0.5 * (g2 + g0) - g1
    scale = jnp.abs(A) + jnp.abs(B) + jnp.abs(C)
    fit_ok = jnp.abs(g3 - (0.25 * A + 0.5 * B + C)) <= FIT_RTOL * scale
    D = B * B - 4.0 * A * C
    sq = jnp.sqrt(jnp.where(D >= -BOUNDARY_RTOL * B * B, jnp.maximum(D, 0.0), jnp.nan))
    same = sigma * B >= 0.0  # -B - sigma sqrt(D) has no cancellation
    u = jnp.where(same, 2.0 * C / (-B - sigma * sq), (-B + sigma * sq) / (2.0 * A))
    return mid + h * u, fit_ok & (h > 0), scale


def _polish(g, t, sigma, width):
    """One Newton step on the true ``g`` from the fitted root ``t``, taken only when it is below
    ``POLISH_MAX`` of ``width`` (near a double root the step is meaningless and the fitted root
    stays); returns ``(t_1, |g(t)|, sigma g'(t))`` (residual and slope of the fitted root)."""
    gt, dg = jax.jvp(g, (t,), (jnp.ones_like(t),))
    step = gt / dg
    t1 = jnp.where(jnp.abs(step) <= POLISH_MAX * width, t - step, t)
    return t1, jnp.abs(gt), sigma * dg


def _bracket_root(g, sigma, revolute: bool, lo, hi, samples: int, iterations: int):
    """First root in increasing ``t`` of slope sign ``sigma`` by sampling and safeguarded
    Newton/bisection (fixed counts). Returns ``(t, ok)``."""
    if revolute:
        t0 = jnp.where(jnp.isfinite(lo), lo, -jnp.pi)
        ts = t0 + jnp.arange(samples + 1, dtype=jnp.float64) * (2.0 * jnp.pi / samples)
    else:
        ts = lo + (hi - lo) * jnp.arange(samples + 1, dtype=jnp.float64) / samples
    gs = jax.vmap(g)(ts)
    s = sigma * gs
    crossing = (s[:-1] <= 0.0) & (s[1:] > 0.0)
    k = jnp.argmax(crossing)
    found = jnp.any(crossing)
    a, b = ts[k], ts[k + 1]

    def step(_, state):
        a, b, t = state
        gt, dg = jax.jvp(g, (t,), (jnp.ones_like(t),))
        left = sigma * gt <= 0.0
        a, b = jnp.where(left, t, a), jnp.where(left, b, t)
        tn = t - gt / dg
        t = jnp.where((tn > a) & (tn < b), tn, 0.5 * (a + b))
        return a, b, t

    a, b, t = jax.lax.fori_loop(0, iterations, step, (a, b, 0.5 * (a + b)))
    scale = jnp.nanmax(jnp.abs(gs))
    ok = found & (jnp.abs(g(t)) <= FIT_RTOL * scale)
    if revolute:
        t = _wrap(t, t0)
    return jnp.where(ok, t, jnp.nan), ok


def _quadratic_root(g, sigma, lo, hi):
    """Root of slope sign ``sigma`` of a ``g`` that is a polynomial of degree <= 2 in ``t`` by its
    operations (:func:`_quadratic_chains`): its Taylor expansion at the middle ``m`` of the search
    interval, ``g(m + s) = c + b s + a s^2`` with ``c = g(m)``, ``b = g'(m)``, ``a = g''(m) / 2``
    (forward-mode derivatives, exact for such a ``g``: no fit check, no fallback), and the
    cancellation-free quadratic formula for the root with ``g' = 2 a s + b = sigma sqrt(b^2 - 4 a c)``.
    NaN where the discriminant is negative (no real root of that sign)."""
    mid = 0.5 * (lo + hi)
    mid = jnp.where(jnp.isfinite(mid), mid, 0.0)
    one = jnp.ones_like(mid)
    (c, b), (_, g2) = jax.jvp(lambda t: jax.jvp(g, (t,), (one,)), (mid,), (one,))
    a = 0.5 * g2
    D = b * b - 4.0 * a * c
    sq = jnp.sqrt(jnp.where(D >= -BOUNDARY_RTOL * b * b, jnp.maximum(D, 0.0), jnp.nan))
    same = sigma * b >= 0.0  # -b - sigma sqrt(D) has no cancellation
    den = jnp.where(same, -b - sigma * sq, 2.0 * a)
    # one division, whose result is used once (an expensive value used twice, or two divisions,
    # would each end XLA's fused loop there: every chain's samples of F_i recomputed in each loop);
    # a zero denominator (a = 0 and the root on the wrong slope, or a constant g) is no root
    return mid + jnp.where(same, 2.0 * c, -b + sigma * sq) / jnp.where(den == 0.0, jnp.nan, den)


def _fit_chain(g_of, sigma, revolute, lo, hi, xs, extra, quadratic=False):
    """The fitted root of one chain at every point (columns of ``xs`` and ``extra``) and where
    it needs the bracketing fallback: ``(t, need)``, each ``(N,)``. ``quadratic``: ``F_i`` is a
    polynomial of degree <= 2 in ``q_i`` (:func:`_quadratic_chains`): solved exactly, never
    needing the fallback."""
    if quadratic:
        t = jax.vmap(lambda x, e: _quadratic_root(g_of(x, e), sigma, lo, hi), in_axes=(1, 1))(xs, extra)
        return t, jnp.zeros(t.shape, dtype=bool)

    def fit_point(x, e):
        g = g_of(x, e)
        t, fit_ok, scale = _fit_root(g, sigma, revolute, lo, hi)
        t, res, slope = _polish(g, t, sigma, 1.0 if revolute else 0.5 * (hi - lo))
        if revolute:
            t = _wrap(t, jnp.where(jnp.isfinite(lo), lo, -jnp.pi))
        # the fit's root has the requested slope by construction; at a double root (type-1
        # boundary) the true slope may round to either sign
        ok = fit_ok & (jnp.isnan(t) | ((slope >= -SLOPE_RTOL * scale) & (res <= FIT_RTOL * scale)))
        ok = ok | ~jnp.all(jnp.isfinite(x))  # a NaN pose stays NaN: nothing to bracket
        return jnp.where(ok, t, jnp.inf)  # one output (+inf: needs the fallback) fuses best

    t = jax.vmap(fit_point, in_axes=(1, 1))(xs, extra)
    return t, jnp.isposinf(t)


def _bracket_chain(g_of, sigma, revolute, lo, hi, xs, extra, samples, iterations):
    """:func:`_bracket_root` of one chain at every point, ``(N,)``."""
    return jax.vmap(
        lambda x, e: _bracket_root(g_of(x, e), sigma, revolute, lo, hi, samples, iterations)[0], in_axes=(1, 1)
    )(xs, extra)


# --------------------------------------------------------------------------- polynomial structure
#: Primitives whose result is a polynomial in t of at most the largest degree of their operands
#: (sums, and moving, selecting or converting values).
_DEGREE_MAX = frozenset(
    {
        "add",
        "add_any",
        "sub",
        "neg",
        "convert_element_type",
        "copy",
        "copy_p",
        "slice",
        "squeeze",
        "reshape",
        "broadcast_in_dim",
        "concatenate",
        "transpose",
        "reduce_sum",
        "expand_dims",
        "real",
        "pad",
        "rev",
        "stop_gradient",
        "optimization_barrier",
    }
)
#: Primitives whose listed operands (by position) must not depend on t; the result has the
#: largest degree of the others (``select_n``'s predicate, indices of a slice or a gather).
_DEGREE_INDEX_OPERANDS = {
    "select_n": lambda n: (0,),
    "gather": lambda n: (1,),
    "scatter": lambda n: (1,),
    "scatter-add": lambda n: (1,),
    "scatter_add": lambda n: (1,),
    "dynamic_slice": lambda n: range(1, n),
    "dynamic_update_slice": lambda n: range(2, n),
}


def _degrees(jaxpr, in_degrees):
    """Upper bounds of the polynomial degree in ``t`` of each output of ``jaxpr`` (``None``: not
    a polynomial in ``t`` as far as its operations show), from those of its inputs."""
    from jax.extend import core as jcore

    deg = dict(zip(jaxpr.invars, in_degrees))
    for v in jaxpr.constvars:
        deg[v] = 0

    def of(v):
        return 0 if isinstance(v, jcore.Literal) else deg[v]

    for e in jaxpr.eqns:
        ins = [of(v) for v in e.invars]
        name = e.primitive.name
        sub = e.params.get("jaxpr", e.params.get("call_jaxpr"))
        if all(d == 0 for d in ins):
            outs = [0] * len(e.outvars)  # nothing here depends on t
        elif sub is not None and name in (
            "pjit",
            "jit",
            "closed_call",
            "core_call",
            "custom_jvp_call",
            "remat",
            "checkpoint",
        ):
            inner = sub.jaxpr if hasattr(sub, "jaxpr") else sub
            outs = _degrees(inner, ins)
        elif any(d is None for d in ins):
            outs = [None] * len(e.outvars)
        elif name in _DEGREE_MAX:
            outs = [max(ins)] * len(e.outvars)
        elif name in _DEGREE_INDEX_OPERANDS:
            fixed = tuple(_DEGREE_INDEX_OPERANDS[name](len(ins)))
            ok = all(ins[k] == 0 for k in fixed)
            rest = [d for k, d in enumerate(ins) if k not in fixed]
            outs = [max(rest) if ok else None] * len(e.outvars)
        elif name in ("mul", "dot_general"):
            outs = [ins[0] + ins[1]]
        elif name == "square":
            outs = [2 * ins[0]]
        elif name == "integer_pow" and e.params["y"] >= 0:
            outs = [e.params["y"] * ins[0]]
        elif name == "div" and ins[1] == 0:
            outs = [ins[0]]
        else:
            outs = [None] * len(e.outvars)
        deg.update(zip(e.outvars, outs))
    return [of(v) for v in jaxpr.outvars]


# --------------------------------------------------------------------------- structure of B
def detect_structure(mech: Mechanism, params: Any) -> str:
    """``"diagonal"``, ``"lower"`` or ``"general"``: the sparsity of ``B = dF/dq``.

    Chainwise mechanisms are diagonal. Otherwise ``B`` is evaluated by forward-mode autodiff at
    three seeded random points (``x`` and ``q`` uniform in ``[0.01, 0.1]``) with the given
    parameters; entries that are exactly zero at every point are structural zeros (a NaN entry
    counts as non-zero). Traced parameters give ``"general"``. Cached per mechanism.
    """
    check_mechanism("mech", mech)
    if mech.chainwise:
        return "diagonal"
    if any(_is_tracer(leaf) for leaf in jax.tree_util.tree_leaves(params)):
        return "general"
    if mech in _STRUCTURE_CACHE:
        return _STRUCTURE_CACHE[mech]
    rng = np.random.default_rng(0)
    nonzero = np.zeros((mech.n_actuators,) * 2, dtype=bool)
    for _ in range(3):
        x = jnp.asarray(rng.uniform(0.01, 0.1, mech.n_outputs))
        q = jnp.asarray(rng.uniform(0.01, 0.1, mech.n_actuators))
        B = np.asarray(jax.jacfwd(lambda q_: mech.constraints(x, q_, params))(q))
        nonzero |= (B != 0.0) | np.isnan(B)
    n = mech.n_actuators
    if not np.any(nonzero & ~np.eye(n, dtype=bool)):
        out = "diagonal"
    elif not np.any(np.triu(nonzero, 1)):
        out = "lower"
    else:
        out = "general"
    _STRUCTURE_CACHE[mech] = out
    return out


_STRUCTURE_CACHE: dict = {}


# --------------------------------------------------------------------------- inverse positions
def _chain_function(mech: Mechanism, i: int, params, structure: str):
    """``g_of(x, q_partial) -> (t -> F_i)`` for chain ``i`` at one point."""
    if mech.chainwise:
        return lambda x, e: lambda t: mech.chain_constraint(i, x, t, params)
    if structure == "diagonal":
        return lambda x, e: lambda t: mech.constraints(x, jnp.zeros(mech.n_actuators).at[i].set(t), params)[i]
    return lambda x, e: lambda t: mech.constraints(x, e.at[i].set(t), params)[i]


def _starts(lo, hi, k: int) -> Array:
    """``k ** n`` points at the cell centres of the box ``[lo, hi]``, lexicographic (first
    coordinate slowest), shape ``(k ** n, n)``."""
    lo, hi = jnp.asarray(lo), jnp.asarray(hi)
    n = lo.shape[0]
    idx = np.array(list(itertools.product(range(k), repeat=n)), dtype=np.float64)
    return lo[None] + (idx + 0.5) / k * (hi - lo)[None]


def _swapped(mech: Mechanism) -> Mechanism:
    return _SWAPPED.setdefault(
        mech,
        Mechanism(
            name=f"{mech.name} (x and q swapped)",
            constraints=lambda q, x, p: mech.constraints(x, q, p),
            actuator_limits=lambda p: (jnp.full(mech.n_outputs, -jnp.inf), jnp.full(mech.n_outputs, jnp.inf)),
            output_names=mech.actuator_names,
            output_units=mech.actuator_units,
            actuator_names=mech.output_names,
            actuator_units=mech.output_units,
        ),
    )


_SWAPPED: dict = {}


def _bounds(mech, params, interval):
    """Actuator limits and the search interval (limits where finite, else ``interval``)."""
    q_min, q_max = (jnp.asarray(v, dtype=jnp.float64) for v in mech.actuator_limits(params))
    return (
        q_min,
        q_max,
        jnp.where(jnp.isfinite(q_min), q_min, interval[:, 0]),
        jnp.where(jnp.isfinite(q_max), q_max, interval[:, 1]),
    )


def _quadratic_chains(mech: Mechanism, structure: str, revolute, n_x: int, params) -> tuple[bool, ...]:
    """For each chain, whether ``F_i`` is a polynomial of degree <= 2 in its own actuator ``q_i``
    for every pose, every other actuator and every parameter value, as its operations show
    (:func:`_degrees` over the jaxpr of ``t -> F_i(x, q_i = t)``: sums, products, integer powers
    and divisions by what does not depend on ``t``). Then the chain's exact quadratic through three
    samples is ``F_i`` itself (:func:`_quadratic_root`). Prismatic actuators only (a revolute
    one enters through ``cos`` and ``sin``: its 3-sample trigonometric fit is checked instead);
    the ``"general"`` method has no chains. Depends only on the shapes of ``params``; cached."""
    leaves, tree = jax.tree_util.tree_flatten(params)
    avals = tuple((np.shape(v), jnp.result_type(v)) for v in leaves)
    key = (mech, structure, revolute, n_x, tree, avals)
    if key in _QUADRATIC_CACHE:
        return _QUADRATIC_CACHE[key]
    n = mech.n_actuators
    out = [False] * n
    if structure != "general":
        f64 = jnp.float64
        specs = [jax.ShapeDtypeStruct(s, d) for s, d in avals]
        for i in range(n):
            if revolute[i]:
                continue

            def g(x, e, t, *leaves_, i=i):
                p_ = jax.tree_util.tree_unflatten(tree, leaves_)
                return _chain_function(mech, i, p_, structure)(x, e)(t)

            closed = jax.make_jaxpr(g)(
                jax.ShapeDtypeStruct((n_x,), f64),
                jax.ShapeDtypeStruct((n,), f64),
                jax.ShapeDtypeStruct((), f64),
                *specs,
            )
            (d,) = _degrees(closed.jaxpr, [0, 0, 1] + [0] * len(specs))
            out[i] = d is not None and d <= 2
    _QUADRATIC_CACHE[key] = tuple(out)
    return _QUADRATIC_CACHE[key]


_QUADRATIC_CACHE: dict = {}


def _chain_step(mech, structure, revolute, i, which, samples, iterations, xs, params, branch, interval, extra):
    """Fit (``which="fit"``: ``(t, need)``) or bracketing (``"bracket"``: ``t``) for chain ``i``."""
    _, _, lo, hi = _bounds(mech, params, interval)
    g_of = _chain_function(mech, i, params, structure)
    if which == "fit":
        quadratic = _quadratic_chains(mech, structure, revolute, xs.shape[0], params)[i]
        return _fit_chain(g_of, branch[i], revolute[i], lo[i], hi[i], xs, extra, quadratic)
    return _bracket_chain(g_of, branch[i], revolute[i], lo[i], hi[i], xs, extra, samples, iterations)


def _fit_all(mech, structure, revolute, xs, params, branch, interval):
    """Every chain's fitted root of a diagonal mechanism, ``(n, N)``; ``+inf`` where a pose needs
    the bracketing fallback."""
    zeros = jnp.zeros((mech.n_actuators, xs.shape[1]))
    out = [
        _chain_step(mech, structure, revolute, i, "fit", 0, 0, xs, params, branch, interval, zeros)
        for i in range(mech.n_actuators)
    ]
    return jnp.stack([t for t, _ in out])


def _fit_finish(mech, structure, revolute, residuals, xs, params, branch, interval):
    """:func:`_fit_all` then :func:`_finish` in one compiled call, for a diagonal mechanism whose
    chains are all quadratic (no pose can need the fallback)."""
    return _finish(mech, residuals, _fit_all(mech, structure, revolute, xs, params, branch, interval), xs, params)


def _general(mech, revolute, iterations, starts_per_axis, xs, params, branch, interval):
    """Multi-start Newton on all of ``q`` (the ``"general"`` method), ``(n, N)``."""
    _, _, lo, hi = _bounds(mech, params, interval)
    rev = jnp.asarray(revolute)
    lo_s = jnp.where(rev, jnp.where(jnp.isfinite(lo), lo, -jnp.pi), lo)
    hi_s = jnp.where(rev, lo_s + 2.0 * jnp.pi, hi)
    starts = _starts(lo_s, hi_s, starts_per_axis)
    swapped = _swapped(mech)

    def point(x1):
        sol = jax.vmap(lambda q0: solve_forward_position(swapped, x1, params, q0, tol=0.0, max_iter=iterations))(starts)
        qs = jnp.where(rev[None], _wrap(sol.x, lo_s[None]), sol.x)
        F = jax.vmap(lambda q_: mech.constraints(x1, q_, params))(qs)
        Bd = jax.vmap(lambda q_: jnp.diag(jax.jacfwd(lambda z: mech.constraints(x1, z, params))(q_)))(qs)
        scale = jnp.max(jnp.abs(jax.vmap(lambda q_: mech.constraints(x1, q_, params))(starts))) + 1e-300
        good = (jnp.max(jnp.abs(F), axis=1) <= FIT_RTOL * scale) & jnp.all(jnp.sign(Bd) == branch[None], axis=1)
        k = jnp.argmax(good)
        return jnp.where(jnp.any(good), qs[k], jnp.nan)

    return jax.vmap(point, in_axes=1, out_axes=1)(xs)


def _finish(mech, residuals, q, x, params):
    """NaN where an actuator leaves its limits, and the residuals ``max_i |F_i|`` (NaN unless
    ``residuals``: not asked for, not computed)."""
    q_min, q_max = (jnp.asarray(v, dtype=jnp.float64) for v in mech.actuator_limits(params))
    # row by row (no reduction over the stacked q): under a caller's jit each row is then an
    # elementwise function of the poses that XLA can fuse into whatever uses it, the whole map one
    # loop; a reduction over the stacked rows stores q first, and XLA's CPU backend then computes
    # each chain's root in a loop of its own, every value the chains share (the sines and cosines
    # of the pose) once per chain
    rows = [q[i] for i in range(q.shape[0])]
    inside = functools.reduce(jnp.logical_and, [(r >= q_min[i]) & (r <= q_max[i]) for i, r in enumerate(rows)])
    q = jnp.stack([jnp.where(inside, r, jnp.nan) for r in rows])
    if not residuals:
        return q, jnp.full(q.shape[1:], jnp.nan)
    F = jax.vmap(lambda qp, xp: mech.constraints(xp, qp, params), in_axes=(1, 1), out_axes=1)(q, x)
    # NaN stated explicitly: fused into the solve, XLA's vectorised max may drop a NaN operand
    return q, jnp.where(jnp.any(jnp.isnan(F), axis=0), jnp.nan, jnp.max(jnp.abs(F), axis=0))


def _solve_traced(mech, structure, revolute, samples, iterations, starts_per_axis, x, params, branch, interval):
    """The whole solve in one traced computation (inside a caller's ``jit``/``grad``): the
    bracketing fallback is computed at every point and selected where needed."""
    xs, ps = jax.lax.stop_gradient(x), jax.lax.stop_gradient(params)
    if structure == "general":
        return _general(mech, revolute, iterations, starts_per_axis, xs, ps, branch, interval)
    quadratic = _quadratic_chains(mech, structure, revolute, xs.shape[0], ps)
    q, ts = jnp.zeros((mech.n_actuators, xs.shape[1])), []
    for i in range(mech.n_actuators):
        t, need = _chain_step(mech, structure, revolute, i, "fit", 0, 0, xs, ps, branch, interval, q)
        if not quadratic[i]:
            tb = _chain_step(mech, structure, revolute, i, "bracket", samples, iterations, xs, ps, branch, interval, q)
            t = jnp.where(need, tb, t)
        q = q.at[i].set(t) if structure == "lower" else q
        ts.append(t)
    return q if structure == "lower" else jnp.stack(ts)


@functools.lru_cache(maxsize=256)
def _jitted(fn, *static):
    """``fn`` with its leading static arguments bound, compiled once (cached), as a
    :class:`_Hoisted` pair of compiled calls."""
    return _Hoisted(functools.partial(fn, *static))


#: Values of at most this many elements computed without the poses are hoisted (:class:`_Hoisted`).
HOIST_MAX_SIZE = 256


class _Hoisted:
    """``fn(z, *rest)`` (``z`` the per-pose array) as two compiled calls: first every operation
    whose inputs do not depend on ``z`` and whose result is small (the parameters' derived values:
    joint placements, sines and cosines of fixed angles, the search interval), then the per-pose
    rest, with those values as inputs.

    In one compiled call XLA fuses such scalar operations into the loop over the poses and
    evaluates them again at every pose: 2-3x the time of the fit of a loaded description (P2,
    P4, the Delta; ``benchmarks/mechanisms.py``). Results are those of ``fn`` up to rounding
    (XLA may order a sum differently). One split per shape and type of the arguments."""

    def __init__(self, fn):
        self.fn = fn
        self._splits: dict = {}

    def __call__(self, z, *rest):
        leaves, tree = jax.tree_util.tree_flatten((z,) + rest)
        key = (tree, tuple((np.shape(v), jnp.result_type(v)) for v in leaves))
        if key not in self._splits:
            self._splits[key] = self._split(leaves, tree)
        known, per_pose, out_tree = self._splits[key]
        return jax.tree_util.tree_unflatten(out_tree, per_pose(*leaves, *known(*leaves)))

    def _split(self, leaves, tree):
        from jax.extend import core as jcore

        def flat(*v):
            z, *rest = jax.tree_util.tree_unflatten(tree, v)
            return self.fn(z, *rest)

        closed, out_shape = jax.make_jaxpr(flat, return_shape=True)(*leaves)
        jp = closed.jaxpr
        big = lambda v: int(np.prod(v.aval.shape)) > HOIST_MAX_SIZE  # noqa: E731
        unknown = {jp.invars[0]} | {v for v in jp.invars if big(v)}
        first, second = [], []
        for e in jp.eqns:
            if e.effects or any(big(v) for v in e.outvars) or any(v in unknown for v in e.invars if _is_var(v)):
                second.append(e)
                unknown.update(e.outvars)
            else:
                first.append(e)
        needed, inputs = {}, set(jp.invars)
        for v in [v for e in second for v in e.invars] + list(jp.outvars):
            if _is_var(v) and v not in unknown and v not in inputs:
                needed.setdefault(v, None)
        needed = list(needed)  # the hoisted values, in a fixed order
        known = jcore.Jaxpr(jp.constvars, jp.invars, needed, first, jcore.no_effects, jp.debug_info)
        rest = jcore.Jaxpr([], jp.invars + needed, jp.outvars, second, jp.effects, jp.debug_info)
        return (
            jax.jit(jcore.jaxpr_as_fun(jcore.ClosedJaxpr(known, closed.consts))),
            jax.jit(jcore.jaxpr_as_fun(jcore.ClosedJaxpr(rest, []))),
            jax.tree_util.tree_structure(out_shape),
        )


def _is_var(v) -> bool:
    from jax.extend import core as jcore

    return isinstance(v, jcore.Var)


def _bucket(k: int) -> int:
    """Padded size for ``k`` fallback points (powers of two from 256: few compilations)."""
    return max(256, 1 << (k - 1).bit_length())


def _solve_concrete(mech, structure, revolute, samples, iterations, starts_per_axis, x, params, branch, interval):
    """The solve with concrete inputs: compiled fits, then the bracketing fallback compiled for
    (and run on) only the poses that need it."""
    n = mech.n_actuators
    if structure == "general":
        return _jitted(_general, mech, revolute, iterations, starts_per_axis)(x, params, branch, interval)
    # the glue between the compiled calls in NumPy (the same values: rows set and poses picked),
    # not in eager jnp operations, each of them a program compiled per shape (one per count of
    # fallback poses for the scatter)
    x_np = None  # the poses on the host, fetched only if some pose needs the fallback
    if structure == "diagonal":
        q = np.array(_jitted(_fit_all, mech, structure, revolute)(x, params, branch, interval))
        need = np.isposinf(q)
        extra = np.zeros_like(q)
    else:
        q = np.zeros((n, x.shape[1]))
    for i in range(n):
        if structure == "lower":
            t = np.asarray(
                _jitted(_chain_step, mech, structure, revolute, i, "fit", 0, 0)(x, params, branch, interval, q)[0]
            )
            need_i = np.isposinf(t)
            extra = q.copy()
            q[i] = np.where(need_i, np.nan, t)
        else:
            need_i = need[i]
        if structure == "diagonal" and need_i.any():
            q[i] = np.where(np.isposinf(q[i]), np.nan, q[i])
        if need_i.any():
            idx = np.flatnonzero(need_i)
            pad = np.full(_bucket(idx.size), idx[0])
            pad[: idx.size] = idx
            x_np = np.asarray(x) if x_np is None else x_np
            tb = _jitted(_chain_step, mech, structure, revolute, i, "bracket", samples, iterations)(
                x_np[:, pad], params, branch, interval, extra[:, pad]
            )
            q[i, idx] = np.asarray(tb)[: idx.size]
    return jax.device_put(q)


def _any_tracer(*trees) -> bool:
    return any(_is_tracer(v) for v in jax.tree_util.tree_leaves(trees))


def _on_device(v):
    """A NumPy array as a JAX array by ``jax.device_put`` (``jnp.asarray`` of a NumPy array compiles a
    program per shape, jaxlib 0.10); a traced value unchanged."""
    return v if _is_tracer(v) else jax.device_put(v)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _solve(static, x, params, branch, interval):
    """``(q, residual)`` at the ``(n_x, N)`` poses ``x`` (the residual NaN unless ``static[-1]``). Concrete inputs take the compiled path
    (:func:`_solve_concrete`); inside a caller's ``jit`` the traced one. Differentiated by the
    implicit function theorem (:func:`_solve_jvp`), never through the iterations; under
    ``jax.jvp``/``grad``/``jacfwd`` outside ``jit`` the primal solve stays on the compiled path."""
    mech, structure, revolute = static[:3]
    solver, residuals = static[:-1], static[-1]
    if _any_tracer(x, params, branch, interval):
        q = _solve_traced(*solver, x, params, branch, interval)
    else:
        if structure == "diagonal" and all(_quadratic_chains(mech, structure, revolute, x.shape[0], params)):
            # no pose can need the fallback: the solve and the limits in one compiled call
            return _jitted(_fit_finish, mech, structure, revolute, residuals)(x, params, branch, interval)
        q = _solve_concrete(*solver, x, params, branch, interval)
    return _jitted(_finish, mech, residuals)(q, x, params)


@_solve.defjvp
def _solve_jvp(static, primals, tangents):
    """``dq = -B^-1 (A dx + F_p dp)`` per pose (P1 eq (2)-(4)); the residual's tangent is zero."""
    x, params, branch, interval = primals
    x_dot, p_dot = tangents[0], tangents[1]
    q, res = _solve(static, x, params, branch, interval)
    q_dot = _jitted(_ift_tangent, static[0])(q, x, params, x_dot, p_dot)
    return (q, res), (q_dot, jnp.zeros_like(res))


def _ift_tangent(mech, q, x, params, x_dot, p_dot):
    """``-B^-1 (A x_dot + F_p p_dot)`` at each ``(n, N)`` solution (compiled: one call per
    tangent instead of many small eager operations)."""

    def point(q1, x1, xd1):
        rhs = jax.jvp(lambda x_, p_: mech.constraints(x_, q1, p_), (x1, params), (xd1, p_dot))[1]
        B = jax.jacfwd(lambda z: mech.constraints(x1, z, params))(q1)
        return -jnp.linalg.solve(B, rhs)

    return jax.vmap(point, in_axes=(1, 1, 1), out_axes=1)(q, x, x_dot)


def inverse_positions(
    mech: Mechanism,
    x: Array,
    params: Any,
    branch: Any = None,
    *,
    residuals: bool = False,
    search_interval: Any = None,
    structure: str | None = None,
    samples: int = 64,
    iterations: int = 40,
    starts_per_axis: int = 4,
):
    """Inverse position ``q(x)`` on ``branch`` by solving ``F(x, q) = 0`` numerically (P1 eq (1),
    P2 eq (1)); the method and the branch rule are in :mod:`pkmlib._positions`.

    Args:
        mech: any :class:`pkmlib.Mechanism` (a closed form is not needed and not used).
        x: poses, ``(n_x,)`` or ``(n_x, *batch)`` (any grid shape).
        params: the mechanism's parameters (a pytree; a run-time argument: the solver is compiled
            once per mechanism and method).
        branch: one sign per actuator, the sign of ``dF_i/dq_i`` at the solution; default: the
            mechanism's ``default_branch`` when that is such a rule (mechanisms without a closed
            form, and chainwise ones, whose closed-form signs are these: P1, P2, P4); otherwise
            it must be given (P3's closed forms use other signs).
        residuals: also return ``max_i |F_i(x, q)|`` per pose (an :class:`InverseSolution`).
        search_interval: ``(n, 2)`` bracketing interval per actuator, used where the actuator
            limits are infinite (prismatic actuators without limits need it).
        structure: ``"diagonal"``, ``"lower"``, ``"general"`` or None (detected: see
            :func:`detect_structure`).
        samples, iterations: bracketing samples and safeguarded Newton/bisection (or Newton)
            iterations of the fallback and general methods.
        starts_per_axis: Newton starts per actuator for the ``"general"`` method.

    Returns:
        ``q`` of shape ``(n, *batch)`` (NaN outside the branch's workspace or the actuator
        limits), or an :class:`InverseSolution` with ``residuals=True``. Differentiable in ``x``
        and ``params`` by the implicit function theorem (``dq/dx = J^-1``).
    """
    check_mechanism("mech", mech)
    residuals = check_flag("residuals", residuals)
    n = mech.n_actuators
    if branch is None:
        if (
            mech.default_branch is None
            or len(mech.default_branch) != n
            or not (mech.inverse_position is None or mech.chainwise)
        ):
            raise ValueError(
                f"{mech.name}: give branch, {n} signs (+1 or -1), the sign of dF_i/dq_i at the "
                f"solution for each actuator ({', '.join(mech.actuator_names)})"
            )
        branch = mech.default_branch
    branch = check_branch(branch, n)
    b = jnp.asarray(branch, dtype=jnp.float64) if _any_tracer(branch) else np.asarray(branch, dtype=np.float64)
    if structure is None:
        structure = detect_structure(mech, params)
    if structure not in STRUCTURES:
        raise ValueError(f"structure must be one of {', '.join(STRUCTURES)} or None, got {structure!r}")
    samples = check_count("samples", samples, minimum=3)
    iterations = check_count("iterations", iterations, minimum=1)
    starts_per_axis = check_count("starts_per_axis", starts_per_axis, minimum=1)
    revolute = tuple(u == "rad" for u in mech.actuator_units)
    if search_interval is None:
        interval = np.full((n, 2), np.nan)
    else:
        interval = np.asarray(search_interval, dtype=np.float64)
        if interval.shape != (n, 2) or not np.all(np.isfinite(interval)) or np.any(interval[:, 0] >= interval[:, 1]):
            raise ValueError(f"search_interval must be {n} finite (lo, hi) pairs with lo < hi, got {search_interval!r}")
    leaves = jax.tree_util.tree_leaves(params)
    limits = None
    if not any(_is_tracer(v) for v in leaves):
        limits = mech.actuator_limits(params)
        if any(_is_tracer(v) for v in jax.tree_util.tree_leaves(limits)):
            limits = None  # limits built by jnp inside a jit trace: not checked here (NaN outside them)
    if limits is not None:
        q_min, q_max = (np.asarray(v, dtype=np.float64) for v in limits)
        for i in range(n):
            if (
                not revolute[i]
                and not (np.isfinite(q_min[i]) or np.isfinite(interval[i, 0]))
                or not revolute[i]
                and not (np.isfinite(q_max[i]) or np.isfinite(interval[i, 1]))
            ):
                raise ValueError(
                    f"{mech.name}: actuator {mech.actuator_names[i]} ({mech.actuator_units[i]}) is not "
                    "revolute and has infinite limits: give search_interval"
                )
    # concrete poses stay NumPy until the solve (no eager program per shape for the conversions)
    x = jnp.asarray(x, dtype=jnp.float64) if _any_tracer(x) else np.asarray(x, dtype=np.float64)
    if x.ndim == 0 or x.shape[0] != mech.n_outputs:
        raise ValueError(
            f"x must have shape ({mech.n_outputs}, *batch) ({', '.join(mech.output_names)}), got {x.shape}"
        )
    batch = x.shape[1:]
    n_in = max(1, int(np.prod(batch)))
    if structure == "general":  # per pose: the starts' solutions, residuals and Jacobian diagonals
        n_starts = float(starts_per_axis) ** n
        check_memory(
            8.0 * n_in * n_starts * n * (n + 4),
            what=f"inverse positions from {n_starts:.3g} starts ({starts_per_axis} per axis) at {n_in:.3g} poses",
            parameter="starts_per_axis",
        )
    else:  # per pose and chain: the bracketing samples of F_i (fallback where the fit fails)
        check_memory(
            8.0 * n_in * n * (float(samples) + 1.0) * 3.0,
            what=f"inverse positions bracketed by {samples} samples at {n_in:.3g} poses",
            parameter="samples",
        )
    flat = x.reshape(mech.n_outputs, -1)
    static = (mech, structure, revolute, samples, iterations, starts_per_axis, bool(residuals))
    q, res = _solve(static, _on_device(flat), params, _on_device(b), jax.device_put(interval))
    # row by row, then stacked: under a caller's jit, q[i] of the result is then the solve's own
    # row (XLA folds a slice of a concatenation, not of a reshaped one), so a map that uses q row
    # by row (pk.inverse_jacobian_rows) fuses with the solve into one loop over the poses instead
    # of storing q and computing each chain's root in a loop of its own (benchmarks/mechanisms.py)
    if _any_tracer(q, res):
        q = jnp.stack([q[i].reshape(batch) for i in range(n)])
        q, res = nan_unless_signs(q, branch), res.reshape(batch)
    else:  # concrete (and branch checked): reshaped in NumPy, not by eager programs of each shape
        q, res = jax.device_put(np.asarray(q).reshape((n, *batch))), jax.device_put(np.asarray(res).reshape(batch))
    return InverseSolution(q, res) if residuals else q


# --------------------------------------------------------------------------- forward positions
def _forward_point(mech, starts_per_axis, max_modes, iterations, q1, params, lo, hi, tol, dedup_tol):
    """Every assembly mode at one input ``q1`` (see the module docstring)."""
    ps = jax.lax.stop_gradient(params)
    qs = jax.lax.stop_gradient(q1)
    starts = _starts(lo, hi, starts_per_axis)
    sol = jax.vmap(lambda x0: solve_forward_position(mech, qs, ps, x0, tol=0.0, max_iter=iterations))(starts)
    periodic = jnp.asarray([u == "rad" for u in mech.output_units]) & (hi - lo >= 2.0 * jnp.pi - 1e-12)
    xs = jnp.where(periodic[None], _wrap(sol.x, lo[None]), sol.x)
    F = jax.vmap(lambda x_: mech.constraints(x_, qs, ps))(xs)
    res = jnp.max(jnp.abs(F), axis=1)
    conv = (res <= tol) & jnp.all((xs >= lo[None]) & (xs <= hi[None]), axis=1)
    d = jnp.abs(xs[:, None, :] - xs[None, :, :])
    d = jnp.where(periodic[None, None], jnp.minimum(d, 2.0 * jnp.pi - d), d)
    same = jnp.all(d <= dedup_tol * (hi - lo)[None, None], axis=2)
    S = xs.shape[0]
    earlier = jnp.tril(jnp.ones((S, S), dtype=bool), -1)
    dup = jnp.any(same & earlier & conv[None, :], axis=1)
    keep = conv & ~dup
    A = jax.vmap(lambda x_: jax.jacfwd(lambda z: mech.constraints(z, qs, ps))(x_))(xs)
    sdet = jnp.sign(jnp.linalg.det(A))
    keys = [xs[:, j] for j in range(xs.shape[1] - 1, -1, -1)] + [-sdet, (~keep).astype(jnp.float64)]
    order = jnp.lexsort(tuple(keys))[:max_modes]
    kept = keep[order]
    x_out = jnp.where(kept[:, None], xs[order], jnp.nan)
    G = lambda x_, q_, p_: mech.constraints(x_, q_, p_)  # noqa: E731
    x_out = jax.vmap(lambda xo: _implicit(G, xo, q1, params))(x_out)
    s_out, r_out = jnp.where(kept, sdet[order], jnp.nan), jnp.where(kept, res[order], jnp.nan)
    pad = max_modes - S  # fewer starts than slots: the slots no start can fill are NaN
    if pad > 0:
        x_out = jnp.concatenate([x_out, jnp.full((pad, x_out.shape[1]), jnp.nan)])
        s_out, r_out = (jnp.concatenate([v, jnp.full((pad,), jnp.nan)]) for v in (s_out, r_out))
    return (x_out, s_out, r_out, jnp.sum(keep))


@functools.lru_cache(maxsize=64)
def _compiled_forward(mech, starts_per_axis, max_modes, iterations):
    point = functools.partial(_forward_point, mech, starts_per_axis, max_modes, iterations)
    return jax.jit(jax.vmap(point, in_axes=(1, None, None, None, None, None), out_axes=(2, 1, 1, 0)))


def forward_positions(
    mech: Mechanism,
    q: Array,
    params: Any,
    box: Any,
    *,
    starts_per_axis: int = 4,
    max_modes: int = 8,
    iterations: int = 30,
    tol: float = 1e-9,
    dedup_tol: float = 1e-6,
) -> ForwardPositions:
    """Every assembly mode ``x`` with ``F(x, q) = 0`` inside ``box`` at each input ``q``.

    Method: Newton (:func:`pkmlib.solve_forward_position`, ``iterations`` steps at most) from the
    ``starts_per_axis ** n_x`` cell centres of ``box`` (lexicographic, first coordinate slowest);
    a start counts when ``max |F| <= tol`` (in F's units) and its solution lies in the box (output
    angles in rad wrapped into it when it spans a full turn); solutions closer than
    ``dedup_tol * (box width)`` in every coordinate are one mode. Modes are ordered by a stated,
    reproducible rule: ``det(A) > 0`` first (then ``det(A) < 0``, then 0), and within a sign
    lexicographically by ``x``. The starts sample the box, they do not prove that every mode
    is found: raise ``starts_per_axis`` until ``count`` stops changing.

    Args:
        q: inputs, ``(n,)`` or ``(n, *batch)``.
        box: ``(x_lo, x_hi)``, each ``n_x`` finite values with ``x_lo < x_hi``.
        max_modes: the fixed number of slots (NaN-padded) so that the result vmaps over a grid;
            any whole number >= 1 (more than ``starts_per_axis ** n_x``, the most modes the starts
            can find, leaves the extra slots NaN).

    Returns:
        :class:`ForwardPositions` (``x`` of shape ``(max_modes, n_x, *batch)``), differentiable
        in ``q`` and ``params`` by the implicit function theorem (``dx/dq = J``).
    """
    check_mechanism("mech", mech)
    starts_per_axis = check_count("starts_per_axis", starts_per_axis, minimum=1)
    max_modes = check_count("max_modes", max_modes, minimum=1)
    iterations = check_count("iterations", iterations, minimum=1)
    tol = check_tolerance("tol", tol)
    dedup_tol = check_tolerance("dedup_tol", dedup_tol)
    try:
        lo, hi = (np.asarray(v, dtype=np.float64) for v in box)
    except (TypeError, ValueError):
        raise ValueError(f"box must be (x_lo, x_hi), each {mech.n_outputs} numbers, got {box!r}") from None
    if (
        lo.shape != (mech.n_outputs,)
        or hi.shape != lo.shape
        or not np.all(np.isfinite(lo) & np.isfinite(hi))
        or np.any(lo >= hi)
    ):
        raise ValueError(
            f"box must be (x_lo, x_hi), each {mech.n_outputs} finite numbers "
            f"({', '.join(mech.output_names)}) with x_lo < x_hi, got {box!r}"
        )
    q = jnp.asarray(q, dtype=jnp.float64)
    if q.ndim == 0 or q.shape[0] != mech.n_actuators:
        raise ValueError(
            f"q must have shape ({mech.n_actuators}, *batch) ({', '.join(mech.actuator_names)}), got {q.shape}"
        )
    batch = q.shape[1:]
    # per input: the starts' solutions and constraint Jacobians and the (starts x starts) distances
    n_starts, n_x, n_in = float(starts_per_axis) ** mech.n_outputs, mech.n_outputs, max(1, int(np.prod(batch)))
    check_memory(
        8.0 * n_in * n_starts * (n_starts * (n_x + 2) + n_x * (n_x + 4)),
        what=f"forward positions from {n_starts:.3g} starts ({starts_per_axis} per axis) at {n_in:.3g} inputs",
        parameter="starts_per_axis",
    )
    fn = _compiled_forward(mech, starts_per_axis, max_modes, iterations)
    x, s, r, c = fn(q.reshape(mech.n_actuators, -1), params, jnp.asarray(lo), jnp.asarray(hi), tol, dedup_tol)
    return ForwardPositions(
        x.reshape((max_modes, mech.n_outputs) + batch),
        s.reshape((max_modes,) + batch),
        r.reshape((max_modes,) + batch),
        c.reshape(batch),
    )
