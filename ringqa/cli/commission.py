"""ringqa commission: commission ring applicators and write the report.

    ringqa commission ring26x60 --out out/ring26x60
    ringqa commission plan.dcm --out out/oncentra          # RT Plan with Oncentra's library
    ringqa commission --all-shipped --out out/all          # the six shipped rings + summary
    ringqa commission a/ b/ c.json --out out/batch         # several inputs = batch
    ringqa commission my_rings/ --out out/batch            # a folder of applicator folders/files
    ringqa commission plan.dcm --register plane-height --out out/reg   # a 2D reference path
    ringqa commission plan.dcm --centreline-correction ct_ring.csv --out out/ct
    ringqa commission --example --out out/example          # the shipped example plan
    ringqa commission plan.dcm --config site.toml --export --out out/site   # clinic settings,
                                                           # and files back to the planning system

The reference source path (the vendor's library path or your measurement) is checked against
the applicator channel (positions that cannot lie in the lumen or are not along the channel; a
flat path stored in 2D) and aligned with the channel as --register says (none: as supplied;
plane-height: a flat path moved into the ring's plane; rigid: best fit to the channel's centre
line). Numbers as supplied and as aligned are reported side by side. Every simulation is run
twice (commissioning settings and a finer run) and each dwell's numerical error is reported.

Writes DIR/dwells.csv, doses.csv, plan_dwells.csv, summary.csv, results.json, report.pdf and
report.html (a 3D view to open in a browser; one subfolder per applicator for several inputs,
plus summary.csv, batch.json and summary.pdf for all of them). Nothing is half-written: DIR
is replaced as a whole at the end (an earlier ringqa output in DIR completely; a DIR holding
other files is refused before any work). Site settings: --config (docs/config.md). See
docs/validation.md.

Exit status (for scripts, cron jobs and QA databases):
  0    every verdict PASS or WARN (or a FAIL / ACTION without --strict); files written
  1    a verdict FAIL or ACTION with --strict (or report.strict = true); files written
  2    bad input or settings, or a folder that cannot be written; nothing written
  3    the simulation jammed or failed; nothing written (in a batch: the others are)
  130  interrupted (Ctrl-C), 143 terminated (SIGTERM); nothing written
With --log-file FILE the log is an audit trail: inputs and data files with SHA-256, every
setting with its origin, every verdict, every file written with SHA-256, the exit status and
the wall time.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
import time
from pathlib import Path

from ringqa.cli._options import add_set_option, deferred, plain_help
from ringqa.errors import RingQAError


def add_parser(subparsers) -> None:
    add_arguments(_new_parser(subparsers))


def add_parser_deferred(subparsers) -> argparse.ArgumentParser:
    """As :func:`add_parser`, the arguments added when the parser is first used (building them
    imports the settings table, and with it numba and pandas: not for ``ringqa --help``); the
    parser made (:class:`ringqa.cli._options.DeferredArgumentsParser`)."""
    return deferred(_new_parser(subparsers), add_arguments)


def _new_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "commission",
        help="measured vs simulated vs centreline dwell positions and doses, with a PDF report",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.set_defaults(func=run)
    return p


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Every argument of ``ringqa commission`` (in the order ``--help`` lists them)."""
    p.add_argument(
        "inputs",
        nargs="*",
        metavar="INPUT",
        help="shipped applicator name, folder, applicator JSON or RT Plan (.dcm)",
    )
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder")
    p.add_argument(
        "--all-shipped",
        action="store_true",
        help="commission every shipped ring applicator (batch)",
    )
    p.add_argument(
        "--config",
        type=Path,
        default=None,
        metavar="FILE",
        help="clinic configuration (TOML: tolerances, plan, dose points, cable, report fields; "
        "see docs/config.md); command-line options override it. 'ringqa config show' prints "
        "the settings in force",
    )
    p.add_argument(
        "--label",
        action="append",
        metavar="LABEL",
        help="a label for each input, in order (e.g. the applicator's serial number; repeat "
        "for several inputs): printed on its report and, in a batch, the name of its folder "
        "(default: the applicator's name; a repeated name gets -2, -3 ...)",
    )
    p.add_argument(
        "--example",
        action="store_true",
        help="commission the shipped example plan (Oncentra 26 mm / 60 degree ring) as README's "
        "quick start does: with --register plane-height unless --register says otherwise",
    )
    p.add_argument(
        "--export",
        action="store_true",
        help="also write DIR/export/: the simulated source path per channel "
        "(source_path_<channel>.csv) and, for an RT Plan input, RP_simulated.dcm (a copy of "
        "the plan with the ring dwells moved to the simulated positions, for commissioning "
        "verification only; docs/export.md)",
    )
    add_setting_options(p)
    p.add_argument(
        "--centreline-correction",
        type=Path,
        default=None,
        metavar="FILE",
        help="a measured (CT/film) piece of the ring channel's centre line (CSV x_mm,y_mm,z_mm, "
        "entry to tip, in the plan's coordinates) that replaces the library's there (one "
        "applicator only)",
    )
    p.add_argument(
        "--measured",
        type=Path,
        default=None,
        metavar="FILE",
        help="the clinic's measured source path of the channel (CSV/JSON, mm; any subset of "
        "relative positions, optional sd_mm and method: film, ct, panel, vendor) in place of "
        "the input's own; the standard plan stays on the input's library path (one applicator "
        "only)",
    )
    add_set_option(p)
    p.add_argument(
        "--centreline-reference",
        action="store_true",
        help="accept inputs without a reference source path (then the simulated path is "
        "compared with the channel's centre line)",
    )
    p.add_argument(
        "--accuracy-csv",
        type=Path,
        default=None,
        metavar="FILE",
        help="accuracy.csv of 'ringqa accuracy' for the simulation settings used (adds a "
        "report page)",
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
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="processes commissioning a batch's applicators and rendering their reports at "
        "once (default: 2 on a machine with 2 or more cores, else 1; the results are the same "
        "as with 1)",
    )
    p.add_argument("--no-pdf", action="store_true", help="write the CSV/JSON files only")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_channel_options(p)


