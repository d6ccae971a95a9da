"""``ringqa sweep``: an uncertainty and sensitivity study of a commissioning run on Dask.

    ringqa sweep data/sweeps/ring26-uncertainty.toml --out out/sweep
    ringqa sweep spec.toml --out out/sweep --workers 2 --set samples=24 --set seed=7
    ringqa sweep spec.toml --out out/sweep --scheduler tcp://10.0.0.5:8786

Each sample is a converged commissioning run (the input named in the spec) with the spec's
parameters drawn from their distributions (seeded: the same spec and seed give the same
numbers whichever worker runs a sample). The samples run on a Dask LocalCluster of processes
(all cores, or --workers N) or on the cluster at --scheduler, in batches, and are appended to
DIR/samples.h5 as they finish: re-running the same command resumes, skipping finished samples.

--partial writes the outputs from the samples finished so far without running more (a long
study looked at while unfinished; sweep.json says "partial": true).

Writes DIR/samples.h5, summary.csv (per dwell and dose point: mean, sd, p2_5, p97_5),
sensitivity.csv, sweep.json and uncertainty.png. A bad spec (unknown key, negative sd, an
impossible distribution) or an unreachable scheduler: one line, exit 2, nothing written.
See docs/sweeps.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ringqa.cli._options import plain_help
from ringqa.errors import RingQAError


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep",
        help="uncertainty/sensitivity study of a commissioning run on Dask",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("spec", type=Path, metavar="SPEC.toml", help="sweep spec (docs/sweeps.md)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="address of a running Dask scheduler (default: a LocalCluster here)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="worker processes of the LocalCluster (default: all cores)",
    )
    p.add_argument(
        "--set",
        dest="sets",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a spec key: samples=24, seed=7, set.<scene key>=v, "
        "parameters.<key>.<field>=v; repeatable",
    )
    p.add_argument(
        "--partial",
        action="store_true",
        help="run nothing: write the outputs from the samples already in DIR/samples.h5",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.outdir import check_writable
    from ringqa.simulation.scenefile import parse_set_args
    from ringqa.sweep import load_spec, run_sweep
    from ringqa.sweep.store import SAMPLES_NAME

    if args.workers is not None and args.workers < 1:
        raise RingQAError(f"--workers {args.workers}: give a number of processes >= 1")
    if args.workers is not None and args.scheduler:
        raise RingQAError(
            "--workers: the number of workers of an existing --scheduler is its "
            "own; give one of --workers or --scheduler"
        )
    spec = load_spec(args.spec, parse_set_args(args.sets))
    check_writable(args.out, ours=(SAMPLES_NAME,))
    res = run_sweep(
        spec,
        args.out,
        scheduler=args.scheduler,
        workers=args.workers,
        progress=not args.quiet,
        partial=args.partial,
    )
    r = res.record
    print(
        f"ringqa sweep: {r['n_ok']} of {r['n_runs']} samples ok ({r['n_failed']} failed, "
        f"{r['computed_now']} computed now) -> {args.out}"
    )
    if r["n_failed"]:
        print(f"ringqa sweep: {r['failure_report']['text']}")
    if r.get("sensitivity_note"):
        print(f"ringqa sweep: sensitivity.csv: {r['sensitivity_note']}")
    check = r.get("numerical_check", {})
    if check.get("mode") == "calibrated" and check.get("max_error_mm") is not None:
        print(
            f"ringqa sweep: numerical error of each sample (one engine run at the commissioning "
            f"settings) <= {check['max_error_mm']:.3f} mm, measured on "
            f"{len(check['calibration_samples'])} samples run both ways (sweep.json "
            "numerical_check)"
        )
    return 0
