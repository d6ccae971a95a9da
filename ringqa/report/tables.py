"""CSV and JSON writers for commissioning results (the file contract other tools read).

Files per applicator (issue 5):

- ``dwells.csv``: one row per dwell and path (``measured``/``simulated``/``centreline``).
- ``doses.csv``: one row per dose point and plan (``measured``/``simulated``/``centreline``; and
  ``rtplan`` = the RT Plan's own dwells at its TPS points, beside ``tps_dose_gy``).
- ``plan_dwells.csv``: the standard plans' dwells and (equal) dwell times.
- ``summary.csv``: one row per applicator.
- ``results.json``: stable keys (``schema`` = ``ringqa.commission/1``), provenance included.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ringqa.jsonio import csv_encoding, to_jsonable, write_json
from ringqa.pipeline import BatchResult, CommissioningResult
from ringqa.provenance import input_folder, relative_paths

SCHEMA = "ringqa.commission/1"
FLOAT_FORMAT = "%.6g"
#: results.json ``files``: what a run writes into its folder (report.pdf and report.html unless
#: --no-pdf)
FILES = ("dwells.csv", "doses.csv", "plan_dwells.csv", "summary.csv", "report.pdf", "report.html")


def results_dict(result: CommissioningResult, files=FILES) -> dict:
    """The results.json content of one CommissioningResult (stable keys, plain JSON data);
    ``files``: what the run writes into its folder (default :data:`FILES`)."""
    points = (
        result.doses[result.doses["plan"] == result.reference][
            ["point", "kind", "x_mm", "y_mm", "z_mm"]
        ].to_dict("records")
        if not result.doses.empty
        else []
    )
    base = input_base(result)
    data = to_jsonable(
        {
            "schema": SCHEMA,
            "applicator": result.applicator,
            "input": result.input_label,
            "input_kind": result.input_kind,
            "reference": result.reference,
            "passed": result.passed,
            "verdicts": [v.as_dict() for v in result.verdicts],
            "summary": {**result.summary_row(), "channel": channel_of_result(result)},
            "notes": list(result.notes),
            "warnings": result.warning_records(),
            "settings": result.settings.as_dict(),
            "settings_origin": dict(getattr(result, "settings_origin", {}) or {}),
            "simulation": result.simulation.as_dict(),
            "dose_points": points,
            "doses": result.doses.to_dict("records"),
            "geometry": result.geometry.as_dict(),
            "timings_s": result.timings.as_dict(),
            "provenance": result.provenance.as_dict(),
            "files": list(files),
            "conclusion": result.conclusion,
            "reference_check": (
                result.reference_check.as_dict() if result.reference_check is not None else None
            ),
            "numerical_check": result.numerics.as_dict() if result.numerics is not None else None,
        }
    )
    if getattr(result, "measured_points", None) is not None:  # a measured subset
        data["measured_points"] = to_jsonable(result.measured_points)
    out = relative_paths(data, base)
    # the input as given (two inputs of one batch stay apart), as summary.csv names it
    out["input"] = out["summary"]["input"] = result.input_label
    return out


def input_base(result: CommissioningResult) -> Path | None:
    """The folder a result's own files are named relative to in its outputs (the input's
    folder; None for a shipped input or a Python object)."""
    p = Path(result.input)
    if result.input_kind in ("shipped", "object") or not p.exists():
        return None
    return input_folder(p)


def channel_of_result(result: CommissioningResult) -> str:
    """The ``channel`` column's value of a result (its ``channel``, else the channel simulated)."""
    return str(getattr(result, "channel", "") or result.settings.channel)


