"""``ringqa simulate``: push the instrument of a scene file through its channel.

Writes ``DIR/dwells.csv`` (one row per cable advance: source centre, direction, push force,
arc length, offset), ``DIR/run.json`` (status, timings, settings, the whole scene) and, with
``--trajectory``, ``DIR/trajectory.h5``.

Exit status: 0 success; 1 the instrument jammed (outputs are still written: a jam is a result);
3 the solver failed (outputs written, see run.json's message); 2 bad input (nothing written).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ringqa.cli._options import add_set_option, plain_help

EXIT_JAMMED = 1
EXIT_FAILED = 3


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "simulate",
        help="simulate a source cable (or catheter) in a channel from a scene file",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", help="scene TOML file, or a shipped scene name (ring26-flexitron)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    add_set_option(p)
    p.add_argument("--trajectory", action="store_true", help="also write DIR/trajectory.h5")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.outdir import check_writable
    from ringqa.simulation import simulate
    from ringqa.simulation.output import write_outputs
    from ringqa.simulation.scenefile import load_scene, parse_set_args, resolve_scene_path

    check_writable(args.out)
    check_scene_name(args.scene)
    overrides = parse_set_args(args.overrides)
    if args.trajectory:
        overrides["outputs.trajectory"] = True
    scene = load_scene(args.scene, overrides)
    result = simulate(scene, progress=not args.quiet)
    scene_path = resolve_scene_path(args.scene)
    inputs = [scene_path] if scene_path.is_file() else []
    write_outputs(args.out, result, scene, inputs=inputs)
    n = len(result.advances_mm)
    print(
        f"ringqa simulate: {scene.name}: {result.message} ({n} advances, {result.n_elements} "
        f"elements, solve {result.solve_time_s:.3f} s) -> {args.out}/dwells.csv"
    )
    for warning in result.warnings:  # also in run.json; a person reads the terminal
        print(f"ringqa simulate: warning: {warning}", file=sys.stderr)
    if result.status == 0:
        return 0
    return EXIT_JAMMED if result.status == 1 else EXIT_FAILED


def shipped_scenes() -> list[str]:
    """The names of the shipped scenes (``data/scenes/*.toml``), sorted."""
    from ringqa.paths import data_dir

    return sorted(p.stem for p in (data_dir() / "scenes").glob("*.toml"))


def check_scene_name(scene: str) -> None:
    """Refuse a scene that is neither a file nor a shipped scene, naming the shipped ones."""
    from ringqa.errors import RingQAError

    path = Path(scene)
    if path.exists() or path.suffix.lower() == ".toml" or scene in shipped_scenes():
        return  # a file (its own errors), or a shipped name
    raise RingQAError(
        f"{scene}: no such scene file or shipped scene (give the path to a .toml scene file, "
        f"or one of the shipped scenes: {', '.join(shipped_scenes())})"
    )
