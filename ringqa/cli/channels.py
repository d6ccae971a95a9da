"""``ringqa commission`` of several channels of one input (issue 30): each channel its own
simulation, comparison, numerical error and report (``DIR/channel-<N>/``), and the combined
``dwells.csv``, ``doses.csv`` and ``summary.csv`` (with the ``channel`` column),
``channels.json`` (each channel's conclusion, the channels NOT simulated, one conclusion) and
``summary.pdf`` (the report's cross-result summary: every channel's row, the channels not
simulated, the signature block) in ``DIR``, all written together
(:func:`ringqa.outdir.staged_output`).
"""

from __future__ import annotations

import re
import sys

import pandas as pd

__all__ = ["channels_wanted", "run_channels"]


def channels_wanted(item, settings, channel_args) -> list[str] | None:
    """The channels to commission one by one, or None for the single-channel run (one
    ``--channel``, or an input with one default channel: its files as before)."""
    if channel_args:
        return None if len(channel_args) == 1 else [str(c) for c in channel_args]
    from ringqa.errors import RingQAError
    from ringqa.pipeline.commission import default_channels
    from ringqa.pipeline.inputs import load_input

    try:
        app = load_input(item, settings.structures, settings.lumen_mm).applicator
    except RingQAError:
        return None  # the single run says what is wrong
    names = default_channels(app)
    return None if len(names) <= 1 else list(names)


def _folder_name(label: str) -> str:
    return "channel-" + re.sub(r"[^A-Za-z0-9_.-]+", "_", label)


def run_channels(item, settings, wanted, args, fields) -> int:
    """Commission ``wanted`` channels of ``item`` and write the files (module docstring)."""
    from ringqa.jsonio import csv_encoding, write_json
    from ringqa.outdir import staged_output
    from ringqa.pipeline.commission import commission_channels
    from ringqa.report import write_report
    from ringqa.report.tables import FLOAT_FORMAT, with_channel

    runs = commission_channels(item, settings, channels=wanted, progress=not args.quiet)
    with staged_output(args.out) as stage:
        for res in runs.results:
            write_report(
                res,
                stage / _folder_name(res.channel),
                pdf=not args.no_pdf,
                fields=fields,
                export=args.export,
            )
        for name, frames in (
            ("dwells.csv", [with_channel(r, r.dwells) for r in runs.results]),
            ("doses.csv", [with_channel(r, r.doses) for r in runs.results]),
            (
                "summary.csv",
                [with_channel(r, pd.DataFrame([r.summary.as_row()])) for r in runs.results],
            ),
        ):
            table = pd.concat(frames, ignore_index=True)
            table.to_csv(
                stage / name, index=False, float_format=FLOAT_FORMAT, encoding=csv_encoding(table)
            )
        write_json(stage / "channels.json", channels_record(runs), indent=2)
        if not args.no_pdf and runs.results:
            from ringqa.report import write_batch_pdf

            write_batch_pdf(summary_batch(runs), stage / "summary.pdf", fields=fields)
    for res in runs.results:
        verdicts = "; ".join(f"{v.status} {v.check}" for v in res.verdicts)
        print(
            f"ringqa commission: {res.applicator}, channel {res.channel} ({res.reference} "
            f"reference): {verdicts}"
        )
    for note in runs.not_simulated:
        print(f"ringqa commission: warning: {note}", file=sys.stderr)
    print(f"ringqa commission: {conclusion(runs)} -> {args.out}")
    return 0


def summary_batch(runs):
    """The channels as a :class:`ringqa.pipeline.BatchResult` for the report's summary PDF
    (one row per channel, named ``<applicator> channel <N>``; the channels not simulated are
    its failures)."""
    from ringqa.pipeline import BatchResult

    rows = [
        {**r.summary.as_row(), "applicator": f"{r.applicator} channel {r.channel}",
         "error": "", "folder": _folder_name(r.channel)}
        for r in runs.results
    ]  # fmt: skip
    failures = tuple(("not simulated", note) for note in runs.not_simulated)
    labels = tuple(_folder_name(r.channel) for r in runs.results)
    return BatchResult(tuple(runs.results), failures, pd.DataFrame(rows), labels)


def conclusion(runs) -> str:
    """One conclusion for every channel."""
    failed = [r.channel for r in runs.results if not r.passed]
    n = len(runs.results)
    text = (
        f"{n} channels commissioned, all passed"
        if not failed
        else f"{n} channels commissioned; channel(s) {', '.join(failed)} did not pass"
    )
    if runs.not_simulated:
        text += f"; {len(runs.not_simulated)} channel(s) with dwells NOT simulated"
    return text


def channels_record(runs) -> dict:
    """``channels.json``: each channel's folder, conclusion and numerical error, the channels
    not simulated and the conclusion."""
    return {
        "schema": "ringqa.commission-channels/1",
        "channels": [
            {
                "channel": r.channel,
                "name": r.settings.channel,
                "folder": _folder_name(r.channel),
                "passed": r.passed,
                "conclusion": r.conclusion,
                "max_numerical_error_mm": None if r.numerics is None else r.numerics.max_mm,
                "solve_time_s": r.timings.as_dict().get("simulation_s"),
            }
            for r in runs.results
        ],
        "not_simulated": list(runs.not_simulated),
        "conclusion": conclusion(runs),
    }
