"""The shipped families' rules against hand-derived values."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ringqa.errors import RingQAError
from ringqa.geometry import Applicator, Centreline, Channel, GeometryError, Lumen
from ringqa.geometry.families import family_name_of, family_named, family_of, tandem_frame
from ringqa.io.applicator_file import load_applicator
from ringqa.plan import DosePointSpec, applicator_dose_points, dose_points_from_frame

DATA = Path(__file__).parents[3] / "data" / "applicators"


def _straight(a_mm, b_mm, n=61):
    a, b = np.asarray(a_mm, float), np.asarray(b_mm, float)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return Centreline.from_points((a + t * (b - a)) * 1e-3)


def _lumen():
    return Lumen.circular(1.5e-3, 1.4e-3)


def test_ring_points_equal_the_frame_definition_bit_for_bit():
    """The ring family's points (and Point A) are dose_points_from_frame's, to the last bit."""
    app = load_applicator("ring26x60")
    spec = DosePointSpec()
    got = applicator_dose_points(app, spec)
    want = dose_points_from_frame(app.ring_centre_m * 1e3, app.ring_normal, app.ring_lateral,
                                  app.ring_radius_m * 1e3, spec)  # fmt: skip
    assert [p.name for p in got] == [p.name for p in want]
    for g, w in zip(got, want, strict=True):
        assert np.array_equal(g.position_mm, w.position_mm)


def test_family_by_name_and_field():
    """A channel's own family wins; else its name ("left ovoid" -> ovoid, "Lunar R" -> ovoid,
    "tandem" -> tandem); else the applicator's."""
    cl = _straight([0, 0, -60], [0, 0, 0])
    app = Applicator("x", (Channel("chan", cl, _lumen(), 0.05),), family="free-form")
    assert family_name_of(app, Channel("left ovoid", cl, _lumen(), 0.05)) == "ovoid"
    assert family_name_of(app, Channel("Lunar_R", cl, _lumen(), 0.05)) == "ovoid"
    assert family_name_of(app, Channel("tandem", cl, _lumen(), 0.05)) == "tandem"
    assert family_name_of(app, Channel("tandem", cl, _lumen(), 0.05, family="ring")) == "ring"
    assert family_of(app, app.channels[0]).name == "free-form"
    with pytest.raises(GeometryError, match="no applicator family 'nope'"):
        family_named("nope")


def _tandem_and_ovoids():
    """Tandem along +z, tip at (0, 0, 60), entry at (0, 0, -60); ovoids along +z at x = +-20 mm,
    tips at z = 0, each bending... kept straight here: relative position 0 sits 5 mm below
    the tip."""
    tandem = Channel("tandem", _straight([0, 0, -60], [0, 0, 60], 121), _lumen(), 0.115)
    left = Channel("left ovoid", _straight([20, 0, -100], [20, 0, 0], 101), _lumen(), 0.095)
    right = Channel("right ovoid", _straight([-20, 0, -100], [-20, 0, 0], 101), _lumen(), 0.095)
    return tandem, left, right


def test_tandem_frame_by_hand():
    """Axis +z (entry -> tip); the ovoids' relative-position-0 points are (+-20, 0, -5), so the
    origin is (0, 0, -5); lateral = right -> left ovoid = +x; scale = tip (0, 0, 55) - origin
    = 60 mm."""
    tandem, left, right = _tandem_and_ovoids()
    f = tandem_frame(tandem, (left, right), left, right)
    assert np.allclose(f.normal, [0, 0, 1], atol=1e-9)
    assert np.allclose(f.centre_m * 1e3, [0, 0, -5], atol=1e-6)
    assert np.allclose(f.lateral, [1, 0, 0], atol=1e-9)
    assert f.scale_m == pytest.approx(0.060, abs=1e-9)


def test_ovoid_points_by_hand():
    """With that frame: Point A at (+-20, 0, -5 + 26.9); each ovoid's distal 20 mm (relative
    positions 0-20, z = -5 .. -25) is equally lateral (x = +-20), so the most lateral stretch is
    all of it and its middle is relative position 10, (+-20, 0, -15); the ovoid surface points
    are 10 mm (cap radius) further along the lateral axis, x = +-30, and the 5 mm points at
    x = +-35."""
    tandem, left, right = _tandem_and_ovoids()
    f = tandem_frame(tandem, (left, right), left, right)
    app = Applicator("to", (tandem, left, right), f.centre_m, f.normal, f.lateral, f.scale_m,
                     family="tandem")  # fmt: skip
    pts = {p.name: p.position_mm for p in applicator_dose_points(app)}
    assert set(pts) == {
        "point_a_left",
        "point_a_right",
        "ovoid_surface_left",
        "ovoid_depth5_left",
        "ovoid_surface_right",
        "ovoid_depth5_right",
    }
    assert np.allclose(pts["point_a_left"], [20, 0, 21.9], atol=1e-6)
    assert np.allclose(pts["ovoid_surface_left"], [30, 0, -15], atol=1e-6)
    assert np.allclose(pts["ovoid_depth5_right"], [-35, 0, -15], atol=1e-6)


