"""Report writers: the CSV/JSON contract files and the PDF a physicist signs.

Public API::

    from ringqa.report import write_report, write_batch
    write_report(result, "out/ring26x60")   # dwells.csv doses.csv plan_dwells.csv summary.csv
                                            # results.json report.pdf, staged (never half-written)
    write_batch(batch, "out/")              # one subfolder per applicator + summary.csv,
                                            # batch.json, summary.pdf
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ringqa.errors import InputFileError
from ringqa.jsonio import write_json
from ringqa.outdir import MARKER_NAME, marker_record, staged_output
from ringqa.report.pdf import write_batch_pdf, write_pdf
from ringqa.report.tables import SCHEMA, results_dict, write_batch_tables, write_tables

__all__ = [
    "SCHEMA",
    "read_accuracy_csv",
    "results_dict",
    "write_batch",
    "write_batch_pdf",
    "write_pdf",
    "write_report",
    "write_tables",
]


ACCURACY_COLUMNS = ("time_s", "max_err_mm", "status")


def read_accuracy_csv(path) -> pd.DataFrame:
    """Read ``accuracy.csv`` of ``ringqa accuracy`` (for the report's accuracy page)."""
    p = Path(path)
    try:
        table = pd.read_csv(p)
    except (OSError, ValueError) as exc:
        raise InputFileError(
            p,
            f"cannot read the accuracy table ({exc})",
            "give the accuracy.csv written by ringqa accuracy",
        ) from exc
    missing = [c for c in ACCURACY_COLUMNS if c not in table.columns]
    if missing:
        raise InputFileError(
            p,
            f"missing column(s) {', '.join(missing)}",
            "give the accuracy.csv written by ringqa accuracy",
        )
    return table


def _write_one(result, folder: Path, pdf: bool, accuracy=None) -> None:
    write_tables(result, folder)
    if pdf:
        write_pdf(result, folder / "report.pdf", accuracy=accuracy)


def write_report(result, out_dir, *, pdf: bool = True, accuracy_csv=None) -> Path:
    """Write one applicator's files into ``out_dir`` (staged: all or nothing).

    ``accuracy_csv``: optional accuracy.csv of ``ringqa accuracy`` for the scene used (adds a
    page with its error-vs-time plot).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    accuracy = None if accuracy_csv is None else read_accuracy_csv(accuracy_csv)
    with staged_output(out_dir) as stage:
        _write_one(result, stage, pdf, accuracy)
    return Path(out_dir)


def write_batch(batch, out_dir, *, pdf: bool = True, progress: bool = False) -> Path:
    """Write a BatchResult: ``out_dir/<applicator>/`` per result, plus the cross-applicator
    ``summary.csv``, ``all_dwells.csv``, ``all_doses.csv``, ``batch.json`` and ``summary.pdf``.
    Failed applicators appear in summary.csv / batch.json with their error (no subfolder)."""
    from tqdm import tqdm

    with staged_output(out_dir) as stage:
        results = tqdm(batch.results, desc="reports", unit="applicator", disable=not progress)
        for i, res in enumerate(results):
            sub = stage / batch.label(i)
            _write_one(res, sub, pdf)
            # each applicator's folder is recognisably ringqa's own (copied out on its own, it
            # is replaced whole by a later run like any output folder)
            write_json(sub / MARKER_NAME, marker_record(), indent=2, end="\n")
        write_batch_tables(batch, stage)
        if pdf:
            write_batch_pdf(batch, stage / "summary.pdf")
    return Path(out_dir)
