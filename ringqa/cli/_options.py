"""Command-line options shared by several sub-commands (one definition, one parser)."""

from __future__ import annotations

import argparse

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
