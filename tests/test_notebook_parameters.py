"""Every notebook re-runs with new parameters: its `parameters` cell (the cell papermill and the
re-run entry point `python -m pkmlib.tools.rerun` replace) governs what the notebook computes, and a
re-run's results move as the geometry says.

Executing every notebook again would double the notebooks' time in `make test` (nbval executes
each once already), so the re-run path is executed end to end on the cheapest notebooks (P1, the
README's example; P5; the tutorial, which has no kernelspec), and for every notebook two cheap
checks fail where a re-run would silently repeat the paper's run: each parameter is read after the
parameters cell and never re-bound to a value that does not come from it, and no later cell writes
to a fixed path of the paper's run. The claims of the re-runs of P2 and P4 (linear in the speed,
the force and the torque; stiffness independent of the torque) are checked on the library calls
their notebooks make. The bad inputs, which stop before any work, are in test_rerun_bad_inputs.py.
"""

import ast
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

import nbformat

from pkmlib.tools import rerun

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.stem for p in (ROOT / "notebooks").glob("*.ipynb"))


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
def test_p1_with_phi_30_moves_the_singular_lines(tmp_path, monkeypatch):
    # 30 deg is also an edge of the notebook (issue 11: Fig 1's hard-coded pose left the workspace
    # there); tests/test_rerun_bad_inputs.py runs the other edge, 0 deg
    r, changes = run("p1_gripper_4prr", tmp_path, monkeypatch, "-p", "phi_deg", "30", "-p", "dx_D_m", "0.01")
    phi = np.deg2rad(30.0)
    predicted = sorted([0.14 * np.sin(phi), -0.22 * np.sin(phi)])  # lower -l_C2D sin(phi), upper s sin(phi)
    np.testing.assert_allclose(r["singular_lines_y_m"], predicted, rtol=0, atol=1e-9)
    assert r["parameters"]["phi_deg"] == 30.0
    assert len(list((tmp_path / "figures").glob("p1_fig*.png"))) == 7
    assert committed("p1")["parameters"]["phi_deg"] == 20.0  # the paper's run is untouched
    # changes.md: the parameters, the lines at the predicted heights (from the paper run's at 20 deg)
    assert "| `phi_deg` | 20 | 30 |" in changes and "| `dx_D_m` | 0.005 | 0.01 |" in changes
    _, paper, ours, unit, _ = row(changes, "singular_lines_y_m")
    phi20 = np.deg2rad(20.0)
    np.testing.assert_allclose(numbers(paper), sorted([0.14 * np.sin(phi20), -0.22 * np.sin(phi20)]), rtol=1e-7)
    np.testing.assert_allclose(numbers(ours), predicted, rtol=1e-7)
    assert unit == "m"
    assert (
        "| ![paper's run: p1_fig5_det_A_sign.png](" in changes
        and "| ![this run: p1_fig5_det_A_sign.png](figures/p1_fig5_det_A_sign.png) |" in changes
    )


@pytest.mark.slow
def test_p5_doubling_the_forces_doubles_the_linear_acceleration_only(tmp_path, monkeypatch):
    r, changes = run("p5_decoupled_6dof_dynamics", tmp_path, monkeypatch, "-p", "forces_N", "[2, 2, 4, 4, 6, 6]")
    base = committed("p5")
    np.testing.assert_allclose(r["linear_acceleration"], 2 * np.asarray(base["linear_acceleration"]), rtol=1e-12)
    # paired forces give no moment: the angular acceleration is gyroscopic, independent of the forces
    np.testing.assert_allclose(r["angular_acceleration"], base["angular_acceleration"], rtol=1e-12)
    assert "`linear_acceleration`" in changes and "`angular_acceleration`" not in changes


@pytest.mark.slow
def test_the_tutorial_without_kernelspec_re_runs(tmp_path, monkeypatch):
    # the tutorial notebook has no kernelspec: the re-run names the kernel itself
    r, changes = run("tutorial_bring_your_own_mechanism", tmp_path, monkeypatch, "-p", "step_m", "0.02")
    assert r is None  # the tutorial writes figures only
    assert "| `step_m` | 0.005 | 0.02 |" in changes
    maps = ["tutorial_delta_maps", "tutorial_det_A_sign", "tutorial_max_leg_force", "tutorial_max_leg_speed"]
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == sorted(
        ["tutorial_assembly_modes.png"] + [f"{n}.{ext}" for n in maps for ext in ("npz", "png")]
    )
    assert "### tutorial_det_A_sign" in changes  # a coarser grid: every map looks different


# ---------------------------------------------------------------- every notebook, without running it


def _later_code(stem):
    """The parameters and the parsed code cells after the parameters cell (IPython magics and
    shell lines dropped)."""
    nb = nbformat.read(ROOT / "notebooks" / f"{stem}.ipynb", as_version=4)
    k = rerun.parameters_cell_index(nb)
    cells = []
    for cell in nb.cells[k + 1 :]:
        if cell.cell_type == "code":
            src = "\n".join(line for line in cell.source.splitlines() if not line.lstrip().startswith(("%", "!")))
            cells.append(ast.parse(src))
    return list(rerun.notebook_parameters(nb)), cells


