"""Page 1 of the report, read as text: where the reference comes from, what its checks found,
the verdicts by role with the conclusion, the numbers "as supplied | registered" with the
simulation's numerical error; and the other pages' new parts (registered path, flags, numerical
error, registered dose differences). No "nan" anywhere, no text off the page.

The stand-in ring (tests/pipeline/fakes.py) has its reference path 0.5 mm outside the centreline
in the ring plane; lifted 0.5 mm cranially (+z, the ring normal) it is planar at a constant
height, and plane-height registration moves it back by exactly 0.5 mm. The stand-in simulator
puts the source 0.3 mm outside the centreline and 0.2 mm cranial, so (in mm):

- centreline vs reference: sqrt(0.5^2 + 0.5^2) = 0.71 as supplied, 0.50 registered;
- simulated vs reference: sqrt(0.2^2 + 0.3^2) = 0.36 as supplied, sqrt(0.2^2 + 0.2^2) = 0.28
  registered;
- numerical error: the unrefined run sits 0.03 mm further cranially (``coarse_z_m``).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from ringqa.pipeline import CommissionSettings, commission
from ringqa.report.pdf import (
    comparison_rows,
    dose_table,
    dwell_table,
    page1_items,
    page1_lines,
    plain_wording,
    report_figures,
    transform_text,
)
from tests.pipeline.fakes import fake_engine, fake_simulator, make_applicator, outward

NAN = re.compile(r"\bnan\b", re.IGNORECASE)
#: Words page 1 must not use for the reference path (it is not a measurement unless its source
#: says so).
MEASUREMENT_WORDS = re.compile(r"measured (source )?path|measured plan|vendor", re.IGNORECASE)


def with_reference_path(app, path_m):
    """``app`` with its ring channel's reference path replaced by ``path_m`` (m)."""
    ring = dataclasses.replace(app.channels[0], measured_path_m=path_m)
    return dataclasses.replace(app, channels=(ring, *app.channels[1:]))


def lifted(app, dz_m: float):
    """``app`` with its reference path moved ``dz_m`` along +z (cranially)."""
    return with_reference_path(app, app.channels[0].measured_path_m + np.array([0.0, 0.0, dz_m]))


def run(app, register: str = "none"):
    """Commission ``app`` with the stand-in engine (numerical error 0.03 mm)."""
    engine = fake_engine(fake_simulator(z_m=2e-4, coarse_z_m=3e-5))
    return commission(app, CommissionSettings(register=register), engine=engine)


@pytest.fixture(scope="module")
def registered():
    """Planar reference path 0.5 mm above the ring plane, registration plane-height."""
    return run(lifted(make_applicator(), 0.5e-3), "plane-height")


@pytest.fixture(scope="module")
def unregistered():
    """Reference path in the ring plane (with a tandem), registration none."""
    return run(make_applicator(tandem=True))


@pytest.fixture(scope="module")
def centreline():
    """No reference path: the centreline is the reference."""
    return run(make_applicator(n_measured=0))


@pytest.fixture(scope="module")
def flagged():
    """Reference position 3 (relative 7.5 mm) 1 mm further out: beyond the lumen's reach."""
    app = make_applicator()
    path = app.channels[0].measured_path_m.copy()
    path[3] += 1e-3 * outward(path[3:4])[0]
    return run(with_reference_path(app, path))


def row(rows, label):
    """The table row whose label starts with ``label``."""
    hits = [r for r in rows if r[0].startswith(label)]
    assert len(hits) == 1, (label, rows)
    return hits[0]


def test_page1_states_reference_checks_and_registration(registered):
    text = "\n".join(page1_lines(registered))
    assert "Reference path: stand-in path." in text  # where it comes from, in its own words
    assert "planar" in text and "0.50 mm above the ring channel's plane" in text
    assert "Registration (plane-height): translated 0.50 mm caudally" in text
    assert "translation (x, y, z) = (+0.00, +0.00, -0.50) mm" in text
    assert "rotation 0.00 deg" in text
    assert not MEASUREMENT_WORDS.search(text)


def test_page1_numbers_as_supplied_and_registered(registered):
    rows = comparison_rows(registered)
    assert rows[0] == ("", "as supplied", "registered (plane-height)")
    assert row(rows, "Centreline vs reference: max distance")[1:] == ("0.71", "0.50")
    assert row(rows, "Simulated vs reference: median distance")[1:] == ("0.36", "0.28")
    assert row(rows, "Simulated: numerical error")[1:] == ("0.030 (0.030)", "0.030 (0.030)")
    assert row(rows, "Reference positions that cannot lie in the lumen")[1:] == ("0", "0")
    for plan in ("Simulated", "Centreline"):
        for where in ("surface", "5 mm deeper", "Point A"):
            label = f"{plan} plan: max |dose difference|, {where}"
            raw = registered.summary.max_abs_diff_pct[plan.lower()]
            reg = registered.summary.max_abs_diff_registered_pct[plan.lower()]
            kind = {"surface": "surface", "5 mm deeper": "depth5", "Point A": "point_a"}[where]
            assert row(rows, label)[1:] == (f"{raw[kind]:.2f}", f"{reg[kind]:.2f}")
    lines = page1_lines(registered)
    assert " | as supplied | registered (plane-height)" in lines
    # the numerical error in words follows the table
    table = next(k for k, line in enumerate(lines) if "as supplied | registered" in line)
    assert any(line.startswith("Numerical error of the simulated positions: up to 0.030 mm")
               for line in lines[table:])  # fmt: skip


