"""Inverse dynamics of a mechanism whose rigid bodies are explicit functions of the actuators.

When the forward position solution is explicit (P3 section 2.1: the 2T1R mechanisms A and B have
symbolic FK), every body's centre of mass ``c_k(q)`` and orientation ``R_k(q)`` is a function of the
actuated coordinates ``q``, which are then independent generalized coordinates. Two independent ways
to get the actuator forces ``tau`` along a prescribed motion ``q(t)``:

* :func:`inverse_dynamics_virtual_work`: the principle of virtual work with d'Alembert's inertia
  forces (P3 eq (19)-(23), (30)-(31)): ``tau = sum_k J_vk^T (m_k a_k - m_k g - f_k)
  + J_wk^T (I_k eps_k + w_k x I_k w_k - t_k)`` with ``J_vk = dc_k/dq``, ``J_wk = dw_k/dq'``.
* :func:`inverse_dynamics_lagrange`: Lagrange's equations ``tau = d/dt(dT/dq') - dT/dq + dV/dq``
  with the kinetic energy ``T = sum 1/2 m_k |c_k'|^2 + 1/2 w_k . I_k w_k`` and the potential
  ``V = -sum (m_k g + f_k) . c_k`` (constant external forces), all derivatives by JAX.

Angular velocities come from ``[w]_x = R' R^T``; world inertia tensors are ``R I_body R^T``.
Units are the caller's, as long as they are consistent: in SI (m, kg, kg m^2, m/s^2, N) the
forces come out in N (for prismatic actuators); in mm, kg, kg mm^2, mm/s^2 and kg mm/s^2 they
come out in kg mm/s^2 = mN (what :func:`pkmlib.mechanisms.two_t_one_r.actuator_forces` uses and
converts). Time derivatives are JAX forward-mode derivatives of ``q(t)`` (no finite differences);
``vmap`` over the time samples.

Compiled once per model: ``pose`` and ``trajectory`` are passed to a module-level ``jax.jit`` as
pytrees. Give them as :class:`jax.tree_util.Partial` of a module-level function with the values
that vary (parameters, branch, amplitudes) as its arguments, e.g. ``Partial(body_poses, params,
branch)``: the compiled function is then reused for any values of those arguments. A plain
function is wrapped as ``Partial(f)`` and reused as long as the same function object is passed;
a fresh lambda on every call compiles every time. The time samples are padded (with the last
sample) to the next power of two, at least 16, so calls with other numbers of samples reuse the
compiled function too.
"""

from __future__ import annotations

import functools
from typing import Any, Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.tree_util import Partial

from . import _config  # noqa: F401  (float64)
from ._validation import check_array, concrete

Array = Any


def _vee(W: Array) -> Array:
    """``w`` from a skew matrix ``[w]_x`` (last two axes)."""
    return jnp.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=-1)


def _angular(Rd: Array, R: Array) -> Array:
    """``vee(Rd R^T)`` over the last two axes (broadcast over the others): the angular velocity for
    ``Rd = R'``, and the same map applied to any derivative of ``R``."""
    return _vee(jnp.einsum("...ij,...lj->...il", Rd, R))


def body_velocities(pose: Callable, q: Array, qd: Array) -> tuple[Array, Array, Array, Array]:
    """``(c, R, v, w)``: centres ``(K, 3)``, orientations ``(K, 3, 3)``, velocities and angular
    velocities ``(K, 3)`` of the bodies for ``pose(q) -> (c, R)`` at ``(q, q')``."""
    (c, R), (v, Rd) = jax.jvp(pose, (q,), (qd,))
    return c, R, v, _angular(Rd, R)


def kinetic_energy(pose: Callable, masses: Array, inertias: Array, q: Array, qd: Array) -> Array:
    """``T = sum_k 1/2 m_k |v_k|^2 + 1/2 w_k . (R_k I_k R_k^T) w_k`` (``inertias``: ``(K, 3, 3)`` body frame)."""
    _, R, v, w = body_velocities(pose, q, qd)
    Iw = jnp.einsum("kij,kjl,kml,km->ki", R, inertias, R, w)
    return 0.5 * jnp.sum(masses * jnp.sum(v * v, axis=-1)) + 0.5 * jnp.sum(w * Iw)


