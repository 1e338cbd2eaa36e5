"""Design studies on the papers' own mechanisms (beyond the papers): smooth objectives for
:func:`pkmlib.design.maximise` and :func:`pkmlib.design.atlas`, and their exact, non-smooth counterparts;
:class:`DesignStudy` bundles one design question as the optimisers take it (built by
:func:`p2_torque_area_study`, :func:`p4_effective_workspace_study`, :func:`p4_task_study`, used by
``notebooks/design_studies.ipynb`` and ``benchmarks/design.py``).

Study b, P2's planar 3-RRR (Laryushkin 2019): which link lengths and platform size maximise the
area of the workspace where the largest actuator torque for an external force of given size
and unknown direction (P2 eq (6), (8)) stays under a bound, for the same base triangle (the same
footprint) and a total link length no more than the paper's (l1 + l2 <= 0.36 m)?

Units: SI (m, rad, N, N m), as in :mod:`pkmlib.mechanisms.three_rrr`.
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from .. import _config  # noqa: F401  (float64)
from .._design import _best_seconds, _check_bounds, _derivative_modes, exact_area, penalised_min, soft_indicator
from .._grid import Grid
from .._jacobians import inverse_jacobian_rows
from .._validation import check_branch, check_positive
from ..mechanisms import three_rrr as p2

Array = Any

#: P2 design vector: (a, L, r_p) with l1 = a L, l2 = (1 - a) L (so l1 + l2 = L <= the paper's 0.36 m).
P2_DESIGN_NAMES = ("a", "L_m", "r_p_m")


def p2_params(design: Array, base: Sequence[Sequence[float]]) -> p2.ThreeRRRParams:
    """The 3-RRR geometry of a design vector ``(a, L, r_p)`` on a fixed base (a JAX pytree,
    differentiable in the design)."""
    a, L, r_p = design[0], design[1], design[2]
    return p2.ThreeRRRParams(l1=a * L, l2=(1.0 - a) * L, r_p=r_p, base=tuple(tuple(map(float, v)) for v in base))


def p2_design_of(params: p2.ThreeRRRParams) -> np.ndarray:
    """``(a, L, r_p)`` of a geometry (the inverse of :func:`p2_params`)."""
    L = float(params.l1) + float(params.l2)
    return np.array([float(params.l1) / L, L, float(params.r_p)])


def p2_torque_margins(
    design: Array,
    xy: Array,
    base,
    *,
    force: float,
    log_bound: float,
    phi: float = 0.0,
    branch: Sequence[int] = p2.PAPER_BRANCH,
) -> tuple[Array, Array]:
    """Per pose, two margins that are >= 0 inside the set whose area we want:

    - workspace margin ``min_i (1 - |cos|_i)``: every chain reaches (the closed-form inverse
      position of :func:`pkmlib.mechanisms.three_rrr.inverse_position` is real);
    - torque margin ``log(bound) - log(|e|_max)``: the largest actuator torque for a force of size
      ``force`` in any direction of the plane (P2 eq (6), (8)) is under the bound.

    ``xy`` is ``(2, N)`` (x_P, y_P) at the platform angle ``phi``. The elbow B_i is placed
    without angles, as P2's maps place it (:func:`pkmlib.mechanisms.three_rrr.pose_criteria`:
    A_iC_i rotated by the elbow angle), its cosine clipped to [-1 + 1e-12, 1 - 1e-12] here, so
    both margins and their gradients are finite everywhere (outside the workspace the torque
    margin is meaningless and the workspace margin negative). The rows of J^-1 are
    ``-(dF_i/dx) / (dF_i/dtheta_i)`` (P2 eq (3)), by forward-mode JVPs of the chain constraint
    ``F_i = |C_i - B_i|^2 - l2^2`` (P2 eq (1), :func:`pkmlib.inverse_jacobian_rows`);
    J = adj(J^-1) / det(J^-1) in closed form.
    """
    p = p2_params(design, base)
    x = p2.pose(xy[0], xy[1], jnp.asarray(phi, dtype=jnp.float64))
    q, solved, cosines = p2._at_solution(x, p, branch, clip=1e-12)
    margin = [1.0 - jnp.abs(c) for c in cosines]
    m = inverse_jacobian_rows(solved, x, q, p)  # rows of J^-1 (P2 eq (3))
    ws = jnp.minimum(jnp.minimum(margin[0], margin[1]), margin[2])

    def cof(k, j):  # cofactor of entry (k, j) of the 3x3 J^-1 (cyclic indices carry the sign)
        k1, k2, j1, j2 = (k + 1) % 3, (k + 2) % 3, (j + 1) % 3, (j + 2) % 3
        return m[k1][j1] * m[k2][j2] - m[k1][j2] * m[k2][j1]

    det = m[0][0] * cof(0, 0) + m[0][1] * cof(0, 1) + m[0][2] * cof(0, 2)
    # J = adj(J^-1) / det, so J[r, k] = cof(k, r) / det; |e_k|max = force ||(J[0,k], J[1,k])|| (eq (6), (8))
    sq = [cof(k, 0) ** 2 + cof(k, 1) ** 2 for k in range(3)]
    log_top = 0.5 * jnp.log(jnp.maximum(jnp.maximum(sq[0], sq[1]), sq[2]))
    log_torque = jnp.log(force) + log_top - jnp.log(jnp.abs(det))
    return ws, log_bound - log_torque


def p2_soft_area(
    design: Array,
    xy: Array,
    base,
    *,
    force: float,
    log_bound: float,
    cell_area: float,
    width_ws: float,
    width_torque: float,
    phi: float = 0.0,
    branch: Sequence[int] = p2.PAPER_BRANCH,
) -> Array:
    """Smooth area of ``{in the workspace and |e|_max <= bound}`` (m^2): the sum over the poses of
    ``sigmoid(ws / width_ws) * sigmoid(torque margin / width_torque)`` times ``cell_area``.
    Converges to :func:`p2_exact_area` on the same poses as both widths go to zero."""
    ws, tq = p2_torque_margins(design, xy, base, force=force, log_bound=log_bound, phi=phi, branch=branch)
    return jnp.sum(soft_indicator(ws, width_ws) * soft_indicator(tq, width_torque)) * cell_area


def p2_torque_map(
    design: Sequence[float],
    grid: Grid,
    base,
    *,
    force: float,
    phi: float = 0.0,
    branch: Sequence[int] = p2.PAPER_BRANCH,
    size_parameter: str | None = None,
) -> np.ndarray:
    """P2's own map of the largest actuator torque (N m; :func:`pkmlib.mechanisms.three_rrr.pose_criteria`,
    P2 eq (6), (8)) for a design ``(a, L, r_p)`` over a grid of (x_P, y_P) at orientation ``phi``;
    NaN outside the workspace. One compiled sweep for every design (the geometry is an argument)."""
    from .._sweep import sweep

    p = p2_params(jnp.asarray(design, dtype=jnp.float64), base)
    return sweep(
        _p2_torque_at,
        grid,
        args=(p, jnp.float64(force), jnp.float64(phi), jnp.asarray(branch, jnp.float64)),
        size_parameter=size_parameter,
    )


def p2_exact_area(
    design: Sequence[float],
    grid: Grid,
    base,
    *,
    force: float,
    bound: float,
    phi: float = 0.0,
    branch: Sequence[int] = p2.PAPER_BRANCH,
) -> float:
    """The exact measure, independently of the smooth one: the area (m^2) of the grid points
    (x_P, y_P) at orientation ``phi`` where P2's own map (:func:`p2_torque_map`, NaN outside the
    workspace) gives a largest actuator torque <= ``bound``."""
    torque = p2_torque_map(design, grid, base, force=force, phi=phi, branch=branch)
    return exact_area(bound - torque, grid.cell_area)


def _p2_torque_at(point, p, force, phi, branch):
    x = p2.pose(point[0], point[1], phi)
    return p2.pose_criteria(x, p, V=1.0, force=force, branch=branch)["max_actuator_torque"]


# --- Study a: P4's five-bar, the effective workspace (Erastova 2020) -------------------------------

#: P4 design vector: (l_A1A2, T, c, a_1, a_2), mm and fractions: the four links total T (<= the
#: paper's 700 mm), chain 1 takes c T of it, split as l_A1B1 = a_1 c T, l_B1C = (1 - a_1) c T;
#: chain 2 takes (1 - c) T, split as l_A2B2 = a_2 (1 - c) T, l_B2C = (1 - a_2)(1 - c) T. Box
#: bounds on these five keep the total-length constraint a box.
P4_DESIGN_NAMES = ("l_A1A2_mm", "T_mm", "c", "a_1", "a_2")


def p4_design_text(design: Sequence[float]) -> str:
    """A P4 design vector as a figure's text: ``$l_{A_1A_2}$ = 100 mm, $T$ = 700 mm, $c$ = 0.5,
    $a_1$ = 0.5, $a_2$ = 0.5`` (4 significant digits, the precision the optima are stored at)."""
    b, T, c, a1, a2 = (float(v) for v in design)
    return f"$l_{{A_1A_2}}$ = {b:.4g} mm, $T$ = {T:.4g} mm, $c$ = {c:.4g}, $a_1$ = {a1:.4g}, $a_2$ = {a2:.4g}"


def p4_params(design: Array, paper) -> "FiveBarParams":  # noqa: F821 (imported in the body)
    """The five-bar of a design vector ``(l_A1A2, T, c, a_1, a_2)`` with the paper's link section."""
    from ..mechanisms import five_bar as fb

    b, T, c, a1, a2 = (design[k] for k in range(5))
    return fb.FiveBarParams(
        l_A1A2=b,
        l_A1B1=a1 * c * T,
        l_B1C=(1.0 - a1) * c * T,
        l_A2B2=a2 * (1.0 - c) * T,
        l_B2C=(1.0 - a2) * (1.0 - c) * T,
        section=paper.section,
    )


