"""The report's figures drawn faster without a pixel changing (issue 16).

Axes titles are pinned at their default height (``plots._pin_title``) where matplotlib's
automatic placing could not move them; drawing then skips a second measurement of the tick
labels. The figures must be pixel-identical to the automatically placed ones, and a title that an
offset text ("+1e3", "1e-7") could collide with must stay automatic.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.report import figures as plots

FIGURES = ("positions_figure", "deviations_figure", "dose_points_figure")


def _pixels(fig) -> np.ndarray:
    fig.set_dpi(60)  # small and quick; the placing does not depend on the resolution
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


def test_pinned_titles_draw_the_same_pixels(fake_result, monkeypatch):
    """Each report figure with pinned titles equals, pixel for pixel, the one matplotlib places
    itself (``_pin_title`` switched off); in each some title is pinned (else the test would
    compare a figure with itself): the positions and dose figures' (mm coordinates, no offset
    text) and the deviations figure's, on the middle one of three axes sharing x (its x tick
    labels hidden: matplotlib's tick position "unknown", no labels on top)."""
    real = plots._pin_title
    for name in FIGURES:
        pinned: list[bool] = []

        def spy(ax, pinned=pinned):
            pinned.append(real(ax))
            return pinned[-1]

        monkeypatch.setattr(plots, "_pin_title", spy)
        fast = _pixels(getattr(plots, name)(fake_result))
        monkeypatch.setattr(plots, "_pin_title", lambda ax: False)
        auto = _pixels(getattr(plots, name)(fake_result))
        assert any(pinned), (name, pinned)
        assert fast.shape == auto.shape
        assert np.array_equal(fast, auto), name


def _axes_with(y, title="a title long enough to run over the top left corner of the axes"):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 2))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], y)
    ax.set_title(title, fontsize=9)
    return fig, ax


@pytest.mark.parametrize(
    ("y", "pinned"),
    [
        ((0.0, 5.0), True),  # plain tick labels: nothing to avoid
        ((1000.001, 1000.002), False),  # offset text "+1e3" above the axes
        ((0.0, 1e-7), False),  # order of magnitude "1e-7" above the axes
    ],
)
def test_title_stays_automatic_when_an_offset_text_shows(y, pinned):
    """Pinned only without offset text; with one, matplotlib still lifts the title above it
    (the title's lower edge at or above the offset text's upper edge, in pixels)."""
    fig, ax = _axes_with(y)
    assert plots._pin_title(ax) is pinned
    fig.canvas.draw()
    offset = ax.yaxis.offsetText
    assert bool(offset.get_text()) is not pinned
    if not pinned:
        renderer = fig.canvas.get_renderer()
        top = offset.get_window_extent(renderer).y1
        assert ax.title.get_window_extent(renderer).y0 >= top - 0.5


@pytest.mark.parametrize(
    "move",
    [
        lambda ax: ax.xaxis.tick_top(),  # ticks and labels on top: position "top"
        lambda ax: ax.tick_params(labeltop=True),  # labels on both sides: position "unknown"
        lambda ax: ax.xaxis.set_label_position("top"),  # the x label on top
    ],
)
def test_top_tick_labels_keep_the_title_automatic(move):
    """Tick labels or the x label on top of the axes can push the title up: not pinned, and
    matplotlib lifts it above them (the title's lower edge at or above their upper edge)."""
    fig, ax = _axes_with((0.0, 5.0))
    ax.set_xlabel("x (mm)")
    move(ax)
    assert plots._pin_title(ax) is False
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    top = ax.xaxis.get_tightbbox(renderer).y1
    assert ax.title.get_window_extent(renderer).y0 >= top - 0.5


