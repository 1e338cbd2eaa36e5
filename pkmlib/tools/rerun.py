"""Re-run one paper notebook with your own parameters, into ``runs/<NB>/``.

::

    python -m pkmlib.tools.rerun p1_gripper_4prr -p phi_deg 25
    python -m pkmlib.tools.rerun p2_three_rrr_singularity_proximity -y "branch: [1, -1, 1]"
    make rerun NB=p1_gripper_4prr PARAMS="-p phi_deg 25"

What it does, in order:

1. Finds the notebook (a stem such as ``p1_gripper_4prr`` or a path) and reads the names and
   default values of its ``parameters`` cell with :mod:`ast` (papermill's own reader skips any
   line holding more than one ``=``, comments included, and then warns falsely that the parameter
   is unknown).
2. Rejects unknown names before executing anything, listing the valid ones (exit status 2).
3. Checks the values with the notebook's own ``check_parameters`` call (the cell after
   ``parameters``) and the pure checks right after it in that cell (``if not q_min_m < q_max_m:
   raise ValueError(...)``) in this process, so a bad value fails in a second, naming the
   parameter, the value and what is accepted (exit status 2). The notebook checks them again when
   it runs. A ``--kernel`` Jupyter does not know and an output folder that is not this notebook's
   run (:mod:`pkmlib._run_folder`) are refused here too, before anything is written.
4. Takes the lock ``runs/<NB>.lock`` (a second re-run into the same folder stops, naming the
   first) and executes the notebook with papermill (kernel ``python3`` unless ``--kernel`` says
   otherwise; the working directory is ``notebooks/``) into a fresh folder
   ``runs/<NB>.incomplete-<time>/`` marked ``INCOMPLETE``: the executed notebook, ``results.json``
   and ``figures/``. If a cell fails, it prints that cell's error (``ValueError: parameter ...``)
   and where the executed notebook is, up to the error, and exits with status 1.
5. Writes ``changes.md`` there: the parameters that differ from the paper's run, every result
   that changed against the committed paper run (``data/results/<paper>.json``) and each changed
   figure beside the paper run's (``figures/``); then the manifest ``pkmlib-run.json``, and puts
   the folder in place of ``runs/<NB>/`` (the previous run is removed only then).

A run that fails or is interrupted (SIGINT, SIGTERM: the kernel is stopped) leaves the previous run
as it was and its own output in the ``.incomplete-<time>`` folder, the reason appended to
``INCOMPLETE``; every failure is two lines (the cause, then what was kept). Exit status: 0 done, 2
nothing was run or changed, 1 a run failed, 128 + the signal when interrupted.

Values: ``-p name value`` reads ``value`` as papermill does (``True``, ``False``,
``None``, integers, floats including ``nan`` and ``1e-3``, else a string) and a value in brackets
as a YAML list or mapping (``-p branch "[1, -1, 1]"``); ``-y`` takes YAML text and ``-f`` a YAML
file (both read ``2.5e-5`` as a number, which plain YAML does not). All YAML is read by
:func:`pkmlib._safe_yaml.load`: size and alias limits, duplicate keys, tags and empty values
refused, naming the input.
"""

from __future__ import annotations

import ast
import difflib
import json
import math
import os
import shlex
import signal
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from .. import _run_folder, _safe_yaml
from .._atomic import atomic_write_text
from .._run_folder import shown as _shown

#: Parameters the re-run sets itself (they point into ``runs/<NB>/``).
OUTPUT_PARAMETERS = ("results_path", "figures_dir")
#: Numbers in the results count as changed when they differ by more than this, relatively ...
REL_TOL = 1e-6
#: ... and by more than this absolutely (round-off around zero is not a change).
ABS_TOL = 1e-12
#: Exit status for bad usage or bad parameters (nothing executed), and for a failed notebook.
EXIT_BAD_INPUT = 2
EXIT_FAILED = 1

USAGE = """usage: python -m pkmlib.tools.rerun NB [-p NAME VALUE]... [-y YAML] [-f YAML_FILE] [-o OUT_DIR] [--kernel NAME]

  NB               notebook stem (p1_gripper_4prr) or path to a .ipynb
  -p NAME VALUE    set one parameter (value read as papermill does; [..] is a list)
  -y YAML          set parameters from YAML text, e.g. -y "branch: [1, -1, 1]"
  -f YAML_FILE     set parameters from a YAML file
  -o OUT_DIR       where to write (default: runs/<NB>/ beside notebooks/)
  --kernel NAME    Jupyter kernel (default: python3)
  --list           list the notebook's parameters and their paper values, run nothing
"""


class RerunError(Exception):
    """A problem found before (or while) executing: printed as one message, non-zero exit."""

    def __init__(self, message: str, status: int = EXIT_BAD_INPUT):
        super().__init__(message)
        self.status = status


# ----------------------------------------------------------------------------- values


def load_yaml(text: str | bytes, what: str) -> Any:
    """YAML text (``-y``, ``-f``, a bracketed ``-p`` value) read by :func:`pkmlib._safe_yaml.load`:
    size and alias limits, duplicate keys, tags and empty values refused, naming ``what``."""
    try:
        return _safe_yaml.load(text, what)
    except _safe_yaml.YamlError as e:
        raise _YamlRefused(str(e), syntax=e.syntax) from None


