"""Inverse position solution of P1: loop closure, branches, NaN outside the workspace."""

import itertools

import jax
import numpy as np

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close


def test_loop_closure_on_every_branch(p1_params, p1_poses):
    x = np.asarray(p1_poses).T  # every pose in one call per branch (pkmlib's batch axes on the right)
    closed = 0
    for branch in itertools.product((-1, 1), repeat=4):
        q = np.asarray(m.mechanism.inverse(x, p1_params, branch))
        ok = np.all(np.isfinite(q), axis=0)  # a carriage out of travel on this branch: NaN
        F = np.asarray(m.mechanism.constraints(x, q, p1_params))
        assert np.all(np.isnan(F[:, ~ok]).any(axis=0))
        assert np.max(np.abs(F[:, ok]), initial=0.0) < 1e-12
        closed += ok.sum()
    assert closed >= len(p1_poses)  # at least the paper's branch closes at every pose


def test_paper_branch_puts_carriages_on_both_sides_of_their_C_point(p1_params, p1_poses):
    for x in p1_poses:
        q = np.asarray(m.mechanism.inverse(x, p1_params))
        C1, C2 = (np.asarray(c) for c in m.joint_points(x, p1_params))
        assert q[0] < C1[0] < q[1]
        assert q[2] < C2[0] < q[3]


def test_links_have_their_lengths(p1_params, p1_poses):
    """Independent of eq (1): distances from the carriages (on y = 0) to C1, C2."""
    p = p1_params
    lengths = [p.l_B11C1, p.l_B12C1, p.l_B21C2, p.l_B22C2]
    for x in p1_poses:
        q = np.asarray(m.mechanism.inverse(x, p))
        C1, C2 = (np.asarray(c) for c in m.joint_points(x, p))
        for k, C in enumerate((C1, C1, C2, C2)):
            assert_close(np.hypot(C[0] - q[k], C[1]), lengths[k], rtol=1e-13)
        assert_close(np.hypot(*(C1 - x[:2])), x[3], rtol=1e-13)
        assert_close(np.hypot(*(C2 - x[:2])), p.l_C2D, rtol=1e-13)


def test_outside_the_workspace_gives_nan_not_an_exception(p1_params):
    p = p1_params
    phi, s = np.deg2rad(20), 0.14
    out = [
        m.pose(0.7, 0.3, phi, s),  # links cannot reach the rail
        m.pose(0.1, 0.0, phi, s),  # carriage x_A11 below 0
        m.pose(1.4, 0.0, phi, s),
    ]  # carriage x_A22 above 1.5
    for x in out:
        q = m.mechanism.inverse(x, p)
        assert np.all(np.isnan(np.asarray(q)))
        assert np.isnan(float(pk.det_A(m.mechanism, x, q, p)))
        crit = m.pose_criteria(x, p, speeds=(1, 1, 1), loads=(1, 1, 1), F_pr=100.0, external_load=(1, 1, 0.1))
        assert all(np.all(np.isnan(np.asarray(v))) for v in crit.values())
    # the same under jit + vmap
    X = np.stack(out, axis=1)
    qs = jax.jit(jax.vmap(lambda x: m.mechanism.inverse(x, p), in_axes=1))(X)
    assert np.all(np.isnan(np.asarray(qs)))


def test_type1_boundary_is_where_the_short_link_is_vertical(p1_params):
    p = p1_params
    phi, s = np.deg2rad(20), 0.14
    lo, hi = m.type1_bounds_y(phi, s, p)
    assert_close(hi, p.l_B21C2 - p.l_C2D * np.sin(phi))
    q = np.asarray(m.mechanism.inverse(m.pose(0.7, hi - 1e-12, phi, s), p))
    C2 = np.asarray(m.joint_points(m.pose(0.7, hi, phi, s), p)[1])
    assert abs(q[2] - C2[0]) < 1e-5  # B21 directly below C2
    assert np.all(np.isnan(np.asarray(m.mechanism.inverse(m.pose(0.7, hi + 1e-6, phi, s), p))))
    assert np.all(np.isnan(np.asarray(m.mechanism.inverse(m.pose(0.7, lo - 1e-6, phi, s), p))))