def add_setting_options(p) -> None:
    """The options of the settings table's rows that have one
    (:data:`ringqa.pipeline.settings.SETTINGS`: option, type from the kind, placeholder, help);
    each defaults to None, so that the configuration decides what is not given."""
    from ringqa.pipeline.settings import SETTINGS

    types = {"number": float, "int": int}
    for s in SETTINGS:
        if not s.option:
            continue
        kw = {"default": None, "help": s.help or s.doc}
        if s.kind == "flag":
            kw["action"] = argparse.BooleanOptionalAction if s.negatable else "store_true"
        else:
            kw["metavar"] = s.metavar or None
            if s.kind in types:
                kw["type"] = types[s.kind]
        p.add_argument(s.option, **kw)


def add_channel_options(p) -> None:
    """``--channel`` (repeatable), ``--structures`` and ``--lumen-mm`` (issue 30)."""
    p.add_argument(
        "--channel",
        action="append",
        default=None,
        metavar="N",
        help="commission this channel (the plan's channel number or the channel's name; "
        "repeatable); default: every channel with a centreline (a ring applicator: its ring)",
    )
    p.add_argument(
        "--structures",
        type=Path,
        default=None,
        metavar="RS.dcm",
        help="an RT Structure Set whose open contours are the RT Plan's channels (matched by "
        "the dwells lying on them)",
    )
    p.add_argument(
        "--lumen-mm",
        type=float,
        default=None,
        metavar="D",
        help="lumen diameter (mm) of the channels read from --structures (default: the "
        "per-applicator table data/applicators/lumen_table.csv)",
    )


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
        raise RingQAError(
            "no INPUT given: name an applicator, a folder, a file, --example or --all-shipped"
        )
    return items


def option_keys() -> dict[str, str]:
    """Command-line option (argparse dest) -> configuration key, from the settings table."""
    from ringqa.pipeline.settings import SETTINGS

    return {s.dest: s.key for s in SETTINGS if s.option}


