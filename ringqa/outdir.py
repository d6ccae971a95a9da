"""Output that is never left half-written: output folders as transactions, atomic single files.

Every command writes its files into a hidden staging folder beside the target
(``.NAME.staging-PID-XXXX``) and, only when everything succeeded, puts that folder in the
target's place as a whole (:func:`staged_output`):

- a missing or empty target: the staging folder is renamed into place;
- a target an earlier ringqa run wrote (it holds the marker file :data:`MARKER_NAME`): the old
  folder is renamed aside (``.NAME.old-PID-XXXX``), the staging folder renamed into place and the
  old folder deleted, so no file of the earlier run survives next to the new ones;
- a non-empty target without the marker: refused before any work starts (:func:`check_writable`),
  since ringqa would otherwise delete files it did not write.

While the staging folder exists SIGTERM and SIGINT raise :class:`OutputInterrupted`, so the
staging folder is removed and the target stays as it was. Staging folders left by a process that
no longer runs (SIGKILL, power loss) are removed at the start of the next run into the same
target (:func:`remove_leftovers`).

A single file written on its own (an applicator file, a points file) goes through
:func:`atomic_write_text` / :func:`atomic_write_bytes`: a temporary file in the same folder,
flushed to disk, then renamed over the target, so readers see the old file or the new one,
never a part.
"""

from __future__ import annotations

import contextlib
import contextvars
import datetime as _dt
import json
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from ringqa.errors import RingQAError

#: the file that marks a folder as written by ringqa (replaced as a whole by the next run)
MARKER_NAME = ".ringqa-output.json"

#: the signals that, while a staging folder exists, end the run cleanly
HANDLED_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM)

_COMMAND: contextvars.ContextVar[str] = contextvars.ContextVar("ringqa_command", default="")


class OutputInterrupted(KeyboardInterrupt):
    """A signal (SIGTERM, SIGINT) arrived while an output folder was being written.

    A :class:`KeyboardInterrupt` (not an ``Exception``), so that code catching ``Exception``
    (a batch recording one applicator's failure) does not swallow it; the staging folder is
    removed on the way out.

    Parameters
    ----------
    signum : int
        The signal received.
    """

    #: True if the signal arrived just after the output folder was put in place
    output_complete: bool = False

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(f"{signal.Signals(self.signum).name} received")

    @property
    def exit_status(self) -> int:
        """The conventional exit status of a process ended by this signal (128 + number)."""
        return 128 + self.signum


@dataclass(frozen=True)
class FolderState:
    """What an output folder holds, as far as replacing it is concerned.

    Attributes
    ----------
    kind : {"missing", "empty", "ringqa", "foreign"}
        ``ringqa``: it holds the marker of an earlier run (or only files of ``ours``);
        ``foreign``: it holds other files.
    example : str or None
        For ``foreign``: the name of one file ringqa did not write (for the message).
    """

    kind: Literal["missing", "empty", "ringqa", "foreign"]
    example: str | None = None


@dataclass(frozen=True)
class Leftover:
    """A hidden folder beside a target left by an earlier process.

    Attributes
    ----------
    path : Path
        The folder.
    role : {"staging", "old"}
        ``staging``: an unfinished output; ``old``: an earlier output renamed aside.
    pid : int
        The process that created it.
    """

    path: Path
    role: Literal["staging", "old"]
    pid: int


@contextlib.contextmanager
def running_command(name: str) -> Iterator[None]:
    """Name the command being run (recorded in the marker file of the folders it writes)."""
    token = _COMMAND.set(name)
    try:
        yield
    finally:
        _COMMAND.reset(token)


def marker_record() -> dict:
    """The content of :data:`MARKER_NAME`: software, version, command, date, process id."""
    from ringqa import __version__

    return {
        "software": "ringqa",
        "version": __version__,
        "command": _COMMAND.get() or "python API",
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "pid": os.getpid(),
    }


def has_marker(folder: Path) -> bool:
    """True if ``folder`` holds a readable ringqa marker file."""
    path = folder / MARKER_NAME
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("software") == "ringqa"


def folder_state(out: Path, ours: Iterable[str] = ()) -> FolderState:
    """Classify the output folder ``out`` (see :class:`FolderState`).

    Parameters
    ----------
    out : Path
        The target folder (a missing one is ``missing``).
    ours : iterable of str
        Names the running command itself keeps in the folder while it works (the accuracy
        study's run cache): a folder holding only these counts as ringqa's.
    """
    if not out.exists():
        return FolderState("missing")
    names = sorted(p.name for p in out.iterdir())
    if not names:
        return FolderState("empty")
    if has_marker(out):
        return FolderState("ringqa")
    other = [n for n in names if n not in set(ours)]
    if not other:
        return FolderState("ringqa")
    return FolderState("foreign", other[0])


