"""Rigid-body Newton-Euler equations in the body frame and two time integrators.

Frames and units (one convention for the whole module): SI units. The state of a free rigid body
is its centre ``position`` and ``velocity`` in the base frame, its ``rotation`` R (body-to-base;
columns: the body axes xi, eta, zeta in the base frame, as in P5 eq 3) and its angular velocity
``omega`` projected on the body axes (P5's phi'_xi, phi'_eta, phi'_zeta). ``inertia`` is the
central inertia tensor in the body frame, given either as the principal moments ``(J_xi, J_eta,
J_zeta)`` (body axes principal, as in P5) or as a full symmetric ``(3, 3)`` tensor. The wrench an
:func:`integrate` callback returns is the force and the moment about the centre of mass, both in
the BASE frame.

Newton-Euler (P5 eq 7, with the sign of the eta equation corrected; see :func:`newton_euler`):

    m a = F,    J eps + omega x (J omega) = M   (body frame),

which for principal axes reads J_xi eps_xi + (J_zeta - J_eta) w_eta w_zeta = M_xi and cyclically.

Integrators (:func:`integrate`, ``method=``):

* ``"splitting"`` (default, second order): the symplectic splitting of Dullweber, Leimkuhler and
  McLachlan (J. Chem. Phys. 107, 5840, 1997; "kick-drift-kick" with the free rotor split into
  rotations about the principal axes, McLachlan 1993 / Reich 1994). Every sub-step is an exact flow
  when the wrench depends on the pose and time only, so R stays a rotation to round-off, the
  spatial angular momentum R J omega is conserved to round-off when there is no moment, and, being
  symplectic and time-reversible, the energy error stays bounded (O(h^2), no drift) for forces
  that derive from a potential, such as P5's constant motor forces (potential
  ``-sum_i P_i r_i . A_i``). A wrench that depends on the velocities makes the kicks an ODE of
  their own; they are then taken with Heun's method (second order), which reduces to the exact
  kick when the wrench does not depend on the velocities.
* ``"rkmk4"`` (fourth order): the Runge-Kutta-Munthe-Kaas method built on classical RK4
  (Munthe-Kaas, BIT 38, 92, 1998; Hairer, Lubich, Wanner, Geometric Numerical Integration, IV.8):
  the rotation is advanced as ``R_n exp([u])`` with ``u`` from RK4 on the Lie algebra (``dexp^-1``
  truncated after the second commutator, enough for order 4), the rest of the state by RK4. Why
  this one: R stays a rotation to round-off without re-orthonormalisation (every update is an
  exact rotation, :func:`pkmlib.exp_so3`), it is fourth order for any smooth wrench, including
  time- and velocity-dependent ones, and it needs no principal axes. It is not symplectic: energy
  and angular momentum drift slowly, O(h^4) per unit time, but at P5's step it is orders of
  magnitude more accurate than the splitting (see ``benchmarks/p5_dynamics_api.py``).

Both run as one ``lax.scan`` compiled once per wrench function (:func:`integrate`).
"""

from __future__ import annotations

import functools
from typing import Any, Callable, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from . import _config  # noqa: F401  (float64)
from ._memory import check_memory
from ._screws import exp_so3, rot_x, rot_y, rot_z, rotation_matrix

from ._validation import (
    check_array,
    check_finite,
    check_last_axes,
    check_last_axis,
    check_positive_traced,
    positive_or_nan,
    check_flag,
)

Array = Any

#: The integration methods of :func:`integrate` and their orders of accuracy.
INTEGRATION_METHODS = {"splitting": 2, "rkmk4": 4}


class RigidBodyState(NamedTuple):
    """State of a rigid body (a JAX pytree): ``position`` (3,) and ``velocity`` (3,) of the centre
    of mass in the base frame, ``rotation`` (3, 3) body-to-base, ``omega`` (3,) angular velocity in
    the body frame."""

    position: Array
    velocity: Array
    rotation: Array
    omega: Array


def _is_principal(inertia: Array) -> bool:
    return jnp.ndim(inertia) == 1