def potential_energy(pose: Callable, masses: Array, gravity: Array, forces: Array, q: Array) -> Array:
    """``V = -sum_k (m_k g + f_k) . c_k``: gravity and constant external forces ``f_k`` at the centres."""
    c, _ = pose(q)
    return -jnp.sum((masses[:, None] * gravity[None, :] + forces) * c)


def _time_derivatives(trajectory: Callable, t: Array) -> tuple[Array, Array, Array]:
    one = jnp.ones_like(t)
    q_dot = lambda s: jax.jvp(trajectory, (s,), (jnp.ones_like(s),))[1]  # noqa: E731
    q, qd = jax.jvp(trajectory, (t,), (one,))
    return q, qd, jax.jvp(q_dot, (t,), (one,))[1]


def state_trajectory(q: Array, qd: Array, qdd: Array) -> Partial:
    """The trajectory ``q + qd t + qdd t^2 / 2`` as a :class:`jax.tree_util.Partial`: evaluated at
    ``t = 0`` it has position ``q``, velocity ``qd`` and acceleration ``qdd``, so the inverse
    dynamics at ``t = [0]`` are the actuator forces at that state (and differentiable in it)."""
    return Partial(
        _quadratic,
        q=jnp.asarray(q, dtype=jnp.float64),
        qd=jnp.asarray(qd, dtype=jnp.float64),
        qdd=jnp.asarray(qdd, dtype=jnp.float64),
    )


def _quadratic(t: Array, q: Array, qd: Array, qdd: Array) -> Array:
    return q + qd * t + 0.5 * qdd * t * t


def _as_partial(f: Any, name: str) -> Partial:
    if isinstance(f, Partial):
        return f
    if not callable(f):
        raise ValueError(f"{name} must be a function or a jax.tree_util.Partial, got {f!r}")
    return Partial(f)


def _checked_model(masses, inertias, gravity, forces, t):
    """Shapes: masses (K,), inertias (K, 3, 3), gravity (3,), forces (K, 3), t (N,) with N >= 1.

    Values: masses finite and >= 0 (a massless body allowed); each inertia tensor finite, symmetric
    and positive semidefinite (zero for a body that does not rotate); gravity, forces and t
    finite. ``ValueError`` naming the argument (and the body) otherwise. For masses and inertias
    traced by ``jit``/``vmap`` (e.g. differentiated) it returns ``checks``, ``(bad, message)``
    pairs that :func:`_run` applies to the result with ``equinox.error_if`` (on the result, so the
    check runs even where the forces do not depend on a value), raised when the compiled call runs."""
    masses = check_array("masses", masses, ndim=1, what="body masses (K,)")
    K = masses.shape[0]
    inertias = check_array("inertias", inertias, (K, 3, 3), ndim=3, what=f"body-frame inertia tensors of {K} bodies")
    gravity = check_array("gravity", gravity, (3,), ndim=1)
    forces = check_array("forces", forces, (K, 3), ndim=2, what=f"a constant force on each of {K} bodies")
    t = t if isinstance(t, jax.core.Tracer) else np.asarray(check_array("t", t), dtype=np.float64)
    if t.ndim != 1 or t.shape[0] == 0:
        raise ValueError(f"t must be a non-empty 1-D array of times, got shape {t.shape}")
    for name, v in (("gravity", gravity), ("forces", forces), ("t", t)):
        a = concrete(v)
        if a is not None and not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite, got {a.tolist()}")
    checks = []  # traced values: (bad, message) for equinox.error_if on the result (not dead code)
    m = concrete(masses)
    if m is not None:
        bad = np.flatnonzero(~(np.isfinite(m) & (m >= 0)))
        if bad.size:
            raise ValueError(f"masses must be finite and >= 0 (one per body), got {m.tolist()} (body {int(bad[0])})")
    else:
        checks.append((~jnp.all(jnp.isfinite(masses) & (masses >= 0)), _MASSES_ACCEPTED))
    inertia = concrete(inertias)
    if inertia is not None:
        ok = _inertias_ok(inertia, np)
        if not ok.all():
            k = int(np.flatnonzero(~ok)[0])
            raise ValueError(f"inertias: {_INERTIA_ACCEPTED}; body {k} has {inertia[k].tolist()}")
    else:
        checks.append((~jnp.all(_inertias_ok(inertias)), f"inertias: {_INERTIA_ACCEPTED}"))
    return masses, inertias, gravity, forces, t, checks


