"""Design tools: smooth measures converge to the exact ones, their gradients match central
differences, the optimiser respects bounds, the atlas equals direct evaluation."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_close, central_difference_batched

import pkmlib as pk
from pkmlib.design import studies as S
from pkmlib.mechanisms import three_rrr as p2

P2 = p2.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])
BASE = P2.base
D0 = S.p2_design_of(P2)
GRID = pk.Grid.from_ranges(x_P=(-0.25, 0.65, 0.02), y_P=(-0.25, 0.6, 0.02))
XY = jnp.asarray(GRID.points().reshape(-1, 2).T)
FORCE, BOUND = 10.0, 2.3


def test_soft_indicator_converges_and_ignores_nan():
    g = jnp.array([-1.0, -1e-3, 2e-3, 0.5, jnp.nan])
    exact = np.array([0.0, 0.0, 1.0, 1.0, 0.0])
    errs = [float(np.max(np.abs(np.asarray(pk.design.soft_indicator(g, w)) - exact))) for w in (1e-2, 1e-3, 1e-4, 1e-5)]
    assert errs[-1] < 1e-8 and all(a > b for a, b in zip(errs, errs[1:])), errs
    grad = jax.grad(lambda z: jnp.sum(pk.design.soft_indicator(z, 0.1)))(g)
    assert np.all(np.isfinite(np.asarray(grad))) and float(grad[-1]) == 0.0


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "abc"])
def test_widths_are_checked(bad):
    with pytest.raises(ValueError, match="width"):
        pk.design.soft_indicator(jnp.ones(3), bad)


def test_soft_max_min_converge_within_bound_and_skip_nan():
    rng = np.random.default_rng(1)
    v = jnp.asarray(np.append(rng.normal(size=200), np.nan))
    n = 200
    for w in (1.0, 0.1, 0.01, 0.001):
        smax, smin = float(pk.design.soft_max(v, w)), float(pk.design.soft_min(v, w))
        assert np.nanmax(v) - w * np.log(n) - 1e-12 <= smax <= np.nanmax(v) + 1e-12
        assert np.nanmin(v) - 1e-12 <= smin <= np.nanmin(v) + w * np.log(n) + 1e-12
    assert abs(float(pk.design.soft_max(v, 1e-4)) - np.nanmax(v)) < 1e-3


def test_near_singularity_converges_to_the_exact_fraction():
    det = jnp.asarray(np.linspace(-1.0, 1.0, 2001)[:-1] + 2.5e-4)  # no entry at |det| = eps exactly
    exact = float(np.mean(np.abs(np.asarray(det)) < 0.1))
    errs = [abs(float(pk.design.near_singularity(det, 0.1, w)) - exact) for w in (1e-2, 1e-3, 1e-5)]
    assert errs[-1] < 1e-6 and errs[0] > errs[-1]


def test_p2_margins_match_the_p2_map():
    """The design study's torque (closed-form adjugate, algebraic elbows) equals P2's own map
    (pkmlib.mechanisms.three_rrr.pose_criteria, J by matrix inverse) and its workspace."""
    ws, tq = S.p2_torque_margins(jnp.asarray(D0), XY, BASE, force=FORCE, log_bound=0.0)
    torque_map = S.p2_torque_map(D0, GRID, BASE, force=FORCE)
    inside = np.isfinite(torque_map.ravel())
    assert np.array_equal(np.asarray(ws) >= 0, inside)
    assert_close(np.exp(-np.asarray(tq))[inside], torque_map.ravel()[inside], rtol=1e-8)


def test_p2_soft_area_converges_to_the_exact_area():
    exact = S.p2_exact_area(D0, GRID, BASE, force=FORCE, bound=BOUND)
    errs = [
        abs(
            float(
                S.p2_soft_area(
                    jnp.asarray(D0),
                    XY,
                    BASE,
                    force=FORCE,
                    log_bound=np.log(BOUND),
                    cell_area=GRID.cell_area,
                    width_ws=w,
                    width_torque=w,
                )
            )
            - exact
        )
        for w in (1e-1, 1e-2, 1e-3, 1e-5)
    ]
    assert errs[-1] < 0.01 * exact and errs[0] > errs[-1], errs


def test_gradients_of_the_smooth_measures_match_central_differences():
    def area(d):
        return S.p2_soft_area(
            d, XY, BASE, force=FORCE, log_bound=np.log(BOUND), cell_area=GRID.cell_area, width_ws=0.05, width_torque=0.2
        )

    def task_min(d):  # smallest torque margin over a task rectangle, smoothed
        box = jnp.asarray(pk.Grid.from_ranges(x_P=(0.15, 0.25, 0.01), y_P=(0.08, 0.16, 0.01)).points().reshape(-1, 2).T)
        return pk.design.soft_min(S.p2_torque_margins(d, box, BASE, force=FORCE, log_bound=np.log(BOUND))[1], 0.05)

    def singular(d):
        ws, tq = S.p2_torque_margins(d, XY, BASE, force=FORCE, log_bound=0.0)
        return pk.design.near_singularity(jnp.where(ws >= 0, jnp.exp(tq), jnp.nan), 0.05, 0.01)

    for f in (area, task_min, singular):
        g = np.asarray(jax.jit(jax.grad(f))(jnp.asarray(D0)))  # compiled, as the optimiser calls it
        fd = central_difference_batched(f, D0, h=1e-6)[0]
        assert_close(g, fd, rtol=1e-5, atol=1e-9, err_msg=f.__name__)


def test_maximise_finds_a_bounded_optimum_and_checks_its_bounds():
    target = jnp.array([0.3, 2.0])
    res = pk.design.maximise(lambda z: -jnp.sum((z - target) ** 2), [0.0, 0.0], [(-1.0, 1.0), (-1.0, 1.0)])
    assert_close(res.design, [0.3, 1.0], atol=1e-6)  # the second optimum coordinate is clipped at its bound
    assert res.evaluations > 0 and res.history[-1] >= res.history[0]
    with pytest.raises(ValueError, match="bounds"):
        pk.design.maximise(lambda z: z[0], [0.0], [(1.0, -1.0)])
    with pytest.raises(ValueError, match="x0"):
        pk.design.maximise(lambda z: z[0], [2.0], [(-1.0, 1.0)])


def test_maximise_is_the_same_in_either_derivative_mode_and_at_any_scale():
    """Forward, reverse and measured ("auto") derivatives reach the same optimum; variables of very
    different scales (the unit-box map) converge as well as unit ones."""
    target = np.array([400.0, 2e-4])
    bounds = [(0.0, 1000.0), (0.0, 1e-3)]
    span = np.array([1000.0, 1e-3])

    def f(z):
        return -jnp.sum(((z - target) / span) ** 2) - 0.1 * jnp.sum(((z - target) / span) ** 4)

    results = {m: pk.design.maximise(f, [900.0, 9e-4], bounds, derivatives=m) for m in ("forward", "reverse", "auto")}
    for mode, r in results.items():
        assert_close(r.design / span, target / span, atol=1e-7, err_msg=mode)
        assert r.derivatives in ("forward", "reverse") and r.setup_seconds > 0
    assert results["forward"].derivatives == "forward" and results["reverse"].derivatives == "reverse"
    assert results["forward"].evaluations == results["reverse"].evaluations
    with pytest.raises(ValueError, match="derivatives"):
        pk.design.maximise(f, [900.0, 9e-4], bounds, derivatives="central")
    with pytest.raises(ValueError, match="x0"):
        pk.design.maximise(f, [1.0, 2.0, 3.0], bounds)


def test_maximise_reports_each_start_of_a_multi_start():
    def f(z):  # two maxima: 1 at z = -0.5, 2 at z = 0.6
        return jnp.exp(-50 * (z[0] + 0.5) ** 2) + 2 * jnp.exp(-50 * (z[0] - 0.6) ** 2)

    r = pk.design.maximise(f, [[-0.4], [0.5], [-0.6]], [(-1.0, 1.0)])
    assert_close(r.start_objectives, [1.0, 2.0, 1.0], atol=1e-9)
    assert_close(r.design, [0.6], atol=1e-5)
    assert r.objective == pytest.approx(2.0, abs=1e-9)


def test_maximise_min_solves_a_max_min_problem_exactly():
    """max over the box [0, 2]^2 of min(x, 2 - x - y, y): x = y = 2/3 (all three tie); with the
    margin 0.5 - x >= 0: x = 0.5 and any y in [0.5, 1] (the minimum is x = 0.5). An exact, non-smooth
    optimum reached without smoothing, from several starts."""

    def values(d):
        return jnp.stack([d[0], 2.0 - d[0] - d[1], d[1]])

    bounds = [(0.0, 2.0), (0.0, 2.0)]
    r = pk.design.maximise_min(values, [0.1, 1.7], bounds)
    assert_close(r.design, [2 / 3, 2 / 3], atol=1e-7)
    assert r.objective == pytest.approx(2 / 3, abs=1e-9) and r.success and r.derivatives == "forward"
    rc = pk.design.maximise_min(values, [[0.1, 1.7], [1.9, 0.1]], bounds, margins=lambda d: jnp.atleast_1d(0.5 - d[0]))
    assert rc.design[0] == pytest.approx(0.5, abs=1e-7) and 0.5 - 1e-7 <= rc.design[1] <= 1.0 + 1e-7
    assert rc.objective == pytest.approx(0.5, abs=1e-9) and rc.success
    assert len(rc.start_objectives) == 2 and all(abs(v - 0.5) < 1e-9 for v in rc.start_objectives)
    assert rc.evaluations == len(rc.history) > 0
    # a margin no design can meet: not a success, no objective
    ri = pk.design.maximise_min(values, [1.0, 1.0], bounds, margins=lambda d: jnp.atleast_1d(-1.0 - d[0] ** 2))
    assert not ri.success and np.isnan(ri.objective) and "infeasible" in ri.message


def test_maximise_min_uses_reverse_mode_for_wide_designs():
    def values(d):  # more variables (6) than values (2): the Jacobian by reverse mode
        return jnp.stack([jnp.sum(d), 10.0 - jnp.sum(d**2)])

    r = pk.design.maximise_min(values, np.zeros(6), [(-2.0, 2.0)] * 6)
    assert r.derivatives == "reverse"
    # optimum: the two values tie, and for a given sum, sum d^2 is least with every d_i equal (a):
    # 6a = 10 - 6a^2, so a = (-1 + sqrt(1 + 40/6)) / 2
    a = (-1.0 + np.sqrt(1.0 + 4.0 * 10.0 / 6.0)) / 2.0
    assert_close(r.design, np.full(6, a), atol=1e-6)


def test_penalised_min_is_the_exact_penalty_form():
    assert float(pk.design.penalised_min(jnp.array([3.0, 1.0, 2.0]))) == 1.0
    assert float(
        pk.design.penalised_min(jnp.array([3.0, 1.0, 2.0]), jnp.array([0.5, -0.2, 0.0]), 100.0)
    ) == pytest.approx(-19.0)
    with pytest.raises(ValueError, match="penalty"):
        pk.design.penalised_min(jnp.ones(2), jnp.ones(2), 0.0)


@pytest.mark.parametrize("vectorized", [False, True])
def test_derivative_free_baseline_finds_the_optimum(vectorized):
    r = pk.design.maximise_derivative_free(
        lambda z: -jnp.sum((z - jnp.array([0.3, -0.2])) ** 2), [(-1.0, 1.0)] * 2, seed=1, vectorized=vectorized
    )
    assert_close(r.design, [0.3, -0.2], atol=2e-2)
    assert r.evaluations == len(r.history) >= 30 and r.derivatives == "none"


def test_task_study_max_min_form_agrees_with_p4s_own_map():
    """The variant's max-min form (log k at the task poses by the design study's margins) gives the
    exact check's minimum (P4's own map, pkmlib.mechanisms.five_bar.stiffness_map) at the paper's
    design, and the margins hold there (the paper's five-bar reaches the task rectangle)."""
    from pkmlib.mechanisms import five_bar as fb

    p4 = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    study = S.p4_task_study(p4, check_step_mm=10.0)  # the check on the optimised poses themselves
    d = jnp.asarray(study.design_paper)
    assert float(np.exp(np.min(np.asarray(study.values(d))))) == pytest.approx(
        study.exact(study.design_paper), rel=1e-9
    )
    finer = S.p4_task_study(p4)  # a finer check grid can only find a smaller minimum
    assert finer.info["check_task"].size > study.info["check_task"].size
    assert finer.exact(study.design_paper) <= study.exact(study.design_paper) * (1 + 1e-12)
    assert np.all(np.asarray(study.margins(d)) > 0)
    assert float(study.baseline_objective(d)) == pytest.approx(float(np.min(np.asarray(study.values(d)))), rel=1e-12)
    with pytest.raises(ValueError, match="workspace_margin"):
        S.p4_task_study(p4, workspace_margin=0.0)


def test_atlas_equals_direct_evaluation_in_any_chunking():
    designs = pk.Grid.from_ranges(a=(0.4, 0.6, 0.1), r_p_m=(0.05, 0.09, 0.02))
    poses = pk.Grid.from_ranges(x_P=(-0.2, 0.6, 0.05), y_P=(-0.2, 0.5, 0.05))

    def crit(d, xy, log_bound):
        ws, tq = S.p2_torque_margins(jnp.stack([d[0], 0.36, d[1]]), xy, BASE, force=FORCE, log_bound=log_bound)
        return ((ws >= 0) & (tq >= 0)).astype(jnp.float64)

    def reduce(v):
        return jnp.sum(v) * poses.cell_area

    lb = jnp.float64(np.log(BOUND))
    a1 = pk.design.atlas(crit, designs, poses, args=(lb,), reduce=reduce)
    a2 = pk.design.atlas(crit, designs, poses, args=(lb,), reduce=reduce, chunk_designs=2)
    full = pk.design.atlas(crit, designs, poses, args=(lb,), chunk_designs=4)
    assert a1.shape == designs.shape and full.shape == designs.shape + poses.shape
    xy = jnp.asarray(poses.points().reshape(-1, 2).T)
    direct = np.array(
        [[float(reduce(crit(jnp.array([a, r]), xy, lb))) for r in designs.axes[1]] for a in designs.axes[0]]
    )
    assert np.array_equal(a1, direct) and np.array_equal(a2, direct)
    assert np.array_equal(full.sum(axis=(2, 3)) * poses.cell_area, direct)
    with pytest.raises(ValueError, match="chunk_designs"):
        pk.design.atlas(crit, designs, poses, args=(lb,), chunk_designs=0)


def _design_results():
    import json

    return json.loads((pk.DATA_DIR / "results" / "design.json").read_text())


def test_p2_optimum_meets_its_constraints_on_the_fine_grid():
    """The stored P2 optimum: inside its bounds, l1 + l2 <= the paper's 0.36 m, the base unchanged,
    and its exact area on the 2.5 mm check grid is what design.json says, at least the paper's and
    the baseline's less 1 %."""
    r = _design_results()["p2_torque_area"]
    a, L, r_p = r["design_gradient"]
    assert 0.3 <= a <= 0.7 and 0.2 <= L <= 0.36 + 1e-12 and 0.03 <= r_p <= 0.12
    assert a * L + (1 - a) * L <= 0.36 + 1e-12
    check = pk.Grid.from_ranges(x_P=(-0.25, 0.65, 0.0025), y_P=(-0.25, 0.6, 0.0025))
    area = S.p2_exact_area(r["design_gradient"], check, BASE, force=r["force_N"], bound=r["torque_bound_N_m"])
    assert area == pytest.approx(r["objective_gradient"], rel=1e-12)
    assert area > r["objective_paper"] and area >= 0.99 * r["objective_baseline"]


def test_p4_optima_meet_their_constraints_on_the_fine_grid():
    """The stored P4 optima: four links total <= 700 mm, positive lengths, exact effective area as
    stored; the task variant's optimum reaches every task pose (finite stiffness everywhere)."""
    from pkmlib.mechanisms import five_bar as fb

    res = _design_results()
    p4 = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    ws = res["p4_effective_workspace"]
    for key in ("design_gradient", "design_baseline"):
        q = S.p4_params(jnp.asarray(ws[key]), p4)
        links = [float(v) for v in (q.l_A1B1, q.l_B1C, q.l_A2B2, q.l_B2C)]
        assert min(links) > 0 and sum(links) <= 700.0 + 1e-9
    h = ws["check_step_mm"]
    grid = pk.Grid.from_ranges(x_C=(-350.0, 550.0, h), z_C=(h / 4, 350.0, h))
    area = S.p4_exact_area(ws["design_gradient"], grid, p4, threshold=ws["threshold_N_mm"])
    assert area == pytest.approx(ws["objective_gradient"], rel=1e-12) and area > 2 * ws["objective_paper"]
    task = res["p4_task_min_stiffness"]
    q = S.p4_params(jnp.asarray(task["design_gradient"]), p4)
    assert sum(float(v) for v in (q.l_A1B1, q.l_B1C, q.l_A2B2, q.l_B2C)) <= 700.0 + 1e-9
    h = task["check_step_mm"]
    assert h < task["task_step_mm"]  # the check sees the poses between the optimised ones
    task_grid = pk.Grid.from_ranges(x_C=(*task["task_x_C_mm"], h), z_C=(*task["task_z_C_mm"], h))
    k_min = S.p4_exact_task_min(task["design_gradient"], task_grid, p4)
    assert np.isfinite(k_min) and k_min == pytest.approx(task["objective_gradient"], rel=1e-9)
    assert k_min >= 0.99 * task["objective_baseline"] and k_min > 10 * task["objective_paper"]
    # every task pose keeps the required workspace margin (elbows away from straight), up to what
    # storing the optimum at 4 significant digits (design_studies.stored_design) moves an active
    # margin: 1e-4 of the margin's 0.01 scale is 1 %, measured 9.1e-5; the unrounded optimum meets it
    study = S.p4_task_study(
        p4,
        task_x_C_mm=task["task_x_C_mm"],
        task_z_C_mm=task["task_z_C_mm"],
        task_step_mm=task["task_step_mm"],
        workspace_margin=task["workspace_margin"],
    )
    margins = np.asarray(study.margins(jnp.asarray(task["design_gradient"])))
    assert np.all(margins >= -1e-4) and margins.min() < 1e-3  # met to the rounding, and active


def test_p4_smooth_measures_have_the_gradients_of_central_differences():
    from pkmlib.mechanisms import five_bar as fb

    p4 = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    d0 = S.p4_design_of(p4)
    # grids off the symmetry line x_C = 50 mm: there |j_1| = |j_2| and the worst direction switches
    # actuator, a kink where the gradient is P4's stated one-sided choice (actuator 1), not a derivative
    xz = jnp.asarray(pk.Grid.from_ranges(x_C=(-297.0, 400.0, 35.0), z_C=(5.0, 345.0, 35.0)).points().reshape(-1, 2).T)
    task = jnp.asarray(pk.Grid.from_ranges(x_C=(3.0, 100.0, 25.0), z_C=(150.0, 250.0, 25.0)).points().reshape(-1, 2).T)

    def area(d):
        return S.p4_soft_area(d, xz, p4, log_threshold=np.log(100.0), cell_area=35.0**2, width_ws=0.05, width_k=0.2)

    def task_min(d):
        return S.p4_task_min_stiffness(d, task, p4, width=0.05, width_ws=0.02)

    scale = np.array([1.0, 1.0, 1e-3, 1e-3, 1e-3])  # steps in mm for lengths, fractions for shares
    for f in (area, task_min):
        g = np.asarray(jax.jit(jax.grad(f))(jnp.asarray(d0)))  # compiled, as the optimiser calls it
        fd = central_difference_batched(lambda z: f(d0 + scale * z), np.zeros(5), h=1e-4)[0] / scale
        assert_close(g, fd, rtol=1e-5, atol=1e-6 * np.max(np.abs(fd)), err_msg=f.__name__)


def test_findings_say_reached_or_not_and_quote_the_benchmark():
    study = {
        "objective_paper": 1.0,
        "objective_gradient": 2.0,
        "objective_baseline": 2.01,
        "evaluations_gradient": 10,
        "evaluations_baseline": 900,
    }
    below = dict(study, objective_gradient=1.5)
    text = S.findings_markdown({"p2_torque_area": study, "p4_effective_workspace": below})
    lines = text.strip().splitlines()
    assert len(lines) == 2 and "-0.50%" in lines[0] and ": reached" in lines[0]
    assert "-25.37%" in lines[1] and "not reached" in lines[1]
    speed = {
        "studies": {
            "p2_torque_area": {"seconds_ratio": 12.4, "target_met": True, "seconds_ratio_scipy_default_tol": 9.6},
            "p4_effective_workspace": {"seconds_ratio": 8.0, "target_met": False},
        },
        "p2_atlas": {"pairs_per_s": 2.1e7},
    }
    last = S.findings_markdown({"p2_torque_area": study}, speed).strip().splitlines()[-1]
    assert "12x, 8x fewer seconds" in last and "met in 1 of 2 studies" in last and "2.1e7" in last
    assert "SciPy's default tolerance: 9.6x)" in last


def test_p2_area_atlas_equals_the_exact_area_of_each_design_and_its_best():
    """Each atlas value is the exact area of that design counted directly (S.p2_exact_area on the
    same poses), and atlas_best is the argmax."""
    designs, poses, values = S.p2_area_atlas(
        BASE,
        force=FORCE,
        bound=BOUND,
        L=0.36,
        bounds_a=(0.4, 0.6),
        bounds_r_p=(0.05, 0.09),
        step_a=0.1,
        step_r_p=0.02,
        pose_step=0.02,
    )
    assert values.shape == (designs.shape[0], designs.shape[1]) == (3, 3)
    for i, a in enumerate(designs.axes[0]):
        for j, r_p in enumerate(designs.axes[1]):
            direct = S.p2_exact_area(np.array([a, 0.36, r_p]), poses, BASE, force=FORCE, bound=BOUND)
            assert abs(values[i, j] - direct) <= 1e-12 + 1e-9 * direct
    (i, j), best = S.atlas_best(values, designs)
    assert values[i, j] == values.max() and tuple(best) == (designs.axes[0][i], designs.axes[1][j])


def test_design_rows_give_the_link_lengths_of_the_design_vectors():
    rows = S.p2_design_rows({"paper": [0.5, 0.36, 0.08], "x": [0.25, 0.2, 0.05]}, {"paper": 2e-2, "x": 1e-2})
    assert rows[1] == ["x", "0.0500", "0.1500", "0.0500", "0.2000", "100.00", "0.500"]
    from pkmlib.mechanisms import five_bar as fb

    p4 = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    # (l_A1A2, T, c, a_1, a_2) = (100, 600, 0.5, 0.25, 0.5): links 75, 225, 150, 150 mm
    rows = S.p4_design_rows({"d": [100.0, 600.0, 0.5, 0.25, 0.5]}, p4, {"d": ["1", "2"]})
    assert rows == [["d", "100.0", "75.0", "225.0", "150.0", "150.0", "600.0", "1", "2"]]
    assert len(S.P4_TABLE_HEADERS) == len(rows[0]) - 2


def test_study_record_and_derivative_costs():
    r = S.study_record(
        "q?",
        ["a", "b"],
        [[1, 2], [3, 4], [5, 6]],
        [1.0, 2.0, 3.0],
        objective_unit="m^2",
        method_gradient="m",
        derivatives_gradient="forward",
        step_m=0.01,
    )
    assert list(r)[:3] == ["question", "step_m", "design_names"]
    assert r["objective_gradient"] == 2.0 and r["design_baseline"].tolist() == [5, 6]
    with pytest.raises(ValueError):
        S.study_record("q", ["a"], [[1]], [1.0], objective_unit="", method_gradient="", derivatives_gradient="")
    costs = S.derivative_costs(lambda z: jnp.sum(z**2), np.ones(3), repeats=2)
    assert set(costs) == {"value", "forward", "reverse"} and all(v > 0 for v in costs.values())


def test_speed_rows_read_the_benchmark_file():
    import json
    from pathlib import Path

    speed = json.loads((Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "design.json").read_text())
    rows = S.speed_rows(speed)
    assert len(rows) == len(speed["studies"]) and all(len(r) == len(S.SPEED_HEADERS) for r in rows)
    r = speed["studies"]["p2_torque_area"]
    assert rows[0][3] == f"{r['seconds_ratio']:.1f}x"


def test_p4_stiffness_margins_check_the_branch_and_reuse_one_trace():
    """A branch is two signs +-1 (ValueError naming it otherwise, never truncated to one); a list
    or tuple of the same signs gives the same margins; each call at one shape and branch reuses the
    one trace (the jitted function's cache grows by one entry only)."""
    from pkmlib.mechanisms import five_bar as fb

    paper = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    d = jnp.asarray(S.p4_design_of(paper))
    xz = jnp.array([[0.0, 100.0, 50.0], [200.0, 150.0, 120.0]])
    for bad in [(1.5, -1), (1, 0), (1,), "1-1", (True, False)]:
        with pytest.raises(ValueError, match="branch"):
            S.p4_stiffness_margins(d, xz, paper, log_threshold=0.0, branch=bad)
    S._p4_stiffness_margins_jit.clear_cache()
    a = S.p4_stiffness_margins(d, xz, paper, log_threshold=0.0, branch=(1, -1))
    b = S.p4_stiffness_margins(d + 1e-3, xz, paper, log_threshold=0.5, branch=[1.0, -1.0])
    assert S._p4_stiffness_margins_jit._cache_size() == 1
    assert_close(a[0], S.p4_stiffness_margins(d, xz, paper, log_threshold=0.0)[0], rtol=0)
    assert np.all(np.isfinite(np.asarray(b[1])))
