"""The report's page layout with reportlab: fonts, styles, running header/footer, tables, figures.

Every page carries a running header (report title with the applicator's full name; software
version and date) and footer (the input's SHA-256 prefix; ``page n/N``). Text and tables are
reportlab flowables (fast, selectable, wrapped to the page); matplotlib is used for the figures
only, embedded as Flate-compressed RGB images at :data:`FIGURE_DPI` (no PNG).

Fonts: DejaVu Sans (shipped with matplotlib, so present wherever ringqa runs) is registered as a
TrueType font and embedded (subset) in the PDF: no Type 3 fonts, no unembedded base-14 fonts, and
the degree sign, "±", "≤" print as written.

Extra pages: :func:`ringqa.report.pdf.write_pdf` takes ``sections``, a list of callables
``section(result) -> list of flowables``; each starts on a new page after the standard pages.
Build them with :func:`heading`, :func:`para`, :func:`grid_table` and :func:`figure_image`.
"""

from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

from reportlab import rl_config
from reportlab.lib import colors
from reportlab.lib.enums import TA_LEFT
from reportlab.lib.pagesizes import A4
from reportlab.lib.styles import ParagraphStyle
from reportlab.lib.units import mm
from reportlab.pdfbase import pdfdoc, pdfmetrics
from reportlab.pdfbase.ttfonts import TTFont
from reportlab.pdfgen import canvas as rl_canvas
from reportlab.platypus import (
    Flowable,
    Paragraph,
    SimpleDocTemplate,
    Spacer,
    Table,
    TableStyle,
)

#: Resolution of the embedded figures (dots per inch): sharp on paper, small and fast.
FIGURE_DPI = 150
PAGE = A4
MARGIN_X = 15 * mm
MARGIN_TOP = 17 * mm
MARGIN_BOTTOM = 15 * mm
#: Width of the text frame, points.
FRAME_WIDTH = PAGE[0] - 2 * MARGIN_X
FONT = "DejaVuSans"
FONT_BOLD = "DejaVuSans-Bold"
FONT_ITALIC = "DejaVuSans-Oblique"
FONT_MONO = "DejaVuSansMono"
STATUS_COLOURS = {
    "PASS": "#2e7d32",
    "WARN": "#ef6c00",
    "FAIL": "#c62828",
    "ACTION": "#c62828",
    "ERROR": "#c62828",
}
#: Number of hexadecimal digits of the input's SHA-256 printed in the footer.
SHA_PREFIX = 12


def _matplotlib_fonts() -> Path:
    """The folder of the TrueType fonts shipped with matplotlib (found without importing it)."""
    spec = importlib.util.find_spec("matplotlib")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("matplotlib is not installed: the report needs its DejaVu fonts")
    return Path(next(iter(spec.submodule_search_locations))) / "mpl-data" / "fonts" / "ttf"


@functools.cache
def register_fonts() -> None:
    """Register DejaVu Sans (regular, bold, oblique) and DejaVu Sans Mono with reportlab."""
    folder = _matplotlib_fonts()
    for name, file in (
        (FONT, "DejaVuSans.ttf"),
        (FONT_BOLD, "DejaVuSans-Bold.ttf"),
        (FONT_ITALIC, "DejaVuSans-Oblique.ttf"),
        (FONT_MONO, "DejaVuSansMono.ttf"),
    ):
        pdfmetrics.registerFont(TTFont(name, str(folder / file)))
    pdfmetrics.registerFontFamily(
        FONT, normal=FONT, bold=FONT_BOLD, italic=FONT_ITALIC, boldItalic=FONT_BOLD
    )


