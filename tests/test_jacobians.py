"""Autodiff A, B, J^-1, J against finite differences, a hand-derived J^-1 and the general path."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close, central_difference


def hand_inverse_jacobian(x, q, p):
    """J^-1 from hand-differentiated P1 eq (1): row ij = -(dF/dx) / (dF/dx_Aij)."""
    x_D, y_D, phi, s = x
    c, sn = np.cos(phi), np.sin(phi)
    rows = []
    for i in range(4):
        if i < 2:
            u, v = q[i] - x_D + s * c, y_D - s * sn  # F = u^2 + v^2 - l^2
            dF = [-2 * u, 2 * v, 2 * u * (-s * sn) + 2 * v * (-s * c), 2 * u * c + 2 * v * (-sn)]
        else:
            u, v = q[i] - x_D - p.l_C2D * c, y_D + p.l_C2D * sn
            dF = [-2 * u, 2 * v, 2 * u * (p.l_C2D * sn) + 2 * v * (p.l_C2D * c), 0.0]
        rows.append(-np.array(dF) / (2 * u))
    return np.array(rows)


def test_A_and_B_match_finite_differences(p1_params, p1_poses, p1_pose_batch):
    p = p1_params
    x, q = p1_pose_batch  # every pose in each call: (4, 4, N) matrices
    A = pk.A_matrix(m.mechanism, x, q, p)
    B = pk.B_matrix(m.mechanism, x, q, p)
    A_fd = central_difference(lambda z: m.mechanism.constraints(z, q, p), x)  # shifts a row of all poses
    B_fd = central_difference(lambda z: m.mechanism.constraints(x, z, p), q)
    assert A.shape == B.shape == A_fd.shape == (4, 4, len(p1_poses))
    assert_close(A, A_fd, rtol=1e-6, atol=1e-9)
    assert_close(B, B_fd, rtol=1e-6, atol=1e-9)
    off_diagonal = ~np.eye(4, dtype=bool)
    assert_close(np.asarray(B)[off_diagonal], np.zeros((12, len(p1_poses))), atol=0.0)


def test_inverse_jacobian_matches_hand_derivation(p1_params, p1_poses, p1_pose_batch):
    x, q = p1_pose_batch
    J_inv = np.asarray(pk.inverse_jacobian(m.mechanism, x, q, p1_params))
    for k in range(len(p1_poses)):
        assert_close(
            J_inv[..., k],
            hand_inverse_jacobian(np.asarray(x)[:, k], np.asarray(q)[:, k], p1_params),
            rtol=1e-10,
            atol=1e-12,
        )


def test_inverse_jacobian_relates_velocities_along_a_path(p1_params, p1_poses):
    """q' = J^-1 x' (P1 eq (3)) checked by differencing the inverse position solution."""
    p = p1_params
    for x in p1_poses[:5]:
        xdot = np.array([0.3, -0.2, 0.5, 0.1])
        q = m.mechanism.inverse(x, p)
        h = 1e-6
        qdot_fd = (
            np.asarray(m.mechanism.inverse(x + h * xdot, p)) - np.asarray(m.mechanism.inverse(x - h * xdot, p))
        ) / (2 * h)
        assert_close(pk.inverse_jacobian(m.mechanism, x, q, p) @ xdot, qdot_fd, rtol=1e-6, atol=1e-9)


def test_forward_jacobian_inverts_inverse_jacobian(p1_params, p1_pose_batch):
    x, q = p1_pose_batch
    J = pk.jacobian(m.mechanism, x, q, p1_params)
    J_inv = pk.inverse_jacobian(m.mechanism, x, q, p1_params)
    product = np.einsum("ijn,jkn->nik", np.asarray(J), np.asarray(J_inv))
    assert_close(product, np.broadcast_to(np.eye(4), product.shape), atol=1e-9)


def test_general_path_equals_chainwise_fast_path(p1_params, p1_pose_batch):
    """A mechanism given by its full F (not chainwise) goes through B and a linear solve."""
    general = m.mechanism.general()
    assert not general.chainwise and m.mechanism.chainwise
    x, q = (a[:, :5] for a in p1_pose_batch)
    for f in (pk.inverse_jacobian, pk.jacobian, pk.det_A, pk.det_B, pk.B_matrix):
        assert_close(f(general, x, q, p1_params), f(m.mechanism, x, q, p1_params), rtol=1e-10, atol=1e-14)


def test_batched_structure_of_arrays_equals_per_point(p1_params, p1_poses):
    X = jnp.asarray(p1_poses.T)  # (4, N)
    Q = m.mechanism.inverse(X, p1_params)
    for f in (pk.inverse_jacobian, pk.jacobian, pk.det_A, pk.det_B, pk.A_matrix, pk.B_matrix):
        batched = np.moveaxis(np.asarray(f(m.mechanism, X, Q, p1_params)), -1, 0)
        per_point = jax.vmap(lambda x, q: f(m.mechanism, x, q, p1_params))(X.T, Q.T)
        assert_close(batched, per_point, rtol=1e-12, atol=1e-15)
    rows = pk.inverse_jacobian_rows(m.mechanism, X, Q, p1_params)
    assert_close(np.array(rows), pk.inverse_jacobian(m.mechanism, X, Q, p1_params), rtol=0, atol=0)


def test_det_A_vanishes_on_the_analytic_lines_and_det_B_is_the_diagonal_product(p1_params):
    p = p1_params
    for phi_deg, s in ((20.0, 0.14), (30.0, 0.1)):
        phi = np.deg2rad(phi_deg)
        for y in m.type2_lines_y(phi, s, p):
            x = m.pose(0.7, y, phi, s)
            q = m.mechanism.inverse(x, p)
            A = np.asarray(pk.A_matrix(m.mechanism, x, q, p))
            # relative to the scale of A: |det A| / prod of row norms
            assert abs(float(pk.det_A(m.mechanism, x, q, p))) / np.prod(np.linalg.norm(A, axis=1)) < 1e-12
            x_off = m.pose(0.7, y + 0.01, phi, s)
            q_off = m.mechanism.inverse(x_off, p)
            assert abs(float(pk.det_A(m.mechanism, x_off, q_off, p))) > 1e-5
    x = m.pose(0.7, 0.0, np.deg2rad(20), 0.14)
    q = m.mechanism.inverse(x, p)
    assert_close(pk.det_B(m.mechanism, x, q, p), np.prod(pk.B_diagonal(m.mechanism, x, q, p)))


def test_b_diagonal_refuses_a_general_mechanism(p1_params):
    general = m.mechanism.general()
    x = m.pose(0.7, 0.0, 0.3, 0.14)
    with pytest.raises(ValueError, match="not diagonal"):
        pk.B_diagonal(general, x, m.mechanism.inverse(x, p1_params), p1_params)


def test_mechanism_needs_exactly_one_constraint_form():
    with pytest.raises(ValueError, match="exactly one"):
        dataclasses.replace(m.mechanism, constraints=lambda x, q, p: m.mechanism.constraints(x, q, p))
    with pytest.raises(ValueError, match="exactly one"):
        dataclasses.replace(m.mechanism, chain_constraint=None, constraints=None)
