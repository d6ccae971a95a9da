"""The ``ringqa`` command line: a thin layer over the Python API.

Each sub-command lives in its own module in this package and exposes ``add_parser(subparsers)``
(which registers its arguments and sets ``func``). ``main(argv=None)`` is testable in-process
(after pydicom's cli/main.py). Errors the user can fix are printed on one line, exit status 2;
so are operating-system errors (a full disk, a read-only or missing folder: :func:`os_error_line`).
SIGTERM / SIGINT / SIGHUP while an output folder is being written end the command with status
143 / 130 / 129 and leave no staging folder (:mod:`ringqa.outdir`). Anything else is a bug and
keeps its traceback (exit status 1).

Before any work ``--out`` is checked (:func:`ringqa.outdir.check_out_path`: not a symbolic
link, not ``.``, under a writable folder) and ``--log-file`` opened and written once (a full
device or an unwritable file: refused at once; a log file inside ``--out``: refused, since the
folder is replaced whole). While the command runs, standard output and standard error pass
through :class:`TerminalStream`: text from files is shown with its control characters escaped
(:func:`ringqa.textio.terminal_text`), and a closed or full stream (``| head``, ``>&-``,
``>/dev/full``) never turns a finished run into a failure: the exit status stays the run's, and
a log file that stops accepting lines gives one warning line and is left alone.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import logging
import os
import signal
import sys
import time
from pathlib import Path

from ringqa.cli._options import LazyVersionAction
from ringqa.errors import RingQAError
from ringqa.outdir import OutputInterrupted, check_out_path, check_writable, running_command
from ringqa.textio import terminal_text

# command name -> module (imported lazily so that `ringqa --help` stays fast)
COMMANDS: dict[str, str] = {
    "tg43-demo": "ringqa.cli.tg43_demo",
    "import": "ringqa.cli.import_plan",
    "simulate": "ringqa.cli.simulate",
    "accuracy": "ringqa.cli.accuracy",
    "commission": "ringqa.cli.commission",
    "needle": "ringqa.cli.needle",
    "config": "ringqa.cli.config",
    "sweep": "ringqa.cli.sweep",
    "warmup": "ringqa.cli.warmup",
    "calibrate": "ringqa.cli.calibrate",
}

#: commands that run numba kernels: while one compiles, stderr says so (ringqa/cli/_jit.py)
JIT_COMMANDS = frozenset({"tg43-demo", "simulate", "accuracy", "commission", "needle", "warmup"})


def build_parser(deferred: bool = False) -> argparse.ArgumentParser:
    """The argument parser with every registered sub-command.

    ``deferred``: a sub-command module with ``add_parser_deferred(subparsers)`` adds its
    arguments only when its parser is first used (:class:`ringqa.cli._options
    .DeferredArgumentsParser`: the same arguments and help), so that ``ringqa --help`` and the
    other sub-commands do not import what building them needs (:func:`main` builds it so)."""
    parser = argparse.ArgumentParser(
        prog="ringqa",
        description="Commissioning QA for HDR brachytherapy ring applicators.",
    )
    parser.add_argument("--version", action=LazyVersionAction)
    parser.add_argument(
        "-v",
        "--verbose",
        action="count",
        default=0,
        help="print what ringqa does (-v: steps; -vv: details) on the terminal",
    )
    parser.add_argument(
        "--log-file",
        type=Path,
        default=None,
        metavar="FILE",
        help="also write the log (with details) to FILE, appended",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    parser.deferred_parsers = {}  # command -> its parser, where its arguments wait
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(module_name)
        add = getattr(module, "add_parser_deferred", None) if deferred else None
        made = (add or module.add_parser)(sub)
        if add is not None:
            parser.deferred_parsers[name] = made
    return parser


#: commands that load numba's cached kernels (ringqa/cli/_numba_loads.py)
LEAN_COMMANDS = JIT_COMMANDS | {"sweep", "calibrate"}

#: commands that run the simulation engine: on an empty numba cache a helper process compiles
#: the engine's leaf kernels beside them (ringqa/cli/_precompile.py)
ENGINE_COMMANDS = frozenset({"simulate", "accuracy", "commission", "warmup"})


@contextlib.contextmanager
def _jit_notice(command: str):
    """The compile notice and, on an empty cache, the compile helper, for a command that runs
    numba kernels (nothing for the others; ``RINGQA_COMPILE_NOTICE=0`` turns both off, e.g. for
    a test that reads the command's own stderr lines on a cold cache). Such a command and
    the processes it forks load numba's cached kernels without numba's compiler set-up
    (:func:`ringqa.cli._numba_loads.lean_cache_loads`: 0.25-0.4 s of a warm start)."""
    if command in LEAN_COMMANDS:
        from ringqa.cli._numba_loads import lean_cache_loads

        lean_cache_loads()
    if command not in JIT_COMMANDS or os.environ.get("RINGQA_COMPILE_NOTICE", "1") == "0":
        yield
        return
    from ringqa.cli._jit import compile_notice

    helper = None
    if command in ENGINE_COMMANDS:
        from ringqa.cli._precompile import start_helper

        helper = start_helper()
    try:
        with compile_notice(helper=helper is not None):
            yield
    finally:
        if helper is not None:
            from ringqa.cli._precompile import stop_helper

            stop_helper(helper)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser(deferred=True)
    for name, sub in parser.deferred_parsers.items():  # the command named: its arguments now
        if name in (sys.argv[1:] if argv is None else argv):
            sub.ensure_arguments()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    logger = logging.getLogger("ringqa")
    saved = (logger.level, logger.propagate)
    with terminal_streams() as (out, _err):
        try:
            check_paths(args)
            handlers = configure_logging(args.verbose, args.log_file)
        except RingQAError as exc:
            print(f"ringqa {args.command}: error: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:  # removing a left-over staging folder, reading --out
            print(os_error_line(args.command, exc, getattr(args, "out", None)), file=sys.stderr)
            return 2
        words = sys.argv[1:] if argv is None else argv
        cli_log = logging.getLogger(__name__)
        if cli_log.isEnabledFor(logging.DEBUG):  # the version: package metadata, looked up now
            import ringqa

            cli_log.debug("ringqa %s: ringqa %s", ringqa.__version__, " ".join(words))
        try:
            code = _run(args)
        finally:
            for handler in handlers:
                logger.removeHandler(handler)
                with contextlib.suppress(OSError, ValueError):
                    handler.close()
            logger.setLevel(saved[0])
            logger.propagate = saved[1]
        if out.failed is not None:
            print(
                f"ringqa {args.command}: note: standard output could not be written "
                f"({_reason(out.failed)}); the exit status is the command's ({code})",
                file=sys.stderr,
            )
        return code


def _reason(exc: BaseException) -> str:
    return getattr(exc, "strerror", None) or str(exc) or type(exc).__name__


class TerminalStream:
    """Standard output or error while a command runs: escapes control characters of what is
    written (:func:`ringqa.textio.terminal_text`) and never raises on a closed or full stream.

    Parameters
    ----------
    stream : file-like
        The stream wrapped (``sys.stdout``).
    progress : bool
        Standard error: keep what progress bars need (a leading carriage return, cursor up).

    Attributes
    ----------
    failed : Exception or None
        The first error writing to the stream (then nothing more is written to it).
    """

    def __init__(self, stream, *, progress: bool = False) -> None:
        self._stream = stream
        self._progress = progress
        self.failed: BaseException | None = None

    def write(self, text: str) -> int:
        if self.failed is None:
            try:
                self._stream.write(terminal_text(text, keep_cr=self._progress))
            except (OSError, ValueError) as exc:  # EPIPE, ENOSPC, a closed file
                self.failed = exc
        return len(text)

    def writelines(self, lines) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        if self.failed is None:
            try:
                self._stream.flush()
            except (OSError, ValueError) as exc:
                self.failed = exc

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


@contextlib.contextmanager
def terminal_streams():
    """Put :class:`TerminalStream` in place of ``sys.stdout`` and ``sys.stderr`` (a stream that
    is None, closed at start, stays None); yield the two wrappers; restore the streams after."""
    saved = sys.stdout, sys.stderr
    out = TerminalStream(saved[0])
    err = TerminalStream(saved[1], progress=True)
    if saved[0] is not None:
        sys.stdout = out
    if saved[1] is not None:
        sys.stderr = err
    try:
        yield out, err
    finally:
        sys.stdout, sys.stderr = saved


#: the cyclic garbage collector's generation-0 threshold while the ``ringqa`` script runs
#: (Python's default 700 makes it collect hundreds of times while numpy, scipy, pandas,
#: matplotlib and reportlab are imported: 0.25-0.3 s of the warm example's ~3 s, measured).
#: Nearly everything those imports make lives until the exit, so each collection only
#: traverses survivors: at 100 000 the warm example still made three generation-0 and one
#: generation-1 collection, 0.2 s of CPU (one of 0.06 s in the start-up before the
#: commissioning is forked); at 1 000 000 it makes none, for 10 MB more peak memory
#: (docs/speed.md, 2026-11-29). A long batch or sweep still collects, every million objects.
GC_THRESHOLD_0 = 1_000_000

#: the environment the ``ringqa`` script sets for itself where the user has not: OpenBLAS
#: (numpy's BLAS) with one thread. ringqa's work runs in processes (the commissioning, its
#: engine runs, the figures, a batch's workers), its matrices are small (3x3 frames, banded
#: systems of a few hundred unknowns), and OpenBLAS's extra threads only spin: in the warm
#: example they took 0.13-0.17 s of CPU while numpy was imported, before the first fork
#: (measured, docs/speed.md 2026-11-29). numba's own threads (tg43's parallel kernel) are not
#: affected. Set before numpy is imported; a value in the environment is kept.
SCRIPT_ENVIRONMENT = {"OPENBLAS_NUM_THREADS": "1"}


def console_main() -> None:
    """The ``ringqa`` script (and ``python -m ringqa``): :func:`main`, then a quick exit.

    The garbage collector runs less often (:data:`GC_THRESHOLD_0`), OpenBLAS runs one thread
    (:data:`SCRIPT_ENVIRONMENT`), matplotlib is imported without generating its docstrings
    (:mod:`ringqa.cli._lean_matplotlib`) and numba without a YAML parser for a configuration
    file that is not there (:func:`ringqa.cli._numba_loads.numba_config_without_yaml`), and
    once the command has returned - its files written and closed, its log handlers closed,
    the compile helper stopped - the exit handlers run and the process ends without tearing
    down every module and object one by one (0.4-0.5 s of the warm example's run, measured).
    Only the script does this; :func:`main` called in-process (tests, notebooks) returns as
    usual."""
    import atexit
    import gc

    from ringqa.cli._lean_matplotlib import lean_matplotlib_docs
    from ringqa.cli._numba_loads import numba_config_without_yaml

    for name, value in SCRIPT_ENVIRONMENT.items():
        os.environ.setdefault(name, value)
    lean_matplotlib_docs()
    numba_config_without_yaml()
    gc.set_threshold(GC_THRESHOLD_0, *gc.get_threshold()[1:])
    code = main()
    atexit._run_exitfuncs()  # what a normal exit runs: logging.shutdown, finalizers, dask
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    os._exit(code)


class LogFileHandler(logging.FileHandler):
    """The ``--log-file`` handler: when the file stops accepting lines (a full disk, a
    device like /dev/full) it says so once on standard error and writes nothing more, instead of
    a traceback per record and an exit status 1 after a finished run. Control characters of
    logged text are escaped as on the terminal."""

    failed: BaseException | None = None

    def emit(self, record: logging.LogRecord) -> None:
        if self.failed is None:
            super().emit(record)

    def format(self, record: logging.LogRecord) -> str:
        """The record as a line, control characters from files escaped (``cat run.log``)."""
        return terminal_text(super().format(record))

    def handleError(self, record: logging.LogRecord) -> None:
        exc = sys.exc_info()[1]
        if self.failed is None and exc is not None:
            self.failed = exc
            with contextlib.suppress(OSError, ValueError):
                print(
                    f"ringqa: warning: --log-file {self.baseFilename}: cannot be written "
                    f"({_reason(exc)}); the log stops here, the run goes on",
                    file=sys.stderr,
                )

    def flush(self) -> None:
        with contextlib.suppress(OSError, ValueError):
            super().flush()

    def close(self) -> None:
        with contextlib.suppress(OSError, ValueError):
            super().close()


def configure_logging(verbose: int, log_file: Path | None) -> list[logging.Handler]:
    """Attach the command line's log handlers to the ``ringqa`` logger (library modules only
    call ``logging.getLogger(__name__)``; only the command line configures handlers).

    Parameters
    ----------
    verbose : int
        0: warnings only on stderr; 1 (``-v``): INFO; 2 or more (``-vv``): DEBUG.
    log_file : Path or None
        Also append DEBUG-level records with time stamps to this file (:class:`LogFileHandler`;
        opened and written once here, so a file that cannot be written is refused at once).

    Returns
    -------
    list of logging.Handler
        The handlers added (removed again when the command ends).

    Raises
    ------
    RingQAError
        ``--log-file`` cannot be opened or written (a folder, no permission, a full device).
    """
    logger = logging.getLogger("ringqa")
    level = logging.WARNING if verbose <= 0 else logging.INFO if verbose == 1 else logging.DEBUG
    console = logging.StreamHandler(sys.stderr)
    console.setLevel(level)
    console.setFormatter(logging.Formatter("ringqa: %(message)s"))
    handlers: list[logging.Handler] = [console]
    if log_file is not None:
        fh = _open_log_file(Path(log_file))
        fh.setLevel(logging.DEBUG)
        fh.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        handlers.append(fh)
    logger.setLevel(min(h.level for h in handlers))
    for handler in handlers:
        logger.addHandler(handler)
    logger.propagate = False
    return handlers


def _open_log_file(log_file: Path) -> LogFileHandler:
    """Open ``--log-file`` for appending and write its first line (refused if either fails)."""
    fix = "choose a writable file on a disk with free space"
    if log_file.is_dir():
        raise RingQAError(f"--log-file {log_file}: is a folder ({fix})")
    try:
        fh = LogFileHandler(log_file, encoding="utf-8")
    except OSError as exc:
        raise RingQAError(f"--log-file {log_file}: {_reason(exc)} ({fix})") from None
    try:
        stamp = time.strftime("%Y-%m-%d %H:%M:%S")
        fh.stream.write(f"{stamp} INFO ringqa.cli: log opened by process {os.getpid()}\n")
        fh.stream.flush()
    except (OSError, ValueError) as exc:
        fh.close()
        raise RingQAError(
            f"--log-file {log_file}: cannot be written: {_reason(exc)} ({fix})"
        ) from None
    return fh


def _run(args: argparse.Namespace) -> int:
    """Run the chosen sub-command; errors the user can fix -> one line, exit 2."""
    try:
        with running_command(args.command), _jit_notice(args.command):
            return int(args.func(args) or 0)
    except RingQAError as exc:
        print(f"ringqa {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except _tg43_error() as exc:
        print(f"ringqa {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(os_error_line(args.command, exc, getattr(args, "out", None)), file=sys.stderr)
        return 2
    except (OutputInterrupted, KeyboardInterrupt) as exc:
        return _interrupted(args.command, exc)
    except Exception as exc:
        # a signal's exception wrapped by the code it landed in (Python 3.11 turns one raised in
        # a class body's __set_name__ - a library being imported - into RuntimeError from it)
        stop = _interruption_in(exc)
        if stop is None:
            raise
        return _interrupted(args.command, stop)


def _interruption_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The :class:`KeyboardInterrupt` (or :class:`OutputInterrupted`) that ``exc`` was raised
    from or while handling, if any (its ``__cause__`` / ``__context__`` chain)."""
    seen: set[int] = set()
    cause = exc.__cause__ or exc.__context__
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return None


def _interrupted(command: str, exc: KeyboardInterrupt) -> int:
    """One line for a signal that stopped ``command``; its exit status (130 without a signal
    number: Ctrl-C outside an output folder)."""
    if not isinstance(exc, OutputInterrupted):
        print(f"ringqa {command}: interrupted", file=sys.stderr)
        return 130
    name = signal.Signals(exc.signum).name
    what = (
        " after the output was complete"
        if exc.output_complete
        else "; nothing written (the output folder is as it was)"
    )
    print(f"ringqa {command}: interrupted by {name}{what}", file=sys.stderr)
    return exc.exit_status


#: commands that keep a cache in their --out folder while they work (checked by the command)
KEEPS_CACHE = frozenset({"accuracy", "sweep"})


def check_paths(args: argparse.Namespace) -> None:
    """Check ``--out`` (:func:`ringqa.outdir.check_out_path`) and that ``--log-file`` neither
    lies inside it nor is one of the command's input files, before any work.

    Raises
    ------
    RingQAError
        Naming the option, the reason and the fix.
    """
    log = getattr(args, "log_file", None)
    if log is not None and Path(log).is_file():
        for name, value in vars(args).items():
            values = value if isinstance(value, list | tuple) else [value]
            for v in values:
                if name != "log_file" and isinstance(v, str | Path) and _same_file(v, log):
                    raise RingQAError(
                        f"--log-file {log}: is also an input of the command ({v}); the log "
                        "would be appended to it (give a separate log file)"
                    )
    out = getattr(args, "out", None)
    if out is None:
        return
    check_out_path(out)
    if getattr(args, "command", None) not in KEEPS_CACHE:  # these check with their cache's name
        check_writable(out)  # the folder's content too: a foreign file refused at once
    if log is not None:
        out_abs, log_abs = Path(out).resolve(), Path(log).resolve()
        if out_abs in log_abs.parents:
            raise RingQAError(
                f"--log-file {log}: lies inside --out {out}, which ringqa replaces as a whole "
                "(put the log file beside the output folder)"
            )


def _same_file(a, b) -> bool:
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError, TypeError):
        return False