def foreign_message(out: Path, example: str | None) -> str:
    """The one-line refusal for a non-empty folder ringqa did not write."""
    return (
        f"--out {out}: holds files ringqa did not write (e.g. {example}); choose an empty or new "
        "folder, or a folder an earlier ringqa run wrote"
    )


def _leftover_pattern(name: str) -> re.Pattern[str]:
    return re.compile(rf"^\.{re.escape(name)}\.(staging|old)-(\d+)-.+$")


def find_leftovers(out: Path) -> list[Leftover]:
    """Hidden staging / set-aside folders beside ``out`` whose creating process is gone."""
    parent = _parent(out)
    if not parent.is_dir():
        return []
    pattern = _leftover_pattern(out.name)
    found = []
    for p in sorted(parent.iterdir()):
        m = pattern.match(p.name)
        if m and p.is_dir() and not p.is_symlink() and not pid_alive(int(m.group(2))):
            found.append(Leftover(p, m.group(1), int(m.group(2))))  # type: ignore[arg-type]
    return found


def pid_alive(pid: int) -> bool:
    """True if a process with this id exists (it may belong to another user)."""
    if pid <= 0:
        return False
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except OSError:
        return False
    return True


def remove_leftovers(out: Path, say: Callable[[str], None] | None = None) -> list[Leftover]:
    """Remove staging folders beside ``out`` left by processes that no longer run.

    A set-aside earlier output (``.NAME.old-PID-XXXX``, left when a run died between its two
    renames) is put back in place if ``out`` is missing, else removed. Each action is reported in
    one line through ``say`` (default: standard error).

    Returns
    -------
    list of Leftover
        What was found (and removed or restored).
    """
    say = say or _say
    found = find_leftovers(out)
    for item in found:
        if item.role == "old" and not out.exists():
            os.rename(item.path, out)
            say(f"restored {out} from {item.path.name}, set aside by an interrupted run")
            continue
        shutil.rmtree(item.path, ignore_errors=True)
        what = "staging folder" if item.role == "staging" else "earlier output"
        say(f"removed left-over {what} {item.path} from an interrupted run (process {item.pid})")
    return found


def _say(line: str) -> None:
    print(f"ringqa: {line}", file=sys.stderr)


def _parent(out: Path) -> Path:
    return out.parent if str(out.parent) not in ("", ".") else Path(".")


def check_writable(out_dir: str | Path, *, ours: Iterable[str] = ()) -> Path:
    """Return ``out_dir`` as a Path after checking ringqa may write it (before any work).

    Also removes left-over staging folders of interrupted runs beside it
    (:func:`remove_leftovers`).

    Parameters
    ----------
    out_dir : str or Path
        The output folder.
    ours : iterable of str
        File names the command itself keeps in the folder (see :func:`folder_state`).

    Raises
    ------
    RingQAError
        If the folder is a file, not writable (nor its nearest existing parent), or holds files
        ringqa did not write.
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise RingQAError(f"--out {out}: exists and is not a folder (choose a folder path)")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise RingQAError(
            f"--out {out}: folder {probe} is not writable (choose a folder you can write to)"
        )
    state = folder_state(out, ours)
    if state.kind == "foreign":
        raise RingQAError(foreign_message(out, state.example))
    remove_leftovers(out)
    return out


@contextlib.contextmanager
def staged_output(out_dir: str | Path, *, ours: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a staging folder; on success it replaces ``out_dir`` as a whole.

    The folder is refused at entry if it holds files ringqa did not write
    (:func:`check_writable`). On success the marker file is added, the files named in ``ours``
    are carried over from the old folder (unless the block wrote them), and the staging folder
    takes the target's place (:func:`commit_folder`). On any exception, SIGTERM or SIGINT
    (:class:`OutputInterrupted`) the staging folder is removed and ``out_dir`` is untouched.

    Parameters
    ----------
    out_dir : str or Path
        The output folder.
    ours : iterable of str
        Files the command keeps in ``out_dir`` while it works (the accuracy study's run cache):
        not counted as foreign, and carried into the new folder.
    """
    ours = tuple(ours)
    out = check_writable(out_dir, ours=ours)
    parent = _parent(out)
    parent.mkdir(parents=True, exist_ok=True)
    stage: Path | None = None
    with _signals_raise():
        try:
            with _signals_blocked():
                stage = Path(tempfile.mkdtemp(prefix=staging_prefix(out), dir=parent))
            yield stage
            (stage / MARKER_NAME).write_text(json.dumps(marker_record(), indent=2) + "\n")
            carry_over(out, stage, ours)
            with _signals_blocked():
                commit_folder(stage, out, ours)
        except OutputInterrupted as exc:
            # a signal held back during the renames arrives after them: the output is complete
            exc.output_complete = stage is not None and not stage.exists()
            raise
        finally:
            if stage is not None:
                with _signals_blocked():
                    shutil.rmtree(stage, ignore_errors=True)