def p4_design_of(p) -> np.ndarray:
    """``(l_A1A2, T, c, a_1, a_2)`` of a five-bar (the inverse of :func:`p4_params`)."""
    c1 = float(p.l_A1B1) + float(p.l_B1C)
    c2 = float(p.l_A2B2) + float(p.l_B2C)
    T = c1 + c2
    return np.array([float(p.l_A1A2), T, c1 / T, float(p.l_A1B1) / c1, float(p.l_A2B2) / c2])


def p4_stiffness_margins(
    design: Array, xz: Array, paper, *, log_threshold: float, branch: Sequence[int] = (1, -1)
) -> tuple[Array, Array]:
    """Per pose ``xz`` (``(2, N)``, mm), the workspace margin ``min_i (1 - |cos gamma_i|)`` (both
    chains reach C) and the stiffness margin ``log(k_worst) - log(threshold)``, ``k_worst`` the
    stiffness along P4's worst force direction (P4 eq (2), (5), Fig 6) from the beam model of
    :mod:`pkmlib.mechanisms.five_bar` (:func:`~pkmlib.mechanisms.five_bar.worst_stiffness`). The
    inverse position is :func:`pkmlib.mechanisms.five_bar.inverse_position_clipped`, so
    both margins and their gradients are finite everywhere. Where the two actuators tie
    (``|j_1| = |j_2|``, e.g. on the symmetry line of a symmetric five-bar) the worst direction
    switches actuator: a kink, where the gradient is the one-sided choice of
    :func:`pkmlib.mechanisms.five_bar.worst_direction` (actuator 1)."""
    branch = jnp.asarray(check_branch(branch, 2), dtype=jnp.float64)
    return _p4_stiffness_margins_jit(design, xz, paper, log_threshold, branch)


