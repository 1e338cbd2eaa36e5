"""Parameter checks (ValueError naming the parameter) and the results helpers."""

import json
import math

import numpy as np
import pytest

import pkmlib as pk
from pkmlib.mechanisms import gripper_4prr as m
from conftest import assert_close

GOOD = dict(l_B11C1=0.25, l_B12C1=0.18, l_B21C2=0.18, l_B22C2=0.25, l_C2D=0.22, x_A_min=0.0, x_A_max=1.5)


def test_paper_parameters_load(p1_params):
    assert p1_params == m.Gripper4PRRParams.create(**GOOD)


@pytest.mark.parametrize(
    "name, value", [("l_B11C1", 0.0), ("l_B12C1", -0.18), ("l_C2D", float("nan")), ("l_B22C2", float("inf"))]
)
def test_non_positive_lengths_are_refused_by_name(name, value):
    with pytest.raises(ValueError, match=name):
        m.Gripper4PRRParams.create(**(GOOD | {name: value}))


def test_carriage_range_min_above_max_is_refused():
    with pytest.raises(ValueError, match="carriage range"):
        m.Gripper4PRRParams.create(**(GOOD | {"x_A_min": 1.0, "x_A_max": 0.5}))


def test_missing_parameters_are_named():
    d = {f"{k}_m": v for k, v in GOOD.items() if k != "l_C2D"}
    with pytest.raises(ValueError, match="l_C2D_m"):
        m.Gripper4PRRParams.from_dict(d)


def test_params_are_a_pytree(p1_params):
    import jax

    leaves = jax.tree_util.tree_leaves(p1_params)
    assert len(leaves) == 7
    # traced parameters: the same criterion under jit with params as an argument
    f = jax.jit(lambda p: m.max_carriage_velocity(m.pose(0.7, 0.0, 0.35, 0.14), p, (1.0, 1.0, 1.0)))
    assert_close(f(p1_params), m.max_carriage_velocity(m.pose(0.7, 0.0, 0.35, 0.14), p1_params, (1.0, 1.0, 1.0)))


def test_compare_statuses():
    assert pk.tools.compare("a", 1.0, 1.004, rel_tol=0.005)["status"] == "reproduced"
    assert pk.tools.compare("a", 1.0, 1.1, rel_tol=0.005)["status"] == "differs"
    row = pk.tools.compare("a", -0.0725, -0.0752, abs_tol=0.0025, erratum="digits transposed")
    assert row["status"] == "erratum" and row["note"] == "digits transposed"
    assert pk.tools.compare("a", 3.0, 3.4, abs_tol=0.5)["status"] == "reproduced"
    table = pk.tools.format_table([row])
    assert "erratum" in table and "-0.0725" in table


def test_summary_ignores_nan_and_results_json_has_no_nan(tmp_path):
    v = np.array([[1.0, np.nan], [3.0, 2.0]])
    assert pk.tools.summary(v) == {"min": 1.0, "median": 2.0, "max": 3.0}
    assert math.isnan(pk.tools.summary(np.array([np.nan]))["min"])
    path = pk.tools.write_results(
        tmp_path / "sub" / "r.json", {"x": np.float64(np.nan), "a": np.arange(3), "n": np.int64(4)}
    )
    assert json.loads(path.read_text()) == {"x": None, "a": [0, 1, 2], "n": 4}