def test_hidden_tick_labels_of_a_shared_stack_pin_the_title():
    """A title on an axes of a stack sharing x (its x tick labels hidden by matplotlib) is
    pinned, and drawn where matplotlib would place it (same pixels)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    def stack(pin):
        fig = Figure(figsize=(3, 4))
        FigureCanvasAgg(fig)
        axes = fig.subplots(3, 1, sharex=True)
        for k, ax in enumerate(axes):
            ax.plot([0.0, 10.0], [k, 2.0 * k + 1.0])
        axes[1].set_title("a title over the middle axes", fontsize=8)
        return fig, axes[1], (plots._pin_title(axes[1]) if pin else None)

    fig, ax, pinned = stack(True)
    assert pinned is True and ax.xaxis.get_ticks_position() == "unknown"
    auto, _, _ = stack(False)
    assert np.array_equal(_pixels(fig), _pixels(auto))


def test_figure_pixels_are_the_canvas_rgb():
    """``layout.figure_pixels`` (copied a channel at a time) is the canvas's RGBA buffer less
    its alpha, as a C-ordered uint8 array (the bytes reportlab and the MD5 name read)."""
    from ringqa.report import layout

    fig = plots.new_figure((2.0, 1.5))
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 1, 4], color="tab:red", marker="o", label="a line")
    ax.axvspan(0.5, 1.0, color="#cfd8dc", alpha=0.8)
    ax.legend()
    rgb, size = layout.figure_pixels(fig, 100)
    rgba = np.asarray(fig.canvas.buffer_rgba())
    assert size == (2.0, 1.5) and rgb.shape == (150, 200, 3) and rgb.dtype == np.uint8
    assert rgb.flags["C_CONTIGUOUS"]
    assert np.array_equal(rgb, rgba[..., :3])
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 10  # not a blank canvas


def test_unnamed_and_cheaper_flate_images_hold_the_same_pixels():
    """``figure_flate(..., named=False)`` skips the MD5 name (""), ``level`` changes only the
    compression: every variant decompresses to the same RGB bytes as the default image, whose
    name is reportlab's (MD5 of the bytes and ``b"None"``)."""
    import hashlib
    import zlib

    from ringqa.report import layout

    def fig():
        f = plots.new_figure((2.0, 1.5))
        f.add_subplot().plot([0, 1, 2], [0, 1, 4], marker="o")
        return f

    default = layout.figure_flate(fig())
    raw = zlib.decompress(default.data)
    assert default.name == hashlib.md5(raw + b"None").hexdigest()
    assert len(raw) == 3 * default.width_px * default.height_px
    unnamed = layout.figure_flate(fig(), named=False)
    assert unnamed.name == "" and unnamed.data == default.data
    fast = layout.figure_flate(fig(), named=False, level=1)
    assert fast.data != default.data and zlib.decompress(fast.data) == raw


def test_one_line_of_markers_draws_as_one_line_per_marker(fake_result):
    """What the dose map relies on (its star markers, one line per run of points of one
    colour): a line of N markers draws the same pixels as N one-marker lines in the same
    order, overlapping markers of two colours included; the dose map of the stand-in ring has
    one star line per run of its points' colours in each view."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    rng = np.random.default_rng(3)
    x, y = rng.uniform(0, 10, 12), rng.uniform(0, 10, 12)
    colours = ["tab:green"] * 5 + ["tab:purple"] * 4 + ["tab:green"] * 3

    def draw(grouped):
        fig = Figure(figsize=(2.0, 2.0))
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
        ax.set_xlim(0, 10)
        ax.set_ylim(0, 10)
        if grouped:
            for a, b, c in ((0, 5, colours[0]), (5, 9, colours[5]), (9, 12, colours[9])):
                ax.plot(x[a:b], y[a:b], "*", color=c, ms=9)
        else:
            for k in range(12):
                ax.plot(x[k], y[k], "*", color=colours[k], ms=9)
        fig.set_dpi(150)
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba()).copy()

    assert np.array_equal(draw(True), draw(False))
    import itertools

    pts = fake_result.doses[fake_result.doses["plan"] == fake_result.reference]
    runs = len(list(itertools.groupby(k == "tps" for k in pts["kind"])))
    fig = plots.dose_points_figure(fake_result)
    for ax in fig.axes:
        stars = [line for line in ax.get_lines() if line.get_marker() == "*"]
        assert len(stars) == runs and sum(len(line.get_xdata()) for line in stars) == len(pts)