class _YamlRefused(RerunError):
    def __init__(self, message: str, syntax: bool):
        super().__init__(message)
        self.syntax = syntax


def parse_value(text: str) -> Any:
    """A ``-p`` value as papermill reads it (``True``/``False``/``None``, int, float, else a
    string), plus lists and mappings written in brackets (``[1, -1, 1]``)."""
    if text == "True":
        return True
    if text == "False":
        return False
    if text == "None":
        return None
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        pass
    stripped = text.strip()
    if stripped[:1] in "[{" and stripped[-1:] in "]}":
        try:
            return load_yaml(stripped, "value")
        except _YamlRefused as e:
            if e.syntax:  # not YAML: the text itself (the notebook's check says what it expects)
                return text
            raise
    return text


# ----------------------------------------------------------------------------- notebooks


def resolve_notebook(name: str, cwd: Path | None = None) -> Path:
    """``name`` as a path (``notebooks/p1_gripper_4prr.ipynb``) or a stem (``p1_gripper_4prr``)."""
    cwd = Path.cwd() if cwd is None else cwd
    candidates = [
        Path(name),
        cwd / name,
        cwd / "notebooks" / name,
        Path(__file__).resolve().parents[2] / "notebooks" / name,
    ]
    for c in candidates:
        for path in (c, c.with_name(c.name + ".ipynb")) if c.suffix != ".ipynb" else (c,):
            if path.is_file():
                return path.resolve()
    folder = next((c.parent for c in candidates[2:] if c.parent.is_dir()), None)
    known = sorted(p.stem for p in folder.glob("*.ipynb")) if folder else []
    hint = f"; notebooks: {', '.join(known)}" if known else ""
    raise RerunError(f"notebook {name!r} not found{hint}")


def _code(cell) -> str:
    """A code cell's source with IPython magics and shell lines blanked (so :mod:`ast` reads it)."""
    lines = cell.source.splitlines() if isinstance(cell.source, str) else "".join(cell.source).splitlines()
    return "\n".join("" if line.lstrip().startswith(("%", "!")) else line for line in lines)


def parameters_cell_index(nb) -> int:
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "code" and "parameters" in cell.get("metadata", {}).get("tags", []):
            return i
    raise RerunError("the notebook has no cell tagged 'parameters': nothing can be set")


@dataclass(frozen=True)
class NotALiteral:
    """A default the parameters cell computes (not a literal): shown as its source."""

    source: str

    def __repr__(self) -> str:
        return self.source


def notebook_parameters(nb) -> dict[str, Any]:
    """Names and default values of the ``parameters`` cell, in order, read with :mod:`ast`.

    Each top-level assignment ``name = value`` (or ``name: type = value``) is one parameter;
    comments may hold anything (papermill's reader drops a line with a second ``=`` in its
    comment). A value that is not a Python literal comes back as :class:`NotALiteral`.
    """
    cell = nb.cells[parameters_cell_index(nb)]
    source = _code(cell)
    try:
        tree = ast.parse(source)
    except SyntaxError as e:
        raise RerunError(f"the parameters cell is not valid Python: {e}") from None
    found: dict[str, Any] = {}
    for node in tree.body:
        if isinstance(node, ast.Assign):
            targets, value = node.targets, node.value
        elif isinstance(node, ast.AnnAssign) and node.value is not None:
            targets, value = [node.target], node.value
        else:
            continue
        for target in targets:
            if isinstance(target, ast.Name):
                try:
                    found[target.id] = ast.literal_eval(value)
                except (ValueError, TypeError, SyntaxError, RecursionError):
                    found[target.id] = NotALiteral(ast.get_source_segment(source, value) or "?")
    return found


def check_names(given: Sequence[str], defaults: dict[str, Any], notebook: str) -> None:
    """Reject names the notebook does not have (or that the re-run sets itself)."""
    unknown = [n for n in given if n not in defaults]
    valid = [n for n in defaults if n not in OUTPUT_PARAMETERS]
    if unknown:
        lines = []
        for n in unknown:
            close = difflib.get_close_matches(n, valid, n=1)
            lines.append(f"unknown parameter {n!r}" + (f" (did you mean {close[0]!r}?)" if close else ""))
        raise RerunError(f"{notebook}: " + "; ".join(lines) + f". Valid parameters: {', '.join(valid)}")
    own = [n for n in given if n in OUTPUT_PARAMETERS]
    if own:
        raise RerunError(
            f"{notebook}: {', '.join(own)} is set by the re-run (it writes into the output "
            f"folder; choose that with -o). Valid parameters: {', '.join(valid)}"
        )


def _is_pure_check(stmt: ast.stmt) -> bool:
    """Whether ``stmt`` only tests and raises (``if not q_min_m < q_max_m: raise ValueError(...)``,
    a ``for`` over names doing that): the checks a notebook writes after its ``check_parameters``."""
    if isinstance(stmt, ast.Raise):
        return True
    if isinstance(stmt, ast.If):
        return all(_is_pure_check(s) for s in stmt.body + stmt.orelse)
    if isinstance(stmt, ast.For):
        return (
            not stmt.orelse
            and all(isinstance(n, ast.Name) for n in ast.walk(stmt.target) if not isinstance(n, (ast.Tuple, ast.Store)))
            and all(_is_pure_check(s) for s in stmt.body)
        )
    return False


