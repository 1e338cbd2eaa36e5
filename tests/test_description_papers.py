"""Every paper mechanism as a description (data/mechanisms/*.yaml) against its hand-written module.

On each paper's own grid (the notebooks' parameters cells), with q from the hand-written closed-form
inverse position: F, A, B, J^-1, det(A), det(B) of the loaded mechanism equal the module's to 1e-10
relative (entries compared with rtol = 1e-10 and atol = 1e-10 times the largest |entry| of that
quantity over the grid, since single entries pass through zero). F is compared at q and at q + 0.01
(at the solution both are rounding noise). The branch rule of data/mechanisms/README.md is checked
too: sign(dF_i/dq_i) at the hand-written inverse is the module's branch constant.
"""

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import assert_close, central_difference

import pkmlib as pk
from pkmlib.mechanisms import decoupled_6dof, five_bar, gripper_4prr, three_rrr, two_t_one_r

DESC = pk.DATA_DIR / "mechanisms"
ROOT = Path(__file__).resolve().parents[1]
RTOL = 1e-10


def _pose_grid(grid, *fixed):
    pts = grid.points().reshape(-1, grid.ndim).T  # (ndim, N)
    rows = [pts[k] for k in range(pts.shape[0])] + [np.full(pts.shape[1], v) for v in fixed]
    return jnp.asarray(np.stack(rows))


def _inside(x, q):
    # picked in NumPy: a boolean index of a JAX array compiles programs for each count of points
    x, q = np.asarray(x), np.asarray(q)
    ok = np.all(np.isfinite(q), axis=0)
    return jax.device_put(x[:, ok]), jax.device_put(q[:, ok])


def _padded(x, q):
    """The poses (``(n, N)``, N > 0, counted by the caller first) repeated from the first to a
    power of two: a mechanism's branches keep different numbers of poses, and on a few shapes the
    compiled comparisons (:func:`_jitted`) are traced a few times, not once per branch."""
    keep = np.resize(np.arange(x.shape[1]), 1 << int(x.shape[1] - 1).bit_length())
    return jax.device_put(np.asarray(x)[:, keep]), jax.device_put(np.asarray(q)[:, keep])


_JITTED: dict = {}


def _jitted(what, *objects, make):
    """``jax.jit(make())``, made once per ``what`` and mechanism objects (kept here, so their ids
    stay theirs): every branch and call that compares the same mechanisms reuses its traces."""
    key = (what, *map(id, objects))
    if key not in _JITTED:
        _JITTED[key] = (objects, jax.jit(make()))
    return _JITTED[key][1]


def _close(a, b, what):
    """Equal to RTOL (atol: RTOL times the largest finite |b|), non-finite at the same entries
    (J^-1 is inf where det(B) = 0 in both)."""
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape, what
    ok = np.isfinite(b)
    assert np.array_equal(np.isfinite(a), ok), f"{what}: non-finite at other entries"
    assert ok.mean() > 0.99, what
    assert_close(a[ok], b[ok], rtol=RTOL, atol=RTOL * float(np.max(np.abs(b[ok]))), err_msg=what)


QUANTITIES = {
    "F": lambda m, x, q, p: m.constraints(x, q, p),
    "A": pk.A_matrix,
    "B": pk.B_matrix,
    "J^-1": pk.inverse_jacobian,
    "det(A)": pk.det_A,
    "det(B)": pk.det_B,
}


def _all(mech, x, q, p):
    return {k: f(mech, x, q, p) for k, f in QUANTITIES.items()}