def command_line_settings(args: argparse.Namespace) -> dict:
    """The settings given on the command line, by configuration key (``--set`` as
    ``scene.<key>``); options not given are left out (the configuration decides)."""
    from ringqa.config import KEYS
    from ringqa.simulation.scenefile import parse_set_args

    specs = {k.key: k for k in KEYS}
    given = {}
    for dest, key in option_keys().items():
        value = getattr(args, dest, None)
        if value is None:
            continue
        problem = specs[key].problem(value)
        if problem and dest not in ("register", "cable", "source"):
            raise RingQAError(f"{specs[key].option} {value!r}: {problem}")
        given[key] = value
    for dotted, value in parse_set_args(getattr(args, "overrides", None)).items():
        given[f"scene.{dotted}"] = value
    return given


def effective(args: argparse.Namespace):
    """The :class:`ringqa.config.EffectiveConfig` of a ``commission`` command line."""
    from ringqa.config import effective_config

    extra = {}
    if getattr(args, "centreline_correction", None) is not None:
        extra["centreline_correction"] = args.centreline_correction
    if getattr(args, "centreline_reference", False):
        extra["require_measured"] = False
    if getattr(args, "measured", None) is not None:
        extra["measured"] = args.measured
    return effective_config(args.config, command_line_settings(args), extra=extra)


def print_warnings(res, prefix: str = "") -> None:
    """One line on stderr per named warning of a result (also in results.json ``warnings`` and
    the report's first page)."""
    for w in res.warning_records():
        print(
            f"ringqa commission: {w['severity']}: {prefix}[{w['name']}] {w['message']}",
            file=sys.stderr,
        )


#: exit statuses of ``ringqa commission`` (README "Exit status", ``--help``)
EXIT_OK = 0  # every verdict PASS or WARN (or a FAIL / ACTION without --strict)
EXIT_FAIL = 1  # --strict (report.strict) and a verdict FAIL or ACTION
EXIT_INPUT = 2  # bad input or settings, or a file that cannot be written: nothing written
EXIT_SOLVER = 3  # the simulation jammed or failed (nothing written)
EXIT_MEANINGS = {
    EXIT_OK: "all verdicts PASS or WARN, or --strict not given",
    EXIT_FAIL: "a verdict is FAIL or ACTION (--strict)",
    EXIT_INPUT: "bad input",
    EXIT_SOLVER: "simulation failure",
    130: "interrupted (SIGINT)",
    143: "terminated (SIGTERM)",
}

#: the audit trail (``ringqa --log-file FILE``, ``-v``): inputs, settings, verdicts, files, exit
log = logging.getLogger(__name__)


def run(args: argparse.Namespace) -> int:
    """``ringqa commission``: commission, write, and leave an audit trail in the log (inputs
    with SHA-256, settings with origin, every verdict, every file written with SHA-256, the exit
    status and the wall time). Returns the exit status (:data:`EXIT_MEANINGS`)."""
    from ringqa.outdir import OutputInterrupted
    from ringqa.pipeline import SimulationJammedError

    t0 = time.perf_counter()
    try:
        code = _run(args)
    except SimulationJammedError as exc:
        print(f"ringqa commission: error: {exc}", file=sys.stderr)
        code = EXIT_SOLVER
    except RingQAError as exc:
        _audit_exit(EXIT_INPUT, t0, str(exc))
        raise
    except OSError as exc:
        _audit_exit(EXIT_INPUT, t0, str(exc))
        raise
    except OutputInterrupted as exc:
        _audit_exit(exc.exit_status, t0)
        raise
    except KeyboardInterrupt:
        _audit_exit(130, t0)
        raise
    _audit_exit(code, t0)
    return code


def _audit_exit(code: int, t0: float, reason: str = "") -> None:
    meaning = EXIT_MEANINGS.get(code, "error")
    why = f": {reason}" if reason else ""
    log.info("exit status %d (%s%s), wall time %.2f s", code, meaning, why,
             time.perf_counter() - t0)  # fmt: skip


def audit_inputs_and_settings(config, results) -> None:
    """Log each result's input files and data files with their SHA-256 and every setting in
    force with its origin (the audit trail's first part)."""
    for res in results:
        prov = res.provenance
        log.info("input: %s (%s, applicator %s)", res.input_label, res.input_kind,
                 res.applicator)  # fmt: skip
        for name, digest in prov.inputs.items():
            log.info("input file: %s SHA-256 %s", name, digest)
        for name, digest in prov.data.items():
            log.info("data file: %s SHA-256 %s", name, digest)
    for key in sorted(config.values):
        log.info("setting: %s = %r (%s)", key, config.values[key], config.origins.get(key, ""))


