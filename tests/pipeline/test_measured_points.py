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
    plan needs reference positions every 5 mm"); now, with no vendor/library path in the input,
    the plan is built on the SIMULATED path every 5 mm (its equal times set so that the mean
    Point A dose of the simulated plan is the 7 Gy prescription; the centreline plan carries
    the same times), the measured points are compared with the simulated path at their own
    relative positions, and the verdict, notes and results (measured_points) name them."""
    rel = [0.0, 5.0, 10.0, 25.0, 30.0, 50.0]
    folder = _sparse_folder(tmp_path, rel)
    res = commission(folder, CommissionSettings(cable="flexitron"))
    v = next(v for v in res.verdicts if v.check == CHECK_MEASURED_POINTS)
    assert "6 measured points" in v.text
    notes = " ".join(res.notes)
    assert "a subset of 6 positions (0, 5, 10, 25, 30, 50 mm" in notes
    assert "method film" in notes and "as measured" in notes
    assert "built on the SIMULATED source path" in notes
    assert res.reference == "centreline"
    mp = res.measured_points
    assert mp["plan_path"] == "simulated" and mp["relative_position_mm"] == rel
    point_a = res.doses[res.doses["kind"] == "point_a"]
    sim = point_a[point_a["plan"] == "simulated"]["dose_gy"].mean()
    cl = point_a[point_a["plan"] == "centreline"]["dose_gy"].mean()
    assert sim == pytest.approx(7.0, rel=1e-9)
    assert abs(cl - 7.0) > 1e-3  # the centreline plan keeps the simulated plan's times


def _film_subset(
    tmp_path, every=4, sd=0.3, rows=None, columns="x_mm,y_mm,z_mm,relative_position_mm,sd_mm"
):
    """Every ``every``-th position of the example plan's library path as a film file."""
    from ringqa.datasets import example_plan

    ring = load_input(example_plan()).applicator.channel("ring")
    pts = np.asarray(ring.measured_path_m) * 1e3
    rel = np.asarray(ring.measured_relative_positions_m) * 1e3
    rows = range(0, len(pts), every) if rows is None else rows
    lines = ["# method = film", columns]
    for k in rows:
        x, y, z = pts[k]
        vals = [f"{x:.4f}", f"{y:.4f}", f"{z:.4f}", f"{rel[k]:g}", f"{sd:g}"]
        lines.append(",".join(vals[: len(columns.split(","))]))
    path = tmp_path / "film.csv"
    path.write_text("\n".join(lines) + "\n")
    return path, rel[list(rows)]


@pytest.fixture(scope="module")
def plan_alone():
    """``commission(example_plan())`` with the default settings, run once for the two tests
    that compare a measured file's run with the plan's own (each only reads it)."""
    from ringqa.datasets import example_plan

    return commission(example_plan())


@pytest.mark.slow
def test_subset_of_an_rt_plan_keeps_the_plan_on_the_library_path(tmp_path, plan_alone):
    """The example RT Plan with ``measured = film subset`` (every 4th library position, sd
    0.3 mm): the standard plan and the dwell table stay on the plan's library path, so the
    dwells and doses are those of the plan alone, cell for cell; the measured points are
    compared at their own positions (one more verdict), results name the plan's path and the
    measured positions, and the film file is in the provenance's inputs."""
    from ringqa.datasets import example_plan

    film, rel = _film_subset(tmp_path)
    plan = example_plan()
    dense = plan_alone
    sub = commission(plan, CommissionSettings(measured=film))
    import pandas as pd

    pd.testing.assert_frame_equal(sub.dwells, dense.dwells)
    pd.testing.assert_frame_equal(sub.doses, dense.doses)
    assert sub.reference == "measured"
    assert [v.check for v in sub.verdicts] == [
        *(v.check for v in dense.verdicts),
        CHECK_MEASURED_POINTS,
    ]
    mp = sub.measured_points
    assert mp["plan_path"] == "library" and "Oncentra" in mp["plan_source"] + str(sub.notes)
    assert mp["relative_position_mm"] == pytest.approx(rel.tolist())
    assert mp["method"] == "film" and mp["sd_mm"] == pytest.approx([0.3] * rel.size)
    # the measured points ARE library positions: the distances are the library comparison's,
    # up to the file's 4 decimals (<= 0.9e-4 mm) and the subset's own run stopping at fewer
    # advances (its load steps differ; measured 4e-5 mm, far inside the 0.03 mm numerical error)
    d = sub.dwells[sub.dwells["path"] == "simulated"].set_index("relative_position_mm")
    assert np.allclose(mp["distance_mm"], d.loc[rel, "dist_to_measured_mm"], atol=1e-3)
    notes = " ".join(sub.notes)
    assert "built on the input's own dense source path" in notes
    assert any(str(film) == str(p) or p.endswith("film.csv") for p in sub.provenance.inputs)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"columns": "x_mm,y_mm,z_mm"}, r"film\.csv: relative_position_mm: missing.*add a "
         r"relative_position_mm column"),
        ({"rows": [0, 8, 4, 12]}, r"film\.csv.*relative_position_mm"),
    ],
)  # fmt: skip
def test_measured_file_refusals_name_file_field_and_fix(tmp_path, kwargs, match):
    from ringqa.datasets import example_plan
    from ringqa.errors import RingQAError

    film, _ = _film_subset(tmp_path, **kwargs)
    with pytest.raises(RingQAError, match=match):
        commission(example_plan(), CommissionSettings(measured=film))


@pytest.mark.slow
def test_dense_measured_file_is_the_reference(tmp_path, plan_alone):
    """``measured = FILE`` holding every library position (a dense path, sd 0.3 mm): it is the
    reference itself (no subset: no measured-points verdict), and the dwell table is the plan's
    own up to the file's 4 decimals (<= 0.9e-4 mm per coordinate)."""
    from ringqa.datasets import example_plan

    film, _rel = _film_subset(tmp_path, every=1)
    plan = example_plan()
    dense = plan_alone
    own = commission(plan, CommissionSettings(measured=film))
    assert own.measured_points is None and own.reference == "measured"
    assert CHECK_MEASURED_POINTS not in [v.check for v in own.verdicts]
    a = dense.dwells["dist_to_measured_mm"].to_numpy()
    b = own.dwells["dist_to_measured_mm"].to_numpy()
    assert np.allclose(a, b, atol=2e-4)
    assert "film.csv" in " ".join(own.notes)