def _compare(loaded, hand, x, q, p_hand, dq=0.01, no_node=None):
    """F, A, B, J^-1, det(A), det(B) of both mechanisms at the poses x, q (SoA), each compiled once.

    ``no_node(F_hand)``: for a description with a node, the poses off the solution where the node
    does not exist (the loaded F is NaN there in every row through the node; the hand-written one
    may keep some rows finite)."""
    assert loaded.n_outputs == hand.n_outputs and loaded.n_actuators == hand.n_actuators
    got = _jitted("all", loaded, make=lambda: lambda x, q, p: _all(loaded, x, q, p))(x, q, loaded.params)
    want = _jitted("all", hand, p_hand, make=lambda: lambda x, q: _all(hand, x, q, p_hand))(x, q)
    F_off = np.asarray(_jitted("F", loaded, make=lambda: loaded.constraints)(x, q + dq, loaded.params))
    F_off_hand = np.asarray(
        _jitted("F", hand, p_hand, make=lambda: lambda x, q: hand.constraints(x, q, p_hand))(x, q + dq)
    )
    if no_node is not None:
        rows, cols = no_node(F_off_hand)
        assert np.all(np.isnan(F_off[np.ix_(rows, cols)]))
        F_off, F_off_hand = F_off[:, ~cols], F_off_hand[:, ~cols]
    _close(F_off, F_off_hand, "F off the solution")
    scale = float(np.max(np.abs(np.asarray(F_off_hand))))
    assert np.max(np.abs(np.asarray(got["F"]) - np.asarray(want["F"]))) <= RTOL * scale, "F at the solution"
    # J^-1 only where B is invertible: a grid node exactly on a type-1 singularity (det(B) = 0 to
    # rounding) gives inf or 1/rounding, differently in each
    det_B = np.abs(np.asarray(want["det(B)"]))
    regular = det_B > 1e-8 * np.median(det_B)
    assert regular.mean() > 0.95
    for name in ("A", "B", "J^-1", "det(A)", "det(B)"):
        a, b = np.asarray(got[name]), np.asarray(want[name])
        if name == "J^-1":
            a, b = a[..., regular], b[..., regular]
        _close(a, b, name)


def _diag_B(m, x, q, p):
    """dF_i/dq_i: the diagonal of B (B_diagonal for a chainwise mechanism)."""
    if m.chainwise:
        return pk.B_diagonal(m, x, q, p)
    B = pk.B_matrix(m, x, q, p)
    return jnp.stack([B[i, i] for i in range(m.n_actuators)])


def _assert_branch(loaded, x, q, branch):
    """sign(dF_i/dq_i) = branch_i at every pose (up to the poses on the type-1 boundary, where
    dF_i/dq_i = 0 to rounding: those are at most 1 %)."""
    d = np.asarray(
        _jitted("diag B", loaded, make=lambda: lambda x, q, p: _diag_B(loaded, x, q, p))(x, q, loaded.params)
    )
    clear = np.abs(d) > 1e-8 * np.max(np.abs(d), axis=1, keepdims=True)
    assert clear.mean() > 0.99
    expected = np.broadcast_to(np.asarray(branch, dtype=np.float64)[:, None], d.shape)
    assert np.array_equal(np.sign(d)[clear], expected[clear])


# --------------------------------------------------------------------------- P1
def test_p1_description_equals_gripper_4prr_on_the_paper_grid():
    m = pk.load_mechanism(DESC / "p1_gripper_4prr.yaml")
    p = gripper_4prr.Gripper4PRRParams.from_dict(pk.load_params("p1"))
    grid = pk.Grid.from_ranges(x_D=(0.2, 1.2, 0.005), y_D=(-0.25, 0.25, 0.0025))  # notebook parameters
    x = _pose_grid(grid, np.deg2rad(20.0), 0.14)  # phi = 20 deg, s = 0.14 m
    q = gripper_4prr.mechanism.inverse(x, p, gripper_4prr.PAPER_BRANCH)
    x, q = _inside(x, q)
    assert x.shape[1] > 10000
    _compare(m, gripper_4prr.mechanism, x, q, p)
    assert m.chainwise and m.default_branch == gripper_4prr.PAPER_BRANCH
    _assert_branch(m, x, q, np.asarray(gripper_4prr.PAPER_BRANCH))
    assert m.output_names == gripper_4prr.mechanism.output_names
    assert m.output_units == gripper_4prr.mechanism.output_units
    assert m.actuator_names == gripper_4prr.mechanism.actuator_names
    lo, hi = m.actuator_limits(m.params)
    assert_close(lo, np.full(4, p.x_A_min)), assert_close(hi, np.full(4, p.x_A_max))
    assert m.actuator_kinds == ("prismatic",) * 4


def test_p1_every_branch_sign_is_the_branch_of_dF_dq():
    m = pk.load_mechanism(DESC / "p1_gripper_4prr.yaml")
    p = gripper_4prr.Gripper4PRRParams.from_dict(pk.load_params("p1"))
    x = _pose_grid(pk.Grid.from_ranges(x_D=(0.5, 0.9, 0.05), y_D=(-0.05, 0.05, 0.025)), 0.35, 0.1)
    for branch in [(1, 1, 1, 1), (-1, -1, 1, 1), (1, -1, -1, 1)]:
        q = gripper_4prr.inverse_position(x, p, jnp.asarray(branch, dtype=jnp.float64))
        xi, qi = _inside(x, q)
        assert xi.shape[1] > 0
        _assert_branch(m, xi, qi, np.asarray(branch))