@functools.cache
def styles() -> dict[str, ParagraphStyle]:
    """The paragraph styles by name: title, h1, h2, body, small, mono, cell, cellhead, field."""
    register_fonts()
    base = ParagraphStyle(
        "body", fontName=FONT, fontSize=8.3, leading=10.2, alignment=TA_LEFT, spaceAfter=2
    )

    def s(name, **kw):
        return ParagraphStyle(name, parent=base, **kw)

    return {
        "title": s("title", fontName=FONT_BOLD, fontSize=14, leading=17, spaceAfter=4),
        "h1": s("h1", fontName=FONT_BOLD, fontSize=11, leading=13.5, spaceBefore=5, spaceAfter=2),
        "h2": s("h2", fontName=FONT_BOLD, fontSize=8.8, leading=11, spaceBefore=3, spaceAfter=2),
        "body": base,
        "small": s("small", fontSize=7.3, leading=9, spaceAfter=1.5),
        "note": s("note", fontSize=7.8, leading=9.6, leftIndent=8, bulletIndent=0, spaceAfter=1),
        "mono": s("mono", fontName=FONT_MONO, fontSize=6.8, leading=8.3, spaceAfter=0),
        "cell": s("cell", fontSize=7.3, leading=8.8, spaceAfter=0),
        "cellhead": s("cellhead", fontName=FONT_BOLD, fontSize=7.3, leading=8.8, spaceAfter=0),
        "conclusion": s("conclusion", fontName=FONT_BOLD, fontSize=10, leading=12.5),
    }


def para(text: str, style: str = "body", *, markup: bool = False) -> Paragraph:
    """A paragraph of plain ``text`` (escaped; newlines kept) in the named style.

    ``markup=True`` passes reportlab's inline markup (``<b>``, ``<font>``) through unescaped.
    """
    body = text if markup else escape(str(text)).replace("\n", "<br/>")
    return Paragraph(body, styles()[style])


def heading(text: str, level: int = 1) -> Paragraph:
    """A heading (level 0: the page title, 1: a section, 2: a sub-section)."""
    return para(text, {0: "title", 1: "h1"}.get(level, "h2"))


def badge(status: str) -> str:
    """Inline markup of a verdict status on its colour (white bold text)."""
    colour = STATUS_COLOURS.get(status, "#757575")
    return f'<font backColor="{colour}" color="white"><b>&nbsp;{escape(status)}&nbsp;</b></font>'


def grid_table(
    rows,
    col_widths=None,
    *,
    header_rows: int = 1,
    style: str = "cell",
    align: str = "CENTER",
    first_left: bool = True,
    row_colours: dict[int, str] | None = None,
    cell_colours: dict[tuple[int, int], str] | None = None,
    repeat_header: bool = True,
) -> Table:
    """A ruled table of text cells (wrapped to the column widths; the header rows repeat when
    the table runs over a page).

    Parameters
    ----------
    rows : sequence of sequence of str
        The header row(s) first.
    col_widths : sequence of float, optional
        Column widths, points (default: equal shares of the frame width).
    row_colours, cell_colours : dict, optional
        Background colours of body rows (index in ``rows``) or single cells ``(row, col)``.
    """
    ncol = len(rows[0])
    if col_widths is None:
        col_widths = [FRAME_WIDTH / ncol] * ncol
    cells = [
        [
            para(c, "cellhead" if r < header_rows else style) if isinstance(c, str) else c
            for c in row
        ]
        for r, row in enumerate(rows)
    ]
    commands = [
        ("FONTNAME", (0, 0), (-1, -1), FONT),  # the table's own default is Helvetica
        ("GRID", (0, 0), (-1, -1), 0.4, colors.HexColor("#9e9e9e")),
        ("BACKGROUND", (0, 0), (-1, header_rows - 1), colors.HexColor("#eeeeee")),
        ("VALIGN", (0, 0), (-1, -1), "MIDDLE"),
        ("TOPPADDING", (0, 0), (-1, -1), 1.2),
        ("BOTTOMPADDING", (0, 0), (-1, -1), 1.6),
        ("LEFTPADDING", (0, 0), (-1, -1), 2.5),
        ("RIGHTPADDING", (0, 0), (-1, -1), 2.5),
    ]
    for r, colour in (row_colours or {}).items():
        commands.append(("BACKGROUND", (0, r), (-1, r), colors.HexColor(colour)))
    for (r, c), colour in (cell_colours or {}).items():
        commands.append(("BACKGROUND", (c, r), (c, r), colors.HexColor(colour)))
    table = Table(
        cells,
        colWidths=col_widths,
        repeatRows=header_rows if repeat_header else 0,
        hAlign="LEFT",
        style=TableStyle(commands),
    )
    for row in cells:
        for k, cell in enumerate(row):
            if isinstance(cell, Paragraph) and not (first_left and k == 0):
                cell.style = ParagraphStyle(
                    cell.style.name + "-c", parent=cell.style, alignment={"CENTER": 1}.get(align, 0)
                )
    return table


