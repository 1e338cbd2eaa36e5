"""P5: what the printed example implies and how its numbers are scored (pkmlib.mechanisms.decoupled_6dof).

Independent checks: the torque-free Euler equations written out by hand, rotation angles of
rotations built by Rodrigues' formula, the closed-form translation against the integrator, the
pair motions solved from a finite-difference Jacobian, and the printed digits of Python's Decimal
written out by hand.
"""

import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import decoupled_6dof as m

OMEGA = np.array([3.0, 2.0, 1.0])
EPS_PRINTED = np.array([1.2, 2.4, 2.308])


@pytest.fixture(scope="module")
def p5():
    return m.Decoupled6DofParams.from_dict(pk.load_params("p5")["mechanism"])


@pytest.fixture(scope="module")
def pose():
    return jnp.array([0.1, 0.15, 0.2]), pk.rotation_matrix(np.pi / 6, np.pi / 6, np.pi / 6)


def rodrigues(axis, angle):
    if angle == 0.0:
        return np.eye(3)
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_implied_inertia_null_vector_solves_the_printed_euler_equations_by_hand():
    out = m.implied_inertia(OMEGA, EPS_PRINTED)
    J = out["ratios"] * 13.0
    np.testing.assert_allclose(J, [45.0, 40.0, 13.0], atol=5e-3)  # P5's digits: 45 : 40 : 13 to the printed rounding
    w, e = OMEGA, EPS_PRINTED
    # P5's equations as printed, torque-free: the eta equation with (J_zeta - J_xi)
    printed = [
        J[0] * e[0] + w[1] * w[2] * (J[2] - J[1]),
        J[1] * e[1] + w[0] * w[2] * (J[2] - J[0]),
        J[2] * e[2] + w[0] * w[1] * (J[1] - J[0]),
    ]
    assert np.max(np.abs(printed)) < 1e-3 * np.max(J)
    assert out["singular_values_printed"][2] < 1e-4 < out["singular_values_euler"][2]
    n = out["null_vector"]
    assert abs(out["energy_rate"] - float(np.sum(n * w * e))) < 1e-15
    # exact eps_zeta = 30/13 makes the printed C exactly singular with null vector (45, 40, 13)
    exact = m.implied_inertia(OMEGA, [1.2, 2.4, 30.0 / 13.0])
    np.testing.assert_allclose(exact["ratios"] * 13.0, [45.0, 40.0, 13.0], rtol=1e-12)


def test_inertia_for_moment_inverts_newton_euler_as_printed(p5):
    M = np.array([0.102, -0.03, 0.05])
    eps = np.asarray(pk.dynamics.newton_euler_as_printed(p5.inertia, jnp.asarray(M), jnp.asarray(OMEGA)))
    np.testing.assert_allclose(m.inertia_for_moment(OMEGA, eps, M), np.asarray(p5.inertia), rtol=1e-10)


def test_turned_angle_of_rodrigues_rotations():
    R0 = rodrigues([1.0, 2.0, -0.5], 0.7)
    angles = np.array([0.0, 0.3, 1.2, 2.9])
    Rs = np.stack([rodrigues([0.2, -1.0, 0.4], a) @ R0 for a in angles])
    np.testing.assert_allclose(np.asarray(m.turned_angle(Rs, R0)), angles, atol=2e-8)


def test_total_energy_is_conserved_and_translation_matches_the_integrator(p5, pose):
    T, R = pose
    P = jnp.array([1.0, 1.0, 2.0, 2.0, 3.0, 3.0])
    rest = pk.dynamics.RigidBodyState(T, jnp.zeros(3), R, jnp.zeros(3))
    traj = m.simulate(rest, P, p5, 1e-3, 200)
    t = 1e-3 * np.arange(201)
    # equal forces in each pair: pure translation, O_m = T + F t^2 / 2m with F = (2, 4, 6) N, m = 1 kg
    expected = np.asarray(T)[None] + 0.5 * np.array([2.0, 4.0, 6.0])[None] / p5.mass * t[:, None] ** 2
    np.testing.assert_allclose(np.asarray(m.translation_closed_form(T, P, p5, t)), expected, atol=1e-15)
    np.testing.assert_allclose(np.asarray(traj.position), expected, atol=1e-12)
    E = np.asarray(m.total_energy(traj, P, p5))
    # kinetic energy m v^2 / 2 equals the work of F: by hand at the last step
    v = np.array([2.0, 4.0, 6.0]) / p5.mass * t[-1]
    assert abs(0.5 * p5.mass * v @ v - np.array([2.0, 4.0, 6.0]) @ (expected[-1] - expected[0])) < 1e-12
    assert np.max(np.abs(E - E[0])) < 1e-12


