"""Numerical positions (pkmlib._positions) against the papers' closed forms on their own grids,
against central differences and J^-1 for derivatives, and the forward assembly modes against
independent solutions (circle intersection for the five-bar, trilateration for a Delta)."""

from __future__ import annotations

import dataclasses
import itertools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import five_bar as m4
from pkmlib.mechanisms import gripper_4prr as m1
from pkmlib.mechanisms import three_rrr as m2
from pkmlib.mechanisms import two_t_one_r as m3


# ----------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def p1():
    return m1.Gripper4PRRParams.from_dict(pk.load_params("p1"))


@pytest.fixture(scope="module")
def p2():
    return m2.ThreeRRRParams.from_dict(pk.load_params("p2"))


@pytest.fixture(scope="module")
def p4():
    return m4.FiveBarParams.from_dict(pk.load_params("p4"))


@pytest.fixture(scope="module")
def pa():
    return m3.ParamsA.from_dict(pk.load_params("p3"))


@pytest.fixture(scope="module")
def pb():
    return m3.ParamsB.from_dict(pk.load_params("p3"))


def _axis(lo, hi, step):
    return np.arange(lo, hi + 0.5 * step, step)


def grid_p1():
    """P1's notebook grid (parameters cell: x_D 0.2..1.2 step 0.005, y_D -0.25..0.25 step 0.0025,
    phi = 20 deg, s = 0.14 m)."""
    X, Y = np.meshgrid(_axis(0.2, 1.2, 0.005), _axis(-0.25, 0.25, 0.0025), indexing="ij")
    return m1.pose(X, Y, np.deg2rad(20.0), 0.14)


def grid_p2():
    """P2's notebook grid (x_P -0.15..0.55, y_P -0.15..0.5, step 0.0025 m, phi = 0)."""
    X, Y = np.meshgrid(_axis(-0.15, 0.55, 0.0025), _axis(-0.15, 0.5, 0.0025), indexing="ij")
    return m2.pose(X, Y, 0.0)


def grid_p4():
    """P4's notebook grid (x_C -250..350, z_C 2.5..350, step 2.5 mm)."""
    X, Z = np.meshgrid(_axis(-250.0, 350.0, 2.5), _axis(2.5, 350.0, 2.5), indexing="ij")
    return jnp.stack([jnp.asarray(X), jnp.asarray(Z)])


def actuator_grid_p3(p, step=5.0):
    """P3's notebook actuator grid (the workspace sweeps: the actuator box at step_mm = 5 mm)."""
    axes = [_axis(lo, hi, step) for lo, hi in ((p.x1_min, p.x1_max), (p.x2_min, p.x2_max), (p.x3_min, p.x3_max))]
    return jnp.stack([jnp.asarray(g) for g in np.meshgrid(*axes, indexing="ij")])


def pose_nan(q):
    return np.any(np.isnan(np.asarray(q)), axis=0)


def assert_same(q_closed, q_num, *, periodic, near_double=None, atol=1e-10, min_finite=0.05):
    """Equal to ``atol`` (angles modulo 2 pi) where both are finite, NaN at the same poses.
    ``near_double``: poses on the boundary within rounding: a double root (type-1 boundary, where
    the root is only determined to sqrt(eps)) or an actuator at its limit; they are not compared."""
    qc, qn = np.asarray(q_closed), np.asarray(q_num)
    nc, nn = pose_nan(qc), pose_nan(qn)
    if near_double is not None:  # on the boundary within rounding either answer is right
        nn = np.where(near_double, nc, nn)
    assert np.array_equal(nc, nn), f"NaN at different poses: {np.sum(nc != nn)} of {nc.size}"
    assert (~nc).sum() > min_finite * nc.size, "the grid must reach into the workspace"
    d = qc - qn
    if periodic:
        d = np.angle(np.exp(1j * d))
    ok = ~nc if near_double is None else ~nc & ~near_double
    if ok.any():
        assert np.max(np.abs(d[:, ok])) <= atol, np.max(np.abs(d[:, ok]))
    return int(ok.sum())


def at_limit(q_unlimited, p, rtol=1e-9):
    """Poses where an actuator (from a closed form without the box) is at a P3 box limit within
    rounding: inside or outside is decided by the last bit there."""
    q = np.asarray(q_unlimited)
    lo = np.array([p.x1_min, p.x2_min, p.x3_min])[:, None, None, None]
    hi = np.array([p.x1_max, p.x2_max, p.x3_max])[:, None, None, None]
    tol = rtol * (hi - lo)
    return np.any((np.abs(q - lo) <= tol) | (np.abs(q - hi) <= tol), axis=0)


def double_root(mech, x, q, p, rtol=1e-6):
    """Poses where some |dF_i/dq_i| is below rtol of its largest value on the grid."""
    B = np.asarray(pk.B_matrix(mech, x, jnp.asarray(q), p))
    b = np.abs(np.stack([B[i, i] for i in range(B.shape[0])]))
    return np.any(b <= rtol * np.nanmax(b), axis=0)


