"""P3 (2T1R mechanisms A and B): forward/inverse position round trips on every branch, loop
closure, Tables 1-2 of A to the printed digits, autodiff Jacobians vs the paper's hand entries."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import two_t_one_r as m
from conftest import assert_close

N = 400


@pytest.fixture(scope="module")
def pa():
    return m.ParamsA.from_dict(pk.load_params("p3")["mechanism_A"])


@pytest.fixture(scope="module")
def pb():
    return m.ParamsB.from_dict(pk.load_params("p3")["mechanism_B"])


@pytest.fixture(scope="module")
def q_random():
    """N actuator inputs uniformly in the paper's box (P3 section 2.2.1), shape (3, N)."""
    rng = np.random.default_rng(3)
    return np.stack([rng.uniform(-250.0, 0.0, N), rng.uniform(0.0, 250.0, N), rng.uniform(-300.0, 300.0, N)])


def _finite_columns(*arrays):
    ok = np.ones(arrays[0].shape[-1], dtype=bool)
    for a in arrays:
        ok &= np.all(np.isfinite(np.asarray(a)), axis=0)
    return ok


def _ik_branch_a(q, x):
    """The (u, v) of eq (14) that returns ``q``: the side of x_C each carriage lies on."""
    return jnp.stack([jnp.sign(q[0] - x[0]), jnp.sign(q[2] - x[0])])


def test_forward_then_inverse_returns_the_inputs_on_every_branch_A(pa, q_random):
    q = jnp.asarray(q_random)
    for mm in m.FORWARD_BRANCHES["A"]:
        x = m.forward_a(q, pa, mm)
        ok = _finite_columns(x)
        assert ok.sum() > N // 4, "branch with almost no real solutions: sample is not testing anything"
        back = m.inverse_a(x[:, ok], pa, _ik_branch_a(q[:, ok], x[:, ok]))
        assert_close(back, q[:, ok], rtol=0, atol=1e-9)


def test_inverse_then_forward_on_all_four_branches_A(pa, q_random):
    q = jnp.asarray(q_random)
    for mm in m.FORWARD_BRANCHES["A"]:
        x = m.forward_a(q, pa, mm)
        ok = _finite_columns(x)
        for br in m.INVERSE_BRANCHES["A"]:
            q_br = m.inverse_a(x[:, ok], pa, jnp.array(br))
            assert_close(m.forward_a(q_br, pa, mm), x[:, ok], rtol=0, atol=1e-9)


def test_loop_closure_residual_A(pa, q_random):
    q = jnp.asarray(q_random)
    for mm in m.FORWARD_BRANCHES["A"]:
        x = m.forward_a(q, pa, mm)
        ok = _finite_columns(x)
        assert_close(m.link_length_errors_a(x[:, ok], q[:, ok], pa), np.zeros((3, int(ok.sum()))), rtol=0, atol=1e-9)
        # and the constraint function of the Mechanism (mm^2) vanishes there too
        assert_close(m.constraints_a(x[:, ok], q[:, ok], pa), np.zeros((3, int(ok.sum()))), rtol=0, atol=1e-7)


def test_forward_then_inverse_on_every_branch_B(pb, q_random):
    q = jnp.asarray(q_random)
    seen = 0
    for br in m.FORWARD_BRANCHES["B"]:
        x = m.forward_b(q, pb, jnp.array(br))
        ok = _finite_columns(x)
        seen += int(ok.sum())
        if not ok.any():
            continue
        xs, qs = x[:, ok], q[:, ok]
        u = jnp.sign(qs[0] - xs[0])
        v = jnp.sign(qs[2] - xs[0])
        # w: the IK branch whose five-bar height equals the forward solution's H > 0
        H = jnp.sqrt(pb.l2**2 - (0.5 * (qs[1] - qs[0])) ** 2)
        w = jnp.where(
            jnp.abs(m.five_bar_height_b(xs, pb, 1.0) - H) < jnp.abs(m.five_bar_height_b(xs, pb, -1.0) - H), 1.0, -1.0
        )
        assert_close(m.inverse_b(xs, pb, jnp.stack([u, v, w])), qs, rtol=0, atol=1e-8)
        assert_close(m.link_length_errors_b(xs, qs, pb), np.zeros((5, int(ok.sum()))), rtol=0, atol=1e-9)
        assert_close(m.constraints_b(xs, qs, pb), np.zeros((3, int(ok.sum()))), rtol=0, atol=1e-7)
    assert seen > N // 4


