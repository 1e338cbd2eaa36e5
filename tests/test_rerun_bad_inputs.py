"""Issue 11's bad inputs, each through the re-run entry point: a non-zero exit and a message naming
the parameter, before any work is done.

Most of these need the notebooks' check cells (``paper_run = pk.tools.check_parameters(globals(),
{...})`` in the cell after ``parameters``) and, for the size guard, ``sweep(...,
size_parameter="step_m")`` in P2. Until a notebook has its check cell, its cases here fail at once
(``assert_has_check_cell``), without running the notebook. The cases that depend on the notebooks
are listed in ``NEEDS_NOTEBOOK_CHECK_CELLS`` (test ids, for the integrator:
``pytest tests/test_rerun_bad_inputs.py``); the name check needs nothing from the notebooks.

The value checks run twice in a real re-run: in this process (the entry point evaluates the
notebook's own ``check_parameters`` call, exit status 2, no kernel) and in the notebook itself
(``--no-precheck`` shows the notebook alone stops them, exit status 1: run in a kernel for one
notebook; for each, a test that its first code cell holds the check).
"""

import os

import nbformat
import pytest

from pkmlib.tools import rerun

# (notebook, arguments, parameter the message must name) - the failures listed in issue 11
BAD_INPUTS = {
    "p5-misspelled-name": ("p5_decoupled_6dof_dynamics", ["-p", "alpha_dge", "45"], "alpha_dge"),
    # issue 11's "[-1, 1, -1] (a sign missing) ... 15777 workspace points instead of 13125" is P1 (4 chains)
    "p1-branch-sign-missing": ("p1_gripper_4prr", ["-y", "branch: [-1, 1, -1]"], "branch"),
    "p1-branch-sign-half": ("p1_gripper_4prr", ["-y", "branch: [-1, 1, -1, 0.5]"], "branch"),
    "p2-branch-sign-missing": ("p2_three_rrr_singularity_proximity", ["-y", "branch: [1, -1]"], "branch"),
    "p2-branch-sign-2": ("p2_three_rrr_singularity_proximity", ["-y", "branch: [2, 1, 1]"], "branch"),
    "p2-branch-sign-half": ("p2_three_rrr_singularity_proximity", ["-y", "branch: [1, 0.5, 1]"], "branch"),
    "p1-branch-sign-2": ("p1_gripper_4prr", ["-p", "branch", "[-1, 1, -2, 1]"], "branch"),
    "p1-F_pr_N-negative": ("p1_gripper_4prr", ["-p", "F_pr_N", "-100"], "F_pr_N"),
    "p1-s_m-negative": ("p1_gripper_4prr", ["-p", "s_m", "-0.14"], "s_m"),
    "p1-v_D_m_s-negative": ("p1_gripper_4prr", ["-p", "v_D_m_s", "-1"], "v_D_m_s"),
    "p1-phi_deg-text": ("p1_gripper_4prr", ["-p", "phi_deg", "abc"], "phi_deg"),
    "p1-phi_deg-nan": ("p1_gripper_4prr", ["-p", "phi_deg", "nan"], "phi_deg"),
    "p1-zero-loads": ("p1_gripper_4prr", ["-p", "F_D_N", "0", "-p", "T_N_m", "0", "-p", "F_s_N", "0"], "F_D_N"),
    "p1-range-as-string": ("p1_gripper_4prr", ["-p", "x_D_range_m", "0.2, 1.2"], "x_D_range_m"),
    "p1-step-zero": ("p1_gripper_4prr", ["-p", "dx_D_m", "0"], "dx_D_m"),
    "p2-zero-force": ("p2_three_rrr_singularity_proximity", ["-p", "force_N", "0"], "force_N"),
    "p2-range-as-string": ("p2_three_rrr_singularity_proximity", ["-y", "x_P_range_m: '-0.15, 0.55'"], "x_P_range_m"),
    "p2-l3_is-unknown": ("p2_three_rrr_singularity_proximity", ["-p", "l3_is", "radius"], "l3_is"),
    "p3-n_t-1": ("p3_two_t_one_r", ["-p", "n_t", "1"], "n_t"),
    "p3-t_end_s-inf": ("p3_two_t_one_r", ["-p", "t_end_s", "inf"], "t_end_s"),
    "p3-inputs-short": ("p3_two_t_one_r", ["-p", "inputs_B_mm", "[-100, 150]"], "inputs_B_mm"),
    "p4-zero-torque": ("p4_five_bar_stiffness", ["-p", "T_max_N_mm", "0"], "T_max_N_mm"),
    "p4-step-boolean": ("p4_five_bar_stiffness", ["-p", "step_mm", "True"], "step_mm"),
    "p4-mode-sign-0": ("p4_five_bar_stiffness", ["-p", "working_mode", "[1, 0]"], "working_mode"),
    "p5-sim_dt_s-zero": ("p5_decoupled_6dof_dynamics", ["-p", "sim_dt_s", "0"], "sim_dt_s"),
    "p5-sim_duration_s-negative": ("p5_decoupled_6dof_dynamics", ["-p", "sim_duration_s", "-1"], "sim_duration_s"),
    "p5-forces-five": ("p5_decoupled_6dof_dynamics", ["-p", "forces_N", "[1, 1, 2, 2, 3]"], "forces_N"),
    "tutorial-zero-loads": ("tutorial_bring_your_own_mechanism", ["-p", "F_N", "0", "-p", "T_N_m", "0"], "F_N"),
    "tutorial-q_max-below-q_min": ("tutorial_bring_your_own_mechanism", ["-p", "q_max_m", "0.05"], "q_max_m"),
    "tutorial-step-negative": ("tutorial_bring_your_own_mechanism", ["-p", "step_m", "-0.005"], "step_m"),
}
#: Every case but the misspelled name needs a notebook check cell (they fail until the notebooks have them).
NEEDS_NOTEBOOK_CHECK_CELLS = [
    f"test_a_bad_value_is_stopped_before_any_work[{k}]" for k in BAD_INPUTS if k != "p5-misspelled-name"
] + [
    "test_the_size_guard_stops_a_step_typo_naming_it",
    "test_the_notebook_itself_stops_a_bad_value[tutorial_bring_your_own_mechanism]",
    *[
        f"test_each_notebook_checks_its_parameters_in_its_first_cell_of_code[{nb}]"
        for nb in (
            "p1_gripper_4prr",
            "p2_three_rrr_singularity_proximity",
            "p3_two_t_one_r",
            "p4_five_bar_stiffness",
            "p5_decoupled_6dof_dynamics",
            "tutorial_bring_your_own_mechanism",
        )
    ],
    "test_p1_edge_angles_run_to_the_end[0]",
]