def figure_image(fig, width: float = FRAME_WIDTH, dpi: int = FIGURE_DPI) -> Flowable:
    """A matplotlib Figure as an embedded image ``width`` points wide (its aspect kept).

    The figure is drawn by the Agg canvas at ``dpi`` (no pyplot, no backend switch) and its
    pixels compressed as the PDF stores them (:func:`figure_flate`: no PNG encoding and
    decoding on the way; Flate, lossless).
    """
    return FlateFigure(figure_flate(fig, dpi), width)


@dataclass(frozen=True)
class FlateImage:
    """A figure's pixels as the PDF stores them: what reportlab makes of an RGB image
    (``canvas.drawImage`` of an ``ImageReader``), made ahead, e.g. in the process that drew
    the figure (:func:`figure_flate`), so that only the compressed bytes travel and the
    report's process does not copy, hash and compress megabytes of pixels again.

    Attributes
    ----------
    width_px, height_px : int
        Pixels across and down.
    size_in : tuple of float
        The figure's size (width, height), inches.
    name : str
        The image's name in the PDF: reportlab's for these pixels (the MD5 hex digest of the
        RGB bytes and ``b"None"``, the mask: ``reportlab.lib.utils._digester``), so the file is
        the one ``drawImage`` writes; ``""`` for an image made unnamed (``figure_flate(...,
        named=False)``: one that :class:`LaterFigure` places, under its own key).
    data : bytes
        The RGB bytes (rows top to bottom, 3 bytes a pixel), zlib-compressed (the PDF's
        FlateDecode stream): at zlib's default level, as reportlab compresses them, unless
        made with another ``level``.
    """

    width_px: int
    height_px: int
    size_in: tuple[float, float]
    name: str
    data: bytes

    def reader(self):
        """The pixels as a reportlab ``ImageReader`` (a canvas without :func:`draw_flate`)."""
        import zlib

        from PIL import Image as PILImage
        from reportlab.lib.utils import ImageReader

        raw = zlib.decompress(self.data)
        return ImageReader(PILImage.frombytes("RGB", (self.width_px, self.height_px), raw))


def figure_flate(fig, dpi: int = FIGURE_DPI, *, named: bool = True,
                 level: int = -1) -> FlateImage:  # fmt: skip
    """A matplotlib Figure drawn by the Agg canvas at ``dpi``, as the PDF stores it
    (:class:`FlateImage`: picklable and small, a figure may be drawn in another process).

    ``named=False`` leaves the image's name empty (no MD5 of the pixels: for
    :class:`LaterFigure`, which names the image by its key); ``level`` is zlib's
    compression level (-1: zlib's default, 6, as reportlab compresses images)."""
    import hashlib
    import zlib

    rgb, (w_in, h_in) = figure_pixels(fig, dpi)  # C order: the bytes PIL gives reportlab
    name = ""
    if named:
        digest = hashlib.md5(rgb, usedforsecurity=False)
        digest.update(b"None")  # reportlab names an ImageReader's pixels with its mask (None)
        name = digest.hexdigest()
    return FlateImage(int(rgb.shape[1]), int(rgb.shape[0]), (w_in, h_in), name,
                      zlib.compress(rgb, level))  # fmt: skip


