"""The P1 notebook re-runs with new parameters through its `parameters` cell (papermill, the
same cell Quarto's -P uses), and the results move as the geometry says."""

import json

import numpy as np
import papermill
import pytest

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_p1_notebook_with_phi_25_moves_the_singular_lines(tmp_path):
    results = tmp_path / "p1.json"
    papermill.execute_notebook(
        str(ROOT / "notebooks" / "p1_gripper_4prr.ipynb"), str(tmp_path / "out.ipynb"),
        parameters={"phi_deg": 25.0, "dx_D_m": 0.01, "results_path": str(results),
                    "figures_dir": str(tmp_path / "figures")},
        cwd=str(ROOT / "notebooks"), progress_bar=False, kernel_name="python3",
    )
    r = json.loads(results.read_text())
    phi = np.deg2rad(25.0)
    expected = sorted([0.14 * np.sin(phi), -0.22 * np.sin(phi)])
    np.testing.assert_allclose(r["singular_lines_y_m"], expected, rtol=0, atol=1e-9)
    assert r["parameters"]["phi_deg"] == 25.0
    assert len(list((tmp_path / "figures").glob("p1_fig*.png"))) == 7
    # the paper's default run is untouched
    default = json.loads((ROOT / "data" / "results" / "p1.json").read_text())
    assert default["parameters"]["phi_deg"] == 20.0
