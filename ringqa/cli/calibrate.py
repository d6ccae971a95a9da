"""ringqa calibrate: fit the cable model to the clinic's own measured source paths.

    ringqa calibrate ring26x60 --measured film_ring26.csv --out out/cal
    ringqa calibrate ring26x60 --measured film_ring26.csv ring30x60=film_ring30.csv --out out/cal
    ringqa calibrate plan.dcm --register plane-height --out out/cal   # the plan's library path
    ringqa commission plan.dcm --config out/cal/calibrated_cable.toml --out out/site

Each --measured item is a measured path file of INPUT's ring channel (CSV/JSON in mm with a
relative_position_mm column, optionally sd_mm per point, and a method: see docs/importers.md),
APPLICATOR=FILE for another applicator of the same cable, or an applicator folder/file/plan that
carries its own measured path. Without --measured, INPUT's own path is fitted (a vendor's
library path). The paths are registered to their channels as --register says; points that
cannot lie in the lumen after that are left out of the fit and named.

The fit (weighted least squares, scipy.optimize.least_squares with bounds; docs/calibration.md)
varies --fit KEYS (default contact.mu_k, contact.mu_s, instrument.ei_scale; also
lumen.diameter_delta_mm, fitted per applicator when there are several: the cable's friction and
stiffness are shared, the lumen belongs to each applicator), each point weighted by its
uncertainty and the simulation's numerical error, and reports every key's standard error and
whether the measurement determines it at all (identifiable). With two or more applicators each
is also predicted by the fit on the others.

Writes DIR/calibration.json, calibrated_cable.toml (give it to ringqa commission --config),
residuals.csv, calibration.png and calibration.pdf, all at once at the end; a fit that does not
converge or runs into a bound exits 2 with the reason and writes nothing.
"""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from ringqa.cli._options import add_set_option


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="fit the cable model (friction, stiffness) to measured source paths",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "input",
        metavar="INPUT",
        help="shipped applicator name, folder, applicator JSON or RT Plan (.dcm)",
    )
    p.add_argument(
        "--measured",
        nargs="+",
        default=[],
        metavar="FILE_OR_FOLDER",
        help="measured source path(s): a file of INPUT's ring channel, APPLICATOR=FILE, or an "
        "applicator folder with its own path (default: INPUT's own path)",
    )
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument(
        "--fit",
        nargs="+",
        default=None,
        metavar="KEY",
        help="scene keys to fit (default contact.mu_k contact.mu_s instrument.ei_scale; also "
        "lumen.diameter_delta_mm)",
    )
    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="clinic configuration (cable, registration, scene keys)")  # fmt: skip
    p.add_argument(
        "--register",
        choices=("none", "plane-height", "rigid"),
        default=None,
        help="how the measured paths are aligned with their channels (default: the "
        "configuration's, else none)",
    )
    p.add_argument("--cable", default=None, help="cable model (default: the source's)")
    p.add_argument("--sd-mm", type=float, default=None, dest="sd_mm",
                   help="one uncertainty (mm) for points whose file gives none")  # fmt: skip
    p.add_argument("--method", choices=("film", "ct", "panel", "vendor"), default=None,
                   help="how paths that do not say were measured")  # fmt: skip
    p.add_argument("--no-leave-one-out", action="store_true",
                   help="skip the leave-one-out predictions (two or more applicators)")  # fmt: skip
    add_set_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.calibration.measured import CalibrationError, measured_applicators
    from ringqa.calibration.output import applicator_use, write_outputs
    from ringqa.calibration.run import calibrate, check_keys
    from ringqa.config import effective_config
    from ringqa.outdir import check_writable, staged_output
    from ringqa.provenance import Provenance
    from ringqa.simulation.scenefile import parse_set_args

    keys = check_keys(args.fit)  # refused before any work
    if args.sd_mm is not None and not (args.sd_mm > 0):
        raise CalibrationError(f"--sd-mm {args.sd_mm!r}: must be a number of mm > 0")
    given = {}
    if args.register is not None:
        given["simulation.register"] = args.register
    if args.cable is not None:
        given["simulation.cable"] = args.cable
    for dotted, value in parse_set_args(args.overrides).items():
        given[f"scene.{dotted}"] = value
    config = effective_config(args.config, given)
    settings = config.settings()
    fields = config.report_fields()
    check_writable(args.out)
    measured = measured_applicators(
        args.measured, args.input, settings=settings, sd_mm=args.sd_mm, method=args.method
    )
    cal = calibrate(
        measured, keys=keys, overrides=dict(settings.scene_overrides), stem_mm=settings.stem_mm,
        register=settings.register, leave_one_out=not args.no_leave_one_out,
    )  # fmt: skip
    files = [f for m in measured for f in m.files]
    if args.config is not None:
        files.append(Path(args.config))
    prov = Provenance.now(inputs=files, settings={
        "fit": list(keys), "register": settings.register, "cable": cal.cable,
        "stem_mm": settings.stem_mm, "scene_overrides": dict(settings.scene_overrides),
        "measured": [{"applicator": m.label, "file": m.file, "method": m.method}
                     for m in measured],
    })  # fmt: skip
    command = command_line(args)
    with staged_output(args.out) as stage:
        write_outputs(stage, cal, prov, command=command, fields=fields)
    f = cal.fit
    before, after = cal.used_distances("before"), cal.used_distances("after")
    print(
        f"ringqa calibrate: {', '.join(m.label for m in measured)} ({cal.cable} cable, "
        f"{before.size} points): measured vs simulated median {float(_median(before)):.2f} / max "
        f"{before.max():.2f} mm before, {float(_median(after)):.2f} / {after.max():.2f} mm after "
        f"({cal.seconds:.1f} s) -> {args.out}/calibration.json"
    )
    for k in f.keys:
        se = f.se[k]
        shown = f"± {se:.2g}" if se != float("inf") else "± undetermined"
        flag = "" if f.identifiable[k] else "  (NOT identifiable from these measurements)"
        print(f"  {k} = {f.values[k]:.4g} {shown}{flag}")
    for m in measured:  # each applicator's own lumen (calibration.json applicators[].use)
        use = applicator_use(cal, m.label)
        if use:
            print(f"  {m.label}: its own lumen; commission it with: {use}")
    for lo in cal.left_out:
        print(f"  left out {lo.label}: predicted within median {lo.median_mm:.2f} / max "
              f"{lo.max_mm:.2f} mm")  # fmt: skip
    return 0


def command_line(args: argparse.Namespace) -> str:
    """The ``ringqa calibrate`` command of ``args`` (as it would be typed; recorded in
    calibrated_cable.toml and named by the commissioning report)."""
    words = ["ringqa", "calibrate", str(args.input)]
    if args.measured:
        words += ["--measured", *map(str, args.measured)]
    if args.fit:
        words += ["--fit", *args.fit]
    for flag, value in (("--config", args.config), ("--register", args.register),
                        ("--cable", args.cable), ("--sd-mm", args.sd_mm),
                        ("--method", args.method)):  # fmt: skip
        if value is not None:
            words += [flag, str(value)]
    for item in getattr(args, "overrides", None) or ():
        words += ["--set", str(item)]
    if args.no_leave_one_out:
        words.append("--no-leave-one-out")
    words += ["--out", str(args.out)]
    return shlex.join(words)


def _median(x):
    import numpy as np

    return np.median(x)
