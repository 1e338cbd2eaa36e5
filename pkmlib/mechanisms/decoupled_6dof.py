"""P5: the 6-DOF decoupled parallel mechanisms 6-PRRS and 6-PRPS, force screws and dynamics.

Kheylo, Garin, Terekhova, Prokhorovich, Dukhov, J. Mach. Manuf. Reliab. 2022 no. 1, pp. 39-46
("P5"). Equation numbers (P5 eq 1-8) are those listed in :mod:`pkmlib._screws` (the paper prints
none; they are its displayed equations in order).

Six linear motors on the base, their axes along the edges of a parallelepiped centred at O and
parallel to the base axes in pairs (x, x, y, y, z, z). Each chain (P R R S, or P R P S) has its
joints after the motor arranged so that the sphere centre A_i on the platform can move freely across
the motor axis: with the carriage locked, the chain can only push A_i along the motor axis. It
therefore passes the motor force P_i to A_i unchanged in size and direction: the force screw
``R_i(r_i, r_i^0)`` is the line through A_i along the motor axis (P5 eq 4-5). The platform's
centre of mass O_m is the origin of the moving frame, whose axes xi, eta, zeta are principal.

Poses are given as ``position`` (the point O_m in the base frame, ``(3,)``) and ``rotation``
(``R``, ``(3, 3)``, from :func:`pkmlib.rotation_matrix` for P5's angles alpha, beta, gamma).

Units: one convention for the whole module, the paper's: SI (m, kg, kg m^2, s, N, N m, rad).
Frames: forces and positions in the base frame; :func:`platform_wrench` and
:func:`forward_dynamics` give the moment and the angular acceleration on the moving axes xi, eta,
zeta (P5 eq 7-8), :func:`motor_wrench` the moment in the base frame (what
:func:`pkmlib.dynamics.integrate` takes).
"""

from __future__ import annotations

import dataclasses
import re
from decimal import ROUND_DOWN, ROUND_HALF_UP, Decimal
from typing import Any, Mapping, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._mechanism import Mechanism
from .._pytree import pytree_dataclass
from .._reference import compare_reference, reference_row
from .._rigid_body import RigidBodyState, box_inertia, euler_coefficients, integrate, kinetic_energy, newton_euler
from .._tables import markdown_table
from .._screws import line, relative_moment, rotation_matrix, skew
from .._notebook_parameters import check_parameter, numbers
from .._validation import (
    check_array,
    check_count,
    check_first_axis,
    check_keys,
    check_mapping,
    check_number,
    check_positive,
)
from ._contract import load_paper_params, stack_pose

Array = Any

#: The paper's key in the registry (:mod:`pkmlib._papers`).
PAPER = "p5"
#: The module's unit convention, the paper's: SI.
UNITS = {"length": "m", "angle": "rad", "time": "s", "mass": "kg", "inertia": "kg m^2", "force": "N", "torque": "N m"}
#: P5's mechanism has one inverse position solution (:func:`inverse_position`): no branch.
PAPER_BRANCH = None