def _check_call(nb, start: int):
    """The ``check_parameters(...)`` call in the first code cells after ``parameters``, with the
    import statements and the constant assignments (upper-case names, such as ``SPEC = {...}``)
    before it (to evaluate it here), and the pure checks (:func:`_is_pure_check`) right after it
    in the same cell."""
    imports: list[ast.stmt] = []
    for cell in nb.cells[start:]:
        if cell.cell_type != "code":
            continue
        try:
            tree = ast.parse(_code(cell))
        except SyntaxError:
            return None
        for stmt in tree.body:
            if isinstance(stmt, (ast.Import, ast.ImportFrom)) or (
                isinstance(stmt, ast.Assign) and all(isinstance(t, ast.Name) and t.id.isupper() for t in stmt.targets)
            ):
                imports.append(stmt)
            for node in ast.walk(stmt):
                if isinstance(node, ast.Call):
                    f = node.func
                    if (isinstance(f, ast.Attribute) and f.attr == "check_parameters") or (
                        isinstance(f, ast.Name) and f.id == "check_parameters"
                    ):
                        rest = tree.body[tree.body.index(stmt) + 1 :]
                        checks = []
                        for later in rest:
                            if not _is_pure_check(later):
                                break
                            checks.append(later)
                        return imports, node, checks
    return None


def find_check_call(nb) -> ast.Call | None:
    """The notebook's ``check_parameters(...)`` call after its ``parameters`` cell, if it has one."""
    found = _check_call(nb, parameters_cell_index(nb) + 1)
    return None if found is None else found[1]


def precheck(nb, values: dict[str, Any]) -> bool:
    """Evaluate the notebook's own ``check_parameters(globals(), {...})`` on ``values`` here,
    before starting a kernel. Returns False (and checks nothing) when the notebook has no such
    call or its spec needs the notebook's own variables; raises :class:`RerunError` with the
    check's message when a value is not accepted."""
    if any(isinstance(v, NotALiteral) for v in values.values()):
        return False
    found = _check_call(nb, parameters_cell_index(nb) + 1)
    if found is None:
        return False
    imports, call, checks = found
    namespace: dict[str, Any] = {}
    try:
        exec(compile(ast.Module(body=imports, type_ignores=[]), "<notebook imports>", "exec"), namespace)
        namespace.update(values)  # the notebook's globals at that point: its parameters
        namespace["globals"] = lambda: dict(values)
        expression = ast.Expression(body=call)
        ast.fix_missing_locations(expression)
        code = compile(expression, "<notebook check_parameters>", "eval")
        after = compile(
            ast.fix_missing_locations(ast.Module(body=checks, type_ignores=[])), "<notebook checks>", "exec"
        )
    except Exception:  # an import this process cannot do: the notebook will check
        return False
    try:
        eval(code, namespace)
        exec(after, namespace)  # the checks the notebook makes right after the call
    except (NameError, AttributeError, ImportError, TypeError, KeyError):
        return False  # the spec uses the notebook's own variables: the notebook checks them
    except ValueError as e:
        raise RerunError(f"{type(e).__name__}: {e}") from None
    return True


# ----------------------------------------------------------------------------- execution


@dataclass
class Run:
    """One re-run: where things are. ``out`` is where the completed run goes; ``work`` (beside it,
    ``<out>.incomplete-<time>/``) is where it is written until it completes."""

    notebook: Path
    out: Path
    given: dict[str, Any]
    defaults: dict[str, Any]
    command: str = ""
    paths: dict[str, Path] = field(default_factory=dict)
    work: Path | None = None

    @property
    def stem(self) -> str:
        return self.notebook.stem

    @property
    def dir(self) -> Path:
        """The folder being written: ``work`` while the run is under way, else ``out``."""
        return self.work if self.work is not None else self.out

    @property
    def executed(self) -> Path:
        return self.dir / self.notebook.name

    def final(self, path: Path) -> Path:
        """Where ``path`` (in :attr:`dir`) will be once the run is in place at ``out``."""
        try:
            return self.out / Path(path).relative_to(self.dir)
        except ValueError:
            return Path(path)

    def paper_path(self, name: str) -> Path | None:
        """Where the paper's run writes output parameter ``name`` (its default, relative to the
        notebook's folder, which is the working directory of a run)."""
        default = self.defaults.get(name)
        return (self.notebook.parent / default).resolve() if isinstance(default, str) else None

    def injected(self) -> dict[str, Any]:
        """``given`` plus the output parameters, pointing into :attr:`dir` (relative to notebooks/)."""
        params = dict(self.given)
        if "results_path" in self.defaults:
            self.paths["results_path"] = self.dir / "results.json"
        if "figures_dir" in self.defaults:
            self.paths["figures_dir"] = self.dir / "figures"
        for name, path in self.paths.items():
            params[name] = os.path.relpath(path, self.notebook.parent)
        return params