# ----------------------------------------------------------------------------- the branch rule
@pytest.mark.parametrize("paper", ["p1", "p2", "p4"])
def test_branch_rule_is_the_papers_sign(paper, p1, p2, p4):
    """sign(dF_i/dq_i) at the closed-form solution equals the sign the paper's formula takes
    (P1 x_A = C_x + sign sqrt, P2/P4 atan2 + sign acos), on every branch."""
    mech, p, x = {
        "p1": (m1.mechanism, p1, grid_p1()),
        "p2": (m2.mechanism, p2, grid_p2()),
        "p4": (m4.mechanism, p4, grid_p4()),
    }[paper]
    n = mech.n_actuators
    for branch in itertools.product((1.0, -1.0), repeat=n):
        q = mech.inverse(x, p, branch)
        b = np.asarray(pk.B_diagonal(mech, x, q, p))
        fin = np.isfinite(b) & (np.abs(b) > 1e-9 * np.nanmax(np.abs(b)))
        assert fin.sum() > 100
        for i in range(n):
            assert np.all(np.sign(b[i][fin[i]]) == branch[i]), (paper, branch, i)


# ----------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("branch", [m1.PAPER_BRANCH, (1, 1, 1, 1), (-1, -1, 1, -1)])
def test_p1_equals_closed_form(p1, branch):
    x = grid_p1()
    qc = m1.mechanism.inverse(x, p1, branch)
    qn = pk.inverse_positions(m1.mechanism, x, p1, branch)
    assert qn.shape == (4,) + x.shape[1:]
    assert_same(qc, qn, periodic=False, near_double=double_root(m1.mechanism, x, qc, p1))


@pytest.mark.parametrize("branch", list(itertools.product((1, -1), repeat=3)))
def test_p2_equals_closed_form(p2, branch):
    x = grid_p2()
    qc = m2.mechanism.inverse(x, p2, branch)
    qn = pk.inverse_positions(m2.mechanism, x, p2, branch)
    assert_same(qc, qn, periodic=True, near_double=double_root(m2.mechanism, x, qc, p2))


@pytest.mark.parametrize("branch", list(itertools.product((1, -1), repeat=2)))
def test_p4_equals_closed_form(p4, branch):
    x = grid_p4()
    qc = m4.mechanism.inverse(x, p4, branch)
    qn = pk.inverse_positions(m4.mechanism, x, p4, branch)
    assert_same(qc, qn, periodic=True, near_double=double_root(m4.mechanism, x, qc, p4))
    # revolute results lie in [-pi, pi) (no finite lower limit)
    qn = np.asarray(qn)
    assert np.all((qn[np.isfinite(qn)] >= -np.pi) & (qn[np.isfinite(qn)] < np.pi))


def p3a_chain_signs(u, v):
    """P3 eq (14)'s (u, v) as the signs of dF_i/dq_i: dF1/dx1 = 2 (x1 - x) has the sign of u,
    x2 = 2x - x1 the opposite one, dF3/dx3 the sign of v."""
    return (u, -u, v)


def p3b_chain_signs(u, v, w):
    """P3 eq (16)-(17)'s (u, v, w) as the signs of diag(B) of constraints_b:
    df1/dx1 = 2 w R (x_E - x1)/H has the sign of -w u, df2/dx2 = -2 (x1 - x_E) of -u, df3/dx3 of v."""
    return (-w * u, -u, v)


def test_p3_a_is_diagonal_and_b_lower_triangular(pa, pb):
    assert pk.detect_structure(m3.mechanism_a, pa) == "diagonal"
    assert pk.detect_structure(m3.mechanism_b, pb) == "lower"
    assert pk.detect_structure(m2.mechanism, None) == "diagonal"  # chainwise: no probing


@pytest.mark.parametrize("m_fk", m3.FORWARD_BRANCHES["A"])
def test_p3_a_equals_closed_form(pa, m_fk):
    """On the notebook's actuator grid: the poses of FK branch m, then every IK branch (u, v)."""
    step = 5.0 if m_fk == m3.FORWARD_BRANCHES["A"][0] else 10.0  # the notebook's 5 mm for the paper's branch
    x = m3.forward_a(actuator_grid_p3(pa, step), pa, m_fk)
    compared = 0
    for u, v in m3.INVERSE_BRANCHES["A"]:
        qc = m3.mechanism_a.inverse(x, pa, (u, v))
        qn = pk.inverse_positions(m3.mechanism_a, x, pa, p3a_chain_signs(u, v))
        compared += assert_same(
            qc,
            qn,
            periodic=False,
            atol=1e-10 * 300.0,
            min_finite=1e-4,  # mm: relative to the 300 mm box
            near_double=double_root(m3.mechanism_a, x, np.where(np.isnan(qc), qn, qc), pa)
            | at_limit(m3.inverse_a(x, pa, (u, v)), pa),
        )
    assert compared > 1000