def _apply_inertia(inertia: Array, w: Array) -> Array:
    """``J w`` for principal moments ``(3,)`` or a full tensor ``(3, 3)``; ``w`` may be ``(..., 3)``."""
    inertia = jnp.asarray(inertia)
    if _is_principal(inertia):
        return jnp.einsum("j,...j->...j", inertia, w)
    return jnp.einsum("ij,...j->...i", inertia, w)


def _solve_inertia(inertia: Array, v: Array) -> Array:
    """``J^-1 v`` for principal moments or a full tensor."""
    inertia = jnp.asarray(inertia)
    if _is_principal(inertia):
        return v / inertia
    return jnp.linalg.solve(inertia, v)


def check_inertia(inertia: Array, name: str = "inertia") -> Array:
    """Return ``inertia`` as a float64 array; raise ``ValueError`` naming ``name`` unless it is the
    principal moments ``(3,)`` (finite, positive) or a full ``(3, 3)`` tensor (finite, symmetric,
    positive definite). Values that are traced (inside ``jit``) are only checked for shape."""
    if isinstance(inertia, (str, bytes)) or inertia is None:
        raise ValueError(
            f"{name} must be 3 principal moments or a symmetric positive-definite 3 x 3 tensor, kg m^2; got {inertia!r}"
        )
    try:
        J = jnp.asarray(inertia, dtype=jnp.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(
            f"{name} must be 3 principal moments or a symmetric positive-definite 3 x 3 tensor, kg m^2; got {inertia!r}"
        ) from e
    if J.shape not in ((3,), (3, 3)):
        raise ValueError(
            f"{name} must have shape (3,) (principal moments) or (3, 3) (full tensor), got shape {J.shape}"
        )
    if isinstance(J, jax.core.Tracer):
        return J
    a = np.asarray(J)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {a.tolist()}")
    if a.ndim == 1:
        if np.any(a <= 0):
            raise ValueError(f"{name}: principal moments must be positive, got {a.tolist()}")
        return J
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-300):
        raise ValueError(f"{name}: the inertia tensor must be symmetric, got {a.tolist()}")
    if np.linalg.eigvalsh(a).min() <= 0:
        raise ValueError(f"{name}: the inertia tensor must be positive definite, got {a.tolist()}")
    return J


def newton_euler(mass: Array, inertia: Array, force: Array, moment: Array, omega: Array) -> tuple[Array, Array]:
    """Linear acceleration (base frame) and angular acceleration (body frame) of a rigid body.

    ``m a = F`` and ``J eps + omega x (J omega) = M`` with ``J`` the central inertia tensor in the
    body frame (principal moments ``(J_xi, J_eta, J_zeta)`` or a full ``(3, 3)`` tensor) and ``M``
    the moment about the centre in the body frame (P5 eq 7-8). P5 eq 7 prints the eta equation
    with ``(J_zeta - J_xi)``; Euler's equation (the eta component of ``omega x J omega``) has
    ``(J_xi - J_zeta)``, which is what this function uses.
    """
    mass = positive_or_nan("mass", mass, "a finite positive mass, kg")
    inertia = check_inertia(inertia)
    force, moment = check_last_axis("force", force, 3), check_last_axis("moment", moment, 3)
    omega = check_last_axis("omega", omega, 3)
    a = force / mass
    eps = _solve_inertia(inertia, moment - jnp.cross(omega, _apply_inertia(inertia, omega)))
    return a, eps


def newton_euler_as_printed(inertia: Array, moment: Array, omega: Array) -> Array:
    """Angular acceleration from P5 eq 7 exactly as printed, with ``(J_zeta - J_xi)`` in the eta
    equation (a sign misprint: Euler's equation has ``(J_xi - J_zeta)``). Principal moments only.
    Only for reproducing the paper's numbers; use :func:`newton_euler`."""
    inertia = check_array("inertia", inertia, (3,), ndim=1, what="principal moments, kg m^2")
    moment, omega = check_array("moment", moment, (3,)), check_array("omega", omega, (3,))
    Jx, Jy, Jz = inertia[0], inertia[1], inertia[2]
    wx, wy, wz = omega[0], omega[1], omega[2]
    gyro = jnp.stack([wy * wz * (Jz - Jy), wx * wz * (Jz - Jx), wx * wy * (Jy - Jx)])
    return (jnp.asarray(moment) - gyro) / jnp.asarray(inertia)


