"""Reading a real Eclipse/BrachyVision tandem-and-ovoids plan and its RT Structure Set.

The files: ``data/examples/eclipse_tandem_ovoids`` (from github.com/livingag/pyTG43,
``examples/HDR`` at commit a6aa553, GNU AGPL-3.0; a water phantom, no patient data; see its
README). What a real export needs that the synthetic pairs of test_rtstruct.py did not have:

- channel contours with very uneven point spacing (a point 0.15 mm from the tip, 1.48 mm steps in
  the ovoid bend, 20-72 mm straight runs) that an interpolating spline through the points alone
  cannot follow (``rtstruct.even_points_mm``);
- ``SourceIsotopeName`` holding the source model ("GammaMed Plus HDR source 0.9 mm") and the
  isotope known only by its half-life (73.83 d);
- the TPS dose at each point as ``CumulativeDoseReferenceCoefficient`` x
  ``BrachyApplicationSetupDose`` (``DeliveryMaximumDose`` = 6 Gy on both points is a constraint).
"""

from __future__ import annotations

import numpy as np
import pydicom
import pytest

from ringqa.geometry import Centreline, GeometryError
from ringqa.io.rtplan import COEFFICIENT_DOSE_TAG, read_rtplan
from ringqa.io.rtstruct import (
    MERGE_FRACTION,
    applicator_from_structures,
    even_points_mm,
    polyline_distance_mm,
    read_rtstruct,
)
from ringqa.paths import data_dir
from ringqa.units import mm_to_m

FOLDER = data_dir() / "examples" / "eclipse_tandem_ovoids"
PLAN = FOLDER / "RP_tandem_ovoids_eclipse.dcm"
STRUCTURES = FOLDER / "RS_tandem_ovoids_eclipse.dcm"


def _contour(name):
    return next(c for c in read_rtstruct(STRUCTURES).contours if c.roi_name == name).points_mm


def test_even_points_leaves_an_evenly_spaced_contour_alone():
    """Points 1 mm apart on a circle arc (all spacings equal the median): returned unchanged."""
    phi = np.arange(0.0, 1.0, 1.0 / 40.0)
    pts = np.c_[40.0 * np.cos(phi), 40.0 * np.sin(phi), np.zeros_like(phi)]
    out, note = even_points_mm(pts)
    assert note == "" and np.array_equal(out, pts)


def test_even_points_merges_repeated_points_and_keeps_dense_contours_bounded():
    """A repeated point (which Centreline.from_points refuses: "points coincide") is merged;
    a contour whose median spacing is 0.01 mm (z = 0, a cluster 20.00 .. 20.10 every 0.01 mm,
    40.1) works with h = MIN_EVEN_SPACING_MM = 0.5 mm: the cluster's points closer than 0.1 mm
    to z = 20 are merged (9; z = 20.10 is not closer), and each 20 mm run is 40 pieces, not
    2000: 1 + 40 + 1 + 40 = 82 points."""
    line = np.c_[np.zeros(21), np.zeros(21), np.arange(21.0)]
    doubled = np.insert(line, 5, line[5], axis=0)
    out, note = even_points_mm(doubled)
    assert np.array_equal(out, line) and "1 point(s)" in note
    with pytest.raises(GeometryError, match="coincide"):
        Centreline.from_points(mm_to_m(doubled))
    assert len(Centreline.from_points(mm_to_m(out)).points_m) == 21
    cluster = np.c_[np.zeros(11), np.zeros(11), 20.0 + 0.01 * np.arange(11)]
    dense = np.vstack([[[0.0, 0.0, 0.0]], cluster, [[0.0, 0.0, 40.1]]])
    out, _ = even_points_mm(dense)
    assert len(out) == 1 + 40 + 1 + 40


def test_even_points_merges_and_divides_on_the_polyline():
    """The right ovoid's 14 points (spacings 0.15, 19.33, 1.48 x 9, 20.30, 72.00 mm; median
    h = 1.479 mm): the point 0.15 mm from the tip (< 0.2 h = 0.30 mm) is merged (the tip itself
    is kept), and the three runs longer than 1.5 h are divided into round(L / h) pieces:
    19.33 -> 13, 20.30 -> 14, 72.00 -> 49 pieces. 14 - 1 + (12 + 13 + 48) = 86 points on the
    original polyline (the first 13 within the merged point's offset), both ends kept, no spacing
    above 1.5 h or below 0.2 h."""
    pts = _contour("right ovoid")
    out, note = even_points_mm(pts)
    assert len(out) == 86
    assert "1 point(s) closer than 0.30 mm merged" in note and "3 straight segment(s)" in note
    assert np.array_equal(out[0], pts[0]) and np.array_equal(out[-1], pts[-1])
    # the new first segment (tip -> third point) passes 0.0036 mm from the merged point: the
    # pieces of that segment lie that close to the exported polyline, all others exactly on it
    assert polyline_distance_mm(pts[1], out).max() < 0.004
    assert polyline_distance_mm(out, pts).max() < 0.004
    assert polyline_distance_mm(out[13:], pts[2:]).max() < 1e-9
    spacing = np.linalg.norm(np.diff(out, axis=0), axis=1)
    h = np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    assert spacing.max() < 1.5 * h and spacing.min() > MERGE_FRACTION * h