def assert_has_check_cell(stem):
    path = rerun.resolve_notebook(stem)
    nb = nbformat.read(path, as_version=4)
    assert rerun.find_check_call(nb) is not None, (
        f"{stem} has no `check_parameters(globals(), {{...}})` call after its parameters cell yet (issue 11)"
    )


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_a_bad_value_is_stopped_before_any_work(case, capsys, tmp_path):
    stem, args, name = BAD_INPUTS[case]
    if case != "p5-misspelled-name":
        assert_has_check_cell(stem)
    status = rerun.main([stem, *args, "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert f"parameter {name!r}" in err or (f"{name} = " in err and "ValueError: parameters " in err), err
    # stopped by the entry point's pre-check (check_parameters and the checks right after it in the
    # notebook's check cell, such as q_min_m < q_max_m): no kernel started, nothing written
    assert status == 2, err
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob("out.*"))


@pytest.mark.slow
def test_the_size_guard_stops_a_step_typo_naming_it(capsys, tmp_path, monkeypatch):
    # ~7e8 points; the budget is fixed so the test does not depend on this machine's memory
    assert_has_check_cell("p2_three_rrr_singularity_proximity")
    monkeypatch.setenv("PKMLIB_MEMORY_BUDGET", "4e9")
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    status = rerun.main(["p2_three_rrr_singularity_proximity", "-p", "step_m", "2.5e-5", "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 1, err
    assert "MemoryBudgetError: a sweep of 7." in err and "set by step_m" in err, err


KERNEL_CASES = {  # one bad value per notebook, stopped by the notebook's own check cell
    "p1_gripper_4prr": (["-p", "phi_deg", "abc"], "phi_deg"),
    "p2_three_rrr_singularity_proximity": (["-y", "branch: [1, 1, 2]"], "branch"),
    "p3_two_t_one_r": (["-p", "n_t", "1"], "n_t"),
    "p4_five_bar_stiffness": (["-p", "T_max_N_mm", "0"], "T_max_N_mm"),
    "p5_decoupled_6dof_dynamics": (["-p", "sim_dt_s", "0"], "sim_dt_s"),
    "tutorial_bring_your_own_mechanism": (["-p", "step_m", "-0.005"], "step_m"),
}


@pytest.mark.parametrize("stem", KERNEL_CASES)
def test_each_notebook_checks_its_parameters_in_its_first_cell_of_code(stem):
    # what the kernel runs first after the parameters: the same check the entry point evaluates
    # (one notebook is run in a kernel below; running all six cost a kernel start each)
    nb = nbformat.read(rerun.resolve_notebook(stem), as_version=4)
    start = rerun.parameters_cell_index(nb) + 1
    first_code = next(i for i in range(start, len(nb.cells)) if nb.cells[i].cell_type == "code")
    assert rerun._check_call(nbformat.v4.new_notebook(cells=[nb.cells[first_code]]), 0) is not None
    args, name = KERNEL_CASES[stem]
    a = rerun.parse_arguments([stem, *args])
    with pytest.raises(rerun.RerunError, match=f"ValueError: parameter {name!r}"):
        rerun.precheck(nb, {**rerun.notebook_parameters(nb), **rerun.given_parameters(a)})


@pytest.mark.slow
@pytest.mark.parametrize("stem", ["tutorial_bring_your_own_mechanism"])
def test_the_notebook_itself_stops_a_bad_value(stem, capsys, tmp_path, monkeypatch):
    assert_has_check_cell(stem)
    args, name = KERNEL_CASES[stem]
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    status = rerun.main([stem, "--no-precheck", *args, "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 1, err
    first = err.splitlines()[0]
    assert f": ValueError: parameter {name!r}" in first, err
    assert "Traceback" not in err and len(err.splitlines()) == 2  # the error, not a traceback wall


@pytest.mark.slow
@pytest.mark.parametrize("phi_deg", ["0"])
def test_p1_edge_angles_run_to_the_end(phi_deg, capsys, tmp_path, monkeypatch):
    # issue 11: at 0 deg both singular lines lie at y = 0 (they touch without a sign change) and the
    # notebook crashed; at 30 deg Fig 1's hard-coded pose left the workspace: that re-run is
    # tests/test_notebook_parameters.py's test_p1_with_phi_30_moves_the_singular_lines
    assert_has_check_cell("p1_gripper_4prr")
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    status = rerun.main(["p1_gripper_4prr", "-p", "phi_deg", phi_deg, "-p", "dx_D_m", "0.01", "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 0, err
    assert f"| `phi_deg` | 20 | {phi_deg} |" in (tmp_path / "changes.md").read_text()
