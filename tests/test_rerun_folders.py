"""Issue 18.1: a re-run never destroys another run or a previous one.

Each case runs the entry point in this process on a small project whose notebook is "executed" by
a stand-in for :func:`pkmlib.tools.rerun.execute` (it writes what the notebook would: the executed
notebook, results.json, a figure), so the folder logic (lock, fresh folder, manifest, swap,
incomplete marking, signals, errors) is tested in milliseconds without a kernel. One test
(marked slow) sends SIGTERM to a real re-run with a real kernel.
"""

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

from pkmlib import _run_folder
from pkmlib.tools import rerun

ROOT = Path(__file__).resolve().parents[1]
PNG = (ROOT / "figures").glob("*.png")
A_PNG = next(iter(sorted(PNG)))


def project(root: Path) -> Path:
    """One notebook ``toy`` with a parameters cell, its check and the paper's run (results, a
    figure). Returns the notebook's path."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            'x_m = 1.0\nresults_path = "../data/results/toy.json"\nfigures_dir = "../figures"',
            metadata={"tags": ["parameters"]},
        ),
        nbformat.v4.new_code_cell(
            "import pkmlib as pk\npk.tools.check_parameters(globals(), {\n"
            '    "x_m": pk.tools.number(1.0, min=0.0, min_open=True, unit="m")})'
        ),
    ]
    (root / "notebooks").mkdir(parents=True)
    nbformat.write(nb, root / "notebooks" / "toy.ipynb")
    (root / "data" / "results").mkdir(parents=True)
    (root / "data" / "results" / "toy.json").write_text(json.dumps({"length_m": 1.0}))
    (root / "figures").mkdir()
    shutil.copy(A_PNG, root / "figures" / "toy_fig1.png")
    return root / "notebooks" / "toy.ipynb"


def fake_execute(then=None):
    """A stand-in for :func:`rerun.execute`: writes what the toy notebook would, then calls
    ``then(run)`` (to fail, wait or be interrupted in the middle of a run)."""

    def execute(run, kernel):
        params = run.injected()
        run.executed.write_text(nbformat.writes(nbformat.v4.new_notebook()))
        (run.dir / "figures").mkdir(exist_ok=True)
        shutil.copy(A_PNG, run.dir / "figures" / "toy_fig1.png")
        (run.dir / "results.json").write_text(json.dumps({"length_m": params.get("x_m", 1.0)}))
        if then is not None:
            then(run)

    return execute


def snapshot(folder: Path) -> dict:
    """Every file below ``folder`` and its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def hidden(root: Path) -> list:
    return [str(p) for p in root.rglob(".*")]


def incomplete(runs: Path) -> list:
    return sorted(runs.glob("*.incomplete-*"))


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """(notebook path, runs/ folder, a function calling the entry point: (status, stderr))."""
    nb = project(tmp_path)
    monkeypatch.chdir(tmp_path)

    def run(*argv, execute=None, capsys=None):
        monkeypatch.setattr(rerun, "execute", execute or fake_execute())
        status = rerun.main([str(nb), *argv])
        return status

    return nb, tmp_path / "runs", run


def previous_run(toy, capsys):
    """A completed run at x_m = 2 in runs/toy/, and its snapshot."""
    _nb, runs, run = toy
    assert run("-p", "x_m", "2") == 0, capsys.readouterr().err
    capsys.readouterr()
    return snapshot(runs / "toy")


class SignalReachedTest(Exception):
    """Raised by the test's own handlers when the entry point lets a signal through."""


@pytest.fixture
def signals_caught():
    """Handlers that turn SIGINT / SIGTERM into an exception (not a killed pytest) when the entry
    point does not handle them itself."""

    def handler(signum, frame):
        raise SignalReachedTest(signal.Signals(signum).name)

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM)}
    yield
    for s, h in old.items():
        signal.signal(s, h)


# ---------------------------------------------------------------- a completed run


def test_a_completed_run_is_in_place_with_its_manifest_and_nothing_else(toy, capsys):
    _nb, runs, run = toy
    assert run("-p", "x_m", "2") == 0
    out = runs / "toy"
    assert sorted(p.name for p in runs.iterdir()) == ["toy"]  # no lock, no incomplete folder left
    assert sorted(p.name for p in out.iterdir()) == [
        "changes.md",
        "figures",
        _run_folder.MANIFEST,
        "results.json",
        "toy.ipynb",
    ]
    manifest = json.loads((out / _run_folder.MANIFEST).read_text())
    assert manifest["notebook"] == "toy" and manifest["parameters"] == {"x_m": 2}
    assert "`runs/toy/results.json` (this run)" in (out / "changes.md").read_text()
    assert ".incomplete" not in (out / "changes.md").read_text()
    assert hidden(runs) == []