#: Platform points A_1..A_6 in the moving frame in units of ``a`` (P5 eq 1).
PLATFORM_POINTS_UNIT = np.array(
    [[0, 1, -1], [0, -1, 1], [-1, 0, 1], [1, 0, -1], [-1, 1, 0], [1, -1, 0]], dtype=np.float64
)
#: Unit vectors r_1..r_6 of the force screws: along x, x, y, y, z, z (P5 eq 4).
FORCE_DIRECTIONS = np.array([[1, 0, 0], [1, 0, 0], [0, 1, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1]], dtype=np.float64)
#: The pairs of chains whose motors are parallel (0-based).
PAIRS = ((0, 1), (2, 3), (4, 5))
#: Names of the moving axes.
AXES = ("xi", "eta", "zeta")
#: The base axis (0 = x, 1 = y, 2 = z) of each motor, the direction of r_i (P5 eq 4).
MOTOR_AXES = (0, 0, 1, 1, 2, 2)


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class Decoupled6DofParams:
    """Platform of the P5 mechanism (SI units). A JAX pytree; build it with :meth:`create` or
    :meth:`from_dict`, which check the values.

    ``a``: platform size (A_i at distance ``a`` along two moving axes, P5 eq 1), m; ``mass``, kg;
    ``J_xi, J_eta, J_zeta``: principal central moments of inertia, kg m^2 (not printed in P5).
    """

    a: float
    mass: float
    J_xi: float
    J_eta: float
    J_zeta: float

    @classmethod
    def create(cls, *, a, mass, J_xi, J_eta, J_zeta) -> "Decoupled6DofParams":
        """Checked constructor: every value a finite positive real number, and the principal moments
        satisfy the triangle inequalities of a real body (each at most the sum of the other two)."""
        units = dict(a="m", mass="kg", J_xi="kg m^2", J_eta="kg m^2", J_zeta="kg m^2")
        v = {
            k: check_number(k, x, unit=units[k], positive=True)
            for k, x in dict(a=a, mass=mass, J_xi=J_xi, J_eta=J_eta, J_zeta=J_zeta).items()
        }
        J = (v["J_xi"], v["J_eta"], v["J_zeta"])
        for k, name in enumerate(("J_xi", "J_eta", "J_zeta")):
            if J[k] > J[(k + 1) % 3] + J[(k + 2) % 3]:
                raise ValueError(f"{name} = {J[k]!r} exceeds the sum of the other two principal moments")
        return cls(**v)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Decoupled6DofParams":
        """From ``data/params/p5.json`` as :func:`pkmlib.load_params` returns it (the whole file) or
        from its ``"mechanism"`` object: ``a_m``, ``mass_kg`` and either ``J_xi_kg_m2, J_eta_kg_m2,
        J_zeta_kg_m2`` or ``inertia_box_edges_m`` (three edges of a uniform box along xi, eta, zeta;
        :func:`pkmlib.dynamics.box_inertia`). Every value is checked: ``ValueError`` names the key and what
        is accepted."""
        what = "the P5 parameters (data/params/p5.json as loaded, or its 'mechanism' object)"
        d = check_mapping(what, d)
        if "mechanism" in d:
            d = check_mapping("'mechanism' of the P5 parameters", d["mechanism"])
        check_keys(what, d, ("a_m", "mass_kg"), (*(f"J_{n}_kg_m2" for n in AXES), "inertia_box_edges_m"))
        a = check_number("a_m", d["a_m"], unit="m", positive=True)
        mass = check_number("mass_kg", d["mass_kg"], unit="kg", positive=True)
        if all(f"J_{n}_kg_m2" in d for n in AXES):
            J = [check_number(f"J_{n}_kg_m2", d[f"J_{n}_kg_m2"], unit="kg m^2", positive=True) for n in AXES]
        elif "inertia_box_edges_m" in d:
            edges = d["inertia_box_edges_m"]
            check_parameter("inertia_box_edges_m", edges, numbers(None, shape=(3,), min=0.0, min_open=True, unit="m"))
            J = [float(j) for j in box_inertia(mass, jnp.asarray(edges, dtype=jnp.float64))]
        else:
            raise ValueError("missing P5 parameters: J_xi_kg_m2, J_eta_kg_m2, J_zeta_kg_m2 or inertia_box_edges_m")
        return cls.create(a=a, mass=mass, J_xi=J[0], J_eta=J[1], J_zeta=J[2])

    @property
    def inertia(self) -> Array:
        """``(J_xi, J_eta, J_zeta)``."""
        return jnp.stack([jnp.asarray(self.J_xi), jnp.asarray(self.J_eta), jnp.asarray(self.J_zeta)])


def platform_points_body(p: Decoupled6DofParams) -> Array:
    """A_1..A_6 in the moving frame, ``(6, 3)`` (P5 eq 1)."""
    return p.a * jnp.asarray(PLATFORM_POINTS_UNIT)


