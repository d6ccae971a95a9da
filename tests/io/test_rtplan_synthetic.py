"""Must-show 3: synthetic RT Plans (written by pydicom in tests/io/conftest.py) -- no patient data.

Each case states its hand-derived expectation. Dwell time = ChannelTotalTime x (increase of
CumulativeTimeWeight over the dwell's control points) / FinalCumulativeTimeWeight.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.errors import RingQAError
from ringqa.io.rtplan import RTPlanError, dwell_times, guess_tg43_name, read_rtplan

# --------------------------------------------------------------------------- well-formed plans


def test_several_channels_paired_control_points(rtplan_factory):
    """Default plan: channel 1 times 10, 20, 30 s; channel 2 times 15, 5 s (weights = seconds)."""
    plan = read_rtplan(rtplan_factory())
    assert [c.number for c in plan.channels] == [1, 2]
    np.testing.assert_allclose(plan.channel(1).times_s, [10, 20, 30], rtol=1e-12)
    np.testing.assert_allclose(plan.channel(2).times_s, [15, 5], rtol=1e-12)
    np.testing.assert_allclose(plan.channel(1).relative_position_mm, [0, 5, 10])
    np.testing.assert_allclose(plan.channel(1).positions_mm[1], [8, 5, -100])
    assert plan.channel(1).step_mm == 2.5 and plan.channel(1).length_mm == 1500
    assert plan.source.sk_U == 40000 and plan.source.tg43_name == "mhdr-v2"
    assert [(p.name, p.tps_dose_gy) for p in plan.points] == [("A1", 7.0), ("A2", 7.1)]
    assert plan.library is None
    assert any("no Oncentra applicator library" in w for w in plan.warnings)


def test_weights_in_arbitrary_units_scale_to_channel_total_time(rtplan_factory):
    """Weights 0, 1, 1, 3 (x1/10 s) with ChannelTotalTime 30 s, final weight 3 -> 10 s, 20 s."""
    spec = {"number": 3, "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0)],
            "weight_scale": 0.1}  # fmt: skip
    plan = read_rtplan(rtplan_factory([spec]))
    np.testing.assert_allclose(plan.channel(3).times_s, [10, 20], rtol=1e-12)


def test_unpaired_zero_time_control_point_is_a_zero_time_position(rtplan_factory):
    """p0 (w 0 -> 10), p1 alone (w 10), p2 (w 10 -> 30), T = 30 s: times 10, 0, 20 s."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 0.0), (10, (0, 0, 10), 20.0)],
        "weights": [0.0, 10.0, 10.0, 10.0, 30.0],
        "rel": [0, 0, 5, 10, 10],
        "positions": [(0, 0, 0), (0, 0, 0), (0, 0, 5), (0, 0, 10), (0, 0, 10)],
        "final_weight": 30.0,
    }
    ch = read_rtplan(rtplan_factory([spec])).channel(1)
    np.testing.assert_allclose(ch.times_s, [10, 0, 20], rtol=1e-12)
    np.testing.assert_allclose(ch.relative_position_mm, [0, 5, 10])


def test_unpaired_weights_increasing_between_positions_are_refused(rtplan_factory):
    """One control point per position, weights 0, 10, 30: which position got the 10 s? Refused."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 0.0), (5, (0, 0, 5), 10.0), (10, (0, 0, 10), 20.0)],
        "weights": [0.0, 10.0, 30.0],
        "rel": [0, 5, 10],
        "positions": [(0, 0, 0), (0, 0, 5), (0, 0, 10)],
        "final_weight": 30.0,
    }
    with pytest.raises(RTPlanError, match=r"ambiguous.*paired control points"):
        read_rtplan(rtplan_factory([spec]))


def test_pdr_weights_are_not_seconds(rtplan_factory):
    """PDR: weights 0..0.6 (not s), T = 600 s per pulse, final 0.6 -> 100, 200, 300 s."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 100.0), (5, (0, 0, 5), 200.0), (10, (0, 0, 10), 300.0)],
        "weight_scale": 0.001,
    }

    def pulses(ds):
        ch = ds.ApplicationSetupSequence[0].ChannelSequence[0]
        ch.NumberOfPulses = 20
        ch.PulseRepetitionInterval = 3600

    plan = read_rtplan(rtplan_factory([spec], treatment_type="PDR", edit=pulses))
    ch = plan.channel(1)
    np.testing.assert_allclose(ch.times_s, [100, 200, 300], rtol=1e-12)
    assert ch.number_of_pulses == 20 and ch.pulse_interval_s == 3600
    assert plan.treatment_type == "PDR"
    assert any("per pulse" in w for w in plan.warnings)


