"""Report writers: the CSV/JSON contract files and the PDF a physicist signs.

Public API::

    from ringqa.report import write_report, write_batch
    write_report(result, "out/ring26x60")   # dwells.csv doses.csv plan_dwells.csv summary.csv
                                            # results.json report.pdf, staged (never half-written)
    write_batch(batch, "out/")              # one subfolder per applicator + summary.csv,
                                            # batch.json, summary.pdf
    write_report(result, "out", fields=ReportFields(institution="...", physicist="..."))
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from ringqa.errors import InputFileError
from ringqa.jsonio import write_json
from ringqa.outdir import MARKER_NAME, marker_record, staged_output
from ringqa.report.fields import ReportFields
from ringqa.report.pdf import write_batch_pdf, write_pdf
from ringqa.report.tables import SCHEMA, results_dict, write_batch_tables, write_tables

__all__ = [
    "SCHEMA",
    "ReportFields",
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


def _write_one(
    result, folder: Path, pdf: bool, accuracy=None, fields=None, export=None, sections=(),
    extra_files=None,
) -> None:  # fmt: skip
    write_tables(result, folder)
    for name, data in (extra_files or {}).items():
        (folder / name).write_bytes(data)
    if export is not None:
        from ringqa.io.export_tps import write_exports

        write_exports(result, folder, export)
    if pdf:
        write_pdf(
            result, folder / "report.pdf", accuracy=accuracy, fields=fields, sections=sections
        )


def _checked_exports(results, export: bool) -> list:
    """The exports of every result, made and checked before anything is written (an export
    that cannot be made ends the command with nothing written)."""
    if not export:
        return [None] * len(results)
    from ringqa.io.export_tps import check_export

    return [check_export(r) for r in results]


def write_report(
    result,
    out_dir,
    *,
    pdf: bool = True,
    accuracy_csv=None,
    fields: ReportFields | None = None,
    export: bool = False,
    sections: Sequence = (),
    extra_files: Mapping[str, bytes] | None = None,
) -> Path:
    """Write one applicator's files into ``out_dir`` (staged: all or nothing).

    ``accuracy_csv``: optional accuracy.csv of ``ringqa accuracy`` for the scene used (adds a
    page with its error-vs-time plot). ``fields``: what the signing physicist fills in (from the
    clinic configuration). ``export``: also write ``export/`` (:mod:`ringqa.io.export_tps`:
    ``source_path_<channel>.csv``, and ``RP_simulated.dcm`` for an RT Plan input).
    ``sections``: extra report pages, callables ``section(result) -> list of reportlab
    flowables`` (see :func:`ringqa.report.pdf.write_pdf`). ``extra_files``: more files of the
    run (name -> bytes, e.g. the uncertainty sweep's ``uncertainty.csv``), written in the same
    staged folder (all or nothing).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    accuracy = None if accuracy_csv is None else read_accuracy_csv(accuracy_csv)
    (checked,) = _checked_exports([result], export)
    with staged_output(out_dir) as stage:
        _write_one(result, stage, pdf, accuracy, fields, checked, sections, extra_files)
    return Path(out_dir)


def write_batch(
    batch,
    out_dir,
    *,
    pdf: bool = True,
    progress: bool = False,
    fields: ReportFields | None = None,
    export: bool = False,
    sections: Sequence = (),
) -> Path:
    """Write a BatchResult: ``out_dir/<applicator>/`` per result, plus the cross-applicator
    ``summary.csv``, ``all_dwells.csv``, ``all_doses.csv``, ``batch.json`` and ``summary.pdf``.
    Failed applicators appear in summary.csv / batch.json with their error (no subfolder).
    ``fields``, ``export`` and ``sections`` as :func:`write_report` (the exports per applicator
    folder; the fields also go on summary.pdf)."""
    from tqdm import tqdm

    checked = _checked_exports(batch.results, export)
    with staged_output(out_dir) as stage:
        items = zip(batch.results, checked, strict=True)
        for i, (res, exp) in enumerate(
            tqdm(items, desc="reports", unit="applicator", disable=not progress,
                 total=len(batch.results))
        ):  # fmt: skip
            sub = stage / batch.label(i)
            own = dataclasses.replace(fields or ReportFields(), label=batch.label(i))
            _write_one(res, sub, pdf, None, own, exp, sections)
            # each applicator's folder is recognisably ringqa's own (copied out on its own, it
            # is replaced whole by a later run like any output folder)
            write_json(sub / MARKER_NAME, marker_record(), indent=2, end="\n")
        write_batch_tables(batch, stage)
        if pdf:
            write_batch_pdf(batch, stage / "summary.pdf", fields=fields)
    return Path(out_dir)
