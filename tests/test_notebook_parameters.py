"""Every paper notebook re-runs with new parameters through its `parameters` cell (papermill,
the same cell Quarto's -P uses), and its results move as the geometry says."""

import json
from pathlib import Path

import numpy as np
import papermill
import pytest

ROOT = Path(__file__).resolve().parents[1]


def run(notebook, tmp_path, **parameters):
    """Execute a copy of ``notebook`` with ``parameters``; return its results JSON."""
    results = tmp_path / "results.json"
    papermill.execute_notebook(
        str(ROOT / "notebooks" / notebook), str(tmp_path / "out.ipynb"),
        parameters={**parameters, "results_path": str(results), "figures_dir": str(tmp_path / "figures")},
        cwd=str(ROOT / "notebooks"), progress_bar=False, kernel_name="python3",
    )
    return json.loads(results.read_text())


def committed(paper):
    return json.loads((ROOT / "data" / "results" / f"{paper}.json").read_text())


@pytest.mark.slow
def test_p1_with_phi_25_moves_the_singular_lines(tmp_path):
    r = run("p1_gripper_4prr.ipynb", tmp_path, phi_deg=25.0, dx_D_m=0.01)
    phi = np.deg2rad(25.0)
    np.testing.assert_allclose(r["singular_lines_y_m"], sorted([0.14 * np.sin(phi), -0.22 * np.sin(phi)]),
                               rtol=0, atol=1e-9)
    assert r["parameters"]["phi_deg"] == 25.0
    assert len(list((tmp_path / "figures").glob("p1_fig*.png"))) == 7
    assert committed("p1")["parameters"]["phi_deg"] == 20.0  # the paper's run is untouched


@pytest.mark.slow
def test_p2_doubling_speed_and_force_doubles_both_maps(tmp_path):
    r = run("p2_three_rrr_singularity_proximity.ipynb", tmp_path, V_m_s=0.2, force_N=20.0)
    base = committed("p2")
    assert r["workspace_points"] == base["workspace_points"]
    for key in ("max_joint_velocity_rad_s", "max_actuator_torque_N_m"):  # both criteria are linear in the size
        for stat in ("min", "median", "max"):
            np.testing.assert_allclose(r[key][stat], 2 * base[key][stat], rtol=1e-9)
    assert r["parameters"]["V_m_s"] == 0.2


@pytest.mark.slow
def test_p3_another_input_for_b_moves_its_tables(tmp_path):
    from pkmlib.mechanisms import two_t_one_r as m

    import pkmlib as pk

    q = [-100.0, 150.0, 20.0]
    r = run("p3_two_t_one_r.ipynb", tmp_path, inputs_B_mm=q, step_mm=12.5, voxel_mm=25.0, t_end_s=1.0, n_t=101)
    pb = m.ParamsB.from_dict(pk.load_params("p3")["mechanism_B"])
    for row in r["table1_B"]:
        expected = np.asarray(m.forward_b(np.array(q), pb, np.array([row["n"], row["m"]])))
        got = [row["x_mm"], row["z_mm"], row["alpha_rad"]]
        for g, e in zip(got, expected):
            if g is None:
                assert np.isnan(e)
            else:
                np.testing.assert_allclose(g, e, rtol=1e-12)
    assert r["table1_B"][0]["x_mm"] == pytest.approx((q[0] + q[1]) / 2)
    assert r["workspace_volume_ratio_A_over_B"] > 1.0  # the paper's claim at a coarser resolution too


@pytest.mark.slow
def test_p5_doubling_the_forces_doubles_the_linear_acceleration_only(tmp_path):
    r = run("p5_decoupled_6dof_dynamics.ipynb", tmp_path, forces_N=[2.0, 2.0, 4.0, 4.0, 6.0, 6.0])
    base = committed("p5")
    np.testing.assert_allclose(r["linear_acceleration"], 2 * np.asarray(base["linear_acceleration"]), rtol=1e-12)
    # paired forces give no moment: the angular acceleration is gyroscopic, independent of the forces
    np.testing.assert_allclose(r["angular_acceleration"], base["angular_acceleration"], rtol=1e-12)


@pytest.mark.slow
def test_p4_doubling_the_torque_doubles_the_parallelogram_not_the_stiffness(tmp_path):
    r = run("p4_five_bar_stiffness.ipynb", tmp_path, T_max_N_mm=4000.0, step_mm=10.0)
    base = committed("p4")
    np.testing.assert_allclose(r["parallelogram_at_50_150"]["corners_N"],
                               2 * np.asarray(base["parallelogram_at_50_150"]["corners_N"]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(r["k_worst_at_50_150_N_mm"], base["k_worst_at_50_150_N_mm"], rtol=1e-12)
    assert r["workspace_points"] < base["workspace_points"]  # the coarser grid has fewer points
