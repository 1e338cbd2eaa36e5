"""P1 (4-PRR) analysis functions of the notebook, moved into ``gripper_4prr``: each against an
independent computation (hand formulas, finite-difference Jacobians, brute-force loops)."""

from functools import partial

import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m

PHI, S = np.deg2rad(20.0), 0.14
F_PR, LOAD = 100.0, np.array([1.0, 1.0, 0.1, 0.0])


def test_vertical_link_heights_and_type1_bounds_by_hand(p1_params):
    p = p1_params
    h = m.vertical_link_heights(PHI, S, p)
    # P1 text after Fig 3: B21C2 vertical at l_B21C2 - l_C2D sin(phi), B12C1 at s sin(phi) - l_B12C1
    assert abs(h["B21C2"][1] - (p.l_B21C2 - p.l_C2D * np.sin(PHI))) < 1e-15
    assert abs(h["B12C1"][0] - (S * np.sin(PHI) - p.l_B12C1)) < 1e-15
    for k, name in enumerate(m.LINKS):
        for y in h[name]:
            C = np.asarray(m.joint_points(m.pose(0.7, y, PHI, S), p)[k // 2])
            assert abs(abs(C[1]) - (p.l_B11C1, p.l_B12C1, p.l_B21C2, p.l_B22C2)[k]) < 1e-12
    assert m.type1_bounds_y(PHI, S, p) == (max(lo for lo, _ in h.values()), min(hi for _, hi in h.values()))
    assert m.workspace_bounds_y(PHI, S, p) == m.type1_bounds_y(PHI, S, p)
    with pytest.raises(ValueError, match="phi_deg .* s_m .*workspace is empty"):
        m.workspace_bounds_y(PHI, 10.0, p)


def test_link_angles_equal_the_arcsine_of_the_height(p1_params, p1_poses):
    ang = np.asarray(m.link_angles_to_rail_deg(p1_poses.T, p1_params))
    lengths = (p1_params.l_B11C1, p1_params.l_B12C1, p1_params.l_B21C2, p1_params.l_B22C2)
    C = [np.asarray(c) for c in m.joint_points(p1_poses.T, p1_params)]  # C1, C2: (2, n) each
    expected = [np.degrees(np.arcsin(np.abs(C[k // 2][1]) / lengths[k])) for k in range(4)]
    np.testing.assert_allclose(ang, expected, rtol=1e-9)
    assert np.all(np.isnan(np.asarray(m.link_angles_to_rail_deg(m.pose(0.7, 0.5, PHI, S), p1_params))))


def test_x_inside_and_nearest_workspace_point_by_brute_force(p1_params):
    xs = np.arange(0.2, 1.2001, 0.05)
    for y in (0.0, 0.1, -0.13, 0.3):
        q = np.asarray(m.mechanism.inverse(m.pose(xs, np.full_like(xs, y), PHI, S), p1_params))
        ok = [x for x, good in zip(xs, np.all(np.isfinite(q), axis=0)) if good]
        got = m.x_inside(y, xs, PHI, S, p1_params)
        assert got == (min(ok, key=lambda v: abs(v - 0.7)) if ok else None)
    grid = pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.1), y_D=(-0.25, 0.25, 0.05))
    inside = np.zeros(grid.shape, bool)
    inside[3, 4] = inside[8, 8] = True
    pts = grid.points().reshape(*grid.shape, 2)
    assert m.nearest_workspace_point(grid, inside, (0.55, 0.0)) == (*pts[3, 4], True)
    assert m.nearest_workspace_point(grid, inside, tuple(pts[8, 8])) == (*pts[8, 8], False)


def test_row_functions_by_brute_force():
    rng = np.random.default_rng(3)
    inside = rng.random((9, 7)) > 0.3
    inside[:, 0] = False  # a row without workspace points
    values = rng.random((9, 7))
    med = m.row_medians(values, inside)
    for j in range(7):
        col = values[inside[:, j], j]
        assert (np.isnan(med[j]) and not len(col)) or med[j] == np.median(col)
    side = m.side_edge_points(inside)
    rows_in = np.flatnonzero(inside.any(axis=0))
    for i in range(9):
        for j in range(7):
            edge = inside[i, j] and (i == 0 or not inside[i - 1, j] or i == 8 or not inside[i + 1, j])
            assert side[i, j] == (edge and j not in (rows_in[0], rows_in[-1]))
    jump, other = m.row_step_factors(np.array([1.0, 1.1, 8.0, 1.2, 1.3]), [2])
    assert jump == pytest.approx(8.0 / 1.2) and other == pytest.approx(1.1)  # steps 1-2, 2-3 are at the line


def test_force_peak_offsets_and_rows_by_hand():
    y = np.array([0.0, 0.01, 0.02, 0.03, 0.04])
    force = np.ones((3, 5))
    force[:, 3] = 10.0  # peak on the row y = 0.03 in every column
    inside = np.ones((3, 5), bool)
    offsets = m.force_peak_offsets(force, inside, y, {"upper": 0.026}, band=0.011)
    np.testing.assert_allclose(offsets, [0.004] * 3, atol=1e-15)
    rows = m.force_peak_rows(y, force[0], {"upper": 0.026, "far": 0.5}, band=0.011)
    assert rows["upper"] == (0.026, 0.02, 0.03, 0.03) and rows["far"] == (0.5, None, None, None)
    assert m.lambda_link_angle_deg(0.0, (0.25, 0.18)) == 0.0
    assert m.lambda_link_angle_deg(0.09, (0.25, 0.18)) == pytest.approx(30.0)


def fd_inverse_jacobians(xs, p, h=1e-8):
    """J^-1 = dq/dx at the poses ``xs`` (``(n, 4)``) by central differences of the closed-form inverse
    position (no autodiff), all poses at once: ``(n, 4, 4)``."""
    cols = []
    for j in range(4):
        dz = np.zeros(4)
        dz[j] = h
        plus, minus = (np.asarray(m.mechanism.inverse((xs + sgn * dz).T, p)) for sgn in (1, -1))
        cols.append((plus - minus).T / (2 * h))
    return np.stack(cols, axis=2)


def fd_reserves(xs, p, load=LOAD):
    """min_k (F_pr - |e^ext_k|), e = -J^T P (P1 eq (12)), J^-1 from finite differences: ``(n,)``."""
    J_inv = fd_inverse_jacobians(np.asarray(xs, dtype=np.float64), p)
    e = -np.linalg.solve(np.swapaxes(J_inv, 1, 2), np.broadcast_to(load, (len(xs), 4))[..., None])[..., 0]
    return np.min(F_PR - np.abs(e), axis=1)


def test_load_gap_half_width_edges_are_zeros_of_the_reserve(p1_params):
    lower = m.type2_lines_y(PHI, S, p1_params)[1]
    width, null = m.load_gap_half_width(0.7, lower, PHI, S, p1_params, F_pr=F_PR, load=LOAD)
    assert 1e-4 < width < 2e-3  # the notebook prints 0.9655 mm
    # the reserve (from finite differences) changes sign within 1 um of each edge, negative on the line
    ys = [lower, lower - width + 1e-6, lower - width - 1e-6, lower + width - 1e-6, lower + width + 1e-6]
    r = fd_reserves([[0.7, y, PHI, S] for y in ys], p1_params)
    assert r[0] < 0 and r[1] < 0 < r[2] and r[3] < 0 < r[4]
    x = m.pose(0.7, lower, PHI, S)
    A = np.asarray(pk.A_matrix(m.mechanism, x, m.mechanism.inverse(x, p1_params), p1_params))
    assert np.linalg.norm(A @ null) < 1e-9 and abs(np.linalg.norm(null) - 1) < 1e-12


def test_load_sign_gaps_by_brute_force(p1_params):
    grid = pk.Grid.from_ranges(x_D=(0.5, 0.9, 0.1), y_D=(-0.0775, -0.0725, 0.0005))
    pts = grid.points().reshape(-1, 2)
    q = np.asarray(m.mechanism.inverse(m.pose(pts[:, 0], pts[:, 1], PHI, S), p1_params))
    inside = np.all(np.isfinite(q), axis=0).reshape(grid.shape)
    lines = m.type2_lines_y(PHI, S, p1_params)
    rows = m.load_sign_gaps(grid, inside, PHI, S, p1_params, F_pr=F_PR, load=LOAD[:3], lines=lines)
    assert [r[:3] for r in rows[:2]] == [["+1", "+1", "+0.1"], ["+1", "+1", "-0.1"]]
    xs = np.column_stack([pts, np.full(len(pts), PHI), np.full(len(pts), S)])[inside.ravel()]
    for r in rows:
        signed = np.array([float(v) for v in r[:3]] + [0.0])
        assert r[3] == int(np.sum(fd_reserves(xs, p1_params, signed) < 0))
    assert any(r[3] > 0 for r in rows)


def test_type2_lines_are_found_on_the_analytic_heights(p1_params):
    grid = pk.Grid.from_ranges(x_D=(0.5, 0.9, 0.1), y_D=(-0.1, 0.1, 0.0025))
    crit = partial(
        m.criteria_at,
        phi=PHI,
        s=S,
        p=p1_params,
        speeds=(1, 1, 1),
        loads=(1, 1, 1),
        F_pr=F_PR,
        external_load=(1.0, 1.0, 0.1),
    )
    maps = pk.sweep(crit, grid, batched=True)
    det_A_at = lambda pt: m.det_A_at(pt, phi=PHI, s=S, p=p1_params)  # noqa: E731
    roots, along = pk.singular_crossings(det_A_at, grid, maps["det_A"], tol=1e-9)
    lines = m.type2_lines(roots, along, PHI, S, p1_params)
    assert abs(lines["upper"]["refined"] - S * np.sin(PHI)) < 1e-9  # C1 on the rail (hand formula)
    assert abs(lines["lower"]["refined"] + p1_params.l_C2D * np.sin(PHI)) < 1e-9  # C2 on the rail
    notes = m.type2_line_notes(lines, PHI, S, p1_params)
    assert notes[0].startswith("upper line: 5 crossings") and notes[1].startswith("lower line: 5 crossings")
    at_zero = m.type2_lines(roots[:0], along[:0], 0.0, S, p1_params)
    assert "double zero" in m.type2_line_notes(at_zero, 0.0, S, p1_params)[0]
    probes = m.probes([(0.7, 0.0), (0.7, 0.5)], crit)
    assert probes[0]["x_D_m"] == 0.7 and np.isnan(probes[1]["det_A"])


def test_type2_lines_count_the_exact_zeros_at_grid_nodes(p1_params):
    """A line on a grid row: where det(A)'s last bits at the nodes are 0.0, ``singular_crossings``
    reports the nodes (axis -1), not a sign change along y_D; they are the line's crossings all the
    same (before, such a line was silently lost: P1 at phi = 30 deg, y_D = -0.11 m). A crossing
    found along x_D (axis 0) is not on a horizontal line and is not counted."""
    phi = np.deg2rad(30.0)
    upper, lower = m.type2_lines_y(phi, S, p1_params)
    roots = np.array([[0.5, lower], [0.6, lower], [0.7, upper], [0.8, upper + 1e-10], [0.9, lower]])
    along = np.array([-1, -1, 1, 1, 0])
    lines = m.type2_lines(roots, along, phi, S, p1_params)
    assert lines["lower"]["refined"] == pytest.approx(lower, abs=1e-12)
    assert lines["upper"]["refined"] == pytest.approx(upper, abs=1e-9)
    notes = m.type2_line_notes(lines, phi, S, p1_params)
    assert notes[0].startswith("upper line: 2 crossings") and notes[1].startswith("lower line: 2 crossings"), notes


def test_study_parameters_and_rules():
    values = {name: spec.paper for name, spec in m.STUDY_PARAMETERS.items()}
    assert pk.tools.check_parameters(values, m.STUDY_PARAMETERS, m.STUDY_RULES) is True
    assert pk.tools.check_parameters(values | {"phi_deg": 25.0}, m.STUDY_PARAMETERS, m.STUDY_RULES) is False
    with pytest.raises(ValueError, match="v_D_m_s"):
        pk.tools.check_parameters(
            values | {"v_D_m_s": 0.0, "omega_rad_s": 0.0, "v_s_m_s": 0.0}, m.STUDY_PARAMETERS, m.STUDY_RULES
        )


def test_det_A_at_and_criteria_at_refuse_points_that_are_not_x_D_y_D():
    p = m.load_params()
    kw = dict(phi=np.deg2rad(20.0), s=0.14, p=p)
    assert np.isfinite(float(m.det_A_at(np.array([0.7, 0.0]), **kw)))
    for bad in (np.array([0.7, 0.0, 0.1]), np.array([0.7]), 0.7):
        with pytest.raises(ValueError, match=r"point \(x_D, y_D\)"):
            m.det_A_at(bad, **kw)
    with pytest.raises(ValueError, match=r"points \(x_D, y_D\)"):
        m.criteria_at(
            np.zeros((3, 4)),
            **kw,
            speeds=(1.0, 1.0, 1.0),
            loads=(1.0, 1.0, 1.0),
            F_pr=1.0,
            external_load=(0.0, 0.0, 0.0),
        )
