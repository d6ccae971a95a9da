"""The Agg canvas of the report's figures: matplotlib's own, its plain text drawn with less work.

matplotlib 3.11's Agg renderer draws a string by laying it out (``FT2Font._layout``: shaping
and the glyphs' places) and then, glyph by glyph, setting the font's size, building the
rotation matrix with numpy, setting FreeType's transform (the matrix and the glyph's place in
1/64 pixel) and rendering the glyph (FreeType's autohinter and rasteriser) before blending its
bitmap into the canvas (``RendererAgg.draw_text`` and ``_draw_text_glyphs_and_boxes``). In
the report's three figures that is 151 strings and 1442 glyphs, about a fifth of their
drawing's CPU, much of it repeated: tick labels such as ``0``, ``20``, ``−20`` recur on every
axis and figure.

:class:`FigureCanvas` (``FigureCanvasAgg`` with :class:`TextRenderer`) does the same steps
with the same numbers, but

- lays out each (font, size, dpi, string, options) once per process (:data:`_LAYOUTS`),
- builds the matrix once per string and sets a font's size once per string (not per glyph:
  nothing else touches the font in between, and the transform is set before each glyph as
  before), and
- renders each (font, size, dpi, glyph, matrix, load flags, mode, place modulo one pixel) once
  per process (:data:`_GLYPHS`): FreeType translates a glyph's hinted outline by the 26.6
  offset before rasterising it, all in integers, so a glyph moved by whole pixels is the same
  bitmap moved by whole pixels (its ``left``/``top``); the cache keeps the bitmap and its
  place less the whole pixels;
- measures each (font, size, dpi, string, flags) once per process (:data:`_METRICS`;
  matplotlib's own cache of text metrics is per renderer, i.e. per figure), and
- answers ``Text._get_layout``'s question for a font's ascent, descent and line gap
  (``_get_font_height_metrics``, which matplotlib asks a renderer that has it) with the same
  numbers ``_get_layout`` reads from the font's tables itself, once per (font, size, dpi)
  (:data:`_HEIGHTS`) instead of two table reads per layout (463 in the three figures).

So it blends the same bitmaps at the same places in the same order: the same pixels
(tests/report/test_agg_text.py compares the report figures and rotated text with
matplotlib's own canvas, and every glyph of a cached render with a fresh one). Mathtext and
any matplotlib other than the release this was written against (:data:`CHECKED`) are drawn by
matplotlib's own code.
"""

from __future__ import annotations

import math

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg, RendererAgg, get_hinting_flag
from matplotlib.font_manager import fontManager, get_font
from matplotlib.ft2font import RenderMode

#: the matplotlib releases (major, minor) whose ``RendererAgg.draw_text`` this repeats
#: (constraints/clinical.txt pins 3.11.2); on any other the text is drawn by matplotlib's own
CHECKED = ((3, 11),)

#: entries of each cache before it is emptied (a long notebook session stays bounded)
CACHE_LIMIT = 20_000

#: laid-out strings: (font, size pt, dpi, string, flags, features, language) -> layout items
_LAYOUTS: dict[tuple, list] = {}
#: rendered glyphs: (font, size, dpi, glyph, matrix, flags, mode, x % 64, y % 64 in 1/64 px)
#: -> (bitmap rows x columns, uint8; left and top in pixels less the offset's whole pixels)
_GLYPHS: dict[tuple, tuple[np.ndarray, int, int]] = {}
#: measured strings: (font, size pt, dpi, string, flags) -> width, height, descent (pixels)
_METRICS: dict[tuple, tuple[float, float, float]] = {}
#: a font's line metrics: (font, size pt, dpi) -> ascent, descent, line gap (pixels) or Nones
_HEIGHTS: dict[tuple, tuple] = {}
#: the font tables Text._get_layout reads the line metrics from, in turn (matplotlib 3.11.2)
_HEIGHT_TABLES = (
    ("OS/2", "sTypoLineGap", "sTypoAscender", "sTypoDescender"),
    ("hhea", "lineGap", "ascent", "descent"),
)


def checked(version: str = matplotlib.__version__) -> bool:
    """``version`` is a matplotlib release in :data:`CHECKED` whose Agg renderer has the parts
    :class:`TextRenderer` repeats."""
    parts = version.split(".")
    try:
        release = (int(parts[0]), int(parts[1]))
    except (IndexError, ValueError):
        return False
    return release in CHECKED and hasattr(RendererAgg, "_draw_text_glyphs_and_boxes")


def clear_caches() -> None:
    """Forget every laid-out and measured string, rendered glyph and font's line metrics."""
    for cache in (_LAYOUTS, _GLYPHS, _METRICS, _HEIGHTS):
        cache.clear()


def _kept(cache: dict, key, value):
    if len(cache) >= CACHE_LIMIT:
        cache.clear()
    cache[key] = value
    return value


def _hashable(value):
    if value is None or isinstance(value, str):
        return value
    return tuple(_hashable(v) for v in value)


