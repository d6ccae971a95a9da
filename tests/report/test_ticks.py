"""Tick places in view only (``ringqa.report.ticks``): the ticks drawn, their labels, the offset
texts and the pixels are matplotlib's own; fewer ticks are made."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ringqa.report import agg_text, ticks
from ringqa.report import figures as plots


def _figure(x0, x1, y0, y1, wrap: bool, size=(2.6, 2.0), limits=False):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([x0, x1], [y0, y1], marker="o")
    ax.set_title("t", fontsize=8)
    if limits:  # the view exactly the data's ends: ticks on the view's edges
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    if wrap:
        assert ticks.ticks_in_view(fig) == 2
    fig.set_dpi(60)
    fig.canvas.draw()
    return fig, ax


def _drawn(ax) -> list:
    """Per axis: the drawn ticks' places and labels, and the offset text."""
    out = []
    for axis in (ax.xaxis, ax.yaxis):
        shown = axis._update_ticks()  # the ticks the draw drew (matplotlib's own selection)
        out.append([(t.get_loc(), t.label1.get_text()) for t in shown])
        out.append(axis.offsetText.get_text())
    return out


#: spans from a thousandth to a million, around zero, far from zero (offset texts) and tiny
#: (order-of-magnitude texts)
ENDS = st.tuples(
    st.sampled_from([0.0, -3.7, 12.5, 1000.0, -2.5e5, 1e-6, 7e7]),
    st.floats(-1.0, 1.0),
    st.sampled_from([1e-3, 0.02, 0.37, 1.0, 4.4, 9.5, 60.0, 1234.0, 2e6]),
)


@settings(max_examples=25)  # two figures drawn per example: about 0.1 s each
@given(x=ENDS, y=ENDS)
def test_same_ticks_labels_offsets_and_pixels(x, y):
    """Random data spans (the view autoscaled with margins around them): with the places
    outside the view dropped, the same ticks are drawn at the same places with the same labels
    and offset texts, and the figure is the same pixels; never more ticks are made."""
    (cx, fx, wx), (cy, fy, wy) = x, y
    ends = (cx + fx * wx, cx + fx * wx + wx, cy + fy * wy, cy + fy * wy + wy)
    plain_fig, plain = _figure(*ends, wrap=False)
    lean_fig, lean = _figure(*ends, wrap=True)
    assert _drawn(lean) == _drawn(plain)
    for axis_lean, axis_plain in ((lean.xaxis, plain.xaxis), (lean.yaxis, plain.yaxis)):
        assert len(axis_lean.majorTicks) <= len(axis_plain.majorTicks)
    assert np.array_equal(
        np.asarray(lean_fig.canvas.buffer_rgba()), np.asarray(plain_fig.canvas.buffer_rgba())
    )


#: views whose ends are multiples of a round step (as ``set_xlim(-30, 30)``): ticks fall on
#: the view's edges, where a place dropped wrongly would show
ROUND_VIEW = st.tuples(
    st.sampled_from([1e-3, 0.5, 2.0, 25.0, 1e4]), st.integers(-7, 7), st.integers(1, 12)
)


@settings(max_examples=25)
@given(x=ROUND_VIEW, y=ROUND_VIEW)
def test_same_ticks_on_the_views_edges(x, y):
    """Views set to multiples of a round step (ticks on the edges, drawn by matplotlib within
    its tolerance): the same ticks, labels, offset texts and pixels with the places outside
    the view dropped."""
    (sx, kx, mx), (sy, ky, my) = x, y
    ends = (kx * sx, (kx + mx) * sx, ky * sy, (ky + my) * sy)
    plain_fig, plain = _figure(*ends, wrap=False, limits=True)
    lean_fig, lean = _figure(*ends, wrap=True, limits=True)
    assert _drawn(lean) == _drawn(plain)
    assert np.array_equal(
        np.asarray(lean_fig.canvas.buffer_rgba()), np.asarray(plain_fig.canvas.buffer_rgba())
    )


def test_report_figures_make_fewer_ticks_and_keep_the_locators_api(fake_result):
    """The report figures' linear axes get the in-view locator (on the checked matplotlib):
    fewer major ticks made than places the plain locator gives; ``get_xticks`` lists the
    places in view; ``locator_params`` reaches the wrapped locator; a log scale set later
    replaces it as it replaces matplotlib's default."""
    from matplotlib.ticker import LogLocator

    if not agg_text.checked():
        pytest.skip("not the checked matplotlib: the default locators are kept")
    fig = plots.positions_figure(fake_result)
    fig.canvas.draw()
    made = plain = 0
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            locator = axis.get_major_locator()
            assert isinstance(locator, ticks.InView) and axis.isDefault_majloc
            low, high = sorted(axis.get_view_interval())
            locs = axis.get_majorticklocs()
            assert ((locs >= low - 1e-9) & (locs <= high + 1e-9)).all()
            made += len(axis.majorTicks)
            plain += len(locator.locator())
    assert made < plain
    ax = fig.axes[0]
    ax.locator_params(axis="y", nbins=3)
    assert ax.yaxis.get_major_locator().locator._nbins == 3
    ax.set_yscale("log")
    assert isinstance(ax.yaxis.get_major_locator(), LogLocator)


def test_shared_axes_wrapped_once():
    """Axes sharing x share one locator: wrapped once, not a wrapper of a wrapper."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 3))
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1, sharex=True)
    for ax in axes:
        ax.plot([0, 1], [0, 2])
    assert ticks.ticks_in_view(fig) == 4  # one x (shared) and three y
    assert all(type(ax.xaxis.get_major_locator().locator).__name__ == "AutoLocator" for ax in axes)
