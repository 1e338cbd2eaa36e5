"""Where a re-run writes: a fresh folder, a lock, and a swap into place only once it completed.

A re-run into ``runs/<NB>/`` (or ``-o DIR``):

1. takes the lock ``runs/<NB>.lock`` (``fcntl.flock``, beside the folder; it names the holder).
   A second re-run into the same folder stops at once, naming the first (its pid, start time
   and command), and changes nothing;
2. checks the folder: missing, empty, or a run of the same notebook (marked by its manifest
   :data:`MANIFEST`, or, for runs made before manifests, by the first line of its
   ``changes.md``). Another notebook's run, a folder that is not a run, or a file are refused;
3. writes everything into a new folder beside it, ``runs/<NB>.incomplete-<time>/``, which holds
   the file :data:`INCOMPLETE` from its first moment (so even a killed run is marked);
4. once the run has completed (executed notebook, results, figures, ``changes.md``, manifest),
   removes ``INCOMPLETE`` and puts the folder in place of the previous run in two renames.

A run that fails or is interrupted leaves the previous run as it was and its own partial output
in the ``.incomplete-<time>`` folder, with the reason appended to ``INCOMPLETE``. The lock file is
removed when the run ends.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import shutil
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

#: The manifest every completed run folder holds: which notebook, when, with what.
MANIFEST = "pkmlib-run.json"
#: The marker of a run that did not complete (it says why, once known).
INCOMPLETE = "INCOMPLETE"


class FolderError(Exception):
    """A problem with the output folder: ``message`` (two lines: the cause, then what is kept or
    what to do) and ``cause`` (one of "busy", "not writable", "disk full", "not a folder",
    "not a run", "another notebook's run")."""

    def __init__(self, message: str, cause: str):
        super().__init__(message)
        self.cause = cause


def os_cause(e: OSError) -> str:
    """An OSError's cause in words: "disk full", "not writable", "not a folder", or its strerror."""
    if e.errno in (errno.ENOSPC, errno.EDQUOT):
        return "disk full"
    if e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "not writable"
    if e.errno in (errno.ENOTDIR, errno.EEXIST):
        return "not a folder"
    return e.strerror or type(e).__name__


def shown(path: Path) -> str:
    """``path`` relative to the working directory when it lies below it, else absolute."""
    try:
        rel = os.path.relpath(path)
    except ValueError:
        return str(path)
    return str(path) if rel.startswith("..") else rel


def _stamp() -> str:
    return time.strftime("%Y%m%d-%H%M%S")


# ----------------------------------------------------------------------------- what a folder holds


def run_of(folder: Path) -> str | None:
    """The notebook (stem) whose run ``folder`` holds, from its manifest or, for runs made before
    manifests, from the first line of its ``changes.md`` ("# Re-run of <stem>: ..."); else None."""
    manifest = folder / MANIFEST
    if manifest.is_file():
        try:
            name = json.loads(manifest.read_text()).get("notebook")
        except (OSError, ValueError, AttributeError):
            return None
        return name if isinstance(name, str) else None
    changes = folder / "changes.md"
    if changes.is_file():
        try:
            with open(changes, encoding="utf-8", errors="replace") as f:
                first = f.readline()
        except OSError:
            return None
        if first.startswith("# Re-run of ") and ":" in first:
            return first[len("# Re-run of ") :].split(":", 1)[0].strip() or None
    return None


