"""A measured path that is a subset of positions (issue 26 item 1): commissioned end to end,
compared at its own positions, each point judged with its own uncertainty."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ringqa.paths import data_dir
from ringqa.pipeline import CommissionSettings, commission
from ringqa.pipeline.dwells import centreline_dwells
from ringqa.pipeline.inputs import load_input
from ringqa.pipeline.measured_points import CHECK_MEASURED_POINTS, NOT_RESOLVABLE, point_status


@pytest.mark.parametrize(
    ("d", "sd", "status"),
    [
        (0.5, 0.2, "PASS"),  # 0.5 + 0.4 = 0.9 <= 1
        (0.7, 0.2, NOT_RESOLVABLE),  # 0.3 .. 1.1 spans the 1 mm limit
        (1.5, 0.2, "WARN"),  # 1.1 .. 1.9: above 1, within 2
        (2.6, 0.2, "FAIL"),  # 2.2 > 2
        (2.2, 0.2, NOT_RESOLVABLE),  # 1.8 .. 2.6 spans the 2 mm limit
        (0.9, 0.0001, "PASS"),
    ],
)
def test_point_status_uses_the_points_own_2_sd(d, sd, status):
    """Limits 1 / 2 mm; the expected statuses are worked out beside each case."""
    assert point_status(d, sd, 1.0, 2.0) == status


def _sparse_folder(tmp_path, rel_mm, offset_mm=0.4):
    """ring26x60 with a measured subset: the centreline at relative positions ``rel_mm``
    moved ``offset_mm`` towards the ring's centre (inside the 1.5 mm lumen), sd 0.2 mm, film."""
    app = load_input("ring26x60").applicator
    ring = app.channel("ring")
    pts = centreline_dwells(ring, np.asarray(rel_mm, float)).positions_mm
    centre = np.asarray(app.ring_centre_m) * 1e3
    inward = centre - pts
    inward -= np.outer(inward @ np.asarray(app.ring_normal), app.ring_normal)
    pts = pts + offset_mm * inward / np.linalg.norm(inward, axis=1)[:, None]
    folder = tmp_path / "ring_film"
    folder.mkdir()
    doc = json.loads((data_dir() / "applicators" / "ring26x60.json").read_text())
    doc["channels"][0]["measured_path_file"] = "measured_path.csv"
    (folder / "applicator.json").write_text(json.dumps(doc))
    lines = ["# method = film", "x_mm,y_mm,z_mm,relative_position_mm,sd_mm"]
    lines += [
        f"{x:.6f},{y:.6f},{z:.6f},{r:g},0.2" for (x, y, z), r in zip(pts, rel_mm, strict=True)
    ]
    (folder / "measured_path.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_sparse_measured_path_commissioned_end_to_end(tmp_path):
    """Film positions 0, 5, 10, 25, 30, 50 mm (no 15, 20, ...): once refused ("the standard
    plan needs reference positions every 5 mm"); now the plan is built on the centreline every
    5 mm, the measured points are compared with the simulated path at their own relative
    positions, and the verdict and notes name them."""
    rel = [0.0, 5.0, 10.0, 25.0, 30.0, 50.0]
    folder = _sparse_folder(tmp_path, rel)
    res = commission(folder, CommissionSettings(cable="flexitron"))
    v = next(v for v in res.verdicts if v.check == CHECK_MEASURED_POINTS)
    assert "6 measured points" in v.text
    notes = " ".join(res.notes)
    assert "a subset of 6 positions (0, 5, 10, 25, 30, 50 mm" in notes
    assert "method film" in notes and "as measured" in notes
    assert "built on the channel CENTRELINE" in notes
    assert res.reference == "centreline"