# --------------------------------------------------------------------------- P2
def test_p2_description_equals_three_rrr_on_the_paper_grid():
    m = pk.load_mechanism(DESC / "p2_three_rrr.yaml")
    p = three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2"))
    grid = pk.Grid.from_ranges(x_P=(-0.15, 0.55, 0.0025), y_P=(-0.15, 0.5, 0.0025))
    x = _pose_grid(grid, 0.0)
    q = three_rrr.mechanism.inverse(x, p, three_rrr.PAPER_BRANCH)
    x, q = _inside(x, q)
    assert x.shape[1] > 10000
    _compare(m, three_rrr.mechanism, x, q, p)
    _assert_branch(m, x, q, np.asarray(three_rrr.PAPER_BRANCH))
    assert m.default_branch == three_rrr.PAPER_BRANCH
    assert m.actuator_kinds == ("revolute",) * 3 and m.actuator_units == ("rad",) * 3


def test_p2_description_at_another_orientation_and_working_mode():
    m = pk.load_mechanism(DESC / "p2_three_rrr.yaml")
    p = three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2"))
    x = _pose_grid(pk.Grid.from_ranges(x_P=(0.1, 0.3, 0.01), y_P=(0.05, 0.25, 0.01)), 0.3)
    branch = (1, -1, 1)
    q = three_rrr.inverse_position(x, p, jnp.asarray(branch, dtype=jnp.float64))
    x, q = _inside(x, q)
    _compare(m, three_rrr.mechanism, x, q, p)
    _assert_branch(m, x, q, np.asarray(branch))


# --------------------------------------------------------------------------- P4
def test_p4_description_equals_five_bar_on_the_paper_grid():
    m = pk.load_mechanism(DESC / "p4_five_bar.yaml")
    p = five_bar.FiveBarParams.from_dict(pk.load_params("p4"))
    grid = pk.Grid.from_ranges(x_C=(-250.0, 350.0, 2.5), z_C=(2.5, 350.0, 2.5))
    x = _pose_grid(grid)
    q = five_bar.mechanism.inverse(x, p, five_bar.PAPER_BRANCH)
    x, q = _inside(x, q)
    assert x.shape[1] > 10000
    _compare(m, five_bar.mechanism, x, q, p)
    _assert_branch(m, x, q, np.asarray(five_bar.PAPER_BRANCH))
    assert m.default_branch == five_bar.PAPER_BRANCH and m.output_units == ("mm", "mm")


# --------------------------------------------------------------------------- P3 A
def _p3a_poses(p):
    """Table 1's input and a grid over the actuator box (25 mm), each through both FK branches m."""
    table1 = np.asarray(pk.load_params("p3")["table1_inputs_A_mm"])[:, None]
    g = np.meshgrid(
        np.arange(-250.0, 0.1, 25.0), np.arange(0.0, 250.1, 25.0), np.arange(-300.0, 300.1, 25.0), indexing="ij"
    )
    qs = np.concatenate([table1, np.stack([c.ravel() for c in g])], axis=1)
    xs = [two_t_one_r.forward_a(jnp.asarray(qs), p, mm) for mm in (1.0, -1.0)]
    return jnp.concatenate(xs, axis=1)


def test_p3_mechanism_a_description_equals_two_t_one_r():
    m = pk.load_mechanism(DESC / "p3_mechanism_a.yaml")
    p = two_t_one_r.ParamsA.from_dict(pk.load_params("p3"))
    x_all = _p3a_poses(p)
    # Table 1 row 1: (x, z) = (37.79, 238.9192) mm, alpha = -0.7097 rad
    assert_close(x_all[:, 0], [37.79, 238.9192, -0.7097], rtol=2e-4)
    for u, v in two_t_one_r.INVERSE_BRANCHES["A"]:
        q = two_t_one_r.inverse_a(x_all, p, jnp.array([u, v]))
        x, q = _inside(x_all, q)
        assert x.shape[1] > 500
        x, q = _padded(x, q)
        _compare(m, two_t_one_r.mechanism_a, x, q, p, dq=1.0)
        # the paper's (u, v) is the sign pattern (u, -u, v) of dF_i/dq_i
        _assert_branch(m, x, q, np.array([u, -u, v]))
    u, v = two_t_one_r.mechanism_a.default_branch
    assert m.default_branch == (u, -u, v)
    lo, hi = m.actuator_limits(m.params)
    lo_h, hi_h = two_t_one_r.actuator_limits(p)
    assert_close(lo, lo_h), assert_close(hi, hi_h)