def check_folder(out: Path, stem: str) -> None:
    """Refuse ``out`` unless it is missing, empty, or holds a run of ``stem`` (which a completed
    run replaces)."""
    if out.is_symlink():
        raise FolderError(
            f"{shown(out)} is not a folder (it is a symbolic link): give the folder itself\n"
            f"nothing was run or changed; choose a folder with -o DIR",
            "not a folder",
        )
    if out.exists() and not out.is_dir():
        raise FolderError(
            f"{shown(out)} is not a folder (it is a file)\nnothing was run or changed; choose a folder with -o DIR",
            "not a folder",
        )
    if not out.exists():
        if out.parent.exists() and not out.parent.is_dir():
            raise FolderError(
                f"{shown(out.parent)} is not a folder (it is a file)\n"
                f"nothing was run or changed; choose a folder with -o DIR",
                "not a folder",
            )
        return
    try:
        empty = not any(out.iterdir())
    except OSError as e:
        raise FolderError(f"cannot read {shown(out)}: {os_cause(e)}\nnothing was run or changed", os_cause(e)) from None
    if empty:
        return
    holder = run_of(out)
    if holder is None:
        raise FolderError(
            f"{shown(out)} is not a re-run's folder (it holds other files and no {MANIFEST})\n"
            f"nothing was run or changed; choose a new or empty folder with -o DIR",
            "not a run",
        )
    if holder != stem:
        raise FolderError(
            f"{shown(out)} holds a run of {holder}, not of {stem}\n"
            f"nothing was run or changed; choose another folder with -o DIR "
            f"(default: runs/{stem}/)",
            "another notebook's run",
        )


def check_writable(out: Path) -> None:
    """Refuse, before anything runs, when the folder beside which the run is written (or the
    previous run, which the new one replaces) cannot be written."""
    parent = out.parent
    while not parent.exists() and parent != parent.parent:
        parent = parent.parent
    for folder in (parent, out) if out.is_dir() else (parent,):
        if not os.access(folder, os.W_OK | os.X_OK):
            raise FolderError(
                f"{shown(folder)} is not writable\nnothing was run or changed; choose another folder with -o DIR",
                "not writable",
            )


# ----------------------------------------------------------------------------- the lock


def lock_path(out: Path) -> Path:
    return out.with_name(out.name + ".lock")


@contextlib.contextmanager
def locked(out: Path, holder: str) -> Iterator[Path]:
    """Hold the lock of ``out`` (``<out>.lock``, an ``flock`` on it) while the block runs; the lock
    file names the holder. Raises :class:`FolderError` (cause "busy") at once when another process
    holds it. The lock file is removed on leaving."""
    path = lock_path(out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise _folder_error(e, out.parent) from None
    fd = None
    for _ in range(20):  # the file locked must be the one at `path` (another run may remove it)
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise _folder_error(e, out.parent) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                with open(fd, closefd=False) as f:
                    who = f.read().strip().replace("\n", ", ") or "a process that has not written its name yet"
            finally:
                os.close(fd)
            raise FolderError(
                f"{shown(out)} is busy: another re-run is writing it ({who})\n"
                f"nothing was run or changed; wait for it to end, or write elsewhere with -o DIR",
                "busy",
            ) from None
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
        fd = None
    if fd is None:  # pragma: no cover - twenty lost races in a row
        raise FolderError(f"{shown(path)}: cannot take the lock\nnothing was run or changed", "busy")
    try:
        try:
            os.ftruncate(fd, 0)
            os.write(fd, f"pid {os.getpid()}, since {time.strftime('%Y-%m-%d %H:%M:%S')}: {holder}\n".encode())
        except OSError as e:
            raise _folder_error(e, out.parent) from None
        yield path
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)
        os.close(fd)


def _folder_error(
    e: OSError, where: Path, kept: str = "nothing was run or changed; choose another folder with -o DIR"
) -> FolderError:
    cause = os_cause(e)
    what = {
        "disk full": f"disk full: cannot write in {shown(where)}",
        "not writable": f"{shown(where)} is not writable",
        "not a folder": f"{shown(where)} is not a folder",
    }.get(cause, f"cannot write in {shown(where)}: {cause}")
    return FolderError(f"{what}\n{kept}", cause)


# ----------------------------------------------------------------------------- the new folder