def platform_points_base(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """A_1..A_6 in the base frame, ``A^b = R A^m + T`` (P5 eq 2-3), ``(6, 3)``."""
    position, rotation = _check_position_rotation(position, rotation)
    return platform_points_body(p) @ rotation.T + position[None, :]


def _check_position_rotation(position: Array, rotation: Array) -> tuple[Array, Array]:
    """One pose: ``position`` ``(3,)`` (O_m in the base frame) and ``rotation`` ``(3, 3)``."""
    position = check_array("position", position, (3,), ndim=1, what="O_m in the base frame")
    rotation = check_array("rotation", rotation, (3, 3), ndim=2, what="the platform's rotation matrix")
    return position, rotation


def force_screws(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """Unit force screws ``R_i = (r_i, r_i^0)`` with ``r_i^0 = r_Ai x r_i`` (P5 eq 4-5), ``(6, 6)``:
    the lines through A_i along the motor axes."""
    return line(jnp.asarray(FORCE_DIRECTIONS), platform_points_base(position, rotation, p))


def axis_screws(position: Array, rotation: Array) -> Array:
    """Pluecker coordinates ``(xi, xi^0), (eta, eta^0), (zeta, zeta^0)`` of the moving axes in the
    base frame: lines through O_m along the columns of R (P5, before eq 6). ``(3, 6)``."""
    position, rotation = _check_position_rotation(position, rotation)
    return line(rotation.T, jnp.broadcast_to(position, (3, 3)))


def relative_moments(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """``mom(R_i, xi), mom(R_i, eta), mom(R_i, zeta)`` (P5 eq 6) as a ``(3, 6)`` array: row l, column
    i is the moment about moving axis l of a unit force on chain i's force screw."""
    return relative_moment(force_screws(position, rotation, p)[None, :, :], axis_screws(position, rotation)[:, None, :])


def platform_wrench(position: Array, rotation: Array, forces: Array, p: Decoupled6DofParams) -> tuple[Array, Array]:
    """Principal vector (base frame) and principal moment about O_m (moving frame) of the motor
    forces ``P_i`` (P5 eq 8): ``R^E = sum_i P_i r_i``, ``M^E_l = sum_i P_i mom(R_i, l)``."""
    forces = check_array("forces", forces, (6,), ndim=1, what="one motor force per chain")
    return forces @ jnp.asarray(FORCE_DIRECTIONS), relative_moments(position, rotation, p) @ forces


def forward_dynamics(
    position: Array, rotation: Array, omega: Array, forces: Array, p: Decoupled6DofParams
) -> tuple[Array, Array]:
    """Linear acceleration (base frame) and angular acceleration projections on xi, eta, zeta from
    the motor forces and the angular velocity ``omega`` (moving frame): P5 eq 8 with Euler's
    equations sign-corrected (:func:`pkmlib.dynamics.newton_euler`)."""
    F, M = platform_wrench(position, rotation, forces, p)
    return newton_euler(p.mass, p.inertia, F, M, jnp.asarray(omega, dtype=jnp.float64))


def actuator_coordinates(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """Carriage coordinates ``q_i = r_i . A_i^b`` (P5 eq 2 and 4): the chain leaves A_i free across
    the motor axis, so the carriage follows A_i's coordinate along it (up to a constant offset).
    Equal displacements of a pair translate the platform with transmission ratio one (P5 abstract)."""
    return jnp.sum(jnp.asarray(FORCE_DIRECTIONS) * platform_points_base(position, rotation, p), axis=-1)


def wrench_jacobian(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """``dq / d(dp, dtheta)`` at the pose, ``(6, 6)``: rows are chains, columns the base-frame
    translation of O_m and the small rotation about the moving axes (``R -> R (I + [dtheta]x)``),
    by ``jax.jacfwd``. By virtual work its transpose maps motor forces to the platform wrench, so
    its rotation block equals the relative moments transposed (P5 eq 6): an independent route."""

    position, rotation = _check_position_rotation(position, rotation)

    def q(delta):
        return actuator_coordinates(position + delta[:3], rotation @ (jnp.eye(3) + skew(delta[3:])), p)

    return jax.jacfwd(q)(jnp.zeros(6, dtype=jnp.float64))


def pose(x, y, z, alpha, beta, gamma) -> Array:
    """The output vector of :data:`mechanism`, ``x = (x, y, z, alpha, beta, gamma)``: the position of
    O_m (m) and P5's angles (rad, :func:`pkmlib.rotation_matrix`), ``(6,)`` or ``(6, *batch)``."""
    return stack_pose(x, y, z, alpha, beta, gamma)


def position_rotation(x: Array) -> tuple[Array, Array]:
    """``(position, rotation)`` of a pose ``x = (x, y, z, alpha, beta, gamma)`` (one pose), as the
    dynamics functions of this module take it: ``x[:3]`` and ``R = R_gamma R_beta R_alpha``
    (P5 eq 3)."""
    x = check_array("x", x, (6,), ndim=1, what="one pose x, y, z, alpha, beta, gamma")
    return x[:3], rotation_matrix(x[3], x[4], x[5])


def _rotation_row(k: int, alpha: Array, beta: Array, gamma: Array) -> tuple[Array, Array, Array]:
    """Row ``k`` of ``R = R_gamma R_beta R_alpha`` (P5 eq 3; :func:`pkmlib.rotation_matrix` multiplied
    out), for angles of any shape: the chains need one row each, and this keeps their derivatives
    small."""
    ca, sa, cb, sb, cg, sg = (
        f(v)
        for v, f in (
            (alpha, jnp.cos),
            (alpha, jnp.sin),
            (beta, jnp.cos),
            (beta, jnp.sin),
            (gamma, jnp.cos),
            (gamma, jnp.sin),
        )
    )
    if k == 0:
        return cg * cb, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa
    if k == 1:
        return sg * cb, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa
    return -sb, cb * sa, cb * ca


def _carriage(i: int, x: Array, p: Decoupled6DofParams) -> Array:
    """``r_i . A_i^b`` with ``A_i^b = R A_i^m + T`` (P5 eq 2-4) for a pose ``x`` that is only indexed
    (any trailing batch shape): the coordinate of A_i along motor axis i."""
    check_first_axis("x", x, 6, "x, y, z, alpha, beta, gamma")
    k = MOTOR_AXES[i]
    row = _rotation_row(k, x[3], x[4], x[5])
    return x[k] + sum(p.a * float(c) * row[j] for j, c in enumerate(PLATFORM_POINTS_UNIT[i]) if c)


def chain_constraint(i: int, x: Array, q_i: Array, p: Decoupled6DofParams) -> Array:
    """``F_i = q_i - r_i . A_i^b(x)`` (P5 eq 2-4): the chain leaves A_i free across motor axis i, so
    the carriage coordinate follows A_i's coordinate along it (:func:`actuator_coordinates`).
    ``B = I``; ``A = -dq/dx`` in the angle rates of P5's angles."""
    return q_i - _carriage(i, x, p)


def inverse_position(x: Array, p: Decoupled6DofParams, branch: None = None) -> Array:
    """Carriage coordinates ``q_i = r_i . A_i^b`` at pose ``x = (x, y, z, alpha, beta, gamma)``
    (P5 eq 2-4), ``(6,)`` or ``(6, *batch)``; one solution (``branch`` is None). P5 gives no
    actuator travel, so every pose is inside (no NaN)."""
    return jnp.stack([_carriage(i, x, p) for i in range(6)])


def actuator_limits(p: Decoupled6DofParams) -> tuple[Array, Array]:
    """P5 states no carriage travel."""
    return jnp.full(6, -jnp.inf), jnp.full(6, jnp.inf)


#: The mechanism of P5 (the contract of :mod:`pkmlib.mechanisms`): chainwise, its constraint
#: equations those of :func:`chain_constraint`.
mechanism = Mechanism(
    name="P5 6-DOF decoupled",
    chain_constraint=chain_constraint,
    inverse_position=inverse_position,
    actuator_limits=actuator_limits,
    output_names=("x", "y", "z", "alpha", "beta", "gamma"),
    output_units=("m", "m", "m", "rad", "rad", "rad"),
    actuator_names=("q_1", "q_2", "q_3", "q_4", "q_5", "q_6"),
    actuator_units=("m",) * 6,
    default_branch=PAPER_BRANCH,
)
#: The paper's mechanisms by key.
MECHANISMS = {"6-PRRS": mechanism}


def load_params(key: str | None = None, source=None) -> Decoupled6DofParams:
    """The checked platform of P5 from ``data/params/p5.json`` (or ``source``: another parameter
    file's name or path, or a dict of its layout); ``key`` is None or ``"6-PRRS"``."""
    return load_paper_params(PAPER, {"6-PRRS": Decoupled6DofParams.from_dict}, key, source)


def potential_energy(position: Array, rotation: Array, forces: Array, p: Decoupled6DofParams) -> Array:
    """Potential of constant motor forces, ``-sum_i P_i r_i . A_i^b`` (their work is path-independent),
    so that kinetic plus potential energy is conserved under constant forces."""
    forces = check_array("forces", forces, (6,), ndim=1, what="one motor force per chain")
    return -jnp.dot(forces, actuator_coordinates(position, rotation, p))


def motor_wrench(t: Array, state: RigidBodyState, forces: Array, p: Decoupled6DofParams) -> tuple[Array, Array]:
    """The wrench of constant motor forces as :func:`pkmlib.dynamics.integrate` wants it: the principal
    vector and the principal moment about O_m, both in the base frame (P5 eq 8; the moment of
    :func:`platform_wrench` turned from the moving frame by R). ``t`` is not used."""
    F, M_body = platform_wrench(state.position, state.rotation, forces, p)
    return F, state.rotation @ M_body


def simulate(
    state: RigidBodyState, forces: Array, p: Decoupled6DofParams, dt: float, n_steps: int, *, method: str = "splitting"
) -> RigidBodyState:
    """Motion of the platform under constant motor forces (P5 eq 8, sign-corrected), integrated by
    :func:`pkmlib.dynamics.integrate` (``method``: ``"splitting"``, symplectic, or ``"rkmk4"``, fourth order).
    Returns ``n_steps + 1`` states at ``t = k dt``, the first being ``state``. Compiled once: the
    forces and the parameters are traced arguments of the module-level :func:`motor_wrench`."""
    forces = jnp.asarray(forces, dtype=jnp.float64)
    if forces.shape != (6,):
        raise ValueError(f"forces must be the six motor forces P_1..P_6 (N), shape (6,), got shape {forces.shape}")
    return integrate(state, motor_wrench, p.mass, p.inertia, dt, n_steps, args=(forces, p), method=method)


# ---------------------------------------------------------------------------------------------
# What P5's printed example implies, and its numbers beside ours


def turned_angle(rotations: Array, rotation0: Array) -> Array:
    """The angle (rad) of ``R(t) R0^T`` for each rotation of ``rotations`` (``(..., 3, 3)``):
    ``acos((tr(R R0^T) - 1) / 2)``, the argument clipped to [-1, 1] against round-off (the
    axis-angle form of a rotation; 0 for a platform that only translates)."""
    c = (jnp.einsum("...ij,ij->...", jnp.asarray(rotations), jnp.asarray(rotation0)) - 1.0) / 2.0
    return jnp.arccos(jnp.clip(c, -1.0, 1.0))


def total_energy(states: RigidBodyState, forces: Array, p: Decoupled6DofParams) -> Array:
    """Kinetic plus potential energy (J) of each state of a trajectory (leading axis) under constant
    motor forces: :func:`pkmlib.dynamics.kinetic_energy` plus :func:`potential_energy`, conserved by the
    exact motion (P5 eq 8 with constant forces), so its drift measures the integrator's error."""
    V = jax.vmap(lambda pos, rot: potential_energy(pos, rot, forces, p))(states.position, states.rotation)
    return kinetic_energy(states, p.mass, p.inertia) + V


def translation_closed_form(position: Array, forces: Array, p: Decoupled6DofParams, t: Array) -> Array:
    """``O_m(t) = T + F t^2 / 2m`` (m), ``(len(t), 3)``: the path of O_m from rest, or of any
    platform (the principal vector of P5 eq 8 is ``F = sum_i P_i r_i`` at every pose, so the centre
    of mass moves as a free point under it) for constant motor forces ``forces`` (N)."""
    forces = check_array("forces", forces, (6,), ndim=1, what="one motor force per chain")
    position = check_array("position", position, (3,), ndim=1, what="O_m in the base frame")
    F = forces @ jnp.asarray(FORCE_DIRECTIONS)
    t = jnp.asarray(t, dtype=jnp.float64)
    return position[None] + 0.5 * F[None] / p.mass * t[:, None] ** 2


def pair_transmission(position: Array, rotation: Array, p: Decoupled6DofParams) -> tuple[Array, Array]:
    """P5's abstract: equal displacements of the two motors of a parallel pair translate the
    platform with transmission ratio one. Solves ``W dX = dq`` (``W``: :func:`wrench_jacobian`,
    by ``jax.jacfwd``) for ``dq = 1`` on the two motors of each pair of :data:`PAIRS` and 0
    elsewhere. Returns the length of the translation ``|dX[:3]|`` (m per m, the transmission
    ratio) and of the small rotation ``|dX[3:]|`` (rad per m) for the x, y and z pairs."""
    dq = np.zeros((6, len(PAIRS)))
    for k, (a, b) in enumerate(PAIRS):
        dq[[a, b], k] = 1.0
    dX = jnp.linalg.solve(wrench_jacobian(position, rotation, p), jnp.asarray(dq))
    return jnp.linalg.norm(dX[:3], axis=0), jnp.linalg.norm(dX[3:], axis=0)


#: How the notebook's moments of inertia were chosen (P5 does not print them; see :func:`implied_inertia`).
INERTIA_NOTE = "not printed in P5; with zero moment (equal forces in pairs) its angular accelerations under its printed Euler equations fix only the ratios J_xi : J_eta : J_zeta = 45 : 40 : 13 (null vector of C); Euler's correct equations admit only J = 0. Scale free: a uniform 1 kg box 0.1 x 0.15 x 0.3 m (edges 2 : 3 : 6) from data/params/p5.json"


def implied_inertia(omega: Array, eps: Array) -> dict[str, np.ndarray]:
    """What P5's printed angular accelerations ``eps`` at the angular velocity ``omega`` say about
    the principal moments of inertia when the principal moment is zero (equal forces in each pair).

    Euler's equations are linear in ``J``: ``C(omega, eps) J = M = 0``
    (:func:`pkmlib.dynamics.euler_coefficients`, P5 eq 8). With P5's printed eta equation
    (``printed_signs=True``) ``C`` is singular to the printed digits and its null vector fixes the
    ratios ``J_xi : J_eta : J_zeta``; with Euler's equations ``C`` has full rank (only ``J = 0``).
    Returns ``singular_values_printed``, ``singular_values_euler`` (descending), ``null_vector``
    (the unit right singular vector of the smallest singular value of the printed ``C``, as LAPACK
    signs it), ``ratios`` (the null vector over its ``J_zeta``) and ``energy_rate``
    (``sum_l J_l omega_l eps_l`` for ``J`` = the null vector: zero for any torque-free motion under
    Euler's equations, which the printed values violate)."""
    omega, eps = jnp.asarray(omega, dtype=jnp.float64), jnp.asarray(eps, dtype=jnp.float64)
    C_printed = np.asarray(euler_coefficients(omega, eps, printed_signs=True))
    C_euler = np.asarray(euler_coefficients(omega, eps, printed_signs=False))
    _, s_printed, vt = np.linalg.svd(C_printed)
    null = vt[-1]
    return {
        "singular_values_printed": s_printed,
        "singular_values_euler": np.linalg.svd(C_euler, compute_uv=False),
        "null_vector": null,
        "ratios": null / null[2],
        "energy_rate": float(np.dot(null * np.asarray(omega), np.asarray(eps))),
    }


def inertia_for_moment(omega: Array, eps: Array, moment: Array, *, printed_signs: bool = True) -> np.ndarray:
    """The principal moments of inertia ``J`` (kg m^2) that give the angular accelerations ``eps``
    at ``omega`` under the moment ``moment`` (N m, moving axes): ``C(omega, eps) J = M``
    (:func:`pkmlib.dynamics.euler_coefficients`; P5's printed eta equation by default)."""
    C = np.asarray(euler_coefficients(jnp.asarray(omega), jnp.asarray(eps), printed_signs=printed_signs))
    return np.linalg.solve(C, np.asarray(moment, dtype=np.float64))


#: The note of a printed value that is ours cut (not rounded) after its printed digits.
TRUNCATED_NOTE = "printed value is truncated, not rounded"


def printed_digits(value: float, decimals: int, *, truncate: bool = False) -> str:
    """``value`` as P5 would print it with ``decimals`` decimals: rounded half up (0.0875 ->
    "0.088"), or cut after them with ``truncate=True``; "-0" is written "0"."""
    decimals = check_count("decimals", decimals, minimum=0, maximum=12)
    q = Decimal(f"{float(value):.12f}").quantize(
        Decimal(1).scaleb(-decimals), rounding=ROUND_DOWN if truncate else ROUND_HALF_UP
    )
    return f"{abs(q) if q == 0 else q:f}"


def score_printed(quantity: str, ours: float, *, paper_run: bool = True) -> dict[str, Any]:
    """One scorecard row for a number P5 prints: :func:`pkmlib.tools.compare_reference` on
    ``data/reference/p5.json``, with ``printed`` (the paper's text) and ``ours_printed_digits``
    (ours rounded to the printed decimals). A row whose reference says ``rounding: "truncated"``
    is reproduced (with :data:`TRUNCATED_NOTE`) when cutting ours after the printed digits gives
    exactly the printed ones; a reproduced ``by_construction`` row becomes *by construction* (our
    value was inferred from the paper's). A printed pair "0.0069 and -0.0069" is scored on its first."""
    ref = reference_row(PAPER, quantity)
    printed = ref["printed"].split(" and ")[0]
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    r = compare_reference(PAPER, quantity, float(ours), paper_run=paper_run)
    r["printed"] = ref["printed"]
    r["ours_printed_digits"] = printed_digits(ours, decimals)
    if paper_run and ref.get("rounding") == "truncated":
        r["ours_truncated_digits"] = printed_digits(ours, decimals, truncate=True)
        if r["ours_truncated_digits"] == printed:
            r["status"], r["rounding"], r["note"] = "reproduced", "truncated", TRUNCATED_NOTE
    if paper_run and ref.get("by_construction") and r["status"] == "reproduced":
        r["status"], r["by_construction"] = "by construction", ref["by_construction"]
    return r


#: The groups of P5's printed numbers, in the order of the notebook's tables.
SCORE_GROUPS = ("points", "screws", "axes", "moments", "accelerations")


def score_example(
    points: Array, screws: Array, axes: Array, moments: Array, lin_acc: Array, ang_acc: Array, *, paper_run: bool = True
) -> dict[str, list[dict[str, Any]]]:
    """Every number P5 prints for its example scored by :func:`score_printed`, by group of
    :data:`SCORE_GROUPS`: the points ``A_i^b`` (:func:`platform_points_base`), the moments
    ``r_i^0`` of the force screws (``screws[:, 3:]`` of :func:`force_screws`), the Pluecker
    coordinates of the moving axes (:func:`axis_screws`), the relative moments
    (:func:`relative_moments`; P5 prints ``mom(R_5, zeta) = -mom(R_6, zeta)`` as one pair, scored as
    one row with ``ours_R6``) and the accelerations with their magnitudes
    (:func:`forward_dynamics`)."""
    xyz = "xyz"
    points, screws, axes, moments = (np.asarray(v) for v in (points, screws, axes, moments))
    lin_acc, ang_acc = np.asarray(lin_acc), np.asarray(ang_acc)

    def row(quantity, ours):
        return score_printed(quantity, ours, paper_run=paper_run)

    groups = {g: [] for g in SCORE_GROUPS}
    for i in range(6):
        groups["points"] += [row(f"A_{i + 1}^b {xyz[c]}", points[i, c]) for c in range(3)]
        groups["screws"] += [row(f"r_{i + 1}^0 {xyz[c]}", screws[i, 3 + c]) for c in range(3)]
    for k, name in enumerate(AXES):
        groups["axes"] += [row(f"{name} {xyz[c]}", axes[k, c]) for c in range(3)]
        groups["axes"] += [row(f"{name}^0 {xyz[c]}", axes[k, 3 + c]) for c in range(3)]
    for k, name in enumerate(AXES):
        for i in range(6):
            if (name, i) == ("zeta", 5):
                continue  # printed as the pair below
            if (name, i) == ("zeta", 4):
                groups["moments"].append(row("mom(R_5, zeta) = -mom(R_6, zeta)", moments[k, 4]))
                groups["moments"][-1]["ours_R6"] = float(moments[k, 5])
            else:
                groups["moments"].append(row(f"mom(R_{i + 1}, {name})", moments[k, i]))
    groups["accelerations"] += [row(f"linear acceleration {xyz[c]}", lin_acc[c]) for c in range(3)]
    groups["accelerations"].append(row("linear acceleration magnitude", np.linalg.norm(lin_acc)))
    groups["accelerations"] += [row(f"angular acceleration {name}", ang_acc[k]) for k, name in enumerate(AXES)]
    groups["accelerations"].append(row("angular acceleration magnitude", np.linalg.norm(ang_acc)))
    return groups


_GREEK = {"xi": "\\xi", "eta": "\\eta", "zeta": "\\zeta"}


def quantity_as_math(quantity: str) -> str:
    """A quantity of ``data/reference/p5.json`` as the paper writes it, in TeX: ``"A_1^b x"`` ->
    ``$A^b_{1x}$``, ``"xi^0 y"`` -> ``$\\xi^0_y$``, ``"mom(R_5, xi)"`` ->
    ``$\\mathrm{mom}(\\mathbf R_5, \\xi)$``; anything else unchanged."""
    mo = re.fullmatch(r"(A|r)_(\d)\^(b|0) ([xyz])", quantity)
    if mo:
        return f"${mo[1]}^{mo[3]}_{{{mo[2]}{mo[4]}}}$"
    mo = re.fullmatch(r"(xi|eta|zeta)(\^0)? ([xyz])", quantity)
    if mo:
        return f"${_GREEK[mo[1]]}{mo[2] or ''}_{mo[3]}$"
    return re.sub(
        r"mom\(R_(\d), (xi|eta|zeta)\)", lambda k: f"$\\mathrm{{mom}}(\\mathbf R_{k[1]}, {_GREEK[k[2]]})$", quantity
    )


def score_table(rows: Sequence[Mapping[str, Any]]):
    """The rows of :func:`score_example` as a Markdown table (:func:`pkmlib.tools.markdown_table`): the
    quantity, the paper as printed, ours, ours to the printed digits and the status, which links
    the row's one place, the scorecard (``scorecard.html#<row id>``, :func:`pkmlib.tools.report.status_link`)."""
    from ..tools.report import status_link

    body = [
        (
            quantity_as_math(r["quantity"]),
            r["printed"],
            f"{r['ours']:+.5f}",
            r["ours_printed_digits"],
            status_link("p5", r["quantity"], r["status"])
            + (" (truncated)" if r.get("rounding") == "truncated" else ""),
        )
        for r in rows
    ]
    return markdown_table(body, ["quantity", "paper (printed)", "ours", "ours, printed digits", "status"])


# ---------------------------------------------------------------------------------------------
# Drawing (beyond the paper's formulas: a geometry for the chains, used for P5 Fig 1-3 only)


def rail_points(rail_offset: float) -> np.ndarray:
    """A point of each motor axis: ``rail_offset * PLATFORM_POINTS_UNIT[i]``, i.e. the axes run along
    six edges of a cube of half-size ``rail_offset`` centred at O, each beside its point A_i.
    ``ValueError`` naming ``rail_offset`` unless it is a finite positive number (m)."""
    return check_positive("rail_offset", rail_offset) * PLATFORM_POINTS_UNIT


def chain_points(
    position: Array,
    rotation: Array,
    p: Decoupled6DofParams,
    *,
    kind: str = "PRRS",
    rail_offset: float = 0.4,
    link_lengths: Sequence[float] = (0.4, 0.4),
) -> dict[str, np.ndarray]:
    """Joint centres of the six chains for drawing: carriages C_i (on the motor axis at A_i's
    coordinate along it), the elbows E_i of the two R joints (``kind="PRRS"``; links
    ``link_lengths``, axes parallel to the motor; the elbow on the side ``r_i x (A_i - C_i)``),
    and A_i. For ``"PRPS"`` the elbow is the carriage (R joint) and the P joint is the strut C_i A_i.
    NaN where a 2R chain cannot reach."""
    A = np.asarray(platform_points_base(position, rotation, p))
    r = FORCE_DIRECTIONS
    C = rail_points(rail_offset) + np.sum(r * A, axis=1, keepdims=True) * r
    if kind == "PRPS":
        return {"C": C, "E": C.copy(), "A": A}
    if kind != "PRRS":
        raise ValueError(f"kind must be 'PRRS' or 'PRPS', got {kind!r}")
    l1, l2 = (check_positive("link_lengths", v) for v in link_lengths)
    d_vec = A - C
    d = np.linalg.norm(d_vec, axis=1, keepdims=True)
    u = d_vec / d
    n = np.cross(r, u)
    along = (l1**2 - l2**2 + d**2) / (2 * d)
    h2 = l1**2 - along**2
    h = np.sqrt(np.where(h2 >= 0, h2, np.nan))
    return {"C": C, "E": C + along * u + h * n, "A": A}


def hexagon_order(points_body: np.ndarray) -> np.ndarray:
    """Order of the six A_i around the platform (they lie in the plane xi + eta + zeta = 0)."""
    n = np.ones(3) / np.sqrt(3.0)
    e1 = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)
    e2 = np.cross(n, e1)
    return np.argsort(np.arctan2(points_body @ e2, points_body @ e1))


def upright_z_label(ax, label: str = "$z$, m") -> None:
    """Label the z axis of a 3-D axes reading bottom to top (mplot3d turns it with the view)."""
    ax.zaxis.set_rotate_label(False)
    ax.set_zlabel(label, rotation=90)


def draw(
    ax,
    position: Array,
    rotation: Array,
    p: Decoupled6DofParams,
    *,
    kind: str = "PRRS",
    chains: Sequence[int] = range(6),
    forces: Array | None = None,
    rail_offset: float = 0.4,
    link_lengths: Sequence[float] = (0.4, 0.4),
    rail_half_length: float = 0.45,
    force_scale: float = 0.05,
    axis_length: float = 0.15,
    label: bool = True,
):
    """Draw the mechanism on a 3-D axes: motor axes (grey), carriages (blue squares), links, the
    spheres A_i (red), the platform (hexagon A_1..A_6), the moving axes xi, eta, zeta and, if
    ``forces`` is given, the motor forces as arrows along the force screws (``force_scale`` m/N).
    ``label`` writes the names A_i. Axis limits: a cube of half-size ``rail_offset + 0.1`` m."""
    pts = chain_points(position, rotation, p, kind=kind, rail_offset=rail_offset, link_lengths=link_lengths)
    C, E, A = pts["C"], pts["E"], pts["A"]
    rails = rail_points(rail_offset)
    T = np.asarray(position)
    Rm = np.asarray(rotation)
    colours = ("tab:blue", "tab:blue", "tab:green", "tab:green", "tab:purple", "tab:purple")
    for i in chains:
        r = FORCE_DIRECTIONS[i]
        ends = np.stack([rails[i] - rail_half_length * r, rails[i] + rail_half_length * r])
        ax.plot(*ends.T, color="0.6", lw=3, alpha=0.6, solid_capstyle="butt")
        ax.scatter(*C[i], marker="s", s=40, color=colours[i], depthshade=False)
        if kind == "PRRS":
            ax.plot(*np.stack([C[i], E[i], A[i]]).T, color=colours[i], lw=2)
            ax.scatter(*E[i], s=15, color="k", depthshade=False)
        else:
            mid = C[i] + 0.5 * (A[i] - C[i])
            ax.plot(*np.stack([C[i], mid]).T, color=colours[i], lw=4)
            ax.plot(*np.stack([mid, A[i]]).T, color=colours[i], lw=1.8)
        ax.scatter(*A[i], s=25, color="tab:red", depthshade=False)
        if label:
            ax.text(*(A[i] + 0.02), f"$A_{i + 1}$", fontsize=8)
        if forces is not None:
            ax.quiver(*A[i], *(force_scale * float(forces[i]) * r), color="tab:orange", lw=1.5, arrow_length_ratio=0.25)
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    order = hexagon_order(PLATFORM_POINTS_UNIT)
    ax.add_collection3d(Poly3DCollection([A[order]], facecolor="0.5", edgecolor="k", alpha=0.35, lw=1.0))
    for k, name in enumerate(("\\xi", "\\eta", "\\zeta")):
        tip = T + axis_length * Rm[:, k]
        ax.plot(*np.stack([T, tip]).T, color="k", lw=0.8, ls="--")
        ax.text(*tip, f"${name}$", fontsize=9)
    ax.set_xlabel("$x$, m")
    ax.set_ylabel("$y$, m")
    upright_z_label(ax)
    half = rail_offset + 0.1
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-half, half)
    ax.set_box_aspect((1, 1, 1))
    return pts


def draw_first_chain(ax, position: Array, rotation: Array, p: Decoupled6DofParams, *, forces: Array, **drawing):
    """P5 Fig 3: the first kinematic chain P-R-R-S of 6-PRRS (:func:`draw` of chain 1 only), zoomed
    on it, with its joints named and its force screw ``R_1``, the line through A_1 along x (P5 eq
    4-5), dashed. ``drawing``: the chain geometry of :func:`draw`. Returns :func:`draw`'s points."""
    pts = draw(ax, position, rotation, p, kind="PRRS", chains=[0], forces=forces, label=False, **drawing)
    for txt in list(ax.texts):  # the names of the moving axes would pile up at A_1 in this close view
        txt.remove()
    C1, E1, A1 = pts["C"][0], pts["E"][0], pts["A"][0]
    line_ = np.stack([A1 - [0.3, 0, 0], A1 + [0.3, 0, 0]])
    ax.plot(*line_.T, color="tab:orange", ls="--", lw=1)
    box = np.stack([C1, E1, A1, line_[0], line_[1]])
    lo, hi = box.min(axis=0) - 0.06, box.max(axis=0) + 0.06
    for setter, a, b in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), lo, hi):
        setter(a, b)
    ax.set_box_aspect(hi - lo)
    ax.text(*(C1 + [0.0, 0.0, -0.07]), "P (motor, carriage)", fontsize=10, ha="center")
    ax.text(*(C1 + [0.0, 0.03, 0.03]), "R", fontsize=11)
    ax.text(*(E1 + [0.0, -0.05, 0.0]), "R", fontsize=11)
    ax.text(*(A1 + [0.0, -0.07, -0.05]), "S ($A_1$)", fontsize=11)
    ax.text(*(line_[1] + [0.0, 0.0, 0.02]), r"$\mathbf{R}_1$", fontsize=12, color="tab:orange")
    from matplotlib.ticker import MaxNLocator

    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
        axis.set_major_locator(MaxNLocator(4))
    return pts


__all__ = [
    "INERTIA_NOTE",
    "draw_first_chain",
    "upright_z_label",
    "turned_angle",
    "translation_closed_form",
    "total_energy",
    "score_table",
    "score_printed",
    "score_example",
    "quantity_as_math",
    "printed_digits",
    "pair_transmission",
    "inertia_for_moment",
    "implied_inertia",
    "TRUNCATED_NOTE",
    "SCORE_GROUPS",
    "AXES",
    "Decoupled6DofParams",
    "FORCE_DIRECTIONS",
    "MECHANISMS",
    "MOTOR_AXES",
    "PAIRS",
    "PAPER",
    "PAPER_BRANCH",
    "PLATFORM_POINTS_UNIT",
    "UNITS",
    "actuator_coordinates",
    "actuator_limits",
    "chain_constraint",
    "axis_screws",
    "chain_points",
    "draw",
    "force_screws",
    "hexagon_order",
    "forward_dynamics",
    "inverse_position",
    "load_params",
    "mechanism",
    "motor_wrench",
    "platform_points_base",
    "platform_points_body",
    "platform_wrench",
    "pose",
    "position_rotation",
    "potential_energy",
    "rail_points",
    "relative_moments",
    "simulate",
    "wrench_jacobian",
]
