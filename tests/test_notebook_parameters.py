"""Every notebook re-runs with new parameters through the re-run entry point (`python -m
pkmlib.rerun`, what `make rerun` calls: papermill on the `parameters` cell, the same cell Quarto's
-P uses), its results move as the geometry says, and changes.md says what moved.

One run per notebook, on grids as coarse as the claim allows (the bad inputs, which stop before
any work, are in test_rerun_bad_inputs.py)."""

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from pkmlib import rerun

ROOT = Path(__file__).resolve().parents[1]


def run(notebook, tmp_path, monkeypatch, *args):
    """Re-run ``notebook`` with ``args`` into ``tmp_path``; return (results or None, changes.md)."""
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))  # the re-run adds pkmlib's folder
    status = rerun.main([notebook, *args, "-o", str(tmp_path)])
    assert status == 0
    results = tmp_path / "results.json"
    return (json.loads(results.read_text()) if results.exists() else None), (tmp_path / "changes.md").read_text()


def committed(paper):
    return json.loads((ROOT / "data" / "results" / f"{paper}.json").read_text())


def row(changes, key):
    """The cells of the changes.md table row of result ``key``."""
    line = next(l for l in changes.splitlines() if l.startswith(f"| `{key}` |"))
    return [c.strip() for c in line.strip("|").split(" | ")]


def numbers(cell):
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e[-+]\d+)?", cell)]


@pytest.mark.slow
def test_p1_with_phi_25_moves_the_singular_lines(tmp_path, monkeypatch):
    r, changes = run("p1_gripper_4prr", tmp_path, monkeypatch, "-p", "phi_deg", "25", "-p", "dx_D_m", "0.01")
    phi = np.deg2rad(25.0)
    predicted = sorted([0.14 * np.sin(phi), -0.22 * np.sin(phi)])  # lower -l_C2D sin(phi), upper s sin(phi)
    np.testing.assert_allclose(r["singular_lines_y_m"], predicted, rtol=0, atol=1e-9)
    assert r["parameters"]["phi_deg"] == 25.0
    assert len(list((tmp_path / "figures").glob("p1_fig*.png"))) == 7
    assert committed("p1")["parameters"]["phi_deg"] == 20.0  # the paper's run is untouched
    # changes.md: the parameters, the lines at the predicted heights (from the paper run's at 20 deg)
    assert "| `phi_deg` | 20 | 25 |" in changes and "| `dx_D_m` | 0.005 | 0.01 |" in changes
    _, paper, ours, unit, _ = row(changes, "singular_lines_y_m")
    phi20 = np.deg2rad(20.0)
    np.testing.assert_allclose(numbers(paper), sorted([0.14 * np.sin(phi20), -0.22 * np.sin(phi20)]), rtol=1e-7)
    np.testing.assert_allclose(numbers(ours), predicted, rtol=1e-7)
    assert unit == "m"
    assert ("| ![paper's run: p1_fig5_det_A_sign.png](" in changes
            and "| ![this run: p1_fig5_det_A_sign.png](figures/p1_fig5_det_A_sign.png) |" in changes)


@pytest.mark.slow
def test_p2_doubling_speed_and_force_doubles_both_maps(tmp_path, monkeypatch):
    r, changes = run("p2_three_rrr_singularity_proximity", tmp_path, monkeypatch,
                     "-p", "V_m_s", "0.2", "-p", "force_N", "20.0")
    base = committed("p2")
    assert r["workspace_points"] == base["workspace_points"]
    for key in ("max_joint_velocity_rad_s", "max_actuator_torque_N_m"):  # both criteria are linear in the size
        for stat in ("min", "median", "max"):
            np.testing.assert_allclose(r[key][stat], 2 * base[key][stat], rtol=1e-9)
            assert row(changes, f"{key}.{stat}")[-1] == "+1"  # relative change: doubled
    assert "| `workspace_points` |" not in changes and "| `type2_crossings` |" not in changes  # same geometry
    assert row(changes, "delta_q_min")[-1] == "+1"  # the excess velocity near singularities scales too
    assert r["parameters"]["V_m_s"] == 0.2