def _module_level(tree):
    """The nodes of ``tree`` outside function, class and comprehension scopes."""
    stack = list(ast.iter_child_nodes(tree))
    while stack:
        node = stack.pop()
        yield node
        if not isinstance(
            node,
            (
                ast.FunctionDef,
                ast.AsyncFunctionDef,
                ast.Lambda,
                ast.ClassDef,
                ast.ListComp,
                ast.SetComp,
                ast.DictComp,
                ast.GeneratorExp,
            ),
        ):
            stack.extend(ast.iter_child_nodes(node))


def _reads(node, name):
    return any(isinstance(n, ast.Name) and n.id == name and isinstance(n.ctx, ast.Load) for n in ast.walk(node))


@pytest.mark.parametrize("stem", NOTEBOOKS)
def test_every_parameter_is_read_after_the_parameters_cell_and_never_replaced(stem):
    names, cells = _later_code(stem)
    unread = [n for n in names if not any(_reads(tree, n) for tree in cells)]
    assert not unread, f"{stem}: parameters never read after the parameters cell (a re-run would ignore them): {unread}"
    replaced = []
    for tree in cells:
        for node in _module_level(tree):
            if isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                value = node.value
            elif isinstance(node, (ast.For, ast.AsyncFor)):
                targets, value = [node.target], None
            else:
                continue
            for t in targets:
                for n in ast.walk(t):
                    if (
                        isinstance(n, ast.Name)
                        and n.id in names
                        and isinstance(n.ctx, ast.Store)
                        and not (isinstance(node, ast.AugAssign) or (value is not None and _reads(value, n.id)))
                    ):
                        replaced.append(f"{n.id} (line {node.lineno})")
    assert not replaced, f"{stem}: parameters re-bound to values that do not come from them: {replaced}"


@pytest.mark.parametrize("stem", NOTEBOOKS)
def test_no_later_cell_writes_to_a_fixed_path_of_the_papers_run(stem):
    _, cells = _later_code(stem)
    # the paper's values in the parameter specification (pk.tools.text("../figures", output=True)) are no writes
    spec = {
        id(a)
        for tree in cells
        for n in ast.walk(tree)
        if isinstance(n, ast.Call) and getattr(n.func, "attr", getattr(n.func, "id", None)) == "text"
        for a in n.args
    }
    fixed = [
        n.value
        for tree in cells
        for n in ast.walk(tree)
        if isinstance(n, ast.Constant)
        and id(n) not in spec
        and isinstance(n.value, str)
        and re.search(r"(^|/)(figures|data/results)(/|$)", n.value)
    ]
    assert not fixed, (
        f"{stem}: paths of the paper's run outside the parameters cell (a re-run would overwrite them): {fixed}"
    )


# ---------------------------------------------------------------- the claims of the P2 and P4 re-runs


def test_p2_doubling_speed_and_force_doubles_both_maps():
    import pkmlib as pk
    from pkmlib.mechanisms import three_rrr as t

    p = t.ThreeRRRParams.from_dict(pk.load_params("p2"))
    x = t.pose(np.linspace(0.1, 0.3, 7), np.linspace(0.05, 0.25, 7), 0.0)
    base = t.pose_criteria(x, p, V=0.1, force=10.0)
    doubled = t.pose_criteria(x, p, V=0.2, force=20.0)
    assert np.isfinite(np.asarray(base["max_joint_velocity"])).sum() >= 5
    for key in ("max_joint_velocity", "max_actuator_torque", "delta_q", "delta_e"):
        np.testing.assert_allclose(doubled[key], 2 * np.asarray(base[key]), rtol=1e-12)
    for key in ("q", "det_A", "det_B"):  # the same geometry
        np.testing.assert_array_equal(doubled[key], base[key])


def test_p4_doubling_the_torque_doubles_the_parallelogram_not_the_stiffness():
    import pkmlib as pk
    from pkmlib.mechanisms import five_bar as fb

    p = fb.FiveBarParams.from_dict(pk.load_params("p4"))
    x = np.array([50.0, 150.0])  # the notebook's probe
    base, doubled = fb.pose_stiffness_jit(x, p, 2000.0), fb.pose_stiffness_jit(x, p, 4000.0)
    J_inv = pk.inverse_jacobian(fb.mechanism, x, base["q"], p)
    np.testing.assert_allclose(
        fb.force_parallelogram(J_inv, 4000.0), 2 * np.asarray(fb.force_parallelogram(J_inv, 2000.0)), rtol=1e-12
    )
    np.testing.assert_allclose(doubled["diagonal_length"], 2 * base["diagonal_length"], rtol=1e-12)
    for key in ("k_worst", "k_min", "K_C"):
        np.testing.assert_allclose(doubled[key], base[key], rtol=1e-12)
