"""Report writers: the CSV/JSON contract files and the PDF a physicist signs.

Public API::

    from ringqa.report import write_report, write_batch
    write_report(result, "out/ring26x60")   # dwells.csv doses.csv plan_dwells.csv summary.csv
                                            # results.json report.pdf report.html, staged (never
                                            # half-written)
    write_batch(batch, "out/")              # one subfolder per applicator + summary.csv,
                                            # batch.json, summary.pdf
    write_report(result, "out", fields=ReportFields(institution="...", physicist="..."))
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from ringqa.errors import InputFileError
from ringqa.jsonio import write_json
from ringqa.outdir import MARKER_NAME, marker_record, staged_output
from ringqa.pipeline.result import register_report_writer
from ringqa.report.fields import ReportFields
from ringqa.report.figures import deviations_figure, dose_points_figure, positions_figure
from ringqa.report.pdf import draw_ahead, write_batch_pdf, write_channels_pdf, write_pdf
from ringqa.report.tables import SCHEMA, results_dict, write_batch_tables, write_tables
from ringqa.textio import read_csv_table

__all__ = [
    "SCHEMA",
    "ReportFields",
    "prepare_report",
    "read_accuracy_csv",
    "results_dict",
    "write_batch",
    "write_batch_pdf",
    "write_channels_pdf",
    "write_pdf",
    "write_report",
    "write_tables",
]


ACCURACY_COLUMNS = ("time_s", "max_err_mm", "status")


def _write_html(result, path):
    """report.html of ``result`` (:func:`ringqa.report.html.write_html`, imported when used)."""
    from ringqa.report.html import write_html

    return write_html(result, path)


# the pipeline's named seam (CommissioningResult.publish_pdf / publish_html / plot_*)
register_report_writer("pdf", write_pdf)
register_report_writer("html", _write_html)
register_report_writer("figure.positions", positions_figure)
register_report_writer("figure.deviations", deviations_figure)
register_report_writer("figure.doses", dose_points_figure)


def read_accuracy_csv(path) -> pd.DataFrame:
    """Read ``accuracy.csv`` of ``ringqa accuracy`` (for the report's accuracy page)."""
    p = Path(path)
    table = read_csv_table(p)  # ringqa.textio: encodings, repeated columns refused
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
    extra_files=None, html: bool | None = None, files=None, ahead: bool = False,
) -> None:  # fmt: skip
    # ahead: the PDF's costliest figures are drawn in a forked process (when a core is free)
    # while the tables, report.html and the rest of the PDF are made here
    drawn = draw_ahead(result) if pdf and ahead else None
    try:
        _write_files(result, folder, pdf, accuracy, fields, export, sections, extra_files, html,
                     drawn, files)  # fmt: skip
    finally:
        if drawn is not None:
            drawn.cancel()


def _write_files(result, folder, pdf, accuracy, fields, export, sections, extra_files, html,
                 drawn, files=None) -> None:  # fmt: skip
    if files is None:
        write_tables(result, folder)
    else:
        write_tables(result, folder, files)
    if pdf if html is None else html:
        from ringqa.report.html import write_html

        write_html(result, folder / "report.html")
    for name, data in (extra_files or {}).items():
        (folder / name).write_bytes(data)
    if export is not None:
        from ringqa.io.export_tps import add_export_listing, write_exports

        add_export_listing(folder, write_exports(result, folder, export))  # in results.json
    if pdf:
        write_pdf(
            result, folder / "report.pdf", accuracy=accuracy, fields=fields, sections=sections,
            notes=_export_note(export), drawn=drawn,
        )  # fmt: skip