_MASSES_ACCEPTED = "masses must be finite and >= 0 (one per body)"
_INERTIA_ACCEPTED = (
    "each inertia tensor must be finite, symmetric and positive semidefinite (kg m^2 or the model's unit)"
)


def _inertias_ok(inertias: Array, xp: Any = jnp) -> Array:
    """``(K,)``: each ``(3, 3)`` tensor finite, symmetric (to 1e-12 of its largest entry) and
    positive semidefinite (every principal minor >= -1e-12 of the same scale: Sylvester's
    criterion for semidefinite matrices, in closed form). ``xp``: ``numpy`` for values known now
    (inside ``jit`` even ``jnp`` operations on constants are traced), ``jax.numpy`` for traced."""
    I = inertias  # noqa: E741
    scale = xp.max(xp.abs(xp.where(xp.isfinite(I), I, 0.0)), axis=(1, 2))
    tol = 1e-12 * scale
    finite = xp.all(xp.isfinite(I), axis=(1, 2))
    symmetric = xp.all(xp.abs(I - xp.swapaxes(I, 1, 2)) <= tol[:, None, None], axis=(1, 2))
    d = xp.stack([I[:, 0, 0], I[:, 1, 1], I[:, 2, 2]], axis=1)
    minors2 = xp.stack([d[:, i] * d[:, j] - I[:, i, j] ** 2 for i, j in ((0, 1), (0, 2), (1, 2))], axis=1)
    det = (
        I[:, 0, 0] * (I[:, 1, 1] * I[:, 2, 2] - I[:, 1, 2] * I[:, 2, 1])
        - I[:, 0, 1] * (I[:, 1, 0] * I[:, 2, 2] - I[:, 1, 2] * I[:, 2, 0])
        + I[:, 0, 2] * (I[:, 1, 0] * I[:, 2, 1] - I[:, 1, 1] * I[:, 2, 0])
    )
    semidefinite = (
        xp.all(d >= -tol[:, None], axis=1)
        & xp.all(minors2 >= -1e-12 * scale[:, None] ** 2, axis=1)
        & (det >= -1e-12 * scale**3)
    )
    return finite & symmetric & semidefinite


def _padded(t: Array) -> Array:
    """``t`` padded with its last sample to the next power of two (at least 16) samples (on the
    host when ``t`` is concrete, so a new length costs no compilation)."""
    n = t.shape[0]
    size = max(16, 1 << (n - 1).bit_length())
    if isinstance(t, jax.core.Tracer):
        return jnp.concatenate([t, jnp.broadcast_to(t[-1], (size - n,))])
    t = np.asarray(t)
    return np.concatenate([t, np.full(size - n, t[-1])])


def _virtual_work_at(pose, masses, inertias, gravity, forces, trajectory, s):
    """The virtual-work forces at the time ``s`` (P3 eq (19)-(23), (30)-(31)) from two derivatives of
    ``pose`` in the joint space: its Jacobian ``(dc/dq, dR/dq)`` (three tangents) and its second
    derivative along ``q'`` (a JVP of a JVP), so that ``a = J_v q'' + d2c[q', q']``,
    ``R'' = dR[q''] + d2R[q', q']``, ``w = vee(R' R^T)``, ``eps = vee(R'' R^T + R' R'^T)`` (the time
    derivative of the skew ``R' R^T``; :func:`_vee` reads three entries, so the symmetric ``R' R'^T``
    counts) and ``J_w``'s column ``j`` is ``vee(dR/dq_j R^T)``."""
    q, qd, qdd = _time_derivatives(trajectory, s)
    along_qd = lambda qq: jax.jvp(pose, (qq,), (qd,))  # noqa: E731
    ((_, R), (_, Rd)), (_, (a_qd, Rdd_qd)) = jax.jvp(along_qd, (q,), (qd,))
    J_v, J_R = jax.jacfwd(pose)(q)  # (K, 3, n), (K, 3, 3, n)
    a = a_qd + J_v @ qdd
    Rdd = Rdd_qd + J_R @ qdd
    w = _angular(Rd, R)
    eps = _angular(Rdd, R) + _angular(Rd, Rd)
    J_w = jnp.moveaxis(_angular(jnp.moveaxis(J_R, -1, 0), R), 0, -1)  # (K, 3, n)
    I_world = jnp.einsum("kij,kjl,kml->kim", R, inertias, R)
    F = masses[:, None] * (a - gravity[None, :]) - forces
    M = jnp.einsum("kij,kj->ki", I_world, eps) + jnp.cross(w, jnp.einsum("kij,kj->ki", I_world, w))
    return jnp.einsum("kin,ki->n", J_v, F) + jnp.einsum("kin,ki->n", J_w, M)


