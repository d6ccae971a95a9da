"""CSV/JSON centreline and source-path files: round trips and every refusal (with its message)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.io.points import PointsFileError, read_point_set, read_points, write_points


def _helix_mm(n=40, r=13.0, pitch=2.0):
    t = np.linspace(0, 2 * np.pi, n)
    return np.column_stack([r * np.cos(t), r * np.sin(t), pitch * t])


def _csv(tmp_path, text, name="pts.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_csv_is_millimetres_in_metres_out(tmp_path):
    """1000 mm in the file is 1 m inside."""
    p = _csv(tmp_path, "x_mm,y_mm,z_mm\n0,0,0\n1000,0,0\n1000,1000,0\n1000,1000,1000\n")
    np.testing.assert_allclose(read_points(p)[-1], [1, 1, 1])


def test_columns_in_any_order_with_comments_and_extras(tmp_path):
    p = _csv(tmp_path, "# measured 2026\nlabel,z_mm,x_mm,y_mm\na,3,1,2\nb,6,4,5\n\nc,9,7,8\n")
    np.testing.assert_allclose(read_points(p, kind="path") * 1e3, [[1, 2, 3], [4, 5, 6], [7, 8, 9]])


@pytest.mark.parametrize("suffix", [".csv", ".json"])
def test_round_trip(tmp_path, suffix):
    """write_points then read_points gives the points back to 1 nm (6 decimals in mm)."""
    pts_m = _helix_mm() * 1e-3
    rel = np.arange(len(pts_m)) * 2.5
    p = write_points(tmp_path / f"cl{suffix}", pts_m, rel)
    ps = read_point_set(p, kind="path")
    np.testing.assert_allclose(ps.points_m, pts_m, atol=1e-9)
    np.testing.assert_allclose(ps.relative_position_mm, rel)


@given(st.lists(st.floats(-500, 500), min_size=3, max_size=3), st.floats(0.5, 5.0))
def test_round_trip_any_straight_line(tmp_path_factory, start, step):
    """Evenly spaced points on a line (step 0.5-5 mm) round-trip through CSV to 1 nm (read as a
    source path: 6 points over 2.5-25 mm are too short for a channel centreline)."""
    d = np.array([0.6, 0.0, 0.8])
    pts = (np.array(start) + np.outer(np.arange(6) * step, d)) * 1e-3
    p = write_points(tmp_path_factory.mktemp("rt") / "line.csv", pts)
    np.testing.assert_allclose(read_points(p, kind="path"), pts, atol=1e-9)


@pytest.mark.parametrize("sep", [";", "\t"])
def test_semicolon_or_tab_separated(tmp_path, sep):
    rows = ["x_mm", "y_mm", "z_mm"], ["0", "0", "0"], ["2.5", "0", "0"]
    p = _csv(tmp_path, "\n".join(sep.join(r) for r in rows) + "\n")
    np.testing.assert_allclose(read_points(p, kind="path")[1], [2.5e-3, 0, 0])


def test_decimal_comma_is_named(tmp_path):
    p = _csv(tmp_path, "x_mm;y_mm;z_mm\n0;0;0\n2,5;0;0\n")
    with pytest.raises(PointsFileError, match=r"line 3, column x_mm: '2,5' is not a number.*point"):
        read_points(p, kind="path")


def test_json_column_form(tmp_path):
    p = tmp_path / "c.json"
    p.write_text(json.dumps({"x_mm": [0, 10, 20], "y_mm": [0, 0, 0], "z_mm": [0, 1, 3]}))
    assert read_points(p, kind="path").shape == (3, 3)


# --------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("x_m,y_m,z_m\n0,0,0\n0.01,0,0\n0.02,0,0\n0.03,0,0\n", "in metres"),
        ("x_cm,y_cm,z_cm\n0,0,0\n1,0,0\n2,0,0\n3,0,0\n", "centimetres"),
        ("x,y,z\n0,0,0\n1,0,0\n2,0,0\n3,0,0\n", "no column.*x_mm"),
        ("x_mm,y_mm,z_mm\n0,0,0\n0.0001,0,0\n0.0002,0,0\n0.0003,0,0\n", "looks like metres"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n1,0,0\n3,0,0\n", "line 4 repeats the point of line 3"),
        ("x_mm,y_mm,z_mm\n0,0,0\n2,0,0\n1,0,0\n3,0,0\n", "turns back .* at line 3"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\nnan,0,0\n3,0,0\n", "line 4, column x_mm: value is nan"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,,0\n2,0,0\n3,0,0\n", "line 3, column y_mm: '' is not a number"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n2,0,0\n", "3 point.*at least 4"),
        ("", "empty file"),
    ],
)
def test_bad_centreline_csv(tmp_path, text, match):
    p = _csv(tmp_path, text)
    with pytest.raises(PointsFileError, match=match) as info:
        read_points(p, kind="centreline")
    assert str(p) in str(info.value)


def test_loop_through_itself_is_a_duplicate(tmp_path):
    """A square walked twice: point 5 repeats point 1 (non-consecutive duplicate)."""
    rows = ["0,0,0", "10,0,0", "10,10,0", "0,10,0", "0,0,0.0000001", "10,0,1"]
    p = _csv(tmp_path, "x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n")
    with pytest.raises(PointsFileError, match="line 6 repeats the point of line 2"):
        read_points(p)


def test_path_relative_positions_must_increase(tmp_path):
    p = _csv(tmp_path, "x_mm,y_mm,z_mm,relative_position_mm\n0,0,0,5\n2.5,0,0,2.5\n5,0,0,0\n")
    with pytest.raises(PointsFileError, match="most distal first"):
        read_points(p, kind="path")


@pytest.mark.parametrize(
    ("doc", "match"),
    [
        ({"units": "m", "points": [[0, 0, 0], [0.01, 0, 0]]}, "units.*'m'.*multiply by 1000"),
        ({"points": [[0, 0, 0], [10, 0, 0]]}, 'no "units" key'),
        ({"units": "mm", "points": [[0, 0], [10, 0, 0]]}, r"points\[0\]"),
        ({"units": "mm", "points": [[0, 0, 0], [10, "a", 0]]}, r"points\[1\]\[1\]"),
        ({"x_m": [0, 1], "y_m": [0, 0], "z_m": [0, 0]}, "metres"),
        ({"foo": 1}, "no points found"),
        ([1, 2, 3], "not an object"),
    ],
)
def test_bad_json(tmp_path, doc, match):
    p = tmp_path / "p.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(PointsFileError, match=match):
        read_points(p, kind="path")


def test_bad_json_syntax_and_type_and_missing(tmp_path):
    p = tmp_path / "p.json"
    p.write_text("{not json")
    with pytest.raises(PointsFileError, match="not valid JSON"):
        read_points(p)
    with pytest.raises(PointsFileError, match="unknown file type"):
        read_points(_csv(tmp_path, "x", name="p.txt"))
    with pytest.raises(PointsFileError, match="file not found"):
        read_points(tmp_path / "missing.csv")


# --------------------------------------------------------------------------------------------
# plausibility (issue 18): encodings, units. Inputs are built from the shipped ring26x60.


def _ring_centreline_m():
    from ringqa.io.applicator_file import load_applicator

    return load_applicator("ring26x60").channel("ring").centreline.points_m


@pytest.mark.parametrize(
    ("encode", "encoding", "noted"),
    [
        (lambda t: t.encode("utf-8"), "UTF-8", False),
        (lambda t: b"\xef\xbb\xbf" + t.encode("utf-8"), "UTF-8 with BOM", False),
        (lambda t: t.encode("utf-16"), "UTF-16", True),
        (lambda t: t.encode("latin-1"), "Latin-1", True),
    ],
)
def test_csv_encodings_are_read_and_recorded(tmp_path, encode, encoding, noted):
    """A German Excel's Latin-1 comment (and a BOM, and UTF-16 'Unicode text') is read; the
    encoding is recorded and anything but UTF-8 gives a note naming the file."""
    pts = _ring_centreline_m()
    plain = write_points(tmp_path / "plain.csv", pts).read_text()
    p = tmp_path / "excel.csv"
    p.write_bytes(encode("# Länge gemessen, Ø 26 mm\n" + plain))
    ps = read_point_set(p)
    np.testing.assert_allclose(ps.points_m, pts, atol=1e-9)
    assert ps.encoding == encoding
    if noted:
        assert len(ps.notes) == 1 and "excel.csv" in ps.notes[0] and encoding in ps.notes[0]
        assert "save the file as UTF-8" in ps.notes[0]
    else:
        assert ps.notes == ()


@pytest.mark.parametrize(
    ("scale", "offset", "words"),
    [
        (0.1, 0.0, ("centimetres", "multiply by 10", "long")),
        (1000.0, 0.0, ("micrometres", "divide by 1000")),
        (1.0, 2.0e6, ("e+06 mm", "no applicator lies", "offset")),
    ],
)
def test_centreline_in_another_unit_is_refused(tmp_path, scale, offset, words):
    """The shipped ring's centreline in cm (28 mm long), um, or with a 2 km offset."""
    p = write_points(tmp_path / "centreline.csv", _ring_centreline_m() * scale + offset * 1e-3)
    with pytest.raises(PointsFileError) as info:
        read_points(p)
    msg = str(info.value)
    for w in ("centreline.csv", *words):
        assert w in msg, (w, msg)


