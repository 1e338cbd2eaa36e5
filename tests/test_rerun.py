"""`python -m pkmlib.tools.rerun` (and `make rerun`): names checked before anything runs, values read as
papermill reads them, the notebook's own checks run first, failures reported as the notebook's
error, and changes.md listing what changed against the paper's run."""

import json
import logging
import math
import os
import subprocess
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import nbformat  # noqa: E402
import papermill  # noqa: E402
import pytest  # noqa: E402

from pkmlib import _atomic  # noqa: E402
from pkmlib.tools import rerun  # noqa: E402
from pkmlib.plotting import save_figure  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.stem for p in (ROOT / "notebooks").glob("*.ipynb"))


def main(capsys, *argv):
    """Run the entry point in this process; return (exit status, stdout, stderr)."""
    status = rerun.main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


# ---------------------------------------------------------------- reading the parameters cell


@pytest.mark.parametrize("stem", NOTEBOOKS)
def test_every_assignment_of_the_parameters_cell_is_a_parameter(stem):
    nb = nbformat.read(ROOT / "notebooks" / f"{stem}.ipynb", as_version=4)
    cell = nb.cells[rerun.parameters_cell_index(nb)].source
    assigned = [
        line.split("=")[0].strip()
        for line in cell.splitlines()
        if line and not line.startswith(("#", " ")) and "=" in line.split("#")[0]
    ]
    assert list(rerun.notebook_parameters(nb)) == assigned
    assert "figures_dir" in assigned


def test_comments_with_equals_signs_are_read_without_warnings(caplog):
    # papermill's reader skips every line with two '=' (comments included) and then warns falsely
    # that the parameter is unknown: the cause of the warnings for P1's s_m and P2's l3_is.
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            's_m = 0.14  # gripper opening s = |C1 D|, m\nl3_is = "circumradius"  # (l3 = |P C_i|)\n'
            "n: int = 3  # annotated\nx = [1,\n     2]  # over two lines\n",
            metadata={"tags": ["parameters"]},
        )
    ]
    nb.metadata["kernelspec"] = {"name": "python3", "language": "python", "display_name": "Python 3"}
    with caplog.at_level(logging.WARNING):
        assert rerun.notebook_parameters(nb) == {"s_m": 0.14, "l3_is": "circumradius", "n": 3, "x": [1, 2]}
    assert not caplog.records
    papermills = papermill.translators.PythonTranslator.inspect(nb.cells[0])
    assert "s_m" not in {p.name for p in papermills}  # the papermill behaviour this works around


def test_p1_and_p2_parameters_with_bars_in_their_comments_are_found():
    p1 = rerun.notebook_parameters(nbformat.read(ROOT / "notebooks" / "p1_gripper_4prr.ipynb", as_version=4))
    p2 = rerun.notebook_parameters(
        nbformat.read(ROOT / "notebooks" / "p2_three_rrr_singularity_proximity.ipynb", as_version=4)
    )
    assert p1["s_m"] == 0.14 and p1["phi_deg"] == 20.0
    assert p2["l3_is"] == "circumradius" and p2["branch"] == [1, 1, 1]


def test_notebooks_are_found_by_stem_or_path():
    assert rerun.resolve_notebook("p1_gripper_4prr") == ROOT / "notebooks" / "p1_gripper_4prr.ipynb"
    assert rerun.resolve_notebook(str(ROOT / "notebooks" / "p1_gripper_4prr.ipynb")).name == "p1_gripper_4prr.ipynb"
    with pytest.raises(rerun.RerunError, match=r"notebook 'p9' not found; notebooks: .*p1_gripper_4prr, "):
        rerun.resolve_notebook("p9", cwd=ROOT)


# ---------------------------------------------------------------- names and values


def test_an_unknown_name_fails_before_anything_runs_and_lists_the_valid_ones(capsys, tmp_path):
    out = tmp_path / "out"
    status, stdout, err = main(capsys, "p5_decoupled_6dof_dynamics", "-p", "alpha_dge", "45", "-o", str(out))
    assert status == 2
    assert "unknown parameter 'alpha_dge' (did you mean 'alpha_deg'?)" in err
    assert "Valid parameters: alpha_deg, beta_deg, gamma_deg, position_m, forces_N" in err
    assert "results_path" not in err  # set by the re-run, not by the user
    assert not out.exists()  # nothing executed, nothing written