def euler_coefficients(omega: Array, eps: Array, printed_signs: bool = False) -> Array:
    """The 3 x 3 matrix C with ``C (J_xi, J_eta, J_zeta) = M``: Euler's equations (P5 eq 7) are
    linear in the principal moments for given angular velocity and acceleration. With
    ``printed_signs`` the eta row follows P5's misprinted ``(J_zeta - J_xi)``. Solving C J = M
    (or finding its null space when M = 0) tells what an angular acceleration implies about J."""
    omega, eps = check_array("omega", omega, (3,)), check_array("eps", eps, (3,))
    check_flag("printed_signs", printed_signs)
    wx, wy, wz = omega[0], omega[1], omega[2]
    s = -1.0 if printed_signs else 1.0
    return jnp.stack(
        [
            jnp.stack([eps[0], -wy * wz, wy * wz]),
            jnp.stack([s * wx * wz, eps[1], -s * wx * wz]),
            jnp.stack([-wx * wy, wx * wy, eps[2]]),
        ]
    )


def box_inertia(mass: Array, edges: Array) -> Array:
    """Principal central moments of a uniform box with edges ``(d_xi, d_eta, d_zeta)``:
    ``J_xi = m (d_eta^2 + d_zeta^2) / 12`` and cyclically (textbook formula)."""
    mass = positive_or_nan("mass", mass, "a finite positive mass, kg")
    d2 = positive_or_nan("edges", check_array("edges", edges, (3,)), "3 finite positive edge lengths") ** 2
    return mass / 12.0 * jnp.stack([d2[1] + d2[2], d2[0] + d2[2], d2[0] + d2[1]])


def _check_state_type(state: Any) -> None:
    if not isinstance(state, RigidBodyState):
        raise ValueError(
            f"state must be a pkmlib.dynamics.RigidBodyState (position, velocity, rotation, omega), got {type(state).__name__}"
        )


def kinetic_energy(state: RigidBodyState, mass: Array, inertia: Array) -> Array:
    """``m v^2 / 2 + omega . J omega / 2`` (J principal ``(3,)`` or full ``(3, 3)`` in the body frame,
    omega in the body frame); states may be stacked along leading axes (a trajectory)."""
    _check_state_type(state)
    mass = positive_or_nan("mass", mass, "a finite positive mass, kg")
    inertia = check_inertia(inertia)
    omega, velocity = (
        check_last_axis("state.omega", state.omega, 3),
        check_last_axis("state.velocity", state.velocity, 3),
    )
    rot = jnp.sum(omega * _apply_inertia(inertia, omega), -1)
    return 0.5 * mass * jnp.sum(velocity**2, -1) + 0.5 * rot


def angular_momentum(state: RigidBodyState, inertia: Array) -> Array:
    """Angular momentum about the centre of mass in the base frame, ``R J omega`` (leading axes
    allowed; J principal or full)."""
    _check_state_type(state)
    inertia = check_inertia(inertia)
    rotation = check_last_axes("state.rotation", state.rotation, (3, 3))
    return jnp.einsum(
        "...ij,...j->...i", rotation, _apply_inertia(inertia, check_last_axis("state.omega", state.omega, 3))
    )


def angular_velocity_from_angle_rates(angles: Array, angle_rates: Array) -> Array:
    """Body-frame angular velocity for rates of P5's angles ``(alpha, beta, gamma)``:
    ``[omega]x = R^T dR/dt`` with ``R = R_gamma R_beta R_alpha`` (P5 eq 3); ``dR/dt`` by forward-mode
    autodiff (``jax.jvp``)."""
    angles = check_array("angles", angles, (3,), what="(alpha, beta, gamma), rad")
    angle_rates = check_array("angle_rates", angle_rates, (3,), what="rad/s")
    f = lambda q: rotation_matrix(q[0], q[1], q[2])  # noqa: E731
    R, dR = jax.jvp(f, (angles,), (angle_rates,))
    W = jnp.swapaxes(R, -1, -2) @ dR
    return jnp.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], -1)