def _takes_images(canv) -> bool:
    """The canvas has the parts :func:`_place_image` uses (reportlab's ``Canvas``, as
    ``drawImage`` uses them) and writes binary streams (:func:`build_pdf`)."""
    parts = ("_doc", "_setXObjects", "_code", "_formsinuse", "saveState", "translate", "scale")
    return not rl_config.useA85 and all(hasattr(canv, a) for a in parts)


def _place_image(canv, name: str, make: Callable[[], pdfdoc.PDFImageXObject], x: float,
                 y: float, width: float, height: float) -> None:  # fmt: skip
    """What ``canv.drawImage`` does with an image named ``name``: the image object registered
    once per name (``make()`` makes it), then drawn at ``x, y`` (points), ``width`` x
    ``height``, and listed as used on the page."""
    doc = canv._doc
    canv._currentPageHasImages = 1
    reg = doc.getXObjectName(name)
    if not doc.idToObject.get(reg, None):
        obj = make()
        canv._setXObjects(obj)
        doc.Reference(obj, reg)
        doc.addForm(name, obj)
    canv.saveState()
    canv.translate(x, y)
    canv.scale(width, height)
    canv._code.append(f"/{reg} Do")
    canv.restoreState()
    canv._formsinuse.append(name)


class _LaterImage(pdfdoc.PDFImageXObject):
    """An RGB image XObject whose compressed pixels (a :class:`FlateImage`, from ``fetch()``)
    are fetched when the PDF is written (``format`` is called once, by the canvas's
    ``save``), not when its page is laid out."""

    def __init__(self, name: str, fetch: Callable[[], FlateImage]) -> None:
        super().__init__(name)  # no source: every field is set here or in format
        self._fetch = fetch
        self.bitsPerComponent = 8
        self.colorSpace = "DeviceRGB"
        self._filters = ("FlateDecode",)
        self.mask = None

    def format(self, document):
        if self._fetch is not None:
            image, self._fetch = self._fetch(), None
            self.width, self.height = image.width_px, image.height_px
            self.streamContent = image.data
        return super().format(document)


def draw_flate(canv, image: FlateImage, x: float, y: float, width: float, height: float) -> bool:
    """Draw ``image`` on reportlab canvas ``canv`` at ``x, y`` (points), ``width`` x ``height``,
    as ``canv.drawImage`` draws an RGB ``ImageReader`` with the same pixels (the same image
    object, name, stream and drawing operators), from its compressed bytes. Returns False,
    drawing nothing, where the canvas lacks the parts this uses (another reportlab) or streams
    are ASCII85-encoded (:func:`build_pdf` switches that off): the caller then draws
    ``image.reader()`` with ``drawImage``."""
    if not _takes_images(canv):
        return False  # pragma: no cover - another reportlab, or ASCII85 streams
    _place_image(canv, image.name, lambda: _LaterImage(image.name, lambda: image), x, y, width,
                 height)  # fmt: skip
    return True


def draw_flate_later(canv, key: str, fetch: Callable[[], FlateImage], x: float, y: float,
                     width: float, height: float) -> bool:  # fmt: skip
    """As :func:`draw_flate`, the image fetched (``fetch()``, e.g. waiting for the process
    drawing it) only when the canvas writes the PDF: its page, and the pages after it, are laid
    out meanwhile. Its name in the PDF is ``key`` with the number of such images before it in
    the document (``positions-1``: no pixels to name it by yet; unique in a document that holds
    several results' figures). Returns False, drawing nothing, where :func:`draw_flate` would."""
    if not _takes_images(canv):
        return False  # pragma: no cover - another reportlab, or ASCII85 streams
    count = canv._doc.__dict__.get("_ringqa_later", 0) + 1
    canv._doc._ringqa_later = count
    name = f"{key}-{count}"
    _place_image(canv, name, lambda: _LaterImage(name, fetch), x, y, width, height)
    return True