def _check_output_folder(run: Run) -> None:
    """Refuse an output folder where the re-run would overwrite the paper's run or the notebooks."""
    out = run.out.resolve()
    paper = {run.paper_path("results_path"), run.paper_path("figures_dir")} - {None}
    mine = {out / "results.json", out / "figures"}
    if out in (run.notebook.parent.resolve(), run.notebook.parent.parent.resolve()) or paper & mine:
        raise RerunError(
            f"output folder {out}: the re-run would overwrite the paper's run or the notebooks "
            f"there; choose another (default: runs/{run.stem}/)"
        )


def check_kernel(name: str) -> None:
    """Refuse a ``--kernel`` that Jupyter does not know, before anything is written."""
    from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel

    manager = KernelSpecManager()
    try:
        manager.get_kernel_spec(name)
    except NoSuchKernel:
        known = ", ".join(sorted(manager.find_kernel_specs())) or "none"
        raise RerunError(
            f"no such kernel {name!r} (--kernel)\nnothing was run or changed; the kernels here: "
            f"{known} (see `jupyter kernelspec list`)"
        ) from None


def _record_final_paths(nb, run: Run) -> None:
    """In the executed notebook of a completed run, name the output paths where they will be (in
    ``out``), not where they were written (``work``): the injected-parameters cell and papermill's
    record of the parameters."""
    if run.work is None:
        return
    here = run.notebook.parent
    swap = {os.path.relpath(p, here): os.path.relpath(run.final(p), here) for p in run.paths.values()}
    params = nb.metadata.get("papermill", {}).get("parameters", {})
    for name, value in list(params.items()):
        if isinstance(value, str) and value in swap:
            params[name] = swap[value]
    for cell in nb.cells:
        if "injected-parameters" in cell.get("metadata", {}).get("tags", []):
            for old, new in swap.items():
                cell.source = cell.source.replace(repr(old), repr(new)).replace(json.dumps(old), json.dumps(new))


def execute(run: Run, kernel: str) -> None:
    """Execute the notebook with papermill into ``run.executed`` (in the run's own folder, so no
    temporary file is needed; it is kept up to the error on failure)."""
    import nbformat
    import papermill
    from papermill.exceptions import PapermillExecutionError
    from papermill.iorw import load_notebook_node
    from papermill.parameterize import parameterize_notebook
    from jupyter_client.manager import KernelManager

    nb = load_notebook_node(str(run.notebook))
    params = run.injected()
    # Parameterize here (not in papermill.execute_notebook, whose name check misreads comments).
    nb = parameterize_notebook(nb, params, kernel_name=kernel, language="python")
    executed = run.executed
    nbformat.write(nb, executed)
    error: PapermillExecutionError | None = None
    try:
        with tempfile.TemporaryDirectory(prefix="pkmlib-kernel-") as sockets:
            # Local sockets (IPC), not TCP: nothing listens on the network, and ipykernel has
            # no reason for its "running over TCP without encryption" warning.
            km = KernelManager(kernel_name=kernel, transport="ipc", ip=os.path.join(sockets, "kernel"))
            try:
                papermill.execute_notebook(
                    str(executed),
                    str(executed),
                    kernel_name=kernel,
                    language="python",
                    cwd=str(run.notebook.parent),
                    progress_bar=False,
                    request_save_on_cell_execute=False,
                    km=km,
                )
            except KeyboardInterrupt:  # SIGINT, SIGTERM (_run_folder.Interrupted)
                _stop_kernel_now(km)
                raise
            finally:  # nbclient leaves a kernel manager it was given running
                if km.has_kernel:
                    km.shutdown_kernel(now=True)
    except PapermillExecutionError as e:
        error = e
    result = nbformat.read(executed, as_version=4)
    meta = result.metadata.setdefault("papermill", {})
    meta["input_path"] = os.path.relpath(run.notebook)
    meta["output_path"] = os.path.relpath(run.final(executed) if error is None else executed)
    if error is None:
        _record_final_paths(result, run)
    atomic_write_text(executed, nbformat.writes(result) + "\n")
    if error is not None:
        if error.ename == "KeyboardInterrupt":
            raise _run_folder.Interrupted(signal.SIGINT)
        cell = f"In [{error.exec_count}]" if error.exec_count else f"cell {error.cell_index + 1}"
        cause = "disk full: " if "[Errno 28]" in str(error.evalue) else ""
        raise _CellFailed(f"{cause}{run.stem} stopped in {cell}: {error.ename}: {error.evalue}")


def _stop_kernel_now(km) -> None:
    """After an interrupt: kill the kernel's process and cancel nbclient's waiting tasks, without
    running its event loop again (a task left in it would wait for the kernel's reply forever)."""
    import asyncio
    import contextlib

    from jupyter_core.utils import ensure_event_loop

    process = getattr(km.provisioner, "process", None)
    if process is not None and process.poll() is None:
        with contextlib.suppress(OSError):
            process.kill()
        with contextlib.suppress(Exception):
            process.wait(timeout=10)
    if km.provisioner is not None:
        km.provisioner.process = None  # has_kernel is now False: no shutdown request is sent
    with contextlib.suppress(Exception):
        km.cleanup_connection_file()
    loop = ensure_event_loop()
    tasks = [t for t in asyncio.all_tasks(loop) if not t.done()]
    for t in tasks:
        t.cancel()
    if tasks and not loop.is_running():
        with contextlib.suppress(BaseException):
            loop.run_until_complete(asyncio.wait(tasks, timeout=5))
    for t in tasks:  # retrieved, so asyncio does not print "Task exception was never retrieved"
        if t.done() and not t.cancelled():
            t.exception()