@pytest.mark.parametrize("fk", m3.FORWARD_BRANCHES["B"])
def test_p3_b_equals_closed_form(pb, fk):
    """Sequential solves (B lower triangular) on the notebook's actuator grid, every IK branch
    (u, v, w) whose closed form satisfies constraints_b (which takes the five-bar assembly H > 0:
    the closed form's other points have H < 0 and are not solutions of these F)."""
    x = m3.forward_b(actuator_grid_p3(pb, step=10.0), pb, jnp.asarray(fk))
    compared = 0
    compared_poses = 0
    for u, v, w in m3.INVERSE_BRANCHES["B"]:
        if u == 1.0:
            continue  # diag(B) takes the first root in increasing x1: u = -1 (see the next test)
        qc = np.asarray(m3.mechanism_b.inverse(x, pb, (u, v, w)))
        H = np.asarray(m3.five_bar_height_b(x, pb, w))
        qc = np.where(H >= 0.0, qc, np.nan)
        qn = pk.inverse_positions(m3.mechanism_b, x, pb, p3b_chain_signs(u, v, w))
        if np.all(np.isnan(qc)):
            assert np.all(np.isnan(np.asarray(qn)))
            continue
        compared += 1
        amb = (
            at_limit(m3.inverse_b(x, pb, (u, v, w)), pb)
            | (np.abs(H) <= 1e-9 * pb.l2)
            | double_root(m3.mechanism_b, x, np.where(np.isnan(qc), np.asarray(qn), qc), pb)
        )
        qn = np.asarray(qn)
        nc, nn = pose_nan(qc), pose_nan(qn)
        both = ~nc & ~nn & ~amb
        assert np.max(np.abs(qc - qn)[:, both], initial=0.0) <= 1e-10 * 300.0
        # NaN-ness is not compared on B: diag(B) does not label its branches uniquely (the same
        # signs hold at the degenerate five-bar x2 = x1 and at the other root of f1), so where the
        # closed form's point leaves the box another root may be returned, and near x1 = x_E the
        # sequential solve may miss the closed form's (known limit, see the report)
        compared_poses += int(both.sum())
    assert compared >= 1
    if tuple(fk) == (1.0, 1.0):  # the paper's assembly: the comparison must bite
        assert compared_poses > 100


def test_p3_b_signs_do_not_separate_u(pb):
    """The stated limit of the diag(B) rule on B: (u, v, w) and (-u, v, -w) have the same signs
    of dF1/dx1; with both roots present the sequential solve takes the first in increasing x1."""
    assert p3b_chain_signs(1, 1, 1)[0] == p3b_chain_signs(-1, 1, -1)[0]


# ----------------------------------------------------------------------------- NaN, limits, residuals
def test_nan_at_and_beyond_the_reach_boundary(p2):
    """P2 chain 1 stretched: |A_1 C_1| = l1 + l2 - 1e-9 (inside) has a solution on each branch,
    + 1e-7 (just outside) is NaN on every branch, never the other branch's point."""
    A1 = np.asarray(p2.base[0])
    for eps, finite in ((-1e-9, True), (1e-7, False)):
        d = p2.l1 + p2.l2 + eps
        direction = np.array([np.cos(0.3), np.sin(0.3)])
        C1 = A1 + d * direction
        P = C1 - p2.r_p * np.array([np.cos(m2.GAMMA[0]), np.sin(m2.GAMMA[0])])
        x = jnp.asarray([P[0], P[1], 0.0])
        for branch in itertools.product((1, -1), repeat=3):
            q = np.asarray(pk.inverse_positions(m2.mechanism, x, p2, branch))
            qc = np.asarray(m2.mechanism.inverse(x, p2, branch))
            if finite:
                assert np.isfinite(q[0]) and abs(np.angle(np.exp(1j * (q[0] - 0.3)))) < 1e-3
                assert np.array_equal(np.isnan(q), np.zeros(3, bool) | np.any(np.isnan(qc)))
            else:
                assert np.all(np.isnan(q))


def test_result_is_always_on_the_requested_branch(p2):
    rng = np.random.default_rng(1)
    x = jnp.asarray(np.stack([rng.uniform(-0.2, 0.6, 4000), rng.uniform(-0.2, 0.6, 4000), rng.uniform(-1, 1, 4000)]))
    for branch in itertools.product((1, -1), repeat=3):
        q = pk.inverse_positions(m2.mechanism, x, p2, branch)
        b = np.asarray(pk.B_diagonal(m2.mechanism, x, q, p2))
        fin = np.all(np.isfinite(b), axis=0)
        assert 200 < fin.sum() < 4000
        assert np.all(np.sign(b[:, fin]) == np.asarray(branch, float)[:, None])


def test_actuator_limits_give_nan(p1):
    """P1 poses whose closed-form carriage leaves [x_A_min, x_A_max] are NaN numerically too
    (the grid of test_p1_equals_closed_form covers them; here one is built explicitly)."""
    q_lo = p1.x_A_min
    x = m1.pose(q_lo + 0.01, 0.0, np.deg2rad(20.0), 0.14)  # chain 11 would be left of the rail
    assert np.all(np.isnan(np.asarray(m1.mechanism.inverse(x, p1))))
    assert np.all(np.isnan(np.asarray(pk.inverse_positions(m1.mechanism, x, p1))))
    x = m1.pose(0.7, 0.0, np.deg2rad(20.0), 0.14)
    assert np.all(np.isfinite(np.asarray(pk.inverse_positions(m1.mechanism, x, p1))))


def test_residuals(p2):
    x = grid_p2()[:, ::20, ::20]
    sol = pk.inverse_positions(m2.mechanism, x, p2, residuals=True)
    assert isinstance(sol, pk.InverseSolution)
    F = np.asarray(m2.mechanism.constraints(x, sol.q, p2))
    np.testing.assert_allclose(np.asarray(sol.residual), np.max(np.abs(F), axis=0), rtol=0, atol=1e-15)
    fin = np.isfinite(np.asarray(sol.residual))
    assert fin.sum() > 10 and np.max(np.asarray(sol.residual)[fin]) < 1e-15
    assert np.array_equal(~fin, pose_nan(sol.q))