def test_a_second_run_replaces_the_first_only_when_it_has_completed(toy, capsys):
    _nb, runs, run = toy
    first = previous_run(toy, capsys)
    seen = {}

    def during(r):  # while the second run is written, the first is still in place, untouched
        seen["before"] = snapshot(runs / "toy")
        seen["work"] = r.dir

    assert run("-p", "x_m", "3", execute=fake_execute(during)) == 0
    assert seen["before"] == first and seen["work"].parent == runs and seen["work"].name.startswith("toy.incomplete-")
    assert json.loads((runs / "toy" / "results.json").read_text()) == {"length_m": 3}
    assert sorted(p.name for p in runs.iterdir()) == ["toy"]


def test_the_executed_notebook_records_where_its_outputs_are_once_in_place():
    nb = nbformat.v4.new_notebook()
    nb.cells = [
        nbformat.v4.new_code_cell(
            '# Parameters\nresults_path = "../runs/toy.incomplete-1/results.json"\n',
            metadata={"tags": ["injected-parameters"]},
        )
    ]
    nb.metadata["papermill"] = {"parameters": {"results_path": "../runs/toy.incomplete-1/results.json", "x": 1}}
    root = Path("/p")
    run = rerun.Run(
        root / "notebooks" / "toy.ipynb",
        root / "runs" / "toy",
        {},
        {},
        paths={"results_path": root / "runs" / "toy.incomplete-1" / "results.json"},
        work=root / "runs" / "toy.incomplete-1",
    )
    rerun._record_final_paths(nb, run)
    assert nb.cells[0].source == '# Parameters\nresults_path = "../runs/toy/results.json"\n'
    assert nb.metadata["papermill"]["parameters"] == {"results_path": "../runs/toy/results.json", "x": 1}


# ---------------------------------------------------------------- -o into a folder that is not this notebook's run


@pytest.mark.parametrize("marker", ["manifest", "changes.md of a run made before manifests"])
def test_o_into_another_notebooks_run_is_refused_and_leaves_it_as_it_was(toy, tmp_path, capsys, marker):
    # issue 18: a P5 re-run with -o runs/p1_gripper_4prr removed P1's results, changes.md and figures
    other = tmp_path / "runs" / "p1_gripper_4prr"
    (other / "figures").mkdir(parents=True)
    (other / "results.json").write_text('{"max_gripper_force_N": 1.0}')
    (other / "p1_gripper_4prr.ipynb").write_text("{}")
    shutil.copy(A_PNG, other / "figures" / "toy_fig1.png")  # a figure of the same name as toy's
    if marker == "manifest":
        (other / _run_folder.MANIFEST).write_text(json.dumps({"notebook": "p1_gripper_4prr"}))
    else:
        (other / "changes.md").write_text("# Re-run of p1_gripper_4prr: what changed against the paper's run\n")
    before = snapshot(other)
    _nb, runs, run = toy
    status = run("-o", str(other))
    err = capsys.readouterr().err
    assert status == 2
    assert err.splitlines() == [
        "error: runs/p1_gripper_4prr holds a run of p1_gripper_4prr, not of toy",
        "nothing was run or changed; choose another folder with -o DIR (default: runs/toy/)",
    ]
    assert snapshot(other) == before and sorted(p.name for p in runs.iterdir()) == ["p1_gripper_4prr"]


def test_o_into_a_folder_that_is_not_a_run_is_refused(toy, tmp_path, capsys):
    folder = tmp_path / "my_thesis"
    folder.mkdir()
    (folder / "chapter1.tex").write_text("text")
    (folder / "results.json").write_text("{}")
    _nb, _runs, run = toy
    assert run("-o", str(folder)) == 2
    assert capsys.readouterr().err.splitlines() == [
        "error: my_thesis is not a re-run's folder (it holds other files and no pkmlib-run.json)",
        "nothing was run or changed; choose a new or empty folder with -o DIR",
    ]
    assert snapshot(folder) == {"chapter1.tex": b"text", "results.json": b"{}"}