class _CellFailed(Exception):
    """A cell of the notebook raised (its first line is the message)."""


# ----------------------------------------------------------------------------- changes.md

_UNIT_WORDS = {
    "m": "m",
    "mm": "mm",
    "deg": "deg",
    "rad": "rad",
    "s": "s",
    "N": "N",
    "m2": "m²",
    "mm2": "mm²",
    "mm3": "mm³",
    "m3": "m³",
    "mm4": "mm⁴",
    "MPa": "MPa",
    "Hz": "Hz",
    "kg": "kg",
}
_UNIT_PAIRS = {
    ("m", "s"): "m/s",
    ("mm", "s"): "mm/s",
    ("rad", "s"): "rad/s",
    ("mm", "s2"): "mm/s²",
    ("m", "s2"): "m/s²",
    ("rad", "s2"): "rad/s²",
    ("N", "m"): "N m",
    ("N", "mm"): "N mm",
    ("kg", "m2"): "kg m²",
}


def unit_of_key(key: str) -> str:
    """The unit a results key names by its suffix (``max_carriage_velocity_m_s`` -> ``m/s``,
    ``max_gripper_force_N_no_load`` -> ``N``, ``k_worst_N_mm`` -> ``N/mm``, a rate
    ``atlas_pairs_per_s`` -> ``pairs/s``), or ``""``."""
    tokens = key.split("_")
    for i in range(len(tokens) - 1, 0, -1):  # the first token is the quantity's symbol, not a unit
        t = tokens[i]
        if i >= 2 and tokens[i - 1] == "per" and t in _UNIT_WORDS:  # a count per unit
            return f"{tokens[i - 2]}/{_UNIT_WORDS[t]}"
        if i >= 2 and (tokens[i - 1], t) in _UNIT_PAIRS:
            unit = _UNIT_PAIRS[(tokens[i - 1], t)]
            return "N/mm" if unit == "N mm" and tokens[0] == "k" else unit  # stiffness k: force per length
        if t in _UNIT_WORDS or t == "s2":
            return _UNIT_WORDS.get(t, "")
    return ""


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _is_leaf(v: Any) -> bool:
    if isinstance(v, dict):
        return False
    if isinstance(v, list):
        return all(_is_leaf(x) and not isinstance(x, list) for x in v) or (
            all(isinstance(x, list) and all(not isinstance(y, (list, dict)) for y in x) for x in v)
        )
    return True


def numbers_differ(a: Any, b: Any) -> bool:
    """Whether two numbers differ by more than ``REL_TOL`` relatively and ``ABS_TOL`` absolutely
    (NaN equals NaN; a number never equals None)."""
    a, b = float(a), float(b)
    if math.isnan(a) or math.isnan(b):
        return not (math.isnan(a) and math.isnan(b))
    if math.isinf(a) or math.isinf(b):
        return a != b
    d = abs(a - b)
    return d > ABS_TOL and d > REL_TOL * max(abs(a), abs(b))


def values_differ(a: Any, b: Any) -> bool:
    if _is_number(a) and _is_number(b):
        return numbers_differ(a, b)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) != len(b) or any(values_differ(x, y) for x, y in zip(a, b))
    return type(a) is not type(b) or a != b


def _fmt(v: Any, limit: int = 8) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return str(v).lower()
    if _is_number(v):
        return f"{v:.8g}"
    if isinstance(v, str):
        return v if len(v) <= 60 else v[:57] + "..."
    if isinstance(v, list):
        shown = ", ".join(_fmt(x, limit) for x in v[:limit])
        return f"[{shown}{', ...' if len(v) > limit else ''}]" + (f" ({len(v)} entries)" if len(v) > limit else "")
    return repr(v)


def _relative_change(a: Any, b: Any) -> str:
    if _is_number(a) and _is_number(b) and a != 0 and math.isfinite(a) and math.isfinite(b):
        return f"{(b - a) / abs(a):+.3g}"
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b) and a:
        rel = [
            abs(y - x) / abs(x)
            for x, y in zip(a, b)
            if _is_number(x) and _is_number(y) and x != 0 and math.isfinite(x) and math.isfinite(y)
        ]
        n = sum(values_differ(x, y) for x, y in zip(a, b))
        if rel:
            return f"{n} of {len(a)} entries; largest {max(rel):.3g}"
    return ""