def _lagrange_at(pose, masses, inertias, gravity, forces, trajectory, s):
    """Lagrange's equations at the time ``s``: one JVP of ``(dT/dq, dT/dq')`` along ``(q', q'')``
    gives ``dT/dq`` and, by the chain rule, ``d/dt(dT/dq')``."""
    T = lambda q, qd: kinetic_energy(pose, masses, inertias, q, qd)  # noqa: E731
    V = lambda q: potential_energy(pose, masses, gravity, forces, q)  # noqa: E731
    q, qd, qdd = _time_derivatives(trajectory, s)
    (dT_dq, _), (_, dp_dt) = jax.jvp(jax.grad(T, argnums=(0, 1)), (q, qd), (qd, qdd))
    return dp_dt - dT_dq + jax.grad(V)(q)


@functools.partial(jax.jit, static_argnames=("method",))
def _compiled(pose, masses, inertias, gravity, forces, trajectory, t, method):
    at = _virtual_work_at if method == "virtual_work" else _lagrange_at
    return jax.vmap(lambda s: at(pose, masses, inertias, gravity, forces, trajectory, s))(t)


def _run(method, pose, masses, inertias, gravity, forces, trajectory, t):
    masses, inertias, gravity, forces, t, checks = _checked_model(masses, inertias, gravity, forces, t)
    out = _compiled(
        _as_partial(pose, "pose"),
        masses,
        inertias,
        gravity,
        forces,
        _as_partial(trajectory, "trajectory"),
        _padded(t),
        method,
    )
    for bad, message in checks:
        out = eqx.error_if(out, bad, message)
    n = t.shape[0]
    if isinstance(out, jax.core.Tracer):
        return out[:n]
    return jax.device_put(np.asarray(out)[:n])  # sliced on the host: no compilation for a new length


def inverse_dynamics_virtual_work(
    pose: Callable, masses: Array, inertias: Array, gravity: Array, forces: Array, trajectory: Callable, t: Array
) -> Array:
    """Actuator forces ``(len(t), n)`` along ``q = trajectory(t)`` by virtual work (P3 eq (19)-(23),
    (30)-(31)): each body's inertia force ``-m a`` and moment ``-(I eps + w x I w)``, its weight and
    the external forces, mapped to the actuators by the velocity Jacobians ``J_v = dc/dq`` and
    ``J_w = dw/dq'`` (autodiff). Assumes no friction and massless joints.

    ``pose(q) -> (c (K, 3), R (K, 3, 3))``; ``masses (K,)``, body-frame ``inertias (K, 3, 3)``,
    ``gravity (3,)``, constant external ``forces (K, 3)`` at the centres, ``t (N,)``. Compiled once
    per model (module docstring: pass ``pose``/``trajectory`` as ``jax.tree_util.Partial``).
    """
    return _run("virtual_work", pose, masses, inertias, gravity, forces, trajectory, t)


def inverse_dynamics_lagrange(
    pose: Callable, masses: Array, inertias: Array, gravity: Array, forces: Array, trajectory: Callable, t: Array
) -> Array:
    """Actuator forces ``(len(t), n)`` along ``q = trajectory(t)`` from Lagrange's equations
    ``tau = d/dt(dT/dq') - dT/dq + dV/dq`` with ``T`` and ``V`` of :func:`kinetic_energy` and
    :func:`potential_energy`, all derivatives by JAX (the independent check of the virtual-work
    result, in place of P3's ADAMS runs). Arguments and compilation as
    :func:`inverse_dynamics_virtual_work`."""
    return _run("lagrange", pose, masses, inertias, gravity, forces, trajectory, t)


__all__ = [
    "body_velocities",
    "inverse_dynamics_lagrange",
    "inverse_dynamics_virtual_work",
    "kinetic_energy",
    "potential_energy",
    "state_trajectory",
]
