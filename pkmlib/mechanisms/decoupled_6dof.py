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
:func:`pkmlib.integrate` takes).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._mechanism import Mechanism
from .._pytree import pytree_dataclass
from .._rigid_body import RigidBodyState, box_inertia, integrate, newton_euler
from .._screws import line, relative_moment, rotation_matrix, skew
from .._notebook_parameters import check_parameter, numbers
from .._validation import check_number, check_positive
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
        :func:`pkmlib.box_inertia`). Every value is checked: ``ValueError`` names the key and what
        is accepted."""
        what = "the P5 parameters (data/params/p5.json as loaded, or its 'mechanism' object)"
        if not isinstance(d, Mapping):
            raise ValueError(f"{what} must be a dict, got {type(d).__name__}: {d!r}")
        if "mechanism" in d:
            d = d["mechanism"]
            if not isinstance(d, Mapping):
                raise ValueError(f"'mechanism' must be a dict of P5 parameters, got {type(d).__name__}: {d!r}")
        missing = [k for k in ("a_m", "mass_kg") if k not in d]
        if missing:
            raise ValueError(
                f"missing P5 parameters: {', '.join(missing)} (expected a_m, mass_kg and either "
                "J_xi_kg_m2, J_eta_kg_m2, J_zeta_kg_m2 or inertia_box_edges_m)"
            )
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
    return platform_points_body(p) @ rotation.T + jnp.asarray(position)[None, :]


def force_screws(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """Unit force screws ``R_i = (r_i, r_i^0)`` with ``r_i^0 = r_Ai x r_i`` (P5 eq 4-5), ``(6, 6)``:
    the lines through A_i along the motor axes."""
    return line(jnp.asarray(FORCE_DIRECTIONS), platform_points_base(position, rotation, p))


def axis_screws(position: Array, rotation: Array) -> Array:
    """Pluecker coordinates ``(xi, xi^0), (eta, eta^0), (zeta, zeta^0)`` of the moving axes in the
    base frame: lines through O_m along the columns of R (P5, before eq 6). ``(3, 6)``."""
    return line(rotation.T, jnp.broadcast_to(position, (3, 3)))


def relative_moments(position: Array, rotation: Array, p: Decoupled6DofParams) -> Array:
    """``mom(R_i, xi), mom(R_i, eta), mom(R_i, zeta)`` (P5 eq 6) as a ``(3, 6)`` array: row l, column
    i is the moment about moving axis l of a unit force on chain i's force screw."""
    return relative_moment(force_screws(position, rotation, p)[None, :, :], axis_screws(position, rotation)[:, None, :])


def platform_wrench(position: Array, rotation: Array, forces: Array, p: Decoupled6DofParams) -> tuple[Array, Array]:
    """Principal vector (base frame) and principal moment about O_m (moving frame) of the motor
    forces ``P_i`` (P5 eq 8): ``R^E = sum_i P_i r_i``, ``M^E_l = sum_i P_i mom(R_i, l)``."""
    forces = jnp.asarray(forces, dtype=jnp.float64)
    return forces @ jnp.asarray(FORCE_DIRECTIONS), relative_moments(position, rotation, p) @ forces


def forward_dynamics(
    position: Array, rotation: Array, omega: Array, forces: Array, p: Decoupled6DofParams
) -> tuple[Array, Array]:
    """Linear acceleration (base frame) and angular acceleration projections on xi, eta, zeta from
    the motor forces and the angular velocity ``omega`` (moving frame): P5 eq 8 with Euler's
    equations sign-corrected (:func:`pkmlib.newton_euler`)."""
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
    x = jnp.asarray(x, dtype=jnp.float64)
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
    return -jnp.dot(jnp.asarray(forces, dtype=jnp.float64), actuator_coordinates(position, rotation, p))


def motor_wrench(t: Array, state: RigidBodyState, forces: Array, p: Decoupled6DofParams) -> tuple[Array, Array]:
    """The wrench of constant motor forces as :func:`pkmlib.integrate` wants it: the principal
    vector and the principal moment about O_m, both in the base frame (P5 eq 8; the moment of
    :func:`platform_wrench` turned from the moving frame by R). ``t`` is not used."""
    F, M_body = platform_wrench(state.position, state.rotation, forces, p)
    return F, state.rotation @ M_body


def simulate(
    state: RigidBodyState, forces: Array, p: Decoupled6DofParams, dt: float, n_steps: int, *, method: str = "splitting"
) -> RigidBodyState:
    """Motion of the platform under constant motor forces (P5 eq 8, sign-corrected), integrated by
    :func:`pkmlib.integrate` (``method``: ``"splitting"``, symplectic, or ``"rkmk4"``, fourth order).
    Returns ``n_steps + 1`` states at ``t = k dt``, the first being ``state``. Compiled once: the
    forces and the parameters are traced arguments of the module-level :func:`motor_wrench`."""
    forces = jnp.asarray(forces, dtype=jnp.float64)
    if forces.shape != (6,):
        raise ValueError(f"forces must be the six motor forces P_1..P_6 (N), shape (6,), got shape {forces.shape}")
    return integrate(state, motor_wrench, p.mass, p.inertia, dt, n_steps, args=(forces, p), method=method)


# ---------------------------------------------------------------------------------------------
# Drawing (beyond the paper's formulas: a geometry for the chains, used for P5 Fig 1-3 only)


def rail_points(rail_offset: float) -> np.ndarray:
    """A point of each motor axis: ``rail_offset * PLATFORM_POINTS_UNIT[i]``, i.e. the axes run along
    six edges of a cube of half-size ``rail_offset`` centred at O, each beside its point A_i."""
    return rail_offset * PLATFORM_POINTS_UNIT


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
    ax.set_zlabel("$z$, m")
    half = rail_offset + 0.1
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-half, half)
    ax.set_box_aspect((1, 1, 1))
    return pts


__all__ = [
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
