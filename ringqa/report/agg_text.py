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
  place less the whole pixels.

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
    """Forget every laid-out string and rendered glyph (e.g. after changing fonts)."""
    _LAYOUTS.clear()
    _GLYPHS.clear()


def _hashable(value):
    if value is None or isinstance(value, str):
        return value
    return tuple(_hashable(v) for v in value)


class TextRenderer(RendererAgg):
    """matplotlib's Agg renderer whose plain (not math) text is laid out and rendered once
    per distinct string and glyph (see the module's description); the same pixels."""

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
            if len(_LAYOUTS) >= CACHE_LIMIT:
                _LAYOUTS.clear()
            items = font._layout(s, flags=flags, features=features, language=language)
            _LAYOUTS[key] = items
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
                if len(_GLYPHS) >= CACHE_LIMIT:
                    _GLYPHS.clear()
                glyph = (buffer, bitmap.left - whole_x, bitmap.top - whole_y)
                _GLYPHS[glyph_key] = glyph
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