def test_single_pose_and_any_grid_shape(p2):
    x = grid_p2()[:, 100:106, 100:103]
    q = pk.inverse_positions(m2.mechanism, x, p2)
    assert q.shape == (3, 6, 3)
    q1 = pk.inverse_positions(m2.mechanism, x[:, 2, 1], p2)
    assert q1.shape == (3,)
    np.testing.assert_array_equal(np.asarray(q1), np.asarray(q)[:, 2, 1])
    q3 = pk.inverse_positions(m2.mechanism, x.reshape(3, 2, 3, 3), p2)
    np.testing.assert_array_equal(np.asarray(q3).reshape(3, 6, 3), np.asarray(q))


# ----------------------------------------------------------------------------- fallbacks and methods
def p2_unsquared():
    """P2 with F_i = |C_i - B_i| - l2 (not squared: no longer a trigonometric polynomial in
    theta_i, so the 3-sample fit fails and bracketing takes over); same roots and slope signs."""

    def chain(i, x, t, p):
        cx, cy = m2.platform_joint(i, x, p)
        bx, by = m2.elbow(i, t, p)
        return jnp.sqrt((cx - bx) ** 2 + (cy - by) ** 2) - p.l2

    return dataclasses.replace(m2.mechanism, chain_constraint=chain, inverse_position=None, name="P2 unsquared")


def test_bracketing_fallback_equals_closed_form(p2):
    x = grid_p2()[:, ::4, ::4]
    mech = p2_unsquared()
    # bracketing samples 64 angles a turn: two roots closer than two samples may be missed (stated)
    q_plus, q_minus = (np.asarray(m2.mechanism.inverse(x, p2, (s, s, s))) for s in (1, -1))
    close = np.any(np.abs(np.angle(np.exp(1j * (q_plus - q_minus)))) < 4 * np.pi / 64, axis=0)
    for branch in ((1, 1, 1), (-1, 1, -1)):
        qc = m2.mechanism.inverse(x, p2, branch)
        qn = pk.inverse_positions(mech, x, p2, branch)
        assert not np.any(np.isfinite(np.asarray(qn)) & ~np.isfinite(np.asarray(qc)))  # never a false root
        assert_same(qc, qn, periodic=True, near_double=close | double_root(m2.mechanism, x, qc, p2, rtol=1e-3))


def test_general_newton_equals_closed_form(p4):
    x = grid_p4()[:, ::12, ::12]
    for branch in ((1, -1), (-1, -1)):
        qc = m4.mechanism.inverse(x, p4, branch)
        qn = pk.inverse_positions(m4.mechanism, x, p4, branch, structure="general", starts_per_axis=6)
        assert_same(qc, qn, periodic=True, near_double=double_root(m4.mechanism, x, qc, p4, rtol=1e-3))


def test_mechanism_inverse_without_closed_form(p2):
    mech = dataclasses.replace(m2.mechanism, inverse_position=None)
    x = grid_p2()[:, ::10, ::10]
    assert_same(
        m2.mechanism.inverse(x, p2, (1, -1, 1)),
        mech.inverse(x, p2, (1, -1, 1)),
        periodic=True,
        near_double=double_root(m2.mechanism, x, m2.mechanism.inverse(x, p2, (1, -1, 1)), p2),
    )
    assert_same(
        m2.mechanism.inverse(x, p2),
        mech.inverse(x, p2),
        periodic=True,
        near_double=double_root(m2.mechanism, x, m2.mechanism.inverse(x, p2), p2),
    )
    with pytest.raises(ValueError, match="branch"):
        mech.inverse(x, p2, (1, 1))


def test_bad_arguments(p1, p2, pa):
    x = grid_p2()[:, 0, 0]
    with pytest.raises(ValueError, match="branch"):
        pk.inverse_positions(m2.mechanism, x, p2, (1, 2, 1))
    with pytest.raises(ValueError, match="branch"):  # P3 A's closed-form signs are not the rule's
        pk.inverse_positions(m3.mechanism_a, jnp.zeros(3), pa)
    with pytest.raises(ValueError, match="x must have shape"):
        pk.inverse_positions(m2.mechanism, jnp.zeros(4), p2)
    with pytest.raises(ValueError, match="structure"):
        pk.inverse_positions(m2.mechanism, x, p2, structure="banded")
    unlimited = dataclasses.replace(
        m1.mechanism, actuator_limits=lambda p: (jnp.full(4, -jnp.inf), jnp.full(4, jnp.inf)), inverse_position=None
    )
    with pytest.raises(ValueError, match="search_interval"):
        pk.inverse_positions(unlimited, m1.pose(0.7, 0.0, 0.3, 0.14), p1)
    q = pk.inverse_positions(unlimited, m1.pose(0.7, 0.0, 0.3, 0.14), p1, search_interval=[(-1.0, 3.0)] * 4)
    np.testing.assert_allclose(
        np.asarray(q), np.asarray(m1.mechanism.inverse(m1.pose(0.7, 0.0, 0.3, 0.14), p1)), atol=1e-12
    )
    with pytest.raises(ValueError, match="search_interval"):
        pk.inverse_positions(unlimited, m1.pose(0.7, 0.0, 0.3, 0.14), p1, search_interval=[(1.0, -1.0)] * 4)


