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