def test_the_output_paths_are_the_reruns_own(capsys, tmp_path):
    status, _, err = main(capsys, "p1_gripper_4prr", "-p", "results_path", "x.json", "-o", str(tmp_path / "o"))
    assert status == 2 and "results_path is set by the re-run" in err


@pytest.mark.parametrize(
    "argv, message",
    [
        ([], "usage: python -m pkmlib.tools.rerun NB"),
        (["p1_gripper_4prr", "-p", "phi_deg"], "-p needs 2 values"),
        (["p1_gripper_4prr", "--bogus"], "unknown option '--bogus'"),
        (["p1_gripper_4prr", "p2_three_rrr_singularity_proximity"], "one notebook at a time"),
        (["p1_gripper_4prr", "-y", "phi_deg: [1"], "-y: not valid YAML"),
        (["p1_gripper_4prr", "-y", "- 1"], "-y: expected a mapping"),
    ],
)
def test_usage_errors(capsys, argv, message):
    status, _, err = main(capsys, *argv)
    assert status == 2 and message in err


def test_list_shows_the_parameters_and_the_papers_values(capsys):
    status, out, _ = main(capsys, "p1_gripper_4prr", "--list")
    assert status == 0
    assert "s_m           0.14" in out and "branch        [-1, 1, -1, 1]" in out and "results_path" not in out


@pytest.mark.parametrize(
    "text, value",
    [
        ("25", 25),
        ("-100", -100),
        ("25.0", 25.0),
        ("2.5e-5", 2.5e-5),
        ("-1e-3", -1e-3),
        ("True", True),
        ("None", None),
        ("abc", "abc"),
        ("0.2, 1.2", "0.2, 1.2"),
        ("[1, -1, 1]", [1, -1, 1]),
        ("[0.2, 2.5e-5]", [0.2, 2.5e-5]),
        ("[[0, 150], [50, 200]]", [[0, 150], [50, 200]]),
        ("[1", "[1"),
    ],
)
def test_p_values_are_read_as_papermill_reads_them_plus_lists(text, value):
    assert rerun.parse_value(text) == value
    assert type(rerun.parse_value(text)) is type(value)


def test_nan_and_inf_reach_the_check_as_numbers():
    assert math.isnan(rerun.parse_value("nan")) and rerun.parse_value("-inf") == -math.inf


def test_yaml_reads_exponents_as_numbers_and_later_values_win():
    a = rerun.parse_arguments(
        ["p2", "-y", "step_m: 2.5e-5\nbranch: [-1, 1, -1]", "-p", "V_m_s", "0.2", "-y", "V_m_s: 0.3"]
    )
    assert rerun.given_parameters(a) == {"step_m": 2.5e-5, "branch": [-1, 1, -1], "V_m_s": 0.2}


