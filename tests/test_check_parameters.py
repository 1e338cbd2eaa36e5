"""pkmlib.tools.check_parameters: every kind of bad notebook input of issue 11 fails with a ValueError
naming the parameter, the value and what is accepted; good input passes and says whether it is
the paper's run."""

import math

import numpy as np
import pytest

import pkmlib as pk

SPEC = {
    "phi_deg": pk.tools.number(20.0, min=0.0, max=90.0, max_open=True, unit="deg"),
    "s_m": pk.tools.number(0.14, min=0.0, min_open=True, unit="m"),
    "F_pr_N": pk.tools.number(100.0, min=0.0, min_open=True, unit="N"),
    "n_t": pk.tools.number(501, min=2, integer=True),
    "sim_dt_s": pk.tools.number(0.0005, min=0.0, min_open=True, unit="s"),
    "branch": pk.tools.signs([1, 1, 1]),
    "x_range_m": pk.tools.numbers([0.2, 1.2], shape=(2,), increasing=True, unit="m"),
    "zoom_m": pk.tools.numbers([0.3, 0.45, -0.11, 0.02], shape=(4,), increasing=((0, 1), (2, 3)), unit="m"),
    "probes_mm": pk.tools.numbers([[0.0, 150.0], [50.0, 200.0]], shape=(None, 2), unit="mm"),
    "l3_is": pk.tools.choice("circumradius", "circumradius", "side"),
    "params_file": pk.tools.text("p2"),
    "verbose": pk.tools.flag(False),
    "F_D_N": pk.tools.number(1.0, min=0.0, unit="N"),
    "T_N_m": pk.tools.number(1.0, min=0.0, unit="N m"),
    "results_path": pk.tools.text("../data/results/p2.json", output=True),
}
PAPER = {name: s.paper for name, s in SPEC.items()}
RULES = [pk.tools.not_all_zero("F_D_N", "T_N_m"), pk.tools.less("sim_dt_s", "phi_deg")]


def check(**changes):
    return pk.tools.check_parameters({**PAPER, **changes}, SPEC, rules=RULES)


def test_the_papers_values_pass_and_count_as_the_papers_run():
    assert check() is True
    assert check(results_path="../runs/elsewhere.json") is True  # where results go is not a parameter of the run
    assert check(phi_deg=25.0) is False
    assert check(phi_deg=20) is True  # 20 == 20.0: the paper's value, written as an integer
    assert check(phi_deg=np.float64(25.0), branch=np.array([1, -1, 1])) is False  # NumPy values are accepted


@pytest.mark.parametrize(
    "name, value, why",
    [
        # types
        ("phi_deg", "abc", "a string"),
        ("phi_deg", "25", "leave out the quotes"),
        ("phi_deg", True, "a boolean"),
        ("phi_deg", None, "None"),
        ("phi_deg", [20.0], "a list, not a single number"),
        # NaN and inf
        ("phi_deg", float("nan"), "not finite"),
        ("s_m", math.inf, "not finite"),
        ("x_range_m", [0.2, float("nan")], "entry 1: not finite"),
        # ranges and signs of single numbers
        ("phi_deg", 90.0, "too large"),
        ("phi_deg", -5.0, "too small"),
        ("s_m", -0.14, "too small"),
        ("s_m", 0.0, "too small"),
        ("F_pr_N", -100.0, "too small"),
        ("sim_dt_s", 0.0, "too small"),
        ("n_t", 1, "too small"),
        ("n_t", 100.5, "not an integer"),
        ("n_t", 501.0, "write it as an integer, 501"),
        # branches
        ("branch", [-1, 1], "2 given"),
        ("branch", [1, 1, 1, 1], "4 given"),
        ("branch", [2, 1, 1], "entry 0 is 2"),
        ("branch", [1, 0.5, 1], "entry 1 is 0.5"),
        ("branch", [1, 1, 0], "entry 2 is 0"),
        ("branch", [True, 1, 1], "entry 0 is True"),
        ("branch", "1, 1, 1", "a string, not a list"),
        ("branch", 1, "a single number, not a list"),
        # ranges and lists
        ("x_range_m", "0.2, 1.2", "a string, not a list"),
        ("x_range_m", "[0.2, 1.2]", "a string, not a list"),
        ("x_range_m", [1.2, 0.2], "not increasing"),
        ("x_range_m", [0.2, 0.2], "not increasing"),
        ("x_range_m", [0.2, 0.7, 1.2], "shape (3,)"),
        ("x_range_m", 0.2, "a single number, not a list"),
        ("x_range_m", [0.2, "1.2"], "entry 1: a string"),
        ("x_range_m", [False, 1.2], "entry 0: a boolean"),
        ("zoom_m", [0.45, 0.3, -0.11, 0.02], "entry 0 is not below entry 1"),
        ("zoom_m", [0.3, 0.45, 0.02, -0.11], "entry 2 is not below entry 3"),
        ("probes_mm", [[0.0, 150.0], [50.0]], "rows of different lengths"),
        ("probes_mm", [0.0, 150.0], "shape (2,)"),
        ("probes_mm", [[0.0, 150.0, 1.0]], "shape (1, 3)"),
        # choices, text, flags
        ("l3_is", "circumradus", ""),
        ("params_file", "", "empty"),
        ("params_file", 3, ""),
        ("verbose", 1, ""),
    ],
)
def test_each_bad_value_names_the_parameter_the_value_and_what_is_accepted(name, value, why):
    with pytest.raises(ValueError) as e:
        check(**{name: value})
    message = str(e.value)
    assert message.startswith(f"parameter {name!r} = {value!r}: expected "), message
    assert SPEC[name].accepted() in message
    assert why in message


