"""Rigid-body Newton-Euler equations in the body (principal) frame and an energy-consistent
time integrator.

The state of a free rigid body is its centre ``position`` and ``velocity`` in the base frame, its
``rotation`` R (columns: the principal axes xi, eta, zeta in the base frame, as in P5 eq 3) and its
angular velocity ``omega`` projected on the body axes (P5's phi'_xi, phi'_eta, phi'_zeta).

Newton-Euler (P5 eq 7, with the sign of the eta equation corrected; see :func:`newton_euler`):

    m a = F,    J_xi eps_xi + (J_zeta - J_eta) w_eta w_zeta = M_xi,
                J_eta eps_eta + (J_xi - J_zeta) w_xi w_zeta = M_eta,
                J_zeta eps_zeta + (J_eta - J_xi) w_xi w_eta = M_zeta.

Integrator (:func:`integrate`): the symplectic splitting of Dullweber, Leimkuhler and McLachlan
(J. Chem. Phys. 107, 5840, 1997; "kick-drift-kick" with the free rotor split into rotations about
the principal axes, McLachlan 1993 / Reich 1994). Why this one: every sub-step is an exact flow,
so R stays a rotation to round-off (products of exact rotation matrices, no re-orthonormalisation
needed), the spatial angular momentum R J omega is conserved to round-off when there is no moment,
and, being symplectic and time-reversible, the energy error stays bounded (O(h^2), no drift) for
forces that derive from a potential, such as P5's constant motor forces (potential
``-sum_i P_i r_i . A_i``). RK4 with re-orthonormalisation is more accurate per step but drifts in
energy and angular momentum.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

import jax
import jax.numpy as jnp

from . import _config  # noqa: F401  (float64)
from ._screws import rot_x, rot_y, rot_z, rotation_matrix

Array = Any


class RigidBodyState(NamedTuple):
    """State of a rigid body (a JAX pytree): ``position`` (3,) and ``velocity`` (3,) of the centre
    of mass in the base frame, ``rotation`` (3, 3) body-to-base, ``omega`` (3,) angular velocity in
    the body (principal) frame."""

    position: Array
    velocity: Array
    rotation: Array
    omega: Array


def newton_euler(mass: Array, inertia: Array, force: Array, moment: Array, omega: Array) -> tuple[Array, Array]:
    """Linear acceleration (base frame) and angular acceleration (body frame) of a rigid body.

    ``m a = F`` and ``J eps + omega x (J omega) = M`` with ``J = diag(inertia)`` the principal
    moments ``(J_xi, J_eta, J_zeta)``, ``M`` the moment about the centre in the body frame
    (P5 eq 7-8). P5 eq 7 prints the eta equation with ``(J_zeta - J_xi)``; Euler's equation (the
    eta component of ``omega x J omega``) has ``(J_xi - J_zeta)``, which is what this function uses.
    """
    inertia = jnp.asarray(inertia)
    a = jnp.asarray(force) / mass
    eps = (jnp.asarray(moment) - jnp.cross(omega, inertia * omega)) / inertia
    return a, eps


def newton_euler_as_printed(inertia: Array, moment: Array, omega: Array) -> Array:
    """Angular acceleration from P5 eq 7 exactly as printed, with ``(J_zeta - J_xi)`` in the eta
    equation (a sign misprint: Euler's equation has ``(J_xi - J_zeta)``). Only for reproducing the
    paper's numbers; use :func:`newton_euler`."""
    Jx, Jy, Jz = inertia[0], inertia[1], inertia[2]
    wx, wy, wz = omega[0], omega[1], omega[2]
    gyro = jnp.stack([wy * wz * (Jz - Jy), wx * wz * (Jz - Jx), wx * wy * (Jy - Jx)])
    return (jnp.asarray(moment) - gyro) / jnp.asarray(inertia)


def euler_coefficients(omega: Array, eps: Array, printed_signs: bool = False) -> Array:
    """The 3 x 3 matrix C with ``C (J_xi, J_eta, J_zeta) = M``: Euler's equations (P5 eq 7) are
    linear in the principal moments for given angular velocity and acceleration. With
    ``printed_signs`` the eta row follows P5's misprinted ``(J_zeta - J_xi)``. Solving C J = M
    (or finding its null space when M = 0) tells what an angular acceleration implies about J."""
    wx, wy, wz = omega[0], omega[1], omega[2]
    s = -1.0 if printed_signs else 1.0
    return jnp.stack([
        jnp.stack([eps[0], -wy * wz, wy * wz]),
        jnp.stack([s * wx * wz, eps[1], -s * wx * wz]),
        jnp.stack([-wx * wy, wx * wy, eps[2]]),
    ])


def box_inertia(mass: Array, edges: Array) -> Array:
    """Principal central moments of a uniform box with edges ``(d_xi, d_eta, d_zeta)``:
    ``J_xi = m (d_eta^2 + d_zeta^2) / 12`` and cyclically (textbook formula)."""
    d2 = jnp.asarray(edges) ** 2
    return mass / 12.0 * jnp.stack([d2[1] + d2[2], d2[0] + d2[2], d2[0] + d2[1]])


def kinetic_energy(state: RigidBodyState, mass: Array, inertia: Array) -> Array:
    """``m v^2 / 2 + omega . J omega / 2`` (J principal, omega in the body frame); states may be
    stacked along leading axes (a trajectory)."""
    rot = jnp.einsum("j,...j->...", jnp.asarray(inertia), state.omega**2)
    return 0.5 * mass * jnp.sum(state.velocity**2, -1) + 0.5 * rot


def angular_momentum(state: RigidBodyState, inertia: Array) -> Array:
    """Angular momentum about the centre of mass in the base frame, ``R J omega`` (leading axes
    allowed)."""
    return jnp.einsum("...ij,j,...j->...i", state.rotation, jnp.asarray(inertia), state.omega)


def angular_velocity_from_angle_rates(angles: Array, angle_rates: Array) -> Array:
    """Body-frame angular velocity for rates of P5's angles ``(alpha, beta, gamma)``:
    ``[omega]x = R^T dR/dt`` with ``R = R_gamma R_beta R_alpha`` (P5 eq 3); ``dR/dt`` by forward-mode
    autodiff (``jax.jvp``)."""
    f = lambda q: rotation_matrix(q[0], q[1], q[2])  # noqa: E731
    R, dR = jax.jvp(f, (jnp.asarray(angles),), (jnp.asarray(angle_rates),))
    W = jnp.swapaxes(R, -1, -2) @ dR
    return jnp.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], -1)