def _p4_stiffness_margins(design, xz, paper, log_threshold, branch):
    """:func:`p4_stiffness_margins`; under ``jit`` (:data:`_p4_stiffness_margins_jit`) it is traced
    once per shape, and every optimiser, derivative mode and atlas that calls it (eagerly, under
    ``jit``, ``vmap`` or ``grad``, with any branch) reuses that trace."""
    from ..mechanisms import five_bar as fb

    p = p4_params(design, paper)

    def one(x):
        q, cos_g = fb.inverse_position_clipped(x, p, branch)
        margin = 1.0 - jnp.abs(cos_g)
        k_worst = fb.worst_stiffness(x, q, p)  # P4 eq (5): along the worst direction
        return jnp.minimum(margin[0], margin[1]), jnp.log(jnp.abs(k_worst)) - log_threshold

    return jax.vmap(one, in_axes=1)(xz)


_p4_stiffness_margins_jit = jax.jit(_p4_stiffness_margins)


def p4_soft_area(
    design: Array,
    xz: Array,
    paper,
    *,
    log_threshold: float,
    cell_area: float,
    width_ws: float,
    width_k: float,
    branch: Sequence[int] = (1, -1),
) -> Array:
    """Smooth effective-workspace area (mm^2): where both chains reach and ``k_worst >= threshold``."""
    ws, km = p4_stiffness_margins(design, xz, paper, log_threshold=log_threshold, branch=branch)
    return jnp.sum(soft_indicator(ws, width_ws) * soft_indicator(km, width_k)) * cell_area


def p4_k_worst_map(
    design: Sequence[float], grid: Grid, paper, *, branch: Sequence[int] = (1, -1), size_parameter: str | None = None
) -> np.ndarray:
    """P4's own map of the stiffness along the worst force direction (N/mm; P4 eq (5), Fig 6) for a
    design ``(l_A1A2, T, c, a_1, a_2)``: :func:`pkmlib.mechanisms.five_bar.stiffness_map`, NaN outside."""
    from ..mechanisms import five_bar as fb

    p = p4_params(jnp.asarray(design, dtype=jnp.float64), paper)
    return fb.stiffness_map(grid, p, 1.0, branch, keys=("k_worst",), size_parameter=size_parameter)["k_worst"]


def p4_exact_area(
    design: Sequence[float], grid: Grid, paper, *, threshold: float, branch: Sequence[int] = (1, -1)
) -> float:
    """The exact effective-workspace area (mm^2) on ``grid`` from P4's own map
    (:func:`p4_k_worst_map`, NaN outside): count(k_worst >= threshold) times the cell area."""
    return exact_area(p4_k_worst_map(design, grid, paper, branch=branch) - threshold, grid.cell_area)


def p4_task_min_stiffness(
    design: Array,
    xz: Array,
    paper,
    *,
    width: float,
    width_ws: float,
    penalty: float = 100.0,
    workspace_margin: float = 0.0,
    branch: Sequence[int] = (1, -1),
) -> Array:
    """Smooth smallest worst-direction stiffness over a required task region (the variant of study
    a): ``soft_min`` of ``log k_worst`` over the task poses ``xz`` (``(2, N)``, mm), minus a penalty
    ``penalty * sum softplus(-(ws - workspace_margin) / width_ws) * width_ws`` for task poses
    outside the workspace or nearer its boundary than ``workspace_margin`` (near zero when all are
    well inside; outside, the stiffness of the clipped pose means nothing). Returns log(N/mm)."""
    from .._design import soft_min

    ws, log_k = p4_stiffness_margins(design, xz, paper, log_threshold=0.0, branch=branch)
    return soft_min(log_k, width) - penalty * jnp.sum(jax.nn.softplus(-(ws - workspace_margin) / width_ws)) * width_ws


