"""report.html: self-contained (plotly's JavaScript inlined, no script or stylesheet from the
network), written beside report.pdf from the same result, with the PDF's numbers."""

from __future__ import annotations

import re

from ringqa.pipeline.numbers import DIST_MM, ERROR_MM, SIGNED_PCT, fmt, fmt_verdict_value
from ringqa.report import write_report
from ringqa.report.html import html_text, view_figure
from ringqa.report.pdf import LONG_NAMES, dose_table


def test_html_is_self_contained_and_carries_the_numbers(fake_result, tmp_path):
    """The page inlines plotly.js (its bundle is megabytes: > 1 MB of script), loads nothing
    over the network (no ``<script src``, no tag with ``src="http`` or ``href="http``), and
    holds every verdict's value in the verdict's form, the conclusion, every dose-table cell
    of the PDF, and each simulated dwell's deviation and numerical error in its hover text."""
    write_report(fake_result, tmp_path / "out")
    page = (tmp_path / "out" / "report.html").read_text(encoding="utf-8")
    assert (tmp_path / "out" / "report.pdf").is_file()
    scripts = re.findall(r"<script\b[^>]*>(.*?)</script>", page, flags=re.S)
    assert max(len(s) for s in scripts) > 1_000_000  # plotly.js inlined
    assert "plotly.js v" in page or "plotly.js" in page
    # no script loaded from anywhere, and no tag outside the scripts that fetches a resource
    # (plotly.js's own text holds link strings; they load nothing)
    assert not re.search(r"<script\b[^>]*\bsrc\s*=", page)
    tags = re.sub(r"(<script\b[^>]*>).*?(</script>)", r"\1\2", page, flags=re.S)
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", tags)
    for v in fake_result.verdicts:
        assert fmt_verdict_value(v.value, v.unit, v.check) in page, v.check
    assert fake_result.conclusion in page
    _, rows = dose_table(fake_result)
    for row in rows:
        for cell in row:
            assert cell.replace("\n", "<br>") in page, cell
    sim = fake_result.dwells[fake_result.dwells["path"] == "simulated"]
    fig = view_figure(fake_result)
    traces = fig["data"]
    sim_trace = next(t for t in traces if t["name"] == "simulated")
    for text, row in zip(sim_trace["text"], sim.itertuples(), strict=True):
        assert f"deviation {fmt(row.dist_to_reference_mm, DIST_MM)} mm" in text
        assert f"numerical error {fmt(row.numerical_error_mm, ERROR_MM)} mm" in text
    names = {t["name"] for t in traces}
    assert {"simulated", "centreline dwells", "channel ring", "dose points"} <= names
    assert "reference as supplied" in names
    points = next(t for t in traces if t["name"] == "dose points")
    sims = fake_result.doses[(fake_result.doses["plan"] == "simulated")
                             & (fake_result.doses["kind"] != "tps")]  # fmt: skip
    for text, row in zip(points["hovertext"], sims.itertuples(), strict=True):
        assert LONG_NAMES.get(row.point, row.point) in text
        assert fmt(row.diff_registered_pct, SIGNED_PCT) in text


def test_html_text_has_no_install_path(fake_result):
    """No path of the installation in the page (the input is named as outputs name it)."""
    from pathlib import Path

    import ringqa

    assert str(Path(ringqa.__file__).resolve().parent.parent) not in html_text(fake_result)


def test_notebook_publish_html(fake_result, tmp_path):
    """``result.publish_html(path)`` writes the same page as the command line."""
    path = fake_result.publish_html(tmp_path / "r.html")
    page = path.read_text(encoding="utf-8")
    assert fake_result.conclusion in page and "<h2>Verdicts</h2>" in page