def _benchmark():
    """benchmarks/mechanisms.py as a module (it puts benchmarks/ on sys.path for its _bench)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("bench_mechanisms", ROOT / "benchmarks" / "mechanisms.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_p3_mechanism_a_benchmark_numerical_inverse_equals_eq14_to_1e10(tmp_path):
    """benchmarks/mechanisms.py's P3 A cases (pk.inverse_positions on two_t_one_r.mechanism_a against
    the jitted eq (14), branch (u, v) = (-1, -1), at the poses of FK branch m = +1 over a 21^3 grid of
    the actuator box: the size whose agreement benchmarks/results/mechanisms.json records) save equal
    values to 1e-10 relative and NaN at the same poses. Its poses lie on the box's faces and on
    x3 = x_C (a double root of f3) by construction; there each side's value is NaN (its
    ``on_boundary``), elsewhere every pose is compared. Comparing them too gave 2.4e-3 and a 1.9 %
    NaN mismatch (7e-7 mm at x3 ~ 0: x3 is fixed only to ~sqrt(eps) l4 there, by either method)."""
    bench = _benchmark()
    saved = {}
    for case in ("inverse_p3a_numerical", "inverse_p3a_closed"):
        run, n_items, values = bench.CASES[case](21)
        saved[case] = tmp_path / f"{case}.npz"
        np.savez(saved[case], **values(run()))
    agreement = bench._bench.compare_saved(saved["inverse_p3a_closed"], saved["inverse_p3a_numerical"], RTOL)
    assert agreement["nan_mismatch_fraction"] == 0.0 and agreement["agree"], agreement
    qn, qc = (np.load(saved[c])["q"] for c in ("inverse_p3a_numerical", "inverse_p3a_closed"))
    assert_close(qn[:, np.isfinite(qc[0])], qc[:, np.isfinite(qc[0])], rtol=RTOL, atol=RTOL * 600.0)
    assert 0.5 < np.isfinite(qc[0]).mean()
    # the poses left out are those on the boundary, a small part of the grid
    mech, p, x, *_ = bench._papers("p3a", 21)
    q = np.asarray(two_t_one_r.inverse_position_a(x, p, jnp.array([-1.0, -1.0])))
    boundary = bench.on_boundary(mech, x, q, p)
    assert 0.0 < boundary.mean() < 0.15
    assert np.array_equal(np.isnan(qc[0]), np.any(np.isnan(q), axis=0) | boundary)


def test_p3_mechanism_a_description_numerical_inverse_equals_eq14_on_the_notebook_grid():
    """The loaded p3_mechanism_a.yaml's numerical inverse (sign rule (u, -u, v)) equals P3 eq (14) on
    the notebook's actuator grid (step_mm = 5, FK branch m = +1, Table 1's), every (u, v): to 1e-10
    relative (of the 300 mm box) where both are finite, NaN at the same poses; the poses on the
    boundary within rounding (benchmarks/mechanisms.py's on_boundary) are not compared."""
    m = pk.load_mechanism(DESC / "p3_mechanism_a.yaml")
    p = two_t_one_r.ParamsA.from_dict(pk.load_params("p3"))
    grid = two_t_one_r.actuator_grid(p, 5.0)
    Q = jnp.asarray(np.stack([g.ravel() for g in np.meshgrid(*grid.axes, indexing="ij")]))
    x = two_t_one_r.forward_a(Q, p, two_t_one_r.FORWARD_BRANCHES["A"][0])
    on_boundary = _benchmark().on_boundary
    compared = 0
    for u, v in two_t_one_r.INVERSE_BRANCHES["A"]:
        qc = np.asarray(two_t_one_r.inverse_position_a(x, p, jnp.array([u, v])))
        qn = np.asarray(pk.inverse_positions(m, x, m.params, (u, -u, v)))
        edge = on_boundary(two_t_one_r.mechanism_a, x, qc, p) | on_boundary(two_t_one_r.mechanism_a, x, qn, p)
        nc, nn = np.any(np.isnan(qc), axis=0), np.any(np.isnan(qn), axis=0)
        assert np.array_equal(nc[~edge], nn[~edge]), (u, v, int(np.sum(nc[~edge] != nn[~edge])))
        both = ~nc & ~nn & ~edge
        assert_close(qn[:, both], qc[:, both], rtol=RTOL, atol=RTOL * 300.0)
        compared += int(both.sum())
    assert compared > 200000


# --------------------------------------------------------------------------- P3 B
def _p3b_poses(p):
    """The actuator box (25 mm, Table 1's input first) through every FK branch (n, m) of P3 eq (15),
    with the five-bar above B1 B2 (h = +1) as constraints_b takes it."""
    table1 = np.asarray(pk.load_params("p3")["table1_inputs_A_mm"])[:, None]
    g = np.meshgrid(
        np.arange(-250.0, 0.1, 25.0), np.arange(0.0, 250.1, 25.0), np.arange(-300.0, 300.1, 25.0), indexing="ij"
    )
    qs = jnp.asarray(np.concatenate([table1, np.stack([c.ravel() for c in g])], axis=1))
    return jnp.concatenate([two_t_one_r.forward_b(qs, p, jnp.asarray(b)) for b in two_t_one_r.FORWARD_BRANCHES["B"]], 1)


def _p3b_signs(u, v, w):
    """P3 eq (16)-(17)'s (u, v, w) as the signs of dF_i/dq_i (the description's branch rule):
    dF1/dx1 = 2 w R (x_E - x1) / H has the sign of -w u, dF2/dx2 = 2 (x_E - x1) of -u, dF3/dx3 of v."""
    return (-w * u, -u, v)


def test_p3_mechanism_b_description_equals_two_t_one_r():
    m = pk.load_mechanism(DESC / "p3_mechanism_b.yaml")
    p = two_t_one_r.ParamsB.from_dict(pk.load_params("p3"))
    assert [e.label for e in m.closure.dependent] == ["the constraint rod_2.plane of node 'C'"]
    assert not m.chainwise and m.closure.dependencies == [{0}, {0, 1}, {2}]  # B lower triangular, as P3 prints J_i
    x_all = _p3b_poses(p)
    compared = 0
    for u, v, w in two_t_one_r.INVERSE_BRANCHES["B"]:
        q = two_t_one_r.inverse_b(x_all, p, jnp.array([u, v, w]))
        # constraints_b (and the node's toward) take the five-bar above B1 B2: H >= 0
        H = two_t_one_r.five_bar_height_b(x_all, p, w)
        q = jnp.where(H > 1e-6, q, jnp.nan)
        x, q = _inside(x_all, q)
        if x.shape[1] < 50:
            continue
        x, q = _padded(x, q)
        compared += 1
        # off the solution, where |x_E - x1| > l2 the node C does not exist: f1 is NaN in both, and
        # the loaded f2 = |C B2|^2 - l2^2 too (the hand-written f2 stays finite)
        _compare(m, two_t_one_r.mechanism_b, x, q, p, dq=1.0, no_node=lambda F: ([0, 1], np.isnan(F[0])))
        _assert_branch(m, x, q, np.array(_p3b_signs(u, v, w)))
    assert compared >= 4
    assert m.default_branch == _p3b_signs(*two_t_one_r.PAPER_BRANCH["B"])
    lo, hi = m.actuator_limits(m.params)
    lo_h, hi_h = two_t_one_r.actuator_limits(p)
    assert_close(lo, lo_h), assert_close(hi, hi_h)
    # the node is P3 eq (11)'s C = C1 = C2 = C3, the other points those of joint_points_b
    x, q = x_all[:, :200], two_t_one_r.inverse_b(x_all[:, :200], p, jnp.asarray(two_t_one_r.PAPER_BRANCH["B"]))
    x, q = _inside(x, q)
    got, want = m.joint_points(x, q), two_t_one_r.joint_points_b(x, q, p)
    for ours, theirs in (("C12", "C"), ("C3", "C"), ("D", "D"), ("E", "E"), ("B1", "B1"), ("B2", "B2"), ("B3", "B3")):
        assert_close(got[ours], want[theirs], rtol=1e-12, atol=1e-9)


def test_p3_mechanism_b_numerical_inverse_equals_the_closed_form_in_the_actuator_box():
    """Inside P3's box (x1 <= 0 <= x2) every solution has x1 < x2, i.e. u = -1, and the signs of
    dF_i/dq_i label the solutions one-to-one: the loaded mechanism's inverse equals P3 eq (16)-(17)."""
    m = pk.load_mechanism(DESC / "p3_mechanism_b.yaml")
    p = two_t_one_r.ParamsB.from_dict(pk.load_params("p3"))
    x = _p3b_poses(p)
    assert pk.detect_structure(m, m.params) == "lower"  # B lower triangular: chain-by-chain solves
    solve = jax.jit(lambda x, b: pk.inverse_positions(m, x, m.params, b, structure="lower"))
    compared = 0
    for u, v, w in two_t_one_r.INVERSE_BRANCHES["B"]:
        qc = np.asarray(two_t_one_r.inverse_position_b(x, p, jnp.array([u, v, w])))
        qc = np.where(np.asarray(two_t_one_r.five_bar_height_b(x, p, w)) > 1e-6, qc, np.nan)
        qn = np.asarray(solve(x, jnp.asarray(_p3b_signs(u, v, w), dtype=jnp.float64)))
        if u == 1.0:
            fin = np.all(np.isfinite(qc), axis=0)  # u = +1 puts x1 > x2, outside the box, but for x1 = x2 = 0
            assert np.all(np.abs(qc[:2, fin]) < 1e-6), "u = +1 puts x1 > x2, outside the box"
        ok = np.all(np.isfinite(qc), axis=0)
        # a closed-form point on the box's edge may round either way
        lo, hi = (np.asarray(b)[:, None] for b in two_t_one_r.actuator_limits(p))
        edge = np.any((np.abs(qc - lo) < 1e-6) | (np.abs(qc - hi) < 1e-6), axis=0)
        # the one place in the box where the degenerate five-bar (x1 = x2, same signs) is a solution:
        # x1 = x2 = 0, on the edge of both carriages' travel (a few grid poses)
        degenerate = np.abs(qn[0] - qn[1]) < 1e-3
        assert np.all(np.abs(qn[:2, degenerate]) < 1e-3) and degenerate.mean() < 0.01
        edge |= degenerate
        # NaN-ness is compared one way only (as in tests/test_positions.py): near x1 = x_E (a double
        # root of f1 in x1) the sequential solve may miss the closed form's point
        found = np.all(np.isfinite(qn), axis=0)
        if (ok & ~edge).any():
            print("P3 B", (u, v, w), "found", found[ok & ~edge].mean(), "of", int((ok & ~edge).sum()))
            assert found[ok & ~edge].mean() > 0.5, (u, v, w, found[ok & ~edge].mean())
        both = ok & found & ~edge
        assert_close(qn[:, both], qc[:, both], rtol=1e-10, atol=1e-10 * 300.0)
        compared += int(both.sum())
    assert compared > 1000


def test_p3_mechanism_b_degenerate_five_bar_shares_the_signs():
    """Why the branch rule of p3_mechanism_b.yaml excludes x1 = x2: with the rods on top of each
    other, F = 0 holds at the other root of f1, (u, w) -> (-u, -w), with the same signs of dF_i/dq_i
    as the proper solution, and A's second row vanishes there (det(A) = 0)."""
    m = pk.load_mechanism(DESC / "p3_mechanism_b.yaml")
    p = two_t_one_r.ParamsB.from_dict(pk.load_params("p3"))
    u, v, w = two_t_one_r.PAPER_BRANCH["B"]
    xs = _p3b_poses(p)
    qs = two_t_one_r.inverse_b(xs, p, jnp.array([u, v, w]))
    qo = two_t_one_r.inverse_b(xs, p, jnp.array([-u, v, -w]))
    Hs = [two_t_one_r.five_bar_height_b(xs, p, s) for s in (w, -w)]
    k = int(np.argmax(np.all(np.isfinite(np.asarray(qs + qo)), axis=0) & (Hs[0] > 1.0) & (Hs[1] > 1.0)))
    x, q, q_other = xs[:, k], qs[:, k], qo[:, k]
    assert np.all(np.isfinite(np.asarray(q_other))) and float(two_t_one_r.five_bar_height_b(x, p, -w)) > 0.0
    q_degenerate = jnp.array([q_other[0], q_other[0], q_other[2]])
    assert np.max(np.abs(np.asarray(m.constraints(x, q_degenerate, m.params)))) < 1e-9
    d = np.sign(np.asarray(_diag_B(m, x, q, m.params)))
    d_deg = np.sign(np.asarray(_diag_B(m, x, q_degenerate, m.params)))
    assert np.array_equal(d, d_deg) and tuple(d) == _p3b_signs(u, v, w)
    A = np.asarray(pk.A_matrix(m, x, q_degenerate, m.params))
    assert np.all(np.abs(A[1]) < 1e-12 * np.max(np.abs(A)))  # rounding of the node's x_C = x_E


# --------------------------------------------------------------------------- P5
def test_p5_description_equals_decoupled_6dof():
    m = pk.load_mechanism(DESC / "p5_decoupled_6prps.yaml")
    p = decoupled_6dof.load_params()
    assert m.chainwise and m.mobility == 6 and m.actuator_kinds == ("prismatic",) * 6
    assert all(e.kind == "plane" for e in m.closure.equations)
    rng = np.random.default_rng(5)
    # the paper's pose (0.1, 0.15, 0.2) m at pi/6 first, then poses around it
    x0 = np.array([0.1, 0.15, 0.2, np.pi / 6, np.pi / 6, np.pi / 6])
    x = np.concatenate(
        [x0[:, None], x0[:, None] + rng.uniform(-0.2, 0.2, (6, 2000)) * np.array([1, 1, 1, 5, 5, 5])[:, None]], 1
    )
    x = jnp.asarray(x)
    q = decoupled_6dof.mechanism.inverse(x, p)
    _compare(m, decoupled_6dof.mechanism, x, q, p)
    _assert_branch(m, x, q, np.ones(6))
    qn = jax.jit(lambda x: m.inverse(x, m.params))(x)
    on_rails = np.all(np.abs(np.asarray(q)) <= m.params["travel"], axis=0)  # the drawn rails, +-0.45 m
    assert on_rails.mean() > 0.5 and np.all(np.isnan(np.asarray(qn)[:, ~on_rails]))
    assert_close(np.asarray(qn)[:, on_rails], np.asarray(q)[:, on_rails], rtol=1e-10, atol=1e-12)
    # J^-1 is P5's force-screw matrix in the angle rates (as in tests/test_contract.py)
    assert_close(pk.B_matrix(m, x[:, :3], q[:, :3], m.params), np.broadcast_to(np.eye(6)[:, :, None], (6, 6, 3)))
    pts = m.joint_points(x[:, :1], q[:, :1])
    A_b = decoupled_6dof.platform_points_base(*decoupled_6dof.position_rotation(x[:, 0]), p)
    for i in range(6):
        assert_close(pts[f"S{i + 1}"][:, 0], A_b[i], rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------- no paper: 3-RPR, Delta
def test_planar_3rpr_description_equals_the_tutorial_chains():
    m = pk.load_mechanism(DESC / "planar_3rpr.yaml")
    B = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 0.8]])
    a = np.array([[-0.1, -0.05], [0.1, -0.05], [0.0, 0.1]])

    def pivot(i, x):
        c, s = jnp.cos(x[2]), jnp.sin(x[2])
        return x[0] + c * a[i, 0] - s * a[i, 1], x[1] + s * a[i, 0] + c * a[i, 1]

    def chain(i, x, q_i, params):  # the tutorial's chain_constraint
        px, py = pivot(i, x)
        return (px - B[i, 0]) ** 2 + (py - B[i, 1]) ** 2 - q_i**2

    def inverse(x, params, branch):
        q = jnp.stack([jnp.hypot(*(pv - b for pv, b in zip(pivot(i, x), B[i]))) for i in range(3)])
        return pk.within_limits(q, 0.1, 0.9)

    tut = pk.Mechanism(
        name="tutorial 3-RPR",
        chain_constraint=chain,
        inverse_position=inverse,
        actuator_limits=lambda p: (jnp.full(3, 0.1), jnp.full(3, 0.9)),
        output_names=("x", "y", "phi"),
        output_units=("m", "m", "rad"),
        actuator_names=("q1", "q2", "q3"),
        actuator_units=("m", "m", "m"),
    )
    x = _pose_grid(pk.Grid.from_ranges(x=(-0.1, 1.1, 0.005), y=(-0.3, 0.95, 0.005)), np.deg2rad(10.0))
    q = tut.inverse(x, None)
    x, q = _inside(x, q)
    assert x.shape[1] > 5000
    _compare(m, tut, x, q, None)
    assert m.default_branch is None
    assert_close(np.stack(m.actuator_limits(m.params)), [[0.1] * 3, [0.9] * 3])
    # the prismatic leg is along the line of centres: dF_i/dq_i = -2 q_i
    assert_close(pk.B_diagonal(m, x, q, m.params), -2.0 * np.asarray(q), rtol=1e-12)