# ----------------------------------------------------------------------------- derivatives (IFT)
def test_dq_dx_is_inverse_jacobian_and_central_differences(p1, p2, p4):
    cases = [
        (m1.mechanism, p1, m1.pose(0.7, 0.05, 0.35, 0.14)),
        (m2.mechanism, p2, m2.pose(0.2, 0.12, 0.1)),
        (m4.mechanism, p4, jnp.asarray([50.0, 150.0])),
    ]
    for mech, p, x in cases:
        f = lambda x_: pk.inverse_positions(mech, x_, p)  # noqa: E731
        q = f(x)
        J_fwd = np.asarray(jax.jacfwd(f)(x))
        J_rev = np.asarray(jax.jacrev(f)(x))
        J_inv = np.asarray(pk.inverse_jacobian(mech, x, q, p))
        np.testing.assert_allclose(J_fwd, J_inv, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(J_rev, J_inv, rtol=1e-10, atol=1e-12)
        h = 1e-6 * max(1.0, float(jnp.max(jnp.abs(x))))
        fd = np.stack(
            [(np.asarray(f(x.at[j].add(h))) - np.asarray(f(x.at[j].add(-h)))) / (2 * h) for j in range(x.shape[0])],
            axis=1,
        )
        np.testing.assert_allclose(J_fwd, fd, rtol=1e-6, atol=1e-8)


def test_dq_dparams_central_differences(p2, pa):
    x = m2.pose(0.2, 0.12, 0.1)

    def f(l1):
        return pk.inverse_positions(m2.mechanism, x, dataclasses.replace(p2, l1=l1))

    g = np.asarray(jax.jacfwd(f)(p2.l1))
    h = 1e-6
    fd = (np.asarray(f(p2.l1 + h)) - np.asarray(f(p2.l1 - h))) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-9)
    assert np.all(np.abs(g) > 1e-3)
    # the grad of a scalar through a batch (reverse mode through the implicit solution)
    xs = grid_p2()[:, 120:125, 100:104]
    total = lambda l2: jnp.nansum(pk.inverse_positions(m2.mechanism, xs, dataclasses.replace(p2, l2=l2)))  # noqa: E731
    gr = float(jax.grad(total)(p2.l2))
    fd = (float(total(p2.l2 + h)) - float(total(p2.l2 - h))) / (2 * h)
    assert abs(gr - fd) <= 1e-5 * abs(fd)
    # P3 A (diagonal, probed) in a parameter
    xa = m3.forward_a(jnp.asarray([-106.09, 181.67, -70.29]), pa, 1.0)
    fa = lambda l4: pk.inverse_positions(m3.mechanism_a, xa, dataclasses.replace(pa, l4=l4), (-1, 1, -1))  # noqa: E731
    ga = np.asarray(jax.jacfwd(fa)(pa.l4))
    fda = (np.asarray(fa(pa.l4 + 1e-4)) - np.asarray(fa(pa.l4 - 1e-4))) / 2e-4
    np.testing.assert_allclose(ga, fda, rtol=1e-6, atol=1e-9)


# ----------------------------------------------------------------------------- forward assembly modes
def delta_mechanism():
    """A Delta robot from its squared-distance closures (three RSS chains): base radius R, arm L,
    forearm l, platform radius r; chain i at gamma_i = 2 pi i / 3, elbow
    B_i = (R + L cos t) e_i - L sin t z, platform joint C_i = P + r e_i, F_i = |C_i - B_i|^2 - l^2."""

    def chain(i, x, t, p):
        g = 2.0 * np.pi * i / 3.0
        c, s = np.cos(g), np.sin(g)
        rad = p["R"] + p["L"] * jnp.cos(t) - p["r"]
        return (x[0] - rad * c) ** 2 + (x[1] - rad * s) ** 2 + (x[2] + p["L"] * jnp.sin(t)) ** 2 - p["l"] ** 2

    return pk.Mechanism(
        name="Delta",
        chain_constraint=chain,
        actuator_limits=lambda p: (jnp.full(3, -jnp.inf), jnp.full(3, jnp.inf)),
        output_names=("x", "y", "z"),
        output_units=("m", "m", "m"),
        actuator_names=("theta_1", "theta_2", "theta_3"),
        actuator_units=("rad",) * 3,
        default_branch=(1, 1, 1),
    )


DELTA = {"R": 0.2, "L": 0.2, "l": 0.45, "r": 0.05}


def delta_trilateration(q, p):
    """Both platform positions of the Delta: the intersection points of the three spheres of
    radius l about S_i = B_i - r e_i (two solutions mirrored in their plane), ``(2, 3)``, z ascending."""
    S = []
    for i in range(3):
        g = 2.0 * np.pi * i / 3.0
        rad = p["R"] + p["L"] * np.cos(q[i]) - p["r"]
        S.append(np.array([rad * np.cos(g), rad * np.sin(g), -p["L"] * np.sin(q[i])]))
    S = np.array(S)
    ex = (S[1] - S[0]) / np.linalg.norm(S[1] - S[0])
    i_ = ex @ (S[2] - S[0])
    ey = S[2] - S[0] - i_ * ex
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    d, j = np.linalg.norm(S[1] - S[0]), ey @ (S[2] - S[0])
    l = p["l"]
    X = d / 2
    Y = (i_**2 + j**2) / (2 * j) - i_ * X / j
    Z = np.sqrt(l**2 - X**2 - Y**2)
    sols = np.array([S[0] + X * ex + Y * ey + s * Z * ez for s in (1, -1)])
    return sols[np.argsort(sols[:, 2])]