def test_a_yaml_file(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text("phi_deg: 25\nx_D_range_m: [0.3, 1.0]\n")
    assert rerun.given_parameters(rerun.parse_arguments(["p1", "-f", str(f)])) == {
        "phi_deg": 25,
        "x_D_range_m": [0.3, 1.0],
    }


# ---------------------------------------------------------------- a small project to re-run

CHECK_CELL = (
    "import pkmlib as pk\n"
    "paper_run = pk.tools.check_parameters(globals(), {\n"
    '    "x_m": pk.tools.number(1.0, min=0.0, min_open=True, unit="m"),\n'
    '    "branch": pk.tools.signs([1, -1]),\n'
    '    "results_path": pk.tools.text("../data/results/toy.json", output=True),\n'
    '    "figures_dir": pk.tools.text("../figures", output=True),\n'
    "})"
)
WORK_CELL = (
    "import json, pathlib\n"
    "from pkmlib.plotting import plt, save_figure\n"
    "fig, ax = plt.subplots()\n"
    "ax.plot([0, 1], [0, x_m])\n"
    'save_figure(fig, pathlib.Path(figures_dir) / "toy_fig1_line.png", source="toy")\n'
    "fig, ax = plt.subplots()\n"
    "ax.plot([0, 1], [0, 1])\n"
    'save_figure(fig, pathlib.Path(figures_dir) / "toy_fig2_fixed.png", source="toy")\n'
    'pathlib.Path(results_path).write_text(json.dumps({"parameters": {"x_m": x_m}, "length_m": x_m,\n'
    '    "area_m2": x_m * x_m, "fixed_N": 3.0, "sizes_mm": [1.0, 2.0 * x_m], "label": "toy"}))\n'
)


def toy_project(root: Path, check: bool = True) -> Path:
    """A project with one notebook (no kernelspec, like the tutorial), its committed results and
    figures, as the paper's run at x_m = 1 would leave them."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            "x_m = 1.0  # a length, x = |AB|, m\nbranch = [1, -1]\n"
            'results_path = "../data/results/toy.json"\nfigures_dir = "../figures"',
            metadata={"tags": ["parameters"]},
        ),
        nbformat.v4.new_code_cell(CHECK_CELL if check else "import pkmlib as pk"),
        nbformat.v4.new_code_cell(WORK_CELL),
    ]
    (root / "notebooks").mkdir(parents=True)
    nbformat.write(nb, root / "notebooks" / "toy.ipynb")
    (root / "data" / "results").mkdir(parents=True)
    (root / "data" / "results" / "toy.json").write_text(
        json.dumps(
            {
                "parameters": {"x_m": 1.0},
                "length_m": 1.0,
                "area_m2": 1.0 + 1e-9,
                "fixed_N": 3.0,
                "sizes_mm": [1.0, 2.0],
                "label": "toy",
                "gone_s": 1.0,
            }
        )
    )
    for name, y in (("toy_fig1_line", 1.0), ("toy_fig2_fixed", 1.0)):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, y])
        save_figure(fig, root / "figures" / f"{name}.png", source="toy")
        plt.close(fig)
    return root / "notebooks" / "toy.ipynb"


def test_a_bad_value_fails_in_the_notebooks_own_check_before_a_kernel_starts(capsys, tmp_path):
    nb = toy_project(tmp_path)
    out = tmp_path / "runs" / "toy"
    for args, message in (
        (["-p", "x_m", "-1"], "parameter 'x_m' = -1: expected a finite number > 0 m (too small)"),
        (
            ["-y", "branch: [1, -1, 1]"],
            "parameter 'branch' = [1, -1, 1]: expected a list of 2 signs, each +1 or -1 (3 given)",
        ),
        (["-p", "x_m", "abc"], "parameter 'x_m' = 'abc'"),
    ):
        status, _, err = main(capsys, str(nb), *args)
        assert status == 2, err
        assert err == f"error: ValueError: {message}\n" if "abc" not in message else message in err
        assert not out.exists()  # no kernel, no output


def test_changes_md_lists_parameters_results_and_figures_that_changed(tmp_path):
    nb = toy_project(tmp_path)
    defaults = rerun.notebook_parameters(nbformat.read(nb, as_version=4))
    run = rerun.Run(nb, tmp_path / "runs" / "toy", {"x_m": 2.0, "branch": [1, -1]}, defaults, command="cmd")
    run.injected()
    # what the notebook would write at x_m = 2
    (run.out / "figures").mkdir(parents=True)
    (run.out / "results.json").write_text(
        json.dumps(
            {
                "parameters": {"x_m": 2.0},
                "length_m": 2.0,
                "area_m2": 4.0,
                "fixed_N": 3.0 * (1 + 1e-9),
                "sizes_mm": [1.0, 4.0],
                "label": "toy",
                "new_deg": 5.0,
            }
        )
    )
    for name, y in (("toy_fig1_line", 2.0), ("toy_fig2_fixed", 1.0), ("toy_fig9_new", 1.0)):
        fig, ax = plt.subplots()
        ax.plot([0, 1], [0, y])
        save_figure(fig, run.out / "figures" / f"{name}.png", source="toy")
        plt.close(fig)
    md = rerun.write_changes(run).read_text()
    assert "| `x_m` | 1 | 2 |" in md
    assert "Given with the paper's value: `branch`." in md
    assert "| `length_m` | 1 | 2 | m | +1 |" in md
    assert "| `area_m2` | 1 | 4 | m² | +3 |" in md
    assert "| `sizes_mm` | [1, 2] | [1, 4] | mm | 1 of 2 entries; largest 1 |" in md
    assert "| `gone_s` | 1 | absent | s |  |" in md
    assert "| `new_deg` | absent | 5 | deg |  |" in md
    assert "fixed_N" not in md  # a relative change of 1e-9 is round-off, not a change
    assert "label" not in md and "| `parameters" not in md
    assert "5 of 7 results changed" in md and "relative 1e-06" in md
    assert "### toy_fig1_line" in md
    assert (
        "| ![paper's run: toy_fig1_line.png](../../figures/toy_fig1_line.png) "
        "| ![this run: toy_fig1_line.png](figures/toy_fig1_line.png) |"
    ) in md
    assert "toy_fig2_fixed" not in md.split("Unchanged:")[0] and "Unchanged: `toy_fig2_fixed.png`." in md
    assert "New figures (no paper-run figure of that name): [toy_fig9_new.png](figures/toy_fig9_new.png)." in md
    for link in ("../../figures/toy_fig1_line.png", "figures/toy_fig1_line.png"):
        assert (run.out / link).is_file()


def test_the_paper_run_has_nothing_to_list(tmp_path):
    nb = toy_project(tmp_path)
    defaults = rerun.notebook_parameters(nbformat.read(nb, as_version=4))
    run = rerun.Run(nb, tmp_path / "runs" / "toy", {}, defaults)
    run.injected()
    run.out.mkdir(parents=True)
    (run.out / "results.json").write_text((tmp_path / "data" / "results" / "toy.json").read_text())
    md = rerun.changes_markdown(run)
    assert "None: every parameter has the paper's value" in md
    assert "None of the 6 results changed." in md
    assert "The run saved no figures." in md


@pytest.mark.parametrize(
    "key, unit",
    [
        ("max_carriage_velocity_m_s", "m/s"),
        ("max_gripper_force_N_no_load", "N"),
        ("s_m", "m"),
        ("k_worst_N_mm", "N/mm"),
        ("T_max_N_mm", "N mm"),
        ("max_actuator_torque_N_m", "N m"),
        ("workspace_volume_mm3_A", "mm³"),
        ("peak_acceleration_mm_s2", "mm/s²"),
        ("max_joint_velocity_rad_s", "rad/s"),
        ("x3_mm_from_row1", "mm"),
        ("first_sample_outside_s", "s"),
        ("det_A", ""),
        ("n_t", ""),
        ("workspace_points", ""),
        ("atlas_pairs_per_s", "pairs/s"),
    ],
)
def test_units_are_read_from_the_keys(key, unit):
    assert rerun.unit_of_key(key) == unit


def test_numbers_are_compared_at_the_stated_tolerance():
    assert not rerun.values_differ(1.0, 1.0 + 0.5e-6)
    assert rerun.values_differ(1.0, 1.0 + 2e-6)
    assert not rerun.values_differ(0.0, 1e-13)  # round-off around zero
    assert rerun.values_differ(None, 0.0) and rerun.values_differ(1, True)
    assert not rerun.values_differ(float("nan"), float("nan")) and rerun.values_differ(float("nan"), 1.0)
    assert rerun.values_differ([1.0, 2.0], [1.0, 2.0, 3.0])


# ---------------------------------------------------------------- atomic writes


def test_atomic_writes_leave_the_old_file_when_the_writer_fails(tmp_path):
    path = tmp_path / "sub" / "results.json"
    _atomic.atomic_write_text(path, "old")
    with pytest.raises(RuntimeError):

        def half_written(tmp):
            tmp.write_text("half")
            raise RuntimeError("crash")

        _atomic.atomic_write_with(path, half_written)
    assert path.read_text() == "old"
    assert [p.name for p in path.parent.iterdir()] == ["results.json"]  # no temporary file left
    _atomic.atomic_write_bytes(path, b"new")
    assert path.read_bytes() == b"new"
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask():
    u = os.umask(0)
    os.umask(u)
    return u


def test_save_figure_is_atomic(tmp_path):
    path = tmp_path / "figures" / "x.png"
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    save_figure(fig, path, source="test")
    before = path.read_bytes()
    assert before[:8] == b"\x89PNG\r\n\x1a\n"

    class Broken(Exception):
        pass

    def broken_savefig(*args, **kwargs):
        raise Broken

    fig.savefig = broken_savefig
    with pytest.raises(Broken):
        save_figure(fig, path, source="test")
    plt.close(fig)
    assert path.read_bytes() == before and len(list(path.parent.iterdir())) == 1


# ---------------------------------------------------------------- executing (a kernel starts)


@pytest.mark.slow
def test_a_run_of_a_notebook_without_kernelspec_writes_everything_into_its_folder(tmp_path, monkeypatch):
    nb = toy_project(tmp_path)
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))  # restored after the run
    r = subprocess.run(
        [sys.executable, "-m", "pkmlib.tools.rerun", str(nb), "-p", "x_m", "2.0"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # no warnings (papermill's false "unknown parameter", ipykernel's TCP one)
    out = tmp_path / "runs" / "toy"
    assert (
        r.stdout == "wrote runs/toy/: the executed notebook, results and figures\nwhat changed: runs/toy/changes.md\n"
    )
    assert sorted(p.name for p in out.iterdir()) == [
        "changes.md",
        "figures",
        "pkmlib-run.json",
        "results.json",
        "toy.ipynb",
    ]
    assert sorted(p.name for p in out.parent.iterdir()) == ["toy"]  # no lock, no incomplete folder
    assert json.loads((out / "results.json").read_text())["length_m"] == 2.0
    executed = nbformat.read(out / "toy.ipynb", as_version=4)
    assert executed.metadata.papermill.parameters["x_m"] == 2.0
    assert executed.metadata.papermill.parameters["results_path"] == "../runs/toy/results.json"
    assert "| `length_m` | 1 | 2 | m | +1 |" in (out / "changes.md").read_text()
    assert json.loads((tmp_path / "data" / "results" / "toy.json").read_text())["length_m"] == 1.0  # untouched


@pytest.mark.slow
def test_a_failing_cell_exits_non_zero_with_the_notebooks_own_error(tmp_path, capsys, monkeypatch):
    nb = toy_project(tmp_path)
    monkeypatch.setenv("PYTHONPATH", os.environ.get("PYTHONPATH", ""))
    status, _, err = main(capsys, str(nb), "--no-precheck", "-p", "x_m", "-1")
    assert status == 1
    [work] = (tmp_path / "runs").glob("toy.incomplete-*")
    assert err.splitlines() == [
        "error: toy stopped in In [3]: ValueError: parameter 'x_m' = -1: expected a finite number > 0 m (too small)",
        f"the executed notebook, up to the error: {work / 'toy.ipynb'} (nothing was in {tmp_path / 'runs' / 'toy'}/ "
        f"before)",
    ]
    executed = nbformat.read(work / "toy.ipynb", as_version=4)
    assert any(o.get("ename") == "ValueError" for c in executed.cells for o in c.get("outputs", []))
    assert not (work / "changes.md").exists() and not (tmp_path / "runs" / "toy").exists()
    assert "ValueError: parameter 'x_m' = -1" in (work / "INCOMPLETE").read_text()
    assert sorted(p.name for p in work.iterdir()) == ["INCOMPLETE", "toy.ipynb"]  # no hidden temporary file


# ---------------------------------------------------------------- the commands the README shows


def readme_rerun_commands():
    """argv of every `make rerun ...` / `python -m pkmlib.tools.rerun ...` line in the README's code blocks."""
    import shlex

    commands, in_code = [], False
    for line in (ROOT / "README.md").read_text().splitlines():
        if line.startswith("```"):
            in_code = not in_code
            continue
        words = (
            shlex.split(line, comments=True)
            if in_code and ("make rerun" in line or "pkmlib.tools.rerun" in line)
            else []
        )
        if words[:2] == ["make", "rerun"]:
            settings = dict(w.split("=", 1) for w in words[2:] if "=" in w)
            if "NB" in settings and "<" not in settings["NB"]:
                commands.append([settings["NB"], *shlex.split(settings.get("PARAMS", ""))])
        elif "pkmlib.tools.rerun" in words:
            argv = words[words.index("pkmlib.tools.rerun") + 1 :]
            if argv and "<" not in argv[0]:
                commands.append(argv)
    return commands


def test_the_makefile_calls_the_entry_point():
    recipe = (ROOT / "Makefile").read_text().split("\nrerun:")[1].split("\n\n")[0]
    assert "$(BIN)/python -m pkmlib.tools.rerun $(NB) $(PARAMS)" in recipe


@pytest.mark.parametrize("argv", readme_rerun_commands(), ids=" ".join)
def test_every_rerun_command_in_the_readme_names_real_parameters_with_accepted_values(argv):
    # what `make rerun` checks before it executes (the runs themselves: test_notebook_parameters.py)
    a = rerun.parse_arguments(argv)
    nb = nbformat.read(rerun.resolve_notebook(a.notebook), as_version=4)
    defaults = rerun.notebook_parameters(nb)
    given = rerun.given_parameters(a)
    rerun.check_names(list(given), defaults, a.notebook)
    rerun.precheck(nb, {**defaults, **given})
    assert given or a.list_only


@pytest.mark.parametrize("out", [".", "notebooks"])
def test_the_paper_run_cannot_be_overwritten(capsys, out):
    # -o . would put results into ./results.json and figures into ./figures/: the paper's own figures
    status, _, err = main(capsys, "p1_gripper_4prr", "-o", str(ROOT / out))
    assert status == 2 and "would overwrite the paper's run" in err