def p4_exact_task_min(design: Sequence[float], task: Grid, paper, *, branch: Sequence[int] = (1, -1)) -> float:
    """The exact counterpart: the smallest ``k_worst`` (N/mm) over the task grid from P4's own map;
    NaN when a task pose is outside the workspace (the constraint is violated)."""
    k = p4_k_worst_map(design, task, paper, branch=branch)
    return float(np.min(k)) if np.all(np.isfinite(k)) else float("nan")


# --- The studies as the optimisers take them --------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class DesignStudy:
    """One design question: the design vector, its box, the paper's design, the objectives, the
    exact measure that scores a design.

    ``objective`` is the smooth objective for :func:`pkmlib.design.maximise`; ``baseline_objective`` the
    one given to :func:`pkmlib.design.maximise_derivative_free` (the same smooth objective for the area
    studies; for the max-min study the exact minimum with an exact penalty,
    :func:`pkmlib.design.penalised_min`, which a derivative-free method does not need smoothed);
    ``values`` / ``margins`` the max-min form for :func:`pkmlib.design.maximise_min` (None for the area
    studies); ``exact(design)`` the exact, non-smooth measure on the check grid; ``info`` the
    study's grids, thresholds and paper map.
    """

    key: str
    design_names: tuple[str, ...]
    design_paper: np.ndarray
    bounds: np.ndarray
    objective: Callable[[Array], Array]
    baseline_objective: Callable[[Array], Array]
    exact: Callable[[Sequence[float]], float]
    info: dict
    values: Callable[[Array], Array] | None = None
    margins: Callable[[Array], Array] | None = None


def derivative_costs(objective: Callable[[Array], Array], x: Array, *, repeats: int = 20) -> dict[str, float]:
    """Seconds of one value of ``objective`` at ``x``, and of one value-and-gradient by forward
    mode (``len(x)`` JVPs batched with ``vmap``) and by reverse mode (``jax.value_and_grad``), the
    best of ``repeats`` calls after compilation (the choice :func:`pkmlib.design.maximise` makes with
    ``derivatives="auto"``, on record). Keys ``value``, ``forward``, ``reverse``."""
    x = jnp.asarray(x, dtype=jnp.float64)
    calls = {"value": jax.jit(objective), **_derivative_modes(objective, int(x.shape[0]))}
    out = {}
    for name, f in calls.items():
        jax.block_until_ready(f(x))  # compile
        out[name] = _best_seconds(f, x, repeats=repeats)
    return out


def _grid_points(grid: Grid) -> Array:
    return jnp.asarray(grid.points().reshape(-1, grid.ndim).T)


def p2_torque_area_study(
    paper: p2.ThreeRRRParams,
    *,
    force: float = 10.0,
    bound_quantile: float = 0.5,
    step_m: float = 0.01,
    check_step_m: float = 0.0025,
    width_workspace: float = 0.02,
    width_torque: float = 0.05,
    bounds: Sequence[Sequence[float]] = ((0.3, 0.7), (0.2, 0.36), (0.03, 0.12)),
) -> DesignStudy:
    """Study b: P2's 3-RRR, the design ``(a, L, r_p)`` maximising the area (m^2, at phi = 0) where
    the largest actuator torque for a force of size ``force`` (N) in any direction stays under a
    bound: the ``bound_quantile`` quantile of the paper design's own torque map on the check grid
    (step ``check_step_m``, m). The smooth objective (:func:`p2_soft_area`) is on a grid of step
    ``step_m``; ``info``: ``bound`` (N m), ``force`` (N), ``base``, ``check_grid``, ``grid``,
    ``torque_paper`` (the paper design's map on the check grid)."""
    base = paper.base
    design_paper = p2_design_of(paper)
    check_grid = Grid.from_ranges(x_P=(-0.25, 0.65, check_step_m), y_P=(-0.25, 0.6, check_step_m))
    torque_paper = p2_torque_map(design_paper, check_grid, base, force=force, size_parameter="p2_check_step_m")
    bound = float(np.nanquantile(torque_paper, bound_quantile))
    grid = Grid.from_ranges(x_P=(-0.25, 0.65, step_m), y_P=(-0.25, 0.6, step_m))
    xy = _grid_points(grid)
    log_bound = float(np.log(bound))

    def objective(d):
        return p2_soft_area(
            d,
            xy,
            base,
            force=force,
            log_bound=log_bound,
            cell_area=grid.cell_area,
            width_ws=width_workspace,
            width_torque=width_torque,
        )

    return DesignStudy(
        "p2_torque_area",
        P2_DESIGN_NAMES,
        design_paper,
        _check_bounds(bounds, 3),
        objective,
        objective,
        lambda d: p2_exact_area(d, check_grid, base, force=force, bound=bound),
        {
            "bound": bound,
            "force": force,
            "base": base,
            "check_grid": check_grid,
            "grid": grid,
            "torque_paper": torque_paper,
        },
    )


