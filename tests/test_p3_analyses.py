"""P3's analyses in the library (two_t_one_r): the paper's determinants against autodiff, the
sweeps against pointwise evaluation and geometry, eq (18) and its RK4 integral against the closed
form and known solutions, the singular poses found, the solution counts, and the figures' text."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import two_t_one_r as m
from pkmlib.plotting import plt, smallest_text_pt
from conftest import assert_close


@pytest.fixture(scope="module")
def P():
    return pk.load_params("p3")


@pytest.fixture(scope="module")
def pa(P):
    return m.ParamsA.from_dict(P["mechanism_A"])


@pytest.fixture(scope="module")
def pb(P):
    return m.ParamsB.from_dict(P["mechanism_B"])


def _real_poses(p, branch, n=300, seed=5):
    rng = np.random.default_rng(seed)
    q = np.stack([rng.uniform(-250.0, 0.0, n), rng.uniform(0.0, 250.0, n), rng.uniform(-300.0, 300.0, n)])
    fw = m.forward_a if isinstance(p, m.ParamsA) else m.forward_b
    x = np.asarray(fw(jnp.asarray(q), p, jnp.asarray(branch)))
    ok = np.all(np.isfinite(x), axis=0)
    return x[:, ok], q[:, ok]


@pytest.mark.parametrize("which, branch", [("A", 1.0), ("A", -1.0), ("B", (1.0, 1.0)), ("B", (1.0, -1.0))])
def test_paper_determinants_equal_autodiff(pa, pb, which, branch):
    """The hand-written det J_o, det J_i of P3 section 2.3 against pkmlib.det_A / det_B (autodiff of
    the loop-closure equations), and f33 = -m sqrt(discriminant) for A."""
    p, mech = (pa, m.mechanism_a) if which == "A" else (pb, m.mechanism_b)
    x, q = _real_poses(p, branch)
    assert x.shape[1] > 100
    dA = np.asarray(jax.vmap(lambda xx, qq: pk.det_A(mech, xx, qq, p), in_axes=1)(x, q))
    dB = np.asarray(jax.vmap(lambda xx, qq: pk.det_B(mech, xx, qq, p), in_axes=1)(x, q))
    paper = m.paper_determinants_a if which == "A" else m.paper_determinants_b
    det_o, det_i, f = paper(x, q, p)
    assert isinstance(det_o, np.ndarray)  # NumPy in, NumPy out
    assert_close(dA, det_o, rtol=0, atol=1e-12 * np.max(np.abs(det_o)))
    assert_close(dB, det_i, rtol=0, atol=1e-12 * np.max(np.abs(det_i)))
    if which == "A":
        assert_close(
            f, -branch * np.sqrt(np.asarray(m.discriminant_a(jnp.asarray(q), p))), rtol=0, atol=1e-9 * np.abs(f).max()
        )
    # traceable too
    det_o_j = jax.jit(lambda xx, qq: paper(xx, qq, p)[0])(jnp.asarray(x), jnp.asarray(q))
    assert_close(np.asarray(det_o_j), det_o, rtol=1e-12)


def test_workspace_cloud_is_the_forward_solution_at_every_grid_point(pa, pb):
    for p, branch, centre, fw, half in (
        (pa, 1.0, m.platform_centre_a, m.forward_a, pa.l3 / 2),
        (pb, (1.0, 1.0), m.platform_centre_b, m.forward_b, pb.l4 / 2),
    ):
        c, x = m.workspace_cloud(p, branch, 50.0)
        grid = m.actuator_grid(p, 50.0)
        assert c.shape == x.shape == (3, grid.size)
        Q = np.stack([g.ravel() for g in np.meshgrid(*grid.axes, indexing="ij")])
        x_ref = np.asarray(fw(jnp.asarray(Q), p, jnp.asarray(branch)))
        assert np.array_equal(np.isfinite(x), np.isfinite(x_ref))
        ok = np.all(np.isfinite(x), axis=0)
        assert 0.2 < ok.mean() < 1.0  # real inside, NaN outside
        assert_close(x[:, ok], x_ref[:, ok], rtol=1e-12, atol=1e-9)
        # the centre is the platform's midpoint: half the platform's length from the output point in the y-z plane
        out = np.stack([x[0], np.full_like(x[0], -p.a if p is pa else p.a), x[1]])
        assert_close(np.linalg.norm((c - out)[:, ok], axis=0), half, rtol=1e-12)
        assert_close(centre(jnp.asarray(x[:, ok]), p), c[:, ok], rtol=1e-12, atol=1e-9)


def test_forward_jacobian_sweep_matches_central_differences(pa, pb):
    for p, branch, fw in ((pa, 1.0, m.forward_a), (pb, (1.0, 1.0), m.forward_b)):
        J, res = m.forward_jacobian_sweep(p, branch, 50.0)
        assert J.shape[1:] == (3, 3) and res.shape == (len(J), 3) and len(J) > 50
        assert np.max(np.abs(res)) < 1e-8  # the closed form closes the loops (mm^2)
        # central differences at the real grid points, in the grid's order
        grid = m.actuator_grid(p, 50.0)
        Q = np.stack([g.ravel() for g in np.meshgrid(*grid.axes, indexing="ij")], axis=1)
        f = lambda q: np.asarray(fw(jnp.asarray(q.T), p, jnp.asarray(branch))).T  # noqa: E731
        h = 1e-4
        fd = np.stack([(f(Q + h * e) - f(Q - h * e)) / (2 * h) for e in np.eye(3)], axis=-1)
        jac = jax.vmap(jax.jacfwd(lambda q: fw(q, p, jnp.asarray(branch))))(jnp.asarray(Q))
        rows = np.all(np.isfinite(np.asarray(jac)).reshape(len(Q), -1), axis=1) & np.all(np.isfinite(f(Q)), axis=1)
        assert rows.sum() == len(J)  # the sweep keeps exactly the poses with a finite dX/dq
        fd = fd[rows]
        interior = np.all(np.isfinite(fd.reshape(len(fd), -1)), axis=1) & (np.max(np.abs(J), axis=(1, 2)) < 1e3)
        assert interior.mean() > 0.8
        assert_close(J[interior], fd[interior], rtol=0, atol=1e-5)
        s = m.kinematics_summary(J, res)
        assert s["generic_rank"] == 3 and s["points"] == len(J)


def test_output_velocity_of_eq18_is_the_derivative_of_the_forward_solution(pa, pb):
    for p, branch, fw in ((pa, 1.0, m.forward_a), (pb, jnp.array([1.0, 1.0]), m.forward_b)):
        q = jnp.array([-106.09, 181.67, -70.29])
        qd = jnp.array([3.0, -1.0, 2.0])
        x = fw(q, p, branch)
        h = 1e-5
        fd = (fw(q + h * qd, p, branch) - fw(q - h * qd, p, branch)) / (2 * h)
        assert_close(m.output_velocity(p, x, q, qd), fd, rtol=1e-7, atol=1e-9)


def test_rk4_is_fourth_order_and_exact_for_cubics():
    f = lambda x, t: jnp.stack([-x[0], 3 * t**2])  # noqa: E731  x0 = exp(-t), x1 = t^3
    errs = []
    for n in (20, 40):
        ts = jnp.linspace(0.0, 2.0, n + 1)
        X = np.asarray(m._rk4_scan(f, jnp.array([1.0, 0.0]), ts))
        assert X.shape == (n, 2)
        assert_close(X[:, 1], np.asarray(ts[1:]) ** 3, rtol=1e-13, atol=1e-13)
        errs.append(np.max(np.abs(X[:, 0] - np.exp(-np.asarray(ts[1:])))))
    assert 14.0 < errs[0] / errs[1] < 18.0  # halving h divides the error by 2^4


def test_eq18_check_along_the_paper_motion(P, pa, pb):
    mo = P["motion"]
    for p, br, t_end in ((pa, 1.0, 5.0), (pb, (1.0, 1.0), 1.1)):
        ep, ev = m.eq18_check(p, br, t_end, mo["rho_mm"], mo["amplitude_mm"], mo["omega_rad_s"])
        assert ev < 1e-12 and ep < 1e-8
        ep_coarse, _ = m.eq18_check(p, br, t_end, mo["rho_mm"], mo["amplitude_mm"], mo["omega_rad_s"], dt_s=0.01)
        assert 8.0 < ep_coarse / ep < 24.0  # fourth order: twice the step, about 16 times the error


def test_exit_time_of_B_is_where_its_forward_solution_stops_being_real(P, pb):
    mo = P["motion"]
    rho, amp, om = (jnp.asarray(mo[k]) for k in ("rho_mm", "amplitude_mm", "omega_rad_s"))
    t_exit = m.exit_time_b(pb, rho, amp, om, 5.0, 501)
    assert 1.1 < t_exit < 1.2
    t = jnp.linspace(0.0, 1.3, 13001)  # an independent fine scan of the forward solution itself
    x = np.asarray(
        m.forward_b(m.sinusoidal_inputs(t[None, :], rho[:, None], amp[:, None], om), pb, jnp.array([1.0, 1.0]))
    )
    first_nan = float(t[np.argmax(~np.all(np.isfinite(x), axis=0))])
    assert abs(first_nan - t_exit) <= 1e-4
    assert np.isnan(m.exit_time_b(pb, rho, amp, om, 1.0, 101))  # a short run stays inside


def test_combined_singularity_of_B_and_its_input_singularity_4(pb):
    q = jnp.asarray(m.combined_singularity_inputs_b(pb, x_E=50.0))
    dets = []
    for br in m.FORWARD_BRANCHES["B"]:
        x = m.forward_b(q, pb, jnp.array(br))
        if np.all(np.isfinite(np.asarray(x))):
            dets.append((abs(float(pk.det_A(m.mechanism_b, x, q, pb))), abs(float(pk.det_B(m.mechanism_b, x, q, pb)))))
    assert min(max(d) for d in dets) < 1e-3  # both vanish on one branch (scale of det: 1e10)
    q4, dz = m.input_singularity_4_b(pb, -106.09, 181.67, branch=(1.0, -1.0))
    assert dz < 1e-9
    x4 = m.forward_b(jnp.asarray(q4), pb, jnp.array([1.0, -1.0]))
    pts = m.joint_points_b(x4, jnp.asarray(q4), pb)
    assert abs(float(pts["D"][2] - pts["C"][2])) < 1e-9
    assert abs(float(pk.det_B(m.mechanism_b, x4, jnp.asarray(q4), pb))) < 1e-4


def test_solution_counts_of_B(pb):
    q = jnp.array([-106.09, 181.67, -70.29])
    c = m.solution_counts_b(pb, m.forward_b(q, pb, jnp.array([1.0, -1.0])), step_mm=25.0)
    assert c["forward"] == 4 and c["inverse"] == 8
    q_all = jnp.asarray(c["q_all_real_mm"])
    assert all(np.all(np.isfinite(np.asarray(m.forward_b(q_all, pb, jnp.array(br))))) for br in m.FORWARD_BRANCHES["B"])


def test_small_helpers():
    assert m.agreeing_digits(238.9192, 238.919205, 4) == 7
    assert m.agreeing_digits(-0.7097, -0.709738, 4) == 5
    assert m.agreeing_digits(1.5, 2.5, 1) == 0
    assert m.sign_fractions(np.array([-2.0, -1.0, 0.0, 1.0])) == [0.5, 0.25, 0.25]
    with pytest.raises(ValueError, match="branch"):
        m.workspace_cloud(m.ParamsB(300, 100, 200, 250, 450, 200, -250, 0, 0, 250, -300, 300), 1.0, 50.0)


def test_figures_text_is_at_least_095_pt_per_inch_of_width(pa, pb):
    """The site's rule: every text >= 10 px at the 800 px column, i.e. font pt >= 0.95 x width in."""
    q = jnp.array([-106.09, 181.67, -70.29])
    x = m.forward_a(q, pa, 1.0)
    c = {"m=+1": np.asarray(m.workspace_cloud(pa, 1.0, 50.0)[0])}
    c = {k: v[:, np.all(np.isfinite(v), axis=0)] for k, v in c.items()}
    t = np.linspace(0.0, 1.0, 11)
    motion = {"A": {"velocity": np.ones((11, 3)), "acceleration": np.ones((11, 3))}}
    figs = [
        m.configurations_figure("A", [(m.joint_points_a(x, q, pa), "a")] * 8, "title"),
        m.configurations_figure("A", [(m.joint_points_a(x, q, pa), "a")], "title", ncols=1, width_in=7.0),
        m.cloud_figure(c, "title"),
        m.section_figure(c, ((0, 0.0), (1, -100.0), (2, 100.0)), 2.5, "title"),
        m.motion_figure(motion, t, 1.0, "title", clip_until=0.5, exit_s=0.9),
        m.force_figure(t, np.ones((11, 3)), np.ones((11, 3)), "title"),
    ]
    for fig in figs:
        assert smallest_text_pt(fig) >= 0.95 * fig.get_size_inches()[0]
        plt.close(fig)