def test_pair_transmission_from_finite_difference_jacobian(p5, pose):
    T, R = pose
    ratios, rotations = (np.asarray(v) for v in m.pair_transmission(T, R, p5))
    h = 1e-6
    W = np.zeros((6, 6))
    for k in range(6):
        d = np.zeros(6)
        d[k] = h
        plus = m.actuator_coordinates(T + d[:3], R @ rodrigues(d[3:], np.linalg.norm(d[3:])), p5)
        d[k] = -h
        minus = m.actuator_coordinates(T + d[:3], R @ rodrigues(d[3:], np.linalg.norm(d[3:])), p5)
        W[:, k] = (np.asarray(plus) - np.asarray(minus)) / (2 * h)
    for k, (a, b) in enumerate(m.PAIRS):
        dq = np.zeros(6)
        dq[[a, b]] = 1.0
        dX = np.linalg.solve(W, dq)
        assert abs(ratios[k] - np.linalg.norm(dX[:3])) < 1e-7
        assert rotations[k] < 1e-12 and np.linalg.norm(dX[3:]) < 1e-7
    np.testing.assert_allclose(ratios, 1.0, atol=1e-12)


@pytest.mark.parametrize(
    "value, decimals, truncate, expected",
    [(0.0875, 3, False, "0.088"), (0.0875, 3, True, "0.087"), (-0.25915, 2, True, "-0.25"), (-1e-9, 3, False, "0.000")],
)
def test_printed_digits(value, decimals, truncate, expected):
    assert m.printed_digits(value, decimals, truncate=truncate) == expected


def test_score_printed_truncation_by_construction_and_errata():
    # r_1^0 z = -A_1y^b = -0.25915: printed -0.25 is ours truncated (reproduced, noted)
    r = m.score_printed("r_1^0 z", -0.25915)
    assert r["status"] == "reproduced" and r["note"] == m.TRUNCATED_NOTE and r["ours_printed_digits"] == "-0.26"
    # a value that neither rounds nor truncates to the printed digits is not reproduced
    assert m.score_printed("r_1^0 z", -0.2415)["status"] != "reproduced"
    # printed eta_y = -0.87, ours +0.875: erratum with the reference's reason
    r = m.score_printed("eta y", 0.875)
    assert r["status"] == "erratum" and r["note"]
    assert m.score_printed("angular acceleration zeta", 30.0 / 13.0)["status"] == "by construction"
    assert m.score_printed("A_1^b x", 0.01585, paper_run=False)["status"] == "not the paper's parameters"


def test_score_example_covers_every_printed_number_once(p5, pose):
    T, R = pose
    P = jnp.array([1.0, 1.0, 2.0, 2.0, 3.0, 3.0])
    lin, ang = m.forward_dynamics(T, R, jnp.asarray(OMEGA), P, p5)
    groups = m.score_example(
        m.platform_points_base(T, R, p5),
        m.force_screws(T, R, p5),
        m.axis_screws(T, R),
        m.relative_moments(T, R, p5),
        lin,
        ang,
    )
    rows = [r for g in groups.values() for r in g]
    printed = {r["quantity"] for r in pk.tools.load_reference_file("p5")["numbers"]}
    assert len(rows) == len({r["quantity"] for r in rows}) == len(printed) - 1  # the transmission ratio apart
    statuses = [r["status"] for r in rows]
    assert (statuses.count("reproduced"), statuses.count("erratum"), statuses.count("by construction")) == (71, 5, 3)
    table = m.score_table(groups["moments"])
    assert "$\\mathrm{mom}(\\mathbf R_1, \\xi)$" in table.data
    # each status links its row's one place, the scorecard (issue 20.9)
    assert "[reproduced](../scorecard.qmd#p5-" in table.data and "| reproduced |" not in table.data


def test_rail_points_refuse_an_offset_that_is_not_a_positive_length():
    assert np.allclose(m.rail_points(0.4), 0.4 * m.PLATFORM_POINTS_UNIT)
    for bad in (np.nan, 0.0, -0.4, np.inf):
        with pytest.raises(ValueError, match="rail_offset"):
            m.rail_points(bad)