def p4_effective_workspace_study(
    paper,
    *,
    step_mm: float = 10.0,
    check_step_mm: float = 5.0,
    width_workspace: float = 0.02,
    width_stiffness: float = 0.1,
    bounds: Sequence[Sequence[float]] = ((20.0, 200.0), (400.0, 700.0), (0.35, 0.65), (0.3, 0.7), (0.3, 0.7)),
) -> DesignStudy:
    """Study a: P4's five-bar, the design ``(l_A1A2, T, c, a_1, a_2)`` maximising the effective
    workspace (mm^2, z_C > 0, ``k_worst`` at least the median of the paper design's map on the
    check grid of step ``check_step_mm``). The smooth objective (:func:`p4_soft_area`) is on a grid
    of step ``step_mm``, the exact area on the check grid. ``info``: ``threshold`` (N/mm),
    ``grid``, ``check_grid``, ``k_paper`` (the paper design's map on the check grid)."""
    design_paper = p4_design_of(paper)
    grid = Grid.from_ranges(x_C=(-350.0, 550.0, step_mm), z_C=(step_mm / 4, 350.0, step_mm))
    check_grid = Grid.from_ranges(x_C=(-350.0, 550.0, check_step_mm), z_C=(check_step_mm / 4, 350.0, check_step_mm))
    k_paper = p4_k_worst_map(design_paper, check_grid, paper, size_parameter="p4_check_step_mm")
    threshold = float(np.nanmedian(k_paper))
    xz = _grid_points(grid)
    log_threshold = float(np.log(threshold))

    def objective(d):
        return p4_soft_area(
            d,
            xz,
            paper,
            log_threshold=log_threshold,
            cell_area=grid.cell_area,
            width_ws=width_workspace,
            width_k=width_stiffness,
        )

    return DesignStudy(
        "p4_effective_workspace",
        P4_DESIGN_NAMES,
        design_paper,
        _check_bounds(bounds, 5),
        objective,
        objective,
        lambda d: p4_exact_area(d, check_grid, paper, threshold=threshold),
        {"threshold": threshold, "grid": grid, "check_grid": check_grid, "k_paper": k_paper},
    )


def p4_task_study(
    paper,
    *,
    task_x_C_mm: Sequence[float] = (0.0, 100.0),
    task_z_C_mm: Sequence[float] = (150.0, 250.0),
    task_step_mm: float = 10.0,
    check_step_mm: float = 2.5,
    workspace_margin: float = 0.01,
    width: float = 0.02,
    width_ws: float = 0.01,
    penalty: float = 100.0,
    bounds: Sequence[Sequence[float]] = ((20.0, 200.0), (400.0, 700.0), (0.35, 0.65), (0.3, 0.7), (0.3, 0.7)),
) -> DesignStudy:
    """The variant of study a: the five-bar maximising the smallest ``k_worst`` (N/mm) over a task
    rectangle, every task pose with workspace margin ``1 - |cos gamma_i| >= workspace_margin``
    (0.01: each elbow at least 8.1 deg from straight). Max-min form: ``values`` = ``log k_worst``
    at the task poses, ``margins`` = the workspace margins less ``workspace_margin``;
    ``objective`` = the smoothed minimum (:func:`p4_task_min_stiffness`, widths ``width``,
    ``width_ws``); ``baseline_objective`` = :func:`pkmlib.design.penalised_min` of the max-min form;
    ``exact`` = the smallest ``k_worst`` from P4's own map on the task rectangle's check grid of
    step ``check_step_mm``, finer than the optimised poses (step ``task_step_mm``), so that a
    weak pose between them counts (NaN if a task pose is unreachable). ``info``: ``task`` (the
    optimised grid), ``check_task`` (the check grid)."""
    task = Grid.from_ranges(x_C=(*task_x_C_mm, task_step_mm), z_C=(*task_z_C_mm, task_step_mm))
    check_task = Grid.from_ranges(x_C=(*task_x_C_mm, check_step_mm), z_C=(*task_z_C_mm, check_step_mm))
    xz = _grid_points(task)
    check_positive("workspace_margin", workspace_margin)

    def both(d):
        return p4_stiffness_margins(d, xz, paper, log_threshold=0.0)

    def values(d):
        return both(d)[1]

    def margins(d):
        return both(d)[0] - workspace_margin

    def objective(d):
        return p4_task_min_stiffness(
            d, xz, paper, width=width, width_ws=width_ws, penalty=penalty, workspace_margin=workspace_margin
        )

    def baseline_objective(d):
        ws, log_k = both(d)
        return penalised_min(log_k, ws - workspace_margin, penalty)

    return DesignStudy(
        "p4_task_min_stiffness",
        P4_DESIGN_NAMES,
        p4_design_of(paper),
        _check_bounds(bounds, 5),
        objective,
        baseline_objective,
        lambda d: p4_exact_task_min(d, check_task, paper),
        {"task": task, "check_task": check_task},
        values,
        margins,
    )


# --- Atlas criteria: exact indicators over two design variables ---------------------------------------


def p2_atlas_indicator(a_rp: Array, xy: Array, L: Array, log_bound: Array, base, *, force: float) -> Array:
    """P2 atlas criterion for :func:`pkmlib.design.atlas`: 1 where the pose ``xy`` (``(2, N)``, m) is in
    the workspace and the largest actuator torque is under ``exp(log_bound)`` N m, else 0, for the
    design ``(a, L, r_p)`` with ``a_rp = (a, r_p)`` varied over the atlas and ``L`` fixed."""
    ws, tq = p2_torque_margins(jnp.stack([a_rp[0], L, a_rp[1]]), xy, base, force=force, log_bound=log_bound)
    return ((ws >= 0) & (tq >= 0)).astype(jnp.float64)