def test_what_is_accepted_is_said_in_words():
    assert SPEC["phi_deg"].accepted() == "a finite number in [0, 90) deg"
    assert SPEC["s_m"].accepted() == "a finite number > 0 m"
    assert SPEC["n_t"].accepted() == "an integer >= 2"
    assert SPEC["branch"].accepted() == "a list of 3 signs, each +1 or -1"
    assert SPEC["x_range_m"].accepted() == "a list (2) of finite numbers, in m, increasing"
    assert (
        SPEC["zoom_m"].accepted() == "a list (4) of finite numbers, in m, with entry 0 < entry 1 and entry 2 < entry 3"
    )
    assert SPEC["probes_mm"].accepted() == "a list (nx2) of finite numbers, in mm"
    assert SPEC["l3_is"].accepted() == "one of 'circumradius', 'side'"


def test_zero_loads_fail_naming_every_load():
    assert check(F_D_N=0.0) is False  # one zero load is a valid study
    with pytest.raises(
        ValueError,
        match=r"parameters F_D_N = 0.0, T_N_m = 0.0: expected at least one of "
        r"F_D_N, T_N_m nonzero",
    ):
        check(F_D_N=0.0, T_N_m=0.0)


def test_an_order_between_two_parameters():
    with pytest.raises(ValueError, match=r"parameters sim_dt_s = 30.0, phi_deg = 20.0: expected sim_dt_s < phi_deg"):
        check(sim_dt_s=30.0)


def test_the_single_checks_come_before_the_rules():
    with pytest.raises(ValueError, match=r"parameter 'F_D_N' = 'abc'"):
        check(F_D_N="abc", T_N_m=0.0)


def test_a_missing_parameter_is_named():
    values = {k: v for k, v in PAPER.items() if k != "s_m"}
    with pytest.raises(ValueError, match=r"parameters \['s_m'\] are not defined"):
        pk.tools.check_parameters(values, SPEC)


def test_a_spec_that_rejects_the_papers_own_value_is_a_bug_in_the_notebook():
    with pytest.raises(ValueError, match=r"the check of 'phi_deg' rejects the paper's own value: fix the spec"):
        pk.tools.check_parameters({"phi_deg": 20.0}, {"phi_deg": pk.tools.number(20.0, max=10.0)})
    with pytest.raises(TypeError, match=r"spec of 'phi_deg' must be made by pkmlib.tools.number"):
        pk.tools.check_parameters({"phi_deg": 20.0}, {"phi_deg": 20.0})
    with pytest.raises(ValueError, match=r"rule on \['x'\]: not in the spec"):
        pk.tools.check_parameters(
            {"phi_deg": 20.0}, {"phi_deg": pk.tools.number(20.0)}, rules=[pk.tools.not_all_zero("x")]
        )