def with_channel(result: CommissioningResult, df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with the ``channel`` column last (CONTRACT: the plan's channel number, or the
    channel's name for file inputs; ``"all"`` on the rows of the RT Plan's own dwells, which are
    every channel's). Last, so that readers indexing the older columns by position still
    work."""
    label = channel_of_result(result)
    if "channel" in df.columns:
        return df
    out = df.copy()
    value = label
    if "plan" in out.columns:
        value = [("all" if p == "rtplan" else label) for p in out["plan"]]
    out["channel"] = value
    return out


def write_tables(result: CommissioningResult, folder: Path, files=FILES) -> list[Path]:
    """Write dwells.csv, doses.csv, plan_dwells.csv, summary.csv and results.json into folder
    (dwells, doses and summary with the ``channel`` column: :func:`with_channel`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for name, df in (
        ("dwells.csv", with_channel(result, result.dwells)),
        ("doses.csv", with_channel(result, result.doses)),
        ("plan_dwells.csv", result.plan_dwells),
        ("summary.csv", with_channel(result, pd.DataFrame([result.summary_row()]))),
    ):
        df.to_csv(folder / name, index=False, float_format=FLOAT_FORMAT, encoding=csv_encoding(df))
        out.append(folder / name)
    write_json(folder / "results.json", results_dict(result, files), indent=2)
    out.append(folder / "results.json")
    return out


def batch_summary_with_channel(batch: BatchResult) -> pd.DataFrame:
    """The batch's summary with the ``channel`` column last (each result's channel, matched by
    its output folder; ``""`` for a failed input)."""
    summary = batch.summary
    if "channel" in summary.columns or "folder" not in summary.columns:
        return summary
    by_folder = {batch.label(i): channel_of_result(r) for i, r in enumerate(batch.results)}
    out = summary.copy()
    out["channel"] = [by_folder.get(f, "") for f in out["folder"]]
    return out


def write_batch_tables(batch: BatchResult, folder: Path) -> list[Path]:
    """The cross-applicator summary.csv, all_dwells.csv and batch.json of a BatchResult."""
    folder = Path(folder)
    summary = batch_summary_with_channel(batch)
    summary.to_csv(
        folder / "summary.csv", index=False, float_format=FLOAT_FORMAT,
        encoding=csv_encoding(summary),
    )  # fmt: skip
    for name, frames in (
        ("all_dwells.csv", [with_channel(r, r.dwells) for r in batch.results]),
        ("all_doses.csv", [with_channel(r, r.doses) for r in batch.results]),
    ):
        if frames:
            table = pd.concat(frames, ignore_index=True)
            table.to_csv(
                folder / name, index=False, float_format=FLOAT_FORMAT,
                encoding=csv_encoding(table),
            )  # fmt: skip
    info = {
        "schema": "ringqa.commission-batch/1",
        "applicators": [r.applicator for r in batch.results],
        "folders": [batch.label(i) for i in range(len(batch.results))],
        "failures": [{"input": i, "error": e} for i, e in batch.failures],
        "summary": batch.summary.to_dict("records"),
        "provenance": batch.results[0].provenance.as_dict() if batch.results else None,
    }
    write_json(folder / "batch.json", info, indent=2)
    return [folder / "summary.csv", folder / "batch.json"]


#: results.json of a several-channel run (issue 30): the one conclusion and a section per channel
CHANNELS_SCHEMA = "ringqa.commission-channels/2"


def channels_results_dict(
    results, not_simulated, conclusion: str, folders, *, files=FILES, channel_files=FILES
) -> dict:
    """The results.json of several channels of one input: ``conclusion`` (one for every
    channel), ``passed``, ``not_simulated`` (one sentence per channel with dwells left out) and
    ``channels``: per channel its ``channel`` (the tables' column), ``name``, ``family``,
    ``folder`` (its files), ``passed``, ``conclusion``, ``max_numerical_error_mm``,
    ``solve_time_s`` and ``results`` (that channel's whole results.json, :func:`results_dict`,
    listing ``channel_files``); ``files``: what the run writes beside them.
    """
    channels = []
    for res, folder in zip(results, folders, strict=True):
        channels.append(
            {
                "channel": channel_of_result(res),
                "name": res.settings.channel,
                "family": getattr(res, "family", "ring"),
                "folder": folder,
                "passed": res.passed,
                "conclusion": res.conclusion,
                "max_numerical_error_mm": None if res.numerics is None else res.numerics.max_mm,
                "solve_time_s": res.timings.as_dict().get("simulation_s"),
                "results": results_dict(res, channel_files),
            }
        )
    first = results[0]
    return to_jsonable(
        {
            "schema": CHANNELS_SCHEMA,
            "applicator": first.applicator,
            "input": first.input_label,
            "passed": not not_simulated and all(r.passed for r in results),
            "conclusion": conclusion,
            "not_simulated": list(not_simulated),
            "channels": channels,
            "files": list(files),
        }
    )