def p4_atlas_indicator(b_a: Array, xz: Array, T: Array, c: Array, log_threshold: Array, paper) -> Array:
    """P4 atlas criterion for :func:`pkmlib.design.atlas`: 1 where the pose ``xz`` (``(2, N)``, mm) is in
    the effective workspace (reachable, ``k_worst >= exp(log_threshold)`` N/mm) of the symmetric
    split five-bar ``(l_A1A2, T, c, a, a)`` with ``b_a = (l_A1A2, a)`` varied, ``T`` and ``c`` fixed."""
    ws, km = p4_stiffness_margins(jnp.stack([b_a[0], T, c, b_a[1], b_a[1]]), xz, paper, log_threshold=log_threshold)
    return ((ws >= 0) & (km >= 0)).astype(jnp.float64)


# --- Atlases over two design variables, and the page's tables --------------------------------------


def p2_area_atlas(
    base,
    *,
    force: float,
    bound: float,
    L: float,
    bounds_a,
    bounds_r_p,
    step_a: float,
    step_r_p: float,
    pose_step: float,
) -> tuple[Grid, Grid, np.ndarray]:
    """Study b's performance atlas: the exact area (m^2) under the torque ``bound`` (N m) at
    ``phi = 0`` for every design ``(a, L, r_p)`` of a grid over ``a`` in ``bounds_a`` (step
    ``step_a``) and ``r_p`` in ``bounds_r_p`` (m, step ``step_r_p``) at fixed ``L`` (m), counted on
    the poses of step ``pose_step`` (m) of the P2 workspace box: :func:`pkmlib.design.atlas` of
    :func:`p2_atlas_indicator`, one compiled call over designs x poses. Returns the design grid,
    the pose grid and the areas ``(n_a, n_r_p)``."""
    from .._design import atlas

    designs = Grid.from_ranges(a=(bounds_a[0], bounds_a[1], step_a), r_p_m=(bounds_r_p[0], bounds_r_p[1], step_r_p))
    poses = Grid.from_ranges(x_P=(-0.25, 0.65, pose_step), y_P=(-0.25, 0.6, pose_step))
    crit = functools.partial(p2_atlas_indicator, base=base, force=force)
    args = (jnp.float64(L), jnp.float64(np.log(bound)))
    values = atlas(crit, designs, poses, args=args, reduce=lambda v: jnp.sum(v) * poses.cell_area, progress=False)
    return designs, poses, np.asarray(values)


def p4_area_atlas(
    paper,
    grid: Grid,
    *,
    T: float,
    c: float,
    threshold: float,
    bounds_l_A1A2,
    bounds_a,
    step_l_A1A2: float,
    step_a: float,
) -> tuple[Grid, np.ndarray]:
    """Study a's performance atlas: the exact effective area (mm^2, ``k_worst >= threshold`` N/mm,
    P4 eq (5)) on ``grid`` for every symmetric five-bar ``(l_A1A2, T, c, a, a)`` of a grid over
    ``l_A1A2`` (mm) and ``a`` at fixed ``T`` (mm) and ``c``: :func:`pkmlib.design.atlas` of
    :func:`p4_atlas_indicator`. Returns the design grid and the areas ``(n_l, n_a)``."""
    from .._design import atlas

    designs = Grid.from_ranges(
        l_A1A2_mm=(bounds_l_A1A2[0], bounds_l_A1A2[1], step_l_A1A2), a=(bounds_a[0], bounds_a[1], step_a)
    )
    args = (jnp.float64(T), jnp.float64(c), jnp.float64(np.log(threshold)))
    crit = functools.partial(p4_atlas_indicator, paper=paper)
    values = atlas(crit, designs, grid, args=args, reduce=lambda v: jnp.sum(v) * grid.cell_area, progress=False)
    return designs, np.asarray(values)


def atlas_best(values: np.ndarray, designs: Grid) -> tuple[tuple[int, int], np.ndarray]:
    """The grid index of the largest value of an atlas over two design variables and the two
    design values there (first of equal maxima, in C order)."""
    i, j = np.unravel_index(int(np.argmax(values)), np.shape(values))
    return (int(i), int(j)), np.array([designs.axes[0][i], designs.axes[1][j]])


def p2_design_rows(designs: dict[str, Sequence[float]], exact: dict[str, float], reference: str = "paper") -> list:
    """Rows of study b's table: per named design ``(a, L, r_p)`` the links ``l_1 = a L`` and
    ``l_2 = (1 - a) L`` (m), ``r_p`` and ``l_1 + l_2`` (m), the exact area (cm^2) and its ratio
    to ``exact[reference]``."""
    rows = []
    for name, d in designs.items():
        l1, l2 = d[0] * d[1], (1 - d[0]) * d[1]
        rows.append(
            [name, f"{l1:.4f}", f"{l2:.4f}", f"{d[2]:.4f}", f"{l1 + l2:.4f}", f"{exact[name] * 1e4:.2f}"]
            + [f"{exact[name] / exact[reference]:.3f}"]
        )
    return rows


#: The columns of :func:`p4_design_rows` before the objective's.
P4_TABLE_HEADERS = ("design", "l_A1A2, mm", "l_A1B1", "l_B1C", "l_A2B2", "l_B2C", "total, mm")