def test_inverse_then_forward_on_all_eight_branches_B(pb, q_random):
    """Every real IK solution (u, v, w) maps back to the pose through the FK branch (n, m) with the
    five-bar assembly h = sign(H) of that solution (the paper's FK fixes h = +1)."""
    q = jnp.asarray(q_random)
    checked = 0
    for br in m.FORWARD_BRANCHES["B"]:
        x = m.forward_b(q, pb, jnp.array(br))
        ok = _finite_columns(x)
        if not ok.any():
            continue
        xs = x[:, ok]
        for ib in m.INVERSE_BRANCHES["B"]:
            q_ib = m.inverse_b(xs, pb, jnp.array(ib))
            h = jnp.sign(m.five_bar_height_b(xs, pb, ib[2]))
            good = _finite_columns(q_ib)
            errs = []
            for mm in (1.0, -1.0):
                fk = m.forward_b(q_ib[:, good], pb, jnp.array([br[0], mm]), h[good])
                errs.append(np.max(np.abs(np.asarray(fk) - np.asarray(xs[:, good])), axis=0))
            err = np.minimum(*errs)
            assert np.all(err < 1e-8), (br, ib, err.max())
            checked += int(good.sum())
    assert checked > N


def test_table1_A_to_the_printed_digits(pa):
    """P3 Table 1: x1 = -106.09, x2 = 181.67, x3 = -70.29 mm; row 1 is branch m = +1."""
    q = jnp.array([-106.09, 181.67, -70.29])
    printed = {1.0: (37.79, 238.9192, -0.7097), -1.0: (37.79, 238.9192, 0.2547)}
    for mm, (x, z, al) in printed.items():
        ours = np.asarray(m.forward_a(q, pa, mm))
        assert abs(ours[0] - x) <= 0.005 and abs(ours[1] - z) <= 5e-5 and abs(ours[2] - al) <= 5e-5
    assert m.FORWARD_BRANCHES["A"][0] == 1.0
    # y of C3 is -a on every pose
    assert float(m.joint_points_a(m.forward_a(q, pa, 1.0), q, pa)["C"][1]) == -300.0


def test_table2_A_follows_table1_row2_rounded(pa):
    """P3 Table 2 (x3 = 145.8604 / -70.2804) follows from Table 1 row 2 rounded as printed
    (37.79, 238.9192, 0.2547), not from row 1 (-0.7097 gives 145.9149 / -70.3349) as the text says."""
    printed = (
        (181.67, -106.09, 145.8604),
        (181.67, -106.09, -70.2804),
        (-106.09, 181.67, 145.8604),
        (-106.09, 181.67, -70.2804),
    )
    row2 = jnp.array([37.79, 238.9192, 0.2547])
    row1 = jnp.array([37.79, 238.9192, -0.7097])
    for br, row in zip(m.INVERSE_BRANCHES["A"], printed):
        ours = np.asarray(m.inverse_a(row2, pa, jnp.array(br)))
        assert np.all(np.abs(ours[:2] - row[:2]) <= 0.005)
        assert abs(ours[2] - row[2]) <= 5e-5
        from_row1 = np.asarray(m.inverse_a(row1, pa, jnp.array(br)))
        assert abs(from_row1[2] - row[2]) > 0.05
    # unrounded, every branch of Table 1 gives the set inputs back exactly (row 4)
    q = jnp.array([-106.09, 181.67, -70.29])
    for mm in m.FORWARD_BRANCHES["A"]:
        assert_close(m.inverse_a(m.forward_a(q, pa, mm), pa, jnp.array([-1.0, -1.0])), q, rtol=0, atol=1e-9)


def _paper_J_A(x, q, p):
    """The paper's hand-written J_o, J_i of A (P3 section 2.3.1), as an independent check."""
    xc, zc, al = x
    f = np.array(
        [
            [2 * (xc - q[0]), 2 * (zc - p.l1), 0.0],
            [2 * (xc - q[1]), 2 * (zc - p.l1), 0.0],
            [
                2 * (xc - q[2]),
                2 * (zc + p.l3 * np.sin(al) - p.l1),
                2 * p.l3 * ((p.a - (-p.a)) * np.sin(al) + (zc - p.l1) * np.cos(al)),
            ],
        ]
    )
    g = np.diag([-2 * (xc - q[0]), -2 * (xc - q[1]), -2 * (xc - q[2])])
    return f, g