class LaterFigure(Flowable):
    """A figure whose pixels come later (``fetch()`` returns its :class:`FlateImage`), drawn
    ``width`` x ``height`` points, centred in the frame: laid out at once, its pixels written
    when the PDF is (:func:`draw_flate_later`; where that cannot be, fetched at its page)."""

    def __init__(self, key: str, fetch: Callable[[], FlateImage], width: float, height: float):
        super().__init__()
        self.key, self.fetch, self.width, self.height = key, fetch, width, height
        self.hAlign = "CENTER"

    def wrap(self, avail_width, avail_height):
        return self.width, self.height

    def draw(self):
        if not draw_flate_later(self.canv, self.key, self.fetch, 0, 0, self.width, self.height):
            self.canv.drawImage(self.fetch().reader(), 0, 0, self.width, self.height)


class FlateFigure(Flowable):
    """A :class:`FlateImage` drawn ``width`` points wide (its aspect kept), centred in the
    frame (:func:`draw_flate`)."""

    def __init__(self, image: FlateImage, width: float):
        super().__init__()
        w_in, h_in = image.size_in
        self.image, self.width, self.height = image, width, width * h_in / w_in
        self.hAlign = "CENTER"

    def wrap(self, avail_width, avail_height):
        return self.width, self.height

    def draw(self):
        if not draw_flate(self.canv, self.image, 0, 0, self.width, self.height):
            self.canv.drawImage(self.image.reader(), 0, 0, self.width, self.height)