def test_delta_description_equals_an_independent_closure():
    m = pk.load_mechanism(DESC / "delta.yaml")
    pr = m.params
    assert m.mobility == 3 and m.chainwise and len(m.closure.twins) == 3
    rng = np.random.default_rng(1)
    x = jnp.asarray(rng.uniform([-0.1, -0.1, -0.5], [0.1, 0.1, -0.3], (50, 3)).T)
    q = jnp.asarray(rng.uniform(-0.5, 1.0, (3, 50)))
    F = np.asarray(m.constraints(x, q, pr))
    for i, g in enumerate(np.deg2rad([0.0, 120.0, 240.0])):
        radial, up = np.array([np.cos(g), np.sin(g), 0.0]), np.array([0.0, 0.0, 1.0])
        th = np.asarray(q[i])
        elbow = (pr["R_b"] * radial)[:, None] + pr["L_a"] * (np.cos(th) * radial[:, None] - np.sin(th) * up[:, None])
        plat = np.asarray(x) + (pr["r_p"] * radial)[:, None]
        assert_close(F[i], np.sum((plat - elbow) ** 2, axis=0) - pr["L_f"] ** 2, rtol=1e-12, atol=1e-14)
    pts = m.joint_points(x, q)
    assert set(pts) == {j.name for j in m.description.joints}
    assert pts["P1b"].shape == (3, 50)


