"""P5: screws, relative moments, Newton-Euler dynamics and the 6-PRRS / 6-PRPS force screws.

Independent checks: the line-distance formula and the body-frame formula of the moment, finite
differences of autodiff derivatives, conservation laws of the simulated free body, the
integrator's order of convergence, and the numbers P5 prints (where the geometry confirms them).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_close, central_difference

import pkmlib as pk
from pkmlib.mechanisms import decoupled_6dof as m

OMEGA = np.array([3.0, 2.0, 1.0])
FORCES = np.array([1.0, 1.0, 2.0, 2.0, 3.0, 3.0])
T_PAPER = np.array([0.1, 0.15, 0.2])


@pytest.fixture(scope="module")
def p5():
    return m.Decoupled6DofParams.from_dict(pk.load_params("p5")["mechanism"])


@pytest.fixture(scope="module")
def R_paper():
    return pk.rotation_matrix(np.pi / 6, np.pi / 6, np.pi / 6)


def random_rotation(rng):
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def rodrigues(v):
    """exp([v]x) by the textbook formula (independent of pkmlib)."""
    th = np.linalg.norm(v)
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]]) / th
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


# ---------------------------------------------------------------- screws


def test_rotation_matrix_is_Rgamma_Rbeta_Ralpha_about_fixed_axes():
    a, b, g = 0.3, -0.7, 1.1
    expected = rodrigues(np.array([0, 0, g])) @ rodrigues(np.array([0, b, 0])) @ rodrigues(np.array([a, 0, 0]))
    assert_close(pk.rotation_matrix(a, b, g), expected, atol=1e-15)
    M = pk.homogeneous_transform(a, b, g, jnp.array([1.0, 2.0, 3.0]))
    assert_close(M[3], [0, 0, 0, 1], atol=0)
    pts = np.array([[0.1, 0.2, 0.3], [-1.0, 0.5, 2.0]])
    assert_close(pk.transform_points(M, pts), pts @ expected.T + np.array([[1.0, 2.0, 3.0]]), atol=1e-15)


def test_relative_moment_is_invariant_under_change_of_reference_point():
    rng = np.random.default_rng(1)
    for _ in range(10):
        S1 = pk.unit_screw(jnp.asarray(rng.normal(size=3)), jnp.asarray(rng.normal(size=3)), rng.normal())
        S2 = pk.unit_screw(jnp.asarray(rng.normal(size=3)), jnp.asarray(rng.normal(size=3)), rng.normal())
        d = jnp.asarray(rng.normal(size=3) * 5)
        assert_close(
            pk.relative_moment(pk.shift_reference(S1, d), pk.shift_reference(S2, d)),
            pk.relative_moment(S1, S2),
            rtol=1e-12,
            atol=1e-13,
        )


def test_relative_moment_of_two_lines_is_distance_times_sine():
    rng = np.random.default_rng(2)
    for _ in range(10):
        p1, p2, s1, s2 = (rng.normal(size=3) for _ in range(4))
        s1, s2 = s1 / np.linalg.norm(s1), s2 / np.linalg.norm(s2)
        n = np.cross(s1, s2)
        dist = abs((p2 - p1) @ n) / np.linalg.norm(n)  # common normal length, textbook
        mom = pk.relative_moment(pk.line(jnp.asarray(s1), jnp.asarray(p1)), pk.line(jnp.asarray(s2), jnp.asarray(p2)))
        assert_close(abs(float(mom)), dist * np.linalg.norm(n), rtol=1e-12)
        assert_close(mom, (p2 - p1) @ np.cross(s2, s1), rtol=1e-12, atol=1e-14)


def test_force_through_the_centre_gives_no_moment(p5):
    rng = np.random.default_rng(3)
    for _ in range(5):
        T, R = jnp.asarray(rng.normal(size=3)), jnp.asarray(random_rotation(rng))
        force = pk.line(jnp.asarray(rng.normal(size=3)), T)  # through O_m
        assert_close(pk.relative_moment(force[None, :], m.axis_screws(T, R)), np.zeros(3), atol=1e-15)
    # and a platform point placed at the centre (a -> 0) carries no moment
    tiny = m.Decoupled6DofParams.create(a=1e-300, mass=1.0, J_xi=1.0, J_eta=1.0, J_zeta=1.0)
    assert_close(m.relative_moments(T, R, tiny), np.zeros((3, 6)), atol=1e-15)


def test_relative_moments_equal_the_body_frame_cross_product(p5):
    """mom(R_i, e_l) = r_i . R (e_l x p_i) with p_i = A_i^m: independent of the translation."""
    rng = np.random.default_rng(4)
    for _ in range(5):
        T, R = rng.normal(size=3), random_rotation(rng)
        P = p5.a * m.PLATFORM_POINTS_UNIT
        expected = np.array(
            [[m.FORCE_DIRECTIONS[i] @ R @ np.cross(np.eye(3)[l], P[i]) for i in range(6)] for l in range(3)]
        )
        assert_close(m.relative_moments(jnp.asarray(T), jnp.asarray(R), p5), expected, atol=1e-15)


def test_wrench_jacobian_matches_finite_differences_and_relative_moments(p5, R_paper):
    T = jnp.asarray(T_PAPER)
    Jw = np.asarray(m.wrench_jacobian(T, R_paper, p5))
    h = 1e-6
    fd = np.zeros((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        qp = m.actuator_coordinates(T + e[:3], R_paper @ rodrigues(e[3:]) if k >= 3 else R_paper, p5)
        qm = m.actuator_coordinates(T - e[:3], R_paper @ rodrigues(-e[3:]) if k >= 3 else R_paper, p5)
        fd[:, k] = (np.asarray(qp) - np.asarray(qm)) / (2 * h)
    assert_close(Jw, fd, atol=1e-9)
    assert_close(Jw[:, :3], m.FORCE_DIRECTIONS, atol=1e-15)  # unit transmission in translation
    assert_close(Jw[:, 3:].T, m.relative_moments(T, R_paper, p5), atol=1e-15)


def test_angular_velocity_from_angle_rates_matches_finite_differences():
    angles, rates = np.array([0.3, -0.5, 0.9]), np.array([0.7, 1.3, -0.4])
    h = 1e-6
    Rdot = (
        np.asarray(pk.rotation_matrix(*(angles + h * rates))) - np.asarray(pk.rotation_matrix(*(angles - h * rates)))
    ) / (2 * h)
    W = np.asarray(pk.rotation_matrix(*angles)).T @ Rdot
    assert_close(
        pk.dynamics.angular_velocity_from_angle_rates(jnp.asarray(angles), jnp.asarray(rates)),
        [W[2, 1], W[0, 2], W[1, 0]],
        atol=1e-9,
    )


# ---------------------------------------------------------------- the paper's example


def test_paper_example_points_axes_and_moments(p5, R_paper):
    T = jnp.asarray(T_PAPER)
    printed_A = [
        [0.016, 0.259, 0.168],
        [0.184, 0.041, 0.232],
        [0.088, 0.085, 0.325],
        [0.113, 0.215, 0.075],
        [0.003, 0.194, 0.293],
        [0.197, 0.106, 0.107],
    ]
    assert_close(m.platform_points_base(T, R_paper, p5), printed_A, atol=0.5e-3 + 1e-12)  # 3 printed decimals
    axes = np.asarray(m.axis_screws(T, R_paper))
    assert_close(axes[0], [0.75, 0.43, -0.5, -0.16, 0.2, -0.07], atol=0.5e-2 + 1e-12)
    assert_close(axes[2, :3], [0.625, -0.217, 0.75], atol=0.5e-3 + 1e-12)
    mom = np.asarray(m.relative_moments(T, R_paper, p5))
    assert_close(mom[1], [-0.075, 0.075, 0.022, -0.022, 0.075, -0.075], atol=0.5e-3 + 1e-12)
    assert_close(mom[0, :5], [0.041, -0.041, -0.088, 0.088, 0.075], atol=0.5e-3 + 1e-12)
    # P5 prints mom(R6, xi) = -0.041; chains 5 and 6 are opposite (A6 - O_m = -(A5 - O_m), same r),
    # so mom(R6, .) = -mom(R5, .) exactly: the printed value is an erratum
    assert_close(mom[:, 5], -mom[:, 4], atol=1e-16)
    assert abs(mom[0, 5] - (-0.041)) > 0.03
    # mom(R5, zeta) = -a (xi_z + eta_z) = a (1/2 - sqrt(3)/4): P5's 0.0069 is off in the last digit
    assert_close(mom[2, 4], 0.1 * (0.5 - np.sqrt(3) / 4), rtol=1e-12)


def test_paper_example_accelerations_and_implied_inertia(p5, R_paper):
    T = jnp.asarray(T_PAPER)
    a, eps = m.forward_dynamics(T, R_paper, jnp.asarray(OMEGA), jnp.asarray(FORCES), p5)
    assert_close(a, [2.0, 4.0, 6.0], rtol=1e-14)
    assert_close(np.linalg.norm(a), 7.483, atol=0.5e-3)
    _, M = m.platform_wrench(T, R_paper, jnp.asarray(FORCES), p5)
    assert_close(M, np.zeros(3), atol=1e-15)  # equal forces in every pair: no moment
    # P5's printed Euler equations with J proportional to (45, 40, 13) give the printed values
    J = jnp.array([45.0, 40.0, 13.0]) * 1e-4
    assert_close(
        pk.dynamics.newton_euler_as_printed(J, jnp.zeros(3), jnp.asarray(OMEGA)), [1.2, 2.4, 30 / 13], rtol=1e-14
    )
    assert_close(np.linalg.norm([1.2, 2.4, 30 / 13]), 3.539, atol=0.5e-3)
    # ... and the printed (rounded) accelerations make P5's coefficient matrix singular to rounding,
    C = np.asarray(pk.dynamics.euler_coefficients(jnp.asarray(OMEGA), jnp.array([1.2, 2.4, 2.308]), printed_signs=True))
    s = np.linalg.svd(C, compute_uv=False)
    assert s[-1] / s[0] < 1e-5
    null = np.linalg.svd(C)[2][-1]
    assert_close(null / null[2] * 13, [45.0, 40.0, 13.0], rtol=1e-3)
    # while Euler's (correct) equations with M = 0 admit only J = 0 (full rank) ...
    Cc = np.asarray(pk.dynamics.euler_coefficients(jnp.asarray(OMEGA), jnp.array([1.2, 2.4, 2.308])))
    assert np.linalg.svd(Cc, compute_uv=False)[-1] > 1.0
    # ... since torque-free motion keeps omega . J eps = 0, impossible with all terms positive
    J_used = np.asarray(p5.inertia)
    assert_close(np.dot(OMEGA * J_used, eps), 0.0, atol=1e-15)
    assert_close(eps, [1.2, -2.4, 30 / 13], rtol=1e-12)  # our box has the implied ratio 45 : 40 : 13
    assert_close(J_used / J_used[2] * 13, [45.0, 40.0, 13.0], rtol=1e-12)


def test_symmetric_paired_forces_give_zero_angular_acceleration(p5):
    rng = np.random.default_rng(5)
    for _ in range(5):
        T, R = jnp.asarray(rng.normal(size=3) * 0.1), jnp.asarray(random_rotation(rng))
        pair = rng.normal(size=3)
        forces = jnp.asarray(np.repeat(pair, 2))
        a, eps = m.forward_dynamics(T, R, jnp.zeros(3), forces, p5)
        assert_close(eps, np.zeros(3), atol=1e-12)  # round-off of M ~ 1e-17 N m over J ~ 3e-3 kg m^2
        assert_close(a, 2.0 * pair / p5.mass, rtol=1e-14)
        # unequal forces in a pair do turn the platform
        _, eps2 = m.forward_dynamics(T, R, jnp.zeros(3), forces.at[0].add(1.0), p5)
        assert np.linalg.norm(eps2) > 1.0


def test_paired_forces_from_rest_give_pure_translation(p5, R_paper):
    state = pk.dynamics.RigidBodyState(jnp.asarray(T_PAPER), jnp.zeros(3), R_paper, jnp.zeros(3))
    dt, n = 1e-3, 500
    traj = m.simulate(state, jnp.asarray(FORCES), p5, dt, n)
    assert_close(traj.rotation - R_paper[None], np.zeros((n + 1, 3, 3)), atol=1e-15)
    t = dt * np.arange(n + 1)  # the trajectory starts with the initial state at t = 0
    F = FORCES @ m.FORCE_DIRECTIONS
    assert_close(traj.position, T_PAPER[None, :] + 0.5 * (F / p5.mass)[None, :] * t[:, None] ** 2, rtol=1e-12)


# ---------------------------------------------------------------- Newton-Euler and the integrator


def test_newton_euler_conserves_energy_and_angular_momentum_with_zero_forces(p5, R_paper):
    state = pk.dynamics.RigidBodyState(jnp.asarray(T_PAPER), jnp.array([0.1, -0.2, 0.05]), R_paper, jnp.asarray(OMEGA))
    traj = m.simulate(state, jnp.zeros(6), p5, 1e-3, 3000)
    E = np.asarray(pk.dynamics.kinetic_energy(traj, p5.mass, p5.inertia))
    E0 = float(pk.dynamics.kinetic_energy(state, p5.mass, p5.inertia))
    L = np.asarray(pk.dynamics.angular_momentum(traj, p5.inertia))
    L0 = np.asarray(pk.dynamics.angular_momentum(state, p5.inertia))
    assert np.max(np.abs(E - E0)) / E0 < 2e-6  # bounded O(h^2) error of a symplectic scheme
    assert_close(L, np.broadcast_to(L0, L.shape), atol=1e-13)  # exact up to round-off
    assert np.max(np.asarray(pk.dynamics.rotation_error(traj.rotation))) < 1e-12
    assert abs(np.ptp(traj.omega[:, 0])) > 0.1  # the body really tumbles (omega changes in the body)
    # error shrinks as h^2: the energy error at half the step is about a quarter
    traj2 = m.simulate(state, jnp.zeros(6), p5, 5e-4, 6000)
    E2 = np.asarray(pk.dynamics.kinetic_energy(traj2, p5.mass, p5.inertia))
    ratio = np.max(np.abs(E - E0)) / np.max(np.abs(E2 - E0))
    assert 3.0 < ratio < 5.0


def test_constant_motor_forces_conserve_total_energy(p5, R_paper):
    forces = jnp.array([1.0, 2.0, 2.0, 1.0, 3.0, 0.0])
    state = pk.dynamics.RigidBodyState(jnp.asarray(T_PAPER), jnp.zeros(3), R_paper, jnp.asarray(OMEGA))
    traj = m.simulate(state, forces, p5, 5e-4, 2000)
    V = jax.vmap(lambda pos, R: m.potential_energy(pos, R, forces, p5))(traj.position, traj.rotation)
    E = np.asarray(pk.dynamics.kinetic_energy(traj, p5.mass, p5.inertia) + V)
    E0 = float(
        pk.dynamics.kinetic_energy(state, p5.mass, p5.inertia)
        + m.potential_energy(state.position, state.rotation, forces, p5)
    )
    assert np.max(np.abs(E - E0)) < 1e-5 * abs(E0)
    # the translation is decoupled: m v = F t exactly
    F = np.asarray(forces) @ m.FORCE_DIRECTIONS
    t = 5e-4 * np.arange(2001)
    assert_close(traj.velocity, F[None, :] * t[:, None] / p5.mass, rtol=1e-10, atol=1e-14)


def test_newton_euler_matches_the_integrated_motion(p5, R_paper):
    """eps from Euler's equations equals the time derivative of omega in a fine simulation
    (the integrator never calls newton_euler)."""
    forces = jnp.array([1.0, 2.0, 2.0, 1.0, 3.0, 0.0])
    state = pk.dynamics.RigidBodyState(jnp.asarray(T_PAPER), jnp.zeros(3), R_paper, jnp.asarray(OMEGA))
    h = 1e-5
    traj = m.simulate(state, forces, p5, h, 2)
    _, eps = m.forward_dynamics(state.position, state.rotation, state.omega, forces, p5)
    # the state one step back in time: a step forward with reversed velocities (time reversal)
    back = m.simulate(state._replace(omega=-state.omega, velocity=-state.velocity), forces, p5, h, 1)
    fd = (np.asarray(traj.omega[1]) - np.asarray(-back.omega[1])) / (2 * h)
    assert_close(fd, eps, rtol=1e-6)


def test_newton_euler_sign_of_the_eta_equation():
    J, w = jnp.array([3.0, 2.0, 1.0]), jnp.array([0.5, -1.0, 2.0])
    _, eps = pk.dynamics.newton_euler(1.0, J, jnp.zeros(3), jnp.zeros(3), w)
    # Euler: J2 eps2 = (J3 - J1) w3 w1
    assert_close(eps[1], (1.0 - 3.0) * 2.0 * 0.5 / 2.0, rtol=1e-15)
    printed = pk.dynamics.newton_euler_as_printed(J, jnp.zeros(3), w)
    assert_close(printed[0], eps[0], rtol=1e-15)
    assert_close(printed[2], eps[2], rtol=1e-15)
    assert_close(printed[1], -eps[1], rtol=1e-15)


def test_box_inertia_textbook():
    assert_close(pk.dynamics.box_inertia(12.0, jnp.array([1.0, 2.0, 3.0])), [13.0, 10.0, 5.0], rtol=1e-15)


# ---------------------------------------------------------------- parameters and drawing


def test_params_validation():
    good = {"a_m": 0.1, "mass_kg": 1.0, "J_xi_kg_m2": 1.0, "J_eta_kg_m2": 1.0, "J_zeta_kg_m2": 1.5}
    assert m.Decoupled6DofParams.from_dict(good).J_zeta == 1.5
    with pytest.raises(ValueError, match="mass_kg"):
        m.Decoupled6DofParams.from_dict({"a_m": 0.1})
    with pytest.raises(ValueError, match="a"):
        m.Decoupled6DofParams.create(a=-0.1, mass=1.0, J_xi=1.0, J_eta=1.0, J_zeta=1.0)
    with pytest.raises(ValueError, match="J_zeta"):
        m.Decoupled6DofParams.create(a=0.1, mass=1.0, J_xi=1.0, J_eta=1.0, J_zeta=3.0)
    with pytest.raises(ValueError, match="inertia_box_edges_m"):
        m.Decoupled6DofParams.from_dict({"a_m": 0.1, "mass_kg": 1.0, "inertia_box_edges_m": [0.1, 0.0, 0.2]})


def test_chain_points_respect_the_link_lengths_and_motor_axes(p5, R_paper):
    pts = m.chain_points(jnp.asarray(T_PAPER), R_paper, p5, kind="PRRS", rail_offset=0.4, link_lengths=(0.4, 0.4))
    assert_close(np.linalg.norm(pts["E"] - pts["C"], axis=1), np.full(6, 0.4), rtol=1e-12)
    assert_close(np.linalg.norm(pts["A"] - pts["E"], axis=1), np.full(6, 0.4), rtol=1e-12)
    # both R axes parallel to the motor axis: the links lie in the plane across it
    r = m.FORCE_DIRECTIONS
    assert_close(np.sum((pts["A"] - pts["C"]) * r, axis=1), np.zeros(6), atol=1e-15)
    assert_close(np.sum((pts["E"] - pts["C"]) * r, axis=1), np.zeros(6), atol=1e-15)


# ---------------------------------------------------------------- the params file and its checks


def test_from_dict_takes_the_whole_params_file_or_its_mechanism_part():
    P = pk.load_params("p5")
    whole = m.Decoupled6DofParams.from_dict(P)
    inner = m.Decoupled6DofParams.from_dict(P["mechanism"])
    assert whole == inner
    assert_close(whole.inertia, pk.dynamics.box_inertia(1.0, jnp.array([0.1, 0.15, 0.3])), rtol=1e-15)


@pytest.mark.parametrize(
    "key, value",
    [
        ("a_m", None),
        ("a_m", [0.1]),
        ("a_m", 0.1 + 1j),
        ("a_m", "abc"),
        ("a_m", float("nan")),
        ("a_m", True),
        ("mass_kg", -1.0),
        ("mass_kg", "1"),
        ("inertia_box_edges_m", 0.1),
        ("inertia_box_edges_m", [0.1, 0.2]),
        ("inertia_box_edges_m", None),
        ("inertia_box_edges_m", [0.1, "x", 0.3]),
        ("inertia_box_edges_m", "abc"),
        ("inertia_box_edges_m", [0.1, 0.2, 1j]),
    ],
)
def test_from_dict_names_the_bad_key(key, value):
    d = dict(pk.load_params("p5")["mechanism"])
    d[key] = value
    with pytest.raises(ValueError, match=key):
        m.Decoupled6DofParams.from_dict(d)
    with pytest.raises(ValueError, match=key):
        m.Decoupled6DofParams.from_dict({**pk.load_params("p5"), "mechanism": d})


def test_from_dict_rejects_what_is_not_a_params_dict():
    for bad in (None, [1.0], "p5", 1.0):
        with pytest.raises(ValueError, match="P5 parameters .* must be a mapping"):
            m.Decoupled6DofParams.from_dict(bad)
    with pytest.raises(ValueError, match="unknown 'J_x_kg_m2'"):  # a misspelt key is named, not ignored
        m.Decoupled6DofParams.from_dict({**pk.load_params("p5")["mechanism"], "J_x_kg_m2": 1.0})
    with pytest.raises(ValueError, match="mechanism"):
        m.Decoupled6DofParams.from_dict({"mechanism": [0.1, 1.0]})
    with pytest.raises(ValueError, match="J_xi_kg_m2"):
        m.Decoupled6DofParams.from_dict({"a_m": 0.1, "mass_kg": 1.0})
    with pytest.raises(ValueError, match="J_eta"):
        m.Decoupled6DofParams.create(a=0.1, mass=1.0, J_xi=1.0, J_eta=None, J_zeta=1.0)
    # 0-d arrays are numbers
    assert (
        m.Decoupled6DofParams.create(a=jnp.asarray(0.1), mass=np.float64(1.0), J_xi=1.0, J_eta=1.0, J_zeta=1.0).a == 0.1
    )


# ---------------------------------------------------------------- gradients against central differences


def _rand_pose(rng):
    return rng.normal(size=3) * 0.1, rng.uniform(-1.0, 1.0, 3)


def test_grad_of_screw_functions_matches_central_differences(p5):
    """relative moments, force screws, wrench and forward dynamics as functions of the pose
    (position and P5's angles), the platform size and the forces."""
    rng = np.random.default_rng(7)
    for _ in range(3):
        T, ang = _rand_pose(rng)
        forces = rng.normal(size=6)
        omega = rng.normal(size=3)
        z0 = np.concatenate([T, ang, [p5.a], forces, omega])

        def f(z):
            R = pk.rotation_matrix(z[3], z[4], z[5])
            p = m.Decoupled6DofParams(z[6], p5.mass, p5.J_xi, p5.J_eta, p5.J_zeta)
            a, eps = m.forward_dynamics(z[:3], R, z[13:16], z[7:13], p)
            return jnp.concatenate(
                [
                    m.relative_moments(z[:3], R, p).ravel(),
                    m.force_screws(z[:3], R, p).ravel(),
                    m.actuator_coordinates(z[:3], R, p),
                    a,
                    eps,
                    m.potential_energy(z[:3], R, z[7:13], p)[None],
                ]
            )

        J = np.asarray(jax.jit(jax.jacrev(f))(jnp.asarray(z0)))
        fd = central_difference(jax.jit(f), z0, h=1e-5)
        assert_close(J, fd, rtol=1e-7, atol=1e-7)


def test_grad_of_generic_screws_matches_central_differences():
    rng = np.random.default_rng(8)
    z0 = rng.normal(size=13)  # direction, point, pitch, and a second screw (6)

    def f(z):
        S1 = pk.unit_screw(z[:3], z[3:6], z[6])
        S2 = pk.line(z[7:10], z[10:13])
        return jnp.concatenate(
            [
                S1,
                S2,
                pk.relative_moment(S1, S2)[None],
                pk.shift_reference(S1, z[10:13]),
                pk.homogeneous_transform(z[0], z[1], z[2], z[3:6]).ravel(),
                pk.exp_so3(z[7:10]).ravel(),
                pk.exp_so3(1e-5 * z[7:10]).ravel(),
            ]
        )

    J = np.asarray(jax.jit(jax.jacrev(f))(jnp.asarray(z0)))
    assert_close(J, central_difference(jax.jit(f), z0, h=1e-6), rtol=1e-7, atol=1e-8)


@pytest.mark.parametrize("full", [False, True])
def test_grad_of_newton_euler_and_energies_matches_central_differences(full):
    """newton_euler, kinetic energy and angular momentum with respect to mass, inertia (principal
    or full tensor), force, moment, omega and rotation angles."""
    rng = np.random.default_rng(9)
    n_J = 6 if full else 3
    J0 = np.array([0.02, 0.015, 0.008, 0.003, -0.001, 0.002])[:n_J]
    z0 = np.concatenate(
        [
            [1.3],
            J0,
            rng.normal(size=3),
            rng.normal(size=3),
            rng.normal(size=3),
            rng.normal(size=3),
            rng.uniform(-1, 1, 3),
        ]
    )

    def f(z):
        mass, J = z[0], z[1 : 1 + n_J]
        if full:
            J = jnp.array([[J[0], J[3], J[4]], [J[3], J[1], J[5]], [J[4], J[5], J[2]]])
        F, M, w, v, ang = (z[1 + n_J + 3 * k : 4 + n_J + 3 * k] for k in range(5))
        a, eps = pk.dynamics.newton_euler(mass, J, F, M, w)
        s = pk.dynamics.RigidBodyState(jnp.zeros(3), v, pk.rotation_matrix(ang[0], ang[1], ang[2]), w)
        return jnp.concatenate(
            [a, eps, pk.dynamics.kinetic_energy(s, mass, J)[None], pk.dynamics.angular_momentum(s, J)]
        )

    J = np.asarray(jax.jit(jax.jacrev(f))(jnp.asarray(z0)))
    assert_close(J, central_difference(jax.jit(f), z0, h=1e-7), rtol=1e-6, atol=1e-7)


def test_grad_of_inertia_inference_matches_central_differences():
    """euler_coefficients, box_inertia and the angular velocity from angle rates (the inference of
    J from P5's printed accelerations), with respect to all their inputs."""
    rng = np.random.default_rng(10)
    z0 = np.concatenate(
        [
            rng.normal(size=3),
            rng.normal(size=3),
            [1.2],
            rng.uniform(0.1, 0.3, 3),
            rng.uniform(-1, 1, 3),
            rng.normal(size=3),
        ]
    )

    def f(z):
        return jnp.concatenate(
            [
                pk.dynamics.euler_coefficients(z[:3], z[3:6]).ravel(),
                pk.dynamics.euler_coefficients(z[:3], z[3:6], printed_signs=True).ravel(),
                pk.dynamics.box_inertia(z[6], z[7:10]),
                pk.dynamics.angular_velocity_from_angle_rates(z[10:13], z[13:16]),
                pk.dynamics.newton_euler_as_printed(z[7:10], z[3:6], z[:3]),
            ]
        )

    J = np.asarray(jax.jit(jax.jacrev(f))(jnp.asarray(z0)))
    assert_close(J, central_difference(jax.jit(f), z0, h=1e-6), rtol=1e-7, atol=1e-8)


def test_grad_of_a_simulation_matches_central_differences(p5, R_paper, method="splitting"):
    """d(final position, omega)/d(forces, initial omega) through the compiled integrator
    (forward mode: cheaper to compile through lax.scan than reverse mode)."""
    state = pk.dynamics.RigidBodyState(jnp.asarray(T_PAPER), jnp.zeros(3), R_paper, jnp.asarray(OMEGA))
    z0 = np.concatenate([FORCES + np.arange(6) * 0.1, OMEGA])

    def f(z):
        tr = m.simulate(state._replace(omega=z[6:]), z[:6], p5, 1e-3, 20, method=method)
        return jnp.concatenate([tr.position[-1], tr.omega[-1], tr.rotation[-1].ravel()])

    J = np.asarray(jax.jacfwd(f)(jnp.asarray(z0)))
    assert_close(J, central_difference(f, z0, h=1e-6), rtol=1e-6, atol=1e-8)