def test_long_centreline_is_refused(tmp_path):
    """6 m of channel (the ring x 40 about its first point): not an applicator."""
    pts = _ring_centreline_m()
    p = write_points(tmp_path / "cl.csv", (pts - pts[0]) * 40.0)
    with pytest.raises(
        PointsFileError, match=r"cl\.csv: the centreline is .* mm long .*another unit"
    ):
        read_points(p)


# --------------------------------------------------------------------------- sparse measured paths


def _ring_rows(rel_mm, radius=13.0, sd=None):
    """Points on a circle of ``radius`` mm at arc lengths ``rel_mm`` (a ring's source path)."""
    rows = []
    for k, r in enumerate(rel_mm):
        phi = r / radius
        row = f"{radius * np.cos(phi):.6f},{radius * np.sin(phi):.6f},0,{r}"
        rows.append(row + (f",{sd[k]}" if sd is not None else ""))
    return rows


def test_sparse_path_with_uncertainty_and_method(tmp_path):
    """Film positions 0, 5, 10, 25, 30, 50, 60 mm on a 13 mm ring: 15-20 mm gaps turn by
    66-88 degrees between chords (not checked beyond 10 mm gaps); each row's sd_mm and the
    method comment are read."""
    rel = [0, 5, 10, 25, 30, 50, 60]
    sd = [0.5, 0.5, 0.6, 0.7, 0.5, 1.0, 0.8]
    text = "# method = film\nx_mm,y_mm,z_mm,relative_position_mm,sd_mm\n"
    p = _csv(tmp_path, text + "\n".join(_ring_rows(rel, sd=sd)) + "\n")
    ps = read_point_set(p, kind="path")
    np.testing.assert_allclose(ps.relative_position_mm, rel)
    np.testing.assert_allclose(ps.sd_mm, sd)
    assert ps.method == "film" and ps.outliers == ()


