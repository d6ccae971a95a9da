"""Centreline correction files (ringqa.io.correction): reading, and every refusal with its line.

The applicator is the parametric 26/60 ring: its ring channel's circle (radius 13 mm in z = 0,
azimuth 1.5 deg + (s - 88 mm) / 13 mm) starts at s = 88.0 mm (60 mm stem + 28 mm transition), so a
correction over s = 93..113 mm is on the proximal ring.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.errors import RingQAError
from ringqa.geometry import GeometryError, ring_applicator
from ringqa.io.correction import (
    CentrelineCorrection,
    apply_centreline_correction,
    read_correction_segment,
)
from ringqa.io.points import PointsFileError, write_points
from ringqa.provenance import sha256_of

S0_MM = 88.0


@pytest.fixture(scope="module")
def app():
    return ring_applicator(26, 60)


def ring_points_mm(radius_mm=13.0, start=93.0, stop=113.0, step=1.0):
    """Points (mm) of the ring's circle at library arc lengths start..stop, at ``radius_mm``."""
    s = np.arange(start, stop + step / 2, step)
    phi = np.deg2rad(1.5) + (s - S0_MM) / 13.0
    return np.column_stack([radius_mm * np.cos(phi), radius_mm * np.sin(phi), 0 * phi])


def write_csv(path, pts_mm, comment=True, extra_header=""):
    """A correction CSV; with ``comment`` the header is on line 2 and point i on line i + 3."""
    rows = ["# proximal ring, CT 2026-03-01"] if comment else []
    rows.append("x_mm,y_mm,z_mm" + extra_header)
    rows += [
        ",".join(f"{v:.6f}" for v in p) + (f",{2.5 * i}" if extra_header else "")
        for i, p in enumerate(pts_mm)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


# --------------------------------------------------------------------------------------------
# reading


def test_reads_millimetres_into_metres(tmp_path):
    """13 mm in the file is 0.013 m; rows kept in order (proximal first)."""
    pts = ring_points_mm()
    got = read_correction_segment(write_csv(tmp_path / "corr.csv", pts))
    assert got.shape == (21, 3)
    np.testing.assert_allclose(got, pts * 1e-3, atol=1e-9)


def test_json_points_are_read_too(tmp_path):
    """The same reader as centrelines: write_points' JSON round-trips to 1 nm."""
    pts_m = ring_points_mm() * 1e-3
    got = read_correction_segment(write_points(tmp_path / "corr.json", pts_m))
    np.testing.assert_allclose(got, pts_m, atol=1e-9)


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        (
            "x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n2,0,0\n",
            r"3 point\(s\); a correction segment needs at least 4",
        ),
        ("x_m,y_m,z_m\n0,0,0\n", r"columns are in metres.*multiply by 1000"),
        ("x_mm,y_mm,z_mm\n0,0,0\n0.001,0,0\n0.002,0,0\n0.003,0,0\n", r"looks like metres"),
        (
            "x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n2,0,0\n1,0,0\n3,0,0\n",
            r"turns back by 180 degrees at line 4.*proximal entry -> distal tip",
        ),
        (
            "x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n1,0,0\n2,0,0\n3,0,0\n",
            r"line 4 repeats the point of line 3",
        ),
        (
            "x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n2,abc,0\n3,0,0\n",
            r"line 4, column y_mm: 'abc' is not a number",
        ),
        ("x,y,z\n0,0,0\n", r"no column\(s\) x_mm, y_mm, z_mm"),
    ],
    ids=["too-few", "metre-columns", "metre-values", "unordered", "duplicate", "text", "header"],
)
def test_reader_refusals_name_file_line_and_fix(tmp_path, text, pattern):
    """The point reader's checks, with "correction segment" in the count message and the
    proximal -> distal order in the sorting hint."""
    p = tmp_path / "corr.csv"
    p.write_text(text)
    with pytest.raises(PointsFileError, match=pattern) as err:
        read_correction_segment(p)
    assert str(err.value).startswith(str(p))


def test_refuses_a_measured_path_file(tmp_path):
    """A relative_position_mm column means a measured source path (most distal first)."""
    p = write_csv(tmp_path / "path.csv", ring_points_mm(), extra_header=",relative_position_mm")
    with pytest.raises(PointsFileError, match=r"relative_position_mm column.*measured source path"):
        read_correction_segment(p)


def test_missing_file(tmp_path):
    with pytest.raises(PointsFileError, match="file not found"):
        read_correction_segment(tmp_path / "nope.csv")


# --------------------------------------------------------------------------------------------
# applying


def test_applies_a_correction(tmp_path, app):
    """The proximal ring 0.5 mm outward: the ring channel is replaced (gaps 0.5 mm, largest
    shift 0.5 mm), the tandem is untouched, and the file and its checksum are recorded."""
    p = write_csv(tmp_path / "corr.csv", ring_points_mm(radius_mm=13.5))
    corr = apply_centreline_correction(app, p)
    assert isinstance(corr, CentrelineCorrection)
    assert corr.channel == "ring" and corr.path == str(p) and corr.sha256 == sha256_of(p)
    sp = corr.splice
    assert sp.gap_start_m == pytest.approx(0.5e-3, abs=1e-9)
    assert sp.max_shift_m == pytest.approx(0.5e-3, abs=5e-6)
    assert sp.old_start_m == pytest.approx(93.0e-3, abs=1e-8)
    assert corr.applicator.channel("ring").centreline is sp.centreline
    assert corr.applicator.channel("tandem") is app.channel("tandem")


