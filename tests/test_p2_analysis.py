"""P2 (3-RRR) analysis functions of the notebook, moved into ``three_rrr``: each against an
independent computation (numpy geometry, finite-difference Jacobians, brute force, hand examples)."""

import jax
import numpy as np
import pytest
from scipy import optimize

import pkmlib as pk
from pkmlib.mechanisms import three_rrr as t

PHI = 0.0


@pytest.fixture(scope="module")
def params():
    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


@pytest.fixture(scope="module")
def poses(params):
    rng = np.random.default_rng(7)
    out = []
    while len(out) < 10:
        x = np.array([rng.uniform(0.0, 0.4), rng.uniform(-0.05, 0.3), 0.0])
        if np.all(np.isfinite(np.asarray(t.mechanism.inverse(x, params)))):
            out.append(x)
    return np.array(out)


def fd_inverse_jacobians(xs, p, h=1e-7):
    """J^-1 = dq/dx at the poses ``xs`` (``(n, 3)``) by central differences of the closed-form inverse
    position (no autodiff), all poses at once: ``(n, 3, 3)``."""
    cols = []
    for j in range(3):
        dz = np.zeros(3)
        dz[j] = h
        plus, minus = (np.asarray(t.mechanism.inverse((xs + sgn * dz).T, p)) for sgn in (1, -1))
        cols.append((plus - minus).T / (2 * h))
    return np.stack(cols, axis=2)


def numpy_concurrence(xs, p):
    """The distal lines as cross products of homogeneous points, normalised, and numpy's det (``(n,)``)."""
    q = np.asarray(t.mechanism.inverse(xs.T, p)).T
    out = []
    for x, qq in zip(xs, q):
        rows = []
        for i in range(3):
            B = np.asarray(p.base[i]) + p.l1 * np.array([np.cos(qq[i]), np.sin(qq[i])])
            g = t.GAMMA[i] + x[2]
            C = x[:2] + p.r_p * np.array([np.cos(g), np.sin(g)])
            line = np.cross([*B, 1.0], [*C, 1.0])
            rows.append(line / np.hypot(line[0], line[1]))
        out.append(np.linalg.det(np.array(rows)))
    return np.array(out)


def first_root(f_batch, f_scalar, lo, hi, n=241):
    """A sign change of ``f_batch`` on ``n`` samples of [lo, hi], refined by brentq on ``f_scalar``."""
    s = np.linspace(lo, hi, n)
    v = np.asarray(f_batch(s))
    k = np.flatnonzero(np.isfinite(v[:-1]) & np.isfinite(v[1:]) & (np.sign(v[:-1]) != np.sign(v[1:])))
    assert len(k), "expected a sign change"
    return optimize.brentq(lambda z: float(f_scalar(z)), s[k[0]], s[k[0] + 1], xtol=1e-15)


def det_A_along_y(x_P, p):
    return jax.jit(lambda y: t.pose_criteria(t.pose(x_P + 0 * y, y, PHI + 0 * y), p, V=0.1, force=10.0)["det_A"])


def test_distal_concurrence_equals_the_numpy_line_geometry(params, poses):
    ours = np.asarray(t.distal_concurrence(poses.T, params))  # batched
    np.testing.assert_allclose(np.abs(ours), np.abs(numpy_concurrence(poses, params)), atol=1e-12)
    assert abs(float(t.distal_concurrence(poses[0], params)) - ours[0]) < 1e-14  # one pose gives the same


def test_distal_concurrence_vanishes_where_det_A_does(params):
    # a root of det(A) along y_P at x_P = 0.08 (the window of Fig 3b), independently of pk's refinement
    f = det_A_along_y(0.08, params)
    y0 = first_root(f, f, -0.06, 0.06)
    typical = abs(numpy_concurrence(np.array([[0.2, 0.1155, 0.0]]), params)[0])
    assert abs(float(t.distal_concurrence(t.pose(0.08, y0, PHI), params))) < 1e-9 * typical
    assert abs(float(t.distal_concurrence(t.pose(0.08, y0 + 0.01, PHI), params))) > 1e-4 * typical


def test_worst_direction_and_chain_switches_from_finite_differences(params, poses):
    wy = np.asarray(t.worst_direction_y(poses.T, params))
    sw = np.asarray(t.chain_switches(poses.T, params))
    for n, Ji in enumerate(fd_inverse_jacobians(poses, params)):
        JT = np.linalg.inv(Ji).T
        a, b = Ji[:, :2], JT[:, :2]
        ia, ib = np.argmax(np.sum(a * a, 1)), np.argmax(np.sum(b * b, 1))
        np.testing.assert_allclose(wy[:, n], [a[ia, 1], b[ib, 1]], rtol=1e-5, atol=1e-9)
        expected = [ia, np.argmax(np.abs(Ji[:, 0])), ib, np.argmax(np.abs(JT[:, 0]))]
        np.testing.assert_array_equal(sw[:, n], expected)


def test_delta_vanishes_where_the_worst_direction_is_x(params):
    # along x_P at y_P = 0.15 the y component of the worst row changes sign; there Delta q = 0
    f = jax.jit(lambda xx: t.worst_direction_y(t.pose(xx, 0.15 + 0 * xx, PHI + 0 * xx), params)[0])
    x0 = first_root(f, f, 0.05, 0.35, 121)
    c = t.pose_criteria(t.pose(x0, 0.15, PHI), params, V=0.1, force=10.0)
    assert abs(float(c["delta_q"])) < 1e-9 * float(c["max_joint_velocity"])