@pytest.mark.slow
def test_p3_another_input_for_b_moves_its_tables(tmp_path, monkeypatch):
    from pkmlib.mechanisms import two_t_one_r as m

    import pkmlib as pk

    q = [-100.0, 150.0, 20.0]
    r, changes = run("p3_two_t_one_r", tmp_path, monkeypatch, "-y",
                     f"inputs_B_mm: {q}\nstep_mm: 12.5\nvoxel_mm: 25.0\nt_end_s: 1.0\nn_t: 101")
    pb = m.ParamsB.from_dict(pk.load_params("p3")["mechanism_B"])
    for row_b in r["table1_B"]:
        expected = np.asarray(m.forward_b(np.array(q), pb, np.array([row_b["n"], row_b["m"]])))
        got = [row_b["x_mm"], row_b["z_mm"], row_b["alpha_rad"]]
        for g, e in zip(got, expected):
            if g is None:
                assert np.isnan(e)
            else:
                np.testing.assert_allclose(g, e, rtol=1e-12)
    assert r["table1_B"][0]["x_mm"] == pytest.approx((q[0] + q[1]) / 2)
    assert r["workspace_volume_ratio_A_over_B"] > 1.0  # the paper's claim at a coarser resolution too
    assert "| `inputs_B_mm` | [-106.09, 181.67, -70.29] | [-100, 150, 20] |" in changes
    assert row(changes, "table1_B[0].x_mm")[1:3] == ["37.79", "25"]  # (x1 + x2) / 2 before and after


@pytest.mark.slow
def test_p5_doubling_the_forces_doubles_the_linear_acceleration_only(tmp_path, monkeypatch):
    r, changes = run("p5_decoupled_6dof_dynamics", tmp_path, monkeypatch, "-p", "forces_N", "[2, 2, 4, 4, 6, 6]")
    base = committed("p5")
    np.testing.assert_allclose(r["linear_acceleration"], 2 * np.asarray(base["linear_acceleration"]), rtol=1e-12)
    # paired forces give no moment: the angular acceleration is gyroscopic, independent of the forces
    np.testing.assert_allclose(r["angular_acceleration"], base["angular_acceleration"], rtol=1e-12)
    assert "`linear_acceleration`" in changes and "`angular_acceleration`" not in changes


@pytest.mark.slow
def test_p4_doubling_the_torque_doubles_the_parallelogram_not_the_stiffness(tmp_path, monkeypatch):
    r, changes = run("p4_five_bar_stiffness", tmp_path, monkeypatch,
                     "-p", "T_max_N_mm", "4000.0", "-p", "step_mm", "10.0")
    base = committed("p4")
    np.testing.assert_allclose(r["parallelogram_at_50_150"]["corners_N"],
                               2 * np.asarray(base["parallelogram_at_50_150"]["corners_N"]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r["k_worst_at_50_150_N_mm"], base["k_worst_at_50_150_N_mm"], rtol=1e-12)
    assert r["workspace_points"] < base["workspace_points"]  # the coarser grid has fewer points
    assert "`k_worst_at_50_150_N_mm`" not in changes  # stiffness at a pose does not depend on the grid
    assert row(changes, "parallelogram_at_50_150.shorter_diagonal_length_N")[-1] == "+1"


@pytest.mark.slow
def test_the_tutorial_without_kernelspec_re_runs(tmp_path, monkeypatch):
    # the tutorial notebook has no kernelspec: the re-run names the kernel itself
    r, changes = run("tutorial_bring_your_own_mechanism", tmp_path, monkeypatch, "-p", "step_m", "0.02")
    assert r is None  # the tutorial writes figures only
    assert "| `step_m` | 0.005 | 0.02 |" in changes
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
        "tutorial_assembly_modes.png", "tutorial_delta_maps.png", "tutorial_det_A_sign.png",
        "tutorial_max_leg_force.png", "tutorial_max_leg_speed.png"]
    assert "### tutorial_det_A_sign" in changes  # a coarser grid: every map looks different