def walk_results(old: Any, new: Any, path: str = "", unit: str = ""):
    """Yield ``(path, unit, old, new)`` for every leaf of two results trees (``None`` where a key is
    absent in one of them; a list of plain values is one leaf)."""
    _absent = _ABSENT
    if isinstance(old, dict) or isinstance(new, dict):
        if not (isinstance(old, dict) and isinstance(new, dict)):
            yield path, unit, old, new
            return
        for key in list(old) + [k for k in new if k not in old]:
            yield from walk_results(
                old.get(key, _absent), new.get(key, _absent), f"{path}.{key}" if path else key, unit_of_key(key) or unit
            )
        return
    if isinstance(old, list) and isinstance(new, list) and not (_is_leaf(old) and _is_leaf(new)):
        for i in range(max(len(old), len(new))):
            a = old[i] if i < len(old) else _absent
            b = new[i] if i < len(new) else _absent
            label = next((r.get("quantity") for r in (a, b) if isinstance(r, dict) and r.get("quantity")), None)
            yield from walk_results(a, b, f"{path}[{i}]" + (f" ({label})" if label else ""), unit)
        return
    yield path, unit, old, new


class _Absent:
    def __repr__(self) -> str:
        return "absent"


_ABSENT = _Absent()


def changed_results(old: dict, new: dict, skip: Sequence[str] = ("parameters",)) -> tuple[list, int]:
    """Changed leaves ``(path, unit, old, new)`` and the number of leaves compared."""
    rows, n = [], 0
    for path, unit, a, b in walk_results(
        {k: v for k, v in old.items() if k not in skip}, {k: v for k, v in new.items() if k not in skip}
    ):
        n += 1
        if a is _ABSENT or b is _ABSENT or values_differ(a, b):
            rows.append((path, unit, a, b))
    return rows, n


def images_differ(a: Path, b: Path) -> bool:
    """Whether two PNG files differ in size or in any pixel (metadata ignored)."""
    import matplotlib.image as mpimg
    import numpy as np

    x, y = mpimg.imread(a), mpimg.imread(b)
    return x.shape != y.shape or not np.array_equal(x, y)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def changes_markdown(run: Run) -> str:
    """The text of ``changes.md`` for a finished run."""
    from .._notebook_parameters import _equal

    md_dir = run.dir
    lines = [f"# Re-run of {run.stem}: what changed against the paper's run", ""]
    if run.command:
        lines += [f"Command: `{run.command}`", ""]
    lines += [
        f"Executed notebook: [{run.notebook.name}]({run.notebook.name}). Paper's run: the committed "
        f"notebook `{_rel(run.notebook, run)}`, its results and figures.",
        "",
    ]

    # parameters
    lines += ["## Parameters that differ from the paper's run", ""]
    differ = [(n, run.defaults.get(n), v) for n, v in run.given.items() if not _equal(v, run.defaults.get(n))]
    same = [n for n, v in run.given.items() if _equal(v, run.defaults.get(n))]
    if differ:
        lines += ["| parameter | paper's run | this run |", "|---|---|---|"]
        lines += [f"| `{n}` | {_cell(_fmt(a))} | {_cell(_fmt(b))} |" for n, a, b in differ]
    else:
        lines += ["None: every parameter has the paper's value (this is the paper's run)."]
    if same:
        lines += ["", f"Given with the paper's value: {', '.join(f'`{n}`' for n in same)}."]
    lines += [""]

    # results
    lines += ["## Results that changed", ""]
    paper_results = run.paper_path("results_path")
    new_results = run.paths.get("results_path")
    if paper_results is None or new_results is None:
        lines += ["This notebook writes no results file; see the figures below.", ""]
    elif not paper_results.is_file():
        lines += [f"No paper-run results at `{_rel(paper_results, run)}` to compare with.", ""]
    elif not new_results.is_file():
        lines += [f"The run wrote no results at `{_rel(run.final(new_results), run)}`.", ""]
    else:
        old, new = json.loads(paper_results.read_text()), json.loads(new_results.read_text())
        rows, n = changed_results(old, new)
        lines += [
            f"`{_rel(paper_results, run)}` (paper's run) against `{_rel(run.final(new_results), run)}` (this run). "
            f"Numbers count as changed when they differ by more than a relative {REL_TOL:g} (and an "
            f"absolute {ABS_TOL:g}). The `parameters` record is left out (see above). "
            f"Units are read from the keys' suffixes.",
            "",
        ]
        if rows:
            lines += [
                f"{len(rows)} of {n} results changed:",
                "",
                "| result | paper's run | this run | unit | relative change |",
                "|---|---|---|---|---|",
            ]
            lines += [
                f"| `{_cell(p)}` | {_cell(_fmt(a))} | {_cell(_fmt(b))} | {u} | {_relative_change(a, b)} |"
                for p, u, a, b in rows
            ]
        else:
            lines += [f"None of the {n} results changed."]
        lines += [""]

    # figures
    lines += ["## Figures that changed", ""]
    paper_figures = run.paper_path("figures_dir")
    new_figures = run.paths.get("figures_dir")
    made = sorted(new_figures.glob("*.png")) if new_figures and new_figures.is_dir() else []
    if not made:
        lines += ["The run saved no figures.", ""]
    else:
        unchanged, new_only, changed = [], [], []
        for f in made:
            old = paper_figures / f.name if paper_figures else None
            if old is None or not old.is_file():
                new_only.append(f)
            elif images_differ(old, f):
                changed.append((old, f))
            else:
                unchanged.append(f)
        lines += [
            f"A figure counts as changed when any pixel differs from the paper run's figure in "
            f"`{_rel(paper_figures, run) if paper_figures else '-'}`. {len(changed)} of {len(made)} changed.",
            "",
        ]
        for old, f in changed:
            lines += [
                f"### {f.stem}",
                "",
                "| paper's run | this run |",
                "|---|---|",
                f"| ![paper's run: {f.name}]({_link(old, md_dir)}) | ![this run: {f.name}]({_link(f, md_dir)}) |",
                "",
            ]
        if new_only:
            lines += [
                "New figures (no paper-run figure of that name): "
                + ", ".join(f"[{f.name}]({_link(f, md_dir)})" for f in new_only)
                + ".",
                "",
            ]
        if unchanged:
            lines += ["Unchanged: " + ", ".join(f"`{f.name}`" for f in unchanged) + ".", ""]
    return "\n".join(lines).rstrip() + "\n"