class TextRenderer(RendererAgg):
    """matplotlib's Agg renderer whose plain (not math) text is laid out, measured and
    rendered once per distinct string and glyph, and a font's line metrics read once (see the
    module's description); the same pixels."""

    def _get_font_height_metrics(self, prop):
        # Text._get_layout asks a renderer that has this method for a font's ascent, descent
        # and line gap first (matplotlib's PDF/PS backends: their AFM fonts); where it answers
        # Nones, _get_layout reads them from the font's tables itself. This reads them as
        # _get_layout does (matplotlib 3.11.2: the same tables, the same arithmetic, the
        # renderer's dpi: the figure's, as the canvas makes a renderer per figure dpi), once
        # per font, size and dpi instead of two table reads per text layout
        if not _ENABLED:
            return None, None, None
        font = get_font(fontManager._find_fonts_by_props(prop))
        fontsize = prop.get_size_in_points()
        key = (font, fontsize, self.dpi)
        heights = _HEIGHTS.get(key)
        if heights is not None:
            return heights
        heights = (None, None, None)
        for table_name, linegap_key, ascent_key, descent_key in _HEIGHT_TABLES:
            table = font.get_sfnt_table(table_name)
            if table is None:
                continue
            units_per_em = font.get_sfnt_table("head")["unitsPerEm"]
            scale = 1 / units_per_em * fontsize * self.dpi / 72
            line_gap = table[linegap_key] * scale
            min_ascent = table[ascent_key] * scale
            min_descent = -table[descent_key] * scale
            heights = (min_ascent, min_descent, line_gap)
            break
        return _kept(_HEIGHTS, key, heights)

    def get_text_width_height_descent(self, s, prop, ismath):
        # matplotlib 3.11.2's, plain text measured once per font, size, dpi, string and flags
        if ismath or not _ENABLED:
            return super().get_text_width_height_descent(s, prop, ismath)
        flags = get_hinting_flag()
        key = (get_font(fontManager._find_fonts_by_props(prop)), prop.get_size_in_points(),
               self.dpi, s, flags)  # fmt: skip
        metrics = _METRICS.get(key)
        if metrics is None:
            font = self._prepare_font(prop)
            font.set_text(s, 0.0, flags=flags)
            w, h = font.get_width_height()  # width and height of unrotated string
            d = font.get_descent()
            metrics = _kept(_METRICS, key, (w / 64.0, h / 64.0, d / 64.0))  # from subpixels
        return metrics

    def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
        # matplotlib 3.11.2's RendererAgg.draw_text + _draw_text_glyphs_and_boxes (extend 1,
        # slant 0, no boxes), the layout and each glyph's bitmap cached
        if ismath or not _ENABLED:
            return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
        font = self._prepare_font(prop)
        flags = get_hinting_flag()
        features = mtext.get_fontfeatures() if mtext is not None else None
        language = mtext.get_language() if mtext is not None else None
        size = prop.get_size_in_points()
        dpi = self.dpi
        key = (font, size, dpi, s, flags, _hashable(features), _hashable(language))
        items = _LAYOUTS.get(key)
        if items is None:
            items = font._layout(s, flags=flags, features=features, language=language)
            _kept(_LAYOUTS, key, items)
        cos = math.cos(math.radians(angle))
        sin = math.sin(math.radians(angle))
        extend, slant = 1, 0
        matrix = (0x10000 * np.array([[cos, -sin], [sin, cos]])
                  @ [[extend, extend * slant], [0, 1]]).round().astype(int)  # fmt: skip
        matrix_key = tuple(matrix.ravel().tolist())
        antialiased = gc.get_antialiased()
        mode = RenderMode.NORMAL if antialiased else RenderMode.MONO
        height = self.height
        draw = self._renderer.draw_text_image
        sized = None  # the font whose size was set last for this string
        for item in items:
            ft, dx, dy = item.ft_object, item.x, item.y  # dy is upwards
            at_x = round(0x40 * (x + dx * cos - dy * sin))
            at_y = round(0x40 * (height - y + dx * sin + dy * cos))  # FreeType's y is upwards
            whole_x, part_x = divmod(at_x, 0x40)
            whole_y, part_y = divmod(at_y, 0x40)
            glyph_key = (ft, size, dpi, item.glyph_index, matrix_key, flags, mode, part_x, part_y)
            glyph = _GLYPHS.get(glyph_key)
            if glyph is None:
                if ft is not sized:
                    ft.set_size(size, dpi)
                    sized = ft
                ft._set_transform(matrix, [at_x, at_y])
                bitmap = ft._render_glyph(item.glyph_index, flags, mode)
                buffer = bitmap.buffer  # owns its memory (a new array each render)
                if not antialiased:
                    buffer *= 0xFF
                glyph = (buffer, bitmap.left - whole_x, bitmap.top - whole_y)
                _kept(_GLYPHS, glyph_key, glyph)
            buffer, left, top = glyph
            # draw_text_image's y is downwards & the bitmap bottom side
            draw(buffer, left + whole_x, int(height) - (top + whole_y) + buffer.shape[0], 0, gc)


#: :class:`TextRenderer` draws with its caches (False: matplotlib's own text drawing)
_ENABLED = checked()


class FigureCanvas(FigureCanvasAgg):
    """matplotlib's Agg canvas drawing with :class:`TextRenderer` (the same pixels; printing,
    ``savefig`` and ``buffer_rgba`` as ``FigureCanvasAgg``)."""

    def get_renderer(self):
        # FigureCanvasAgg.get_renderer with this module's renderer
        w, h = self.get_width_height(physical=True)
        key = w, h, self.figure.dpi
        if self._lastKey != key:
            self.renderer = TextRenderer(w, h, self.figure.dpi)
            self._lastKey = key
        return self.renderer