# --- the notebook's studies, computed in the module ---------------------------------------------
Q_TABLE1 = jnp.array([-106.09, 181.67, -70.29])  # P3 Table 1's input (mm), also B's in the notebook


def test_study_parameters_are_the_notebooks_and_the_papers():
    values = {name: spec.paper for name, spec in m.STUDY_PARAMETERS.items()}
    assert pk.tools.check_parameters(values, m.STUDY_PARAMETERS) is True
    assert pk.tools.check_parameters(values | {"step_mm": 10.0}, m.STUDY_PARAMETERS) is False
    with pytest.raises(ValueError, match="n_t"):
        pk.tools.check_parameters(values | {"n_t": 1}, m.STUDY_PARAMETERS)


def test_claim_keeps_the_note_only_where_the_claim_fails():
    q = "workspace volume A / B"
    held, failed = m.claim(q, 1.5, True, note="why"), m.claim(q, 0.5, False, note="why")
    assert held["status"] == "reproduced" and "note" not in held
    assert failed["status"] != "reproduced" and failed["note"] == "why"
    ours = m.consistency(q, 1.5, True)
    assert ours["kind"] == "consistency" and ours["status"] == "consistency check"
    assert m.consistency(q, 1.5, False)["status"] == "differs"
    assert m.consistency(q, 1.5, True, paper_run=False)["status"] == m.claim(q, 1.5, True, paper_run=False)["status"]