def test_autodiff_jacobians_match_the_paper_and_fk_derivative_A(pa, q_random):
    for k in range(8):
        q = jnp.asarray(q_random[:, k])
        x = m.forward_a(q, pa, 1.0)
        if not np.all(np.isfinite(x)):
            continue
        f, g = _paper_J_A(np.asarray(x), np.asarray(q), pa)
        assert_close(pk.A_matrix(m.mechanism_a, x, q, pa), f, rtol=1e-12, atol=1e-9)
        assert_close(pk.B_matrix(m.mechanism_a, x, q, pa), g, rtol=1e-12, atol=1e-9)  # J_i = -g, dF/dq = g
        # x' = J q' from the constraints equals the derivative of the closed-form FK
        assert_close(pk.jacobian(m.mechanism_a, x, q, pa), jax.jacfwd(m.forward_a)(q, pa, 1.0), rtol=1e-8, atol=1e-10)


def test_autodiff_jacobian_matches_fk_derivative_B(pb, q_random):
    """At 40 random inputs on every forward branch (one compiled program over all 160, not 160
    eager rounds): pkmlib's J from A and B equals the derivative of the forward position, and B is
    lower triangular."""
    Q = jnp.asarray(np.repeat(q_random[:, :40], len(m.FORWARD_BRANCHES["B"]), axis=1).T)  # (160, 3)
    BR = jnp.asarray(np.tile(np.asarray(m.FORWARD_BRANCHES["B"]), (40, 1)))  # (160, 2)

    @jax.jit
    def at(q, br):
        x = m.forward_b(q, pb, br)
        return (
            x,
            pk.jacobian(m.mechanism_b, x, q, pb),
            jax.jacfwd(m.forward_b)(q, pb, br),
            pk.B_matrix(m.mechanism_b, x, q, pb),
        )

    X, J, J_fk, Bm = (np.asarray(a) for a in jax.vmap(at)(Q, BR))
    ok = np.all(np.isfinite(X), axis=1)
    assert ok.sum() > 5
    assert_close(J[ok], J_fk[ok], rtol=1e-7, atol=1e-9)
    for i, j in ((0, 1), (0, 2), (1, 2), (2, 0)):  # lower triangular
        assert np.all(Bm[ok, i, j] == 0.0), (i, j)


def test_bad_parameters_raise():
    d = dict(pk.load_params("p3")["mechanism_A"])
    d["l2_mm"] = -1.0
    with pytest.raises(ValueError, match="l2_mm"):
        m.ParamsA.from_dict(d)
    d = dict(pk.load_params("p3")["mechanism_B"])
    d["x1_min_mm"] = 10.0
    with pytest.raises(ValueError, match="x1"):
        m.ParamsB.from_dict(d)


def test_from_dict_takes_the_whole_params_file_or_its_section():
    P = pk.load_params("p3")
    assert m.ParamsA.from_dict(P) == m.ParamsA.from_dict(P["mechanism_A"])
    assert m.ParamsB.from_dict(P) == m.ParamsB.from_dict(P["mechanism_B"])
    assert m.ParamsB.from_dict(P).l5 == 320.0


@pytest.mark.parametrize("cls, section", [(m.ParamsA, "mechanism_A"), (m.ParamsB, "mechanism_B")])
@pytest.mark.parametrize(
    "key, value",
    [
        ("l3_mm", None),
        ("l3_mm", [450.0]),
        ("l3_mm", 450.0 + 0j),
        ("l3_mm", "abc"),
        ("l3_mm", float("inf")),
        ("l3_mm", 0.0),
        ("x3_min_mm", None),
        ("x3_max_mm", "300"),
        ("a_mm", True),
    ],
)
def test_from_dict_names_the_bad_key(cls, section, key, value):
    P = pk.load_params("p3")
    d = {**P[section], key: value}
    with pytest.raises(ValueError, match=key):
        cls.from_dict(d)
    with pytest.raises(ValueError, match=key):
        cls.from_dict({**P, section: d})


def test_from_dict_rejects_what_is_not_a_params_dict():
    P = pk.load_params("p3")
    for bad in (None, [1.0], "p3", 3.0):
        with pytest.raises(ValueError, match="dict"):
            m.ParamsA.from_dict(bad)
    with pytest.raises(ValueError, match="mechanism_B"):
        m.ParamsB.from_dict({**P, "mechanism_B": 1.0})
    d = dict(P["mechanism_B"])
    del d["l5_mm"]
    with pytest.raises(ValueError, match="l5_mm"):
        m.ParamsB.from_dict(d)
