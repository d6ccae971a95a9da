"""The report figures' Agg canvas (``ringqa.report.agg_text``): text laid out and rendered once
per distinct string and glyph, the same pixels as matplotlib's own ``FigureCanvasAgg``."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.report import agg_text, layout
from ringqa.report import figures as plots

pytestmark = pytest.mark.skipif(
    not agg_text.checked(), reason="not the matplotlib release agg_text repeats: not used"
)

FIGURES = ("positions_figure", "deviations_figure", "dose_points_figure")


def _rgb(fig, canvas_class, dpi=layout.FIGURE_DPI) -> np.ndarray:
    canvas_class(fig)
    return layout.figure_pixels(fig, dpi)[0]


def test_report_figures_same_pixels(fake_result):
    """The three report figures of the stand-in ring at the report's DPI: the same RGB array
    drawn by :class:`agg_text.FigureCanvas` (caches empty, then full from the first drawing)
    as by ``FigureCanvasAgg``; the caches were used (strings and glyphs drawn again come from
    them)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    agg_text.clear_caches()
    for name in FIGURES:
        make = getattr(plots, name)
        plain = _rgb(make(fake_result), FigureCanvasAgg)
        first = _rgb(make(fake_result), agg_text.FigureCanvas)
        again = _rgb(make(fake_result), agg_text.FigureCanvas)
        assert np.array_equal(first, plain), name
        assert np.array_equal(again, plain), name
    assert agg_text._LAYOUTS and agg_text._GLYPHS


def _text_figure():
    """Strings at many sub-pixel places, sizes, angles (0, 90, 33.3 degrees), a bold one, an
    aliased one and a math one (matplotlib's own path)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.1, 2.3))
    rng = np.random.default_rng(7)
    for k in range(40):
        x, y = rng.uniform(0.02, 0.9, 2)
        fig.text(x, y, f"−{k % 7}0 ±µ°", fontsize=6 + k % 5, rotation=(0, 90, 33.3)[k % 3],
                 weight="bold" if k % 4 == 0 else "normal")  # fmt: skip
    fig.text(0.1, 0.5, "aliased 0123", antialiased=False)
    fig.text(0.5, 0.1, r"$\alpha_1 + 20$ mm")
    return fig


@pytest.mark.parametrize("dpi", [72, layout.FIGURE_DPI, 211])
def test_placed_and_rotated_text_same_pixels(dpi):
    """Text at random sub-pixel places, rotated, aliased and math: the same pixels at three
    resolutions, with the caches empty and full."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    agg_text.clear_caches()
    plain = _rgb(_text_figure(), FigureCanvasAgg, dpi)
    assert np.array_equal(_rgb(_text_figure(), agg_text.FigureCanvas, dpi), plain)
    assert np.array_equal(_rgb(_text_figure(), agg_text.FigureCanvas, dpi), plain)


def test_text_extents_and_line_metrics_as_matplotlib_measures_them(fake_result):
    """Every text of the dose-map figure (tick labels, titles, labels, annotations, legend)
    has the same window extent (pixels, exactly) measured through :class:`agg_text
    .TextRenderer` (its cached string metrics and font line metrics) as through matplotlib's
    own renderer, at two resolutions; the line metrics are the font's OS/2 table's."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg
    from matplotlib.text import Text

    def extents(canvas_class, dpi):
        fig = plots.dose_points_figure(fake_result)
        canvas_class(fig)
        layout.figure_pixels(fig, dpi)
        renderer = fig.canvas.get_renderer()
        texts = [t for t in fig.findobj(Text) if t.get_text() and t.get_visible()]
        return [tuple(t.get_window_extent(renderer).bounds) for t in texts]

    for dpi in (layout.FIGURE_DPI, 97):
        agg_text.clear_caches()
        plain = extents(FigureCanvasAgg, dpi)
        assert len(plain) > 20
        assert extents(agg_text.FigureCanvas, dpi) == plain
        assert extents(agg_text.FigureCanvas, dpi) == plain
    assert not hasattr(RendererAgg, "_get_font_height_metrics")  # else matplotlib's own is used
    from matplotlib.font_manager import FontProperties

    renderer = agg_text.TextRenderer(10, 10, 100)
    ascent, descent, gap = renderer._get_font_height_metrics(FontProperties(size=7.2))
    assert 0 < descent < ascent < 7.2 * 100 / 72 and gap >= 0


def test_a_glyph_moved_by_whole_pixels_is_the_same_bitmap():
    """What the glyph cache relies on: FreeType renders a glyph whose offset (1/64 px) differs
    by whole pixels as the same bitmap, its ``left``/``top`` moved by those pixels (upright and
    rotated; 9 glyphs x 5 sub-pixel places x 4 shifts)."""
    import math

    from matplotlib.backends.backend_agg import get_hinting_flag
    from matplotlib.font_manager import findfont, get_font
    from matplotlib.ft2font import RenderMode

    font = get_font(findfont("DejaVu Sans"))
    font.set_size(7.0, layout.FIGURE_DPI)
    flags = get_hinting_flag()
    for angle in (0.0, 90.0, 33.3):
        c, s = math.cos(math.radians(angle)), math.sin(math.radians(angle))
        matrix = (0x10000 * np.array([[c, -s], [s, c]])).round().astype(int)
        for char in "0−5AgW°µ,":
            index = font.get_char_index(ord(char))
            for part in ((0, 0), (1, 63), (17, 40), (32, 32), (63, 5)):
                font._set_transform(matrix, list(part))
                ref = font._render_glyph(index, flags, RenderMode.NORMAL)
                for shift in ((1, 0), (0, 1), (-3, 7), (250, -120)):
                    at = [part[0] + 64 * shift[0], part[1] + 64 * shift[1]]
                    font._set_transform(matrix, at)
                    moved = font._render_glyph(index, flags, RenderMode.NORMAL)
                    assert np.array_equal(moved.buffer, ref.buffer), (angle, char, part, shift)
                    assert (moved.left, moved.top) == (ref.left + shift[0], ref.top + shift[1])


def test_other_matplotlib_releases_draw_with_their_own_canvas(monkeypatch):
    """Only the checked release gets the canvas; another (or an unreadable version) draws with
    ``FigureCanvasAgg`` itself."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    assert agg_text.checked("3.11.2")
    assert not agg_text.checked("3.10.8") and not agg_text.checked("4.0.0")
    assert not agg_text.checked("dev")
    assert type(plots.new_figure((1.0, 1.0)).canvas) is agg_text.FigureCanvas
    monkeypatch.setattr(agg_text, "checked", lambda version=None: False)
    assert type(plots.new_figure((1.0, 1.0)).canvas) is FigureCanvasAgg
