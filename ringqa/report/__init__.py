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

from ringqa.outdir import staged_output
from ringqa.report.pdf import write_batch_pdf, write_pdf
from ringqa.report.tables import SCHEMA, results_dict, write_batch_tables, write_tables

__all__ = [
    "SCHEMA",
    "results_dict",
    "write_batch",
    "write_batch_pdf",
    "write_pdf",
    "write_report",
    "write_tables",
]


def _write_one(result, folder: Path, pdf: bool) -> None:
    write_tables(result, folder)
    if pdf:
        write_pdf(result, folder / "report.pdf")


def write_report(result, out_dir, *, pdf: bool = True) -> Path:
    """Write one applicator's files into ``out_dir`` (staged: all or nothing).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    with staged_output(out_dir) as stage:
        _write_one(result, stage, pdf)
    return Path(out_dir)


def write_batch(batch, out_dir, *, pdf: bool = True) -> Path:
    """Write a BatchResult: ``out_dir/<applicator>/`` per result, plus the cross-applicator
    ``summary.csv``, ``all_dwells.csv``, ``all_doses.csv``, ``batch.json`` and ``summary.pdf``.
    Failed applicators appear in summary.csv / batch.json with their error (no subfolder)."""
    with staged_output(out_dir) as stage:
        for res in batch.results:
            _write_one(res, stage / _safe(res.applicator), pdf)
        write_batch_tables(batch, stage)
        if pdf:
            write_batch_pdf(batch, stage / "summary.pdf")
    return Path(out_dir)


def _safe(name: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in str(name)).strip("._")
    return keep or "applicator"
