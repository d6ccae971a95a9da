"""The --measured items: which applicator each path belongs to, and the refusals."""

from __future__ import annotations

import pytest

from ringqa.calibration.measured import CalibrationError, measured_applicators
from ringqa.pipeline import CommissionSettings
from tests.calibration.conftest import synthetic

SETTINGS = CommissionSettings(cable="flexitron")


def _film(tmp_path, m, name, rel=True):
    p = tmp_path / name
    head = "x_mm,y_mm,z_mm" + (",relative_position_mm" if rel else "")
    pairs = zip(m.measured_mm, m.relative_position_mm, strict=True)
    rows = [f"{x:.6f},{y:.6f},{z:.6f}" + (f",{r:g}" if rel else "") for (x, y, z), r in pairs]
    p.write_text("# measured_sd_mm = 0.4\n" + head + "\n" + "\n".join(rows) + "\n")
    return p


def test_file_belongs_to_input_and_app_equals_file_to_another(tmp_path):
    """A plain file is INPUT's ring; ring30x60=FILE another applicator; the sd comment reaches
    every point."""
    a = _film(tmp_path, synthetic("ring26x60", noise_mm=0.0), "a.csv")
    b = _film(tmp_path, synthetic("ring30x60", noise_mm=0.0), "b.csv")
    got = measured_applicators([str(a), f"ring30x60={b}"], "ring26x60", settings=SETTINGS)
    assert [m.label for m in got] == ["ring26x60", "ring30x60"]
    assert all(m.sd_mm.tolist() == [0.4] * 9 and not m.sd_assumed for m in got)
    assert all(m.used.all() for m in got)


@pytest.mark.parametrize(
    ("items", "match"),
    [
        (["nope.csv"], "no such file or folder"),
        (["ring30x60="], "write APPLICATOR=FILE"),
    ],
)
def test_bad_items_named(tmp_path, items, match):
    with pytest.raises(CalibrationError, match=match):
        measured_applicators([str(tmp_path / i) if "=" not in i else i for i in items],
                             "ring26x60", settings=SETTINGS)  # fmt: skip


def test_subset_without_relative_positions_refused(tmp_path):
    f = _film(tmp_path, synthetic("ring26x60", noise_mm=0.0), "a.csv", rel=False)
    with pytest.raises(CalibrationError, match="no relative_position_mm column"):
        measured_applicators([str(f)], "ring26x60", settings=SETTINGS)


def test_one_applicator_measured_twice_refused(tmp_path):
    m = synthetic("ring26x60", noise_mm=0.0)
    a, b = _film(tmp_path, m, "a.csv"), _film(tmp_path, m, "b.csv")
    with pytest.raises(CalibrationError, match="measured twice"):
        measured_applicators([str(a), str(b)], "ring26x60", settings=SETTINGS)


def test_shipped_ring_without_a_path_refused():
    with pytest.raises(CalibrationError, match="has no measured source path"):
        measured_applicators([], "ring26x60", settings=SETTINGS)