@pytest.mark.parametrize("where", ["a file", "below a file"])
def test_o_that_is_a_file_is_refused_with_two_lines(toy, tmp_path, capsys, where):
    f = tmp_path / "notes.txt"
    f.write_text("keep me")
    _nb, _runs, run = toy
    status = run("-o", str(f if where == "a file" else f / "out"))
    err = capsys.readouterr().err
    assert status == 2
    assert err.splitlines() == [
        "error: notes.txt is not a folder (it is a file)",
        "nothing was run or changed; choose a folder with -o DIR",
    ]
    assert f.read_text() == "keep me"


def test_o_into_an_empty_or_new_folder_and_into_this_notebooks_old_run_is_accepted(toy, tmp_path, capsys):
    _nb, _runs, run = toy
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run("-o", str(empty)) == 0 and (empty / _run_folder.MANIFEST).is_file()
    assert run("-o", str(tmp_path / "new" / "deeper")) == 0
    legacy = tmp_path / "legacy"  # a run of toy made before manifests
    legacy.mkdir()
    (legacy / "changes.md").write_text("# Re-run of toy: what changed against the paper's run\n")
    (legacy / "toy.ipynb").write_text("{}")
    assert run("-o", str(legacy)) == 0, capsys.readouterr().err
    assert json.loads((legacy / _run_folder.MANIFEST).read_text())["notebook"] == "toy"
    assert sorted(p.name for p in tmp_path.iterdir() if "legacy" in p.name or "empty" in p.name) == ["empty", "legacy"]


# ---------------------------------------------------------------- two runs at once


def test_two_runs_of_one_notebook_at_once_the_second_stops_naming_the_first(toy, capsys):
    # issue 18: two re-runs at once both reported success and printed the same changes.md
    nb, runs, run = toy
    second = {}

    def during(r):  # the first run is under way: start a second one into the same folder
        second["status"] = rerun.main([str(nb), "-p", "x_m", "5"])
        second["err"] = capsys.readouterr().err

    assert run("-p", "x_m", "4", execute=fake_execute(during)) == 0
    assert second["status"] == 2
    lines = second["err"].splitlines()
    assert len(lines) == 2
    assert lines[0].startswith(f"error: runs/toy is busy: another re-run is writing it (pid {os.getpid()}, since ")
    assert lines[0].endswith(f"python -m pkmlib.tools.rerun {nb} -p x_m 4)")
    assert lines[1] == "nothing was run or changed; wait for it to end, or write elsewhere with -o DIR"
    assert json.loads((runs / "toy" / "results.json").read_text()) == {"length_m": 4}  # the first run's
    assert sorted(p.name for p in runs.iterdir()) == ["toy"]


def test_the_lock_is_taken_on_a_file_another_process_holds(tmp_path):
    out = tmp_path / "runs" / "toy"
    code = (
        "import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT); "
        "fcntl.flock(fd, fcntl.LOCK_EX); os.write(fd, b'pid 1, since then: another'); "
        "print('locked', flush=True); time.sleep(30)"
    )
    out.parent.mkdir(parents=True)
    p = subprocess.Popen(
        [sys.executable, "-c", code, str(_run_folder.lock_path(out))], stdout=subprocess.PIPE, text=True
    )
    try:
        assert p.stdout.readline() == "locked\n"
        with pytest.raises(
            _run_folder.FolderError,
            match=r"is busy: another re-run is writing it "
            r"\(pid 1, since then: another\)",
        ):
            with _run_folder.locked(out, "me"):
                pass
    finally:
        p.kill()
        p.wait()
    with _run_folder.locked(out, "me") as lock:  # free again
        assert "me" in lock.read_text()
    assert not _run_folder.lock_path(out).exists()


# ---------------------------------------------------------------- runs that fail


def test_a_bad_kernel_is_refused_before_anything_is_deleted(toy, capsys):
    # issue 18: a re-run with a bad --kernel first deleted the previous run, then failed with a traceback
    nb, runs, _run = toy
    before = previous_run(toy, capsys)
    status = rerun.main([str(nb), "--kernel", "no_such_kernel", "-p", "x_m", "3"])  # the real execute
    err = capsys.readouterr().err
    assert status == 2
    lines = err.splitlines()
    assert lines[0] == "error: no such kernel 'no_such_kernel' (--kernel)"
    assert lines[1].startswith("nothing was run or changed; the kernels here: ") and "python3" in lines[1]
    assert len(lines) == 2 and snapshot(runs / "toy") == before and incomplete(runs) == []