#: what to do about an operating-system error, by errno
OS_ERROR_HINTS: dict[int, str] = {
    errno.ENOSPC: "free disk space, or choose a folder on another disk",
    errno.EDQUOT: "free space within your quota, or choose a folder on another disk",
    errno.EACCES: "choose a folder you can write to",
    errno.EPERM: "choose a folder you can write to",
    errno.EROFS: "the file system is read-only; choose a writable folder",
    errno.ENOENT: "choose a folder whose parent exists and can hold folders",
    errno.ENOTDIR: "a part of the path is a file; choose a folder path",
}


def os_error_line(command: str, exc: OSError, out: Path | None) -> str:
    """One line for an operating-system error: what could not be written, why, and the fix.

    Parameters
    ----------
    command : str
        The sub-command (``commission``).
    exc : OSError
        The error.
    out : Path or None
        The command's ``--out`` folder: named when the error concerns it (or its staging
        folder), else the file the error names.
    """
    reason = exc.strerror or str(exc) or type(exc).__name__
    hint = OS_ERROR_HINTS.get(exc.errno or 0, "choose a writable folder")
    filename = exc.filename
    if out is not None and (filename is None or _concerns(Path(filename), Path(out))):
        return f"ringqa {command}: cannot write {out}: {reason} ({hint})"
    if filename is not None:
        return f"ringqa {command}: cannot use {filename}: {reason} ({hint})"
    return f"ringqa {command}: error: {reason} ({hint})"


def _concerns(path: Path, out: Path) -> bool:
    """True if ``path`` is ``out``, inside it, a folder above it, or inside one of its hidden
    staging/set-aside folders."""
    path, out = Path(path).absolute(), Path(out).absolute()
    if path == out or out in path.parents:
        return True
    if path.parent == out.parent:
        return path.name.startswith(f".{out.name}.")
    if out.parent in path.parents:
        top = path.relative_to(out.parent).parts[0]
        return top.startswith(f".{out.name}.")
    return path in out.parents


def _tg43_error() -> type[Exception]:
    from tg43.errors import TG43Error

    return TG43Error


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