def audit_verdicts(res) -> None:
    """Log every verdict of ``res`` and its conclusion."""
    from ringqa.pipeline.numbers import fmt_verdict_value

    for v in res.verdicts:
        log.info("verdict: %s: %s %s: %s (%s)", res.applicator, v.status, v.check,
                 fmt_verdict_value(v.value, v.unit, v.check), v.text)  # fmt: skip
    log.info("conclusion: %s: %s", res.applicator, res.conclusion)


def audit_files(out: Path) -> None:
    """Log every file in ``out`` (just written) with its size and SHA-256 (nothing is read or
    hashed when no handler takes the log's INFO lines: neither ``-v`` nor ``--log-file``)."""
    if not log.isEnabledFor(logging.INFO):
        return
    from ringqa.outdir import recorded_digests
    from ringqa.provenance import sha256_of

    # the folder's marker (ringqa.outdir) already lists every file it finished with its size,
    # modification time and SHA-256: a file it lists unchanged is not read and hashed again
    digests = recorded_digests(Path(out))
    files = sorted(p for p in Path(out).rglob("*") if p.is_file())
    for p in files:
        rel, size = p.relative_to(out).as_posix(), p.stat().st_size
        log.info("file written: %s (%d bytes, SHA-256 %s)", rel, size,
                 digests.get(rel) or sha256_of(p))  # fmt: skip
    log.info("%d file(s) written in %s", len(files), out)


def _run(args: argparse.Namespace) -> int:
    from ringqa.outdir import check_writable
    from ringqa.pipeline import commission_batch
    from ringqa.pipeline.batch import check_labels

    # ringqa.report (reportlab, matplotlib, plotly) is imported where it is used: for one
    # input after the commissioning has been forked (commission_ahead), beside it

    if args.example and args.register is None:
        args.register = "plane-height"  # README's quick start (a 2D path: see README)
    config = effective(args)
    settings = config.settings()
    strict = bool(config.values.get("report.strict", False))
    if args.example:
        from ringqa.datasets import example_plan

        args.inputs = [str(example_plan()), *args.inputs]
    check_writable(args.out)  # fail before the (long) simulations
    items = _inputs(args)
    single = len(items) == 1 and not args.all_shipped
    single = single and expand_folder(Path(args.inputs[0])) is None
    if args.centreline_correction is not None and not single:
        raise RingQAError(
            "--centreline-correction: give one applicator (each applicator has its own frame; "
            "a correction segment belongs to one)"
        )
    if getattr(args, "measured", None) is not None and not single:
        raise RingQAError(
            f"--measured {args.measured}: give one applicator (a measured path belongs to one "
            "applicator's channel; commission the others without --measured)"
        )
    sweep_spec = None
    if args.sweep is not None or args.uncertainty is not None:
        if not single:
            raise RingQAError("--sweep/--uncertainty: give one applicator (a sweep is per input)")
        sweep_spec = sweep_spec_for(args, items[0], settings)  # checked before the simulations
    labels = args.label
    check_labels(labels, len(items))
    if args.workers is not None and args.workers < 1:
        raise RingQAError(
            f"--workers {args.workers}: must be a whole number >= 1 (1: one applicator after "
            "the other)"
        )
    settings = _with_channel_settings(settings, args)
    if single:
        ahead = sweep_spec is None and not args.no_pdf  # the report is prepared meanwhile
        # several channels of one input to commission one by one? (asked where the input is
        # read: in the forked process, beside the commissioning)
        res = commission_ahead(
            items[0], settings, not args.quiet, ahead, by_channel=sweep_spec is None,
            channel_args=args.channel,
        )  # fmt: skip
        fields = config.report_fields()  # imports ringqa.report: after the fork
        if isinstance(res, ChannelsWanted):
            from ringqa.cli.channels import run_channels

            runs = run_channels(items[0], settings, list(res.channels), args, fields,
                                named=bool(args.channel),
                                audit=lambda rs: audit_inputs_and_settings(config, rs))  # fmt: skip
            for r in runs.results:
                audit_verdicts(r)
                print_warnings(r, prefix=f"channel {r.channel}: ")
            audit_files(args.out)
            return EXIT_FAIL if strict and not runs.passed else EXIT_OK
        if labels:
            fields = dataclasses.replace(fields, label=labels[0])
        audit_inputs_and_settings(config, [res])
        sections, extra = (), None
        if sweep_spec is not None:
            sections, extra = _run_uncertainty(sweep_spec, args, res)
        from ringqa.report import write_report

        write_report(
            res, args.out, pdf=not args.no_pdf, accuracy_csv=args.accuracy_csv, fields=fields,
            export=args.export, sections=sections, extra_files=extra,
        )  # fmt: skip
        audit_verdicts(res)
        audit_files(args.out)
        print_warnings(res)
        verdicts = "; ".join(f"{v.status} {v.check}" for v in res.verdicts)
        print(
            f"ringqa commission: {res.applicator} ({res.reference} reference): {verdicts} "
            f"-> {args.out}"
        )
        return EXIT_FAIL if strict and not res.passed else EXIT_OK
    fields = config.report_fields()
    batch = commission_batch(items, settings, progress=not args.quiet, labels=labels,
                             workers=args.workers)  # fmt: skip
    audit_inputs_and_settings(config, batch.results)
    from ringqa.report import write_batch

    write_batch(
        batch, args.out, pdf=not args.no_pdf, progress=not args.quiet, fields=fields,
        export=args.export, workers=args.workers,
    )  # fmt: skip
    for res in batch.results:
        audit_verdicts(res)
        print_warnings(res, prefix=f"{res.applicator}: ")
    audit_files(args.out)
    n = len(batch.results) + len(batch.failures)
    print(f"ringqa commission: {len(batch.results)} of {n} applicators commissioned -> {args.out}")
    for item, err in batch.failures:
        log.info("failed: %s: %s", item, err)
        print(f"ringqa commission: error: {item}: {err}", file=sys.stderr)
    if batch.solver_failures:
        return EXIT_SOLVER
    if batch.failures:
        return EXIT_INPUT
    failed = [r for r in batch.results if not r.passed]
    return EXIT_FAIL if strict and failed else EXIT_OK