def _rel(path: Path, run: Run) -> str:
    """``path`` relative to the repository (the folder above notebooks/) where possible."""
    root = run.notebook.parent.parent
    try:
        return str(path.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(path)


def _link(path: Path, md_dir: Path) -> str:
    return Path(os.path.relpath(path.resolve(), md_dir.resolve())).as_posix()


def write_changes(run: Run) -> Path:
    path = run.dir / "changes.md"
    atomic_write_text(path, changes_markdown(run))
    return path


# ----------------------------------------------------------------------------- command line


@dataclass
class Arguments:
    notebook: str = ""
    pairs: list[tuple[str, str]] = field(default_factory=list)
    yaml_texts: list[tuple[str, str | bytes]] = field(default_factory=list)
    out: str | None = None
    kernel: str = "python3"
    precheck: bool = True
    list_only: bool = False


def parse_arguments(argv: Sequence[str]) -> Arguments:
    """Read the command line by hand: ``-p NAME VALUE`` takes the next two words as they are
    (argparse would read a value such as ``-1e-3`` as an option)."""
    a = Arguments()
    argv = list(argv)
    i = 0

    def take(n: int, flag: str) -> list[str]:
        nonlocal i
        if i + n > len(argv) - 1:
            raise RerunError(f"{flag} needs {n} value{'s' if n > 1 else ''}\n{USAGE}")
        words = argv[i + 1 : i + 1 + n]
        i += n
        return words

    while i < len(argv):
        w = argv[i]
        if w in ("-h", "--help"):
            raise RerunError(USAGE, 0)
        elif w in ("-p", "--parameters"):
            name, value = take(2, w)
            a.pairs.append((name, value))
        elif w in ("-y", "--parameters_yaml"):
            a.yaml_texts.append(("-y", take(1, w)[0]))
        elif w in ("-f", "--parameters_file"):
            path = Path(take(1, w)[0])
            what = f"-f {path}"
            try:
                a.yaml_texts.append((what, _safe_yaml.read_file(path, what)))
            except _safe_yaml.YamlError as e:
                raise RerunError(str(e)) from None
        elif w in ("-o", "--out"):
            a.out = take(1, w)[0]
        elif w == "--kernel":
            a.kernel = take(1, w)[0]
        elif w == "--no-precheck":
            a.precheck = False
        elif w == "--list":
            a.list_only = True
        elif w.startswith("-") and len(w) > 1:
            raise RerunError(f"unknown option {w!r}\n{USAGE}")
        elif not a.notebook:
            a.notebook = w
        else:
            raise RerunError(f"one notebook at a time; got {a.notebook!r} and {w!r}\n{USAGE}")
        i += 1
    if not a.notebook:
        raise RerunError(USAGE)
    return a


def given_parameters(a: Arguments) -> dict[str, Any]:
    """The parameters in command-line order (later ones win, as in papermill)."""
    given: dict[str, Any] = {}
    for what, text in a.yaml_texts:
        data = load_yaml(text, what)
        if data is None:
            raise RerunError(f"{what}: empty (no parameters in it); write 'name: value' lines")
        if not isinstance(data, dict):
            raise RerunError(f"{what}: expected a mapping such as 'name: value', got {_short(data)}")
        for k in data:
            if not isinstance(k, str):
                raise RerunError(f"{what}: parameter names are text, got {k!r}")
        given.update(data)
    for name, value in a.pairs:
        if not value.strip():
            raise RerunError(f"-p {name}: an empty value; write its value, or leave {name} out for the paper's value")
        given[name] = parse_value(value)
    return given


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def rerun(argv: Sequence[str]) -> Path:
    """Do a re-run; return the path of ``changes.md``. Raises :class:`RerunError`: status 2 when
    nothing was run or changed, 1 when a run failed, 128 + the signal when it was interrupted."""
    import nbformat

    a = parse_arguments(argv)
    path = resolve_notebook(a.notebook)
    try:
        nb = nbformat.read(path, as_version=4)
    except Exception as e:  # noqa: BLE001 - any unreadable notebook
        raise RerunError(f"cannot read {path}: {e}") from None
    defaults = notebook_parameters(nb)
    if a.list_only:
        width = max(map(len, defaults), default=0)
        print("\n".join(f"{n:<{width}}  {v!r}" for n, v in defaults.items() if n not in OUTPUT_PARAMETERS))
        raise RerunError("", 0)
    given = given_parameters(a)
    check_names(list(given), defaults, path.stem)
    out = Path(a.out) if a.out else path.parent.parent / "runs" / path.stem
    run = Run(
        path,
        Path(os.path.abspath(out)),
        given,
        defaults,
        command="python -m pkmlib.tools.rerun " + " ".join(shlex.quote(w) for w in argv),
    )
    _check_output_folder(run)
    if a.precheck:
        precheck(nb, {**defaults, **run.injected()})
    check_kernel(a.kernel)
    try:
        _run_folder.check_folder(run.out, run.stem)
        _run_folder.check_writable(run.out)
    except _run_folder.FolderError as e:
        raise RerunError(str(e)) from None
    os.environ.setdefault("JAX_PLATFORMS", "cpu")  # as `make` does; keeps the no-GPU warning out
    _kernel_imports_this_pkmlib()
    with _run_folder.interrupts_raise() as signals:
        try:
            with _run_folder.locked(run.out, run.command):
                _run_folder.check_folder(run.out, run.stem)  # again, now that no other run can write it
                run.work = _run_folder.new_incomplete_folder(run.out, f"a re-run of {run.stem}: {run.command}")
                try:
                    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
                    execute(run, a.kernel)
                    write_changes(run)
                    _run_folder.write_manifest(
                        run.work,
                        {
                            "notebook": run.stem,
                            "notebook_path": _rel(run.notebook, run),
                            "command": run.command,
                            "parameters": run.given,
                            "started": started,
                            "completed": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                        },
                    )
                    signals["armed"] = False  # from here on the run is complete: put it in place
                    _run_folder.install(run.work, run.out)
                except BaseException as e:  # noqa: BLE001 - every failure is reported, the run kept
                    raise _failed(run, e) from None
        except _run_folder.FolderError as e:  # the lock or the new folder: nothing was run
            raise RerunError(str(e)) from None
        except _run_folder.Interrupted as e:  # before the run's folder existed: nothing was run
            raise RerunError(
                f"interrupted ({signal.Signals(e.signum).name}) before {run.stem} started\nnothing was run or changed",
                128 + e.signum,
            ) from None
    return run.out / "changes.md"


def _failed(run: Run, e: BaseException) -> RerunError:
    """The two-line message for a run that started and did not complete (its folder ``run.work``
    is marked incomplete, saying why), and the exit status."""
    work = _shown(run.work) + "/"
    previous = (
        f"the previous run in {_shown(run.out)}/ is kept"
        if _run_folder.run_of(run.out)
        else f"nothing was in {_shown(run.out)}/ before"
    )
    kept = f"{previous}; this run's partial output is in {work} (marked {_run_folder.INCOMPLETE})"
    if isinstance(e, KeyboardInterrupt):
        signum = e.signum if isinstance(e, _run_folder.Interrupted) else signal.SIGINT
        cause, status = f"interrupted ({signal.Signals(signum).name}) while running {run.stem}", 128 + signum
    elif isinstance(e, _CellFailed):
        cause, status = str(e), EXIT_FAILED
        kept = f"the executed notebook, up to the error: {_shown(run.executed)} ({previous})"
    elif isinstance(e, OSError):
        where = f" ({_shown(Path(e.filename))})" if e.filename else ""
        cause, status = f"{_run_folder.os_cause(e)} while writing the run of {run.stem}{where}", EXIT_FAILED
    elif isinstance(e, RerunError):
        cause, status = str(e).splitlines()[0], EXIT_FAILED
    else:
        first = (str(e).strip().splitlines() or [""])[0][:200]
        cause, status = f"{run.stem} could not run: {type(e).__name__}" + (f": {first}" if first else ""), EXIT_FAILED
    _run_folder.mark_incomplete(run.work, cause)
    return RerunError(f"{cause}\n{kept}", status)


def _kernel_imports_this_pkmlib() -> None:
    """Put the folder holding this pkmlib first on the kernel's PYTHONPATH (the kernel inherits the
    environment), so the notebook runs with the same library as this command."""
    here = str(Path(__file__).resolve().parents[2])
    parts = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    if here not in parts:
        os.environ["PYTHONPATH"] = os.pathsep.join([here, *parts])


def main(argv: Sequence[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        with _run_folder.interrupts_raise():  # also while reading and checking, before the run
            changes = rerun(argv)
    except RerunError as e:
        message = str(e)
        if message:
            print(message if e.status == 0 else f"error: {message}", file=sys.stdout if e.status == 0 else sys.stderr)
        return e.status
    except KeyboardInterrupt as e:  # before the run started (a run reports its own interrupt)
        signum = getattr(e, "signum", signal.SIGINT)
        print(
            f"error: interrupted ({signal.Signals(signum).name}) before the run started\nnothing was run or changed",
            file=sys.stderr,
        )
        return 128 + signum
    run_dir = changes.parent
    print(f"wrote {_shown(run_dir)}/: the executed notebook, results and figures")
    print(f"what changed: {_shown(changes)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