def test_tables_of_A_are_the_forward_and_inverse_solutions(pa):
    t = m.tables_a(Q_TABLE1, pa)
    assert [r["m"] for r in t["table1"]] == list(m.FORWARD_BRANCHES["A"])
    for r in t["table1"]:
        assert_close([r["x_mm"], r["z_mm"], r["alpha_rad"]], m.forward_a(Q_TABLE1, pa, r["m"]))
        assert r["y_mm"] == -pa.a
    # the paper's branch (u, v) = (-1, -1) of the exact row 1 gives back the input
    exact = {(r["u"], r["v"]): r["x3_mm_exact"] for r in t["table2"]}
    assert_close(exact[m.PAPER_BRANCH["A"]], Q_TABLE1[2])
    # 8 Table 1 values, then 3 per Table 2 row with the text's reading after row 1
    assert len(t["rows"]) == 8 + 4 * 3 + 1 and t["rows"][11] is t["text_row"]
    assert [r["quantity"] for r in t["rows"][8:11]] == [f"A Table 2 row 1 {n}" for n in ("x1", "x2", "x3")]
    assert len(t["table1_text"]) == 8 and len(t["table2_text"]) == 4
    assert all(r["status"] == "reproduced" for r in t["rows"][:8])


def test_solutions_of_B_and_their_tables(pb):
    s = m.solutions_b(Q_TABLE1, pb)
    real = s["real_branches"]
    assert 0 < len(real) <= 4 and len(s["table2"]) == 8 * len(real)
    for r, br in zip(s["table1"], m.FORWARD_BRANCHES["B"]):
        assert np.isfinite(r["alpha_rad"]) == (br in real)
    assert max(s["round_trip_mm"]) < 1e-9
    for r in s["table2"]:  # every real inverse solution closes the loops at its pose
        q = jnp.array([r["x1_mm"], r["x2_mm"], r["x3_mm"]])
        if np.all(np.isfinite(np.asarray(q))):
            x = m.forward_b(Q_TABLE1, pb, jnp.array([r["pose_n"], r["pose_m"]]))
            assert np.max(np.abs(np.asarray(m.constraints_b(x, q, pb)))) < 1e-6
    rows, headers = m.forward_table_b(s, [-106.09, 181.67, -70.29])
    assert len(rows) == 4 and len(headers) == 5 and headers[0] == "(n, m) at x = (-106.09, 181.67, -70.29) mm"
    assert sum("nan" in r[4] for r in rows) == 4 - len(real)
    body, heads = m.inverse_table_b(s)
    assert len(body) == 8 and all(len(r) == 1 + len(real) for r in body) and len(heads) == 1 + len(real)
    assert body[0][1] == ", ".join(f"{s['table2'][0][c]:.4f}" for c in ("x1_mm", "x2_mm", "x3_mm"))


