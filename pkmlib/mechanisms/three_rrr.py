"""P2: the planar 3-RRR mechanism with actuated base joints.

Laryushkin, Herald of the BMSTU, Series Mechanical Engineering, 2019, no. 1, pp. 71-83 ("P2").

Chain i (i = 0, 1, 2) has the actuated revolute joint A_i at a vertex of the base triangle, a
proximal link A_iB_i of length l1 at the actuated angle ``theta_i`` (from the x axis), a distal
link B_iC_i of length l2, and the platform joint C_i. The platform is an equilateral triangle
with centre P; output ``x = (x_P, y_P, phi)``, with C_i = P + r_p (cos(gamma_i + phi),
sin(gamma_i + phi)) and gamma_i the directions of the base vertices seen from the base centre
(so that at phi = 0 the platform triangle is a scaled copy of the base triangle).

The constraint equation of chain i (P2 eq (1) for this mechanism) is

    F_i = |C_i(x) - B_i(theta_i)|^2 - l2^2 = 0,   B_i = A_i + l1 (cos theta_i, sin theta_i).

The paper does not state the platform orientation for its maps, whether l3 is the platform's
circumradius or side, the working mode, or where the base frame is: each is a parameter here.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._pytree import pytree_dataclass
from .._criteria import _max_over_rows, actuator_efforts, max_actuator_effort, max_actuator_velocity
from .._jacobians import det_A, det_B, inverse_jacobian, matrix_inverse
from .._small_matrices import det_small
from .._mechanism import Mechanism
from .._notebook_parameters import choice, number, numbers, signs, text
from .._validation import (
    check_branch,
    check_first_axis,
    check_index,
    nan_unless_signs,
    check_finite,
    check_keys,
    check_mapping,
    check_positive,
)
from ._contract import deprecated_names, load_paper_params, stack_pose

Array = Any

#: The paper's key in the registry (:mod:`pkmlib._papers`).
PAPER = "p2"
#: The module's unit convention (SI): lengths in m, angles in rad.
UNITS = {"length": "m", "angle": "rad", "velocity": "m/s", "angular velocity": "rad/s", "force": "N", "torque": "N m"}
#: Only the linear part of the output (x_P, y_P) is considered (P2, text before eq (7)).
LINEAR_GROUP = ((0, 1),)
#: Working mode of P2's maps: sign of the elbow of each chain (see :func:`inverse_position`; P2
#: does not state it, the notebook's ``branch`` parameter chooses it).
PAPER_BRANCH = (1, 1, 1)
#: Directions of the base vertices A_1, A_2, A_3 seen from the base centre.
GAMMA = np.deg2rad([210.0, 330.0, 90.0])


#: The notebook's parameters with the paper's values and what each accepts
#: (``pk.tools.check_parameters(globals(), STUDY_PARAMETERS)``): the study conditions of P2 (text after
#: eq (6) and before eq (7)) and every choice the paper leaves open (grid, windows, reading of l3,
#: working mode, base frame, platform orientation).
STUDY_PARAMETERS = {
    "V_m_s": number(0.1, min=0.0, min_open=True, unit="m/s"),
    "force_N": number(10.0, min=0.0, min_open=True, unit="N"),
    "phi_deg": number(0.0, min=-180.0, max=180.0, unit="deg"),
    "l3_is": choice("circumradius", "circumradius", "side"),
    "branch": signs([1, 1, 1]),
    "base_origin": choice("A1", "A1", "centroid"),
    "x_P_range_m": numbers([-0.15, 0.55], shape=(2,), increasing=True, unit="m"),
    "y_P_range_m": numbers([-0.15, 0.5], shape=(2,), increasing=True, unit="m"),
    "step_m": number(0.0025, min=0.0, min_open=True, unit="m"),
    "zoom_boundary_m": numbers([0.30, 0.45, -0.11, 0.02], shape=(4,), unit="m"),
    "zoom_type2_m": numbers([0.02, 0.14, -0.06, 0.06], shape=(4,), unit="m"),
    "zoom_step_m": number(0.0005, min=0.0, min_open=True, unit="m"),
    "scheme_pose": numbers([0.2, 0.1155, 0.0], shape=(3,)),
    "params_file": text("p2"),
    "results_path": text("../data/results/p2.json", output=True),
    "figures_dir": text("../figures", output=True),
}


@pytree_dataclass(meta_fields=("base",))
@dataclasses.dataclass(frozen=True)
class ThreeRRRParams:
    """Geometry of the 3-RRR (SI units: m, rad). A JAX pytree; build with :meth:`create`.

    ``r_p`` is the platform circumradius (distance from P to each C_i); ``base`` holds the
    three actuated joints A_i as ``((x, y), ...)``.
    """

    l1: float
    l2: float
    r_p: float
    base: tuple[tuple[float, float], ...]

    @classmethod
    def create(
        cls, *, l1: float, l2: float, l3: float, base_side: float, l3_is: str = "circumradius", base_origin: str = "A1"
    ) -> "ThreeRRRParams":
        """Checked constructor from the paper's parameters.

        Args:
            l1: proximal link length (P2: 0.18 m).
            l2: distal link length (P2: 0.18 m).
            l3: the platform size the paper calls l3 (0.08 m).
            base_side: side of the equilateral base triangle (0.4 m).
            l3_is: ``"circumradius"`` (l3 = |PC_i|) or ``"side"`` (l3 = |C_iC_j|).
            base_origin: ``"A1"`` puts A_1 at (0, 0), A_2 at (side, 0), A_3 above them;
                ``"centroid"`` puts the base centre at (0, 0).
        """
        l1, l2, l3 = (check_positive(n, v) for n, v in (("l1", l1), ("l2", l2), ("l3", l3)))
        side = check_positive("base_side", base_side)
        if l3_is not in ("circumradius", "side"):
            raise ValueError(f"l3_is must be 'circumradius' or 'side', got {l3_is!r}")
        if base_origin not in ("A1", "centroid"):
            raise ValueError(f"base_origin must be 'A1' or 'centroid', got {base_origin!r}")
        r_p = l3 if l3_is == "circumradius" else l3 / np.sqrt(3.0)
        vertices = np.array([[0.0, 0.0], [side, 0.0], [side / 2, side * np.sqrt(3.0) / 2]])
        if base_origin == "centroid":
            vertices = vertices - vertices.mean(axis=0)
        base = tuple((float(a), float(b)) for a, b in vertices)
        return cls(l1=l1, l2=l2, r_p=float(r_p), base=base)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "ThreeRRRParams":
        """From ``data/params/p2.json`` (the whole file, as every mechanism's ``from_dict`` takes it) or its ``"mechanism"`` object.

        Keys ``l1_m``, ``l2_m``, ``l3_m``, ``base_side_m`` (finite positive numbers), optional
        ``l3_is`` and ``base_origin`` (see :meth:`create`). Raises ``ValueError`` naming the key for
        a missing or unknown key or a value that is not accepted (None, lists, strings, complex).
        """
        if isinstance(d, dict) and isinstance(d.get("mechanism"), dict):
            d = d["mechanism"]  # the whole file, as pkmlib.load_params("p2") gives it
        check_mapping("P2 parameters (data/params/p2.json or its 'mechanism' object)", d)
        need = ("l1_m", "l2_m", "l3_m", "base_side_m")
        check_keys("P2 parameters", d, need, ("l3_is", "base_origin"))
        v = {k: check_positive(f"P2 parameter {k}", d[k]) for k in need}
        return cls.create(
            l1=v["l1_m"],
            l2=v["l2_m"],
            l3=v["l3_m"],
            base_side=v["base_side_m"],
            l3_is=d.get("l3_is", "circumradius"),
            base_origin=d.get("base_origin", "A1"),
        )

    @property
    def base_centre(self) -> np.ndarray:
        return np.mean(np.asarray(self.base), axis=0)


def platform_joint(i: int, x: Array, p: ThreeRRRParams) -> tuple[Array, Array]:
    """C_i = P + r_p (cos(gamma_i + phi), sin(gamma_i + phi)); ``x`` is only indexed."""
    i = check_index("i", i, 3, "a chain")
    check_first_axis("x", x, 3, "x_P, y_P, phi")
    a = GAMMA[i] + x[2]
    return x[0] + p.r_p * jnp.cos(a), x[1] + p.r_p * jnp.sin(a)


def elbow(i: int, theta_i: Array, p: ThreeRRRParams) -> tuple[Array, Array]:
    """B_i = A_i + l1 (cos theta_i, sin theta_i)."""
    return _elbow_towards(i, (jnp.cos(theta_i), jnp.sin(theta_i)), p)


def _elbow_towards(i: int, u: tuple[Array, Array], p: ThreeRRRParams) -> tuple[Array, Array]:
    """B_i = A_i + l1 u, ``u`` the direction (cos theta_i, sin theta_i) of the proximal link."""
    i = check_index("i", i, 3, "a chain")
    ax, ay = p.base[i]
    return ax + p.l1 * u[0], ay + p.l1 * u[1]


def chain_constraint(i: int, x: Array, theta_i: Array, p: ThreeRRRParams) -> Array:
    """``F_i = |C_i - B_i|^2 - l2^2`` (P2 eq (1) written for the 3-RRR)."""
    return _chain_constraint_towards(i, x, (jnp.cos(theta_i), jnp.sin(theta_i)), p)


def _chain_constraint_towards(i: int, x: Array, u: tuple[Array, Array], p: ThreeRRRParams) -> Array:
    """:func:`chain_constraint` with the proximal link's direction ``u = (cos theta_i, sin theta_i)``."""
    cx, cy = platform_joint(i, x, p)
    bx, by = _elbow_towards(i, u, p)
    return (cx - bx) ** 2 + (cy - by) ** 2 - p.l2**2


def _solved_chains(
    x: Array, p: ThreeRRRParams, branch: Array, *, clip: float | None = None
) -> tuple[Array, list[tuple[Array, Array]], list[Array]]:
    """The closed-form solution of F_i = 0 for each chain: ``theta`` (``(3, *batch)``, as
    :func:`inverse_position` returns it), each proximal link's direction ``(cos theta_i,
    sin theta_i)`` computed algebraically, without a cosine or sine of ``theta_i``:
    ``u_i = R(sign_i acos c_i) d_i / |d_i|``, with ``cos = c_i`` and ``sin = sign_i sqrt(1 - c_i^2)``,
    and the cosines ``c_i`` of the elbow angles themselves (``|c_i| > 1``: chain i cannot reach).
    Angles and directions are NaN together (outside the workspace; a traced branch with entries
    other than +-1), unless ``clip``: then ``c_i`` is clipped to ``[-1 + clip, 1 - clip]`` for the
    angles and directions, finite everywhere with finite derivatives (the design studies' smooth
    measures)."""
    check_first_axis("x", x, 3, "x_P, y_P, phi")
    branch = check_branch(branch, 3)
    th, directions, cosines = [], [], []
    for i in range(3):
        cx, cy = platform_joint(i, x, p)
        dx, dy = cx - p.base[i][0], cy - p.base[i][1]
        rho = jnp.sqrt(dx * dx + dy * dy)
        c = (rho * rho + p.l1**2 - p.l2**2) / (2 * p.l1 * rho)
        cosines.append(c)
        if clip is None:
            c = jnp.where(jnp.abs(c) <= 1.0, c, jnp.nan)
        else:
            c = jnp.clip(c, -1.0 + clip, 1.0 - clip)
        th.append(jnp.arctan2(dy, dx) + branch[i] * jnp.arccos(c))
        s = branch[i] * jnp.sqrt(1.0 - c * c)
        ex, ey = dx / rho, dy / rho
        directions.append((ex * c - ey * s, ey * c + ex * s))
    directions = [tuple(nan_unless_signs(jnp.stack(u), branch)) for u in directions]
    return nan_unless_signs(jnp.stack(th), branch), directions, cosines


def inverse_position(x: Array, p: ThreeRRRParams, branch: Array) -> Array:
    """Actuated angles ``theta_i = atan2(d_i) + sign_i acos((|d|^2 + l1^2 - l2^2) / (2 l1 |d|))``
    with ``d_i = C_i - A_i`` (the closed-form solution of F_i = 0 for theta_i).

    ``branch`` holds the working mode of each chain: +1 puts the elbow B_i counter-clockwise of
    A_iC_i; each entry +1 or -1 (``ValueError`` otherwise, naming ``branch``; NaN for a
    ``jit``-traced branch with other entries). NaN where a chain
    cannot reach (|cos| > 1, outside the workspace). Shape ``(3, *batch)``.
    """
    return _solved_chains(x, p, branch)[0]


@jax.custom_jvp
def _on_unit_circle(theta: Array, u: tuple[Array, Array]) -> tuple[Array, Array]:
    """``(cos theta, sin theta)`` given as ``u``, its value from :func:`_solved_chains`: the
    derivative is that of the cosine and sine, ``(-sin theta, cos theta) dtheta``, and the
    cosine and sine are never evaluated again (XLA recomputed them in every fused loop: P2's
    maps ran at 2.3-3x numba's time). Only for a ``theta`` and ``u`` of the same solved chain."""
    return u


@_on_unit_circle.defjvp
def _on_unit_circle_jvp(primals, tangents):
    _, (c, s) = primals
    dtheta, _ = tangents  # u's own tangent is (-s, c) dtheta: u is (cos, sin) of theta
    return (c, s), (-s * dtheta, c * dtheta)


def _at_solution(
    x: Array, p: ThreeRRRParams, branch: Array, *, clip: float | None = None
) -> tuple[Array, Mechanism, list[Array]]:
    """The solved angles at ``x``, :data:`mechanism` with each F_i taking its proximal link's
    direction from the solve (:func:`_on_unit_circle`): the same F, A, B and their derivatives
    at these angles, from JAX's differentiation, without a cosine or sine of the angles; and the
    elbow cosines (:func:`_solved_chains`, with its ``clip``).
    ``branch`` None is the mechanism's default, as :meth:`pkmlib.Mechanism.inverse` takes it."""
    q, directions, cosines = _solved_chains(x, p, mechanism.default_branch if branch is None else branch, clip=clip)

    def solved_chain_constraint(i, x_, theta_i, p_):
        return _chain_constraint_towards(i, x_, _on_unit_circle(theta_i, directions[i]), p_)

    return q, dataclasses.replace(mechanism, chain_constraint=solved_chain_constraint), cosines


def folded_chain_centres(phi: float, p: ThreeRRRParams) -> np.ndarray:
    """Platform centres P where C_i = A_i (chain i folded onto itself when l1 = l2), ``(3, 2)``.

    There the inverse position solution of chain i degenerates (det(B) = 0) inside the workspace.
    ``ValueError`` naming ``phi`` unless it is a finite number (rad).
    """
    a = GAMMA + check_finite("phi", phi)
    return np.asarray(p.base) - p.r_p * np.stack([np.cos(a), np.sin(a)], axis=1)


def actuator_limits(p: ThreeRRRParams) -> tuple[Array, Array]:
    """Revolute actuators without travel limits."""
    return jnp.full(3, -jnp.inf), jnp.full(3, jnp.inf)


#: The mechanism of P2 (the contract of :mod:`pkmlib.mechanisms`).
mechanism = Mechanism(
    name="P2 planar 3-RRR",
    chain_constraint=chain_constraint,
    inverse_position=inverse_position,
    actuator_limits=actuator_limits,
    output_names=("x_P", "y_P", "phi"),
    output_units=("m", "m", "rad"),
    actuator_names=("theta_1", "theta_2", "theta_3"),
    actuator_units=("rad", "rad", "rad"),
    default_branch=PAPER_BRANCH,
)
#: The paper's mechanisms by key.
MECHANISMS = {"3-RRR": mechanism}


def load_params(key: str | None = None, source=None) -> ThreeRRRParams:
    """The checked geometry of P2 from ``data/params/p2.json`` (or ``source``: another parameter
    file's name or path, or a dict of its layout); ``key`` is None or ``"3-RRR"``."""
    return load_paper_params(PAPER, {"3-RRR": ThreeRRRParams.from_dict}, key, source)


def pose(x_P, y_P, phi) -> Array:
    """``x = (x_P, y_P, phi)``, ``(3,)`` or ``(3, *batch)``."""
    return stack_pose(x_P, y_P, phi)


def pose_criteria(
    x: Array, p: ThreeRRRParams, *, V: float, force: float, branch: Sequence[int] = PAPER_BRANCH
) -> dict[str, Array]:
    """Everything P2 maps at pose ``x`` (``(3,)`` or ``(3, *batch)``); NaN outside the workspace.

    ``max_joint_velocity``: P2 eq (4), (7), linear output speed ``V`` only (rad/s);
    ``max_actuator_torque``: P2 eq (6), (8), force ``force`` only (N m);
    ``delta_q``, ``delta_e``: P2 eq (9), the excess over a velocity / force of the same size
    along x.
    """
    x = jnp.asarray(x, dtype=jnp.float64)
    q, solved, _ = _at_solution(x, p, branch)
    J_inv = inverse_jacobian(solved, x, q, p)
    J = matrix_inverse(J_inv)
    q_max = max_actuator_velocity(J_inv, LINEAR_GROUP, (V,))
    e_max = max_actuator_effort(J, LINEAR_GROUP, (force,))
    q_x = _abs_max_rows(jnp.einsum("ij...,j->i...", J_inv, jnp.array([V, 0.0, 0.0])))
    e_x = _abs_max_rows(actuator_efforts(J, jnp.array([force, 0.0, 0.0])))
    return {
        "q": q,
        "det_A": det_A(solved, x, q, p),
        "det_B": det_B(solved, x, q, p),
        "max_joint_velocity": q_max,
        "max_actuator_torque": e_max,
        "delta_q": q_max - q_x,
        "delta_e": e_max - e_x,
    }


def _abs_max_rows(v: Array) -> Array:
    # The largest |v_k|; its gradient is that of the first active row (see pkmlib._criteria).
    return _max_over_rows([jnp.abs(v[k]) for k in range(3)])


def distal_concurrence(x: Array, p: ThreeRRRParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """Concurrence residual of the three distal links B_iC_i at pose ``x`` (``(3,)`` or ``(3, *batch)``).

    The determinant of the three lines' homogeneous coordinates ``(n_x, n_y, -n . C_i)``, each with
    its unit normal ``n`` (so the residual has no scale of the link lengths): zero where the three
    lines meet in one point or are parallel, Bonev and Gosselin's type-2 condition for the 3-RRR
    that P2 cites for its torque curves (text after Fig 3). Independent of the autodiff det(A);
    NaN outside the workspace. Shape ``batch``.
    """
    x = jnp.asarray(x, dtype=jnp.float64)
    q = mechanism.inverse(x, p, branch)
    lines = []
    for i in range(3):
        bx, by = elbow(i, q[i], p)
        cx, cy = platform_joint(i, x, p)
        norm = jnp.hypot(cx - bx, cy - by)
        nx, ny = (by - cy) / norm, (cx - bx) / norm
        lines.append([nx, ny, -(nx * cx + ny * cy)])
    return det_small(lines)


def _criteria_rows(x: Array, p: ThreeRRRParams, branch: Sequence[int]) -> tuple[Array, Array]:
    """``J^-1`` and ``J^T`` at ``x``: the rows whose norms are P2 eq (4) and (6)."""
    q, solved, _ = _at_solution(x, p, branch)
    J_inv = inverse_jacobian(solved, x, q, p)
    return J_inv, jnp.swapaxes(matrix_inverse(J_inv), 0, 1)


def worst_direction_y(x: Array, p: ThreeRRRParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """The y components of the worst-case rows of ``J^-1`` and ``J^T`` (``(2, *batch)``).

    The worst-case row is the one with the largest norm over (x_P, y_P) (P2 eq (4), (6)); the
    worst direction is that row's direction, so its y component is zero exactly where the worst
    direction is the x axis itself: where Delta q (first entry) or Delta e (second) of P2 eq (9)
    vanishes. Its sign changes on a grid bracket those zeros (and switches of the worst chain).
    """
    x = jnp.asarray(x, dtype=jnp.float64)
    J_inv, JT = _criteria_rows(x, p, branch)
    a, b = J_inv[:, :2], JT[:, :2]
    ia = jnp.argmax(jnp.sum(a * a, axis=1), axis=0)
    ib = jnp.argmax(jnp.sum(b * b, axis=1), axis=0)
    return jnp.stack(
        [jnp.take_along_axis(a[:, 1], ia[None], axis=0)[0], jnp.take_along_axis(b[:, 1], ib[None], axis=0)[0]]
    )


def chain_switches(x: Array, p: ThreeRRRParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """Index of the chain attaining each maximum at ``x``: ``max(q')``, ``max(q'_x)``, ``max(e)``,
    ``max(e_x)`` (P2 eq (4), (6) and the fixed-direction terms of eq (9)); ``(4, *batch)`` ints.

    Where one of them changes between neighbouring grid points, the map of Delta has a seam: it is
    continuous there but its slope jumps (the straight seams of P2's Figs 4a, 4b).
    """
    x = jnp.asarray(x, dtype=jnp.float64)
    J_inv, JT = _criteria_rows(x, p, branch)
    return jnp.stack(
        [
            jnp.argmax(jnp.sum(J_inv[:, :2] ** 2, axis=1), axis=0),
            jnp.argmax(jnp.abs(J_inv[:, 0]), axis=0),
            jnp.argmax(jnp.sum(JT[:, :2] ** 2, axis=1), axis=0),
            jnp.argmax(jnp.abs(JT[:, 0]), axis=0),
        ]
    )


def switch_seams(switch: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Grid points next to a change of any of the indices ``switch`` (``grid.shape + (k,)``, e.g.
    from :func:`chain_switches` swept over a grid) between neighbours along either grid axis, both
    inside the workspace. Boolean, ``grid.shape``."""
    seams = np.zeros(inside.shape, bool)
    for k in range(switch.shape[-1]):
        s = np.where(inside, switch[..., k], -1)
        seams[:-1] |= (s[:-1] != s[1:]) & inside[:-1] & inside[1:]
        seams[:, :-1] |= (s[:, :-1] != s[:, 1:]) & inside[:, :-1] & inside[:, 1:]
    return seams


def excess_zeros(grid, phi: float, p: ThreeRRRParams, branch, *, V: float, force: float, tol: float = 1e-12):
    """The points where Delta q and Delta e of P2 eq (9) are zero to round-off, refined by bisection.

    Sign changes of :func:`worst_direction_y` on ``grid`` (platform orientation ``phi``) are refined to
    ``tol``; a refined point is a zero of Delta when Delta there is below 1e-9 of the value itself
    (otherwise it is a switch of the worst-case chain). Returns ``{"Delta q": (zeros, largest ratio,
    switches), "Delta e": ...}`` with ``zeros`` of shape ``(m, 2)``.
    """
    from .._singular import singular_crossings
    from .._sweep import sweep

    def wy_at(point):
        return worst_direction_y(pose(point[0], point[1], phi), p, branch)

    wy = sweep(wy_at, grid, size_parameter="step_m")
    out = {}
    for k, (name, delta, full) in enumerate(
        (("Delta q", "delta_q", "max_joint_velocity"), ("Delta e", "delta_e", "max_actuator_torque"))
    ):
        cand, _ = singular_crossings(lambda pt, k=k: wy_at(pt)[k], grid, wy[..., k], tol=tol)
        if len(cand):
            at = pose_criteria(pose(cand[:, 0], cand[:, 1], phi), p, V=V, force=force, branch=branch)
            rel = np.asarray(at[delta]) / np.asarray(at[full])
        else:
            rel = np.array([])
        zero = np.abs(rel) < 1e-9
        out[name] = (cand[zero], float(np.max(np.abs(rel[zero]), initial=0)), int(len(cand) - zero.sum()))
    return out


def distance_maps(grid, inside: np.ndarray, centres: np.ndarray, roots: np.ndarray) -> dict[str, np.ndarray]:
    """Distances (m) of every grid point to the singularities of P2's checks, each ``grid.shape``.

    ``edge``: to the nearest grid point outside the workspace (Euclidean distance transform on the
    grid's step); ``type1``: the smaller of that and the distance to the interior points ``centres``
    (:func:`folded_chain_centres`); ``type2``: to the nearest refined det(A) = 0 point of ``roots``
    (NaN outside, and everywhere without roots). Needs a grid of equal steps.
    """
    from scipy import ndimage, spatial

    pts = grid.points()[inside]
    edge = ndimage.distance_transform_edt(inside) * grid.steps[0]
    type1 = edge.copy()
    type1[inside] = np.minimum(type1[inside], spatial.cKDTree(centres).query(pts)[0])
    type2 = np.full(grid.shape, np.nan)
    if len(roots):
        type2[inside] = spatial.cKDTree(roots).query(pts)[0]
    return {"edge": edge, "type1": type1, "type2": type2}


def band_median(values: np.ndarray, distance: np.ndarray, inside: np.ndarray, a: float, b: float) -> float:
    """Median of the finite ``values`` at workspace points with ``a < distance <= b`` (NaN if none).

    ``ValueError`` naming ``a`` or ``b`` unless both are finite with ``a < b`` (an empty band
    would be a NaN median that says nothing about the distances)."""
    a, b = check_finite("a", a), check_finite("b", b)
    if not a < b:
        raise ValueError(f"band a < distance <= b: a must be less than b, got a = {a!r}, b = {b!r}")
    sel = inside & (distance > a) & (distance <= b) & np.isfinite(values)
    return float(np.median(values[sel])) if sel.any() else np.nan


def concurrent_crossings(roots: np.ndarray, sample: np.ndarray, phi: float, p: ThreeRRRParams, branch, rtol=1e-6):
    """Which refined det(A) = 0 crossings ``roots`` (``(m, 2)`` platform centres) are Bonev and
    Gosselin type-2 points: :func:`distal_concurrence` there below ``rtol`` times its median
    magnitude over the points ``sample`` (``(k, 2)``, e.g. part of the workspace grid).

    A crossing that fails is a jump of det(A) (e.g. across a point C_i = A_i), not a root.
    Returns ``(mask (m,), median residual)``.
    """
    res = np.abs(np.asarray(distal_concurrence(pose(roots[:, 0], roots[:, 1], phi), p, branch)))
    typical = float(
        np.nanmedian(np.abs(np.asarray(distal_concurrence(pose(sample[:, 0], sample[:, 1], phi), p, branch))))
    )
    return res < rtol * typical, typical


def nearest_distance(points: np.ndarray, to: np.ndarray) -> np.ndarray:
    """Distance from each of ``points`` (``(k, 2)``) to the nearest of ``to`` (``(m, 2)``, m >= 1)."""
    from scipy import spatial

    return spatial.cKDTree(to).query(points)[0]


def torque_map(grid, phi: float, p: ThreeRRRParams, branch, *, V: float, force: float, size_parameter=None):
    """``max(e)`` (P2 eq (6), (8)) over the platform centres of ``grid`` at orientation ``phi`` for
    the geometry ``p`` and working mode ``branch``: one compiled function for every geometry and
    mode (both are arguments of the sweep). ``grid.shape``, NaN outside the workspace."""
    from .._sweep import sweep

    def torque_at(points, params, working_mode):
        x = pose(points[0], points[1], phi)
        return pose_criteria(x, params, V=V, force=force, branch=working_mode)["max_actuator_torque"]

    mode = jnp.asarray(branch, dtype=jnp.float64)
    return sweep(torque_at, grid, args=(p, mode), batched=True, size_parameter=size_parameter)


def probes(points, phi_deg: float, p: ThreeRRRParams, branch, *, V: float, force: float) -> list[dict]:
    """The values of :func:`pose_criteria` at a few platform centres ``points`` (``[(x_P, y_P), ...]``,
    m) at orientation ``phi_deg`` (deg): one dict per point, with units in the keys."""
    px, py = (np.array(c, dtype=np.float64) for c in zip(*points))
    at = {
        k: np.asarray(v)
        for k, v in pose_criteria(pose(px, py, np.deg2rad(phi_deg)), p, V=V, force=force, branch=branch).items()
    }
    return [
        {
            "x_P_m": float(px[i]),
            "y_P_m": float(py[i]),
            "phi_deg": phi_deg,
            "theta_rad": at["q"][:, i],
            "det_A": at["det_A"][i],
            "det_B": at["det_B"][i],
            "max_joint_velocity_rad_s": at["max_joint_velocity"][i],
            "max_actuator_torque_N_m": at["max_actuator_torque"][i],
        }
        for i in range(len(px))
    ]


def draw(ax, x, p: ThreeRRRParams, branch: Sequence[int] = PAPER_BRANCH, *, label: bool = True):
    """Draw the 3-RRR at pose ``x`` (P2 Fig 1) from the same model: base triangle, links A_iB_i
    and B_iC_i, platform C_1C_2C_3 with centre P. Raises ``ValueError`` outside the workspace."""
    x = jnp.asarray(x, dtype=jnp.float64)
    q = np.asarray(mechanism.inverse(x, p, branch))
    if not np.all(np.isfinite(q)):
        raise ValueError(f"pose {np.asarray(x)} is outside the workspace for working mode {branch}")
    A = np.asarray(p.base)
    B = np.array([np.asarray(elbow(i, q[i], p)) for i in range(3)])
    C = np.array([np.asarray(platform_joint(i, x, p)) for i in range(3)])
    ax.fill(*A.T, facecolor="0.92", edgecolor="0.6", ls="--", lw=0.8, zorder=0)
    for i in range(3):
        ax.plot([A[i, 0], B[i, 0]], [A[i, 1], B[i, 1]], color="tab:blue", lw=3, zorder=2)
        ax.plot([B[i, 0], C[i, 0]], [B[i, 1], C[i, 1]], color="k", lw=2, zorder=2)
    ax.fill(*C.T, facecolor="tab:red", alpha=0.35, edgecolor="tab:red", lw=2, zorder=3)
    ax.plot(A[:, 0], A[:, 1], "s", color="tab:blue", ms=8, zorder=4)
    ax.plot(*np.vstack([B, C]).T, "o", color="w", mec="k", ms=5, zorder=4)
    ax.plot([float(x[0])], [float(x[1])], "+", color="k", ms=8, zorder=5)
    if label:
        for i in range(3):
            for P, n in ((A[i], "A"), (B[i], "B"), (C[i], "C")):
                ax.annotate(f"${n}_{i + 1}$", P, textcoords="offset points", xytext=(5, 4), fontsize=9)
        ax.annotate("$P$", np.asarray(x[:2]), textcoords="offset points", xytext=(5, -10), fontsize=9)
    ax.set_aspect("equal")
    return q


def check_study(V: float, force: float, phi: float) -> None:
    """Raise ``ValueError`` for a non-positive speed or force or a non-finite angle."""
    check_positive("V", V)
    check_positive("force", force)
    check_finite("phi", phi)


#: Old names, kept for one release (each use warns).
__getattr__ = deprecated_names(__name__, {"DEFAULT_BRANCH": ("PAPER_BRANCH", lambda: PAPER_BRANCH)})