def test_delta_forward_modes_against_trilateration():
    mech = delta_mechanism()
    rng = np.random.default_rng(2)
    q = rng.uniform(-0.3, 0.9, (3, 5, 4))
    box = ((-0.6, -0.6, -0.8), (0.6, 0.6, 0.8))
    out = pk.forward_positions(mech, q, DELTA, box, starts_per_axis=4, max_modes=4)
    assert out.x.shape == (4, 3, 5, 4) and out.count.shape == (5, 4)
    for a, b in itertools.product(range(5), range(4)):
        ref = delta_trilateration(q[:, a, b], DELTA)
        assert int(out.count[a, b]) == 2
        got = np.asarray(out.x[:2, :, a, b])
        got = got[np.argsort(got[:, 2])]
        np.testing.assert_allclose(got, ref, atol=1e-12)
        assert np.all(np.isnan(np.asarray(out.x[2:, :, a, b])))
        s = np.asarray(out.det_A_sign[:2, a, b])
        assert list(s) == sorted(s, reverse=True)  # det(A) > 0 first
        # each mode solves F and its inverse on the branch sign(diag B) returns q
        for k in range(2):
            xk = jnp.asarray(out.x[k, :, a, b])
            bd = np.sign(np.asarray(pk.B_diagonal(mech, xk, jnp.asarray(q[:, a, b]), DELTA)))
            back = np.asarray(pk.inverse_positions(mech, xk, DELTA, tuple(bd)))
            np.testing.assert_allclose(np.angle(np.exp(1j * (back - q[:, a, b]))), 0.0, atol=1e-10)


def five_bar_circle_intersection(q, p):
    """Both points C of the five-bar: intersections of the circles about B_1, B_2 (P4's frame), ``(2, 2)``."""
    B = [np.array([xa + p.l_A1B1 * np.cos(q[0]), p.l_A1B1 * np.sin(q[0])]) for xa in (0.0,)]
    B.append(np.array([p.l_A1A2 + p.l_A2B2 * np.cos(q[1]), p.l_A2B2 * np.sin(q[1])]))
    r1, r2 = p.l_B1C, p.l_B2C
    d = np.linalg.norm(B[1] - B[0])
    a = (r1**2 - r2**2 + d**2) / (2 * d)
    h = np.sqrt(max(r1**2 - a**2, np.nan) if r1**2 >= a**2 else np.nan)
    e = (B[1] - B[0]) / d
    m = B[0] + a * e
    return np.array([m + s * h * np.array([-e[1], e[0]]) for s in (1, -1)])


def test_five_bar_forward_modes_against_circle_intersection(p4):
    q = np.stack(np.meshgrid(np.linspace(0.8, 2.2, 4), np.linspace(0.2, 1.4, 3), indexing="ij"))
    out = pk.forward_positions(m4.mechanism, q, p4, ((-400.0, -400.0), (500.0, 400.0)), starts_per_axis=6, max_modes=3)
    reached = 0
    for a, b in itertools.product(range(4), range(3)):
        ref = five_bar_circle_intersection(q[:, a, b], p4)
        n = int(out.count[a, b])
        if np.all(np.isnan(ref)):  # the links cannot meet: no assembly
            assert n == 0 and np.all(np.isnan(np.asarray(out.x[:, :, a, b])))
            continue
        assert n == 2
        reached += 1
        got = np.asarray(out.x[:n, :, a, b])
        for r in ref:
            assert np.min(np.max(np.abs(got - r), axis=1)) < 1e-9
        s = np.asarray(out.det_A_sign[:n, a, b])
        assert s[0] > 0 > s[1]  # the two modes have opposite det(A): the rule orders them
        for k in range(n):
            F = np.asarray(m4.mechanism.constraints(jnp.asarray(got[k]), jnp.asarray(q[:, a, b]), p4))
            assert np.max(np.abs(F)) < 1e-9
    assert 4 <= reached < 12
    # an input with no assembly: the links cannot meet
    far = pk.forward_positions(m4.mechanism, jnp.asarray([np.pi, 0.0]), p4, ((-400.0, -400.0), (500.0, 400.0)))
    assert int(far.count) == 0 and np.all(np.isnan(np.asarray(far.x)))


def test_forward_modes_derivative_is_J(p4):
    q = jnp.asarray([1.6, 0.9])
    box = ((-400.0, -400.0), (500.0, 400.0))
    f = lambda q_: pk.forward_positions(m4.mechanism, q_, p4, box, starts_per_axis=6, max_modes=2).x[0]  # noqa: E731
    x = f(q)
    dxdq = np.asarray(jax.jacfwd(f)(q))
    J = np.asarray(pk.jacobian(m4.mechanism, x, q, p4))
    np.testing.assert_allclose(dxdq, J, rtol=1e-9, atol=1e-9)


def test_forward_positions_bad_box(p4):
    with pytest.raises(ValueError, match="box"):
        pk.forward_positions(m4.mechanism, jnp.asarray([1.6, 0.9]), p4, ((0.0, 0.0), (-1.0, 1.0)))
    with pytest.raises(ValueError, match="box"):
        pk.forward_positions(m4.mechanism, jnp.asarray([1.6, 0.9]), p4, (0.0, 1.0))
    with pytest.raises(ValueError, match="q must have shape"):
        pk.forward_positions(m4.mechanism, jnp.zeros(3), p4, ((0.0, 0.0), (1.0, 1.0)))