def p4_design_rows(designs: dict[str, Sequence[float]], paper, values: dict[str, str]) -> list:
    """Rows of the P4 tables: per named design ``(l_A1A2, T, c, a_1, a_2)`` (:func:`p4_params`)
    the base distance and the four link lengths (mm, one decimal), their total, then the
    formatted objective(s) ``values[name]`` (a string or a list of strings)."""
    rows = []
    for name, d in designs.items():
        q = p4_params(jnp.asarray(d, dtype=jnp.float64), paper)
        links = [float(v) for v in (q.l_A1B1, q.l_B1C, q.l_A2B2, q.l_B2C)]
        v = values[name]
        rows.append(
            [name, f"{float(q.l_A1A2):.1f}", *(f"{x:.1f}" for x in links), f"{sum(links):.1f}"]
            + ([v] if isinstance(v, str) else list(v))
        )
    return rows


#: The names of the studies in the speed table, by key of ``benchmarks/results/design.json``.
SPEED_STUDY_NAMES = {
    "p2_torque_area": "P2 torque area (L-BFGS-B)",
    "p4_effective_workspace": "P4 effective area (L-BFGS-B)",
    "p4_task_min_stiffness": "P4 task stiffness (SQP, epigraph)",
}
#: The columns of :func:`speed_rows`.
SPEED_HEADERS = (
    "study",
    "evaluations, gradient / DE",
    "seconds, gradient / DE",
    "DE / gradient seconds",
    "vectorized DE seconds / gradient",
    "objective, gradient / DE",
    "value+gradient cost, fwd / rev (values)",
    "target",
    "DE / gradient seconds at SciPy's tolerance",
)


def speed_rows(speed: dict) -> list:
    """The speed table of the design page, one row per study of ``benchmarks/results/design.json``
    (written by ``benchmarks/design.py``): evaluations and median seconds of the gradient method
    and of DE, their ratios, the cost of a value-and-gradient in values, whether the target holds."""
    rows = []
    for key, r in speed["studies"].items():
        c = r["derivative_costs"]
        rows.append(
            [
                SPEED_STUDY_NAMES[key],
                f"{r['gradient']['evaluations']} / {r['baseline']['median_evaluations']:.0f}",
                f"{r['gradient']['median_seconds']:.3f} / {r['baseline']['median_seconds']:.3f}",
                f"{r['seconds_ratio']:.1f}x",
                f"{r['seconds_ratio_vs_vectorized']:.1f}x",
                f"{r['objective_ratio']:.4f}",
                f"{c['forward_over_value']:.1f} / {c['reverse_over_value']:.1f}",
                "met" if r["target_met"] else "not met",
                f"{r['seconds_ratio_scipy_default_tol']:.1f}x" if "seconds_ratio_scipy_default_tol" in r else "-",
            ]
        )
    return rows


# --- What the page stores: the same digits on every machine ---------------------------------------

#: Significant digits of a stored optimum (:func:`stored_design`).
OPTIMUM_DIGITS = 4
#: Significant digits of every other stored number (:func:`stored_results`).
STORED_DIGITS = 10


def _significant(v: float, digits: int) -> float:
    return float(f"{float(v):.{digits}g}")


def stored_design(design: Sequence[float], bounds: Sequence[Sequence[float]]) -> np.ndarray:
    """An optimiser's end point as the design page reports it, and evaluates it: each variable
    rounded to :data:`OPTIMUM_DIGITS` significant digits (and kept within ``bounds``).

    Why: L-BFGS-B, SLSQP and differential evolution branch on comparisons of objective values,
    so their end points and evaluation counts depend on the last bits of the objective, and those
    differ between machines and thread counts (vector width, threads, BLAS kernels). Measured on
    the P4 variant (SLSQP): 28, 29 or 62 evaluations, the optimum apart in its 7th digit. Rounded
    to 4 digits, with every measure (exact areas, stiffness, figures, atlases) computed at the
    rounded design, the page regenerates identically; the evaluation counts and seconds are
    measurements and live in ``benchmarks/results/design.json``."""
    b = _check_bounds(bounds, len(bounds))
    d = np.asarray(design, dtype=np.float64)
    if d.shape != (len(b),) or not np.all(np.isfinite(d)):
        raise ValueError(f"design must be {len(b)} finite numbers (one per bound), got {design!r}")
    return np.clip(np.array([_significant(v, OPTIMUM_DIGITS) for v in d]), b[:, 0], b[:, 1])


def stored_results(results: Any) -> Any:
    """``results`` (nested dicts, lists, NumPy arrays) with every float at :data:`STORED_DIGITS`
    significant digits: far above the last-bit differences of one computation on two machines
    (e.g. a median of a stiffness map), so the stored file is the same on both."""
    if isinstance(results, dict):
        return {k: stored_results(v) for k, v in results.items()}
    if isinstance(results, (list, tuple)):
        return [stored_results(v) for v in results]
    if isinstance(results, np.ndarray):
        return stored_results(results.tolist())
    if isinstance(results, (bool, np.bool_)):
        return bool(results)
    if isinstance(results, (int, np.integer)):
        return int(results)
    if isinstance(results, (float, np.floating)):
        return _significant(results, STORED_DIGITS) if np.isfinite(results) else float(results)
    return results


