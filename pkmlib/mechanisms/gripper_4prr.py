"""P1: the kinematically redundant planar 4-PRR mechanism with an integrated gripper.

Ispolov, Laryushkin, Sinitsyna, BMSTU J. Mech. Eng. 2025 no. 10 ("P1").

Four PRR chains on one rail (the x axis); carriages ``q = (x_A11, x_A12, x_A21, x_A22)`` are
actuated. Chains 11, 12 meet at C1 and chains 21, 22 at C2. The output link C1C2 passes through
D at angle ``phi``; ``s = |C1 D|`` is the gripper opening. Output ``x = (x_D, y_D, phi, s)``.
From the constraint equations (P1 eq (1)) the joints are

    C1 = (x_D - s cos(phi),      y_D - s sin(phi)),
    C2 = (x_D + l_C2D cos(phi),  y_D + l_C2D sin(phi)).
"""

from __future__ import annotations

import dataclasses
from typing import Any, Sequence

import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._pytree import pytree_dataclass
from .._criteria import max_actuator_effort, max_actuator_velocity, max_gripper_force
from .._jacobians import det_A, det_B, inverse_jacobian, inverse_jacobian_rows, matrix_inverse
from .._mechanism import Mechanism, within_limits
from .._validation import (
    check_branch,
    nan_unless_signs,
    check_finite,
    check_keys,
    check_mapping,
    check_positive,
    check_range,
)
from ._contract import load_paper_params, stack_pose

Array = Any

#: The paper's key in the registry (:mod:`pkmlib._papers`).
PAPER = "p1"
#: The module's unit convention (SI): lengths in m, angles in rad.
UNITS = {"length": "m", "angle": "rad", "velocity": "m/s", "angular velocity": "rad/s", "force": "N", "torque": "N m"}

#: Output coordinate groups normed separately: (x_D, y_D) linear, phi angular, s gripper
#: (P1 eq (6) and (8)).
OUTPUT_GROUPS = ((0, 1), (2,), (3,))
#: Index of the gripper coordinate s in x.
GRIPPER_INDEX = 3
#: Branch of the inverse position solution: the upper signs of P1's solution after eq (1),
#: ``x_A = C_x + sign * sqrt(l^2 - C_y^2)`` with signs (-, +, -, +): in each lambda the two
#: carriages lie on opposite sides of its C point, chain j=1 on the left.
PAPER_BRANCH = (-1, 1, -1, 1)


@pytree_dataclass
@dataclasses.dataclass(frozen=True)
class Gripper4PRRParams:
    """Geometry of the 4-PRR mechanism (SI units: m). A JAX pytree.

    Build it with :meth:`create` or :meth:`from_dict`, which check the values.
    """

    l_B11C1: float
    l_B12C1: float
    l_B21C2: float
    l_B22C2: float
    l_C2D: float
    x_A_min: float
    x_A_max: float

    @classmethod
    def create(cls, *, l_B11C1, l_B12C1, l_B21C2, l_B22C2, l_C2D, x_A_min, x_A_max) -> "Gripper4PRRParams":
        """Checked constructor: lengths must be positive, the carriage range ``min <= max``."""
        lengths = dict(l_B11C1=l_B11C1, l_B12C1=l_B12C1, l_B21C2=l_B21C2, l_B22C2=l_B22C2, l_C2D=l_C2D)
        checked = {k: check_positive(k, v) for k, v in lengths.items()}
        lo, hi = check_range("carriage range x_A", x_A_min, x_A_max)
        return cls(**checked, x_A_min=lo, x_A_max=hi)

    @classmethod
    def from_dict(cls, d: dict[str, float]) -> "Gripper4PRRParams":
        """From ``data/params/p1.json`` (the whole file, as every mechanism's ``from_dict`` takes it) or its ``"mechanism"`` object (keys end in ``_m``).

        Raises ``ValueError`` naming the key for a missing or unknown key or a value that is not a
        finite number (None, lists, strings, complex numbers), and for non-positive lengths or
        ``x_A_min_m > x_A_max_m``.
        """
        if isinstance(d, dict) and isinstance(d.get("mechanism"), dict):
            d = d["mechanism"]  # the whole file, as pkmlib.load_params("p1") gives it
        check_mapping("P1 parameters (data/params/p1.json or its 'mechanism' object)", d)
        names = [f.name for f in dataclasses.fields(cls)]
        check_keys("P1 parameters", d, [f"{n}_m" for n in names])
        lengths = {n: check_positive(f"P1 parameter {n}_m", d[f"{n}_m"]) for n in names if n.startswith("l_")}
        ends = [check_finite(f"P1 parameter {k}", d[k]) for k in ("x_A_min_m", "x_A_max_m")]
        lo, hi = check_range("P1 carriage range (x_A_min_m, x_A_max_m)", *ends)
        return cls.create(**lengths, x_A_min=lo, x_A_max=hi)