_ELEMENTARY = (rot_x, rot_y, rot_z)


def _free_rotor_step(rotation: Array, pi: Array, inertia: Array, h: Array) -> tuple[Array, Array]:
    """Exact flows of ``pi_k^2 / (2 J_k)`` in the order x(h/2) y(h/2) z(h) y(h/2) x(h/2)
    (McLachlan 1993; Dullweber, Leimkuhler, McLachlan 1997): a rotation about body axis k by
    ``theta = h pi_k / J_k``, ``R <- R Rot_k(theta)``, ``pi <- Rot_k(theta)^T pi``."""
    for k, frac in ((0, 0.5), (1, 0.5), (2, 1.0), (1, 0.5), (0, 0.5)):
        Q = _ELEMENTARY[k](frac * h * pi[k] / inertia[k])
        rotation = rotation @ Q
        pi = Q.T @ pi
    return rotation, pi


def integrate(state: RigidBodyState, wrench: Callable[[Array, Array], tuple[Array, Array]], mass: Array,
              inertia: Array, dt: float, n_steps: int) -> RigidBodyState:
    """Integrate the Newton-Euler equations (P5 eq 7, sign-corrected) with ``lax.scan``.

    ``wrench(position, rotation) -> (F, M)`` gives the force in the base frame and the moment about
    the centre in the body frame; it may depend on the pose but not on the velocities (P5's motor
    forces). Scheme: symplectic kick-drift-kick splitting (module docstring). Returns the states
    after each of the ``n_steps`` steps, stacked along a leading axis (the initial state excluded).
    """
    inertia = jnp.asarray(inertia)
    h = jnp.asarray(dt, dtype=jnp.float64)

    def kick(s, pi, tau):
        F, M = wrench(s.position, s.rotation)
        return s._replace(velocity=s.velocity + tau * F / mass), pi + tau * M

    def step(s, _):
        pi = inertia * s.omega
        s, pi = kick(s, pi, 0.5 * h)
        R, pi = _free_rotor_step(s.rotation, pi, inertia, h)
        s = s._replace(position=s.position + h * s.velocity, rotation=R)
        s, pi = kick(s, pi, 0.5 * h)
        s = s._replace(omega=pi / inertia)
        return s, s

    state = RigidBodyState(*(jnp.asarray(v, dtype=jnp.float64) for v in state))
    _, traj = jax.lax.scan(step, state, None, length=n_steps)
    return traj


def rotation_error(rotation: Array) -> Array:
    """``|R^T R - I|`` (Frobenius), how far a stored rotation is from orthonormal."""
    I = jnp.broadcast_to(jnp.eye(3, dtype=rotation.dtype), rotation.shape)
    return jnp.linalg.norm(jnp.swapaxes(rotation, -1, -2) @ rotation - I, axis=(-2, -1))


__all__ = [
    "RigidBodyState",
    "angular_momentum",
    "angular_velocity_from_angle_rates",
    "box_inertia",
    "euler_coefficients",
    "integrate",
    "kinetic_energy",
    "newton_euler",
    "newton_euler_as_printed",
    "rotation_error",
]
