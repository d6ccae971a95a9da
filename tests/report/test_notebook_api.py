"""The notebook conventions of CommissioningResult (pylinac-like): ``to_frames()``,
``plot_*()`` returning matplotlib Figures without touching pyplot or the backend, and
``publish_pdf(path, fields=, notes=)``."""

from __future__ import annotations

import matplotlib
import pandas as pd
import pytest

from ringqa.report import ReportFields
from tests.report.conftest import pdf_pages_text


def test_to_frames(fake_result):
    """The tables as DataFrames: equal to the result's own, copies (editing one leaves the
    result alone); summary one row with summary.csv's columns; one row per verdict."""
    frames = fake_result.to_frames()
    assert set(frames) == {"dwells", "doses", "plan_dwells", "summary", "verdicts", "notes"}
    pd.testing.assert_frame_equal(frames["dwells"], fake_result.dwells)
    pd.testing.assert_frame_equal(frames["doses"], fake_result.doses)
    pd.testing.assert_frame_equal(frames["plan_dwells"], fake_result.plan_dwells)
    assert list(frames["summary"].columns) == list(fake_result.summary.as_row())
    assert len(frames["summary"]) == 1
    assert frames["summary"].loc[0, "verdict"] == fake_result.summary.verdict
    assert list(frames["verdicts"]["status"]) == [v.status for v in fake_result.verdicts]
    assert list(frames["notes"]["note"]) == list(fake_result.notes)
    frames["dwells"].loc[:, "x_mm"] = 1e9
    assert (fake_result.dwells["x_mm"] != 1e9).all()


@pytest.mark.parametrize(
    ("method", "n_axes"), [("plot_positions", 2), ("plot_deviations", 3), ("plot_doses", 2)]
)
def test_plots_return_figures_without_pyplot(fake_result, method, n_axes):
    """Each plot is a Figure with its axes; pyplot's figure list and the backend are unchanged
    (the figures are made without pyplot); the title defaults to the applicator."""
    from matplotlib.figure import Figure

    backend = matplotlib.get_backend()
    import matplotlib.pyplot as plt

    before = plt.get_fignums()
    fig = getattr(fake_result, method)()
    assert isinstance(fig, Figure)
    assert len(fig.axes) == n_axes
    assert plt.get_fignums() == before
    assert matplotlib.get_backend() == backend
    assert fig.get_suptitle() == fake_result.applicator
    fig.canvas.draw()  # renders headless


def test_publish_pdf(fake_result, tmp_path):
    """publish_pdf writes the same report as ringqa commission, with the fields and notes."""
    path = fake_result.publish_pdf(
        tmp_path / "r.pdf",
        fields=ReportFields(physicist="Dr. B. Checker"),
        notes="Ring 3 of the spare set.",
    )
    pages = pdf_pages_text(path)
    first = " ".join(" ".join(pages[:2]).split())
    assert "Dr. B. Checker" in first and "Ring 3 of the spare set." in first
    assert f"page 1/{len(pages)}" in " ".join(pages[0].split())


def test_publish_pdf_reaches_the_report_through_the_named_seam(fake_result, tmp_path, monkeypatch):
    """The pipeline names the seam (pipeline.result.REPORT_WRITERS) and ringqa.report fills it
    when imported; with nothing registered publish_pdf says what to import instead of looking a
    module up by its name."""
    from ringqa.errors import RingQAError
    from ringqa.pipeline import result as result_module
    from ringqa.report import write_pdf

    assert result_module.REPORT_WRITERS["pdf"] is write_pdf
    monkeypatch.setattr(result_module, "REPORT_WRITERS", {})
    with pytest.raises(RingQAError, match=r"import ringqa\.report"):
        fake_result.publish_pdf(tmp_path / "r.pdf")
    assert not (tmp_path / "r.pdf").exists()


def test_plot_methods_reach_the_figures_through_the_named_seam(fake_result, monkeypatch):
    """The figures are the report layer's (ringqa.report.figures); the result's plot_* methods
    find them in the pipeline's seam, which ringqa.report fills when imported; with nothing
    registered a plot method says what to import."""
    from ringqa.errors import RingQAError
    from ringqa.pipeline import result as result_module
    from ringqa.report import figures

    assert result_module.REPORT_WRITERS["figure.positions"] is figures.positions_figure
    assert result_module.REPORT_WRITERS["figure.deviations"] is figures.deviations_figure
    assert result_module.REPORT_WRITERS["figure.doses"] is figures.dose_points_figure
    monkeypatch.setattr(result_module, "REPORT_WRITERS", {})
    with pytest.raises(RingQAError, match=r"no figure\.positions .*import ringqa\.report first"):
        fake_result.plot_positions()