def test_one_uncertainty_for_all_points_json(tmp_path):
    p = tmp_path / "m.json"
    doc = {"units": "mm", "points": [[0, 0, 0], [5, 0, 0], [10, 0, 1]], "measured_sd_mm": 0.4,
           "method": "CT", "relative_position_mm": [0, 5, 10]}  # fmt: skip
    p.write_text(json.dumps(doc))
    ps = read_point_set(p, kind="path")
    np.testing.assert_allclose(ps.sd_mm, 0.4)
    assert ps.method == "ct"


@pytest.mark.parametrize(
    ("head", "tail", "match"),
    [
        ("# method = xray\n", "", "method 'xray' is not known.*film, ct, panel, vendor"),
        ("# measured_sd_mm = -1\n", "", "measured_sd_mm is -1"),
        ("", ",0", r"line 2, sd_mm: 0 is not an uncertainty"),
    ],
)
def test_bad_uncertainty_or_method_is_named(tmp_path, head, tail, match):
    header = "x_mm,y_mm,z_mm,relative_position_mm" + (",sd_mm" if tail else "")
    rows = [f"{x},0,0,{x}" + (tail if tail else "") for x in (0, 5, 10)]
    p = _csv(tmp_path, head + header + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(PointsFileError, match=match):
        read_point_set(p, kind="path")


def test_single_outlier_is_flagged_not_refused(tmp_path):
    """Issue 25: a path every 2.5 mm along x with line 5 moved 4 mm sideways: the path turns
    by 2 x atan(4/2.5) = 116 degrees there (> 100), but the point lies between its neighbours
    and the path without it is straight: kept, named in the notes and in ``outliers``."""
    rows = [f"{2.5 * k},{4.0 if k == 3 else 0.0},0" for k in range(8)]
    p = _csv(tmp_path, "x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n")
    ps = read_point_set(p, kind="path")
    assert ps.outliers == (3,)
    assert any("line 5 lies off the path" in n for n in ps.notes)


def test_swapped_rows_still_refused(tmp_path):
    """Rows 3 and 4 swapped along the path: not a sideways jump, so still 'not in order'."""
    rows = ["0,0,0", "2.5,0,0", "7.5,0,0", "5,0,0", "10,0,0", "12.5,0,0"]
    p = _csv(tmp_path, "x_mm,y_mm,z_mm\n" + "\n".join(rows) + "\n")
    with pytest.raises(PointsFileError, match="not in order"):
        read_point_set(p, kind="path")
