"""Output that is never left half-written: output folders as transactions, atomic single files.

Every command writes its files into a hidden staging folder beside the target
(``.NAME.staging-PID-XXXX``) and, only when everything succeeded, puts that folder in the
target's place as a whole (:func:`staged_output`):

- a missing or empty target: the staging folder is renamed into place;
- a target an earlier ringqa run wrote: its marker file :data:`MARKER_NAME` lists every file
  and folder that run wrote (relative path, size, SHA-256). If the folder holds nothing else
  and none of those files was changed, the old folder is renamed aside
  (``.NAME.old-PID-XXXX``), the staging folder renamed into place and the listed files of the
  old folder deleted (and nothing else: a file that reached the old folder in between is kept);
- anything else - a file not in the list, a listed file changed since (a report signed in
  place), a marker without a list (an older ringqa), a folder without a marker: refused,
  naming the files, before any work starts (:func:`check_writable`) and again at the commit
  (a file saved into the folder while the command ran), since ringqa never deletes a file it
  did not write.

``--out`` itself is checked before any work (:func:`check_out_path`): not a symbolic link,
not the current folder or one above it, not a file, under a writable folder.

While the staging folder exists SIGTERM, SIGINT and SIGHUP raise :class:`OutputInterrupted`,
so the staging folder is removed and the target stays as it was. Staging folders left by a
process that no longer runs (SIGKILL, power loss) are removed at the start of the next run into
the same target (:func:`remove_leftovers`).

Folders and files follow the process's umask (``umask 022``: folders 0755, files 0644).

A single file written on its own (an applicator file, a points file) goes through
:func:`atomic_write_text` / :func:`atomic_write_bytes`: a temporary file in the same folder,
flushed to disk, then renamed over the target, so readers see the old file or the new one,
never a part.
"""

from __future__ import annotations

import contextlib
import contextvars
import datetime as _dt
import errno
import hashlib
import json
import os
import re
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from ringqa.errors import RingQAError

#: the file that marks a folder as written by ringqa (and lists the files it wrote)
MARKER_NAME = ".ringqa-output.json"

#: the signals that, while a staging folder exists, end the run cleanly
HANDLED_SIGNALS: tuple[signal.Signals, ...] = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: how many foreign files a refusal names (then "and N more")
NAMED_FILES = 5

#: how often a commit (or the reading of a folder) is tried again when another ringqa run put
#: its output in place meanwhile
COMMIT_ATTEMPTS = 8

#: how often a folder is read again when it was replaced while it was read (a reading is a
#: directory walk and a marker: cheap; six runs committing at once replace it many times)
READ_ATTEMPTS = 32

_COMMAND: contextvars.ContextVar[str] = contextvars.ContextVar("ringqa_command", default="")
_UMASK_LOCK = threading.Lock()


class OutputInterrupted(KeyboardInterrupt):
    """A signal (SIGTERM, SIGINT, SIGHUP) arrived while an output folder was being written.

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
        ``ringqa``: every entry is listed in the marker of the earlier run (unchanged) or is
        one of ``ours``; ``foreign``: it holds something else.
    example : str or None
        For ``foreign``: the first entry ringqa did not write (for the message).
    foreign : tuple of str
        For ``foreign``: every such entry (relative POSIX paths; a changed listed file is
        followed by `` (changed since ringqa wrote it)``).
    owned : tuple of str
        For ``ringqa``: the entries ringqa may delete when it replaces the folder (files and
        folders relative to it, the marker included), deepest first.
    legacy : bool
        The marker has no file list (written by an older ringqa).
    """

    kind: Literal["missing", "empty", "ringqa", "foreign"]
    example: str | None = None
    foreign: tuple[str, ...] = ()
    owned: tuple[str, ...] = field(default=(), repr=False)
    legacy: bool = False


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
    """The content of :data:`MARKER_NAME` without its file list: software, version, command,
    date, process id (the list - ``files``, ``folders`` - is added when the folder is committed,
    :func:`list_files`)."""
    from ringqa import __version__

    return {
        "software": "ringqa",
        "version": __version__,
        "command": _COMMAND.get() or "python API",
        "created_utc": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "pid": os.getpid(),
    }