def study_record(
    question: str,
    design_names: Sequence[str],
    designs: Sequence[Sequence[float]],
    objectives: Sequence[float],
    *,
    objective_unit: str,
    method_gradient: str,
    derivatives_gradient: str,
    **conditions: Any,
) -> dict[str, Any]:
    """One study's entry of ``data/results/design.json``: the ``question``, its ``conditions``
    (the parameters of the run, names with units), the designs ``(paper, gradient, baseline)`` with
    ``design_names`` and their exact objectives (``objective_paper`` ...) in ``objective_unit``,
    and how the gradient optimum was found. Stored by :func:`stored_results` (optima at
    :data:`OPTIMUM_DIGITS` significant digits already, by :func:`stored_design`)."""
    record = {"question": question, **conditions, "design_names": list(design_names)}
    for which, d in zip(("paper", "gradient", "baseline"), designs, strict=True):
        record[f"design_{which}"] = np.asarray(d)
    for which, v in zip(("paper", "gradient", "baseline"), objectives, strict=True):
        record[f"objective_{which}"] = float(v)
    record |= {
        "objective_unit": objective_unit,
        "method_gradient": method_gradient,
        "derivatives_gradient": derivatives_gradient,
    }
    return record


# --- The page's findings, first -------------------------------------------------------------------


def findings_markdown(results: dict, speed: dict | None = None) -> str:
    """The design page's verdict box: one line per study from its ``design.json`` entry (exact
    objectives of the stored designs) and, given ``speed`` (``benchmarks/results/design.json``,
    written by ``benchmarks/design.py``), the evaluation counts and one line on the seconds ratios
    measured there (medians over repeats and seeds). The results file holds no measurements (no
    seconds, no evaluation counts: they differ between machines), so it regenerates identically."""
    studies = (
        (
            "p2_torque_area",
            "Study b, P2 3-RRR: area under the torque bound",
            1e4,
            "cm²",
            "#study-b-p2s-3-rrr-the-largest-area-of-low-actuator-torque",
        ),
        (
            "p4_effective_workspace",
            "Study a, P4 five-bar: effective workspace",
            1e-2,
            "cm²",
            "#study-a-p4s-five-bar-the-largest-effective-workspace",
        ),
        (
            "p4_task_min_stiffness",
            "Variant, P4: smallest stiffness over the task rectangle (SQP on the epigraph form)",
            1.0,
            "N/mm",
            "#the-variant-the-stiffest-design-for-a-required-task-rectangle",
        ),
    )
    lines = []
    for key, name, scale, unit, anchor in studies:
        r = results.get(key)
        if r is None:
            continue
        paper, grad, base = (r[f"objective_{w}"] * scale for w in ("paper", "gradient", "baseline"))
        verdict = "reached" if grad >= 0.99 * base else "not reached"
        measured = (speed or {}).get("studies", {}).get(key, {})
        n_grad = measured.get("gradient", {}).get("evaluations")
        n_base = measured.get("baseline", {}).get("median_evaluations")
        work = (
            f", in {n_grad} evaluations against {n_base:.0f} (`benchmarks/design.py`)"
            if n_grad is not None and n_base is not None
            else ""
        )
        lines.append(
            f"- **{name}**: paper's design {paper:.4g} {unit}; gradient optimum {grad:.4g} {unit} "
            f"({grad / paper:.3g} times the paper's) against the baseline's {base:.4g} {unit} "
            f"({grad / base - 1:+.2%}; at least the baseline's within 1 %: {verdict}){work} "
            f"([section]({anchor}))."
        )
    if speed is not None:
        ratios = [speed["studies"][key]["seconds_ratio"] for key, *_ in studies if key in speed["studies"]]
        met = sum(speed["studies"][key]["target_met"] for key, *_ in studies if key in speed["studies"])
        atlas = speed.get("p2_atlas", {}).get("pairs_per_s")
        lines.append(
            f"- **Speed** (`benchmarks/design.py`, the default parameters, medians, compilation excluded): "
            f"the gradient methods (L-BFGS-B at the page's `gradient_tol`) take {', '.join(f'{r:.0f}x' for r in ratios)} fewer seconds than "
            f"differential evolution; the target (at least the baseline's objective within 1 % in at least "
            f"10x fewer seconds) is met in {met} of {len(ratios)} studies"
            + (
                " (L-BFGS-B at SciPy's default tolerance: "
                + ", ".join(
                    f"{speed['studies'][key]['seconds_ratio_scipy_default_tol']:.1f}x"
                    for key, *_ in studies
                    if "seconds_ratio_scipy_default_tol" in speed["studies"].get(key, {})
                )
                + ")"
                if any("seconds_ratio_scipy_default_tol" in v for v in speed["studies"].values())
                else ""
            )
            + (f"; the P2 atlas evaluates {atlas:.2g}".replace("e+0", "e") + " (design, pose) pairs/s" if atlas else "")
            + " ([section](#speed-gradient-against-derivative-free))."
        )
    return "\n".join(lines) + "\n"


def write_findings(results: dict, path, speed: dict | None = None) -> None:
    """Write :func:`findings_markdown` to ``path`` atomically (the page includes it at its top)."""
    from .._atomic import atomic_write_text

    atomic_write_text(path, findings_markdown(results, speed))