_ELEMENTARY = (rot_x, rot_y, rot_z)


def _free_rotor_step(rotation: Array, pi: Array, inertia: Array, h: Array) -> tuple[Array, Array]:
    """Exact flows of ``pi_k^2 / (2 J_k)`` in the order x(h/2) y(h/2) z(h) y(h/2) x(h/2)
    (McLachlan 1993; Dullweber, Leimkuhler, McLachlan 1997): a rotation about principal axis k by
    ``theta = h pi_k / J_k``, ``R <- R Rot_k(theta)``, ``pi <- Rot_k(theta)^T pi``."""
    for k, frac in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        Q = _ELEMENTARY[k](frac * h * pi[k] / inertia[k])
        rotation = rotation @ Q
        pi = Q.T @ pi
    return rotation, pi


def _principal_axes(inertia: Array) -> tuple[Array, Array | None]:
    """``(d, Q)`` with ``J = Q diag(d) Q^T``, ``Q`` a proper rotation (body to principal axes);
    ``Q = None`` when ``J`` is given as principal moments."""
    if _is_principal(inertia):
        return inertia, None
    d, Q = jnp.linalg.eigh(inertia)
    Q = Q.at[:, 2].multiply(jnp.sign(jnp.linalg.det(Q)))
    return d, Q


def _splitting_method(wrench, args, mass, inertia):
    """``(to_internal, step, to_state)`` of the kick-drift-kick splitting (module docstring). The
    internal state is ``(position, velocity, R_p, pi_p)`` in principal axes, ``R_p = R Q`` and
    ``pi_p = diag(d) Q^T omega``, so that round-off in ``Q`` does not accumulate over the steps."""
    d, Q = _principal_axes(inertia)

    def to_state(c):
        pos, vel, R_p, pi = c
        if Q is None:
            return RigidBodyState(pos, vel, R_p, pi / d)
        return RigidBodyState(pos, vel, R_p @ Q.T, Q @ (pi / d))

    def to_internal(s):
        if Q is None:
            return (s.position, s.velocity, s.rotation, d * s.omega)
        return (s.position, s.velocity, s.rotation @ Q, d * (Q.T @ s.omega))

    def wrench_at(t, pos, vel, R_p, pi):
        F, M = wrench(t, to_state((pos, vel, R_p, pi)), *args)
        return jnp.asarray(F), R_p.T @ jnp.asarray(M)  # the moment in principal axes

    def kick(t, pos, vel, R_p, pi, tau):
        # Heun's method for v' = F/m, pi' = M with the pose and the time frozen; exact when F and M
        # do not depend on the velocities (then F2 = F1 and this is v + tau F1 / m).
        F1, M1 = wrench_at(t, pos, vel, R_p, pi)
        F2, M2 = wrench_at(t, pos, vel + tau * F1 / mass, R_p, pi + tau * M1)
        return vel + (0.5 * tau) * (F1 + F2) / mass, pi + (0.5 * tau) * (M1 + M2)

    def step(t, h, c):
        pos, vel, R_p, pi = c
        vel, pi = kick(t, pos, vel, R_p, pi, 0.5 * h)
        R_p, pi = _free_rotor_step(R_p, pi, d, h)
        pos = pos + h * vel
        vel, pi = kick(t + h, pos, vel, R_p, pi, 0.5 * h)
        return (pos, vel, R_p, pi)

    return to_internal, step, to_state


def _dexpinv(u: Array, w: Array) -> Array:
    """``u'`` for ``R = R_n exp([u])`` with body angular velocity ``w``: ``dexp^-1_{-u}(w)``
    truncated after the second commutator, ``w + u x w / 2 + u x (u x w) / 12`` (HLW IV.8)."""
    uw = jnp.cross(u, w)
    return w + 0.5 * uw + jnp.cross(u, uw) / 12.0


