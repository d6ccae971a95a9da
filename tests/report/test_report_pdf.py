"""The PDF as a physicist reads it: rendered to images, its text extracted with pypdfium2.

Every page carries the running header (the applicator's full name, software version, date) and
footer (input SHA-256 prefix or what stands for it, ``page n/N`` with N the page count); titles
are not cut; the fields of :class:`ReportFields` are printed (or blank lines to fill in); the
fonts are embedded TrueType (no Type 3, no unembedded base-14 font); text and tables are laid
out without matplotlib (only the figures are matplotlib's); extra sections add pages.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ringqa.report import ReportFields, write_pdf
from ringqa.report.layout import para
from ringqa.report.pdf import BLANK, page_stamp
from tests.report.conftest import pdf_pages_text

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "reports" / "example" / "report.pdf"
#: The example plan's applicator, as its applicator library names it (no "..." cut).
EXAMPLE_APPLICATOR = "Interstitial Ring CT/MR d=26mm, 60°"
NAN = re.compile(r"\bnan\b", re.IGNORECASE)


def _flat(text: str) -> str:
    """Page text with line breaks and hyphenation-free wrapping joined by single spaces."""
    return " ".join(text.split())


def assert_stamped(pages: list[str], applicator: str, software: str, date: str, inputs: str):
    """Every page has the header and footer; page k says "page k/N", N = the page count."""
    n = len(pages)
    for k, text in enumerate(pages, start=1):
        flat = _flat(text)
        assert f"ringqa commissioning report: {applicator}" in flat, (k, flat[:200])
        assert software in flat and date in flat, k
        assert inputs in flat, k
        assert f"page {k}/{n}" in flat, k


@pytest.fixture(scope="module")
def fake_pdf(fake_result, tmp_path_factory):
    path = tmp_path_factory.mktemp("pdf") / "report.pdf"
    fields = ReportFields(
        institution="Sint Elsewhere Hospital",
        physicist="Dr. A. Physicist",
        afterloader="Flexitron #1234",
        applicator_serial="SN-0042",
        source_calibration="Ir-192 D36K-123, 40.8 mGy m2/h, 2026-11-01",
    )
    write_pdf(fake_result, path, fields=fields, notes="Checked against the film measurement.")
    return path


def test_every_page_has_header_and_footer(fake_result, fake_pdf):
    pages = pdf_pages_text(fake_pdf)
    stamp = page_stamp(fake_result)
    assert len(pages) >= 6  # summary, positions, deviations, doses, dwell table, settings
    assert_stamped(pages, fake_result.applicator, stamp.software, stamp.date, stamp.inputs)
    assert [k for k, t in enumerate(pages) if NAN.search(t)] == []


def test_pages_in_order_and_fields_printed(fake_result, fake_pdf):
    """The section titles appear in the report's order, each on a later page than the one
    before; the filled fields, the free notes and the signature block are on the summary."""
    pages = [_flat(t) for t in pdf_pages_text(fake_pdf)]
    titles = [
        "Commissioning report",
        "Dwell positions (paper Figure 6",
        "Deviations from the",
        "Dose points and standard-plan doses",
        "Dwell by dwell",
        "Settings of this run",
    ]
    where = [next(k for k, t in enumerate(pages) if title in t) for title in titles]
    assert where == sorted(where) and len(set(where)) == len(where), where
    summary = " ".join(pages[: where[1]])
    for value in ("Sint Elsewhere Hospital", "Dr. A. Physicist", "Flexitron #1234", "SN-0042",
                  "D36K-123", "Checked against the film measurement.", "Signature",
                  "doi:10.1002/mp.16934"):  # fmt: skip
        assert value in summary, value
    assert "Verdicts" in summary and "Notes" in summary and "Reference path" in summary
    doses = pages[where[3]]
    assert "Perez-Calatayud" in doses  # the TG-43 consensus data cited where it is used
    settings = " ".join(pages[where[5] :])
    for key in ("step_mm", "position_recommended_mm", "dose_action_pct", "register"):
        assert key in settings, key  # the settings table's rows (tests/report/test_settings_page)


def test_blank_fields_are_lines_to_fill(fake_result, tmp_path):
    path = write_pdf(fake_result, tmp_path / "blank.pdf")
    summary = _flat(pdf_pages_text(path)[0])
    assert summary.count(BLANK) >= 5  # institution, physicist, serial, afterloader, source


def test_fonts_embedded_truetype(fake_pdf):
    """reportlab writes font dictionaries uncompressed: every font is a TrueType subset with its
    /FontFile2 stream; no Type 3 or base-14 Type 1 font (those are not embedded)."""
    raw = fake_pdf.read_bytes()
    n_fonts = len(re.findall(rb"/Type /Font\b", raw))
    assert n_fonts >= 2
    assert raw.count(b"/FontFile2") >= 2  # regular and bold at least
    assert b"/Type3" not in raw and b"/Subtype /Type3" not in raw
    assert b"/Subtype /Type1" not in raw
    assert len(re.findall(rb"/Subtype /TrueType", raw)) == n_fonts


def test_streams_binary_not_ascii85(fake_pdf):
    """The streams (pages, fonts, figures) are Flate-compressed binary, not ASCII85 text:
    reportlab's ASCII85 encoder is pure Python (a quarter of the PDF's build time, issue 16) and
    makes each stream 25 % larger. reportlab's global setting is left as it was."""
    from reportlab import rl_config

    raw = fake_pdf.read_bytes()
    assert b"/ASCII85Decode" not in raw
    assert raw.count(b"/FlateDecode") >= 3  # the three figures at least
    assert rl_config.useA85 == 1  # reportlab's default, restored after the build