def joint_points(x: Array, p: Gripper4PRRParams) -> tuple[Array, Array]:
    """C1 and C2 (each ``(2, *batch)``) for ``x = (x_D, y_D, phi, s)``, as in P1 eq (1)."""
    return jnp.stack(_C(0, x, p)), jnp.stack(_C(1, x, p))


def _C(lam: int, x: Array, p: Gripper4PRRParams) -> tuple[Array, Array]:
    """Coordinates of C1 (``lam = 0``) or C2 (``lam = 1``); ``x`` is only indexed."""
    x_D, y_D, phi, s = x[0], x[1], x[2], x[3]
    r = -s if lam == 0 else p.l_C2D
    return x_D + r * jnp.cos(phi), y_D + r * jnp.sin(phi)


def _length(i: int, p: Gripper4PRRParams):
    return (p.l_B11C1, p.l_B12C1, p.l_B21C2, p.l_B22C2)[i]


def chain_constraint(i: int, x: Array, q_i: Array, p: Gripper4PRRParams) -> Array:
    """``F_ij = (x_Aij - C_ix)^2 + C_iy^2 - l_BijCi^2`` (P1 eq (1)) for chain ``i`` = 0..3
    (11, 12, 21, 22); chains 11, 12 end at C1 and 21, 22 at C2."""
    cx, cy = _C(i // 2, x, p)
    return (q_i - cx) ** 2 + cy**2 - _length(i, p) ** 2


def inverse_position(x: Array, p: Gripper4PRRParams, branch: Array) -> Array:
    """Carriage coordinates ``x_Aij = C_ix + sign_ij sqrt(l_BijCi^2 - C_iy^2)`` (P1, after eq (1)).

    ``branch`` holds the four signs, each +1 or -1 (``ValueError`` otherwise, naming ``branch``; NaN
    for a ``jit``-traced branch with other entries);
    :data:`PAPER_BRANCH` is the paper's upper sign. NaN when a link cannot reach the rail or a
    carriage leaves ``[x_A_min, x_A_max]``. Shape ``(4, *batch)``.
    """
    branch = check_branch(branch, 4)
    q = []
    for i in range(4):
        cx, cy = _C(i // 2, x, p)
        radicand = _length(i, p) ** 2 - cy**2
        q.append(cx + branch[i] * jnp.sqrt(jnp.where(radicand >= 0.0, radicand, jnp.nan)))
    return nan_unless_signs(within_limits(jnp.stack(q), p.x_A_min, p.x_A_max), branch)


def actuator_limits(p: Gripper4PRRParams) -> tuple[Array, Array]:
    """Carriage travel ``[x_A_min, x_A_max]`` for each of the four carriages."""
    return jnp.full(4, p.x_A_min), jnp.full(4, p.x_A_max)


#: The mechanism of P1 (the contract of :mod:`pkmlib.mechanisms`).
mechanism = Mechanism(
    name="P1 redundant planar 4-PRR with gripper",
    chain_constraint=chain_constraint,
    inverse_position=inverse_position,
    actuator_limits=actuator_limits,
    output_names=("x_D", "y_D", "phi", "s"),
    output_units=("m", "m", "rad", "m"),
    actuator_names=("x_A11", "x_A12", "x_A21", "x_A22"),
    actuator_units=("m", "m", "m", "m"),
    default_branch=PAPER_BRANCH,
)
#: The paper's mechanisms by key.
MECHANISMS = {"4-PRR": mechanism}


def load_params(key: str | None = None, source=None) -> Gripper4PRRParams:
    """The checked geometry of P1 from ``data/params/p1.json`` (or ``source``: another parameter
    file's name or path, or a dict of its layout); ``key`` is None or ``"4-PRR"``."""
    return load_paper_params(PAPER, {"4-PRR": Gripper4PRRParams.from_dict}, key, source)


def pose(x_D, y_D, phi, s) -> Array:
    """The output vector ``x = (x_D, y_D, phi, s)`` (phi in rad), ``(4,)`` or ``(4, *batch)``."""
    return stack_pose(x_D, y_D, phi, s)


def type2_lines_y(phi: float, s: float, p: Gripper4PRRParams) -> tuple[float, float]:
    """Analytic type-2 singular lines: ``C1_y = 0`` at ``y_D = s sin(phi)`` and ``C2_y = 0`` at
    ``y_D = -l_C2D sin(phi)`` (both links of one lambda horizontal, P1 text after Fig 5)."""
    return float(s * np.sin(phi)), float(-p.l_C2D * np.sin(phi))


def type1_bounds_y(phi: float, s: float, p: Gripper4PRRParams) -> tuple[float, float]:
    """Lower and upper ``y_D`` reachable by every chain (``|C_iy| <= l_BijCi``): the type-1
    boundary where the shortest link becomes vertical (P1 Fig 3)."""
    off1, off2 = -s * np.sin(phi), p.l_C2D * np.sin(phi)
    l1 = min(p.l_B11C1, p.l_B12C1)
    l2 = min(p.l_B21C2, p.l_B22C2)
    return float(max(-l1 - off1, -l2 - off2)), float(min(l1 - off1, l2 - off2))


def pose_criteria(
    x: Array,
    p: Gripper4PRRParams,
    *,
    speeds: Sequence[float],
    loads: Sequence[float],
    F_pr: float,
    external_load: Sequence[float],
    branch: Sequence[int] = PAPER_BRANCH,
) -> dict[str, Array]:
    """Everything P1 maps at pose ``x`` (``(4,)`` or ``(4, *batch)``); NaN outside the workspace.

    Returns ``q``, ``det_A``, ``det_B``, ``max_carriage_velocity`` (P1 eq (6), speeds
    ``(v_D, omega, v_s)``), ``max_carriage_force`` (eq (8), loads ``(F_D, T, F_s)``),
    ``max_gripper_force_no_load`` and ``max_gripper_force_with_load`` (eq (13) with actuator
    force ``F_pr`` and ``external_load = (F_x, F_y, T)``).
    """
    q = mechanism.inverse(x, p, branch)
    J_inv = inverse_jacobian(mechanism, x, q, p)
    J = matrix_inverse(J_inv)
    P_ext = jnp.concatenate([jnp.asarray(external_load, dtype=jnp.float64), jnp.zeros(1)])
    return {
        "q": q,
        "det_A": det_A(mechanism, x, q, p),
        "det_B": det_B(mechanism, x, q, p),
        "max_carriage_velocity": max_actuator_velocity(J_inv, OUTPUT_GROUPS, speeds),
        "max_carriage_force": max_actuator_effort(J, OUTPUT_GROUPS, loads),
        "max_gripper_force_no_load": max_gripper_force(J, F_pr, jnp.zeros(4), GRIPPER_INDEX),
        "max_gripper_force_with_load": max_gripper_force(J, F_pr, P_ext, GRIPPER_INDEX),
    }


def max_carriage_velocity(
    x: Array, p: Gripper4PRRParams, speeds: Sequence[float], branch: Sequence[int] = PAPER_BRANCH
) -> Array:
    """P1 eq (6) alone at pose ``x`` (the Fig 2 map and the benchmark)."""
    q = mechanism.inverse(x, p, branch)
    return max_actuator_velocity(inverse_jacobian_rows(mechanism, x, q, p), OUTPUT_GROUPS, speeds)


def draw(ax, x, p: Gripper4PRRParams, branch: Sequence[int] = PAPER_BRANCH, *, label: bool = True):
    """Draw the mechanism at pose ``x`` (P1 Fig 1 style) from the same model: rail, carriages
    A_ij (with joints B_ij), links B_ijC_i, output link C1C2 with point D."""
    from matplotlib.patches import Rectangle

    x = jnp.asarray(x, dtype=jnp.float64)
    q = np.asarray(mechanism.inverse(x, p, branch))
    if not np.all(np.isfinite(q)):
        raise ValueError(f"pose {np.asarray(x)} is outside the workspace on branch {branch}")
    C1, C2 = (np.asarray(c) for c in joint_points(x, p))
    D = np.asarray(x[:2])
    ax.plot([p.x_A_min, p.x_A_max], [0, 0], color="0.4", lw=3, solid_capstyle="butt", zorder=1)
    names = ("11", "12", "21", "22")
    for k, (qk, C) in enumerate(zip(q, (C1, C1, C2, C2))):
        ax.add_patch(Rectangle((qk - 0.02, -0.012), 0.04, 0.024, color="tab:blue", zorder=3))
        ax.plot([qk, C[0]], [0, C[1]], color="k", lw=2, zorder=2)
        ax.plot([qk], [0], "o", color="w", mec="k", ms=5, zorder=4)
        if label:
            ax.annotate(
                f"$B_{{{names[k]}}}$", (qk, 0), textcoords="offset points", xytext=(0, -14), ha="center", fontsize=8
            )
    ax.plot([C1[0], C2[0]], [C1[1], C2[1]], color="tab:red", lw=3, zorder=2)
    ax.plot([C1[0], D[0]], [C1[1], D[1]], color="tab:orange", lw=5, alpha=0.6, zorder=2)
    for P, name in ((C1, "C_1"), (C2, "C_2"), (D, "D")):
        ax.plot([P[0]], [P[1]], "o", color="w", mec="k", ms=6, zorder=4)
        if label:
            ax.annotate(f"${name}$", P, textcoords="offset points", xytext=(5, 5), fontsize=9)
    ax.set_aspect("equal")
    return q
