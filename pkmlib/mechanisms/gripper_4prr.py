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
from .._notebook_parameters import not_all_zero, number, numbers, signs, text
from .._validation import (
    check_branch,
    check_first_axis,
    check_index,
    check_nonnegative,
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


#: The notebook's parameters with the paper's values and what each accepts
#: (``pk.tools.check_parameters(globals(), STUDY_PARAMETERS, STUDY_RULES)``): the study conditions of P1
#: (text after eq (6), (8) and (13)), its grid and the branch.
STUDY_PARAMETERS = {
    "s_m": number(0.14, min=0.0, min_open=True, unit="m"),
    "phi_deg": number(20.0, min=0.0, max=90.0, max_open=True, unit="deg"),
    "v_D_m_s": number(1.0, min=0.0, unit="m/s"),
    "omega_rad_s": number(1.0, min=0.0, unit="rad/s"),
    "v_s_m_s": number(1.0, min=0.0, unit="m/s"),
    "F_D_N": number(1.0, min=0.0, unit="N"),
    "T_N_m": number(1.0, min=0.0, unit="N m"),
    "F_s_N": number(1.0, min=0.0, unit="N"),
    "F_pr_N": number(100.0, min=0.0, min_open=True, unit="N"),
    "F_x_N": number(1.0, unit="N"),
    "F_y_N": number(1.0, unit="N"),
    "T_ext_N_m": number(0.1, unit="N m"),
    "x_D_range_m": numbers([0.2, 1.2], shape=(2,), increasing=True, unit="m"),
    "y_D_range_m": numbers([-0.25, 0.25], shape=(2,), increasing=True, unit="m"),
    "dx_D_m": number(0.005, min=0.0, min_open=True, unit="m"),
    "dy_D_m": number(0.0025, min=0.0, min_open=True, unit="m"),
    "branch": signs([-1, 1, -1, 1]),
    "params_file": text("p1"),
    "results_path": text("../data/results/p1.json", output=True),
    "figures_dir": text("../figures", output=True),
}
#: Conditions on several parameters: the maps of Figs 2 and 4 are weighted sums of the speeds and
#: of the loads, which must not all be zero.
STUDY_RULES = (not_all_zero("v_D_m_s", "omega_rad_s", "v_s_m_s"), not_all_zero("F_D_N", "T_N_m", "F_s_N"))


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
    check_first_axis("x", x, 4, "x_D, y_D, phi, s")
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
    i = check_index("i", i, 4, "a chain, 0..3 for 11, 12, 21, 22")
    cx, cy = _C(i // 2, x, p)
    return (q_i - cx) ** 2 + cy**2 - _length(i, p) ** 2


def inverse_position(x: Array, p: Gripper4PRRParams, branch: Array) -> Array:
    """Carriage coordinates ``x_Aij = C_ix + sign_ij sqrt(l_BijCi^2 - C_iy^2)`` (P1, after eq (1)).

    ``branch`` holds the four signs, each +1 or -1 (``ValueError`` otherwise, naming ``branch``; NaN
    for a ``jit``-traced branch with other entries);
    :data:`PAPER_BRANCH` is the paper's upper sign. NaN when a link cannot reach the rail or a
    carriage leaves ``[x_A_min, x_A_max]``. Shape ``(4, *batch)``.
    """
    check_first_axis("x", x, 4, "x_D, y_D, phi, s")
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


#: The four links in the order of q.
LINKS = ("B11C1", "B12C1", "B21C2", "B22C2")


def vertical_link_heights(phi: float, s: float, p: Gripper4PRRParams) -> dict[str, tuple[float, float]]:
    """The heights ``y_D`` at which each link stands vertical, below and above the rail:
    ``C_iy = -+ l_BijCi`` with ``C_1y = y_D - s sin(phi)`` and ``C_2y = y_D + l_C2D sin(phi)``
    (P1 eq (1); the type-1 singularities of Fig 3). ``{link: (lower, upper)}``, in m."""
    off = (-s * np.sin(phi), p.l_C2D * np.sin(phi))
    return {
        name: (float(-_length(k, p) - off[k // 2]), float(_length(k, p) - off[k // 2])) for k, name in enumerate(LINKS)
    }


def type1_bounds_y(phi: float, s: float, p: Gripper4PRRParams) -> tuple[float, float]:
    """Lower and upper ``y_D`` reachable by every chain (``|C_iy| <= l_BijCi``): the type-1
    boundary where the shortest link becomes vertical (P1 Fig 3), from :func:`vertical_link_heights`."""
    heights = vertical_link_heights(phi, s, p).values()
    return max(lo for lo, _ in heights), min(hi for _, hi in heights)


def workspace_bounds_y(phi: float, s: float, p: Gripper4PRRParams) -> tuple[float, float]:
    """:func:`type1_bounds_y`, checked: ``ValueError`` naming ``phi_deg`` and ``s_m`` (the notebook's
    parameters) when no y_D lets every link reach the rail (an empty workspace)."""
    y_low, y_high = type1_bounds_y(phi, s, p)
    if not y_low < y_high:
        raise ValueError(
            f"parameters phi_deg = {float(np.degrees(phi))!r}, s_m = {s!r}: no y_D lets every link reach "
            f"the rail (type-1 bounds {y_low:.4f} m >= {y_high:.4f} m), the workspace is empty"
        )
    return y_low, y_high


def nearest_workspace_point(grid, inside: np.ndarray, preferred) -> tuple[float, float, bool]:
    """The grid point inside the workspace nearest ``preferred`` ``(x_D, y_D)`` (m), and whether it
    differs from it (``preferred`` is outside the workspace or off the grid)."""
    pts = grid.points()[inside]
    x, y = (float(v) for v in pts[np.argmin(np.hypot(*(pts - preferred).T))])
    return x, y, bool(np.hypot(x - preferred[0], y - preferred[1]) > 1e-9)


def link_angles_to_rail_deg(x: Array, p: Gripper4PRRParams, branch: Sequence[int] = PAPER_BRANCH) -> Array:
    """Angle of each link B_ijC_i to the rail at pose ``x``, ``atan2(|C_iy|, |C_ix - x_Aij|)`` in deg
    (90 where it stands vertical, the type-1 boundary; 0 where it lies on the rail, the type-2
    lines of P1 Fig 5). ``(4, *batch)``, NaN outside the workspace."""
    x = jnp.asarray(x, dtype=jnp.float64)
    q = mechanism.inverse(x, p, branch)
    angles = []
    for k in range(4):
        cx, cy = _C(k // 2, x, p)
        angles.append(jnp.degrees(jnp.arctan2(jnp.abs(cy), jnp.abs(cx - q[k]))))
    return jnp.stack(angles)


def x_inside(y_D: float, x_axis, phi: float, s: float, p: Gripper4PRRParams, branch=PAPER_BRANCH, x_preferred=0.7):
    """The value of ``x_axis`` (the grid's x_D, m) nearest ``x_preferred`` at which the pose
    ``(x_D, y_D, phi, s)`` is inside the workspace; None if there is none."""
    x_axis = np.asarray(x_axis, dtype=np.float64)
    q = np.asarray(mechanism.inverse(pose(x_axis, np.full_like(x_axis, y_D), phi, s), p, branch))
    ok = np.all(np.isfinite(q), axis=0)
    return float(x_axis[ok][np.argmin(np.abs(x_axis[ok] - x_preferred))]) if ok.any() else None


def type2_line_crossings(roots_y: np.ndarray, y_line: float, atol: float = 1e-6) -> np.ndarray:
    """The refined det(A) = 0 crossings (their ``y_D``, found along y_D) within ``atol`` of a type-2
    line ``y_line`` (:func:`type2_lines_y`)."""
    atol = check_nonnegative("atol", atol)
    roots_y = np.asarray(roots_y, dtype=np.float64)
    return roots_y[np.abs(roots_y - y_line) < atol]


def row_medians(values: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Median over x_D of each grid row (axis 1 of ``values``, shaped like the grid) of the values
    inside the workspace; NaN for a row without finite values."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # rows outside the workspace are all NaN
        return np.nanmedian(np.where(inside, values, np.nan), axis=0)


def side_edge_points(inside: np.ndarray) -> np.ndarray:
    """Workspace points with a neighbour outside along x_D, off the top and bottom workspace rows
    (the side edges of P1 Fig 3). Boolean, the grid's shape."""
    rows_in = np.flatnonzero(inside.any(axis=0))
    left = inside & ~np.pad(inside, ((1, 0), (0, 0)))[:-1]
    right = inside & ~np.pad(inside, ((0, 1), (0, 0)))[1:]
    side = left | right
    side[:, [rows_in[0], rows_in[-1]]] = False
    return side


def row_step_factors(row_values: np.ndarray, line_rows) -> tuple[float, float]:
    """Factors between neighbouring rows of ``row_values`` (per-row medians): the smallest factor
    of a step onto or off one of the rows ``line_rows`` (the rows nearest the type-2 lines) and the
    largest factor of any other step. P1's "almost a jump" of the force at the lines (text after Fig 4)."""
    step = np.maximum(row_values[1:] / row_values[:-1], row_values[:-1] / row_values[1:])  # rows j, j + 1
    at_lines = {j - 1 for j in line_rows} | set(line_rows)
    jump = min((step[j] for j in at_lines if 0 <= j < len(step)), default=np.nan)
    other = [step[j] for j in range(len(step)) if j not in at_lines and np.isfinite(step[j])]
    return jump, max(other, default=np.nan)


def force_peak_offsets(force: np.ndarray, inside: np.ndarray, y_axis, lines: dict, band: float = 0.01) -> list:
    """In every grid column where the row nearest a line is in the workspace, the distance (m) from
    the row of the force peak within ``band`` of the line to the line itself; ``lines`` maps names to
    the refined ``y_D`` of each type-2 line. P1's "sign boundaries of det(A) coincide with the lines
    of force growth" (text after Fig 5)."""
    band = check_nonnegative("band", band)
    y_axis = np.asarray(y_axis)
    offsets = []
    for y_line in lines.values():
        j_line = int(np.argmin(np.abs(y_axis - y_line)))
        rows = np.flatnonzero(np.abs(y_axis - y_line) <= band)
        columns = inside[:, j_line]
        sub = np.where(inside[:, rows] & np.isfinite(force[:, rows]), force[:, rows], -np.inf)[columns]
        offsets += list(np.abs(y_axis[rows[np.argmax(sub, axis=1)]] - y_line))
    return offsets


def lambda_link_angle_deg(C_y: float, lengths) -> float:
    """The larger angle to the rail of the links of ``lengths`` meeting at a C point at height
    ``C_y``: ``asin(|C_y| / l)`` in deg (0 when C lies on the rail, P1 text after Fig 5)."""
    lengths = [check_positive("lengths", length) for length in lengths]
    if not lengths:
        raise ValueError("lengths must be one or more link lengths, each a finite number > 0, got none")
    return float(np.degrees(max(np.arcsin(min(1.0, abs(C_y) / length)) for length in lengths)))


def load_gap_half_width(
    x_D: float,
    y_line: float,
    phi: float,
    s: float,
    p: Gripper4PRRParams,
    *,
    F_pr: float,
    load,
    branch=PAPER_BRANCH,
    window: float = 2e-3,
    step: float = 1e-6,
):
    """Half-width (m) of the gap of P1 Fig 6b across a type-2 line at ``y_D = y_line``, ``x_D = x_D``.

    The smallest drive-force reserve ``min_k (F_pr - |e^ext_k|)`` (the numerator of P1 eq (12)) is
    sampled along y_D over ``y_line +- window`` at ``step`` and its zeros are refined by bisection;
    the gap is where it is negative. Returns ``(half-width, null)``: 0.0 with no gap (reserve positive
    throughout), NaN for a gap wider than the window; ``null`` is the uncontrolled motion of A on the
    line (:func:`pkmlib.null_direction`), whose power ``load . null`` sets the width.
    """
    from .._grid import Grid
    from .._jacobians import A_matrix, jacobian
    from .._criteria import load_reserve
    from .._singular import null_direction, singular_crossings
    from .._sweep import sweep

    load = np.asarray(load, dtype=np.float64)

    def reserve(points):
        xs = pose(x_D, points[0], phi, s)
        return load_reserve(jacobian(mechanism, xs, mechanism.inverse(xs, p, branch), p), F_pr, load, GRIPPER_INDEX)

    x = pose(x_D, y_line, phi, s)
    null = null_direction(np.asarray(A_matrix(mechanism, x, mechanism.inverse(x, p, branch), p)))
    line_grid = Grid.from_ranges(y_D=(y_line - window, y_line + window, step))
    r = sweep(reserve, line_grid, batched=True)
    edges, _ = singular_crossings(lambda pt: reserve(pt[:, None])[0], line_grid, r)
    if len(edges) == 2:
        return float(np.ptp(edges[:, 0])) / 2, null
    return (0.0 if np.nanmin(r) > 0 else np.nan), null


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


def load_sign_gaps(
    grid,
    inside,
    phi: float,
    s: float,
    p: Gripper4PRRParams,
    *,
    F_pr: float,
    load,
    lines,
    near_band: float = 0.01,
    branch=PAPER_BRANCH,
    size_parameter=None,
) -> list[list]:
    """The gap of P1 Fig 6b for each of the eight sign readings of the printed load ``load``
    (``(F_x, F_y, T)``, the paper prints no signs): the workspace points (``inside``) where
    :func:`max_gripper_force` under the load is NaN (eq (13): the drives cannot hold it).

    ``lines`` = (upper, lower) type-2 lines (m). One row per reading: the three signed values as
    text, the gap points and those within ``near_band`` of the upper and of the lower line. One
    compiled function for all eight (the load is an argument of the sweep).
    """
    from .._sweep import sweep

    def gripper_force_under(points, P_ext):
        x = pose(points[0], points[1], phi, s)
        J = matrix_inverse(inverse_jacobian(mechanism, x, mechanism.inverse(x, p, branch), p))
        return max_gripper_force(J, F_pr, jnp.concatenate([P_ext, jnp.zeros(1)]), GRIPPER_INDEX)

    y_axis = grid.axes[1]
    rows = []
    for reading in ((1, 1, 1), (1, 1, -1), (1, -1, 1), (1, -1, -1), (-1, 1, 1), (-1, 1, -1), (-1, -1, 1), (-1, -1, -1)):
        signed = np.array([sg * abs(v) for sg, v in zip(reading, load)])
        g = inside & np.isnan(
            sweep(gripper_force_under, grid, args=(signed,), batched=True, size_parameter=size_parameter)
        )
        gy = y_axis[np.nonzero(g)[1]]
        near = [int(np.sum(np.abs(gy - y) < near_band)) for y in lines]
        rows.append([f"{signed[0]:+g}", f"{signed[1]:+g}", f"{signed[2]:+g}", int(g.sum()), *near])
    return rows


def criteria_at(
    points: Array,
    *,
    phi: float,
    s: float,
    p: Gripper4PRRParams,
    speeds,
    loads,
    F_pr,
    external_load,
    branch=PAPER_BRANCH,
) -> dict[str, Array]:
    """:func:`pose_criteria` at the points ``(x_D, y_D)`` of ``points`` (``(2, *batch)``, structure of
    arrays, as :func:`pkmlib.sweep` passes them with ``batched=True``) at angle ``phi`` and opening ``s``."""
    check_first_axis("points", points, 2, "x_D, y_D")
    x = pose(points[0], points[1], phi, s)
    return pose_criteria(x, p, speeds=speeds, loads=loads, F_pr=F_pr, external_load=external_load, branch=branch)


def det_A_at(point: Array, *, phi: float, s: float, p: Gripper4PRRParams, branch=PAPER_BRANCH) -> Array:
    """det(A) at one point ``(x_D, y_D)`` (or ``(2, *batch)``) at angle ``phi`` and opening ``s``."""
    check_first_axis("point", point, 2, "x_D, y_D")
    x = pose(point[0], point[1], phi, s)
    return det_A(mechanism, x, mechanism.inverse(x, p, branch), p)


def type2_lines(roots: np.ndarray, along: np.ndarray, phi: float, s: float, p: Gripper4PRRParams, atol=1e-6) -> dict:
    """The two type-2 lines of P1 Fig 5 found again on a grid: for ``"upper"`` (C1 on the rail,
    ``y_D = s sin(phi)``) and ``"lower"`` (C2 on the rail, ``y_D = -l_C2D sin(phi)``), the analytic
    ``y_D`` (:func:`type2_lines_y`), the refined det(A) = 0 crossings found along y_D and the exact
    zeros at grid nodes (``along == -1``: a line on a grid row, where the last bits of det(A) may be
    0) within ``atol`` of it (``roots``, ``along`` from :func:`pkmlib.singular_crossings`), their mean
    (None without any), and whether the line lies on the type-1 boundary (:func:`type1_bounds_y`) or
    beyond it."""
    upper, lower = type2_lines_y(phi, s, p)
    y_low, y_high = type1_bounds_y(phi, s, p)
    out = {}
    for name, y_line in (("upper", upper), ("lower", lower)):
        close = type2_line_crossings(np.asarray(roots)[np.asarray(along) != 0, 1], y_line, atol)
        on_boundary = min(abs(y_line - y_low), abs(y_line - y_high)) < 1e-9
        out[name] = {
            "analytic": y_line,
            "crossings": close,
            "refined": float(close.mean()) if len(close) else None,
            "on_boundary": on_boundary,
            "beyond": not (y_low < y_line < y_high),
        }
    return out


def type2_line_notes(lines: dict, phi: float, s: float, p: Gripper4PRRParams) -> list[str]:
    """One sentence per line of :func:`type2_lines`: its crossings, or why the grid shows none
    (a double zero at phi = 0, the line on or beyond the type-1 boundary, or off the grid's points)."""
    y_low, y_high = type1_bounds_y(phi, s, p)
    # the angle from which the lines lie on (or beyond) the type-1 boundary, (s + l_C2D) sin(phi) = l_B21C2
    phi_boundary_deg = np.degrees(np.arcsin(min(1.0, p.l_B21C2 / (s + p.l_C2D))))
    notes = []
    for name, line in lines.items():
        close, y_line = line["crossings"], line["analytic"]
        if len(close):
            notes.append(
                f"{name} line: {len(close)} crossings, spread {np.ptp(close):.1e} m"
                + (
                    " (the line is the workspace boundary itself: the crossings lie between the boundary row "
                    "and the row inside it)"
                    if line["on_boundary"]
                    else ""
                )
            )
        elif lines["upper"]["analytic"] == lines["lower"]["analytic"]:
            notes.append(
                f"{name} line: no sign change. At phi = 0 both lines are y_D = 0 and det(A) has a double zero "
                "there (C1 and C2 on the rail at once): it touches zero without changing sign, so the grid's "
                "sign test cannot see it"
            )
        elif line["on_boundary"] or line["beyond"]:
            notes.append(
                f"{name} line: no sign change inside the workspace; y_D = {y_line:.5f} m is on or beyond its "
                f"boundary [{y_low:.5f}, {y_high:.5f}] m (for s = {s:g} m the lines reach the boundary at "
                f"phi = {phi_boundary_deg:.2f} deg)"
            )
        else:
            notes.append(
                f"{name} line: no sign change on the grid (the line falls outside the grid's workspace points)"
            )
    return notes


def probes(points, criteria) -> list[dict]:
    """The values of ``criteria`` (e.g. :func:`criteria_at` with the study's arguments bound) at a few
    points ``[(x_D, y_D), ...]`` (m): one dict per point, with units in the keys."""
    px, py = (np.array(v) for v in zip(*points))
    at = {k: np.asarray(v) for k, v in criteria(np.stack([px, py])).items()}
    names = {
        "max_carriage_velocity": "max_carriage_velocity_m_s",
        "max_carriage_force": "max_carriage_force_N",
        "max_gripper_force_no_load": "max_gripper_force_N_no_load",
        "max_gripper_force_with_load": "max_gripper_force_N_with_load",
    }
    return [
        {"x_D_m": float(px[i]), "y_D_m": float(py[i]), "q_m": at["q"][:, i], "det_A": at["det_A"][i]}
        | {new: at[old][i] for old, new in names.items()}
        for i in range(len(px))
    ]


def edge_checks(
    maps: dict, grid, inside: np.ndarray, phi: float, s: float, p: Gripper4PRRParams, branch=PAPER_BRANCH
) -> dict:
    """The numbers behind P1's statements on the workspace edges (text after Figs 2 and 3), from the
    maps of :func:`criteria_at` swept over ``grid`` (``inside``: the workspace points).

    ``rows_in`` (grid rows with workspace points), ``v_row`` (:func:`row_medians` of the max carriage
    velocity), ``edge_velocity_ratio`` (the smaller of the bottom and top rows' medians over the
    workspace median: velocity grows toward the upper and lower edges), ``top``/``bottom`` (the
    heights where B21C2 and B12C1 stand vertical, :func:`vertical_link_heights`), ``edge_offset``
    (the farther of the top and bottom rows from them, m), ``angles`` (those links' angle to the rail
    just inside, deg), ``side`` (:func:`side_edge_points`), ``travel_gap`` (the nearest carriage's
    distance to its travel limit at each side-edge point, m) and ``side_velocity_ratio`` (the largest
    max velocity on a side edge over the median of its row: 1 when the side edges are no type-1 points).
    """
    v_map = maps["max_carriage_velocity"]
    x_axis, y_axis = grid.axes
    rows_in = np.flatnonzero(inside.any(axis=0))
    v_row = row_medians(v_map, inside)
    heights = vertical_link_heights(phi, s, p)
    top, bottom = heights["B21C2"][1], heights["B12C1"][0]
    angles = {}
    for name, y, k in (("B21C2", top - 1e-12, 2), ("B12C1", bottom + 1e-12, 1)):
        xx = x_inside(y, x_axis, phi, s, p, branch)
        angles[name] = np.nan if xx is None else float(link_angles_to_rail_deg(pose(xx, y, phi, s), p, branch)[k])
    side = side_edge_points(inside)
    q_side = maps["q"][side]
    return {
        "rows_in": rows_in,
        "v_row": v_row,
        "edge_velocity_ratio": min(v_row[rows_in[0]], v_row[rows_in[-1]]) / np.nanmedian(v_map),
        "top": top,
        "bottom": bottom,
        "edge_offset": max(abs(y_axis[rows_in[-1]] - top), abs(y_axis[rows_in[0]] - bottom)),
        "angles": angles,
        "side": side,
        "travel_gap": np.minimum(q_side.min(axis=-1) - p.x_A_min, p.x_A_max - q_side.max(axis=-1)),
        "side_velocity_ratio": float(np.max(v_map[side] / v_row[np.nonzero(side)[1]])) if side.any() else np.nan,
    }


def line_checks(maps: dict, grid, inside: np.ndarray, refined: dict, gap: np.ndarray, lines, near_band=0.01) -> dict:
    """The numbers behind P1's statements on the type-2 lines (text after Figs 4-6), from the maps of
    :func:`criteria_at` over ``grid``; ``refined`` maps "upper"/"lower" to the refined line (or None),
    ``gap`` marks the workspace points without a gripper force under load, ``lines`` = (upper, lower).

    ``F_row``, ``G_row`` (:func:`row_medians` of the carriage force and the no-load gripper force),
    ``line_rows`` (the grid row nearest each refined line), ``jump_factor`` and ``largest_other_step``
    (:func:`row_step_factors`), ``peak_offsets`` (:func:`force_peak_offsets`, m), ``grip_drop`` (the
    larger no-load gripper force on those rows over the workspace median) and ``gap_near`` (gap points
    within ``near_band`` of each line).
    """
    y_axis = grid.axes[1]
    force, grip = maps["max_carriage_force"], maps["max_gripper_force_no_load"]
    F_row, G_row = row_medians(force, inside), row_medians(grip, inside)
    line_rows = {name: int(np.argmin(np.abs(y_axis - y))) for name, y in refined.items() if y is not None}
    jump_factor, largest_other_step = row_step_factors(F_row, line_rows.values())
    gap_y = y_axis[np.nonzero(gap)[1]]
    return {
        "F_row": F_row,
        "G_row": G_row,
        "line_rows": line_rows,
        "jump_factor": jump_factor,
        "largest_other_step": largest_other_step,
        "peak_offsets": force_peak_offsets(force, inside, y_axis, {name: refined[name] for name in line_rows}),
        "grip_drop": max((G_row[j] for j in line_rows.values()), default=np.nan) / np.nanmedian(grip),
        "gap_near": {name: int(np.sum(np.abs(gap_y - y) < near_band)) for name, y in zip(("upper", "lower"), lines)},
    }


def force_peak_rows(y_axis, F_row: np.ndarray, lines: dict, band: float = 0.01) -> dict:
    """For each type-2 line (``lines``: name to ``y_D``, m) the grid rows just below and above it and
    the row within ``band`` where the row medians of the force ``F_row`` peak: ``(y_line, below,
    above, peak)`` in m, the last three None where no workspace row of the grid lies within ``band``
    (P1's reading of its "about 0.0475 and -0.0725 m" on its grid, text after Fig 4)."""
    band = check_nonnegative("band", band)
    y_axis = np.asarray(y_axis)
    out = {}
    for name, y_line in lines.items():
        near = np.where(np.abs(y_axis - y_line) <= band, F_row, np.nan)
        if not np.isfinite(near).any() or not (y_axis.min() < y_line < y_axis.max()):
            out[name] = (y_line, None, None, None)
            continue
        below, above = y_axis[y_axis < y_line].max(), y_axis[y_axis > y_line].min()
        out[name] = (y_line, below, above, y_axis[int(np.nanargmax(near))])
    return out


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
                f"$B_{{{names[k]}}}$", (qk, 0), textcoords="offset points", xytext=(0, -14), ha="center", fontsize=10
            )
    ax.plot([C1[0], C2[0]], [C1[1], C2[1]], color="tab:red", lw=3, zorder=2)
    ax.plot([C1[0], D[0]], [C1[1], D[1]], color="tab:orange", lw=5, alpha=0.6, zorder=2)
    for P, name in ((C1, "C_1"), (C2, "C_2"), (D, "D")):
        ax.plot([P[0]], [P[1]], "o", color="w", mec="k", ms=6, zorder=4)
        if label:
            ax.annotate(f"${name}$", P, textcoords="offset points", xytext=(5, 5), fontsize=10)
    ax.set_aspect("equal")
    return q