def test_only_the_figures_use_matplotlib(fake_result, tmp_path, monkeypatch):
    """Three matplotlib figures (positions, deviations, dose points) make the whole report: the
    text and table pages are reportlab's (issue 16: they cost most of the old 2.4 s)."""
    import ringqa.report.figures as plots

    made = []
    real = plots.new_figure
    monkeypatch.setattr(plots, "new_figure", lambda size: made.append(size) or real(size))
    write_pdf(fake_result, tmp_path / "r.pdf")
    assert len(made) == 3


def test_extra_sections_add_pages(fake_result, fake_pdf, tmp_path):
    """A section (the place for e.g. an uncertainty page) adds its own page after the standard
    ones, stamped like the others."""
    base = len(pdf_pages_text(fake_pdf))
    path = write_pdf(fake_result, tmp_path / "s.pdf",
                     sections=[lambda res: [para(f"Uncertainty of {res.applicator}")]])  # fmt: skip
    pages = pdf_pages_text(path)
    assert len(pages) == base + 1
    assert f"Uncertainty of {fake_result.applicator}" in _flat(pages[-1])
    stamp = page_stamp(fake_result)
    assert_stamped(pages, fake_result.applicator, stamp.software, stamp.date, stamp.inputs)


def test_pages_render_to_images(fake_pdf):
    """Each page renders (pypdfium2) to an A4-shaped image that is not blank."""
    import numpy as np
    import pypdfium2 as pdfium

    pdf = pdfium.PdfDocument(str(fake_pdf))
    try:
        for k in range(len(pdf)):
            img = np.asarray(pdf[k].render(scale=0.5).to_pil().convert("L"))
            assert img.shape[0] / img.shape[1] == pytest.approx(297 / 210, rel=0.01)
            assert (img < 128).mean() > 0.001, k  # some ink on every page
    finally:
        pdf.close()


@pytest.mark.skipif(not EXAMPLE.is_file(), reason="reports/example not generated")
def test_example_report_titles_not_cut():
    """The committed example report: the applicator's full name (with its size) on every page,
    the input's SHA-256 prefix in every footer (from results.json)."""
    import json

    info = json.loads((EXAMPLE.parent / "results.json").read_text())
    digest = next(iter(info["provenance"]["inputs"].values()))
    pages = pdf_pages_text(EXAMPLE)
    assert info["applicator"] == EXAMPLE_APPLICATOR
    software = info["provenance"]["software"]
    date = info["provenance"]["created_utc"][:10]
    assert_stamped(pages, EXAMPLE_APPLICATOR, software, date, f"input SHA-256 {digest[:12]}")
    assert "library part ID: ring 110350-06" in _flat(pages[0])


@pytest.mark.parametrize("fork", [True, False])
def test_figures_drawn_ahead_give_the_same_pdf(fake_result, tmp_path, monkeypatch, fork):
    """The positions, deviation and dose-map figures drawn in forked processes (draw_ahead, one
    a figure, on the second core) or drawn late in this one give a PDF byte for byte equal to
    the plain one (reportlab's invariant mode: no time stamp or random id in the file), and the
    figures are drawn once: three figures in all (in the children when forked: none drawn here
    again)."""
    from reportlab import rl_config

    import ringqa.report.figures as plots
    from ringqa.parallel import can_fork
    from ringqa.report.pdf import draw_ahead

    monkeypatch.setattr(rl_config, "invariant", 1)
    write_pdf(fake_result, tmp_path / "plain.pdf")
    made = []
    real = plots.new_figure
    monkeypatch.setattr(plots, "new_figure", lambda size: made.append(size) or real(size))
    drawn = draw_ahead(fake_result, fork=fork)
    forked = drawn.forked
    assert forked == (fork and can_fork())
    write_pdf(fake_result, tmp_path / "ahead.pdf", drawn=drawn)
    assert (tmp_path / "ahead.pdf").read_bytes() == (tmp_path / "plain.pdf").read_bytes()
    assert len(made) == (0 if forked else 3)  # in the children when forked