def test_delta_inverse_matches_its_forward():
    """Inverse then forward: every Delta pose of a grid returns through forward_positions."""
    mech = delta_mechanism()
    X, Y, Z = np.meshgrid(
        np.linspace(-0.15, 0.15, 4), np.linspace(-0.15, 0.15, 4), np.linspace(-0.45, -0.3, 3), indexing="ij"
    )
    x = jnp.stack([jnp.asarray(X), jnp.asarray(Y), jnp.asarray(Z)])
    q = pk.inverse_positions(mech, x, DELTA, (1, 1, 1))
    assert np.all(np.isfinite(np.asarray(q)))
    F = np.asarray(mech.constraints(x, q, DELTA))
    assert np.max(np.abs(F)) < 1e-14
    out = pk.forward_positions(mech, q, DELTA, ((-0.6, -0.6, -0.8), (0.6, 0.6, 0.8)), max_modes=2)
    err = np.min(np.max(np.abs(np.asarray(out.x) - np.asarray(x)[None]), axis=1), axis=0)
    assert np.max(err) < 1e-12


def test_inverse_of_a_loaded_mechanism_inside_jit_equals_the_eager_one():
    """The limits of a loaded mechanism are built by jnp: under jit they are traced and not checked
    eagerly; the solve is the same (a regression: np.asarray of traced limits raised)."""
    m = pk.load_mechanism(pk.DATA_DIR / "mechanisms" / "planar_3rpr.yaml")
    x = jnp.array([[0.3, 0.25], [0.3, 0.35], [0.1, -0.2]])
    eager = m.inverse(x, m.params, (-1, -1, -1))
    traced = jax.jit(lambda x: m.inverse(x, m.params, (-1, -1, -1)))(x)
    assert np.all(np.isfinite(np.asarray(eager)))
    np.testing.assert_allclose(np.asarray(traced), np.asarray(eager), rtol=1e-12, atol=0)


# ----------------------------------------------------------------------------- quadratic chains
def _p1_loaded():
    return pk.load_mechanism(pk.DATA_DIR / "mechanisms" / "p1_gripper_4prr.yaml")


def test_quadratic_chains_are_read_from_the_operations(p1, p2):
    """P1's chains (module and description) and the 3-RPR's are polynomials of degree 2 in their
    prismatic actuator; P2's revolute ones are not tested; a prismatic chain through a square root
    or divided by a function of q_i is not quadratic (it keeps the checked fit)."""
    from pkmlib._positions import _quadratic_chains

    loaded = _p1_loaded()
    rpr = pk.load_mechanism(pk.DATA_DIR / "mechanisms" / "planar_3rpr.yaml")
    prismatic = (False,) * 4
    assert _quadratic_chains(m1.mechanism, "diagonal", prismatic, 4, p1) == (True,) * 4
    assert _quadratic_chains(loaded, "diagonal", prismatic, 4, loaded.params) == (True,) * 4
    assert _quadratic_chains(rpr, "diagonal", (False,) * 3, 3, rpr.params) == (True,) * 3
    assert _quadratic_chains(m2.mechanism, "diagonal", (True,) * 3, 3, p2) == (False,) * 3

    def chain_sqrt(i, x, t, p):
        return jnp.sqrt(m1.mechanism.chain_constraint(i, x, t, p) + 1.0)

    def chain_div(i, x, t, p):
        return m1.mechanism.chain_constraint(i, x, t, p) / (1.0 + t * t)

    def chain_cubic(i, x, t, p):
        return m1.mechanism.chain_constraint(i, x, t, p) * (1.0 + t)

    def chain_scaled(i, x, t, p):  # divided by what does not depend on t: still quadratic
        return jnp.where(x[0] > 0.0, m1.mechanism.chain_constraint(i, x, t, p) / (1.0 + x[1] ** 2), 0.0)

    for chain, quadratic in ((chain_sqrt, False), (chain_div, False), (chain_cubic, False), (chain_scaled, True)):
        mech = dataclasses.replace(m1.mechanism, chain_constraint=chain, inverse_position=None, name=chain.__name__)
        assert _quadratic_chains(mech, "diagonal", prismatic, 4, p1) == (quadratic,) * 4, chain.__name__


def test_quadratic_path_equals_the_checked_fit_on_every_branch(p1):
    """The quadratic formula on the Taylor coefficients gives the 3-sample fit's roots (the fit
    forced by hiding the quadratic structure behind a square of a square root) on all 16 branches:
    the same branch labels, the same NaN poses."""
    x = grid_p1()[:, ::8, ::8]
    fitted = dataclasses.replace(
        m1.mechanism,
        chain_constraint=lambda i, x_, t, p: m1.mechanism.chain_constraint(i, x_, t, p) * jnp.sqrt(1.0 + 0.0 * t) ** 2,
        inverse_position=None,
        name="P1 fitted",
    )
    from pkmlib._positions import _quadratic_chains

    assert _quadratic_chains(fitted, "diagonal", (False,) * 4, 4, p1) == (False,) * 4
    for branch in itertools.product((1, -1), repeat=4):
        qq = np.asarray(pk.inverse_positions(m1.mechanism, x, p1, branch))
        qf = np.asarray(pk.inverse_positions(fitted, x, p1, branch))
        assert np.array_equal(np.isnan(qq), np.isnan(qf)), branch
        fin = np.isfinite(qq)
        np.testing.assert_allclose(qq[fin], qf[fin], rtol=0, atol=1e-12)
        b = np.asarray(pk.B_diagonal(m1.mechanism, x, jnp.asarray(qq), p1))
        assert np.all(np.sign(b[fin]) == np.broadcast_to(np.asarray(branch)[:, None, None], b.shape)[fin])