def _with_channel_settings(settings, args):
    """``settings`` with ``--structures``, ``--lumen-mm`` and a single ``--channel``."""
    extra = {}
    if getattr(args, "structures", None) is not None:
        extra["structures"] = args.structures
    if getattr(args, "lumen_mm", None) is not None:
        extra["lumen_mm"] = args.lumen_mm
    if getattr(args, "channel", None) and len(args.channel) == 1:
        extra["channel"] = str(args.channel[0])
    return dataclasses.replace(settings, **extra) if extra else settings


def _real_std_streams() -> bool:
    """stdout and stderr are the process's own file descriptors (a forked child's output then
    reaches the same place; not so under a test's in-memory capture)."""
    try:
        return sys.stdout.fileno() == 1 and sys.stderr.fileno() == 2
    except (AttributeError, OSError, ValueError):
        return False


@dataclasses.dataclass(frozen=True)
class ChannelsWanted:
    """:func:`commission_ahead`'s answer for an input whose channels are commissioned one by
    one (:func:`ringqa.cli.channels.channels_wanted`): their names."""

    channels: tuple[str, ...]


def commission_ahead(
    item, settings, progress: bool, report: bool = True, *, by_channel: bool = False,
    channel_args=None,
):  # fmt: skip
    """:func:`ringqa.pipeline.commission` of one input, in a forked child process while this
    one loads the report's libraries and fonts (:func:`ringqa.report.prepare_report`: about
    0.5 s of the warm example otherwise spent after the commissioning). The result (or the
    error) is the child's; where it cannot be handed back, on one core, without ``fork``, with
    the output captured in memory, on a first run (an empty kernel cache) or with no core free
    (:func:`ringqa.parallel.second_core_free`), the commissioning runs here as before.

    ``by_channel``: an input with several channels may be commissioned channel by channel
    (``channel_args``: the command's ``--channel`` values, None when none was given): the input
    is read first (in the child, beside the report's preparation here) and, for such an input,
    a :class:`ChannelsWanted` is returned instead of a result."""
    from ringqa.parallel import ForkedCall
    from ringqa.pipeline import commission
    from ringqa.pipeline.simulate import second_core_worthwhile

    def run():  # the input as the channel choice read it is not read twice
        loaded, load_s = None, 0.0
        if by_channel:
            from ringqa.cli.channels import channels_wanted

            wanted, loaded, load_s = channels_wanted(item, settings, channel_args)
            if wanted is not None:
                return ChannelsWanted(tuple(wanted))
        return commission(item, settings, progress=progress, loaded=loaded, load_s=load_s)

    # a first run (numba compiling, with its helper process) stays as it was
    # ... and so does a machine whose cores are busy (the fork would only add its overhead)
    fork = report and _real_std_streams() and second_core_worthwhile()
    call = ForkedCall(run, fork)
    try:
        if call.forked:  # the report's imports and set-up here, beside the child's work
            from ringqa.report import prepare_report

            prepare_report()
        return call.result()
    finally:
        call.cancel()