# --------------------------------------------------------------------------- JAX: jit, vmap, grad
def test_loaded_constraints_jit_vmap_and_grad_over_designs():
    m = pk.load_mechanism(DESC / "p2_three_rrr.yaml")
    p = three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2"))
    x = _pose_grid(pk.Grid.from_ranges(x_P=(0.15, 0.25, 0.05), y_P=(0.1, 0.2, 0.05)), 0.1)
    q = three_rrr.mechanism.inverse(x, p, three_rrr.PAPER_BRANCH)
    soa = m.constraints(x, q + 0.01, m.params)
    per_point = jax.jit(jax.vmap(lambda xi, qi: m.constraints(xi, qi, m.params), in_axes=(1, 1), out_axes=1))
    assert_close(per_point(x, q + 0.01), soa, rtol=1e-13)

    # d det(A) / d l3 through the derived r_p = l3, against central differences
    x0, q0 = x[:, 4], q[:, 4]

    def det_at(l3, l1):
        return pk.det_A(m, x0, q0, {**m.params, "l3": l3, "l1": l1})

    g = jax.grad(det_at, argnums=(0, 1))(m.params["l3"], m.params["l1"])
    fd = central_difference(lambda z: np.atleast_1d(det_at(z[0], z[1])), [m.params["l3"], m.params["l1"]])
    assert_close(np.asarray(g), fd[0], rtol=1e-6)
    # vmap over designs: det(A) for a batch of l3 values equals one call per value
    l3s = jnp.array([0.06, 0.08, 0.1])
    batched = jax.vmap(lambda l3: det_at(l3, m.params["l1"]))(l3s)
    assert_close(batched, [det_at(v, m.params["l1"]) for v in l3s], rtol=1e-13)
    # and the gradient of F w.r.t. a parameter, batched
    dF = jax.jacfwd(lambda l2: m.constraints(x, q, {**m.params, "l2": l2}))(m.params["l2"])
    assert_close(dF, np.full(q.shape, -2.0 * m.params["l2"]), rtol=1e-12)


