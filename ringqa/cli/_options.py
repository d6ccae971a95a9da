"""Command-line options shared by several sub-commands (one definition, one parser)."""

from __future__ import annotations

import argparse
import re

SET_HELP = (
    "change one simulation setting, e.g. solver.increment_mm=0.5 (names and units: "
    "data/scenes/README.md); repeatable"
)


def add_set_option(parser: argparse.ArgumentParser) -> None:
    """``--set KEY=VALUE`` (repeatable) into ``args.overrides``.

    Parse the collected strings with :func:`ringqa.simulation.scenefile.parse_set_args`.
    """
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help=SET_HELP,
    )


def plain_help(doc: str | None) -> str:
    """A module docstring as ``--help`` prints it: reST markup taken out (````x```` -> x,
    ``:func:`a.b``` -> b, ``**x**`` -> x), for the physicist reading it on a terminal."""
    text = doc or ""
    text = re.sub(r":(?:func|class|mod|meth|data|attr):`~?([^`]+)`",
                  lambda m: m.group(1).rsplit(".", 1)[-1], text)  # fmt: skip
    text = re.sub(r"``([^`]+)``", r"\1", text)
    return re.sub(r"\*\*([^*]+)\*\*", r"\1", text)


class DeferredArgumentsParser(argparse.ArgumentParser):
    """A sub-command's parser whose arguments are added when it is first used (to parse its
    command line, or to print its help or usage), not when the whole command line is built:
    ``ringqa --help`` and the other sub-commands do not pay for what building them imports
    (``ringqa commission``'s setting options come from the settings table, whose import pulls
    in numba and pandas). The arguments, their order and every help text are those of adding
    them at once."""

    _deferred: list

    def defer(self, add_arguments) -> None:
        """Call ``add_arguments(self)`` before this parser is first used."""
        self.__dict__.setdefault("_deferred", []).append(add_arguments)

    def ensure_arguments(self) -> argparse.ArgumentParser:
        """Add the deferred arguments now (once); return this parser."""
        pending = self.__dict__.get("_deferred") or []
        while pending:
            pending.pop(0)(self)
        return self

    def parse_known_args(self, args=None, namespace=None):
        self.ensure_arguments()
        return super().parse_known_args(args, namespace)

    def format_help(self) -> str:
        self.ensure_arguments()
        return super().format_help()

    def format_usage(self) -> str:
        self.ensure_arguments()
        return super().format_usage()


def deferred(parser: argparse.ArgumentParser, add_arguments) -> argparse.ArgumentParser:
    """``parser`` (a sub-command's, just made) turned into a :class:`DeferredArgumentsParser`
    that calls ``add_arguments(parser)`` when first used."""
    parser.__class__ = DeferredArgumentsParser
    parser.defer(add_arguments)
    return parser


class LazyVersionAction(argparse.Action):
    """``--version``: prints ``ringqa <version>`` and exits; the version (package metadata) is
    looked up only then."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help="show program's version number and exit"):  # fmt: skip
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0,
                         help=help)  # fmt: skip

    def __call__(self, parser, namespace, values, option_string=None):
        import sys

        import ringqa

        parser._print_message(f"ringqa {ringqa.__version__}\n", sys.stdout)
        parser.exit()
