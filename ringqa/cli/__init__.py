"""The ``ringqa`` command line: a thin layer over the Python API.

Each sub-command lives in its own module in this package and exposes ``add_parser(subparsers)``
(which registers its arguments and sets ``func``). ``main(argv=None)`` is testable in-process
(after pydicom's cli/main.py). Errors the user can fix are printed on one line, exit status 2;
so are operating-system errors (a full disk, a read-only or missing folder: :func:`os_error_line`).
SIGTERM / SIGINT while an output folder is being written end the command with status 143 / 130
and leave no staging folder (:mod:`ringqa.outdir`). Anything else is a bug and keeps its
traceback (exit status 1).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import signal
import sys
from pathlib import Path

from ringqa import __version__
from ringqa.errors import RingQAError
from ringqa.outdir import OutputInterrupted, running_command

# command name -> module (imported lazily so that `ringqa --help` stays fast)
COMMANDS: dict[str, str] = {
    "tg43-demo": "ringqa.cli.tg43_demo",
    "import": "ringqa.cli.import_plan",
    "simulate": "ringqa.cli.simulate",
    "accuracy": "ringqa.cli.accuracy",
    "commission": "ringqa.cli.commission",
    "needle": "ringqa.cli.needle",
    "warmup": "ringqa.cli.warmup",
}

#: commands that run numba kernels: while one compiles, stderr says so (ringqa/cli/_jit.py)
JIT_COMMANDS = frozenset({"tg43-demo", "simulate", "accuracy", "commission", "needle", "warmup"})


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every registered sub-command."""
    parser = argparse.ArgumentParser(
        prog="ringqa",
        description="Commissioning QA for HDR brachytherapy ring applicators.",
    )
    parser.add_argument("--version", action="version", version=f"ringqa {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module_name in COMMANDS.values():
        importlib.import_module(module_name).add_parser(sub)
    return parser


#: commands that run the simulation engine: on an empty numba cache a helper process compiles
#: the engine's leaf kernels beside them (ringqa/cli/_precompile.py)
ENGINE_COMMANDS = frozenset({"simulate", "accuracy", "commission", "warmup"})


@contextlib.contextmanager
def _jit_notice(command: str):
    """The compile notice and, on an empty cache, the compile helper, for a command that runs
    numba kernels (nothing for the others)."""
    if command not in JIT_COMMANDS:
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
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
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
    except OutputInterrupted as exc:
        name = signal.Signals(exc.signum).name
        what = (
            " after the output was complete"
            if exc.output_complete
            else "; nothing written (the output folder is as it was)"
        )
        print(f"ringqa {args.command}: interrupted by {name}{what}", file=sys.stderr)
        return exc.exit_status
    except KeyboardInterrupt:
        print(f"ringqa {args.command}: interrupted", file=sys.stderr)
        return 130


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