def new_incomplete_folder(out: Path, about: str) -> Path:
    """A new, empty ``<out>.incomplete-<time>/`` beside ``out``, holding :data:`INCOMPLETE`
    (``about``: what runs there) from the start."""
    base = out.with_name(f"{out.name}.incomplete-{_stamp()}")
    for n in range(1, 1000):
        work = base if n == 1 else base.with_name(f"{base.name}-{n}")
        try:
            work.mkdir()
        except FileExistsError:
            continue
        except OSError as e:
            raise _folder_error(e, out.parent) from None
        try:
            (work / INCOMPLETE).write_text(
                f"This run did not complete: {about}\n"
                f"started {time.strftime('%Y-%m-%d %H:%M:%S')} by pid {os.getpid()}; its output goes to "
                f"{out} once it completes.\n"
                f"If no reason follows, it is still running or was killed.\n"
            )
        except OSError as e:
            shutil.rmtree(work, ignore_errors=True)
            raise _folder_error(e, out.parent) from None
        return work
    raise FolderError(
        f"too many incomplete runs beside {shown(out)}\nremove some of {shown(base)}-*", "busy"
    )  # pragma: no cover


def mark_incomplete(work: Path, reason: str) -> None:
    """Append why the run in ``work`` stopped to its :data:`INCOMPLETE` (best effort: on a full
    disk the marker written at the start stays)."""
    with contextlib.suppress(OSError), open(work / INCOMPLETE, "a", encoding="utf-8") as f:
        f.write(f"stopped {time.strftime('%Y-%m-%d %H:%M:%S')}: {reason}\n")


def write_manifest(work: Path, record: dict[str, Any]) -> None:
    from ._atomic import atomic_write_text

    atomic_write_text(work / MANIFEST, json.dumps(record, indent=2, default=repr) + "\n")


def install(work: Path, out: Path) -> None:
    """Put the completed run ``work`` in place of ``out`` (missing, empty, or the previous run,
    which is removed only once the new one is in place)."""
    (work / INCOMPLETE).unlink(missing_ok=True)
    try:
        if out.is_dir() and not any(out.iterdir()):
            out.rmdir()
        if not out.exists():
            os.rename(work, out)
            return
        old = out.with_name(f"{out.name}.replaced-{_stamp()}-{os.getpid()}")
        os.rename(out, old)
        try:
            os.rename(work, out)
        except BaseException:
            os.rename(old, out)
            raise
        shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        if work.exists():
            with contextlib.suppress(OSError):
                (work / INCOMPLETE).write_text("This run completed but could not be put in place.\n")
        raise


# ----------------------------------------------------------------------------- interrupts


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived while a run was being written (a KeyboardInterrupt, so no
    ``except Exception`` swallows it and asyncio, under papermill, passes it on at once)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextlib.contextmanager
def interrupts_raise() -> Iterator[dict]:
    """While the block runs, SIGINT and SIGTERM raise :class:`Interrupted` (once: a second signal
    during the clean-up is noted, not raised), so ``finally`` blocks run (the kernel is shut
    down, temporary files are removed). Yields a dict whose "armed" entry can be set False to
    defer signals (while the finished run is put in place); "signum" holds a deferred signal."""
    state: dict[str, Any] = {"armed": True, "signum": None}

    def handler(signum, frame):
        if state["armed"] and state["signum"] is None:
            state["signum"] = signum
            state["armed"] = False
            raise Interrupted(signum)
        state["signum"] = state["signum"] or signum

    previous = {}
    try:
        for s in (signal.SIGINT, signal.SIGTERM):
            previous[s] = signal.signal(s, handler)
    except ValueError:  # not the main thread: signals cannot be caught here
        previous = {}
    try:
        yield state
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


__all__ = [
    "INCOMPLETE",
    "MANIFEST",
    "FolderError",
    "Interrupted",
    "check_folder",
    "check_writable",
    "install",
    "interrupts_raise",
    "locked",
    "mark_incomplete",
    "new_incomplete_folder",
    "os_cause",
    "run_of",
    "shown",
    "write_manifest",
]