def _bent_ovoid(x_mm):
    """An ovoid at x = ``x_mm`` whose cap points posteriorly (+y), across the tandem's axis (as
    the public Eclipse phantom's caps do): shaft along +z up to (x, 0, -20), a quarter circle of
    radius 10 mm into +y, then a 30 mm straight cap to the tip (x, 40, -10); s_ref = 5 mm
    before the tip."""
    shaft = [(x_mm, 0.0, z) for z in np.linspace(-100.0, -20.0, 81)]
    phi = np.linspace(0.0, np.pi / 2, 31)[1:]
    bend = [(x_mm, 10.0 - 10.0 * np.cos(f), -20.0 + 10.0 * np.sin(f)) for f in phi]
    cap = [(x_mm, y, -10.0) for y in np.linspace(10.0, 40.0, 61)[1:]]
    cl = Centreline.from_points(np.asarray(shaft + bend + cap) * 1e-3)
    return cl, float(cl.length_m) - 0.005


def test_a_cap_across_the_axis_gets_its_surface_point_beside_it_not_beyond_its_tip():
    """Caps along +y at x = +-20, tips (+-20, 40, -10), relative position 0 at y = 35. The
    distal 20 mm (y = 35 .. 15) all lie on the cap's straight run, equally lateral (x = +-20),
    so the cap's middle is relative position 10, (+-20, 25, -10); the lateral axis (+x) is
    perpendicular to the cap there, so the surface point is (+-30, 25, -10) and the 5 mm point
    (+-35, 25, -10). (Moving outwards from the tandem's axis instead would put it beyond the
    tip, y > 40: the rule this test guards against.)"""
    tandem = Channel("tandem", _straight([0, 0, -60], [0, 0, 60], 121), _lumen(), 0.115)
    chans = []
    for x, name in ((20.0, "left ovoid"), (-20.0, "right ovoid")):
        cl, s_ref = _bent_ovoid(x)
        chans.append(Channel(name, cl, _lumen(), s_ref))
    left, right = chans
    f = tandem_frame(tandem, (left, right), left, right)
    app = Applicator("to", (tandem, left, right), f.centre_m, f.normal, f.lateral, f.scale_m,
                     family="tandem")  # fmt: skip
    pts = {p.name: p.position_mm for p in applicator_dose_points(app)}
    assert np.allclose(pts["ovoid_surface_left"], [30, 25, -10], atol=0.05)
    assert np.allclose(pts["ovoid_depth5_left"], [35, 25, -10], atol=0.05)
    assert np.allclose(pts["ovoid_surface_right"], [-30, 25, -10], atol=0.05)


def test_spans_by_hand():
    """Tandem: distal 60 mm; ovoid: distal 20 mm; both cut to the step grid and to s_ref."""
    tandem, left, _ = _tandem_and_ovoids()
    app = Applicator("to", (tandem, left), family="tandem")
    assert family_of(app, tandem).span_mm(app, tandem, 5.0) == 60.0
    assert family_of(app, left).span_mm(app, left, 7.0) == 14.0


def test_free_form_example_loads_with_its_points():
    """data/applicators/free-form-s: family free-form, 2.6 mm lumen, its three points only (no
    Point A: not a gynaecological family), s_ref = length - 5 mm."""
    app = load_applicator(DATA / "free-form-s")
    ch = app.channels[0]
    assert (app.family, ch.family, ch.name) == ("free-form", "free-form", "s-channel")
    assert [p.name for p in applicator_dose_points(app)] == ["P_left", "P_right", "P_beyond_tip"]
    assert ch.length_m - ch.s_ref_m == pytest.approx(0.005, abs=1e-9)
    rb = ch.lumen.kernel_arrays()[1]
    assert np.allclose(rb, 1.3e-3)


def test_free_form_errors_name_the_field(tmp_path):
    """An unknown family and a ring file with free-form keys are refused by name."""
    src = DATA / "free-form-s"
    (tmp_path / "centreline.csv").write_text((src / "centreline.csv").read_text())
    doc = json.loads((src / "applicator.json").read_text())
    (tmp_path / "applicator.json").write_text(json.dumps({**doc, "family": "free-from"}))
    with pytest.raises(RingQAError, match="family"):
        load_applicator(tmp_path)
    doc.pop("family")
    (tmp_path / "applicator.json").write_text(json.dumps(doc))
    with pytest.raises(RingQAError, match="dose_points"):
        load_applicator(tmp_path)


def test_free_form_lumen_narrower_than_the_cable_is_refused(tmp_path):
    """A 0.8 mm lumen cannot take the 1.1 mm Flexitron cable: commission refuses it."""
    from ringqa.pipeline import CommissionSettings, commission

    src = DATA / "free-form-s"
    (tmp_path / "centreline.csv").write_text((src / "centreline.csv").read_text())
    doc = json.loads((src / "applicator.json").read_text())
    (tmp_path / "applicator.json").write_text(json.dumps({**doc, "lumen_diameter_mm": 0.8}))
    with pytest.raises(RingQAError, match=r"(?i)lumen|cable"):
        commission(tmp_path, CommissionSettings(require_measured=False))
