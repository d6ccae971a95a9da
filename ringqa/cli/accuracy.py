"""``ringqa accuracy``: what accuracy each simulation setting buys, and at what time.

Runs the scene over a grid of settings (element length per cable section, increment or time
step, tolerance, solver kind, each optional effect on/off), compares every run with a reference
refined until it no longer changes, and writes:

  DIR/accuracy.csv      one row per run: the settings, time_s, max_err_mm, median_err_mm,
                        max_err_deg, dose_err_pct, status, pareto, ...
  DIR/accuracy.png      error vs time (log-log), each run labelled, the Pareto front marked
  DIR/recommended.toml  the scene with the cheapest settings meeting --target-mm
  DIR/reference.csv     the reference's refinement levels and how they agree
  DIR/runs.jsonl        finished runs: re-running the command resumes from them

Exit status: 0 done (a recommendation was found), 1 no setting in the grid meets the target,
2 bad input. Interrupt with Ctrl-C and run the same command again to resume.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ringqa.cli._options import add_set_option, plain_help


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "accuracy",
        help="accuracy/time study of a scene's numerical settings",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("scene", help="scene TOML file, or a shipped scene name (ring26-flexitron)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument("--target-mm", type=float, default=0.1, help="accuracy to meet (mm, 0.1)")
    add_set_option(p)
    p.add_argument("--repeats", type=int, default=3, help="timed repeats per run (median; 3)")
    p.add_argument(
        "--factors",
        default="2,1,0.5,0.25",
        help="refinement factors of element length and increment/time step (2,1,0.5,0.25)",
    )
    p.add_argument("--max-levels", type=int, default=4, help="most reference refinement levels (4)")
    p.add_argument(
        "--max-ref-time-s",
        type=float,
        default=120.0,
        help="do not start a reference level predicted to take longer (s; 120)",
    )
    p.add_argument(
        "--formulations",
        action="store_true",
        help="instead of the settings grid: run the rigid and the flexible engine "
        "(model.formulation) over --factors, print each one's order of convergence and cost per "
        "accuracy and write DIR/formulations.csv",
    )
    p.add_argument("--fresh", action="store_true", help="ignore runs cached in DIR")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.accuracy import run_study
    from ringqa.accuracy.cache import CACHE_NAME
    from ringqa.errors import RingQAError
    from ringqa.outdir import check_writable
    from ringqa.simulation.scenefile import load_scene, parse_set_args

    check_writable(args.out, ours=(CACHE_NAME,))  # the run cache of an interrupted study
    if not (math.isfinite(args.target_mm) and args.target_mm > 0):
        raise RingQAError(f"--target-mm {args.target_mm}: must be a positive number of mm")
    if args.repeats < 1:
        raise RingQAError(f"--repeats {args.repeats}: must be at least 1")
    try:
        factors = tuple(float(x) for x in args.factors.split(","))
    except ValueError:
        raise RingQAError(f"--factors {args.factors!r}: give numbers like 2,1,0.5,0.25") from None
    if not factors or not all(math.isfinite(f) and f > 0 for f in factors):
        raise RingQAError(f"--factors {args.factors!r}: factors must be positive numbers")
    if args.max_levels < 2:
        raise RingQAError(f"--max-levels {args.max_levels}: at least 2 (two levels must agree)")
    scene = load_scene(args.scene, parse_set_args(args.overrides))
    if getattr(args, "formulations", False):
        return _formulations(scene, factors, args)
    study = run_study(
        scene,
        target_mm=args.target_mm,
        out_dir=args.out,
        progress=not args.quiet,
        resume=not args.fresh,
        repeats=args.repeats,
        max_levels=args.max_levels,
        factors=factors,
        max_ref_time_s=args.max_ref_time_s,
    )
    t = study.table
    n_bad = int((t["status"] != 0).sum())
    print(
        f"ringqa accuracy: {scene.name}: {len(t)} runs ({n_bad} jammed/failed), reference "
        f"{'converged' if study.reference.converged else 'NOT converged'} "
        f"(finest levels agree to {study.reference.agreement_mm:.2g} mm)"
    )
    for w in study.warnings:
        print(f"ringqa accuracy: warning: {w}")
    from ringqa.accuracy.study import recommendation_summary

    for target, row in recommendation_summary(study).items():
        what = (
            "none in the grid"
            if row is None
            else (
                f"#{row['run']} {row['label']}: {row['max_err_mm']:.3g} mm, {row['time_s']:.3g} s"
            )
        )
        print(f"ringqa accuracy:   cheapest meeting {target} mm: {what}")
    if study.recommended is None:
        print(f"ringqa accuracy: no setting meets {args.target_mm:g} mm -> {args.out}/accuracy.csv")
        return 1
    r = study.recommended
    print(
        f"ringqa accuracy: cheapest meeting {args.target_mm:g} mm: {r['label']} "
        f"({r['max_err_mm']:.3g} mm, {r['time_s']:.3g} s) -> {args.out}/recommended.toml"
    )
    return 0


def _formulations(scene, factors, args) -> int:
    """``--formulations``: both engines over the factors (ringqa.accuracy.compare_formulations)."""
    from dataclasses import asdict

    import pandas as pd

    from ringqa.accuracy import compare_formulations

    study = compare_formulations(scene, factors, target_mm=args.target_mm)
    print(f"ringqa accuracy: {scene.name}: rigid vs flexible engine")
    print(study.text())
    args.out.mkdir(parents=True, exist_ok=True)
    pd.DataFrame([asdict(lv) for lv in study.levels]).to_csv(
        args.out / "formulations.csv", index=False
    )
    print(f"ringqa accuracy: -> {args.out}/formulations.csv")
    return 0