def test_loaded_mechanism_hash_and_replace():
    m = pk.load_mechanism(DESC / "p1_gripper_4prr.yaml")
    hash(m)  # lru_cache'd solvers key on the mechanism; params are not hashed
    g = m.general()
    assert not g.chainwise and g.params == m.params
    x = jnp.array([0.7, 0.05, 0.3, 0.05])
    q = jnp.array([0.4, 0.8, 0.77, 1.1])
    assert_close(pk.det_B(g, x, q, g.params), pk.det_B(m, x, q, m.params), rtol=1e-14)


@pytest.mark.parametrize("path", sorted(DESC.glob("*.yaml")), ids=lambda p: p.stem)
def test_every_description_loads(path):
    m = pk.load_mechanism(path)
    assert isinstance(m, pk.Mechanism) and m.inverse_position is None
    assert m.mobility == m.n_outputs == m.n_actuators
    assert len(m.output_units) == m.n_outputs and len(m.actuator_units) == m.n_actuators
    assert m.params and all(isinstance(v, float) for v in m.params.values())
    d = m.description
    if d.paper is not None:  # values come from the params file, never retyped
        file = pk.load_params(d.paper)
        for sym, key in d.parameter_keys.items():
            node = file
            for part in key.split("."):
                node = node[part]
            assert m.params[sym] == float(node)
