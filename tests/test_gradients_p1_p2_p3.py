"""Gradients of the public criteria (P1 eq (6), (8), (12)-(13); P2 eq (4), (6), (9)) and of
P3's kinematic quantities with respect to the pose and the geometry: ``jax`` derivatives against
central differences at random interior poses, NaN-free, and the stated choices at zero groups and
ties (see :mod:`pkmlib._criteria`)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from pkmlib.mechanisms import three_rrr as t
from pkmlib.mechanisms import two_t_one_r as m3
from conftest import assert_close, central_difference

P1_SPEEDS = (1.0, 1.0, 1.0)
P1_LOADS = (1.0, 1.0, 1.0)
P1_LOAD = (1.0, 1.0, 0.1)


def _p1_values(x, p):
    """Every P1 map quantity (P1 eq (6), (8), (12)-(13)) plus the load reserve at one pose."""
    crit = m.pose_criteria(x, p, speeds=P1_SPEEDS, loads=P1_LOADS, F_pr=100.0, external_load=P1_LOAD)
    J = pk.jacobian(m.mechanism, x, crit["q"], p)
    reserve = pk.load_reserve(J, 100.0, jnp.array([*P1_LOAD, 0.0]), m.GRIPPER_INDEX)
    norms = pk.row_group_norms(pk.inverse_jacobian(m.mechanism, x, crit["q"], p), m.OUTPUT_GROUPS, P1_SPEEDS)
    return jnp.concatenate(
        [
            jnp.stack(
                [
                    crit[k]
                    for k in (
                        "det_A",
                        "det_B",
                        "max_carriage_velocity",
                        "max_carriage_force",
                        "max_gripper_force_no_load",
                        "max_gripper_force_with_load",
                    )
                ]
            ),
            reserve[None],
            norms,
            m.max_carriage_velocity(x, p, P1_SPEEDS)[None],
        ]
    )


def _check_derivative(f, args, z, h, atol, what):
    """``f(z, *args)``'s reverse-mode Jacobian in ``z`` (what ``jax.grad`` uses) against central
    differences. ``f`` is a module-level function, so each test compiles it once for all poses."""
    z = jnp.asarray(z)
    auto = np.asarray(_jitted(jax.jacrev, f)(z, *args))
    fd = central_difference(lambda v: _jitted(None, f)(jnp.asarray(v), *args), np.asarray(z), h=h)
    assert np.all(np.isfinite(auto)), f"NaN/inf derivative of {what} at {z}"
    scale = np.maximum(np.abs(fd), 1.0)
    assert_close(auto / scale, fd / scale, rtol=0, atol=atol, err_msg=what)


_JITTED = {}


def _jitted(transform, f):
    key = (transform, f)
    if key not in _JITTED:
        _JITTED[key] = jax.jit(f if transform is None else transform(f))
    return _JITTED[key]


def test_p1_issue_example_max_carriage_velocity_gradient_is_finite_and_right(p1_params):
    """The issue's case: grad of eq (6) at an interior pose was [nan, nan, nan, .] (sqrt(0) in the
    gripper group of chains 21, 22, whose J^-1 entry is exactly 0)."""
    x = np.array([0.7, 0.0, np.deg2rad(20.0), 0.14])
    f = lambda z: m.max_carriage_velocity(z, p1_params, P1_SPEEDS)  # noqa: E731
    g = np.asarray(jax.grad(f)(jnp.asarray(x)))
    J_inv = np.asarray(pk.inverse_jacobian(m.mechanism, x, m.mechanism.inverse(x, p1_params), p1_params))
    assert J_inv[2, 3] == 0.0 and J_inv[3, 3] == 0.0  # the zero entries that made sqrt(0)
    assert_close(g, central_difference(lambda z: np.asarray(f(z))[None], x, h=1e-7)[0], rtol=1e-6, atol=1e-9)


def test_p1_criteria_gradients_wrt_pose(p1_params, p1_poses):
    for x in p1_poses[:10]:
        _check_derivative(_p1_values, (p1_params,), x, 1e-7, 1e-5, f"P1 criteria at {x}")


P1_LENGTHS = ("l_B11C1", "l_B12C1", "l_B21C2", "l_B22C2", "l_C2D")


def _p1_values_of_lengths(z, x, p):
    return _p1_values(x, dataclasses.replace(p, **{n: z[k] for k, n in enumerate(P1_LENGTHS)}))


def test_p1_criteria_gradients_wrt_geometry(p1_params, p1_poses):
    z0 = np.array([getattr(p1_params, n) for n in P1_LENGTHS])
    for x in p1_poses[:6]:
        _check_derivative(
            _p1_values_of_lengths, (jnp.asarray(x), p1_params), z0, 1e-7, 1e-5, f"P1 criteria w.r.t. lengths at {x}"
        )


@pytest.fixture(scope="module")
def p2_params():
    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


@pytest.fixture(scope="module")
def p2_poses(p2_params):
    rng = np.random.default_rng(12)
    out = []
    while len(out) < 8:
        x = np.array([rng.uniform(0.0, 0.4), rng.uniform(-0.05, 0.3), np.deg2rad(rng.uniform(-30, 30))])
        J_inv = np.asarray(pk.inverse_jacobian(t.mechanism, x, t.mechanism.inverse(x, p2_params), p2_params))
        if np.all(np.isfinite(J_inv)) and np.linalg.cond(J_inv) < 1e3:
            out.append(x)
    return np.array(out)


def _p2_values(x, p):
    crit = t.pose_criteria(x, p, V=0.1, force=10.0)
    return jnp.concatenate(
        [
            crit["q"],
            jnp.stack(
                [crit[k] for k in ("det_A", "det_B", "max_joint_velocity", "max_actuator_torque", "delta_q", "delta_e")]
            ),
        ]
    )


def test_p2_criteria_gradients_wrt_pose(p2_params, p2_poses):
    for x in p2_poses:
        _check_derivative(_p2_values, (p2_params,), x, 1e-7, 1e-5, f"P2 criteria at {x}")


def _p2_values_of_lengths(z, x, p):
    return _p2_values(x, dataclasses.replace(p, l1=z[0], l2=z[1], r_p=z[2]))


def test_p2_criteria_gradients_wrt_link_lengths(p2_params, p2_poses):
    z0 = np.array([p2_params.l1, p2_params.l2, p2_params.r_p])
    for x in p2_poses[:4]:
        _check_derivative(
            _p2_values_of_lengths, (jnp.asarray(x), p2_params), z0, 1e-7, 1e-5, f"P2 criteria w.r.t. l1, l2, r_p at {x}"
        )


def _p3_values(mech, x, p):
    q = mech.inverse(x, p)
    return jnp.concatenate(
        [q, pk.det_A(mech, x, q, p)[None], pk.det_B(mech, x, q, p)[None], pk.inverse_jacobian(mech, x, q, p).ravel()]
    )


@pytest.mark.parametrize("which", ["A", "B"])
def test_p3_kinematics_gradients_wrt_pose(which):
    """det(A), det(B) and J^-1 (P3 eq (18)-(21)) of mechanisms A and B, read-only use of the module."""
    P = pk.load_params("p3")
    if which == "A":
        mech, p, forward = m3.mechanism_a, m3.ParamsA.from_dict(P["mechanism_A"]), m3.forward_a
        branches = [1.0, -1.0]
    else:
        mech, p, forward = m3.mechanism_b, m3.ParamsB.from_dict(P["mechanism_B"]), m3.forward_b
        branches = [jnp.array(b) for b in m3.FORWARD_BRANCHES["B"]]
    values = jax.jit(_p3_values, static_argnums=0)
    jac = jax.jit(jax.jacfwd(_p3_values, argnums=1), static_argnums=0)
    rng = np.random.default_rng(33)
    poses = []
    while len(poses) < 6:
        q = jnp.array([rng.uniform(-250.0, 0.0), rng.uniform(0.0, 250.0), rng.uniform(-300.0, 300.0)])
        for br in branches:
            x = np.asarray(forward(q, p, br))
            if np.all(np.isfinite(x)) and np.all(np.isfinite(np.asarray(values(mech, jnp.asarray(x), p)))):
                J_inv = np.asarray(pk.inverse_jacobian(mech, x, mech.inverse(x, p), p))
                if np.linalg.cond(J_inv) < 1e4:
                    poses.append(x)
    for x in poses:
        h = np.array([1e-3, 1e-3, 1e-5])  # mm, mm, rad
        auto = np.asarray(jac(mech, jnp.asarray(x), p))
        assert np.all(np.isfinite(auto)), f"P3 {which}: NaN derivative at {x}"
        fd = np.stack(
            [
                (
                    np.asarray(values(mech, jnp.asarray(x + hk * e), p))
                    - np.asarray(values(mech, jnp.asarray(x - hk * e), p))
                )
                / (2 * hk)
                for hk, e in zip(h, np.eye(3))
            ],
            axis=1,
        )
        # relative to each quantity's largest derivative (entries span mm, rad and mm^2 scales), or
        # to 1e-4 of its value where it is constant (J^-1_11 of B is 1: its differences are noise)
        v = np.abs(np.asarray(values(mech, jnp.asarray(x), p)))[:, None]
        scale = np.maximum(np.max(np.abs(fd), axis=1, keepdims=True), 1e-4 * np.maximum(v, 1.0))
        assert_close(auto / scale, fd / scale, rtol=0, atol=1e-5, err_msg=f"P3 {which} at {x}")


def test_zero_group_has_the_stated_zero_derivative():
    """||(a, b)|| at (0, 0) and |c| at 0: derivative 0 (least-norm subgradient), never NaN."""

    def f(z):
        M = jnp.stack([jnp.stack([z[0], z[1], z[2]]), jnp.stack([1.0 + z[0], 2.0 * z[1], 3.0 + z[2]])])
        return pk.row_group_norms(M, ((0, 1), (2,)), (1.0, 2.0))

    J = np.asarray(jax.jacfwd(f)(jnp.zeros(3)))
    assert_close(J, [[0.0, 0.0, 0.0], [1.0, 0.0, 2.0]], atol=0)
    assert_close(np.asarray(jax.jacrev(f)(jnp.zeros(3))), J, atol=0)
    # away from zero it is the ordinary norm derivative
    z = jnp.array([0.3, -0.4, 0.2])
    assert_close(np.asarray(jax.jacfwd(f)(z))[0], [0.6, -0.8, 2.0], rtol=1e-14)


def test_max_over_rows_at_a_tie_takes_the_first_active_row():
    def f(z):
        # both rows have norm |z0| + ... equal at z = (1, 1): a tie; row 0 changes with z[0], row 1 with z[1]
        M = jnp.stack([jnp.stack([z[0], 0.0 * z[1]]), jnp.stack([0.0 * z[0], z[1]])])
        return pk.max_actuator_velocity(M, ((0, 1),), (1.0,))

    assert_close(np.asarray(jax.grad(f)(jnp.array([1.0, 1.0]))), [1.0, 0.0], atol=0)
    assert_close(np.asarray(jax.grad(f)(jnp.array([1.0, 2.0]))), [0.0, 1.0], atol=0)
    # NaN (outside the workspace) in any row still propagates
    assert np.isnan(float(f(jnp.array([1.0, np.nan]))))
    assert np.isnan(float(f(jnp.array([np.nan, 1.0]))))


def test_gripper_force_with_an_unloaded_actuator_has_finite_gradient():
    """An actuator with e^hat_k = 0 (eq (12) denominator) allows any F_s: no NaN, no gradient from it."""

    def f(z):
        J = jnp.diag(jnp.stack([1.0 + z[0], 2.0, 0.5, 1.0])).at[3, 1].set(0.0)
        J = J.at[3].set(jnp.stack([z[1], 0.0, 0.0, 2.0]))  # gripper row: actuators 1, 2 unloaded
        return pk.max_gripper_force(J, 100.0, jnp.array([1.0, 0.5, 0.0, 0.0]), 3)

    z = jnp.array([0.1, 0.5])
    g = np.asarray(jax.grad(f)(z))
    assert np.all(np.isfinite(g)) and np.isfinite(float(f(z)))
    assert_close(
        g,
        central_difference(lambda v: np.asarray(f(jnp.asarray(v)))[None], np.asarray(z), h=1e-7)[0],
        rtol=1e-6,
        atol=1e-9,
    )
