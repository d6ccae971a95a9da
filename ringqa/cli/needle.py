"""``ringqa needle``: insertion force of a catheter pushed through an S-shaped channel.

One channel (the paper's S channel with --radius-mm/--torsion-rad/--diameter-mm, default
r = 35 mm, tau = 0, 2.6 mm; or, with a SCENE and none of those options, the scene's own channel,
e.g. a centreline file; or, with --applicator, an applicator's channel, e.g. a free-form
3-D printed channel folder: "will this needle pass, at what force?"), pushed 120 mm at 5 mm/s;
writes

  DIR/force_depth.csv   depth_mm, force_n (filtered like the measurements), force_raw_n
  DIR/force_depth.png   the curve, the bends shaded, the 1st peak, plateau and 2nd peak marked
  DIR/peaks.csv         1st peak, plateau, 2nd peak (N) and their depths (mm), status
  DIR/run.json          settings, status, timings, software versions

With --sweep paper: the paper's three families (radius 20..60 mm, torsion 0..pi, diameter
2.6..3.0 mm), each at the nominal and the +0.2 mm diameter (34 rows), on --workers processes;
writes DIR/peaks.csv, DIR/force_depth.csv, DIR/figure8_force_depth.png, DIR/figure9_peaks.png
and DIR/run.json. --sweep also takes one family or a comma-separated list (radius,torsion,diameter).

SCENE (default: the shipped needle-paper scene) gives the settings: catheter, contact, friction,
speed, link length, increment; override any with --set KEY=VALUE. See docs/needle.md.

Exit status: 0 success; 1 a run jammed (files written); 3 a run failed (files written);
2 bad input (nothing written).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ringqa.cli._options import add_set_option, plain_help

EXIT_JAMMED = 1
EXIT_FAILED = 3


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "needle",
        help="catheter insertion force in S-shaped channels (one channel or the paper's sweep)",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "scene",
        nargs="?",
        default=None,
        help="scene TOML file or shipped scene name for the settings (default needle-paper)",
    )
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--radius-mm", type=float, default=None, help="bend radius r (mm; 35)")
    p.add_argument("--torsion-rad", type=float, default=None, help="torsion tau, 0..pi (rad; 0)")
    p.add_argument("--diameter-mm", type=float, default=None, help="channel diameter (mm; 2.6)")
    p.add_argument(
        "--sweep",
        default=None,
        metavar="FAMILIES",
        help="run the paper's study: 'paper' (all), or radius, torsion, diameter (comma list)",
    )
    p.add_argument(
        "--workers", type=int, default=None, help="processes for --sweep (default 2; 1 = serial)"
    )
    p.add_argument(
        "--applicator",
        type=Path,
        default=None,
        metavar="PATH",
        help="push the catheter through this applicator's channel (a free-form folder with "
        "centreline.csv + applicator.json, an applicator JSON or a shipped name)",
    )
    p.add_argument(
        "--channel", default=None, help="the --applicator's channel (default: its first)"
    )
    add_set_option(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _inputs(scene_ref) -> list[Path]:
    if scene_ref is None:
        from ringqa.needle.scene import DEFAULT_SCENE
        from ringqa.paths import data_dir

        path = data_dir() / "scenes" / f"{DEFAULT_SCENE}.toml"
    else:
        path = Path(scene_ref)
        if not path.is_file():
            from ringqa.paths import data_dir

            path = data_dir() / "scenes" / f"{scene_ref}.toml"
    return [path] if path.is_file() else []


def _exit_code(statuses) -> int:
    from ringqa.needle.output import worst_status

    return {0: 0, 1: EXIT_JAMMED, -1: EXIT_FAILED}[worst_status(statuses)]


def run(args: argparse.Namespace) -> int:
    from ringqa.needle.scene import NeedleError, load_settings
    from ringqa.outdir import check_writable
    from ringqa.simulation.scenefile import parse_set_args

    check_writable(args.out)
    geometry = {
        "--radius-mm": args.radius_mm,
        "--torsion-rad": args.torsion_rad,
        "--diameter-mm": args.diameter_mm,
    }
    given = [k for k, v in geometry.items() if v is not None]
    if getattr(args, "applicator", None) is not None:
        if given or args.sweep is not None:
            raise NeedleError(
                "--applicator: not with --radius-mm/--torsion-rad/--diameter-mm or --sweep (the "
                "applicator's channel is the channel)"
            )
    elif getattr(args, "channel", None) is not None:
        raise NeedleError("--channel: only with --applicator")
    if args.sweep is not None:
        from ringqa.needle.sweep import parse_families

        if given:
            raise NeedleError(
                f"{given[0]}: not with --sweep (the sweep runs the paper's channels); drop it"
            )
        families = parse_families(args.sweep)
        if args.workers is not None and args.workers < 1:
            raise NeedleError(f"--workers {args.workers}: at least 1")
        settings = load_settings(args.scene, parse_set_args(args.overrides))
        return _sweep(args, settings, families)
    if args.workers is not None:
        raise NeedleError("--workers: only with --sweep (one channel runs in one process)")
    settings = load_settings(args.scene, parse_set_args(args.overrides))
    return _single(args, settings, given)


def _single(args, settings, given) -> int:
    from ringqa.needle.output import write_channel_outputs
    from ringqa.needle.run import run_channel
    from ringqa.needle.scene import ChannelSpec, paper_channel

    spec = None
    if getattr(args, "applicator", None) is not None:
        channel = applicator_channel(args.applicator, args.channel, settings)
    elif args.scene is None or given:
        d = ChannelSpec()
        spec = ChannelSpec(
            d.radius_mm if args.radius_mm is None else args.radius_mm,
            d.torsion_rad if args.torsion_rad is None else args.torsion_rad,
            d.diameter_mm if args.diameter_mm is None else args.diameter_mm,
        )
        channel = paper_channel(spec, settings)
    else:
        channel = settings.channel
    result = run_channel(channel, settings)
    write_channel_outputs(args.out, result, channel, settings, spec, inputs=_inputs(args.scene))
    p = result.peaks
    print(
        f"ringqa needle: {result.name}: {result.message}; 1st peak {p.peak1_n:.2f} N at "
        f"{p.peak1_depth_mm:.1f} mm, plateau {p.plateau_n:.2f} N, 2nd peak {p.peak2_n:.2f} N at "
        f"{p.peak2_depth_mm:.1f} mm (solve {result.solve_time_s:.2f} s) -> {args.out}/peaks.csv"
    )
    return _exit_code([result.status])


def _sweep(args, settings, families) -> int:
    from ringqa.needle.output import write_sweep_outputs
    from ringqa.needle.sweep import run_sweep

    sweep = run_sweep(settings, families, workers=args.workers, progress=not args.quiet)
    write_sweep_outputs(args.out, sweep, inputs=_inputs(args.scene))
    runs = list(sweep.runs.values())
    bad = sum(r.status != 0 for r in runs)
    print(
        f"ringqa needle: {len(sweep.points)} rows, {len(runs)} channels simulated "
        f"({bad} jammed/failed) in {sweep.wall_time_s:.1f} s on {sweep.workers} "
        f"process(es) -> {args.out}/peaks.csv"
    )
    return _exit_code(r.status for r in runs)


def applicator_channel(path, name, settings):
    """The channel ``name`` (default the first) of the applicator at ``path``, checked against
    the catheter (:func:`ringqa.needle.scene.check_channel`)."""
    from ringqa.io.applicator_file import load_applicator
    from ringqa.needle.scene import check_channel

    app = load_applicator(path)
    channel = app.channels[0] if name is None else app.channel(name)
    check_channel(channel, settings)
    return channel