def test_page1_verdicts_grouped_by_role_then_conclusion(registered):
    items = page1_items(registered)
    kinds = [it.kind for it in items]
    subheadings = [it.text for it in items if it.kind == "subheading"]
    assert [s.split(" ")[0] for s in subheadings[:3]] == ["TPS", "Simulation", "Numerics:"]
    by_role = {}
    role = None
    for it in items:
        if it.kind == "subheading":
            role = it.text
        elif it.kind == "verdict":
            by_role.setdefault(role, []).append(it.text)
    expected = {}
    for v in registered.verdicts:
        heading = next(s for s in subheadings if s.lower().startswith(v.role.lower()))
        expected.setdefault(heading, []).append(v.text)
    assert by_role == expected
    last_verdict = max(k for k, kind in enumerate(kinds) if kind == "verdict")
    assert items[last_verdict + 1].kind == "conclusion"
    assert items[last_verdict + 1].text == registered.conclusion
    assert kinds.count("conclusion") == 1


def test_page1_registration_none_shows_both_columns(unregistered):
    rows = comparison_rows(unregistered)
    assert rows[0] == ("", "as supplied", "registered (none)")
    assert all(r[1] == r[2] for r in rows[1:])
    text = "\n".join(page1_lines(unregistered))
    assert "Registration: none: the reference path is compared as supplied" in text
    assert "Transform: none" in text
    assert not MEASUREMENT_WORDS.search(text)


def test_page1_centreline_reference(centreline):
    lines = page1_lines(centreline)
    text = "\n".join(lines)
    assert "Reference: the channel centreline (no reference source path was supplied)" in text
    assert "Simulated vs centreline (reference): max distance (mm)" in text
    assert "Registration: none (the centreline is the reference" in text
    assert "Centreline vs reference" not in text  # no TPS-model numbers without a reference path
    assert comparison_rows(centreline)[0] == ("", "as supplied", "registered (none)")


@pytest.mark.parametrize("name", ["registered", "unregistered", "centreline", "flagged"])
def test_no_nan_on_page1(name, request):
    result = request.getfixturevalue(name)
    assert [line for line in page1_lines(result) if NAN.search(line)] == []


def _texts(fig) -> list:
    from matplotlib.text import Text

    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text()]


def _page_texts(fig) -> list:
    """The texts placed on the page itself (paragraphs, titles), not in the plots."""
    return [t for t in fig.texts if t.get_visible() and t.get_text()]


@pytest.mark.parametrize("name", ["registered", "centreline"])
def test_figures_render_without_nan_and_on_the_page(name, request):
    """Every figure renders; no text says "nan"; no figure-level text runs off its figure (the
    text pages are reportlab's: see test_report_pdf.py)."""
    result = request.getfixturevalue(name)
    figs = report_figures(result)
    words = [t.get_text() for fig in figs for t in _texts(fig)]
    assert [w for w in words if NAN.search(w)] == []
    assert len(figs) == 3  # positions, deviations, dose points
    for fig in figs:
        fig.canvas.draw()  # lay out ticks and labels as on the page
        renderer = fig.canvas.get_renderer()
        page = fig.bbox
        for t in _page_texts(fig):
            box = t.get_window_extent(renderer)
            assert page.x0 <= box.x0 and box.x1 <= page.x1, t.get_text()[:60]
            assert page.y0 <= box.y0 and box.y1 <= page.y1, t.get_text()[:60]
    if name == "registered":
        assert "reference registered dwells" in words  # the positions page's legend
        assert "numerical error of the simulation" in words  # the deviation page's legend


def test_dose_table_registered_differences(registered, unregistered):
    header, rows = dose_table(registered)
    assert header == ["dose point", "reference plan\n(as supplied)", "reference plan\n(registered)",
                      "centreline plan", "simulated plan"]  # fmt: skip
    d = registered.doses
    sim = d[(d["plan"] == "simulated") & (d["point"] == "surface_left")].iloc[0]
    cells = next(r for r in rows if r[0] == "lateral ring surface left")
    assert cells[-1] == (
        f"{sim['dose_gy']:.3f} ({sim['diff_pct']:+.2f} / {sim['diff_registered_pct']:+.2f} %)"
    )
    header, rows = dose_table(unregistered)
    assert "reference plan\n(registered)" not in header
    assert not any(" / " in cell for r in rows for cell in r)


def test_dwell_table_flags_and_numerical_error(flagged, registered):
    table = dwell_table(flagged)
    flags = table["ref.\nposition"].tolist()
    assert flags[3] == "infeasible" and set(flags[:3] + flags[4:]) == {""}
    assert set(table["sim.\nnum.\nerror\n(mm)"]) == {"0.030"}
    table = dwell_table(registered)  # registered: the flags as supplied and as registered
    assert {"ref. as\nsupplied", "ref.\nregistered"} <= set(table.columns)


def test_transform_text():
    turn = np.eye(4)
    turn[:3, :3] = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]  # 90 deg about +z
    turn[:3, 3] = [1e-3, 0.0, -2e-3]
    text = transform_text(turn)
    assert "translation (x, y, z) = (+1.00, +0.00, -2.00) mm, 2.24 mm in all" in text
    assert "rotation 90.00 deg about the axis (+0.000, +0.000, +1.000)" in text
    assert transform_text(np.eye(4)).startswith("Transform: none")


def test_plain_wording_keeps_the_source_words():
    assert plain_wording("ring channel, measured path 30 positions") == (
        "ring channel, reference path 30 positions"
    )
    assert plain_wording("No measured source path ships") == "No reference source path ships"
    source = "film measured path, 2024"
    assert plain_wording(f"Reference ({source}; measured path)", keep=(source,)) == (
        f"Reference ({source}; reference path)"
    )