def test_loaded_p1_inside_jit_is_the_eager_solve_without_fallback(p1):
    """Under jit the loaded P1 solve is the quadratic formula alone (no bracketing loop in the
    traced computation), equal to the eager solve and to the closed form; residuals on request."""
    loaded = _p1_loaded()
    x = grid_p1()[:, ::4, ::4]
    f = jax.jit(lambda x_, p_: pk.inverse_positions(loaded, x_, p_))
    traced, eager = np.asarray(f(x, loaded.params)), np.asarray(pk.inverse_positions(loaded, x, loaded.params))
    closed = np.asarray(m1.mechanism.inverse(x, p1, m1.PAPER_BRANCH))
    assert np.array_equal(np.isnan(traced), np.isnan(eager)) and np.array_equal(np.isnan(closed), np.isnan(eager))
    assert np.isfinite(eager).mean() > 0.2
    np.testing.assert_allclose(traced, eager, rtol=0, atol=1e-14)
    np.testing.assert_allclose(eager, closed, rtol=0, atol=1e-13)  # m: some carriages are near 0
    assert "while" not in str(jax.make_jaxpr(lambda x_, p_: pk.inverse_positions(loaded, x_, p_))(x, loaded.params))
    sol = pk.inverse_positions(loaded, x, loaded.params, residuals=True)
    F = np.asarray(loaded.constraints(x, sol.q, loaded.params))
    np.testing.assert_allclose(np.asarray(sol.residual), np.max(np.abs(F), axis=0), rtol=0, atol=1e-15)
    assert np.array_equal(np.isnan(np.asarray(sol.residual)), pose_nan(sol.q))


def test_loaded_p1_eq6_map_under_jit_is_one_loop_with_the_limits_row_by_row(p1):
    """The loaded P1 eq (6) map (pk.inverse_positions, then J^-1 row by row), jitted whole, equals
    the hand-written map, and XLA stores no q: the actuator limits are applied row by row and the
    rows are stacked last (``_finish``, ``inverse_positions``), so the solve fuses into the rows'
    loop instead of each chain's root being computed in a loop of its own
    (benchmarks/mechanisms.py). A pose with one carriage alone beyond its limit is NaN in every
    row, under jit as eagerly."""
    loaded = _p1_loaded()
    speeds = (1.0, 1.0, 1.0)
    x = np.array(grid_p1()[:, ::8, ::8])
    out = np.asarray(m1.pose(p1.x_A_min + 0.01, 0.0, np.deg2rad(20.0), 0.14))  # only carriage 11 left of the rail
    x[:, 0, 0] = out
    x = jnp.asarray(x)

    def eq6(x_, p_):
        q = pk.inverse_positions(loaded, x_, p_)
        return pk.max_actuator_velocity(pk.inverse_jacobian_rows(loaded, x_, q, p_), m1.OUTPUT_GROUPS, speeds)

    f = jax.jit(eq6)
    v = np.asarray(f(x, loaded.params))
    hand = np.asarray(jax.jit(lambda x_, p_: m1.max_carriage_velocity(x_, p_, speeds))(x, p1))
    assert np.array_equal(np.isnan(v), np.isnan(hand)) and np.isnan(v[0, 0])
    assert np.isfinite(v).mean() > 0.2
    fin = np.isfinite(hand)
    np.testing.assert_allclose(v[fin], hand[fin], rtol=1e-10, atol=0)
    q_one = jnp.asarray(out)[:, None]
    traced = np.asarray(jax.jit(lambda x_, p_: pk.inverse_positions(loaded, x_, p_))(q_one, loaded.params))
    eager = np.asarray(pk.inverse_positions(loaded, q_one, loaded.params))
    closed = np.asarray(m1.mechanism.inverse(q_one, p1, m1.PAPER_BRANCH))
    for q in (traced, eager, closed):
        assert np.all(np.isnan(q)), q
    q_ok = jnp.asarray(m1.pose(0.7, 0.0, np.deg2rad(20.0), 0.14))[:, None]
    np.testing.assert_allclose(
        np.asarray(jax.jit(lambda x_, p_: pk.inverse_positions(loaded, x_, p_))(q_ok, loaded.params)),
        np.asarray(m1.mechanism.inverse(q_ok, p1, m1.PAPER_BRANCH)),
        rtol=0,
        atol=1e-13,
    )
    import re

    hlo = f.lower(x, loaded.params).compile().as_text()
    grid = ",".join(str(s) for s in x.shape[1:])
    size = int(np.prod(x.shape[1:]))
    stored_q = re.findall(rf"= f64\[4,(?:{grid}|{size})\]\{{[^}}]*\}} (?:fusion|concatenate)\(", hlo)
    assert not stored_q, f"q is stored between the solve and the rows: {stored_q}"
