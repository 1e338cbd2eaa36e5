"""P2 (3-RRR): closed-form row norms vs sampled directions, Delta >= 0, autodiff vs finite
differences, inverse/forward position round trip."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest
from scipy import optimize

import pkmlib as pk
from pkmlib.mechanisms import three_rrr as t
from conftest import assert_close, central_difference

N_DIRECTIONS = 3600


@pytest.fixture(scope="module")
def params():
    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


@pytest.fixture(scope="module")
def poses(params):
    rng = np.random.default_rng(2)
    out = []
    while len(out) < 12:
        x = np.array([rng.uniform(0.0, 0.4), rng.uniform(-0.05, 0.3), np.deg2rad(rng.uniform(-30, 30))])
        q = np.asarray(t.mechanism.inverse(x, params))
        J_inv = np.asarray(pk.inverse_jacobian(t.mechanism, x, q, params))
        if np.all(np.isfinite(J_inv)) and np.linalg.cond(J_inv) < 1e4:
            out.append(x)
    return np.array(out)


def worst_direction(M, size):
    """Brute force over N unit directions of the linear group, then a local refinement."""
    theta = np.arange(N_DIRECTIONS) * 2 * np.pi / N_DIRECTIONS
    V = size * np.stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
    vals = np.max(np.abs(M @ V), axis=0)
    k = int(np.argmax(vals))
    f = lambda a: -np.max(np.abs(M @ (size * np.array([np.cos(a), np.sin(a), 0.0]))))  # noqa: E731
    h = 2 * np.pi / N_DIRECTIONS
    refined = -optimize.minimize_scalar(f, bracket=(theta[k] - h, theta[k], theta[k] + h), tol=1e-12).fun
    return vals[k], refined


def test_closed_form_norms_equal_the_maximum_over_directions(params, poses):
    # every pose in one call each (pkmlib's batch axes on the right), the sampling per pose
    X = jnp.asarray(poses.T)
    Q = t.mechanism.inverse(X, params)
    J_invs = np.asarray(pk.inverse_jacobian(t.mechanism, X, Q, params))
    Js = np.asarray(pk.jacobian(t.mechanism, X, Q, params))
    crits = {k: np.asarray(v) for k, v in t.pose_criteria(X, params, V=0.1, force=10.0).items()}
    assert J_invs.shape == Js.shape == (3, 3, len(poses))
    for k in range(len(poses)):
        J_inv, J = J_invs[..., k], Js[..., k]
        # velocities: q' = J^-1 x'; efforts: e = -J^T P, the matrix found by a solve, not by J
        for M, size, formula in (
            (J_inv, 0.1, float(crits["max_joint_velocity"][k])),
            (-np.linalg.solve(J_inv.T, np.eye(3)), 10.0, float(crits["max_actuator_torque"][k])),
        ):
            sampled, refined = worst_direction(M, size)
            assert sampled <= formula * (1 + 1e-12)
            assert formula <= sampled / np.cos(np.pi / N_DIRECTIONS) * (1 + 1e-12)
            assert abs(refined - formula) <= 1e-9 * formula
        assert_close(J @ J_inv, np.eye(3), atol=1e-9)


def test_delta_q_and_delta_e_are_never_negative(params, poses):
    X = poses.T
    crit = t.pose_criteria(X, params, V=0.1, force=10.0)
    assert np.all(np.asarray(crit["delta_q"]) >= -1e-15)
    assert np.all(np.asarray(crit["delta_e"]) >= -1e-12)
    # and they are not trivially zero: the worst direction is rarely x
    assert np.max(np.asarray(crit["delta_e"])) > 1e-3


def test_autodiff_A_B_match_finite_differences(params, poses):
    x = jnp.asarray(poses.T)  # every pose at once: (3, 3, N) matrices, a row of all poses shifted
    q = t.mechanism.inverse(x, params)
    A = pk.A_matrix(t.mechanism, x, q, params)
    B = pk.B_matrix(t.mechanism, x, q, params)
    assert A.shape == B.shape == (3, 3, len(poses))
    assert_close(
        A, central_difference(lambda z: t.mechanism.constraints(z, q, params), x, h=1e-7), rtol=1e-6, atol=1e-10
    )
    assert_close(
        B, central_difference(lambda z: t.mechanism.constraints(x, z, params), q, h=1e-7), rtol=1e-6, atol=1e-10
    )


def test_inverse_then_forward_position_round_trip(params, poses):
    for x in poses:
        for branch in ((1, 1, 1), (-1, -1, -1), (1, -1, 1)):
            q = np.asarray(t.mechanism.inverse(x, params, branch))
            if not np.all(np.isfinite(q)):
                continue
            if np.linalg.cond(np.asarray(pk.A_matrix(t.mechanism, x, q, params))) > 1e3:
                continue  # near a type-2 singularity assembly modes are close: Newton may switch
            assert np.max(np.abs(np.asarray(t.mechanism.constraints(x, q, params)))) < 1e-14
            x_fk = pk.forward_position(t.mechanism, q, params, x0=x + np.array([0.003, -0.003, 0.01]))
            assert_close(x_fk, x, rtol=0, atol=1e-10)
            assert_close(t.mechanism.inverse(x_fk, params, branch), q, rtol=0, atol=1e-10)


def test_forward_position_fails_clearly(params):
    q = np.array([0.0, np.pi, np.pi / 2])  # all elbows pointing outward: no platform fits
    with pytest.raises(RuntimeError, match="did not converge"):
        pk.forward_position(t.mechanism, q, params, x0=np.array([0.2, 0.1155, 0.0]), max_iter=30)
    sol = pk.solve_forward_position(t.mechanism, q, params, np.array([0.2, 0.1155, 0.0]), max_iter=30)
    assert not bool(sol.converged)


def test_outside_the_workspace_is_nan(params):
    crit = t.pose_criteria(t.pose(0.8, 0.8, 0.0), params, V=0.1, force=10.0)
    assert all(np.all(np.isnan(np.asarray(v))) for v in crit.values())


def test_geometry_choices_and_bad_parameters():
    side = t.ThreeRRRParams.create(l1=0.18, l2=0.18, l3=0.08, base_side=0.4, l3_is="side", base_origin="centroid")
    assert_close(side.r_p, 0.08 / np.sqrt(3.0))
    assert_close(side.base_centre, [0.0, 0.0], atol=1e-15)
    assert_close(np.linalg.norm(np.diff(np.asarray(side.base + side.base[:1]), axis=0), axis=1), [0.4] * 3)
    with pytest.raises(ValueError, match="l3_is"):
        t.ThreeRRRParams.create(l1=0.18, l2=0.18, l3=0.08, base_side=0.4, l3_is="radius")
    with pytest.raises(ValueError, match="l2"):
        t.ThreeRRRParams.create(l1=0.18, l2=-0.18, l3=0.08, base_side=0.4)
    with pytest.raises(ValueError, match="base_side"):
        t.ThreeRRRParams.create(l1=0.18, l2=0.18, l3=0.08, base_side=0.0)
    with pytest.raises(ValueError, match="force"):
        t.check_study(0.1, 0.0, 0.0)


def test_maps_with_the_solved_link_directions_equal_the_contract_path(params):
    """``pose_criteria`` takes each proximal link's direction from the closed-form solve
    (``_solved_chains``, ``_on_unit_circle``) instead of the cosine and sine of theta: its q, det A,
    det B, J^-1 and their derivatives with respect to the pose and the geometry equal those of the
    contract's ``chain_constraint`` (pkmlib's generic path), NaN at the same poses, on a grid that
    reaches outside the workspace, on two working modes and at three orientations; a traced
    branch with an entry other than +-1 makes every map NaN."""
    import jax

    def generic(x, p, branch):
        q = t.mechanism.inverse(x, p, branch)
        J_inv = pk.inverse_jacobian(t.mechanism, x, q, p)
        return q, pk.det_A(t.mechanism, x, q, p), pk.det_B(t.mechanism, x, q, p), J_inv

    def solved(x, p, branch):
        q, mech, _ = t._at_solution(x, p, branch)
        return q, pk.det_A(mech, x, q, p), pk.det_B(mech, x, q, p), pk.inverse_jacobian(mech, x, q, p)

    g = pk.Grid.from_ranges(x_P=(-0.2, 0.6, 0.02), y_P=(-0.2, 0.55, 0.02))
    P = g.points().reshape(-1, 2).T
    for branch in ((1, 1, 1), (1, -1, 1)):
        for phi in (-0.4, 0.0, 0.3):
            x = t.pose(P[0], P[1], phi)
            ours, ref = solved(x, params, branch), generic(x, params, branch)
            inside = np.isfinite(np.asarray(ref[0][0]))
            assert 0.2 < inside.mean() < 0.9  # the grid crosses the workspace boundary
            for a, b, name in zip(ours, ref, ("q", "det_A", "det_B", "J_inv")):
                a, b = np.asarray(a), np.asarray(b)
                assert np.array_equal(np.isnan(a), np.isnan(b)), name
                scale = np.nanmax(np.abs(b))
                np.testing.assert_allclose(
                    a[np.isfinite(b)], b[np.isfinite(b)], rtol=0, atol=1e-11 * scale, err_msg=name
                )
            crit = t.pose_criteria(x, params, V=0.1, force=10.0, branch=branch)
            np.testing.assert_array_equal(np.asarray(crit["q"]), np.asarray(ref[0]))
    # first and second derivatives (the design gradients and Hessian-vector products go through them)
    x0 = jnp.array([0.2, 0.1, 0.2])
    for f in (lambda x: solved(x, params, (1, -1, 1))[3], lambda x: generic(x, params, (1, -1, 1))[3]):
        assert np.all(np.isfinite(np.asarray(f(x0))))
    d1 = [np.asarray(jax.jacfwd(lambda x, k=k: (solved, generic)[k](x, params, (1, -1, 1))[3])(x0)) for k in (0, 1)]
    d2 = [
        np.asarray(jax.jacfwd(jax.jacrev(lambda x, k=k: (solved, generic)[k](x, params, (1, -1, 1))[1]))(x0))
        for k in (0, 1)
    ]
    assert_close(d1[0], d1[1], rtol=1e-10, atol=1e-12 * np.max(np.abs(d1[1])))
    assert_close(d2[0], d2[1], rtol=1e-9, atol=1e-12 * np.max(np.abs(d2[1])))
    grad = [
        np.asarray(
            jax.grad(lambda l1, k=k: (solved, generic)[k](x0, dataclasses.replace(params, l1=l1), (1, 1, 1))[3][0, 1])(
                params.l1
            )
        )
        for k in (0, 1)
    ]
    assert_close(grad[0], grad[1], rtol=1e-10)
    # no branch: the mechanism's default, as Mechanism.inverse reads it
    for v, w in zip(
        t.pose_criteria(x0, params, V=0.1, force=10.0, branch=None).values(),
        t.pose_criteria(x0, params, V=0.1, force=10.0, branch=t.PAPER_BRANCH).values(),
    ):
        np.testing.assert_array_equal(np.asarray(v), np.asarray(w))
    bad = jax.jit(lambda b: t.pose_criteria(x0, params, V=0.1, force=10.0, branch=b))(jnp.array([1.0, 0.5, 1.0]))
    assert all(np.all(np.isnan(np.asarray(v))) for v in bad.values())
