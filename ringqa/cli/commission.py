"""``ringqa commission``: commission ring applicators and write the report.

    ringqa commission ring26x60 --out out/ring26x60
    ringqa commission plan.dcm --out out/oncentra          # RT Plan with Oncentra's library
    ringqa commission --all-shipped --out out/all          # the six shipped rings + summary
    ringqa commission a/ b/ c.json --out out/batch         # several inputs = batch
    ringqa commission my_rings/ --out out/batch            # a folder of applicator folders/files
    ringqa commission plan.dcm --register plane-height --out out/reg   # a 2D reference path
    ringqa commission plan.dcm --centreline-correction ct_ring.csv --out out/ct

The reference path is checked against the channel (positions that cannot lie in the lumen, or
not along the channel; a planar path stored in 2D) and registered to the CHANNEL as --register
says (none: as supplied; plane-height: a planar path at constant height moved into the ring
channel's plane; rigid: a rigid fit to the centreline). Raw and registered numbers are reported
side by side. Every simulation is run twice (commissioning settings and refined) and each dwell's
numerical error is reported.

Writes DIR/dwells.csv, doses.csv, plan_dwells.csv, summary.csv, results.json and report.pdf (one
subfolder per applicator in batch mode, plus the cross-applicator summary.csv, batch.json and
summary.pdf). Nothing is half-written: files are staged and DIR is replaced as a whole at the
end (an earlier ringqa output in DIR completely; a DIR holding other files is refused before any
work). See docs/validation.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ringqa.cli._options import add_set_option
from ringqa.errors import RingQAError


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "commission",
        help="measured vs simulated vs centreline dwell positions and doses, with a PDF report",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "inputs",
        nargs="*",
        metavar="INPUT",
        help="shipped applicator name, folder, applicator JSON or RT Plan (.dcm)",
    )
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--all-shipped",
        action="store_true",
        help="commission every shipped ring applicator (batch)",
    )
    p.add_argument(
        "--source", default=None, help="TG-43 source (default: the RT Plan's, else flexisource)"
    )
    p.add_argument(
        "--prescription-gy",
        type=float,
        default=7.0,
        help="mean Point A dose of the standard plan, Gy (7)",
    )
    p.add_argument(
        "--dose-action-pct", type=float, default=5.0, help="dose-difference action level, %% (5)"
    )
    p.add_argument(
        "--sk-u",
        type=float,
        default=None,
        help="source air-kerma strength, U (default: the RT Plan's; needed to check a plan "
        "without one against its TPS doses)",
    )
    p.add_argument(
        "--register",
        default="none",
        metavar="MODE",
        help="registration of the reference path to the channel: none (default), plane-height "
        "or rigid",
    )
    p.add_argument(
        "--cable",
        default=None,
        help="cable model (flexitron, microselectron; default: the cable of the plan's source)",
    )
    p.add_argument(
        "--stem-mm",
        type=float,
        default=60.0,
        help="straight channel simulated before the first bend, mm (60)",
    )
    p.add_argument(
        "--whole-channel",
        action="store_true",
        help="simulate the whole channel (however long its straight shaft)",
    )
    p.add_argument(
        "--centreline-correction",
        type=Path,
        default=None,
        metavar="FILE",
        help="CT/film centreline segment (CSV x_mm,y_mm,z_mm, proximal -> distal, in the "
        "applicator/plan frame) spliced over the ring centreline (single applicator only)",
    )
    add_set_option(p)
    p.add_argument(
        "--centreline-reference",
        action="store_true",
        help="allow inputs without a measured path (compare simulated vs centreline)",
    )
    p.add_argument(
        "--accuracy-csv",
        type=Path,
        default=None,
        help="accuracy.csv of 'ringqa accuracy' for the scene used (adds a report page)",
    )
    p.add_argument(
        "--sweep",
        type=Path,
        default=None,
        metavar="SPEC",
        help="also run the uncertainty sweep SPEC (docs/sweeps.md) on this input and write "
        "uncertainty.png and uncertainty.csv (per-dwell and per-point intervals) beside the "
        "report (single applicator only)",
    )
    p.add_argument(
        "--uncertainty",
        type=int,
        default=None,
        metavar="N",
        help="as --sweep with the shipped data/sweeps/ring26-uncertainty.toml parameters and N "
        "samples",
    )
    p.add_argument("--no-pdf", action="store_true", help="write the CSV/JSON files only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def _is_applicator_folder(path: Path) -> bool:
    return any((path / f).is_file() for f in ("applicator.json", "centreline.csv"))


def expand_folder(path: Path) -> list[Path] | None:
    """The applicators in a folder OF applicators (None if ``path`` is one applicator's folder).

    An applicator folder holds ``applicator.json`` or ``centreline.csv``; a folder of applicators
    holds such folders, applicator ``.json`` files and/or RT Plans (``.dcm``), commissioned in
    name order.
    """
    if not path.is_dir() or any(
        (path / f).is_file() for f in ("applicator.json", "centreline.csv")
    ):
        return None
    found = [
        p
        for p in sorted(path.iterdir())
        if (p.is_dir() and _is_applicator_folder(p))
        or (p.is_file() and p.suffix.lower() in (".json", ".dcm"))
    ]
    if not found:
        raise RingQAError(
            f"{path}: no applicator in this folder (expected applicator.json + centreline.csv, "
            "or applicator folders / .json files / RT Plans inside it)"
        )
    return found


def _inputs(args) -> list:
    items: list = []
    for item in args.inputs:
        inner = expand_folder(Path(item))
        items += [item] if inner is None else inner
    if args.all_shipped:
        from ringqa.io.applicator_file import shipped_applicators

        items += list(shipped_applicators())
    if not items:
        raise RingQAError("no INPUT given: name an applicator, a folder, a file, or --all-shipped")
    return items


def run(args: argparse.Namespace) -> int:
    from ringqa.outdir import check_writable
    from ringqa.pipeline import CommissionSettings, commission, commission_batch
    from ringqa.report import write_batch, write_report
    from ringqa.simulation.scenefile import parse_set_args

    check_writable(args.out)  # fail before the (long) simulations
    settings = CommissionSettings(
        scene_overrides=parse_set_args(args.overrides),
        source=args.source,
        prescription_gy=args.prescription_gy,
        dose_action_pct=args.dose_action_pct,
        sk_U=args.sk_u,
        cable=args.cable,
        register=args.register,
        stem_mm=None if args.whole_channel else args.stem_mm,
        centreline_correction=args.centreline_correction,
        require_measured=False if args.centreline_reference else None,
    )
    items = _inputs(args)
    single = len(items) == 1 and not args.all_shipped
    single = single and expand_folder(Path(args.inputs[0])) is None
    if args.centreline_correction is not None and not single:
        raise RingQAError(
            "--centreline-correction: give one applicator (each applicator has its own frame; "
            "a correction segment belongs to one)"
        )
    sweep_spec = None
    if args.sweep is not None or args.uncertainty is not None:
        if not single:
            raise RingQAError("--sweep/--uncertainty: give one applicator (a sweep is per input)")
        sweep_spec = _sweep_spec(args, items[0])  # checked before the simulations
    if single:
        res = commission(items[0], settings, progress=not args.quiet)
        write_report(res, args.out, pdf=not args.no_pdf, accuracy_csv=args.accuracy_csv)
        if sweep_spec is not None:
            _write_uncertainty(sweep_spec, args)
        verdicts = "; ".join(f"{v.status} {v.check}" for v in res.verdicts)
        print(
            f"ringqa commission: {res.applicator} ({res.reference} reference): {verdicts} "
            f"-> {args.out}"
        )
        return 0
    batch = commission_batch(items, settings, progress=not args.quiet)
    write_batch(batch, args.out, pdf=not args.no_pdf, progress=not args.quiet)
    n = len(batch.results) + len(batch.failures)
    print(f"ringqa commission: {len(batch.results)} of {n} applicators commissioned -> {args.out}")
    if batch.failures:
        for item, err in batch.failures:
            print(f"ringqa commission: error: {item}: {err}", file=sys.stderr)
        return 2
    return 0


def _sweep_spec(args, item):
    """The sweep spec of --sweep / --uncertainty N, its input set to the commissioned one."""
    from ringqa.paths import data_dir
    from ringqa.sweep import load_spec

    if args.sweep is not None and args.uncertainty is not None:
        raise RingQAError("--sweep and --uncertainty: give one of them")
    path = args.sweep or data_dir() / "sweeps" / "ring26-uncertainty.toml"
    sets = {"input": str(Path(item).resolve()) if Path(item).exists() else str(item)}
    if args.uncertainty is not None:
        sets["samples"] = args.uncertainty
    return load_spec(path, sets)


def _write_uncertainty(spec, args) -> None:
    """Run the sweep in a temporary folder; put uncertainty.png and uncertainty.csv (the
    sweep's summary.csv) in the commissioning output folder, each written atomically."""
    import tempfile

    from ringqa.outdir import atomic_write_bytes
    from ringqa.sweep import run_sweep

    with tempfile.TemporaryDirectory(prefix="ringqa-sweep-") as tmp:
        res = run_sweep(spec, Path(tmp) / "sweep", progress=not args.quiet)
        atomic_write_bytes(args.out / "uncertainty.png", (res.out / "uncertainty.png").read_bytes())
        atomic_write_bytes(args.out / "uncertainty.csv", (res.out / "summary.csv").read_bytes())
    r = res.record
    print(
        f"ringqa commission: uncertainty sweep {r['n_ok']} of {r['n_runs']} samples ok -> "
        f"{args.out / 'uncertainty.png'}, uncertainty.csv"
    )