def test_a_run_that_fails_keeps_the_previous_run_and_marks_its_own_output_incomplete(toy, capsys):
    _nb, runs, run = toy
    before = previous_run(toy, capsys)

    def crash(r):
        raise RuntimeError("Kernel died before replying to kernel_info")

    status = run("-p", "x_m", "3", execute=fake_execute(crash))
    err = capsys.readouterr().err
    assert status == 1
    [work] = incomplete(runs)
    assert err.splitlines() == [
        "error: toy could not run: RuntimeError: Kernel died before replying to kernel_info",
        f"the previous run in runs/toy/ is kept; this run's partial output is in runs/{work.name}/ (marked INCOMPLETE)",
    ]
    assert snapshot(runs / "toy") == before
    marker = (work / "INCOMPLETE").read_text()
    assert marker.startswith("This run did not complete: a re-run of toy: python -m pkmlib.tools.rerun ")
    assert marker.rstrip().endswith("RuntimeError: Kernel died before replying to kernel_info")
    assert (work / "results.json").is_file() and not (work / _run_folder.MANIFEST).exists()
    assert hidden(runs) == [] and not _run_folder.lock_path(runs / "toy").exists()
    # the next run is not disturbed by the incomplete folder
    assert run("-p", "x_m", "4") == 0 and incomplete(runs) == [work]


def test_a_failing_cell_is_reported_in_two_lines_and_keeps_the_previous_run(toy, capsys):
    _nb, runs, run = toy
    before = previous_run(toy, capsys)

    def cell_fails(r):
        raise rerun._CellFailed("toy stopped in In [3]: ValueError: no")

    assert run("-p", "x_m", "3", execute=fake_execute(cell_fails)) == 1
    [work] = incomplete(runs)
    assert capsys.readouterr().err.splitlines() == [
        "error: toy stopped in In [3]: ValueError: no",
        f"the executed notebook, up to the error: runs/{work.name}/toy.ipynb (the previous run in runs/toy/ is kept)",
    ]
    assert snapshot(runs / "toy") == before


def test_a_full_disk_keeps_the_previous_run_and_names_the_cause(toy, capsys, monkeypatch):
    _nb, runs, run = toy
    before = previous_run(toy, capsys)

    def full(path, text, encoding="utf-8"):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(rerun, "atomic_write_text", full)  # writing changes.md hits a full disk
    assert run("-p", "x_m", "3") == 1
    [work] = incomplete(runs)
    assert capsys.readouterr().err.splitlines() == [
        f"error: disk full while writing the run of toy (runs/{work.name}/changes.md)",
        f"the previous run in runs/toy/ is kept; this run's partial output is in runs/{work.name}/ (marked INCOMPLETE)",
    ]
    assert snapshot(runs / "toy") == before
    assert "disk full" in (work / "INCOMPLETE").read_text() and hidden(runs) == []


