"""``ringqa config show``: the settings ``ringqa commission`` would use, and where each came from.

    ringqa config show                     # defaults < user config
    ringqa config show --config site.toml  # ... < site.toml
    ringqa config path                     # where the user configuration file is looked for

Precedence (lowest first): built-in default, the user configuration (config.toml in the
platform's configuration folder, or the file named by RINGQA_CONFIG), --config FILE, the
command line. Keys, units and ranges: docs/config.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ringqa.cli._options import plain_help


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "config",
        help="show the clinic configuration in force and where each setting came from",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "action",
        choices=("show", "path"),
        help="show: the effective settings with their origin; path: the user configuration file",
    )
    p.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="FILE",
        help="a configuration file, as given to ringqa commission --config",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.config import effective_config, user_config_path

    user = user_config_path()
    if args.action == "path":
        state = "none" if user is None else ("present" if user.is_file() else "not present")
        print(f"user configuration: {user if user is not None else '(none)'} ({state})")
        return 0
    config = effective_config(args.config)
    config.settings()  # the same checks as ringqa commission
    where = "none" if user is None else f"{user}" + ("" if user.is_file() else " (not present)")
    print(f"# ringqa effective settings (user configuration: {where})")
    print(config.show(), end="")
    return 0