@pytest.mark.parametrize(
    ("weights", "expected"),
    [
        # (0, t) pairs: weights decrease -> per-dwell; 10, 20, 30 of 60 s
        ([0, 10, 0, 20, 0, 30], [10, 20, 30]),
        # (t, t) pairs: non-decreasing but 30 - 10 != 60 -> per-dwell
        ([10, 10, 20, 20, 30, 30], [10, 20, 30]),
    ],
)
def test_per_dwell_weights_are_detected_and_read(rtplan_factory, weights, expected):
    """Per-dwell weights sum to FinalCumulativeTimeWeight 60 = T: times are the weights."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0), (10, (0, 0, 10), 30.0)],
        "weights": weights,
        "rel": [0, 0, 5, 5, 10, 10],
        "positions": [(0, 0, 0)] * 2 + [(0, 0, 5)] * 2 + [(0, 0, 10)] * 2,
        "final_weight": 60.0,
    }
    plan = read_rtplan(rtplan_factory([spec]))
    np.testing.assert_allclose(plan.channel(1).times_s, expected, rtol=1e-12)
    assert any("per-dwell" in w for w in plan.warnings)


def test_weights_continuing_from_the_previous_channel(rtplan_factory):
    """Channel 2's weights continue from channel 1 (60 -> 70 -> 80 of a plan-wide final 80) and
    its ChannelTotalTime is 20 s: its own increase 20 is shared out -> 10 s, 10 s."""
    ch1 = {"number": 1, "dwells": [(0, (0, 0, 0), 60.0)], "final_weight": 80.0}
    ch2 = {
        "number": 2,
        "dwells": [(0, (0, 0, 10), 10.0), (5, (0, 0, 15), 10.0)],
        "weights": [60.0, 70.0, 70.0, 80.0],
        "rel": [0, 0, 5, 5],
        "positions": [(0, 0, 10)] * 2 + [(0, 0, 15)] * 2,
        "final_weight": 80.0,
        "total_time_s": 20.0,
    }
    plan = read_rtplan(rtplan_factory([ch1, ch2]))
    np.testing.assert_allclose(plan.channel(2).times_s, [10, 10], rtol=1e-12)
    np.testing.assert_allclose(plan.channel(1).times_s, [60], rtol=1e-12)
    assert any("does not restart at 0" in w for w in plan.warnings)


def test_weights_that_do_not_chain_across_channels_are_refused(rtplan_factory):
    """Channel 1 covers 0..60 of 100 and channel 2 70..80: 60..70 and 80..100 are missing."""
    ch1 = {"number": 1, "dwells": [(0, (0, 0, 0), 60.0)], "final_weight": 100.0}
    ch2 = {
        "number": 2,
        "dwells": [(0, (0, 0, 10), 10.0)],
        "weights": [70.0, 80.0],
        "rel": [0, 0],
        "positions": [(0, 0, 10)] * 2,
        "final_weight": 100.0,
    }
    with pytest.raises(RTPlanError, match=r"channel 2: .* does not continue where the previous"):
        read_rtplan(rtplan_factory([ch1, ch2]))


def test_inconsistent_weights_are_refused_never_negative(rtplan_factory):
    """Weights 0, 10, 5, 8 with final 30: neither cumulative nor per-dwell (10 + 8 != 30)."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0)],
        "weights": [0, 10, 5, 8],
        "rel": [0, 0, 5, 5],
        "positions": [(0, 0, 0)] * 2 + [(0, 0, 5)] * 2,
        "final_weight": 30.0,
    }
    with pytest.raises(RTPlanError, match=r"neither cumulative .* nor per-dwell"):
        read_rtplan(rtplan_factory([spec]))


