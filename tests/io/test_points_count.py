"""Point files with more points than a centreline or path may have (issue 25: dense inputs)."""

from __future__ import annotations

import json

import pytest

from ringqa.geometry.centreline import MAX_POINTS
from ringqa.io.points import PointsFileError, read_point_set


@pytest.mark.parametrize("kind", ["centreline", "path"])
def test_a_csv_with_too_many_rows_is_refused_before_parsing(tmp_path, kind):
    """MAX_POINTS + 1 data rows (a comment and the header do not count) are refused naming the
    file, the count, the limit and the fix; the rows are never parsed (the values are all the
    same point, which the parser would refuse as duplicates instead)."""
    n = MAX_POINTS + 1
    p = tmp_path / "dense.csv"
    p.write_text("# dense\nx_mm,y_mm,z_mm\n" + "1.0,2.0,3.0\n" * n)
    with pytest.raises(PointsFileError) as err:
        read_point_set(p, kind=kind)
    msg = str(err.value)
    assert "dense.csv" in msg and f"{n:,} points" in msg and "resample" in msg


def test_old_mac_line_ends_are_counted_too(tmp_path):
    """A CSV with CR-only line ends (splitlines reads them as lines) is counted as well."""
    p = tmp_path / "cr.csv"
    p.write_text("x_mm,y_mm,z_mm\r" + "1.0,2.0,3.0\r" * (MAX_POINTS + 1))
    with pytest.raises(PointsFileError, match=f"{MAX_POINTS + 1:,} points"):
        read_point_set(p)


def test_a_csv_at_the_limit_is_parsed(tmp_path):
    """MAX_POINTS rows plus a comment and a header pass the count (the next check then speaks:
    all rows are one point, which looks like metres)."""
    p = tmp_path / "limit.csv"
    p.write_text("# c\nx_mm,y_mm,z_mm\n" + "1.0,2.0,3.0\n" * MAX_POINTS)
    with pytest.raises(PointsFileError, match="looks like metres"):
        read_point_set(p)


def test_a_json_with_too_many_points_is_refused(tmp_path):
    """A JSON point file is counted after parsing, before the checks and the fit."""
    n = MAX_POINTS + 1
    p = tmp_path / "dense.json"
    p.write_text(json.dumps({"units": "mm", "points": [[float(i), 0.0, 0.0] for i in range(n)]}))
    with pytest.raises(PointsFileError, match=f"{n:,} points"):
        read_point_set(p)


def test_commission_refuses_a_dense_centreline_file_in_one_line(tmp_path, capsys):
    """The issue's dense input through the command line: an applicator file whose ring
    centreline_file has MAX_POINTS + 1 rows: exit 2, one line naming the CSV and the count, no
    traceback, no output folder."""
    from ringqa.cli import main
    from ringqa.io.applicator_file import applicator_to_dict, load_applicator

    doc = applicator_to_dict(load_applicator("ring26x60"))
    ring = next(c for c in doc["channels"] if c["name"] == "ring")
    ring.pop("centreline_mm")
    ring["centreline_file"] = "dense.csv"
    (tmp_path / "ring.json").write_text(json.dumps(doc))
    (tmp_path / "dense.csv").write_text("x_mm,y_mm,z_mm\n" + "1.0,2.0,3.0\n" * (MAX_POINTS + 1))
    out = tmp_path / "out"
    rc = main(["commission", str(tmp_path / "ring.json"), "--out", str(out), "--no-pdf",
               "--quiet"])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2
    assert "dense.csv" in err and f"{MAX_POINTS + 1:,} points" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