def test_switch_seams_by_hand():
    inside = np.ones((3, 3), bool)
    inside[2, 2] = False
    switch = np.zeros((3, 3, 1), int)
    switch[0, 0, 0] = 1  # differs from both neighbours (1, 0) and (0, 1): each segment marks its lower end
    seams = t.switch_seams(switch, inside)
    assert seams[0, 0] and seams.sum() == 1
    switch[2, 1, 0] = 1  # its segments to (1, 1) and (2, 0) count, the one to the outside point (2, 2) does not
    seams = t.switch_seams(switch, inside)
    assert seams[1, 1] and seams[2, 0] and not seams[2, 1] and seams.sum() == 3


def test_distance_maps_and_band_median_by_brute_force(params):
    grid = pk.Grid.from_ranges(x_P=(0.0, 0.1, 0.01), y_P=(0.0, 0.05, 0.01))
    inside = np.ones(grid.shape, bool)
    inside[0, :] = False
    centres = np.array([[0.05, 0.02]])
    roots = np.array([[0.02, 0.03], [0.09, 0.0]])
    d = t.distance_maps(grid, inside, centres, roots)
    pts = grid.points().reshape(*grid.shape, 2)
    outside = pts[~inside]
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            if not inside[i, j]:
                continue
            edge = np.min(np.hypot(*(outside - pts[i, j]).T))
            assert abs(d["edge"][i, j] - edge) < 1e-12
            assert abs(d["type1"][i, j] - min(edge, np.hypot(*(centres[0] - pts[i, j])))) < 1e-12
            assert abs(d["type2"][i, j] - np.min(np.hypot(*(roots - pts[i, j]).T))) < 1e-12
    values = np.arange(inside.size, dtype=float).reshape(grid.shape)
    sel = inside & (d["edge"] > 0.005) & (d["edge"] <= 0.02)
    assert t.band_median(values, d["edge"], inside, 0.005, 0.02) == np.median(values[sel])
    assert np.isnan(t.band_median(values, d["edge"], inside, 5.0, 6.0))


def test_excess_zeros_are_zeros_of_delta(params):
    grid = pk.Grid.from_ranges(x_P=(0.0, 0.4, 0.02), y_P=(-0.05, 0.3, 0.02))
    zeros = t.excess_zeros(grid, PHI, params, (1, 1, 1), V=0.1, force=10.0)
    assert set(zeros) == {"Delta q", "Delta e"}
    for name, key, full in (
        ("Delta q", "delta_q", "max_joint_velocity"),
        ("Delta e", "delta_e", "max_actuator_torque"),
    ):
        z, largest, switches = zeros[name]
        assert len(z) > 0 and largest < 1e-9 and switches >= 0
        c = t.pose_criteria(t.pose(z[:, 0], z[:, 1], PHI), params, V=0.1, force=10.0)
        assert np.all(np.abs(np.asarray(c[key])) < 1e-9 * np.asarray(c[full]))


def test_concurrent_crossings_and_nearest_distance(params):
    f = det_A_along_y(0.08, params)
    root = [0.08, first_root(f, f, -0.06, 0.06)]
    sample = np.array([[0.2, 0.1155], [0.15, 0.09], [0.25, 0.15]])
    mask, typical = t.concurrent_crossings(np.array([root, [0.2, 0.1155]]), sample, PHI, params, (1, 1, 1))
    assert typical > 0 and mask[0] and not mask[1]
    assert t.nearest_distance(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0], [10.0, 0.0]]))[0] == 5.0


def test_torque_map_and_probes_equal_pose_criteria(params):
    grid = pk.Grid.from_ranges(x_P=(0.1, 0.3, 0.05), y_P=(0.05, 0.2, 0.05))
    e = t.torque_map(grid, PHI, params, (1, 1, 1), V=0.1, force=10.0)
    pts = grid.points().reshape(-1, 2)
    c = t.pose_criteria(t.pose(pts[:, 0], pts[:, 1], PHI), params, V=0.1, force=10.0)
    np.testing.assert_allclose(e.ravel(), np.asarray(c["max_actuator_torque"]), rtol=1e-12)
    rows = t.probes([(0.2, 0.1155), (0.15, 0.09)], 0.0, params, (1, 1, 1), V=0.1, force=10.0)
    assert [r["x_P_m"] for r in rows] == [0.2, 0.15]
    one = t.pose_criteria(t.pose(0.15, 0.09, 0.0), params, V=0.1, force=10.0)
    assert abs(rows[1]["max_actuator_torque_N_m"] - float(one["max_actuator_torque"])) < 1e-12


def test_study_parameters_accept_the_paper_values():
    values = {name: spec.paper for name, spec in t.STUDY_PARAMETERS.items()}
    assert pk.tools.check_parameters(values, t.STUDY_PARAMETERS) is True
    assert pk.tools.check_parameters(values | {"phi_deg": 10.0}, t.STUDY_PARAMETERS) is False
    with pytest.raises(ValueError, match="step_m"):
        pk.tools.check_parameters(values | {"step_m": -1.0}, t.STUDY_PARAMETERS)


def test_band_median_and_folded_centres_refuse_what_would_be_a_silent_nan():
    p = t.load_params()
    v, d, inside = np.arange(5.0), np.arange(5.0), np.ones(5, bool)
    assert t.band_median(v, d, inside, a=0.5, b=3.0) == 2.0  # distances 1, 2, 3
    for a, b, named in ((3.0, 1.0, "a must be less than b"), (1.0, 1.0, "a must be less than b"), (np.nan, 1.0, "a")):
        with pytest.raises(ValueError, match=named):
            t.band_median(v, d, inside, a=a, b=b)
    assert np.all(np.isfinite(t.folded_chain_centres(0.1, p)))
    for phi in (np.nan, np.inf, "0.1"):
        with pytest.raises(ValueError, match="phi"):
            t.folded_chain_centres(phi, p)