def figure_pixels(fig, dpi: int = FIGURE_DPI):
    """A matplotlib Figure drawn by the Agg canvas at ``dpi``: its pixels (rows x columns x 3,
    uint8, C order) and its size (width, height in inches). Picklable: a figure may be drawn in
    another process (:func:`figure_flate` compresses them as the PDF stores them;
    :func:`pixel_image` makes a flowable of them)."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not isinstance(fig.canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    fig.canvas.draw()
    rgba = np.asarray(fig.canvas.buffer_rgba())
    rgb = np.empty((*rgba.shape[:2], 3), dtype=np.uint8)
    for k in range(3):  # a channel at a time: 6-7x faster than one copy of the strided view
        rgb[..., k] = rgba[..., k]
    w_in, h_in = fig.get_size_inches()
    return rgb, (float(w_in), float(h_in))


def pixel_image(rgb, size_in: tuple[float, float], width: float = FRAME_WIDTH) -> Flowable:
    """Pixels of :func:`figure_pixels` (and its size) as an embedded image ``width`` points
    wide, its aspect kept."""
    from PIL import Image as PILImage
    from reportlab.lib.utils import ImageReader

    w_in, h_in = size_in
    return PixelImage(ImageReader(PILImage.fromarray(rgb)), width, width * h_in / w_in)


class PixelImage(Flowable):
    """An image given as pixels (a reportlab ImageReader), drawn ``width`` x ``height`` points
    and centred in the frame."""

    def __init__(self, reader, width: float, height: float):
        super().__init__()
        self.reader, self.width, self.height = reader, width, height
        self.hAlign = "CENTER"

    def wrap(self, avail_width, avail_height):
        return self.width, self.height

    def draw(self):
        self.canv.drawImage(self.reader, 0, 0, self.width, self.height)


def spacer(height_mm: float) -> Spacer:
    """Vertical space, mm."""
    return Spacer(1, height_mm * mm)


@dataclass(frozen=True)
class PageStamp:
    """What the running header and footer of every page say.

    Attributes
    ----------
    title : str
        Header, left: the report and the applicator's full name.
    software : str
        Header, right: ``ringqa <version>``.
    date : str
        Header, right: the run's date (UTC).
    inputs : str
        Footer, left: the input file's SHA-256 prefix (or what stands for it).
    """

    title: str
    software: str
    date: str
    inputs: str


class _NumberedCanvas(rl_canvas.Canvas):
    """A canvas that knows the page count when it saves: draws "page n/N" on every page."""

    def __init__(self, *args, stamp: PageStamp, **kwargs):
        super().__init__(*args, **kwargs)
        self._stamp = stamp
        self._pages: list[dict] = []

    def showPage(self):
        self._pages.append(dict(self.__dict__))
        self._startPage()

    def save(self):
        total = len(self._pages)
        for state in self._pages:
            self.__dict__.update(state)
            self._draw_stamp(total)
            super().showPage()
        super().save()

    def _draw_stamp(self, total: int) -> None:
        st = self._stamp
        w, h = PAGE
        self.saveState()
        self.setStrokeColor(colors.HexColor("#9e9e9e"))
        self.setLineWidth(0.5)
        y_head = h - MARGIN_TOP + 6 * mm
        self.line(MARGIN_X, y_head - 1.8 * mm, w - MARGIN_X, y_head - 1.8 * mm)
        self.setFont(FONT, 7.5)
        right = f"{st.software}  ·  {st.date}"
        right_w = pdfmetrics.stringWidth(right, FONT, 7.5)
        title = st.title
        room = w - 2 * MARGIN_X - right_w - 6 * mm
        while pdfmetrics.stringWidth(title, FONT_BOLD, 7.5) > room and len(title) > 10:
            title = title[:-2]  # only when extremely long; the full name is in the body
        self.setFont(FONT_BOLD, 7.5)
        self.drawString(MARGIN_X, y_head, title)
        self.setFont(FONT, 7.5)
        self.drawRightString(w - MARGIN_X, y_head, right)
        y_foot = MARGIN_BOTTOM - 7 * mm
        self.line(MARGIN_X, y_foot + 3 * mm, w - MARGIN_X, y_foot + 3 * mm)
        self.drawString(MARGIN_X, y_foot, st.inputs)
        self.drawRightString(w - MARGIN_X, y_foot, f"page {self._pageNumber}/{total}")
        self.restoreState()


def build_pdf(path, story: list, stamp: PageStamp, *, title: str, subject: str = "") -> Path:
    """Lay ``story`` (flowables) out on A4 pages with the running header/footer and write
    ``path``.

    Returns
    -------
    pathlib.Path
    """
    register_fonts()
    path = Path(path)
    doc = SimpleDocTemplate(
        str(path),
        pagesize=PAGE,
        leftMargin=MARGIN_X,
        rightMargin=MARGIN_X,
        topMargin=MARGIN_TOP,
        bottomMargin=MARGIN_BOTTOM,
        title=title,
        author=stamp.software,
        subject=subject,
        creator=stamp.software,
        initialFontName=FONT,  # else the canvas adds an unembedded Helvetica
    )
    # Binary streams, not ASCII85: reportlab's ASCII85 encoder is pure Python (about 0.1 s per
    # figure, a quarter of the PDF's build time) and makes every stream 25 % larger. PDF readers
    # take binary streams since PDF 1.0; the setting is reportlab-global, so it is restored.
    a85 = rl_config.useA85
    rl_config.useA85 = 0
    try:
        doc.build(story, canvasmaker=functools.partial(_NumberedCanvas, stamp=stamp))
    finally:
        rl_config.useA85 = a85
    return path


def inputs_digest_text(digests: list[str], none_text: str) -> str:
    """The inputs' SHA-256 as a page stamp prints it (one place for the report and the
    calibration PDF).

    Parameters
    ----------
    digests : list of str
        The inputs' SHA-256 hex digests (``Provenance.inputs`` values).
    none_text : str
        What to print when there is no input file.

    Returns
    -------
    str
        ``"input SHA-256 <prefix>"`` for one input, ``"<n> inputs, combined SHA-256 <prefix>"``
        (the SHA-256 of the sorted digests joined) for several, else ``none_text``.
    """
    import hashlib

    if len(digests) == 1:
        return f"input SHA-256 {digests[0][:SHA_PREFIX]}"
    if digests:
        joined = hashlib.sha256("".join(sorted(digests)).encode()).hexdigest()
        return f"{len(digests)} inputs, combined SHA-256 {joined[:SHA_PREFIX]}"
    return none_text
