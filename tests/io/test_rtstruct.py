"""Channels from an RT Structure Set: synthetic tandem-and-ovoid RT Plan + RT Struct pairs
written with pydicom (no patient data).

Geometry (mm, DICOM LPS): the tandem runs straight up +z from (0, 0, -100) to (0, 0, 0), then
bends 30 deg towards +y on a 40 mm radius; each ovoid runs up +z at x = +-15 from z = -120 to
z = -30 and bends 45 deg outwards (towards +-x) on a 15 mm radius. Contours are sampled every
~1 mm (a chord's sagitta on the 15 mm bend is 1/(8*15) = 0.008 mm). Dwells: 5 on the tandem's
distal 20 mm, 3 on each ovoid's distal 10 mm, 5 mm apart, ON the arcs.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydicom.dataset import Dataset, FileDataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid

from ringqa.errors import RingQAError
from ringqa.io.rtplan import read_rtplan
from ringqa.io.rtstruct import (
    RT_STRUCT,
    applicator_from_structures,
    match_channels,
    read_rtstruct,
)


def _path(start, direction, straight_mm, bend_towards, radius_mm, bend_deg):
    """Points every ~1 mm: a straight part then a circular bend; also the arc-length function."""
    p0, t = np.asarray(start, float), np.asarray(direction, float)
    n = np.asarray(bend_towards, float)
    pts = [p0 + t * s for s in np.arange(0.0, straight_mm + 1e-9, 1.0)]
    a = p0 + t * straight_mm
    centre = a + radius_mm * n
    arc = radius_mm * np.radians(bend_deg)

    def at(s):  # arc length from the start
        if s <= straight_mm:
            return p0 + t * s
        phi = (s - straight_mm) / radius_mm
        return centre - radius_mm * np.cos(phi) * n + radius_mm * np.sin(phi) * t

    k = int(np.ceil(arc))
    pts += [at(straight_mm + arc * i / k) for i in range(1, k + 1)]
    return np.array(pts), at, straight_mm + arc


TANDEM = _path((0, 0, -100), (0, 0, 1), 100.0, (0, 1, 0), 40.0, 30.0)
LEFT = _path((15, 0, -120), (0, 0, 1), 90.0, (1, 0, 0), 15.0, 45.0)
RIGHT = _path((-15, 0, -120), (0, 0, 1), 90.0, (-1, 0, 0), 15.0, 45.0)


def _dwells(path, n, tip_gap_mm=2.0):
    _, at, length = path
    return [(5.0 * k, tuple(at(length - tip_gap_mm - 5.0 * k)), 10.0) for k in range(n)]


CHANNELS = (
    {"number": 1, "dwells": _dwells(TANDEM, 5)},
    {"number": 2, "dwells": _dwells(LEFT, 3)},
    {"number": 3, "dwells": _dwells(RIGHT, 3)},
)


def write_rtstruct(path, rois, uid=None):
    """An RT Structure Set with one open contour per (name, points) in ``rois``."""
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = RT_STRUCT
    meta.MediaStorageSOPInstanceUID = uid or generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = FileDataset(str(path), {}, file_meta=meta, preamble=b"\0" * 128)
    ds.SOPClassUID = RT_STRUCT
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "RTSTRUCT"
    ds.PatientName = "SYNTHETIC^TO"
    ds.StructureSetROISequence, ds.ROIContourSequence = [], []
    for k, (name, pts) in enumerate(rois, start=1):
        roi = Dataset()
        roi.ROINumber, roi.ROIName = k, name
        ds.StructureSetROISequence.append(roi)
        c = Dataset()
        c.ContourGeometricType = "OPEN_NONPLANAR"
        c.NumberOfContourPoints = len(pts)
        c.ContourData = [float(v) for v in np.asarray(pts).ravel()]
        rc = Dataset()
        rc.ReferencedROINumber = k
        rc.ContourSequence = [c]
        ds.ROIContourSequence.append(rc)
    ds.save_as(path, enforce_file_format=True)
    return path


ROIS = (("Tandem", TANDEM[0]), ("Ovoid L", LEFT[0][::-1]), ("Ovoid R", RIGHT[0]))


@pytest.fixture
def pair(tmp_path, rtplan_factory):
    """(plan path, structure set path): the plan references the structure set."""
    uid = generate_uid()
    rs = write_rtstruct(tmp_path / "RS.dcm", ROIS, uid)

    def ref(ds):
        r = Dataset()
        r.ReferencedSOPClassUID = RT_STRUCT
        r.ReferencedSOPInstanceUID = uid
        ds.ReferencedStructureSetSequence = [r]

    return rtplan_factory(CHANNELS, edit=ref), rs


def test_channels_match_their_contours(pair):
    """Each channel matches its ROI; the dwells lie on the arcs, so their largest distance from
    the 1 mm polyline is the chord sagitta, < 0.01 mm. The ovoid L contour is stored tip first:
    it is reversed (its dwells lie near the distal end). s_ref = the most distal dwell's arc
    length = length - 2 mm (to the polyline's 0.01 mm)."""
    plan, rs = pair
    built = applicator_from_structures(read_rtplan(plan), read_rtstruct(rs), lumen_mm=2.0)
    got = {m.channel: m.roi_name for m in built.matches}
    assert got == {1: "Tandem", 2: "Ovoid L", 3: "Ovoid R"}
    assert max(m.max_distance_mm for m in built.matches) < 0.01
    app = built.applicator
    assert [(c.name, c.family, c.label) for c in app.channels] == [
        ("Tandem", "tandem", "1"),
        ("Ovoid L", "ovoid", "2"),
        ("Ovoid R", "ovoid", "3"),
    ]
    left = app.channel("Ovoid L")
    assert left.length_m - left.s_ref_m == pytest.approx(0.002, abs=2e-5)
    assert np.allclose(left.centreline.position(left.length_m) * 1e3, LEFT[0][-1], atol=1e-6)
    assert any("Channel 2 = ROI 'Ovoid L'" in n and "lumen 2 mm (given" in n for n in built.notes)
    # the frame: tandem axis = the mean direction of its distal 60 mm; lateral = towards +x
    assert app.ring_lateral[0] > 0.99


def test_a_structure_set_the_plan_does_not_reference_is_refused(tmp_path, rtplan_factory):
    """The error names both UIDs."""
    rs = write_rtstruct(tmp_path / "RS.dcm", ROIS)

    def ref(ds):
        r = Dataset()
        r.ReferencedSOPClassUID = RT_STRUCT
        r.ReferencedSOPInstanceUID = "1.2.3.4"
        ds.ReferencedStructureSetSequence = [r]

    plan = rtplan_factory(CHANNELS, edit=ref)
    s = read_rtstruct(rs)
    with pytest.raises(RingQAError, match=rf"{s.sop_instance_uid}.*1\.2\.3\.4"):
        applicator_from_structures(read_rtplan(plan), s, lumen_mm=2.0)


def test_missing_and_ambiguous_matches_name_channel_and_rois(tmp_path, rtplan_factory):
    """A channel 5 mm off every contour: no match, the ROIs listed with their distances; a
    duplicated tandem ROI: ambiguous, both named."""
    off = [(r, (x + 5.0, y, z), t) for r, (x, y, z), t in CHANNELS[0]["dwells"]]
    plan = read_rtplan(rtplan_factory(({"number": 1, "dwells": off},)))
    s = read_rtstruct(write_rtstruct(tmp_path / "RS1.dcm", ROIS))
    with pytest.raises(RingQAError, match=r"channel 1 .*'Tandem' \(5\.0 mm\)"):
        match_channels(plan, s)
    s2 = read_rtstruct(write_rtstruct(tmp_path / "RS2.dcm", (*ROIS, ("Tandem copy", TANDEM[0]))))
    plan2 = read_rtplan(rtplan_factory(CHANNELS))
    with pytest.raises(RingQAError, match=r"channel 1 .*several.*'Tandem'.*'Tandem copy'"):
        match_channels(plan2, s2)


def test_no_published_lumen_asks_for_lumen_mm(pair):
    plan, rs = pair
    with pytest.raises(RingQAError, match="--lumen-mm"):
        applicator_from_structures(read_rtplan(plan), read_rtstruct(rs))


def test_a_too_short_contour_is_refused(tmp_path, rtplan_factory):
    """Three points cannot make a channel."""
    d = CHANNELS[0]["dwells"][:1]
    plan = read_rtplan(rtplan_factory(({"number": 1, "dwells": d},)))
    pts = np.array([d[0][1], np.add(d[0][1], (0, 0, -5)), np.add(d[0][1], (0, 0, -10))])
    s = read_rtstruct(write_rtstruct(tmp_path / "RS.dcm", (("Tandem", pts[::-1]),)))
    with pytest.raises(RingQAError, match="3 points"):
        applicator_from_structures(plan, s, lumen_mm=2.0)


def test_every_channel_commissioned(pair):
    """commission_channels: three runs (the stand-in engine puts the source 0.2 mm off the
    centreline: max distance 0.2 mm each), channel labels 1, 2, 3; the dose points are Point A
    left/right, the two ovoid surface and 5 mm points and the plan's own A1/A2."""
    from ringqa.pipeline import CommissionSettings
    from ringqa.pipeline.commission import commission_channels
    from tests.pipeline.fakes import centreline_simulator, stand_in_engine

    plan, rs = pair
    cfg = CommissionSettings(structures=rs, lumen_mm=2.0, require_measured=False)
    runs = commission_channels(plan, cfg, engine=stand_in_engine(centreline_simulator(0.2e-3)))
    assert [r.channel for r in runs.results] == ["1", "2", "3"]
    assert runs.not_simulated == ()
    for r in runs.results:
        assert r.summary.as_row()["max_dist_sim_mm"] == pytest.approx(0.2, abs=1e-3)
    points = set(runs.results[0].doses["point"])
    assert {
        "point_a_left",
        "point_a_right",
        "ovoid_surface_left",
        "ovoid_depth5_left",
        "ovoid_surface_right",
        "ovoid_depth5_right",
        "A1",
        "A2",
    } <= points


def test_import_with_structures_writes_each_channel(pair, tmp_path):
    """ringqa import --structures: centreline_ch1..3.csv (proximal -> distal: the ovoid L contour,
    stored tip first, comes out reversed) and structures.json with each match."""
    import json

    from ringqa.cli import main

    plan, rs = pair
    out = tmp_path / "imp"
    assert main(["import", str(plan), "--structures", str(rs), "--out", str(out)]) == 0
    data = json.loads((out / "structures.json").read_text())
    assert [(m["channel"], m["roi"]) for m in data["matches"]] == [
        (1, "Tandem"),
        (2, "Ovoid L"),
        (3, "Ovoid R"),
    ]
    rows = (out / "centreline_ch2.csv").read_text().splitlines()
    last = np.array([float(v) for v in rows[-1].split(",")])
    assert np.allclose(last, LEFT[0][-1], atol=1e-3)


@pytest.mark.slow
def test_commission_every_channel_end_to_end(pair, tmp_path):
    """ringqa commission RP --structures RS --lumen-mm 2: the real engine on the three channels
    (the ovoids' 45 deg, 15 mm bends: no refusal, no stabilised step); one report.pdf (front
    page with the one conclusion, a section per channel, no ring words) and results.json with a
    section per channel; the combined CSVs with the channel column; --channel 2 --channel 3
    restricts it to the ovoids."""
    import json

    import pandas as pd

    from ringqa.cli import main
    from tests.report.conftest import pdf_pages_text

    plan, rs = pair
    out = tmp_path / "all"
    args = ["commission", str(plan), "--structures", str(rs), "--lumen-mm", "2",
            "--centreline-reference", "--quiet"]  # fmt: skip
    assert main([*args, "--out", str(out)]) == 0
    record = json.loads((out / "results.json").read_text())
    assert record["schema"] == "ringqa.commission-channels/2"
    assert [c["channel"] for c in record["channels"]] == ["1", "2", "3"]
    assert [c["family"] for c in record["channels"]] == ["tandem", "ovoid", "ovoid"]
    assert record["not_simulated"] == []
    assert record["conclusion"].startswith("3 channels commissioned")
    for c in record["channels"]:
        res = c["results"]  # the channel's whole results.json, also in its folder
        assert res == json.loads((out / c["folder"] / "results.json").read_text())
        assert "report.pdf" not in res["files"] and "report.html" in res["files"]  # as written
        assert {f for f in res["files"]} <= {p.name for p in (out / c["folder"]).iterdir()}
        assert res["simulation"]["status"] == 0
        assert res["simulation"]["settings"]["n_stabilised_steps"] == 0
        assert res["numerical_check"]["max_numerical_error_mm"] < 0.1
        assert c["max_numerical_error_mm"] == res["numerical_check"]["max_numerical_error_mm"]
    assert set(pd.read_csv(out / "summary.csv")["channel"].astype(str)) == {"1", "2", "3"}
    # ONE report: a front page with the conclusion and every channel's verdicts, then a section
    # per channel headed with its number and family; no ring words on these channels' pages
    pages = pdf_pages_text(out / "report.pdf")
    assert record["conclusion"] in " ".join(pages[0].split())
    heads = [p.splitlines()[0] for p in pages if p.startswith("Channel ")]
    assert heads == ["Channel 1 (Tandem): tandem channel (tandem)",
                     "Channel 2 (Ovoid L): ovoid channel (ovoid)",
                     "Channel 3 (Ovoid R): ovoid channel (ovoid)"]  # fmt: skip
    text = " ".join(pages).lower()
    assert "ring plane" not in text and "ring surface" not in text and "ring axis" not in text
    assert not list(out.glob("channel-*/report.pdf"))
    out2 = tmp_path / "ovoids"
    assert main([*args, "--no-pdf", "--channel", "2", "--channel", "3", "--out", str(out2)]) == 0
    assert set(pd.read_csv(out2 / "dwells.csv")["channel"].astype(str)) == {"2", "3"}