def _export_note(checked) -> list[str]:
    from ringqa.io.export_tps import export_note

    return export_note(checked)


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
    html: bool | None = None,
    files: Sequence[str] | None = None,
) -> Path:
    """Write one applicator's files into ``out_dir`` (staged: all or nothing).

    ``accuracy_csv``: optional accuracy.csv of ``ringqa accuracy`` for the scene used (adds a
    page with its error-vs-time plot). ``fields``: what the signing physicist fills in (from the
    clinic configuration). ``export``: also write ``export/`` (:mod:`ringqa.io.export_tps`:
    ``source_path_<channel>.csv``, and ``RP_simulated.dcm`` for an RT Plan input).
    ``sections``: extra report pages, callables ``section(result) -> list of reportlab
    flowables`` (see :func:`ringqa.report.pdf.write_pdf`). ``extra_files``: more files of the
    run (name -> bytes, e.g. the uncertainty sweep's ``uncertainty.csv``), written in the same
    staged folder (all or nothing). ``html``: write report.html (default: when ``pdf``).
    ``files``: results.json's list of the files written (default
    :data:`ringqa.report.tables.FILES`).

    Returns
    -------
    pathlib.Path
        ``out_dir``.
    """
    accuracy = None if accuracy_csv is None else read_accuracy_csv(accuracy_csv)
    (checked,) = _checked_exports([result], export)
    with staged_output(out_dir) as stage:
        _write_one(result, stage, pdf, accuracy, fields, checked, sections, extra_files, html,
                   files, ahead=True)  # fmt: skip
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
    workers: int | None = None,
) -> Path:
    """Write a BatchResult: ``out_dir/<applicator>/`` per result, plus the cross-applicator
    ``summary.csv``, ``all_dwells.csv``, ``all_doses.csv``, ``batch.json`` and ``summary.pdf``.
    Failed applicators appear in summary.csv / batch.json with their error (no subfolder).
    ``fields``, ``export`` and ``sections`` as :func:`write_report` (the exports per applicator
    folder; the fields also go on summary.pdf). ``workers``: processes rendering the
    applicators' PDFs at once (default :func:`ringqa.parallel.default_workers`; forked,
    each writes its applicator's ``report.pdf`` into the staging folder while this process
    writes the tables and ``summary.pdf``; the files are those of 1 worker)."""
    from ringqa.parallel import default_workers
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    checked = _checked_exports(batch.results, export)
    n_workers = default_workers() if workers is None else max(1, int(workers))
    forked = pdf and n_workers > 1 and len(batch.results) > 1
    with staged_output(out_dir) as stage, contextlib.ExitStack() as workers_stop:
        subs = [stage / batch.label(i) for i in range(len(batch.results))]
        owns = [dataclasses.replace(fields or ReportFields(), label=batch.label(i))
                for i in range(len(batch.results))]  # fmt: skip
        done = ()
        if forked:  # the workers start on the PDFs now; this process writes the rest meanwhile
            pool = workers_stop.enter_context(
                _pdf_pool(batch.results, subs, owns, sections, n_workers, checked)
            )
            done = pool.imap(_pdf_task, range(len(batch.results)))
        items = zip(batch.results, checked, subs, owns, strict=True)
        for res, exp, sub, own in tqdm(
            items, desc="reports", unit="applicator", total=len(batch.results),
            disable=not progress or forked,
        ):  # fmt: skip
            _write_one(res, sub, pdf and not forked, None, own, exp, sections, html=pdf)
            # each applicator's folder is recognisably ringqa's own (copied out on its own,
            # it is replaced whole by a later run like any output folder)
            write_json(sub / MARKER_NAME, marker_record(), indent=2, end="\n")
        write_batch_tables(batch, stage)
        if pdf:
            write_batch_pdf(batch, stage / "summary.pdf", fields=fields)
        for _ in tqdm(done, desc="reports", unit="applicator", total=len(batch.results),
                      disable=not progress or not forked):  # fmt: skip
            pass  # the workers' PDFs, as they finish
    return Path(out_dir)


def prepare_report() -> None:
    """Load what every report needs, ahead of it (e.g. while a forked process commissions):
    matplotlib's Agg canvas, PIL, reportlab, the report's fonts and styles, plotly's set-up for
    report.html, and matplotlib's text set-up by drawing a small figure once. Nothing is
    written; the report's pixels and text are the same with or without it (only caches are
    filled)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ringqa.report import layout

    layout.register_fonts()
    layout.styles()
    from ringqa.report.html import prepare_html

    prepare_html()  # plotly's set-up for report.html
    fig = Figure(figsize=(2.0, 1.5), dpi=layout.FIGURE_DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 1.0], marker="o")
    ax.set_title("warm-up", fontsize=9)
    ax.set_xlabel("x (mm)")
    ax.legend(["a"], fontsize=7)
    fig.canvas.draw()


def _pdf_pool(results, folders, fields, sections, workers: int, exports=None):
    """A pool of forked processes (a context manager) set up to render ``results[k]`` into
    ``folders[k]/report.pdf`` (:func:`_pdf_task`); the folders are made here first."""
    from ringqa.parallel import worker_pool

    prepare_report()  # once, before forking: the workers inherit it
    for folder in folders:
        folder.mkdir(parents=True, exist_ok=True)
    notes = [_export_note(e) for e in (exports or [None] * len(results))]
    job = (results, [f / "report.pdf" for f in folders], fields, sections, notes)
    return worker_pool(min(workers, len(results)), job=job)


def _pdf_task(k: int) -> int:
    """Render report ``k`` of the pool's job ``(results, PDF paths, fields, sections)`` (in a
    worker)."""
    from ringqa.parallel import job

    results, paths, fields, sections, notes = job()
    write_pdf(results[k], paths[k], fields=fields[k], sections=sections, notes=notes[k])
    return k