@pytest.mark.parametrize("name", ["tandem", "right ovoid", "left ovoid"])
def test_the_real_contours_need_evening_and_then_follow_the_polyline(name):
    """As exported, no spline parametrisation converges (the 0.15 mm step next to a 19 mm one);
    evened out, the fitted centreline stays within 0.05 mm of the exported polyline (its chords
    across a bend sag r (1 - cos(d/2r)): 0.02 mm for the ovoids' 1.48 mm steps at r = 13 mm and
    for the tandem's 3.82 mm steps at r = 90 mm), and the ovoid bend radius is the circle's
    through three of its exported points (independent of the spline) within 15 %."""
    pts = _contour(name)
    with pytest.raises(GeometryError, match="arc-length parametrisation"):
        Centreline.from_points(mm_to_m(pts))
    even, _ = even_points_mm(pts)
    cl = Centreline.from_points(mm_to_m(even))
    assert polyline_distance_mm(cl.table.pos * 1e3, pts).max() < 0.05
    if "ovoid" in name:
        a, b, c = pts[3], pts[6], pts[9]  # in the bend
        ab, bc, ca = np.linalg.norm(a - b), np.linalg.norm(b - c), np.linalg.norm(c - a)
        area2 = np.linalg.norm(np.cross(b - a, c - a))
        r_circle = ab * bc * ca / (2.0 * area2)
        s_b, _ = cl.closest(mm_to_m(b[None]))
        k = np.interp(s_b[0], cl.table.s, cl.table.kappa)
        assert 1e3 / k == pytest.approx(r_circle, rel=0.15)
        assert 10.0 < r_circle < 16.0


def test_the_plan_channels_match_their_rois_and_read_as_families():
    """The dwells lie on the contours (Eclipse puts them on its channel model: < 0.05 mm); names
    give the families; each channel's most distal dwell (s_ref) lies its
    ControlPointRelativePosition from the contour's tip, as Eclipse measures it (7.5 mm on the
    tandem, 3.5 mm on the ovoids; to 0.05 mm, the spline vs the exported polyline)."""
    built = applicator_from_structures(read_rtplan(PLAN), read_rtstruct(STRUCTURES), lumen_mm=2.0)
    assert {m.channel: m.roi_name for m in built.matches} == {
        1: "tandem",
        2: "right ovoid",
        3: "left ovoid",
    }
    assert max(m.max_distance_mm for m in built.matches) < 0.05
    assert [c.family for c in built.applicator.channels] == ["tandem", "ovoid", "ovoid"]
    assert [m.n_dwells for m in built.matches] == [15, 5, 5]
    assert sum("Contour evened out" in n for n in built.notes) == 3
    tip_gap_mm = [(c.length_m - c.s_ref_m) * 1e3 for c in built.applicator.channels]
    assert tip_gap_mm == pytest.approx([7.5, 3.5, 3.5], abs=0.05)


def test_source_model_in_isotope_name_is_read_as_ir192_by_half_life():
    """SourceIsotopeName "GammaMed Plus HDR source 0.9 mm", SourceIsotopeHalfLife 73.83 d
    (Ir-192: 73.829 d): Ir-192, the GammaMed Plus consensus data, and a named notice; S_K 40700 U
    as in the file."""
    plan = read_rtplan(PLAN)
    assert plan.source.isotope == "Ir-192"
    assert plan.source.tg43_name == "gammamed-plus"
    assert plan.source.sk_U == 40700.0
    assert any(w.startswith("[plan.isotope_name]") for w in plan.warnings)
    assert not any(w.startswith("[plan.isotope]") for w in plan.warnings)


def test_a_non_isotope_name_with_another_half_life_is_still_refused_for_doses(tmp_path):
    """The same plan with half-life 1925.2 d (Co-60's): the name is not taken as Ir-192 and the
    isotope warning stays (ringqa's dose data are all Ir-192)."""
    ds = pydicom.dcmread(PLAN)
    ds.SourceSequence[0].SourceIsotopeHalfLife = "1925.2"
    ds.save_as(tmp_path / "RP.dcm")
    plan = read_rtplan(tmp_path / "RP.dcm")
    assert plan.source.isotope == "GammaMed Plus HDR source 0.9 mm"
    assert plan.source.tg43_name is None
    assert any(w.startswith("[plan.isotope]") for w in plan.warnings)