def _rkmk4_method(wrench, args, mass, inertia):
    """``(to_internal, step, to_state)`` of RKMK4 (module docstring); the internal state is the state."""

    def f(tt, pos, vel, R, w):
        F, M = wrench(tt, RigidBodyState(pos, vel, R, w), *args)
        eps = _solve_inertia(inertia, R.T @ jnp.asarray(M) - jnp.cross(w, _apply_inertia(inertia, w)))
        return vel, jnp.asarray(F) / mass, eps

    def step(t, h, s):
        x0, v0, R0, w0 = s
        dx1, dv1, dw1 = f(t, x0, v0, R0, w0)
        K1 = w0
        u = 0.5 * h * K1
        x2, v2, w2 = x0 + 0.5 * h * dx1, v0 + 0.5 * h * dv1, w0 + 0.5 * h * dw1
        dx2, dv2, dw2 = f(t + 0.5 * h, x2, v2, R0 @ exp_so3(u), w2)
        K2 = _dexpinv(u, w2)
        u = 0.5 * h * K2
        x3, v3, w3 = x0 + 0.5 * h * dx2, v0 + 0.5 * h * dv2, w0 + 0.5 * h * dw2
        dx3, dv3, dw3 = f(t + 0.5 * h, x3, v3, R0 @ exp_so3(u), w3)
        K3 = _dexpinv(u, w3)
        u = h * K3
        x4, v4, w4 = x0 + h * dx3, v0 + h * dv3, w0 + h * dw3
        dx4, dv4, dw4 = f(t + h, x4, v4, R0 @ exp_so3(u), w4)
        K4 = _dexpinv(u, w4)
        c = h / 6.0
        return RigidBodyState(
            x0 + c * (dx1 + 2.0 * dx2 + 2.0 * dx3 + dx4),
            v0 + c * (dv1 + 2.0 * dv2 + 2.0 * dv3 + dv4),
            R0 @ exp_so3(c * (K1 + 2.0 * K2 + 2.0 * K3 + K4)),
            w0 + c * (dw1 + 2.0 * dw2 + 2.0 * dw3 + dw4),
        )

    return (lambda s: s), step, (lambda s: s)


_STEPS = {"splitting": _splitting_method, "rkmk4": _rkmk4_method}


@functools.partial(jax.jit, static_argnames=("wrench", "n_steps", "method"))
def _integrate_compiled(state, wrench, args, mass, inertia, dt, t0, n_steps, method):
    to_internal, step, to_state = _STEPS[method](wrench, args, mass, inertia)

    def body(c, i):
        c = step(t0 + dt * i, dt, c)
        return c, to_state(c)

    _, traj = jax.lax.scan(body, to_internal(state), jnp.arange(n_steps, dtype=jnp.float64))
    return jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a[None], b]), state, traj)