def test_segment_off_the_centreline_is_one_line_naming_the_file_and_line(tmp_path, app):
    """Moved 3.2 mm outward: both ends 3.2 mm from the library centreline. The message is one
    line: the file, the channel, 'does not meet the centreline', the first point's file line
    (line 3: a comment and the header come first), the distance and the fix."""
    p = write_csv(tmp_path / "corr.csv", ring_points_mm(radius_mm=16.2))
    with pytest.raises(PointsFileError) as err:
        apply_centreline_correction(app, p)
    msg = str(err.value)
    assert isinstance(err.value, RingQAError)
    assert "\n" not in msg
    assert msg.startswith(f"{p}: channel 'ring': the correction segment does not meet the ")
    assert "its first point (line 3) is 3.2 mm away" in msg
    assert "its last point (line 23) is 3.2 mm away" in msg
    assert "give a segment whose first and last points lie on the library centreline" in msg
    assert "(within 1.0 mm)" in msg


def test_wrong_frame_says_how_far(tmp_path, app):
    """A segment in another frame (shifted 100 mm in z) is refused with the distance."""
    pts = ring_points_mm() + np.array([0.0, 0.0, 100.0])
    with pytest.raises(PointsFileError, match=r"first point \(line 3\) is 100\.0 mm away"):
        apply_centreline_correction(app, write_csv(tmp_path / "corr.csv", pts))


def test_reversed_rows_name_the_lines(tmp_path, app):
    p = write_csv(tmp_path / "corr.csv", ring_points_mm()[::-1], comment=False)
    pattern = r"first point \(line 2\).*its last \(line 22\).*reverse their order"
    with pytest.raises(PointsFileError, match=r"runs from distal to proximal: its " + pattern):
        apply_centreline_correction(app, p)


def test_unknown_channel_and_bad_settings(tmp_path, app):
    p = write_csv(tmp_path / "corr.csv", ring_points_mm())
    with pytest.raises(GeometryError, match="no channel 'ovoid'"):
        apply_centreline_correction(app, p, channel="ovoid")
    with pytest.raises(GeometryError, match="blend_m: must be a positive length"):
        apply_centreline_correction(app, p, blend_m=-1.0)


# --------------------------------------------------------------------------------------------
# the Oncentra plan (patient coordinates)


@pytest.mark.shared
def test_oncentra_plan_ring_corrected_in_patient_coordinates(oncentra_plan_path, tmp_path):
    """The plan's ring (library centreline in DICOM patient coordinates, a 13.00 mm circle from
    ~60 mm before the tip) moved 0.5 mm outward in its ring plane from 50 to 30 mm before the tip,
    points every 0.5 mm written in mm. As on the parametric ring (same radius, same gap, see
    tests/geometry/test_splice.py): blends 7.0 mm, gaps 0.5 mm, largest shift 0.5 mm (10 um:
    the library is a circle only to ~0.01 mm), length +1.0795 mm (5 um), the normal stays in the
    ring plane (< 1 deg); s_ref (library marker, distal of the change) keeps its point (< 1 um,
    the file's 1e-6 mm rounding included); the same file spliced with the points exactly ON the
    library (no displacement) moves nothing by more than 1 um."""
    from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

    app = applicator_from_rtplan(read_rtplan(oncentra_plan_path))
    ring = app.channel("ring")
    cl = ring.centreline
    s = np.arange(cl.length_m - 50e-3, cl.length_m - 30e-3 + 1e-9, 0.5e-3)
    p = cl.position(s)
    c, n = app.ring_centre_m, app.ring_normal
    radial = p - c - ((p - c) @ n)[:, None] * n
    radial /= np.linalg.norm(radial, axis=1)[:, None]

    same = apply_centreline_correction(app, write_points(tmp_path / "same.csv", p)).splice
    assert same.max_shift_m < 1e-6 and abs(same.length_change_m) < 1e-6

    corr = apply_centreline_correction(app, write_points(tmp_path / "out.csv", p + 0.5e-3 * radial))
    sp = corr.splice
    assert sp.blend_start_m == pytest.approx(7e-3) and sp.blend_end_m == pytest.approx(7e-3)
    assert sp.gap_start_m == pytest.approx(0.5e-3, abs=1e-6)
    assert sp.gap_end_m == pytest.approx(0.5e-3, abs=1e-6)
    assert sp.max_shift_m == pytest.approx(0.5e-3, abs=10e-6)
    assert sp.length_change_m == pytest.approx(1.0795e-3, abs=5e-6)
    assert sp.max_normal_turn_deg < 1.0
    new = corr.applicator.channel("ring")
    moved = np.linalg.norm(new.centreline.position(new.s_ref_m) - cl.position(ring.s_ref_m))
    assert moved < 1e-6