def sweep_spec_for(args, item, settings=None):
    """The sweep spec of --sweep / --uncertainty N, its input set to the commissioned one and
    its commissioning settings (registration, cable, source, prescription, action level, stem)
    to the command's: the samples vary only the spec's parameters."""
    from ringqa.paths import data_dir
    from ringqa.sweep import load_spec

    if args.sweep is not None and args.uncertainty is not None:
        raise RingQAError("--sweep and --uncertainty: give one of them")
    path = args.sweep or data_dir() / "sweeps" / "ring26-uncertainty.toml"
    sets = {"input": str(Path(item).resolve()) if Path(item).exists() else str(item)}
    if args.uncertainty is not None:
        sets["samples"] = args.uncertainty
    for row in sweep_setting_rows() if settings is not None else ():
        value = getattr(settings, row.field, None)
        if value is not None and (row.field != "source" or isinstance(value, str)):
            sets[f"settings.{row.key.split('.')[-1]}"] = value
    return load_spec(path, sets)


def sweep_setting_rows():
    """The rows of the settings table a --sweep / --uncertainty run takes over from the command
    (registration, cable, source, S_K, prescription, action level, stem: so the uncertainty
    page judges the same comparison as the report's verdicts; the samples vary only the spec's
    parameters)."""
    from ringqa.pipeline.settings import SETTINGS
    from ringqa.sweep.spec import SWEEP_SETTING_FIELDS

    return [s for s in SETTINGS if s.field in SWEEP_SETTING_FIELDS and s.kind != "flag"]


def _run_uncertainty(spec, args, res=None) -> tuple[tuple, dict[str, bytes]]:
    """Run the sweep in a temporary folder; return the report's uncertainty page (a section)
    and the files it adds to the output folder (``uncertainty.png``; ``uncertainty.csv``: the
    sweep's summary.csv; ``uncertainty_sweep.json``: its sweep.json), written with the report in
    one staged folder."""
    import tempfile

    from ringqa.report.tables import input_base
    from ringqa.report.uncertainty import uncertainty_section
    from ringqa.sweep import run_sweep

    base = None if res is None else input_base(res)
    with tempfile.TemporaryDirectory(prefix="ringqa-sweep-") as tmp:
        res = run_sweep(spec, Path(tmp) / "sweep", progress=not args.quiet)
        png = (res.out / "uncertainty.png").read_bytes()
        csv = (res.out / "summary.csv").read_bytes()
        record = _relative_record((res.out / "sweep.json").read_bytes(), base)
    r = res.record
    print(
        f"ringqa commission: uncertainty sweep {r['n_ok']} of {r['n_runs']} samples ok "
        "(report page 'Uncertainty', uncertainty.png, uncertainty.csv)"
    )
    section = uncertainty_section(res.summary, png, r)
    return (section,), {
        "uncertainty.png": png,
        "uncertainty.csv": csv,
        "uncertainty_sweep.json": record,  # spec, seed, versions, timings, every failure
    }


def _relative_record(data: bytes, base) -> bytes:
    """The sweep's record with every absolute path in it named as outputs name files
    (:func:`ringqa.provenance.relative_paths`: ``ringqa:data/...`` or relative to the input's
    folder), never an install path."""
    import json

    from ringqa.jsonio import json_text
    from ringqa.provenance import relative_paths

    return json_text(relative_paths(json.loads(data), base), indent=2).encode()
