"""Rigid-body dynamics (P5, P3): Newton-Euler in the body frame, a fourth-order symplectic
integrator, energies and momenta, and inverse dynamics of a mechanism by virtual work and by
Lagrange's equations. The screws and rotations they are written with stay at ``pkmlib.*``
(:func:`pkmlib.rotation_matrix`, :func:`pkmlib.relative_moment`, ...): the kinematics use them too.

Formerly at ``pkmlib.*`` (those names still work for one release, with a ``DeprecationWarning``)."""

from .._inverse_dynamics import inverse_dynamics_lagrange, inverse_dynamics_virtual_work, state_trajectory
from .._rigid_body import (
    INTEGRATION_METHODS,
    RigidBodyState,
    angular_momentum,
    angular_velocity_from_angle_rates,
    box_inertia,
    check_inertia,
    euler_coefficients,
    integrate,
    kinetic_energy,
    newton_euler,
    newton_euler_as_printed,
    rotation_error,
)

__all__ = [
    "INTEGRATION_METHODS",
    "RigidBodyState",
    "angular_momentum",
    "angular_velocity_from_angle_rates",
    "box_inertia",
    "check_inertia",
    "euler_coefficients",
    "integrate",
    "inverse_dynamics_lagrange",
    "inverse_dynamics_virtual_work",
    "kinetic_energy",
    "newton_euler",
    "newton_euler_as_printed",
    "rotation_error",
    "state_trajectory",
]
