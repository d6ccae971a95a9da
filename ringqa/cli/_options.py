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
