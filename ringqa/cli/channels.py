"""``ringqa commission`` of several channels of one input (issue 30): each channel its own
simulation, comparison and numerical error, written together
(:func:`ringqa.outdir.staged_output`) as

- ``report.pdf``: ONE report, a front page with one conclusion over every channel and the verdict
  table per channel, then a section per channel (the pages of a one-channel report, headed with
  the channel's number, name and family; :func:`ringqa.report.write_channels_pdf`);
- ``results.json``: the conclusion, the channels NOT commissioned (by name, with why) and a
  section per channel (:func:`ringqa.report.tables.channels_results_dict`);
- ``dwells.csv``, ``doses.csv``, ``plan_dwells.csv``, ``summary.csv``: every channel's rows with
  the ``channel`` column (the RT Plan's own-dwell dose rows, ``channel = all``, once);
- ``channel-<N>/``: each channel's own tables, results.json and report.html (and ``export/``).
"""

from __future__ import annotations

import re
import sys

import pandas as pd

__all__ = ["channels_wanted", "conclusion", "run_channels"]


def channels_wanted(item, settings, channel_args) -> tuple[list[str] | None, object, float]:
    """The channels to commission one by one (None for the one-channel run: one ``--channel``,
    or an input whose default choice is one channel: its files as before, with the plan's other
    channels named in its warnings), the input as loaded for the choice (None when not
    loaded; :func:`ringqa.pipeline.commission` takes it, so it is read once) and the seconds
    the loading took.

    Without ``--channel``: an RT Plan's channels with dwells and a centreline (those without a
    reference source path where one is required are named, not commissioned:
    :func:`ringqa.pipeline.commission.channel_choice`); other inputs: the family's default (a
    ring applicator: its ring)."""
    if channel_args:
        return (None if len(channel_args) == 1 else [str(c) for c in channel_args]), None, 0.0
    import time

    from ringqa.errors import RingQAError
    from ringqa.pipeline.commission import channel_choice, load_commission_input

    t0 = time.perf_counter()
    try:
        loaded = load_commission_input(item, settings)  # as commission() loads it
    except RingQAError:
        return None, None, 0.0  # the single run says what is wrong
    load_s = time.perf_counter() - t0
    names = channel_choice(loaded, settings.require_measured).names
    return (None if len(names) <= 1 else list(names)), loaded, load_s


def _folder_name(label: str) -> str:
    return "channel-" + re.sub(r"[^A-Za-z0-9_.-]+", "_", label)


def combined_tables(results) -> dict[str, pd.DataFrame]:
    """dwells.csv, doses.csv, plan_dwells.csv and summary.csv of every channel (the ``channel``
    column last; the RT Plan's own-dwell dose rows, the same in every channel's run, once)."""
    from ringqa.report.tables import with_channel

    doses = pd.concat([with_channel(r, r.doses) for r in results], ignore_index=True)
    if "plan" in doses.columns:
        own = doses["plan"] == "rtplan"
        doses = pd.concat(
            [doses[~own], doses[own].drop_duplicates(subset=["point", "plan"])],
            ignore_index=True,
        )
    plan_dwells = pd.concat(
        [r.plan_dwells.assign(channel=r.channel or r.settings.channel) for r in results],
        ignore_index=True,
    )
    tables = {
        "dwells.csv": pd.concat([with_channel(r, r.dwells) for r in results], ignore_index=True),
        "doses.csv": doses,
        "plan_dwells.csv": plan_dwells,
        "summary.csv": pd.concat(
            [with_channel(r, pd.DataFrame([r.summary_row()])) for r in results],
            ignore_index=True,
        ),
    }
    # the channel column last (a column only some channels have, e.g. the registered numbers,
    # would otherwise follow it)
    return {name: t[[c for c in t.columns if c != "channel"] + ["channel"]]
            for name, t in tables.items()}  # fmt: skip


def run_channels(item, settings, wanted, args, fields, *, named: bool = True, audit=None):
    """Commission the channels of ``item`` (``wanted`` when ``named``, else the default choice)
    and write the files (module docstring); ``audit(results)`` is called before anything is
    written (the audit trail's inputs and settings). Returns the
    :class:`~ringqa.pipeline.commission.ChannelRuns` (the caller logs the verdicts and files and
    chooses the exit status)."""
    from ringqa.jsonio import csv_encoding, write_json
    from ringqa.outdir import staged_output
    from ringqa.pipeline.commission import commission_channels
    from ringqa.report import write_channels_pdf, write_report
    from ringqa.report.tables import FLOAT_FORMAT, channels_results_dict

    runs = commission_channels(
        item, settings, channels=wanted if named else None, progress=not args.quiet
    )
    results = runs.results
    if audit is not None:
        audit(results)
    text = conclusion(runs)
    folders = [_folder_name(r.channel or r.settings.channel) for r in results]
    with staged_output(args.out) as stage:
        own = ["dwells.csv", "doses.csv", "plan_dwells.csv", "summary.csv"]
        own += [] if args.no_pdf else ["report.html"]  # the channel's PDF is a section of ours
        for res, folder in zip(results, folders, strict=True):
            write_report(res, stage / folder, pdf=False, fields=fields, export=args.export,
                         html=not args.no_pdf, files=own)  # fmt: skip
        for name, table in combined_tables(results).items():
            table.to_csv(
                stage / name, index=False, float_format=FLOAT_FORMAT, encoding=csv_encoding(table)
            )
        files = ["dwells.csv", "doses.csv", "plan_dwells.csv", "summary.csv"]
        files += [] if args.no_pdf else ["report.pdf"]
        record = channels_results_dict(
            results, runs.not_simulated, text, folders, files=files, channel_files=own
        )
        write_json(stage / "results.json", record, indent=2)
        if not args.no_pdf:
            write_channels_pdf(results, stage / "report.pdf", conclusion=text,
                               not_simulated=runs.not_simulated, fields=fields)  # fmt: skip
    for res in results:
        verdicts = "; ".join(f"{v.status} {v.check}" for v in res.verdicts)
        print(
            f"ringqa commission: {res.applicator}, channel {res.channel} ({res.reference} "
            f"reference): {verdicts}"
        )
    for note in runs.not_simulated:
        print(f"ringqa commission: warning: {note}", file=sys.stderr)
    print(f"ringqa commission: {text} -> {args.out}")
    return runs


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
        text += f"; {len(runs.not_simulated)} channel(s) with dwells NOT commissioned (named below)"
    return text + "."