def test_missing_optional_tags(rtplan_factory):
    """No ChannelLength, step, reference date, manufacturer/model, final weight, TPS doses."""

    def strip(ds):
        for ch in ds.ApplicationSetupSequence[0].ChannelSequence:
            del ch.ChannelLength, ch.SourceApplicatorStepSize, ch.FinalCumulativeTimeWeight

    plan = read_rtplan(
        rtplan_factory(
            reference_date=None,
            source_manufacturer=None,
            source_model=None,
            points=[("P", (1, 2, 3), None)],
            edit=strip,
        )
    )
    ch = plan.channel(1)
    assert ch.length_mm is None and ch.step_mm is None
    np.testing.assert_allclose(ch.times_s, [10, 20, 30])  # final weight = last weight
    assert plan.source.reference_date is None and plan.source.tg43_name is None
    assert plan.points[0].tps_dose_gy is None and plan.points[0].dose_tag is None
    plan2 = read_rtplan(rtplan_factory(points=None, sk_U=None))
    assert plan2.points == () and plan2.source.sk_U is None
    assert any("ReferenceAirKermaRate" in w for w in plan2.warnings)


def test_orientation_tags_are_read_as_unit_vectors(rtplan_factory):
    """ControlPointOrientation (0, 0, 2) and (3, 4, 0) -> unit (0, 0, 1) and (0.6, 0.8, 0)."""
    spec = {
        "number": 1,
        "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0)],
        "orient": [(0, 0, 2), (3, 4, 0)],
    }
    ch = read_rtplan(rtplan_factory([spec], orientation=True)).channel(1)
    np.testing.assert_allclose(ch.directions, [[0, 0, 1], [0.6, 0.8, 0]], atol=1e-7)


def test_partial_orientation_is_ignored_with_a_notice(rtplan_factory):
    spec = {"number": 1, "dwells": [(0, (0, 0, 0), 10.0), (5, (0, 0, 5), 20.0)],
            "orient": [(0, 0, 1), (0, 0, 1)]}  # fmt: skip

    def drop(ds):
        cps = ds.ApplicationSetupSequence[0].ChannelSequence[0].BrachyControlPointSequence
        del cps[2].ControlPointOrientation, cps[3].ControlPointOrientation

    plan = read_rtplan(rtplan_factory([spec], orientation=True, edit=drop))
    assert plan.channel(1).directions is None
    assert any("ControlPointOrientation present for only some" in w for w in plan.warnings)


# --------------------------------------------------------------------------- broken files


def test_truncated_file(rtplan_factory, tmp_path):
    data = rtplan_factory().read_bytes()
    bad = tmp_path / "truncated.dcm"
    bad.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(RTPlanError, match="truncated or corrupt"):
        read_rtplan(bad)


def test_not_dicom(tmp_path):
    bad = tmp_path / "plan.dcm"
    bad.write_text("x_mm,y_mm,z_mm\n1,2,3\n")
    with pytest.raises(RTPlanError, match="not a DICOM file"):
        read_rtplan(bad)


def test_missing_file_or_folder(tmp_path):
    with pytest.raises(RTPlanError, match="file not found"):
        read_rtplan(tmp_path / "nope.dcm")
    with pytest.raises(RTPlanError, match="is a folder"):
        read_rtplan(tmp_path)


def test_repeated_channel_numbers(rtplan_factory):
    spec = {"number": 1, "dwells": [(0, (0, 0, 0), 1.0)]}
    with pytest.raises(RTPlanError, match=r"ChannelNumber repeats \(\[1, 1\]\)"):
        read_rtplan(rtplan_factory([spec, spec]))


def test_wrong_modality(rtplan_factory):
    path = rtplan_factory(modality="RTSTRUCT", sop_class="1.2.840.10008.5.1.4.1.1.481.3")
    with pytest.raises(RTPlanError, match=r"not an RT Plan \(Modality RTSTRUCT, RT Structure Set"):
        read_rtplan(path)


def test_external_beam_plan(rtplan_factory):
    def beams(ds):
        ds.BeamSequence = [__import__("pydicom").Dataset()]

    with pytest.raises(RTPlanError, match=r"not a brachytherapy plan.*external beam"):
        read_rtplan(rtplan_factory(brachy=False, edit=beams))


def test_no_channels(rtplan_factory):
    with pytest.raises(RTPlanError, match="no channels"):
        read_rtplan(rtplan_factory([]))