def staging_prefix(out: Path) -> str:
    """Name prefix of this process's staging folders for ``out`` (``.NAME.staging-PID-``)."""
    return f".{out.name}.staging-{os.getpid()}-"


def carry_over(out: Path, stage: Path, names: Iterable[str]) -> None:
    """Copy the files ``names`` from ``out`` into ``stage`` unless the stage already has them."""
    for name in names:
        src, dst = out / name, stage / name
        if src.is_file() and not dst.exists():
            shutil.copy2(src, dst)


def commit_folder(stage: Path, out: Path, ours: Iterable[str] = ()) -> None:
    """Put the finished staging folder ``stage`` in the place of ``out``.

    A missing or empty ``out`` is replaced by one rename. An earlier ringqa output is renamed
    aside, ``stage`` renamed into place (the old folder is put back if that fails) and the old
    folder deleted.

    Raises
    ------
    RingQAError
        If ``out`` came to hold files ringqa did not write while the command ran.
    OSError
        If a rename fails (``out`` is then as it was).
    """
    state = folder_state(out, ours)
    if state.kind == "foreign":
        raise RingQAError(foreign_message(out, state.example))
    if state.kind in ("missing", "empty"):
        os.replace(stage, out)  # POSIX: replaces an empty folder in one step
        return
    aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-{os.getpid()}-", dir=_parent(out)))
    try:
        os.replace(out, aside)
    except BaseException:
        aside.rmdir()
        raise
    try:
        os.replace(stage, out)
    except BaseException:
        os.replace(aside, out)
        raise
    shutil.rmtree(aside, ignore_errors=True)


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


#: signals held back while folders are renamed or removed (see :func:`_signals_blocked`)
_HELD: dict[str, list[int] | bool] = {"active": False, "pending": []}


def _raise_interrupted(signum: int, frame) -> None:
    if _HELD["active"]:
        _HELD["pending"].append(signum)  # type: ignore[union-attr]
        return
    raise OutputInterrupted(signum)


@contextlib.contextmanager
def _signals_raise() -> Iterator[None]:
    """Make SIGTERM and SIGINT raise :class:`OutputInterrupted` (main thread only; a signal the
    process ignores stays ignored; the previous handlers are restored after)."""
    previous = {}
    if _in_main_thread():
        for sig in HANDLED_SIGNALS:
            old = signal.getsignal(sig)
            if old is None or old is signal.SIG_IGN:  # set from C, or ignored on purpose
                continue
            previous[sig] = old
            signal.signal(sig, _raise_interrupted)
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)


@contextlib.contextmanager
def _signals_blocked() -> Iterator[None]:
    """Hold SIGTERM and SIGINT back while folders are renamed or removed, so a signal cannot
    stop those steps half-way; one that arrived meanwhile is raised at the end of the block.

    The handler (which Python always runs in the main thread, whichever thread the operating
    system delivered the signal to) records the signal instead of raising while the block runs.
    """
    outer = _HELD["active"]
    _HELD["active"] = True
    try:
        yield
    finally:
        _HELD["active"] = outer
        pending = _HELD["pending"]
        if not outer and pending:
            _HELD["pending"] = []
            raise OutputInterrupted(pending[0])  # type: ignore[index]


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, mode: int = 0o644) -> Path:
    """Write ``data`` to ``path`` atomically: all of it or (on any error) nothing.

    The bytes go to a temporary file in the target's folder, which is flushed and fsync'ed and
    then renamed over ``path`` (``os.replace``, atomic on POSIX and Windows). On any exception the
    temporary file is removed and ``path`` is left as it was. The folder is created if needed.

    Parameters
    ----------
    path : str or path
        The file to write (replaced if it exists).
    data : bytes
        The whole content.
    mode : int
        Permission bits of the new file (``0o644``: readable by all, as files written with
        ``open()`` under the usual umask; the temporary file itself starts as ``0o600``).

    Returns
    -------
    Path
        ``path``.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def atomic_write_text(
    path: str | os.PathLike, text: str, *, encoding: str = "utf-8", mode: int = 0o644
) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`atomic_write_bytes`).

    Parameters
    ----------
    path : str or path
        The file to write (replaced if it exists).
    text : str
        The whole content, written as is (no newline translation).
    encoding : str
        Text encoding (UTF-8).
    mode : int
        Permission bits of the new file.

    Returns
    -------
    Path
        ``path``.
    """
    return atomic_write_bytes(path, text.encode(encoding), mode=mode)