def test_workspace_and_singularity_summaries_of_both_mechanisms(pa, pb):
    ws = m.workspace_summaries(pa, pb, 50.0, 25.0)
    assert list(ws) == [("A", "m=+1"), ("A", "m=-1")] + [
        ("B", m.branch_label("B", br)) for br in m.FORWARD_BRANCHES["B"]
    ]
    one = m.workspace_summary(pb, (1.0, 1.0), 50.0, 25.0, fine=True)
    assert ws["B", "n=+1,m=+1"]["volume_fine"] == one["volume_fine"] and ws["B", "n=+1,m=+1"]["volume"] == one["volume"]
    assert ws["A", "m=-1"]["volume_fine"] == ws["A", "m=-1"]["volume"]  # no half-step check there
    clouds = {label: w["cloud"] for (n, label), w in ws.items() if n == "B"}
    arrays = m.cloud_arrays(clouds, every=3)
    assert "np1_mm1_y_mm" in arrays and len(arrays) == 3 * 4
    assert_close(arrays["np1_mm1_y_mm"], clouds["n=+1,m=-1"][1, ::3])
    s = m.singularity_summaries(pa, pb, [(1.0, 1.0)], 50.0)
    assert list(s) == ["A m=+1", "A m=-1", "B n=+1,m=+1"]
    assert s["A m=-1"] == m.singularity_summary(pa, -1.0, 50.0)


