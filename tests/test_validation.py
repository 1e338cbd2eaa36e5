"""No silent wrong numbers at the boundary: branches, grids, loaders, forward position (issue 12)."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from pkmlib.mechanisms import three_rrr as t
from conftest import assert_close

X1 = np.array([0.7, 0.0, np.deg2rad(20.0), 0.14])
X2 = np.array([0.2, 0.1155, 0.0])


@pytest.fixture(scope="module")
def p2_params():
    return t.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])


# ----------------------------------------------------------------------------------- branches
BAD_P1_BRANCHES = [
    (-1, 1, -1),
    (-1, 1, -1, 1, 1),
    (0, 1, -1, 1),
    (-1, 2, -1, 1),
    (-0.5, 1, -1, 1),
    "-+-+",
    1,
    (True, 1, -1, 1),
    [[-1, 1], [-1, 1]],
    (np.nan, 1, -1, 1),
]


@pytest.mark.parametrize("branch", BAD_P1_BRANCHES)
def test_bad_p1_branches_are_value_errors_naming_branch(p1_params, branch):
    for call in (
        lambda: m.mechanism.inverse(X1, p1_params, branch),
        lambda: m.inverse_position(X1, p1_params, branch),
        lambda: m.max_carriage_velocity(X1, p1_params, (1.0, 1.0, 1.0), branch=branch),
    ):
        with pytest.raises(ValueError, match=r"branch.*4 signs, each \+1 or -1"):
            call()


@pytest.mark.parametrize("branch", [(1, 1), (1, 1, 1, 1), (1, 0, 1), (1, 1, 3)])
def test_bad_p2_branches_are_value_errors_naming_branch(p2_params, branch):
    with pytest.raises(ValueError, match=r"branch.*3 signs, each \+1 or -1"):
        t.pose_criteria(X2, p2_params, V=0.1, force=10.0, branch=branch)
    with pytest.raises(ValueError, match="branch"):
        t.inverse_position(X2, p2_params, branch)


def test_good_branches_in_any_form_give_the_same_pose(p1_params):
    ref = np.asarray(m.mechanism.inverse(X1, p1_params))
    for b in ([-1, 1, -1, 1], (-1.0, 1.0, -1.0, 1.0), np.array([-1, 1, -1, 1]), jnp.array([-1.0, 1.0, -1.0, 1.0])):
        assert_close(m.mechanism.inverse(X1, p1_params, b), ref, atol=0)


def test_traced_branches_are_checked_for_length_and_give_nan_for_other_signs(p1_params):
    f = jax.jit(lambda b: m.mechanism.inverse(jnp.asarray(X1), p1_params, b))
    assert_close(f(jnp.array([-1.0, 1.0, -1.0, 1.0])), m.mechanism.inverse(X1, p1_params), atol=0)
    assert np.all(np.isnan(np.asarray(f(jnp.array([-1.0, 2.0, -1.0, 1.0])))))
    with pytest.raises(ValueError, match="branch"):
        f(jnp.array([-1.0, 1.0, -1.0]))
    # the module's own inverse solutions do the same (P1, P2)
    g = jax.jit(lambda b: m.inverse_position(jnp.asarray(X1), p1_params, b))
    assert np.all(np.isnan(np.asarray(g(jnp.array([-1.0, 0.5, -1.0, 1.0])))))
    assert np.all(np.isfinite(np.asarray(g(jnp.array([-1.0, 1.0, -1.0, 1.0])))))
    # vmapped over branches: each row checked on its own
    B = jnp.array([[-1.0, 1.0, -1.0, 1.0], [-1.0, 0.0, -1.0, 1.0]])
    Q = np.asarray(jax.vmap(lambda b: m.mechanism.inverse(jnp.asarray(X1), p1_params, b))(B))
    assert np.all(np.isfinite(Q[0])) and np.all(np.isnan(Q[1]))


def test_mechanisms_check_their_default_branch_and_refuse_branches_they_ignore():
    kw = dict(
        name="toy",
        chain_constraint=lambda i, x, q, p: x[0] - q,
        inverse_position=lambda x, p, b: x[:1],
        actuator_limits=lambda p: (jnp.zeros(1), jnp.ones(1)),
        output_names=("x",),
        output_units=("m",),
        actuator_names=("q",),
        actuator_units=("m",),
    )
    with pytest.raises(ValueError, match="default_branch"):
        pk.Mechanism(**kw, default_branch=(2,))
    toy = pk.Mechanism(**kw)
    assert_close(toy.inverse(jnp.array([0.5]), None), [0.5])
    with pytest.raises(ValueError, match="branch must be None"):
        toy.inverse(jnp.array([0.5]), None, (1,))


# -------------------------------------------------------------------------------------- grids
@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(counts=(2.5,)), "axis a count must be a whole number"),
        (dict(counts=(0,)), "axis a count"),
        (dict(counts=("3",)), "axis a count"),
        (dict(counts=(10**12,)), "axis a count"),
        (dict(starts=("0",)), "axis a start must be a finite number"),
        (dict(starts=(None,)), "axis a start"),
        (dict(starts=(np.nan,)), "axis a start"),
        (dict(steps=(np.nan,)), "axis a step must be a finite positive number"),
        (dict(steps=("0.1",)), "axis a step"),
        (dict(steps=(None,)), "axis a step"),
        (dict(steps=(-0.1,)), "axis a step"),
        (dict(starts=(1e10,), steps=(1e-10,)), "axis a.*resolution"),
        (dict(starts=(1e308,), steps=(1e308,)), "axis a.*overflows"),
        (dict(names=("a", "a"), starts=(0.0, 0.0), steps=(1.0, 1.0), counts=(2, 2)), "distinct"),
        (dict(names="a"), "names must be a tuple"),
    ],
)
def test_bad_grids_are_value_errors_naming_the_axis(kwargs, match):
    base = dict(names=("a",), starts=(0.0,), steps=(0.1,), counts=(3,))
    with pytest.raises(ValueError, match=match):
        pk.Grid(**(base | kwargs))


@pytest.mark.parametrize(
    "spec, match",
    [
        ((0.0, 1.0, 1e-300), "at most 1e\\+09 points per axis"),
        ((-1e308, 1e308, 1.0), "points per axis"),
        (("0", 1.0, 0.1), "a \\(min\\) must be a finite number"),
        ((0.0, None, 0.1), "a \\(max\\)"),
        ((0.0, 1.0, "0.1"), "a step"),
        ((0.0, 1.0, np.nan), "a step"),
        ("0,1,0.1", "expected \\(min, max, step\\)"),
    ],
)
def test_bad_ranges_are_value_errors_naming_the_axis(spec, match):
    with pytest.raises(ValueError, match=match):
        pk.Grid.from_ranges(a=spec)


def test_grid_counts_shape_and_axes_agree():
    g = pk.Grid(names=("a", "b"), starts=(0, np.float32(1.0)), steps=(0.5, 1), counts=(3.0, np.int64(2)))
    assert g.shape == (3, 2) and g.size == 6
    assert [len(a) for a in g.axes] == list(g.shape)
    assert g.points().shape == (3, 2, 2)
    assert all(type(c) is int for c in g.counts) and all(type(s) is float for s in g.starts + g.steps)
    assert hash(g) == hash(pk.Grid(("a", "b"), (0.0, 1.0), (0.5, 1.0), (3, 2)))
    with pytest.raises(ValueError, match="no axis 'c'"):
        g.axis("c")


# ------------------------------------------------------------------------------------ loaders
def test_load_params_errors_name_the_file(tmp_path):
    bad = tmp_path / "broken.json"
    bad.write_text('{"mechanism": {"l1_m": 0.18,}}')
    with pytest.raises(ValueError, match=f"{bad}.*invalid JSON at line 1"):
        pk.load_params(bad)
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    with pytest.raises(ValueError, match=f"{listed}.*JSON object"):
        pk.load_params(str(listed))
    with pytest.raises(FileNotFoundError, match="no_such_paper.json.*available names: p1"):
        pk.load_params("no_such_paper")
    for bad_name in (None, 1, ["p1"], ""):
        with pytest.raises(ValueError, match="name_or_path"):
            pk.load_params(bad_name)


BAD_VALUES = [None, [0.25], 0.25j, "abc", "0.25", True, {"value": 0.25}, float("nan")]


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("key", ["l_B11C1_m", "l_C2D_m", "x_A_min_m"])
def test_p1_from_dict_names_the_bad_key(key, value):
    d = dict(pk.load_params("p1")["mechanism"]) | {key: value}
    with pytest.raises(ValueError, match=f"P1 parameter {key} must be a finite"):
        m.Gripper4PRRParams.from_dict(d)


@pytest.mark.parametrize("value", BAD_VALUES)
@pytest.mark.parametrize("key", ["l1_m", "l3_m", "base_side_m"])
def test_p2_from_dict_names_the_bad_key(key, value):
    d = dict(pk.load_params("p2")["mechanism"]) | {key: value}
    with pytest.raises(ValueError, match=f"P2 parameter {key} must be a finite positive number"):
        t.ThreeRRRParams.from_dict(d)


def test_from_dict_missing_unknown_keys_and_non_mappings():
    d1 = dict(pk.load_params("p1")["mechanism"])
    d2 = dict(pk.load_params("p2")["mechanism"])
    with pytest.raises(ValueError, match="missing l_C2D_m.*accepted keys"):
        m.Gripper4PRRParams.from_dict({k: v for k, v in d1.items() if k != "l_C2D_m"})
    with pytest.raises(ValueError, match="unknown 'l_C2D'"):
        m.Gripper4PRRParams.from_dict(d1 | {"l_C2D": 0.2})
    with pytest.raises(ValueError, match="missing base_side_m"):
        t.ThreeRRRParams.from_dict({k: v for k, v in d2.items() if k != "base_side_m"})
    with pytest.raises(ValueError, match="l3_is"):
        t.ThreeRRRParams.from_dict(d2 | {"l3_is": "diameter"})
    for bad in (None, [1, 2], "p1.json", {"paper": "P1"}):  # a file without a 'mechanism' object is refused
        with pytest.raises(ValueError, match="P1 parameters"):
            m.Gripper4PRRParams.from_dict(bad)
    with pytest.raises(ValueError, match="P2 parameters"):
        t.ThreeRRRParams.from_dict([0.18, 0.18, 0.08, 0.4])
    # a file written by json.dump with a NaN is refused by name too
    assert json.loads(json.dumps({"l1_m": float("nan")}))["l1_m"] != 0.0


# ---------------------------------------------------------------------------- forward position
def test_forward_position_is_compiled_once_per_mechanism(p2_params):
    from pkmlib._position import _compiled_solver

    q = np.asarray(t.mechanism.inverse(X2, p2_params))
    x0 = X2 + np.array([0.02, -0.02, np.deg2rad(5.0)])
    assert_close(pk.forward_position(t.mechanism, q, p2_params, x0), X2, rtol=0, atol=1e-12)
    solver = _compiled_solver(t.mechanism)
    compiled = solver._cache_size()
    # other q, other parameters, other tolerance and iteration limit: no new compilation
    other = t.ThreeRRRParams.create(l1=0.2, l2=0.17, l3=0.07, base_side=0.4)
    x = np.array([0.21, 0.12, 0.05])
    q2 = np.asarray(t.mechanism.inverse(x, other))
    assert_close(pk.forward_position(t.mechanism, q2, other, x + 0.003, tol=1e-13, max_iter=40), x, rtol=0, atol=1e-11)
    assert solver._cache_size() == compiled
    assert _compiled_solver(t.mechanism) is solver
    with pytest.raises(RuntimeError, match="did not converge"):
        pk.forward_position(t.mechanism, q + np.array([3.0, 0.0, 0.0]), p2_params, X2, max_iter=30)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(tol=0.0), "tol"),
        (dict(tol=-1.0), "tol"),
        (dict(tol="1e-12"), "tol"),
        (dict(max_iter=2.5), "max_iter"),
        (dict(max_iter=0), "max_iter"),
        (dict(x0=np.zeros(2)), "x0 must be 3 real numbers"),
        (dict(q=np.zeros(4)), "q must be 3 real numbers"),
    ],
)
def test_forward_position_arguments_are_checked(p2_params, kwargs, match):
    args = dict(q=np.asarray(t.mechanism.inverse(X2, p2_params)), x0=X2)
    args |= {k: kwargs.pop(k) for k in ("q", "x0") if k in kwargs}
    with pytest.raises(ValueError, match=match):
        pk.forward_position(t.mechanism, args["q"], p2_params, args["x0"], **kwargs)


def test_every_from_dict_takes_the_whole_params_file():
    """One API (issue 12 item 6): each paper's parameters build from pkmlib.load_params(<paper>)."""
    from pkmlib.mechanisms import decoupled_6dof, five_bar, gripper_4prr, three_rrr, two_t_one_r

    p1 = gripper_4prr.Gripper4PRRParams.from_dict(pk.load_params("p1"))
    assert p1 == gripper_4prr.Gripper4PRRParams.from_dict(pk.load_params("p1")["mechanism"])
    p2 = three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2"))
    assert p2 == three_rrr.ThreeRRRParams.from_dict(pk.load_params("p2")["mechanism"])
    assert five_bar.FiveBarParams.from_dict(pk.load_params("p4")).l_A1B1 == 175.0
    assert decoupled_6dof.Decoupled6DofParams.from_dict(pk.load_params("p5")) is not None
    assert two_t_one_r.ParamsA.from_dict(pk.load_params("p3")) is not None
