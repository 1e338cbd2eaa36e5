"""Closed-form criteria (P1 eq (6), (8), (13)) against brute force over sampled directions."""

import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close

N_DIRECTIONS = 3600


def sampled_maximum(M, speeds, n=N_DIRECTIONS):
    """max over k and over directions of |M[k] . v|, the linear group (cols 0, 1) sampled on a
    circle of radius speeds[0], the angular and gripper groups (cols 2, 3) at +-speeds[1], [2]."""
    theta = np.arange(n) * 2 * np.pi / n
    best = 0.0
    for s2 in (-1, 1):
        for s3 in (-1, 1):
            V = np.stack(
                [
                    speeds[0] * np.cos(theta),
                    speeds[0] * np.sin(theta),
                    np.full(n, s2 * speeds[1]),
                    np.full(n, s3 * speeds[2]),
                ]
            )
            best = max(best, np.max(np.abs(M @ V)))
    return best


def at_poses(p, batch, n=None):
    """The batch of P1 poses (the first ``n``), their J^-1 and J: one call each, not one per pose."""
    x, q = (a[:, :n] for a in batch)
    return x, pk.inverse_jacobian(m.mechanism, x, q, p), pk.jacobian(m.mechanism, x, q, p)


@pytest.mark.parametrize("speeds", [(1.0, 1.0, 1.0), (0.5, 2.0, 0.1)])
def test_max_velocity_equals_brute_force(p1_params, p1_poses, p1_pose_batch, speeds):
    x, J_inv, _ = at_poses(p1_params, p1_pose_batch)
    formula = np.asarray(pk.max_actuator_velocity(J_inv, m.OUTPUT_GROUPS, speeds))
    carriage = np.asarray(m.max_carriage_velocity(x, p1_params, speeds))
    assert formula.shape == carriage.shape == (len(p1_poses),)
    for k in range(len(p1_poses)):
        sampled = sampled_maximum(np.asarray(J_inv)[..., k], speeds)
        assert sampled <= formula[k] * (1 + 1e-12)
        # only the linear group is sampled; its error is at most a factor cos(pi / N) on that part
        assert formula[k] <= sampled / np.cos(np.pi / N_DIRECTIONS) * (1 + 1e-12)
    assert_close(carriage, formula, rtol=1e-13)


def test_max_force_equals_brute_force_with_efforts_from_a_linear_solve(p1_params, p1_poses, p1_pose_batch):
    loads = (1.0, 1.0, 1.0)
    _, J_inv, J = at_poses(p1_params, p1_pose_batch)
    formula = np.asarray(pk.max_actuator_effort(J, m.OUTPUT_GROUPS, loads))
    assert formula.shape == (len(p1_poses),)
    for k in range(len(p1_poses)):
        # e = -J^T P  <=>  (J^-1)^T e = -P: the efforts' matrix is -(J^-1)^-T, found by a solve
        E = -np.linalg.solve(np.asarray(J_inv)[..., k].T, np.eye(4))
        sampled = sampled_maximum(E, loads)
        assert sampled <= formula[k] * (1 + 1e-10)
        assert formula[k] <= sampled / np.cos(np.pi / N_DIRECTIONS) * (1 + 1e-10)


def test_max_gripper_force_against_direct_search(p1_params, p1_pose_batch):
    """Largest F_s with |e_k| <= F_pr for both signs of F_s against the load (eq (12) is this
    worst case), found by bisection on e = -J^T P from a linear solve."""
    F_pr = 100.0
    _, J_inv, J = at_poses(p1_params, p1_pose_batch, 8)
    for load in ((0.0, 0.0, 0.0), (1.0, 1.0, 0.1), (-3.0, 2.0, 0.5)):
        formula = np.asarray(pk.max_gripper_force(J, F_pr, np.array([*load, 0.0]), m.GRIPPER_INDEX))
        assert formula.shape == (8,)
        for k in range(8):
            Jt = np.asarray(J_inv)[..., k].T

            def ok(F_s, Jt=Jt):
                return all(np.max(np.abs(np.linalg.solve(Jt, -np.array([*load, sg * F_s])))) <= F_pr for sg in (-1, 1))

            if not ok(0.0):
                assert np.isnan(formula[k])
                continue
            lo, hi = 0.0, 1e6
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if ok(mid) else (lo, mid)
            assert_close(formula[k], lo, rtol=1e-9)


def test_load_gap_gives_nan_and_negative_reserve(p1_params):
    """On the lower singular line the drives cannot hold F_x = F_y = 1 N, T = 0.1 N m."""
    phi, s = np.deg2rad(20), 0.14
    y_low = m.type2_lines_y(phi, s, p1_params)[1]
    x = m.pose(0.7, y_low + 1e-5, phi, s)
    J = pk.jacobian(m.mechanism, x, m.mechanism.inverse(x, p1_params), p1_params)
    P = np.array([1.0, 1.0, 0.1, 0.0])
    assert float(pk.load_reserve(J, 100.0, P, m.GRIPPER_INDEX)) < 0
    assert np.isnan(float(pk.max_gripper_force(J, 100.0, P, m.GRIPPER_INDEX)))


def test_row_group_norms_checks_its_groups():
    with pytest.raises(ValueError, match="groups"):
        pk.row_group_norms(np.eye(4), ((0, 1), (2,), (3,)), (1.0, 1.0))


@pytest.mark.parametrize(
    "J_shape, P_shape",
    [
        ((4, 4), (4,)),
        ((4, 4, 7), (4,)),
        ((4, 4, 7), (4, 7)),
        ((4, 4), (4, 4)),  # P batched, J not: the batch axis of P must not pair with J's columns
        ((4, 3, 5, 7), (4, 7)),
        ((4, 3, 7), (4, 5, 7)),
    ],
)
def test_actuator_efforts_equal_minus_J_transpose_P_with_batch_axes_aligned_on_the_right(J_shape, P_shape):
    rng = np.random.default_rng(3)
    J, P = rng.normal(size=J_shape), rng.normal(size=P_shape)
    expected = -np.einsum("ij...,i...->j...", J, P)
    got = np.asarray(pk.actuator_efforts(J, P))
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-15)