def test_a_folder_that_cannot_be_written_is_refused_before_anything_runs(toy, tmp_path, capsys, monkeypatch):
    _nb, _runs, run = toy
    target = tmp_path / "readonly"
    target.mkdir()
    real_mkdir, real_open = os.mkdir, os.open

    def refuse(path):  # what a read-only folder answers (root ignores chmod)
        if str(path).startswith(str(target)):
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))

    def fake_mkdir(path, *args, **kwargs):
        refuse(path)
        return real_mkdir(path, *args, **kwargs)

    def fake_open(path, *args, **kwargs):
        refuse(path)
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "mkdir", fake_mkdir)
    monkeypatch.setattr(os, "open", fake_open)
    status = run("-o", str(target / "out"))
    monkeypatch.undo()
    err = capsys.readouterr().err
    assert status == 2
    assert err.splitlines() == [
        "error: readonly is not writable",
        "nothing was run or changed; choose another folder with -o DIR",
    ]
    assert list(target.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_refused_before_anything_runs(toy, tmp_path, capsys):
    _nb, _runs, run = toy
    target = tmp_path / "readonly"
    target.mkdir()
    target.chmod(0o555)
    try:
        assert run("-o", str(target / "out")) == 2
    finally:
        target.chmod(0o755)
    assert capsys.readouterr().err.splitlines() == [
        "error: readonly is not writable",
        "nothing was run or changed; choose another folder with -o DIR",
    ]


# ---------------------------------------------------------------- interrupts


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_run_keeps_the_previous_run_and_marks_its_output(toy, capsys, signals_caught, signum):
    _nb, runs, run = toy
    before = previous_run(toy, capsys)

    def interrupted(r):
        os.kill(os.getpid(), signum)
        time.sleep(5)  # the signal arrives here
        raise AssertionError("not interrupted")

    status = run("-p", "x_m", "3", execute=fake_execute(interrupted))
    name = signal.Signals(signum).name
    [work] = incomplete(runs)
    assert status == 128 + signum
    assert capsys.readouterr().err.splitlines() == [
        f"error: interrupted ({name}) while running toy",
        f"the previous run in runs/toy/ is kept; this run's partial output is in runs/{work.name}/ (marked INCOMPLETE)",
    ]
    assert snapshot(runs / "toy") == before and f"interrupted ({name})" in (work / "INCOMPLETE").read_text()
    assert hidden(runs) == [] and not _run_folder.lock_path(runs / "toy").exists()
    assert signal.getsignal(signum).__name__ == "handler"  # the test's own handler is back


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_while_checking_ends_in_two_lines_and_changes_nothing(
    toy, capsys, signals_caught, monkeypatch, signum
):
    _nb, runs, run = toy
    before = previous_run(toy, capsys)

    def interrupted(nb, values):
        os.kill(os.getpid(), signum)
        time.sleep(5)

    monkeypatch.setattr(rerun, "precheck", interrupted)
    assert run("-p", "x_m", "3") == 128 + signum
    assert capsys.readouterr().err.splitlines() == [
        f"error: interrupted ({signal.Signals(signum).name}) before the run started",
        "nothing was run or changed",
    ]
    assert snapshot(runs / "toy") == before and sorted(p.name for p in runs.iterdir()) == ["toy"]


def test_a_signal_while_the_completed_run_is_put_in_place_does_not_undo_it(toy, capsys, signals_caught, monkeypatch):
    _nb, runs, run = toy
    install = _run_folder.install

    def install_interrupted(work, out):
        os.kill(os.getpid(), signal.SIGTERM)  # deferred: the run is complete
        install(work, out)

    monkeypatch.setattr(_run_folder, "install", install_interrupted)
    assert run("-p", "x_m", "3") == 0
    assert json.loads((runs / "toy" / "results.json").read_text()) == {"length_m": 3}


SLEEPER = (
    "import json, os, pathlib, time\n"
    "pathlib.Path(figures_dir).mkdir(parents=True, exist_ok=True)\n"
    'pathlib.Path(results_path).write_text(json.dumps({"length_m": x_m, "kernel_pid": os.getpid()}))\n'
    "time.sleep(120)\n"
)


@pytest.mark.slow
def test_sigterm_to_a_real_rerun_stops_its_kernel_and_leaves_no_hidden_file(tmp_path):
    # issue 18: a SIGTERM left a hidden .tmp.ipynb behind (and nothing marked the folder incomplete)
    nb = project(tmp_path)
    node = nbformat.read(nb, as_version=4)
    node.cells = [node.cells[0], nbformat.v4.new_code_cell(SLEEPER)]  # no pkmlib import: a fast kernel
    nbformat.write(node, nb)
    (tmp_path / "runs" / "toy").mkdir(parents=True)
    (tmp_path / "runs" / "toy" / _run_folder.MANIFEST).write_text('{"notebook": "toy"}')
    (tmp_path / "runs" / "toy" / "results.json").write_text('{"length_m": 2}')
    before = snapshot(tmp_path / "runs" / "toy")
    p = subprocess.Popen(
        [sys.executable, "-m", "pkmlib.tools.rerun", str(nb), "-p", "x_m", "3"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        deadline = time.monotonic() + 120
        while not list((tmp_path / "runs").glob("toy.incomplete-*/results.json")):  # the kernel is in the cell
            assert p.poll() is None and time.monotonic() < deadline, p.communicate()
            time.sleep(0.2)
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
    [work] = incomplete(tmp_path / "runs")
    assert p.returncode == 128 + signal.SIGTERM, err
    assert err.splitlines() == [
        "error: interrupted (SIGTERM) while running toy",
        f"the previous run in runs/toy/ is kept; this run's partial output is in runs/{work.name}/ (marked INCOMPLETE)",
    ]
    assert snapshot(tmp_path / "runs" / "toy") == before
    assert hidden(tmp_path / "runs") == [] and "SIGTERM" in (work / "INCOMPLETE").read_text()
    with pytest.raises(ProcessLookupError):  # the kernel was stopped too
        os.kill(json.loads((work / "results.json").read_text())["kernel_pid"], 0)