def current_umask() -> int:
    """The process's file-mode creation mask (read without changing it for long)."""
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def sha256_file(path: Path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _walk(folder: Path) -> tuple[list[str], list[str]]:
    """Files (and links, and anything not a folder) and folders under ``folder``, as relative
    POSIX paths; symbolic links are not followed."""
    files: list[str] = []
    folders: list[str] = []
    for root, dirs, names in os.walk(folder, followlinks=False):
        rel = Path(root).relative_to(folder)
        for d in list(dirs):
            p = Path(root) / d
            if p.is_symlink():
                files.append((rel / d).as_posix())
                dirs.remove(d)
            else:
                folders.append((rel / d).as_posix())
        files.extend((rel / n).as_posix() for n in names)
    return sorted(files), sorted(folders)


def list_files(folder: Path, unhashed: Iterable[str] = ()) -> dict:
    """The file list a marker records for ``folder``: ``files`` (path, size in bytes, SHA-256,
    modification time in ns) and ``folders`` (paths), the marker itself left out. A later check
    hashes a file again only when its modification time differs from the recorded one.

    Parameters
    ----------
    folder : Path
        The finished (staging) folder.
    unhashed : iterable of str
        Paths recorded without a checksum (the command's own caches, which it changes in place
        on the next run).
    """
    skip = set(unhashed)
    files, folders = _walk(folder)
    entries = []
    for rel in files:
        if rel == MARKER_NAME:
            continue
        p = folder / rel
        st = p.lstat()
        entries.append(
            {
                "path": rel,
                "size": st.st_size,
                "sha256": None if rel in skip else sha256_file(p),
                "mtime_ns": st.st_mtime_ns,
            }
        )
    return {"files": entries, "folders": folders}


def read_marker(folder: Path) -> dict | None:
    """The marker record of ``folder`` (None when there is none, or it is not ringqa's)."""
    path = folder / MARKER_NAME
    try:
        if path.is_symlink() or not path.is_file():
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("software") != "ringqa":
        return None
    return data


def has_marker(folder: Path) -> bool:
    """True if ``folder`` holds a readable ringqa marker file."""
    return read_marker(folder) is not None


def _listed(data: dict) -> tuple[dict[str, dict], set[str]] | None:
    """The marker's files (path -> entry) and folders, or None if it has no valid list."""
    files, folders = data.get("files"), data.get("folders")
    if not isinstance(files, list) or not isinstance(folders, list):
        return None
    out: dict[str, dict] = {}
    for e in files:
        if not (isinstance(e, dict) and isinstance(e.get("path"), str)):
            return None
        out[e["path"]] = e
    return out, {f for f in folders if isinstance(f, str)}


def recorded_digests(folder: Path) -> dict[str, str]:
    """The SHA-256 that the marker of ``folder`` records for each file still as it was written
    (a plain file of the recorded size and modification time): relative POSIX path -> hex
    digest. A file changed since, not listed, or listed without a checksum is absent (hash it
    to know it); no marker, or one without a valid list: empty."""
    data = read_marker(folder)
    listed = None if data is None else _listed(data)
    if listed is None:
        return {}
    out: dict[str, str] = {}
    for rel, entry in listed[0].items():
        digest = entry.get("sha256")
        try:
            st = (folder / rel).lstat()
        except OSError:
            continue
        same = st.st_size == entry.get("size") and st.st_mtime_ns == entry.get("mtime_ns")
        if isinstance(digest, str) and stat.S_ISREG(st.st_mode) and same:
            out[rel] = digest
    return out


def _unchanged(path: Path, entry: dict) -> bool:
    """True if ``path`` is a plain file with the recorded size and checksum."""
    try:
        st = path.lstat()
    except OSError:
        return False
    if not stat.S_ISREG(st.st_mode):
        return False
    if entry.get("size") is not None and st.st_size != entry.get("size"):
        return False
    digest = entry.get("sha256")
    if digest is None or entry.get("mtime_ns") == st.st_mtime_ns:
        return True  # a cache, or not touched since (a rename keeps the time): no hashing
    try:
        return sha256_file(path) == digest
    except OSError:
        return False


def folder_state(out: Path, ours: Iterable[str] = ()) -> FolderState:
    """Classify the output folder ``out`` (see :class:`FolderState`).

    The folder is read by path; if another run put its own output in ``out``'s place while it
    was being read (its identity, device and inode, changed), it is read again, so that a
    marker and files of two different folders are never compared.

    Parameters
    ----------
    out : Path
        The target folder (a missing one is ``missing``).
    ours : iterable of str
        Names the running command itself keeps in the folder while it works (the accuracy
        study's run cache): never foreign.
    """
    out = Path(out)
    ours = tuple(ours)
    state = FolderState("missing")
    for _ in range(READ_ATTEMPTS):
        before = _identity(out)
        state = _classify(out, ours)
        if _settled(before, _identity(out), state):
            break
    return state


def _settled(before, after, state: FolderState) -> bool:
    """A reading of a folder stands: the same folder was there before and after it. A missing
    folder before and after stands only for "missing": while other runs commit into the same
    ``out`` it is missing between each one's set-aside and its rename, and a reading that began
    in such a gap and ended in the next may have seen parts of a folder that came and went
    (a marker and files of two runs: a false "changed since ringqa wrote it")."""
    if before != after:
        return False
    return before is not None or state.kind == "missing"


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = path.lstat()
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _classify(out: Path, ours: tuple[str, ...]) -> FolderState:
    if not out.exists() and not out.is_symlink():
        return FolderState("missing")
    files, folders = _walk(out)
    if not files and not folders:
        return FolderState("empty")
    own = set(ours)
    data = read_marker(out)
    listed = None if data is None else _listed(data)
    recorded, recorded_dirs = listed if listed is not None else ({}, set())
    foreign: list[str] = []
    for rel in files:
        if rel in own or (rel == MARKER_NAME and data is not None):
            continue
        if rel in recorded:
            if not _unchanged(out / rel, recorded[rel]):
                foreign.append(f"{rel} (changed since ringqa wrote it)")
            continue
        foreign.append(rel)
    foreign_dirs = [d for d in folders if d not in recorded_dirs]
    # a folder counts once, as itself, only when nothing foreign lies inside it already
    for d in foreign_dirs:
        if not any(f.startswith(d + "/") for f in foreign):
            foreign.append(d + "/")
    if foreign:
        foreign.sort()
        return FolderState("foreign", foreign[0], tuple(foreign), legacy=listed is None)
    owned = list(files) + sorted(folders, key=lambda d: -d.count("/"))
    return FolderState("ringqa", owned=tuple(owned))


def _name_files(names: tuple[str, ...]) -> str:
    shown = ", ".join(names[:NAMED_FILES])
    more = len(names) - NAMED_FILES
    return shown + (f" and {more} more" if more > 0 else "")


def foreign_message(out: Path, state: FolderState | str | None, *, at_commit: bool = False) -> str:
    """The one-line refusal for a folder holding files ringqa did not write (or changed).

    Parameters
    ----------
    out : Path
        The folder.
    state : FolderState or str or None
        Its state (a bare file name: the older form, one example).
    at_commit : bool
        The files were found when the finished output was about to be put in place.
    """
    if not isinstance(state, FolderState):
        state = FolderState("foreign", state, (state,) if state else ())
    names = _name_files(state.foreign)
    why = (
        " (its marker comes from an older ringqa that did not list its files)"
        if state.legacy and has_marker(out)
        else ""
    )
    if at_commit:
        return (
            f"--out {out}: files ringqa did not write appeared in it while the command ran: "
            f"{names}; nothing was replaced and they are kept (move them out of the folder, "
            "or choose another --out, and run again)"
        )
    return (
        f"--out {out}: holds files ringqa did not write{why}: {names}; ringqa never deletes "
        "them (move them out of the folder, or choose an empty or new folder)"
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
    renames) is put back in place if ``out`` is missing; else the files its marker lists are
    removed, and anything else in it is kept (the folder renamed to a visible
    ``NAME.kept-PID``). Each action is reported in one line through ``say`` (default: standard
    error).

    Returns
    -------
    list of Leftover
        What was found (and removed or restored).
    """
    say = say or _say
    found = find_leftovers(out)
    for item in found:
        if item.role == "old" and not out.exists() and not out.is_symlink():
            os.rename(item.path, out)
            say(f"restored {out} from {item.path.name}, set aside by an interrupted run")
            continue
        if item.role == "staging":
            shutil.rmtree(item.path, ignore_errors=True)
            say(
                f"removed left-over staging folder {item.path} from an interrupted run "
                f"(process {item.pid})"
            )
            continue
        kept = _delete_owned(item.path, folder_state(item.path))
        if kept is None:
            say(
                f"removed left-over earlier output {item.path} from an interrupted run "
                f"(process {item.pid})"
            )
        else:
            say(
                f"kept files ringqa did not write from an interrupted run's earlier output "
                f"in {kept}"
            )
    return found


def _delete_owned(folder: Path, state: FolderState) -> Path | None:
    """Delete the entries of ``folder`` that ringqa wrote (``state.owned``; a foreign or legacy
    folder: nothing), then the folder if empty. Anything else is kept: the folder is renamed to
    a visible ``NAME.kept-PID-XXXX`` beside it, which is returned (None if all was removed)."""
    if state.kind == "ringqa":
        for rel in state.owned:
            p = folder / rel
            with contextlib.suppress(OSError):
                if p.is_dir() and not p.is_symlink():
                    p.rmdir()  # only when empty: a file that arrived since stays
                else:
                    p.unlink()
    with contextlib.suppress(OSError):
        folder.rmdir()
        return None
    if not folder.exists():
        return None
    base = folder.name.lstrip(".").split(".old-")[0]
    kept = folder.parent / f"{base}.kept-{os.getpid()}-{_dt.datetime.now():%Y%m%d%H%M%S}"
    try:
        os.rename(folder, kept)
    except OSError:
        return folder
    return kept


def _say(line: str) -> None:
    with contextlib.suppress(OSError, ValueError):
        print(f"ringqa: {line}", file=sys.stderr)


def _parent(out: Path) -> Path:
    return out.parent if str(out.parent) not in ("", ".") else Path(".")


def check_out_path(out_dir: str | Path) -> Path:
    """Check the ``--out`` path itself, before any work (its content: :func:`check_writable`).

    Refused: an empty path, a symbolic link (the folder is replaced as a whole, which would
    replace the link, not the folder it points to), ``.``/``..``/``/`` or any folder that holds
    the current folder (renamed away under the running command), an existing file, a path
    below a file, and a path whose nearest existing folder is not writable.

    Raises
    ------
    RingQAError
        Naming ``--out``, the reason and the fix.
    """
    if str(out_dir).strip() == "":
        raise RingQAError("--out: empty path (give an output folder, e.g. --out results)")
    out = Path(out_dir)
    if out.is_symlink():
        target = os.readlink(out)
        raise RingQAError(
            f"--out {out}: is a symbolic link (to {target}); ringqa replaces its output folder "
            "as a whole, which would replace the link (give the folder itself or a new folder)"
        )
    absolute = Path(os.path.abspath(out))
    try:
        here = Path.cwd().resolve()
        holds_cwd = here == out.resolve() or out.resolve() in here.parents
    except OSError:
        holds_cwd = False
    if out.name in ("", ".", "..") or absolute == Path(absolute.anchor) or holds_cwd:
        raise RingQAError(
            f"--out {out}: is the current folder or a folder above it; ringqa replaces its "
            "output folder as a whole (name a new subfolder, e.g. --out results)"
        )
    if out.exists() and not out.is_dir():
        raise RingQAError(f"--out {out}: exists and is not a folder (choose a folder path)")
    probe = absolute
    while not probe.exists() and not probe.is_symlink():
        probe = probe.parent
    if not probe.is_dir():
        raise RingQAError(
            f"--out {out}: {probe} is a file, not a folder (choose a path under a folder)"
        )
    if probe == absolute:
        probe = absolute.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise RingQAError(
            f"--out {out}: folder {probe} is not writable (choose a folder you can write to)"
        )
    try:
        name_max = os.pathconf(probe, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    longest = len(os.fsencode(f".{out.name}.staging-{os.getpid()}-xxxxxxxx"))
    if name_max and longest > name_max:
        raise RingQAError(
            f"--out {out}: the folder name is {len(os.fsencode(out.name))} bytes long; with "
            f"ringqa's staging suffix it passes the file system's {name_max} (choose a name "
            f"of at most {name_max - longest + len(os.fsencode(out.name))} bytes)"
        )
    return out


def check_writable(out_dir: str | Path, *, ours: Iterable[str] = ()) -> Path:
    """Return ``out_dir`` as a Path after checking ringqa may write it (before any work).

    The path is checked (:func:`check_out_path`), then its content (:func:`folder_state`);
    left-over staging folders of interrupted runs beside it are removed
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
        If the path is refused, or the folder holds files ringqa did not write (named).
    """
    out = check_out_path(out_dir)
    if out.is_dir() and not os.access(out, os.R_OK | os.X_OK):
        raise RingQAError(
            f"--out {out}: folder cannot be read (choose a folder you can read and write)"
        )
    state = folder_state(out, ours)
    if state.kind == "foreign":
        raise RingQAError(foreign_message(out, state))
    remove_leftovers(out)
    return out


@contextlib.contextmanager
def staged_output(out_dir: str | Path, *, ours: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a staging folder; on success it replaces ``out_dir`` as a whole.

    The folder is refused at entry if it holds files ringqa did not write
    (:func:`check_writable`). On success the files named in ``ours`` are carried over from the
    old folder (unless the block wrote them), the marker file with the list of every file
    written is added (also in each subfolder that has its own marker) and the staging folder
    takes the target's place (:func:`commit_folder`, which checks the target again). On any
    exception, SIGTERM, SIGINT or SIGHUP (:class:`OutputInterrupted`) the staging folder is
    removed and ``out_dir`` is untouched.

    Parameters
    ----------
    out_dir : str or Path
        The output folder.
    ours : iterable of str
        Files the command keeps in ``out_dir`` while it works (the accuracy study's run cache):
        not counted as foreign, carried into the new folder, listed without a checksum.
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
                os.chmod(stage, 0o777 & ~current_umask())
            yield stage
            carry_over(out, stage, ours)
            write_markers(stage, unhashed=ours)
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


def write_markers(stage: Path, *, unhashed: Iterable[str] = ()) -> None:
    """Write the marker of ``stage`` with the list of its files, and complete the marker of
    every subfolder that has one (a batch's applicator folders) with the list of its own."""
    unhashed = tuple(unhashed)
    for sub in sorted(stage.rglob(MARKER_NAME)):
        folder = sub.parent
        if folder == stage or sub.is_symlink():
            continue
        record = read_marker(folder) or marker_record()
        record.update(list_files(folder))
        sub.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    record = marker_record()
    record.update(list_files(stage, unhashed))
    (stage / MARKER_NAME).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")


def staging_prefix(out: Path) -> str:
    """Name prefix of this process's staging folders for ``out`` (``.NAME.staging-PID-``)."""
    return f".{out.name}.staging-{os.getpid()}-"


def carry_over(out: Path, stage: Path, names: Iterable[str]) -> None:
    """Copy the files ``names`` from ``out`` into ``stage`` unless the stage already has them."""
    for name in names:
        src, dst = out / name, stage / name
        if src.is_file() and not src.is_symlink() and not dst.exists():
            shutil.copy2(src, dst)


_RACED = (errno.ENOTEMPTY, errno.EEXIST)


def commit_folder(stage: Path, out: Path, ours: Iterable[str] = ()) -> None:
    """Put the finished staging folder ``stage`` in the place of ``out``.

    A missing or empty ``out`` is replaced by one rename. An earlier ringqa output (every
    entry listed in its marker and unchanged) is renamed aside, checked again there (a file
    that arrived between the check and the rename: the old folder is put back and the commit
    refused), ``stage`` renamed into place (the old folder is put back if that fails) and the
    listed files of the old folder deleted; anything else found there is kept
    (:func:`_delete_owned`).

    Runs into the same ``out`` at once: when another run's output lands in ``out`` between
    this run's check and its rename (the rename then fails with ENOTEMPTY), the check is made
    again and the commit repeated (at most :data:`COMMIT_ATTEMPTS` times), so that the last run
    to finish leaves one complete folder and no hidden one.

    Raises
    ------
    RingQAError
        If ``out`` holds files ringqa did not write (named), e.g. saved there while the command
        ran; nothing is replaced then.
    OSError
        If a rename fails (``out`` is then as it was).
    """
    ours = tuple(ours)
    for _ in range(COMMIT_ATTEMPTS):
        if _commit_once(stage, out, ours):
            return
    raise RingQAError(
        f"--out {out}: other ringqa runs kept putting their output in place while this one "
        f"tried {COMMIT_ATTEMPTS} times; nothing of this run was written (run it again)"
    )


def _commit_once(stage: Path, out: Path, ours: tuple[str, ...]) -> bool:
    """One attempt of :func:`commit_folder`; False when another run's output got in first."""
    state = folder_state(out, ours)
    if state.kind == "foreign":
        raise RingQAError(foreign_message(out, state, at_commit=True))
    if state.kind in ("missing", "empty"):
        try:
            os.replace(stage, out)  # POSIX: replaces an empty folder in one step
        except OSError as exc:
            if exc.errno not in _RACED:
                raise
            return False  # something arrived just now: look again
        return True
    aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-{os.getpid()}-", dir=_parent(out)))
    try:
        os.replace(out, aside)
    except FileNotFoundError:  # another run set it aside first
        aside.rmdir()
        return False
    except BaseException:
        aside.rmdir()
        raise
    again = folder_state(aside, ours)
    if again.kind == "foreign":  # arrived between the check and the rename: put it all back
        _put_back(aside, out)
        raise RingQAError(foreign_message(out, again, at_commit=True))
    try:
        os.replace(stage, out)
    except OSError as exc:
        if exc.errno in _RACED and folder_state(out, ours).kind != "foreign":
            # another run's complete output landed meanwhile (and may be set aside by a third
            # already): the set-aside one (checked just now) is superseded; remove what ringqa
            # wrote there and try again
            _report_kept(out, _delete_owned(aside, again))
            return False
        _put_back(aside, out)
        raise
    except BaseException:
        _put_back(aside, out)
        raise
    _report_kept(out, _delete_owned(aside, again))
    return True


def _report_kept(out: Path, kept: Path | None) -> None:
    if kept is not None:
        _say(f"kept files that reached the earlier output of {out} during the run in {kept}")


def _put_back(aside: Path, out: Path) -> None:
    """Rename the set-aside earlier output back to ``out`` (or say where it is)."""
    try:
        os.replace(aside, out)
    except OSError as exc:
        raise RingQAError(
            f"--out {out}: the earlier output could not be put back ({exc.strerror or exc}); "
            f"it is complete in {aside} (rename it back by hand)"
        ) from None


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
    """Make SIGTERM, SIGINT and SIGHUP raise :class:`OutputInterrupted` (main thread only; a
    signal the process ignores stays ignored; the previous handlers are restored after)."""
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
    """Hold SIGTERM, SIGINT and SIGHUP back while folders are renamed or removed, so a signal cannot
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


def atomic_write_bytes(path: str | os.PathLike, data: bytes, *, mode: int | None = None) -> Path:
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
    mode : int or None
        Permission bits of the new file (None: ``0o666`` less the umask, as a file written with
        ``open()``; the temporary file itself starts as ``0o600``).

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
        os.chmod(tmp, (0o666 & ~current_umask()) if mode is None else mode)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target


def atomic_write_text(
    path: str | os.PathLike, text: str, *, encoding: str = "utf-8", mode: int | None = None
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
    mode : int or None
        Permission bits of the new file (None: follow the umask).

    Returns
    -------
    Path
        ``path``.
    """
    return atomic_write_bytes(path, text.encode(encoding), mode=mode)