def test_determinants_and_panels_at_the_papers_poses(pa, pb):
    x, dO, dI = m.determinants_at(jnp.array([-200.0, 200.0, 50.0]), pa, 1.0)  # Fig 13: output singular
    assert abs(dO) < 1e-6 and abs(dI) > 1e-3
    x, dO, dI = m.determinants_at(jnp.array([-106.09, 181.67, 37.79]), pb, (1.0, 1.0))  # Fig 14: input singular
    assert abs(dI) < 1e-6 and abs(dO) > 1e-3
    assert m.joint_points(x, Q_TABLE1, pb).keys() == m.joint_points_b(x, Q_TABLE1, pb).keys()
    fa = m.forward_panels(Q_TABLE1, pa)
    assert [label[:3] for _, label in fa] == ["(a)", "(b)"]
    assert len(m.forward_panels(Q_TABLE1, pb)) == len(m.solutions_b(Q_TABLE1, pb)["real_branches"])
    xA = m.forward_a(Q_TABLE1, pa, 1.0)
    for pts, _ in m.inverse_panels(xA, pa):  # every inverse solution is drawn at the same platform
        assert_close(pts["C"], m.joint_points_a(xA, Q_TABLE1, pa)["C"], atol=1e-9)
    assert len(m.inverse_panels(m.forward_b(Q_TABLE1, pb, jnp.array([1.0, -1.0])), pb)) == 8


def test_motions_dynamics_and_their_arrays(P, pa, pb):
    t = jnp.linspace(0.0, 0.5, 6)
    rho, amp, om = (
        jnp.array(P["motion"]["rho_mm"]),
        jnp.array(P["motion"]["amplitude_mm"]),
        float(P["motion"]["omega_rad_s"]),
    )
    motion = m.paper_motions(pa, pb, [(1.0, -1.0)], t, rho, amp, om)
    assert list(motion) == ["A", "A m=-1", "B n=+1,m=-1"]
    direct = m.platform_motion(m.forward_b, m.platform_centre_b, pb, jnp.array([1.0, -1.0]), t, rho, amp, om)
    assert_close(motion["B n=+1,m=-1"]["velocity"], direct["velocity"])
    arrays = m.motion_arrays(motion, np.asarray(t), ["A m=-1"])
    assert list(arrays) == ["t_s", "velocity_A_mm1_mm_s", "acceleration_A_mm1_mm_s2"]
    # the notebook's sample counts (201 and 111, padded to 256 and 128): its compiled force
    # functions, and test_p3_dynamics' for B, are then loaded from the compilation cache
    t_dyn = {"A": jnp.linspace(0.0, 0.4, 201), "B": jnp.linspace(0.0, 0.2, 111)}
    dyn = m.paper_dynamics(P, pa, pb, t_dyn, m.sinusoidal_trajectory(rho, amp, om), jnp.array([0.0, 0.0, -9.81]))
    for name in "AB":
        assert dyn[name]["virtual_work"].shape == (len(t_dyn[name]), 3) and dyn[name]["max_rel_difference"] < 1e-9
    assert list(m.force_arrays(t_dyn["B"], dyn["B"])) == ["t_s", "f_virtual_work_N", "f_lagrange_N"]
    # A's forces over B's time span only (its last sample is beyond it): ranges (2, 2) and (1, 6)
    fake = {
        "A": {"virtual_work": np.array([[0.0, 1.0], [2.0, 3.0], [9.0, 9.0]])},
        "B": {"virtual_work": np.array([[1.0, 0.0], [2.0, 6.0]])},
    }
    range_A, range_B, ratio = m.force_ranges(fake, {"A": np.array([0.0, 1.0, 2.0]), "B": np.array([0.0, 1.0])})
    assert list(range_A) == [2.0, 2.0] and list(range_B) == [1.0, 6.0] and ratio == 3.0