def test_flate_figure_is_what_draw_image_writes(tmp_path, monkeypatch):
    """A figure handed over compressed (``layout.figure_image``: ``figure_flate`` +
    ``draw_flate``, as the children drawing ahead hand figures over) gives the PDF byte for
    byte that reportlab's ``drawImage`` of the same pixels as an ``ImageReader`` gives (the
    same image object, name, Flate stream and operators; reportlab's invariant mode), and so
    does the fallback for a canvas without the parts ``draw_flate`` uses (``image.reader()``
    through ``drawImage``)."""
    from reportlab import rl_config

    from ringqa.report import layout
    from ringqa.report.figures import new_figure

    monkeypatch.setattr(rl_config, "invariant", 1)
    fig = new_figure((3.0, 2.0))
    ax = fig.add_subplot()
    ax.plot([0, 1, 2], [0, 1, 4], marker="o", label="a line")
    ax.legend()
    stamp = layout.PageStamp(title="t", software="ringqa test", date="2026-11-29", inputs="-")

    def build(name, flowable):
        return layout.build_pdf(tmp_path / name, [flowable], stamp, title="t").read_bytes()

    image = layout.figure_flate(fig)
    reader = layout.pixel_image(*layout.figure_pixels(fig))  # reportlab's own path
    assert (image.width_px, image.height_px) == reader.reader.getSize()
    plain = build("plain.pdf", reader)
    assert build("flate.pdf", layout.FlateFigure(image, layout.FRAME_WIDTH)) == plain
    monkeypatch.setattr(layout, "draw_flate", lambda *a: False)  # e.g. another reportlab
    assert build("fallback.pdf", layout.FlateFigure(image, layout.FRAME_WIDTH)) == plain


def test_several_results_figures_each_their_own_image(fake_result, tmp_path):
    """One PDF with two results' figures (``write_channels_pdf``: a section per channel) holds
    six image objects under six names (each figure is named when laid out, its pixels written
    with the file: ``positions-1``, ``deviations-2``, ... in the order laid out), and the two
    results' positions figures differ where their simulated paths differ (0.2 vs 0.5 mm)."""
    import zlib

    from ringqa.pipeline import CommissionSettings, commission
    from ringqa.report.pdf import write_channels_pdf
    from tests.pipeline.fakes import fake_engine, fake_simulator, make_applicator

    engine = fake_engine(fake_simulator(z_m=5e-4, coarse_z_m=3e-5))
    other = commission(make_applicator(tandem=True), CommissionSettings(), engine=engine)
    path = write_channels_pdf([fake_result, other], tmp_path / "two.pdf", conclusion="both")
    data = path.read_bytes()
    streams = [zlib.decompress(m) for m in re.findall(rb"stream\r?\n(.*?)endstream", data, re.S)
               if m[:1] == b"x"]  # the zlib streams: pages and images  # fmt: skip
    names = re.findall(rb"/FormXob\.((?:positions|deviations|doses)-\d+) Do", b"".join(streams))
    assert sorted(set(names)) == sorted(
        f"{k}-{n}".encode() for n, k in enumerate(["positions", "deviations", "doses"] * 2, 1)
    )
    assert data.count(b"/Subtype /Image") == 6
    images = [x for x in streams if len(x) > 1_000_000]  # RGB pixels, 1 MB and more each
    assert len(images) == 6 and len(set(images)) >= 4


def test_report_figures_stored_at_the_cheaper_level_hold_the_same_pixels(fake_result):
    """The report's three figures (drawn ahead or at their page: ``pdf._draw_one``) are stored
    zlib-compressed at ``FIGURE_FLATE_LEVEL`` (3, cheaper than reportlab's default 6), unnamed
    (``LaterFigure`` names them by key): the stream decompresses to the figure's exact RGB
    pixels, and is no larger than 1.3x the default level's."""
    import zlib

    from ringqa.report import figures as plots
    from ringqa.report import layout, pdf

    assert pdf.FIGURE_FLATE_LEVEL == 3
    for name, (make, size) in pdf.AHEAD_FIGURES.items():
        image = pdf._draw_one(make, fake_result)
        rgb, size_in = layout.figure_pixels(make(fake_result))
        assert image.name == "" and image.size_in == size_in == size, name
        assert (image.height_px, image.width_px) == rgb.shape[:2]
        assert zlib.decompress(image.data) == rgb.tobytes(), name
        assert image.data == zlib.compress(rgb.tobytes(), 3)
        assert len(image.data) <= 1.3 * len(zlib.compress(rgb.tobytes())), name
    assert pdf.AHEAD_FIGURES["positions"][0] is plots.positions_figure