def test_nan_positions(rtplan_factory):
    spec = {"number": 4, "dwells": [(0, (0, 0, 0), 10.0), (5, (np.nan, 0, 5), 20.0)]}
    with pytest.raises(RTPlanError, match=r"channel 4, control point 2: ControlPoint3DPosition"):
        read_rtplan(rtplan_factory([spec]))


def test_nan_dose_point(rtplan_factory):
    with pytest.raises(RTPlanError, match="dose reference A1: DoseReferencePointCoordinates"):
        read_rtplan(rtplan_factory(points=[("A1", (np.nan, 0, 0), 7.0)]))


def test_missing_3d_positions(rtplan_factory):
    def strip(ds):
        for cp in ds.ApplicationSetupSequence[0].ChannelSequence[0].BrachyControlPointSequence:
            del cp.ControlPoint3DPosition

    with pytest.raises(RTPlanError, match="ControlPoint3DPosition is missing"):
        read_rtplan(rtplan_factory(edit=strip))


def test_broken_files_each_have_their_own_message(rtplan_factory, tmp_path):
    """The broken cases above give distinct one-line messages naming the file."""
    data = rtplan_factory().read_bytes()
    (tmp_path / "t.dcm").write_bytes(data[:300])
    (tmp_path / "x.dcm").write_text("hello")
    paths = [
        tmp_path / "t.dcm",
        tmp_path / "x.dcm",
        rtplan_factory(modality="RTDOSE", sop_class="1.2.840.10008.5.1.4.1.1.481.2"),
        rtplan_factory([]),
        rtplan_factory([{"number": 1, "dwells": [(0, (np.nan, 0, 0), 1.0)]}]),
    ]
    messages = []
    for p in paths:
        with pytest.raises(RingQAError) as info:
            read_rtplan(p)
        msg = str(info.value)
        assert str(p) in msg and "\n" not in msg
        messages.append(msg.split(": ", 1)[1])
    assert len(set(messages)) == len(messages)


# --------------------------------------------------------------------------- dwell_times itself


@given(
    times=st.lists(st.one_of(st.just(0.0), st.floats(0.01, 100.0)), min_size=1, max_size=12),
    scale=st.floats(1e-3, 1e3),
    per_dwell=st.booleans(),
)
def test_dwell_times_recover_the_times(times, scale, per_dwell):
    """Paired weights built from known times (cumulative, or per-dwell (0, t) pairs) give back
    t_i = T x w_i / W with T = sum(t): the original times, to 1e-9 relative; never negative."""
    t = np.array(times)
    total = float(t.sum())
    if total == 0:
        return
    w = []
    cum = 0.0
    for ti in t * scale:
        w += [0.0, ti] if per_dwell else [cum, cum + ti]
        cum += ti
    groups = [(2 * i, 2 * i + 2) for i in range(len(t))]
    got, mode = dwell_times(np.array(w), groups, total, cum)
    if not (per_dwell and len(t) > 1 and np.count_nonzero(t) > 1):
        assert mode in ("cumulative", "per-dwell")
    np.testing.assert_allclose(got, t, rtol=1e-9, atol=1e-9 * total)
    assert np.all(got >= 0)


@pytest.mark.parametrize(
    ("text", "isotope", "name"),
    [
        ("Nucletron microSelectron v3", "Ir-192", "mhdr-v2"),
        ("Elekta Flexitron", "Ir-192", "flexisource"),
        ("Varian VariSource iX", "Ir-192", "vs2000"),
        ("Varian GammaMed plus iX", "Ir-192", "gammamed-plus"),
        ("Eckert & Ziegler Co0.A86", "Co-60", None),
        ("unknown", "Ir-192", None),
    ],
)
def test_guess_tg43_name(text, isotope, name):
    assert guess_tg43_name(text, isotope) == name