def test_tps_doses_from_the_dose_reference_coefficients():
    """Sum over the three channels of the last control point's coefficient, x the setup dose
    6.00155707882398 Gy: PtA_left 0.10382343 + 0.024936158 + 0.043446993... = 1.000000003 ->
    6.0015571 Gy; PtA_right 1.02242813 -> 6.1361608 Gy (pyTG43's README: TPS 6.002 and 6.136 Gy).
    Not the DeliveryMaximumDose constraint (6 Gy on both)."""
    ds = pydicom.dcmread(PLAN)
    setup = float(
        ds.FractionGroupSequence[0]
        .ReferencedBrachyApplicationSetupSequence[0]
        .BrachyApplicationSetupDose
    )
    expected = {}
    for ch in ds.ApplicationSetupSequence[0].ChannelSequence:
        for r in ch.BrachyControlPointSequence[-1].BrachyReferencedDoseReferenceSequence:
            n = int(r.ReferencedDoseReferenceNumber)
            expected[n] = expected.get(n, 0.0) + float(r.CumulativeDoseReferenceCoefficient)
    points = {p.name: p for p in read_rtplan(PLAN).points}
    assert points["PtA_left"].tps_dose_gy == pytest.approx(expected[1] * setup, rel=1e-12)
    assert points["PtA_left"].tps_dose_gy == pytest.approx(6.0015571, abs=1e-6)
    assert points["PtA_right"].tps_dose_gy == pytest.approx(6.1361608, abs=1e-6)
    assert {p.dose_tag for p in points.values()} == {COEFFICIENT_DOSE_TAG}


def test_target_prescription_dose_still_comes_first():
    """The Oncentra example stores TargetPrescriptionDose (A1 7.157785 Gy, ...) and no
    coefficients: read as before."""
    plan = read_rtplan(data_dir() / "examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm")
    got = {p.name: (p.tps_dose_gy, p.dose_tag) for p in plan.points}
    assert got["A1"] == (7.157785, "TargetPrescriptionDose")
    assert got["ICRU"] == (3.510379, "TargetPrescriptionDose")


def test_the_example_is_a_phantom_without_identifiers_and_names_its_licence():
    """Both files: patient name, ID, birth date, sex, station and operators "UNKNOWN" or empty;
    the structure set is the water phantom's; the folder carries the AGPL-3.0 text and a README
    naming the source repository and commit."""
    for path in (PLAN, STRUCTURES):
        ds = pydicom.dcmread(path)
        for key in ("PatientName", "PatientID", "PatientBirthDate", "PatientSex", "StationName"):
            assert str(ds.get(key, "")) in ("UNKNOWN", ""), (path.name, key)
        assert str(ds.get("OperatorsName", "")) in ("UNKNOWN", "")
    assert pydicom.dcmread(STRUCTURES).StructureSetLabel == "Water phantom1"
    readme = (FOLDER / "README.md").read_text(encoding="utf-8")
    assert (
        "github.com/livingag/pyTG43" in readme
        and "a6aa553e9238848575bea702762428374703cc31" in readme
    )
    assert "GNU AFFERO GENERAL PUBLIC LICENSE" in (FOLDER / "LICENSE-AGPL-3.0.txt").read_text()


def test_ovoid_surface_points_lie_beside_the_real_caps():
    """On this phantom the caps point across the tandem's axis (+y), so moving outwards from
    that axis would put the "ovoid surface" point beyond the cap's tip. The rule (families.ovoid)
    puts it beside the middle of the cap's straight run: 10 mm (the assumed cap radius) from the
    ovoid's centreline, its nearest centreline point in the cap (relative position 5-15 mm of
    the 19 mm straight run, not the tip), and on the ovoid's side, further lateral than the
    ovoid (|x| larger by 9.5-10 mm: the lateral axis is 1 degree off x)."""
    from ringqa.geometry.families.base import channel_points_mm
    from ringqa.plan.points import applicator_dose_points

    app = applicator_from_structures(
        read_rtplan(PLAN), read_rtstruct(STRUCTURES), lumen_mm=2.0
    ).applicator
    pts = {p.name: p.position_mm for p in applicator_dose_points(app)}
    for side, name in (("left", "left ovoid"), ("right", "right ovoid")):
        ch = next(c for c in app.channels if c.name == name)
        rel = np.arange(0.0, 40.0, 0.05)
        cl = channel_points_mm(ch, rel)
        surface = pts[f"ovoid_surface_{side}"]
        d = np.linalg.norm(cl - surface, axis=1)
        assert d.min() == pytest.approx(10.0, abs=0.05)
        assert 5.0 <= rel[int(np.argmin(d))] <= 15.0
        gain = abs(surface[0]) - abs(cl[int(np.argmin(d))][0])
        assert 9.5 <= gain <= 10.0


def test_channels_take_their_names_from_the_applicator_id():
    """Eclipse leaves ``SourceApplicatorName`` empty and names each channel in
    ``SourceApplicatorID`` ('tandem', 'right ovoid', 'left ovoid'; read with pydicom below), so
    the plan alone (no structure set) names them so, not "channel 1/2/3". Oncentra's ID is a
    number ('1', '3'): its channels keep the library's labels ('R' the ring, 'IU' the tandem)."""
    ds = pydicom.dcmread(PLAN)
    setups = ds.ApplicationSetupSequence
    ids = [str(c.SourceApplicatorID) for a in setups for c in a.ChannelSequence]
    assert ids == ["tandem", "right ovoid", "left ovoid"]
    assert [c.name for c in read_rtplan(PLAN).channels] == ids
    oncentra = data_dir() / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
    assert [c.name for c in read_rtplan(oncentra).channels] == ["R", "IU"]
