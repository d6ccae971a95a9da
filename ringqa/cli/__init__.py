"""The ``ringqa`` command line: a thin layer over the Python API.

Each sub-command lives in its own module in this package and exposes ``add_parser(subparsers)``
(which registers its arguments and sets ``func``). ``main(argv=None)`` is testable in-process
(after pydicom's cli/main.py). Errors the user can fix are printed on one line, exit status 2;
anything else is a bug and keeps its traceback (exit status 1).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ringqa import __version__
from ringqa.errors import RingQAError

# command name -> module (imported lazily so that `ringqa --help` stays fast)
COMMANDS: dict[str, str] = {
    "tg43-demo": "ringqa.cli.tg43_demo",
    "import": "ringqa.cli.import_plan",
    "simulate": "ringqa.cli.simulate",
    "accuracy": "ringqa.cli.accuracy",
    "commission": "ringqa.cli.commission",
    "needle": "ringqa.cli.needle",
}


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


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except RingQAError as exc:
        print(f"ringqa {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except _tg43_error() as exc:
        print(f"ringqa {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"ringqa {args.command}: interrupted", file=sys.stderr)
        return 130


def _tg43_error() -> type[Exception]:
    from tg43.errors import TG43Error

    return TG43Error


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