def test_no_pydicom_exception_escapes_at_any_truncation(rtplan_factory, tmp_path):
    """Cut the file at 40 places: each read either fails with an RTPlanError or, when the cut
    falls on an element boundary that DICOM cannot detect, gives non-negative finite times."""
    data = rtplan_factory().read_bytes()
    bad = tmp_path / "cut.dcm"
    for k in range(1, 41):
        bad.write_bytes(data[: len(data) * k // 41])
        try:
            plan = read_rtplan(bad)
        except RTPlanError:
            continue
        for ch in plan.channels:
            assert np.all(np.isfinite(ch.times_s)) and np.all(ch.times_s >= 0)


def _names(plan) -> list[str]:
    from ringqa.errors import split_warning

    return [split_warning(w)[0] for w in plan.warnings]


def test_dose_reference_without_coordinates_is_named(rtplan_factory):
    """A COORDINATES dose reference whose coordinates were dropped: a plan.dose_point warning
    naming it (it used to vanish from the TPS check without a word); a VOLUME reference without
    coordinates stays silent (not a point)."""

    def drop(kind):
        def edit(ds):
            ds.DoseReferenceSequence[0].DoseReferenceStructureType = kind
            del ds.DoseReferenceSequence[0].DoseReferencePointCoordinates

        return edit

    plan = read_rtplan(rtplan_factory(edit=drop("COORDINATES")))
    assert "plan.dose_point" in _names(plan)
    first = next(w for w in plan.warnings if "plan.dose_point" in w)
    assert "left out of the plan-vs-TPS dose check" in first
    plan = read_rtplan(rtplan_factory(edit=drop("VOLUME")))
    assert "plan.dose_point" not in _names(plan)


def test_channel_naming_a_missing_source_is_warned(rtplan_factory):
    """ReferencedSourceNumber 7 while the SourceSequence has only source 0: plan.source_reference
    naming the channel, the number and the sources the plan has."""

    def edit(ds):
        for item in ds.ApplicationSetupSequence[0].ChannelSequence:
            item.ReferencedSourceNumber = 7

    plan = read_rtplan(rtplan_factory(edit=edit))
    warning = next(w for w in plan.warnings if w.startswith("[plan.source_reference]"))
    assert "ReferencedSourceNumber 7" in warning and "SourceSequence: 0" in warning


@pytest.mark.parametrize("kind", ["LDR", "MANUAL", "MDR"])
def test_a_plan_that_is_not_an_afterloaders_is_warned(rtplan_factory, kind):
    """LDR/MANUAL/MDR: plan.treatment_type naming the type; HDR (the factory's default) and PDR
    (its own per-pulse notice) do not get it."""
    plan = read_rtplan(rtplan_factory(treatment_type=kind))
    warning = next(w for w in plan.warnings if w.startswith("[plan.treatment_type]"))
    assert f"BrachyTreatmentType is {kind}" in warning
    for ok in ("HDR", "PDR"):
        assert "plan.treatment_type" not in _names(read_rtplan(rtplan_factory(treatment_type=ok)))


def test_polyline_distance_is_to_segments_not_vertices():
    """A point above the middle of a 10 mm segment at height 0.05 mm: 0.05 mm (its nearest
    vertex is 5.0002 mm away); beyond the end: the distance to the end vertex (3-4-5: 5 mm)."""
    from ringqa.io.rtplan import polyline_distance_mm

    line = np.array([[0.0, 0, 0], [10.0, 0, 0]])
    pts = np.array([[5.0, 0.05, 0], [13.0, 4.0, 0]])
    np.testing.assert_allclose(polyline_distance_mm(pts, line), [0.05, 5.0])


def test_library_of_another_plan_is_warned_above_a_tenth_of_a_millimetre(repo_root, tmp_path):
    """The example plan (dwells on the library's source path within 5e-7 mm: no warning) with
    ring channel 1's dwells moved 0.3 mm along z: plan.library_match naming the channel and a
    distance between 0.2 and 0.3 mm (0.3 mm less the part of the move along the tilted path;
    the old check stayed silent up to 2 mm)."""
    import re

    import pydicom

    example = repo_root / "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"
    assert "plan.library_match" not in _names(read_rtplan(example))
    ds = pydicom.dcmread(example)
    for setup in ds.ApplicationSetupSequence:
        for item in setup.ChannelSequence:
            if int(item.ChannelNumber) == 1:
                for cp in item.BrachyControlPointSequence:
                    x, y, z = (float(v) for v in cp.ControlPoint3DPosition)
                    cp.ControlPoint3DPosition = [x, y, z + 0.3]
    moved = tmp_path / "RP_moved.dcm"
    ds.save_as(moved)
    warning = next(w for w in read_rtplan(moved).warnings if "plan.library_match" in w)
    found = re.search(r"channel 1: dwells lie up to ([0-9.]+) mm", warning)
    assert found and 0.2 < float(found.group(1)) <= 0.3