def integrate(
    state: RigidBodyState,
    wrench: Callable[..., tuple[Array, Array]],
    mass: Array,
    inertia: Array,
    dt: float,
    n_steps: int,
    *,
    args: tuple = (),
    t0: float = 0.0,
    method: str = "splitting",
) -> RigidBodyState:
    """Integrate the Newton-Euler equations (P5 eq 7, sign-corrected) from ``state`` at time ``t0``.

    ``wrench(t, state, *args) -> (F, M)``: the force and the moment about the centre of mass, BOTH
    IN THE BASE FRAME, at time ``t`` and ``state`` (a :class:`RigidBodyState`: pose, velocity and
    body-frame angular velocity); it may depend on all of them. ``args`` (a tuple of pytrees, e.g.
    forces and parameters) is passed on as traced values. ``inertia``: principal moments ``(3,)`` or
    a full symmetric ``(3, 3)`` tensor in the body frame. ``method``: ``"splitting"`` (symplectic,
    second order, default) or ``"rkmk4"`` (fourth order); see the module docstring.

    Returns ``n_steps + 1`` states stacked along a leading axis, at the times ``t0 + k dt``,
    ``k = 0..n_steps``: the first is ``state`` itself.

    Differentiable (``jax.grad``/``jacfwd``) in the state, ``args``, mass, inertia and ``dt``. One
    exception: the splitting diagonalises a full ``(3, 3)`` tensor with ``eigh``, whose derivative
    is undefined (NaN) when two principal moments are equal; differentiate with respect to
    principal moments ``(3,)`` or use ``"rkmk4"`` there.

    Compiled once per ``(wrench, n_steps, method)`` and argument shapes: ``wrench`` is a static
    argument (hashed by identity), so pass a module-level function and put what varies in
    ``args``; a new lambda on every call compiles every time.
    """
    if method not in _STEPS:
        raise ValueError(f"method must be one of {sorted(_STEPS)}, got {method!r}")
    if not callable(wrench):
        raise ValueError(f"wrench must be a function wrench(t, state, *args) -> (F, M), got {wrench!r}")
    if isinstance(n_steps, bool) or not isinstance(n_steps, (int, np.integer)) or n_steps < 1:
        raise ValueError(f"n_steps must be a positive integer, got {n_steps!r}")
    # the n_steps + 1 stacked states (18 numbers each), and as much again for the scan's output buffers
    check_memory(2.0 * (n_steps + 1) * 18 * 8, what=f"{n_steps + 1:.3g} rigid-body states", parameter="n_steps")
    # concrete: ValueError; traced (integrate inside the user's jit): equinox.error_if, raised when it runs
    dt = check_positive_traced("dt", dt, "a finite positive number (time step, s)")
    mass = check_positive_traced("mass", mass, "a finite positive number (mass, kg)")
    if not isinstance(t0, jax.core.Tracer):
        check_finite("t0", t0)
    if not isinstance(args, tuple):
        raise ValueError(f"args must be a tuple (passed as wrench(t, state, *args)), got {type(args).__name__}")
    inertia = check_inertia(inertia)
    if isinstance(inertia, jax.core.Tracer):  # traced (inertia differentiated or vmapped): checked when it runs
        ok = jnp.all(jnp.isfinite(inertia)) & (
            jnp.all(inertia > 0)
            if inertia.ndim == 1
            else jnp.all(jnp.abs(inertia - inertia.T) <= 1e-12 * jnp.max(jnp.abs(inertia)))
            & jnp.all(jnp.diag(inertia) > 0)
        )
        inertia = eqx.error_if(
            inertia,
            ~ok,
            "inertia must be 3 positive principal moments or a symmetric 3 x 3 tensor with a positive diagonal",
        )
    if not isinstance(state, tuple) or len(state) != 4:
        raise ValueError(
            f"state must be a pkmlib.dynamics.RigidBodyState (position, velocity, rotation, omega), got {type(state).__name__}"
        )
    try:
        state = RigidBodyState(*(jnp.asarray(v, dtype=jnp.float64) for v in state))
    except (TypeError, ValueError):
        raise ValueError(f"state must be a pkmlib.dynamics.RigidBodyState of real arrays, got {state!r}") from None
    for name, v, shape in zip(RigidBodyState._fields, state, ((3,), (3,), (3, 3), (3,))):
        if v.shape != shape:
            raise ValueError(f"state.{name} must have shape {shape}, got {v.shape}")
    return _integrate_compiled(
        state,
        wrench,
        args,
        jnp.asarray(mass, dtype=jnp.float64),
        inertia,
        jnp.asarray(dt, dtype=jnp.float64),
        jnp.asarray(t0, dtype=jnp.float64),
        int(n_steps),
        method,
    )


def rotation_error(rotation: Array) -> Array:
    """``|R^T R - I|`` (Frobenius), how far a stored rotation is from orthonormal."""
    rotation = check_last_axes("rotation", rotation, (3, 3))
    I = jnp.broadcast_to(jnp.eye(3, dtype=rotation.dtype), rotation.shape)
    return jnp.linalg.norm(jnp.swapaxes(rotation, -1, -2) @ rotation - I, axis=(-2, -1))
