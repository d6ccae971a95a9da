"""The report's page when the cross-check fails: both engines' dwells plotted (issue 28)."""

from __future__ import annotations

import dataclasses

import numpy as np

from ringqa.pipeline.simulate import CrossCheck
from ringqa.pipeline.verdicts import numerics_verdict
from ringqa.report import write_pdf
from ringqa.report.cross_check import MAX_LABELS, cross_check_figure, failed_cross_check
from ringqa.report.pdf import report_figures
from tests.report.conftest import pdf_pages_text

HEADING = "Numerics FAIL: the two engines disagree"


def _with_cross_check(res, shift_mm: float, limit_mm: float = 0.2):
    """``res`` with a real CrossCheck whose flexible dwells are the simulated ones with every
    second dwell moved ``shift_mm`` across the channel (the rest agree exactly)."""
    sim = res.dwells[res.dwells["path"] == "simulated"]
    pos = sim[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)
    rel = sim["relative_position_mm"].to_numpy(dtype=float)
    flex = pos.copy()
    flex[::2, 2] += shift_mm
    d = np.linalg.norm(flex - pos, axis=1)
    worst = float(d.max())
    xc = CrossCheck(d, worst, limit_mm, worst > limit_mm, True, 0.3, 0.3, flex,
                    f"the dwells agree to {worst:.3f} mm", relative_position_mm=rel)  # fmt: skip
    numerics = dataclasses.replace(res.numerics, cross_check=xc)
    return dataclasses.replace(res, numerics=numerics), xc


def test_a_failed_cross_check_gets_a_page_with_both_paths(fake_result, tmp_path):
    """A disagreement of 0.6 mm at every second dwell (limit 0.2 mm): the Numerics verdict
    fails, the report gains the page with the figure of both engines' dwells (rigid and
    flexible over the ring plane, the dwells beyond the limit circled and labelled, the
    disagreement per dwell against the limit) right after the positions page."""
    res, xc = _with_cross_check(fake_result, 0.6)
    assert xc.fails and numerics_verdict(0.03, 0.1, xc).status == "FAIL"
    assert failed_cross_check(res) is xc
    fig = cross_check_figure(res)
    top, bottom = fig.axes[:2]
    labels = [t.get_text() for t in top.get_legend().get_texts()]
    assert any("flexible" in t for t in labels) and any("rigid" in t for t in labels)
    n_beyond = int(np.sum(xc.disagreement_mm > xc.limit_mm))
    assert n_beyond == len(xc.disagreement_mm[::2])
    marked = [t for t in top.texts if t.get_text().startswith("0.60 mm")]
    assert len(marked) == min(n_beyond, MAX_LABELS)
    assert bottom.lines[-1].get_ydata()[0] == 0.2  # the limit line
    assert len(report_figures(res)) == len(report_figures(fake_result)) + 1
    pages = pdf_pages_text(write_pdf(res, tmp_path / "fail.pdf"))
    plain = pdf_pages_text(write_pdf(fake_result, tmp_path / "plain.pdf"))
    assert len(pages) == len(plain) + 1
    flat = [" ".join(text.split()) for text in pages]
    where = [k for k, text in enumerate(flat) if HEADING in text]
    positions = [k for k, text in enumerate(flat) if text.startswith("Dwell positions")]
    assert where == [positions[0] + 1]  # right after the positions page
    assert "0.600 mm" in flat[where[0]]


def test_a_passing_cross_check_adds_no_page(fake_result, tmp_path):
    """0.1 mm at every second dwell, within the 0.2 mm limit: no page, no figure."""
    res, xc = _with_cross_check(fake_result, 0.1)
    assert not xc.fails and failed_cross_check(res) is None
    assert len(report_figures(res)) == len(report_figures(fake_result))
    pages = pdf_pages_text(write_pdf(res, tmp_path / "pass.pdf"))
    assert not any(HEADING in " ".join(text.split()) for text in pages)
