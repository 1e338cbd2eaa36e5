"""P4: stiffness of the planar five-bar (2-RRR) mechanism from beam elements.

Erastova, "The influence of special positions on the rigidity of parallel structure mechanisms",
BMSTU J. Mech. Eng. 2020 no. 8 ("P4").

Frame (the paper's plane xOz, Fig 1): actuated joints ``A1 = (0, 0)`` and ``A2 = (l_A1A2, 0)``
(mm), output point ``C = (x_C, z_C)``; the input angles ``q = (phi_1, phi_2)`` are measured from
the x axis toward z, so that link ``A_i B_i`` has P4's rotation angle ``a = phi_i``. The chains
are ``A1 B1 C`` and ``A2 B2 C``. Working mode :data:`PAPER_BRANCH` ("elbows out"): ``B1`` lies to
the left of the line ``A1 -> C`` and ``B2`` to the right of ``A2 -> C``; with it, [50, 150] mm is
inside the workspace above the type-2 singular curve (``B1, C, B2`` collinear, which crosses the
symmetry line ``x_C = 50`` mm at ``z_C = sqrt(l^2 - (l - l_A1A2/2)^2) = 122.47`` mm).

Stiffness (P4 eq (3), (6), (7)): the links are 3-D beam elements (:mod:`pkmlib._stiffness`); the
actuators and the hinges are rigid (P4: "in a first approximation"); ``A_i B_i`` is clamped at
``A_i`` and hinged at ``B_i`` (P4's ``N``), ``B_i C`` is hinged at both ends (``H``); the hinge
axes are along global y. Nodes ``A1, B1, C, B2, A2``; after the clamps and the three empty hinge
rows are removed the system is 15 x 15 (P4, text after Fig 3).

Compiled once per model: :func:`stiffness_map` (a grid) and :func:`pose_stiffness_jit` (one
pose or a list of poses) take the parameters, ``T_max`` and the branch as run-time arguments.
Units: mm, N, N mm, rad throughout (parameters from ``data/params/p4.json`` via
:meth:`FiveBarParams.from_dict`, which takes the whole file).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._pytree import pytree_dataclass
from .._small_matrices import det_small, inverse_small
from .._grid import Grid
from .._jacobians import A_matrix, _check_pose, inverse_jacobian
from .._mechanism import Mechanism
from .._notebook_parameters import check_parameter, number
from .._stiffness import (
    FIXED_HINGE_Y,
    HINGE_HINGE_Y,
    U_X,
    U_Z,
    BeamSection,
    Frame,
    canonical_sign,
    directional_stiffness,
    extremal_stiffness,
    node_dof,
    node_dofs,
    positive_number,
    rectangle_section,
    release,
    solve_spd,
)
from .._sweep import sweep
from .._validation import check_choice, check_positive, check_square, positive_or_nan
from ._contract import deprecated_names, load_paper_params, stack_pose

Array = Any

#: The paper's key in the registry (:mod:`pkmlib._papers`).
PAPER = "p4"
#: The module's unit convention, the paper's: lengths in mm, angles in rad, forces in N.
UNITS = {
    "length": "mm",
    "angle": "rad",
    "force": "N",
    "torque": "N mm",
    "stiffness": "N/mm",
    "modulus": "MPa",
    "second moment of area": "mm^4",
}
#: Working mode of P4 ("elbows out"), the branch of the inverse position solution,
#: ``phi_i = atan2(...) + sign_i acos(...)``: ``B1`` counter-clockwise of ``A1 C`` (left,
#: outside), ``B2`` clockwise of ``A2 C`` (right, outside).
PAPER_BRANCH = (1, -1)
#: Node numbers of the frame model.
A1, B1, C, B2, A2 = range(5)
#: The frame: links A1B1 (clamped at A1, hinge about y at B1: P4's ``N``), B1C (hinges at both
#: ends: ``H``), A2B2 (``N``), B2C (``H``); clamps at A1, A2. The three hinge rows (theta_y at B1,
#: C, B2) are emptied by the releases and removed (``FRAME.empty_dofs``), leaving 15 x 15.
FRAME = Frame(
    n_nodes=5,
    elements=((A1, B1), (B1, C), (A2, B2), (B2, C)),
    releases=(release(2), release(1, 2), release(2), release(1, 2)),
    fixed_dofs=node_dofs(A1, A2),
)
#: Global DOF numbers of C's in-plane displacements (u_x, u_z), loaded by the in-plane force.
C_PLANE_DOFS = (node_dof(C, U_X), node_dof(C, U_Z))
#: Positions of C's in-plane displacements (u_x, u_z) in the reduced 15 x 15 system.
C_PLANE = tuple(FRAME.reduced_index(i) for i in C_PLANE_DOFS)
#: Relative tolerance of the ties between the two actuators' worst directions (and between the
#: parallelogram's diagonals): within it, actuator 1 (the first diagonal) is chosen.
TIE_RTOL = 1e-9
#: Points per compiled chunk of :func:`stiffness_map` (measured in benchmarks/p4_stiffness_map.py:
#: larger chunks are no faster and only hold more temporaries).
MAP_CHUNK = 8192


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class FiveBarParams:
    """Geometry (mm) and link section of the P4 five-bar. A JAX pytree.

    Build it with :meth:`create` or :meth:`from_dict`, which check the values.
    """

    l_A1A2: float
    l_A1B1: float
    l_B1C: float
    l_A2B2: float
    l_B2C: float
    section: BeamSection

    @classmethod
    def create(cls, *, l_A1A2, l_A1B1, l_B1C, l_A2B2, l_B2C, section: BeamSection) -> "FiveBarParams":
        """Checked constructor: every length a finite positive number (mm)."""
        lengths = dict(l_A1A2=l_A1A2, l_A1B1=l_A1B1, l_B1C=l_B1C, l_A2B2=l_A2B2, l_B2C=l_B2C)
        if not isinstance(section, BeamSection):
            raise ValueError("section must be a pkmlib.stiffness.BeamSection")
        return cls(**{k: positive_number(k, v) for k, v in lengths.items()}, section=section)

    @classmethod
    def from_dict(cls, d: dict) -> "FiveBarParams":
        """From the whole parameter file as :func:`pkmlib.load_params` gives it (``"p4"``):
        ``mechanism`` lengths in mm, ``material`` E, G in MPa, ``section`` I_y, I_z, I_p in mm^4
        (P4 table) and the rectangle ``b_mm``, ``h_mm`` of ``section_rectangle`` that gives the
        area (not printed in P4; see :func:`section_area`).

        Every value is checked: a missing group or key, or a value that is not a finite positive
        number (None, a string, a list, a complex number, <= 0) is a ``ValueError`` naming it
        (``"section.I_y_mm4"``) and what is accepted.
        """
        _check_file(d)
        m, mat, sec = d["mechanism"], d["material"], d["section"]
        section = BeamSection.create(
            E=mat["E_MPa"],
            G=mat["G_MPa"],
            A=section_area(d),
            I_y=sec["I_y_mm4"],
            I_z=sec["I_z_mm4"],
            I_p=sec["I_p_mm4"],
        )
        return cls.create(**{k[:-3]: m[k] for k in _FILE_KEYS["mechanism"]}, section=section)


#: The keys :meth:`FiveBarParams.from_dict` reads, per group, with their units.
_FILE_KEYS = {
    "mechanism": {"l_A1A2_mm": "mm", "l_A1B1_mm": "mm", "l_B1C_mm": "mm", "l_A2B2_mm": "mm", "l_B2C_mm": "mm"},
    "material": {"E_MPa": "MPa", "G_MPa": "MPa"},
    "section": {"I_y_mm4": "mm^4", "I_z_mm4": "mm^4", "I_p_mm4": "mm^4"},
    "section_rectangle": {"b_mm": "mm", "h_mm": "mm"},
}


def _check_file(d: Any) -> None:
    """ValueError naming the first missing or unacceptable entry of a P4 parameter dict."""
    if not isinstance(d, dict):
        raise ValueError(f"P4 parameters: expected the dict of pkmlib.load_params('p4'), got {type(d).__name__}")
    missing = [g for g in _FILE_KEYS if not isinstance(d.get(g), dict)]
    if missing:
        raise ValueError(
            f"missing P4 parameter group(s): {', '.join(missing)} (each a dict, as in data/params/p4.json)"
        )
    missing = [f"{g}.{k}" for g, keys in _FILE_KEYS.items() for k in keys if k not in d[g]]
    if missing:
        raise ValueError(f"missing P4 parameters: {', '.join(missing)}")
    for g, keys in _FILE_KEYS.items():
        for k, unit in keys.items():
            check_parameter(f"{g}.{k}", d[g][k], number(None, min=0.0, min_open=True, unit=unit))


def section_area(d: dict) -> float:
    """The link area, mm^2: not printed in P4. Its table's ``I_y = 3.41e3``, ``I_z = 1.33e3`` and
    ``I_p = 3.26e3`` mm^4 are, to the printed digits, those of a solid ``b x h = 10 x 16`` mm
    rectangle (:func:`pkmlib.stiffness.rectangle_section`; ``I_p`` is its torsion constant, not
    ``I_y + I_z``), so ``A = b h = 160`` mm^2. Raises ValueError if the rectangle in the file does
    not reproduce the printed inertias to 0.5 % (and names any missing or invalid entry)."""
    _check_file(d)
    rect = d["section_rectangle"]
    r = rectangle_section(rect["b_mm"], rect["h_mm"])
    for name in ("I_y", "I_z", "I_p"):
        printed = float(d["section"][f"{name}_mm4"])
        if abs(r[name] - printed) > 5e-3 * printed:
            raise ValueError(f"section_rectangle: {name} = {r[name]:.4g} mm^4 does not match the printed {printed:.4g}")
    return r["A"]


def _base(i: int, p: FiveBarParams):
    return (0.0, 0.0) if i == 0 else (p.l_A1A2, 0.0)


def _lengths(i: int, p: FiveBarParams):
    return (p.l_A1B1, p.l_B1C) if i == 0 else (p.l_A2B2, p.l_B2C)


def chain_constraint(i: int, x: Array, q_i: Array, p: FiveBarParams) -> Array:
    """``F_i = (x_C - x_Ai - l_AiBi cos phi_i)^2 + (z_C - z_Ai - l_AiBi sin phi_i)^2 - l_BiC^2``:
    ``|B_i C| = l_BiC`` (P4 eq (1) takes its constraint equations from refs [12, 13], not printed)."""
    (xa, za), (l1, l2) = _base(i, p), _lengths(i, p)
    return (x[0] - xa - l1 * jnp.cos(q_i)) ** 2 + (x[1] - za - l1 * jnp.sin(q_i)) ** 2 - l2**2


def _chain_angles(x: Array, p: FiveBarParams) -> tuple[list, list]:
    """Per chain ``i``: the direction ``atan2(z_C - z_Ai, x_C - x_Ai)`` of ``A_i C`` and ``cos gamma_i
    = (l1^2 + d^2 - l2^2) / (2 l1 d)``, ``d = |A_i C|``, the cosine of the angle at ``A_i`` between
    ``A_i C`` and the proximal link (the law of cosines in the triangle ``A_i B_i C``)."""
    directions, cosines = [], []
    for i in range(2):
        (xa, za), (l1, l2) = _base(i, p), _lengths(i, p)
        dx, dz = x[0] - xa, x[1] - za
        d = jnp.sqrt(dx**2 + dz**2)
        directions.append(jnp.arctan2(dz, dx))
        cosines.append((l1**2 + d**2 - l2**2) / (2 * l1 * d))
    return directions, cosines


def inverse_position(x: Array, p: FiveBarParams, branch: Array) -> Array:
    """Input angles ``phi_i = atan2(z_C - z_Ai, x_C - x_Ai) + sign_i acos((l1^2 + d^2 - l2^2) /
    (2 l1 d))``, ``d = |A_i C|`` (the solution of :func:`chain_constraint` for ``phi_i``).

    ``branch = (sign_1, sign_2)``; :data:`PAPER_BRANCH` is the one used for P4. NaN where a chain
    cannot reach ``C``. Shape ``(2, *batch)``.
    """
    directions, cosines = _chain_angles(x, p)
    q = []
    for i, (a, cos_g) in enumerate(zip(directions, cosines)):
        gamma = jnp.arccos(jnp.where(jnp.abs(cos_g) <= 1.0, cos_g, jnp.nan))
        q.append(a + branch[i] * gamma)
    return jnp.stack(q)


def inverse_position_clipped(x: Array, p: FiveBarParams, branch: Array) -> tuple[Array, Array]:
    """:func:`inverse_position` with ``cos gamma_i`` clipped to ``[-1 + 1e-12, 1 - 1e-12]``, and the
    cosines: ``(q (2, *batch), cos_gamma (2, *batch))``. Finite, with finite gradients, everywhere
    (outside the workspace the angles of the nearest reachable configuration), for smooth design
    objectives that carry the workspace margin ``1 - |cos gamma_i|`` separately (chain ``i``
    reaches ``C`` where it is >= 0)."""
    directions, cosines = _chain_angles(x, p)
    q = [
        a + branch[i] * jnp.arccos(jnp.clip(c, -1.0 + 1e-12, 1.0 - 1e-12))
        for i, (a, c) in enumerate(zip(directions, cosines))
    ]
    return jnp.stack(q), jnp.stack(cosines)


def actuator_limits(p: FiveBarParams) -> tuple[Array, Array]:
    """P4 sets no limits on the input angles."""
    return jnp.full(2, -jnp.inf), jnp.full(2, jnp.inf)


#: The mechanism of P4 (the contract of :mod:`pkmlib.mechanisms`).
mechanism = Mechanism(
    name="P4 planar five-bar",
    chain_constraint=chain_constraint,
    inverse_position=inverse_position,
    actuator_limits=actuator_limits,
    output_names=("x_C", "z_C"),
    output_units=("mm", "mm"),
    actuator_names=("phi_1", "phi_2"),
    actuator_units=("rad", "rad"),
    default_branch=PAPER_BRANCH,
)
#: The paper's mechanisms by key.
MECHANISMS = {"five-bar": mechanism}


def load_params(key: str | None = None, source=None) -> FiveBarParams:
    """The checked geometry and section of P4 from ``data/params/p4.json`` (or ``source``: another
    parameter file's name or path, or a dict of its layout); ``key`` is None or ``"five-bar"``."""
    return load_paper_params(PAPER, {"five-bar": FiveBarParams.from_dict}, key, source)


def pose(x_C, z_C) -> Array:
    """``x = (x_C, z_C)`` (mm), ``(2,)`` or ``(2, *batch)``."""
    return stack_pose(x_C, z_C)


def joint_points(x: Array, q: Array, p: FiveBarParams) -> dict[str, Array]:
    """In-plane coordinates ``(x, z)`` of A1, B1, C, B2, A2 for pose ``x`` and input angles ``q``."""
    _check_pose(mechanism, x, q)
    out = {}
    for i, (a, b) in enumerate((("A1", "B1"), ("A2", "B2"))):
        (xa, za), (l1, _) = _base(i, p), _lengths(i, p)
        out[a] = jnp.stack(jnp.broadcast_arrays(jnp.asarray(xa), jnp.asarray(za)))
        out[b] = jnp.stack([xa + l1 * jnp.cos(q[i]), za + l1 * jnp.sin(q[i])])
    out["C"] = jnp.stack([x[0], x[1]])
    return {k: out[k] for k in ("A1", "B1", "C", "B2", "A2")}


def frame_nodes(x: Array, q: Array, p: FiveBarParams) -> Array:
    """Node coordinates ``(5, 3)`` of :data:`FRAME` in 3-D, ``(x, y = 0, z)``, for one pose."""
    pts = joint_points(x, q, p)
    return jnp.stack([jnp.stack([v[0], jnp.zeros_like(v[0]), v[1]]) for v in pts.values()])


def link_rotations(nodes: Array) -> list:
    """P4's rotation ``R`` (after Fig 3) of each link of :data:`FRAME`, ``[[cos a, 0, sin a],
    [0, 1, 0], [-sin a, 0, cos a]]`` with ``a`` the link's angle in the x-z plane, as nested lists
    whose ``0`` and ``1.0`` are structural (for :meth:`pkmlib.stiffness.Frame.condensed_stiffness`): the
    in-plane and out-of-plane DOFs then never meet in the unrolled condensation."""
    out = []
    for a, b in FRAME.elements:
        d = nodes[b] - nodes[a]
        L = jnp.sqrt(d[0] ** 2 + d[2] ** 2)
        c, s = d[0] / L, d[2] / L
        out.append([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])
    return out


def stiffness_matrix(x: Array, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """The reduced 15 x 15 stiffness matrix (N, mm, rad) of the mechanism at pose ``x`` (one
    point): P4 eq (6)-(7) assembled by :class:`pkmlib.stiffness.Frame`, clamps and hinge rows removed."""
    q = mechanism.inverse(x, p, branch)
    return FRAME.reduced_matrix(frame_nodes(x, q, p), p.section)


def output_stiffness(x: Array, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """2 x 2 stiffness (N/mm) of point C in the mechanism plane, ``(x, z)``: the 15 x 15 system
    condensed onto C's in-plane displacements (only C is loaded; P4 eq (3)).

    Computed by :meth:`pkmlib.stiffness.Frame.condensed_stiffness` with P4's in-plane rotations
    (:func:`link_rotations`): the same numbers as the Schur complement of
    :func:`stiffness_matrix`, unrolled with its structure (fast and small under ``vmap``)."""
    q = mechanism.inverse(x, p, branch)
    nodes = frame_nodes(x, q, p)
    return FRAME.condensed_stiffness(nodes, p.section, C_PLANE_DOFS, link_rotations(nodes))


def node_compliance(x: Array, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH, node: int = C) -> Array:
    """Full compliance of a node of :data:`FRAME` at pose ``x``: ``(k, k)`` over the node's free
    DOFs ``FRAME.node_free_dofs(node)`` (for C, B1, B2: ``u_x, u_y, u_z`` in mm, ``theta_x,
    theta_z`` in rad; theta_y is the hinge), under loads on that node only (P4 eq (3)); units
    mm/N, mm/(N mm) = 1/N, rad/(N mm). See :meth:`pkmlib.stiffness.Frame.node_compliance`."""
    q = mechanism.inverse(x, p, branch)
    nodes = frame_nodes(x, q, p)
    return FRAME.node_compliance(nodes, p.section, node, link_rotations(nodes))


def output_compliance(x: Array, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """2 x 2 compliance (mm/N) of point C: the displacements of C under unit loads along x and z,
    solving ``K d = P`` (P4 eq (3)) with the dense 15 x 15 matrix (the paper's route, kept as the
    reference for :func:`output_stiffness`)."""
    K = stiffness_matrix(x, p, branch)
    P = jnp.zeros((K.shape[0], 2), dtype=jnp.float64).at[np.array(C_PLANE), np.arange(2)].set(1.0)
    return solve_spd(K, P)[np.array(C_PLANE)]


def worst_directions(J: Array) -> tuple[Array, Array]:
    """Unit worst force directions for each actuator and their torque per unit force.

    With ``T = -J^T P`` (P4 eq (1)) the torque of actuator ``i`` is largest when ``P`` is
    collinear with ``j_i``, the i-th row of ``J^T`` (column i of ``J``): ``|T_i|max = |j_i| |P|``
    (P4 eq (2)). Returns ``(directions (2, 2) with column i for actuator i, norms (2,))``, units
    N mm per N (= mm).
    """
    norms = jnp.sqrt(jnp.sum(J * J, axis=0))
    return J / norms[None, :], norms


def worst_direction(J: Array) -> Array:
    """The worst direction of the external force: that of the actuator loaded most per unit force,
    ``j_k / |j_k|`` with ``k = argmax_i |j_i|`` (P4 eq (2), (5)): the direction in which the
    smallest force saturates an actuator.

    Canonical, so that it does not depend on round-off or on the call path (jitted or not):
    at a tie ``|j_1| = |j_2|`` to :data:`TIE_RTOL` (e.g. on the symmetry line ``x_C = 50`` mm)
    actuator 1's direction is taken, and the sign is :func:`pkmlib.stiffness.canonical_sign` in the order
    ``(z, x)``: ``z`` component positive, or ``x`` positive when ``z`` is negligible.
    """
    u, n = worst_directions(J)
    w = jnp.where(n[0] >= n[1] * (1.0 - TIE_RTOL), u[:, 0], u[:, 1])
    return canonical_sign(w, order=(1, 0))


def force_parallelogram(J_inv: Array, T_max: float) -> Array:
    """Corners ``(4, 2)`` (N) of the set of forces the actuators can balance with ``|T_i| <= T_max``:
    ``P = -J^-T T`` (P4 eq (1)) for ``T = T_max (+1, +1), (-1, +1), (-1, -1), (+1, -1)`` in order
    (Lynch & Park [14]; P4 Fig 4). Takes ``J^-1`` (rad/mm), so no matrix is inverted."""
    J_inv = check_square("J_inv", J_inv, sizes=(2,), what="the inverse Jacobian at one pose, rad/mm")
    T_max = positive_or_nan("T_max", T_max, "a finite positive torque limit, N mm")  # traced: NaN if not
    signs = jnp.array([[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]], dtype=jnp.float64)
    return -(T_max * signs) @ J_inv


def shorter_diagonal(corners: Array) -> tuple[Array, Array]:
    """Unit direction and length (N) of the shorter diagonal of the parallelogram from
    :func:`force_parallelogram` (P4, text after Fig 4: it gives the worst force direction).
    At a tie (a rhombus' equal diagonals, to :data:`TIE_RTOL`) the first, corners 0 -> 2; sign
    as in :func:`worst_direction` (``z`` positive, else ``x``)."""
    d1, d2 = corners[0] - corners[2], corners[1] - corners[3]
    l1, l2 = jnp.sqrt(jnp.sum(d1 * d1)), jnp.sqrt(jnp.sum(d2 * d2))
    first = l1 <= l2 * (1.0 + TIE_RTOL)
    d, length = jnp.where(first, d1, d2), jnp.where(first, l1, l2)
    return canonical_sign(d / length, order=(1, 0)), length


def pose_stiffness(
    x: Array, p: FiveBarParams, T_max: float = 1.0, branch: Sequence[int] = PAPER_BRANCH
) -> dict[str, Array]:
    """Everything P4 maps at one pose ``x = (x_C, z_C)`` (mm); NaN outside the workspace.

    A pure JAX function (assemble and condense), to be ``vmap``-ed (:func:`stiffness_map`,
    :func:`pose_stiffness_jit`); differentiable with respect to ``x`` and to ``p`` (lengths and
    section). Returns ``q`` (rad), ``det_A`` (mm^2, P4's type-2 singularities at 0), ``J``
    (mm/rad), ``directions`` (unit ``j_i`` per column) and ``torque_per_force`` (``|j_i|``, mm)
    of P4 eq (2), ``worst_direction`` and ``k_worst`` (N/mm, the stiffness along it, P4 eq (5)
    and Fig 6), the shorter diagonal of the force parallelogram for ``T_max`` (N mm) and
    ``k_diagonal`` along it, ``k_min`` (the smallest directional stiffness over all in-plane
    directions, :func:`pkmlib.stiffness.extremal_stiffness`) and ``K_C`` (2 x 2, N/mm).
    """
    x = jnp.asarray(x, dtype=jnp.float64)
    q = mechanism.inverse(x, p, branch)
    inside = jnp.all(jnp.isfinite(q))
    # No LAPACK call in here (see pkmlib._stiffness.solve_spd): the 2 x 2 algebra is written out.
    J_inv = inverse_jacobian(mechanism, x, q, p)
    J = inverse_small(J_inv)
    nodes = frame_nodes(x, q, p)
    K_C = FRAME.condensed_stiffness(nodes, p.section, C_PLANE_DOFS, link_rotations(nodes))
    compliance = inverse_small(K_C)
    u, n = worst_directions(J)
    w = worst_direction(J)
    diag_u, diag_len = shorter_diagonal(force_parallelogram(J_inv, T_max))
    out = {
        "q": q,
        "det_A": det_small(A_matrix(mechanism, x, q, p)),
        "J": J,
        "directions": u,
        "torque_per_force": n,
        "worst_direction": w,
        "k_worst": 1.0 / (w @ compliance @ w),
        "diagonal_direction": diag_u,
        "diagonal_length": diag_len,
        "k_diagonal": 1.0 / (diag_u @ compliance @ diag_u),
        "k_min": extremal_stiffness(K_C)[0],
        "K_C": K_C,
    }
    return {k: jnp.where(inside, v, jnp.nan) for k, v in out.items()}


def worst_stiffness(x: Array, q: Array, p: FiveBarParams) -> Array:
    """The stiffness (N/mm) along P4's worst force direction (P4 eq (2), (5), Fig 6) at the pose
    ``x`` (one point, mm) with the input angles ``q`` (rad; e.g. :func:`inverse_position_clipped`):
    :func:`pkmlib.stiffness.directional_stiffness` of the condensed ``K_C`` along :func:`worst_direction`
    of ``J``. :func:`pose_stiffness` gives the same value as ``k_worst``, from its compliance."""
    J = inverse_small(inverse_jacobian(mechanism, x, q, p))
    nodes = frame_nodes(x, q, p)
    K_C = FRAME.condensed_stiffness(nodes, p.section, C_PLANE_DOFS, link_rotations(nodes))
    return directional_stiffness(K_C, worst_direction(J))


#: The keys of :func:`pose_stiffness`.
POSE_KEYS = (
    "q",
    "det_A",
    "J",
    "directions",
    "torque_per_force",
    "worst_direction",
    "k_worst",
    "diagonal_direction",
    "diagonal_length",
    "k_diagonal",
    "k_min",
    "K_C",
)


def _as_args(T_max, branch):
    positive_or_nan("T_max", T_max, "a finite positive torque limit, N mm")  # concrete here: ValueError
    return jnp.asarray(T_max, dtype=jnp.float64), jnp.asarray(branch, dtype=jnp.float64)


@jax.jit
def _pose_one(x, p, T_max, branch):
    return pose_stiffness(x, p, T_max, branch)


@jax.jit
def _pose_many(x, p, T_max, branch):
    return jax.vmap(pose_stiffness, in_axes=(0, None, None, None))(x, p, T_max, branch)


def pose_stiffness_jit(
    x: Array, p: FiveBarParams, T_max: float = 1.0, branch: Sequence[int] = PAPER_BRANCH
) -> dict[str, Array]:
    """:func:`pose_stiffness` compiled once per model (parameters, ``T_max`` and the branch are
    arguments, not constants): ``x`` one pose ``(2,)`` or poses ``(n, 2)`` (then every value gets
    a leading axis ``n``). Use it for probes and single points instead of eager calls."""
    x = jnp.asarray(x, dtype=jnp.float64)
    if x.ndim not in (1, 2) or x.shape[-1] != 2:
        raise ValueError(f"x must be one pose (2,) or poses (n, 2) in mm, got shape {x.shape}")
    return (_pose_one if x.ndim == 1 else _pose_many)(x, p, *_as_args(T_max, branch))


@functools.lru_cache(maxsize=None)
def _map_point(keys: tuple[str, ...]):
    """One module-level point function per key set, so :func:`pkmlib.sweep` reuses its code."""

    def at_point(point, p, T_max, branch):
        r = pose_stiffness(point, p, T_max, branch)
        return {k: r[k] for k in keys}

    return at_point


def stiffness_map(
    grid: Grid,
    p: FiveBarParams,
    T_max: float = 1.0,
    branch: Sequence[int] = PAPER_BRANCH,
    keys: Sequence[str] = POSE_KEYS,
    *,
    chunk_size: int = MAP_CHUNK,
    progress: bool | None = None,
    size_parameter: str | None = None,
) -> dict[str, np.ndarray]:
    """:func:`pose_stiffness` over a grid of ``(x_C, z_C)`` (mm): a dict of the ``keys``, each
    shaped ``grid.shape + value shape``, NaN outside the workspace (P4 Figs 5-6).

    Compiled once per grid and key set; ``p``, ``T_max`` and ``branch`` are run-time arguments of
    :func:`pkmlib.sweep`, so other parameters reuse the compiled code. ``chunk_size`` points per
    compiled call keep the temporaries small (default :data:`MAP_CHUNK`).
    """
    keys = tuple(keys)
    bad = [k for k in keys if k not in POSE_KEYS]
    if bad or not keys:
        raise ValueError(f"keys: {bad or keys} not among {POSE_KEYS}")
    return sweep(
        _map_point(keys),
        grid,
        args=(p, *_as_args(T_max, branch)),
        chunk_size=chunk_size,
        progress=progress,
        size_parameter=size_parameter,
    )


def det_A_at(point: Array, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """``det(A)`` (mm^2) at one pose: P4's type-2 singularities at 0 (module-level, for
    :func:`pkmlib.singular_crossings` with the parameters as arguments)."""
    point = jnp.asarray(point, dtype=jnp.float64)
    q = mechanism.inverse(point, p, branch)
    return det_small(A_matrix(mechanism, point, q, p))


def draw(ax, x, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH, *, label: bool = True):
    """Draw the five-bar at pose ``x`` (mm) from the same model (P4 Fig 1 style): base A1A2,
    input links A_iB_i, distal links B_iC, joints, and the input angles phi_i."""
    from matplotlib.patches import Arc

    x = jnp.asarray(x, dtype=jnp.float64)
    q = np.asarray(mechanism.inverse(x, p, branch))
    if not np.all(np.isfinite(q)):
        raise ValueError(f"pose {np.asarray(x)} is outside the workspace in working mode {tuple(branch)}")
    P = {k: np.asarray(v) for k, v in joint_points(x, q, p).items()}
    ax.plot([P["A1"][0] - 20, P["A2"][0] + 20], [0, 0], color="0.5", lw=1, ls="--", zorder=1)
    for a, b in (("A1", "B1"), ("A2", "B2")):
        ax.plot(*np.stack([P[a], P[b]]).T, color="tab:blue", lw=3, zorder=2)
        ax.plot(*np.stack([P[b], P["C"]]).T, color="k", lw=2, zorder=2)
    for name in ("A1", "A2"):
        ax.plot(*P[name], marker="^", color="0.3", ms=12, zorder=3)
    for name in ("B1", "B2", "C"):
        ax.plot(*P[name], "o", color="w", mec="k", ms=7, zorder=4)
    if label:
        for name, off in (("A1", (-18, -14)), ("A2", (6, -14)), ("B1", (-18, 6)), ("B2", (6, 6)), ("C", (6, 6))):
            ax.annotate(
                f"${name[0]}_{name[1]}$" if len(name) > 1 else f"${name}$",
                P[name],
                textcoords="offset points",
                xytext=off,
                fontsize=10,
            )
        for i, a in enumerate(("A1", "A2")):
            deg = np.rad2deg(q[i])
            ax.add_patch(Arc(P[a], 50, 50, theta1=min(0, deg), theta2=max(0, deg), color="tab:red", lw=1))
            mid = np.deg2rad(deg / 2)
            ax.annotate(
                rf"$\varphi_{i + 1}$",
                P[a] + 32 * np.array([np.cos(mid), np.sin(mid)]),
                color="tab:red",
                fontsize=10,
                ha="center",
                va="center",
            )
    ax.set_aspect("equal")
    return q


# --- The paper's printed condensed matrices (P4, after the matrix M), entry by entry -------------
# Each entry: 1-based positions as printed, the printed expression, and its value from
# (l, A, I_y, I_z, t = G I_p l^2 / E). All in units of E / l^3.
_M_COMMON = [
    (((1, 1), (7, 7)), "A l^2", lambda l, A, Iy, Iz, t: A * l**2),
    (((1, 7), (7, 1)), "-A l^2", lambda l, A, Iy, Iz, t: -A * l**2),
    (((2, 2), (8, 8)), "12 I_z", lambda l, A, Iy, Iz, t: 12 * Iz),
    (((2, 6), (2, 12), (6, 2), (12, 2)), "6 l I_z", lambda l, A, Iy, Iz, t: 6 * l * Iz),
    (((2, 8), (8, 2)), "-12 I_z", lambda l, A, Iy, Iz, t: -12 * Iz),
    (((4, 4), (10, 10)), "G I_p l^2 / E", lambda l, A, Iy, Iz, t: t),
    (((4, 10), (10, 4)), "-G I_p l^2 / E", lambda l, A, Iy, Iz, t: -t),
]
_IN_PLANE_Z = [  # bending in local x-y with I_z, DOFs 6, 8, 12 as printed for N and H
    (((6, 6),), "4 l^2 I_z", lambda l, A, Iy, Iz, t: 4 * l**2 * Iz),
    (((6, 8), (8, 6), (8, 12), (12, 8)), "-6 l I_z", lambda l, A, Iy, Iz, t: -6 * l * Iz),
    (((6, 12), (12, 6)), "2 l^2 I_z", lambda l, A, Iy, Iz, t: 2 * l**2 * Iz),
    (((12, 12),), "4 l^2 I_y", lambda l, A, Iy, Iz, t: 4 * l**2 * Iy),
]
PRINTED_MATRICES = {
    "M": _M_COMMON
    + [
        (((3, 3), (9, 9)), "12 I_y", lambda l, A, Iy, Iz, t: 12 * Iy),
        (((3, 5), (3, 11), (5, 3), (11, 3)), "-6 l I_y", lambda l, A, Iy, Iz, t: -6 * l * Iy),
        (((3, 9), (9, 3)), "-12 I_y", lambda l, A, Iy, Iz, t: -12 * Iy),
        (((5, 5), (11, 11)), "4 l^2 I_y", lambda l, A, Iy, Iz, t: 4 * l**2 * Iy),
        (((5, 9), (8, 11), (9, 5), (11, 8)), "6 l I_y", lambda l, A, Iy, Iz, t: 6 * l * Iy),
        (((5, 11), (11, 5)), "2 l^2 I_y", lambda l, A, Iy, Iz, t: 2 * l**2 * Iy),
        (((6, 6), (12, 12)), "4 l^2 I_z", lambda l, A, Iy, Iz, t: 4 * l**2 * Iz),
        (((6, 8), (8, 6), (8, 12), (12, 8)), "-6 l I_z", lambda l, A, Iy, Iz, t: -6 * l * Iz),
        (((6, 12), (12, 6)), "2 l^2 I_z", lambda l, A, Iy, Iz, t: 2 * l**2 * Iz),
    ],
    "N": _M_COMMON
    + [
        (((3, 3), (9, 9)), "3 I_y", lambda l, A, Iy, Iz, t: 3 * Iy),
        (((3, 5), (5, 3)), "-3 l I_y", lambda l, A, Iy, Iz, t: -3 * l * Iy),
        (((3, 9), (9, 3)), "-3 I_y", lambda l, A, Iy, Iz, t: -3 * Iy),
        (((5, 5),), "3 l^2 I_y", lambda l, A, Iy, Iz, t: 3 * l**2 * Iy),
        (((5, 9), (9, 5)), "3 l I_y", lambda l, A, Iy, Iz, t: 3 * l * Iy),
    ]
    + _IN_PLANE_Z,
    "H": _M_COMMON + _IN_PLANE_Z,
}
#: The released local DOFs behind each printed matrix.
PRINTED_RELEASES = {"M": (), "N": FIXED_HINGE_Y, "H": HINGE_HINGE_Y}


def printed_matrix(name: str, L: float, s: BeamSection) -> tuple[np.ndarray, dict[tuple[int, int], str]]:
    """P4's printed ``M``, ``N`` or ``H`` (units of ``E / l^3``) as a 12 x 12 array, with the printed
    expression of each nonzero entry (1-based positions). Unlisted entries are zero, as printed."""
    check_choice("name", name, tuple(PRINTED_MATRICES))
    L = check_positive("L", L)
    if not isinstance(s, BeamSection):
        raise ValueError(f"s must be a pkmlib.stiffness.BeamSection, got {type(s).__name__}: {s!r}")
    t = s.G * s.I_p * L**2 / s.E
    M = np.zeros((12, 12))
    expr = {}
    for positions, text, f in PRINTED_MATRICES[name]:
        for i, j in positions:
            M[i - 1, j - 1] = f(L, s.A, s.I_y, s.I_z, t)
            expr[(i, j)] = text
    return M, expr


def pose_criteria(
    x: Array, p: FiveBarParams, T_max: float = 1.0, branch: Sequence[int] = PAPER_BRANCH
) -> dict[str, Array]:
    """P4's pointwise criteria under the contract's name (:mod:`pkmlib.mechanisms`): its
    stiffness at one pose, :func:`pose_stiffness` (the same values)."""
    return pose_stiffness(x, p, T_max, branch)


# --- Analyses and figures of the notebook ----------------------------------------------------------
def symmetric_singular_height(p: FiveBarParams) -> float:
    """``z_C`` (mm) of the type-2 singular point on the symmetry line ``x_C = l_A1A2 / 2`` of a
    symmetric five-bar: ``B1``, ``C``, ``B2`` collinear and horizontal, so
    ``z_C = sqrt(l_A1B1^2 - (l_B1C - l_A1A2 / 2)^2)`` (P4: 122.47 mm for 175 mm links, 100 mm apart)."""
    return float(np.sqrt(p.l_A1B1**2 - (p.l_B1C - p.l_A1A2 / 2) ** 2))


def singular_curve(grid: Grid, det_A_map: np.ndarray, p: FiveBarParams, branch: Sequence[int] = PAPER_BRANCH):
    """P4's type-2 singular curve in the workspace (Fig 5): the sign changes of ``det(A)`` on the
    grid (``det_A_map``, from :func:`stiffness_map`) refined by bisection to 1e-9 mm
    (:func:`pkmlib.singular_crossings`), sorted by ``x_C``. Returns ``(roots (n, 2) mm, largest
    |sin| of the angle between B1C and CB2 at them (0: collinear), length of the curve in mm, the
    roots joined where neighbours are closer than 4 grid steps)``."""
    from .._singular import singular_crossings

    fn = jax.jit(lambda pt: det_A_at(pt, p, branch))
    roots, _ = singular_crossings(fn, grid, det_A_map, tol=1e-9)
    roots = roots[np.argsort(roots[:, 0])]
    q = np.asarray(jax.vmap(lambda x: mechanism.inverse(x, p, branch))(jnp.asarray(roots)))
    B1 = np.stack([p.l_A1B1 * np.cos(q[:, 0]), p.l_A1B1 * np.sin(q[:, 0])], axis=1)
    B2 = np.stack([p.l_A1A2 + p.l_A2B2 * np.cos(q[:, 1]), p.l_A2B2 * np.sin(q[:, 1])], axis=1)
    u1, u2 = roots - B1, B2 - roots
    sin_angle = np.abs(u1[:, 0] * u2[:, 1] - u1[:, 1] * u2[:, 0]) / (
        np.linalg.norm(u1, axis=1) * np.linalg.norm(u2, axis=1)
    )
    seg = np.linalg.norm(np.diff(roots, axis=0), axis=1)
    step = min(float(np.min(np.diff(a))) for a in grid.axes)
    return roots, float(sin_angle.max()), float(seg[seg < 4 * step].sum())


def scheme_figure(x: Array, p: FiveBarParams, branch: Sequence[int], title: str):
    """P4 Fig 1: the five-bar drawn at ``x`` (mm) by :func:`draw`. Returns ``(fig, q)``."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5))
    q = draw(ax, x, p, branch)
    ax.set_xlabel("$x$, mm")
    ax.set_ylabel("$z$, mm")
    ax.set_xlim(-190, 290)
    ax.set_ylim(-30, max(200, float(x[1]) + 40))
    ax.set_title(title)
    return fig, q


def parallelogram_figure(x, p: FiveBarParams, branch, corners, diag_u, diag_len, directions, T_max: float, title: str):
    """P4 Fig 4: the force parallelogram ``corners`` (N, :func:`force_parallelogram`) drawn at ``C``
    on the mechanism (left, 4 mm per N) and in force coordinates (right) with the corners' actuator
    torques, the shorter diagonal (red) and the worst directions ``j_1``, ``j_2`` (dashed)."""
    import matplotlib.pyplot as plt

    corners, diag_u, directions = (np.asarray(v) for v in (corners, diag_u, directions))
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 5.4), gridspec_kw={"width_ratios": [1, 1.1]})
    draw(ax0, x, p, branch)
    scale = 4.0  # mm per N
    poly = np.vstack([corners, corners[:1]])
    ax0.fill(x[0] + scale * poly[:, 0], x[1] + scale * poly[:, 1], color="tab:orange", alpha=0.35)
    ax0.plot(x[0] + scale * poly[:, 0], x[1] + scale * poly[:, 1], color="tab:orange")
    ax0.set_xlabel("$x$, mm")
    ax0.set_ylabel("$z$, mm")
    ax0.set_xlim(-190, 290)
    ax0.set_ylim(-30, max(200, float(x[1]) + 50))
    ax0.set_title("on the mechanism (4 mm per N)")
    ax1.fill(poly[:, 0], poly[:, 1], color="tab:orange", alpha=0.35)
    ax1.plot(poly[:, 0], poly[:, 1], color="tab:orange")
    span = np.abs(corners).max(axis=0)
    for (s1, s2), P in zip([(1, 1), (-1, 1), (-1, -1), (1, -1)], corners):
        out = np.sign(P + 1e-12 * span)  # label outside its corner
        ax1.annotate(
            f"T = ({s1:+d}, {s2:+d}) T$_{{max}}$",
            P,
            textcoords="offset points",
            xytext=(8 * out[0], 8 * out[1]),
            ha="left" if out[0] > 0 else "right",
            va="bottom" if out[1] > 0 else "top",
        )
    ax1.plot(
        *(0.5 * diag_len * np.outer([-1, 1], diag_u)).T,
        color="tab:red",
        lw=3,
        zorder=5,
        label=f"shorter diagonal, {float(diag_len):.2f} N",
    )
    reach = 1.6 * 0.5 * float(diag_len)
    for i, c in enumerate(("tab:blue", "tab:green")):
        u = directions[:, i]
        u = u / max(abs(u[1]), 1e-12) if abs(u[1]) > abs(u[0]) else u / abs(u[0])  # same height for both lines
        ax1.plot(
            *(reach * np.outer([-1, 1], u)).T, ls="--", color=c, lw=1.2, label=f"worst direction, actuator {i + 1}"
        )
    ax1.set_xlim(-2.0 * span[0], 2.0 * span[0])
    ax1.set_ylim(-2.2 * max(span[1], reach), 2.2 * max(span[1], reach))
    ax1.set_xlabel("$P_x$, N")
    ax1.set_ylabel("$P_z$, N")
    ax1.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=1, frameon=False)
    ax1.set_title(f"forces, T$_{{max}}$ = {T_max:g} N mm\n(axes not to equal scale)")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def worst_directions_figure(grid: Grid, maps, inside, roots, x, p: FiveBarParams, quiver_step: float, title: str):
    """P4 Fig 5: the worst force direction of each actuator (``maps["directions"]``, unit ``j_i``)
    on a lattice of ``quiver_step`` (mm) over the workspace ``inside``; background: the actuator
    loaded more per unit force (blue: actuator 1); the singular curve ``roots``; the point ``x``."""
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    from ..plotting import plot_workspace_outline

    ts = maps["torque_per_force"]
    zone = np.where(inside, np.where(ts[..., 0] > ts[..., 1], 0.0, 1.0), np.nan)
    fig, ax = plt.subplots(figsize=(10, 6.4))
    ax.pcolormesh(
        grid.axes[0],
        grid.axes[1],
        zone.T,
        shading="nearest",
        cmap=ListedColormap(["#c6dbef", "#fcbba1"]),
        vmin=0,
        vmax=1,
    )
    plot_workspace_outline(ax, grid, inside)
    step = float(np.min(np.diff(grid.axes[0])))
    k = int(round(quiver_step / step))
    sub = (slice(k // 2, None, k), slice(k // 2, None, k))
    X, Z = (a[sub] for a in np.meshgrid(*grid.axes, indexing="ij"))
    for i, c in enumerate(("tab:blue", "tab:red")):
        U = maps["directions"][..., :, i][sub]
        ax.quiver(
            X,
            Z,
            U[..., 0],
            U[..., 1],
            color=c,
            pivot="middle",
            headwidth=0,
            headlength=0,
            headaxislength=0,
            scale=1.2 / (quiver_step * 0.8),
            scale_units="xy",
            width=0.0025,
            label=f"actuator {i + 1}",
        )
    ax.plot(roots[:, 0], roots[:, 1], ".", color="navy", ms=1.2)
    ax.plot([], [], "--", color="navy", label="type-2 singular curve")
    ax.plot(*np.asarray(x), "k*", ms=9, label=f"[{float(x[0]):g}, {float(x[1]):g}]")
    ax.plot([0, p.l_A1A2], [0, 0], "^", color="0.3", ms=9)
    ax.set_aspect("equal")
    ax.set_xlabel("$x_C$, mm")
    ax.set_ylabel("$z_C$, mm")
    ax.legend(loc="upper right")
    ax.set_title(title)
    return fig, zone


#: Old names, kept for one release (each use warns).
__getattr__ = deprecated_names(__name__, {"WORKING_MODE": ("PAPER_BRANCH", lambda: PAPER_BRANCH)})
