"""CommissionSettings: the defaults of the command line, and every bad value refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.errors import RingQAError
from ringqa.pipeline import CommissionSettings
from ringqa.plan import DosePointSpec


def test_defaults_are_the_command_lines():
    """7 Gy, 1 / 2 mm, 5 %, 5 mm plan step, 7 tandem dwells, the cable of the plan's source
    (None), ring channel, no registration, a 60 mm modelled stem."""
    s = CommissionSettings()
    assert (s.prescription_gy, s.position_limits_mm, s.dose_action_pct) == (7.0, (1.0, 2.0), 5.0)
    assert (s.plan_step_mm, s.tandem_dwells, s.cable, s.channel) == (5.0, 7, None, "ring")
    assert (s.register, s.stem_mm, s.centreline_correction) == ("none", 60.0, None)
    assert s.scene_overrides == {} and s.sk_U is None and s.require_measured is None


def test_values_are_normalised():
    """Integers and numpy numbers become floats / ints; a list of limits a tuple; the overrides
    a copy (changing the caller's dict later does not change the settings)."""
    overrides = {"solver.increment_mm": 0.5}
    s = CommissionSettings(
        scene_overrides=overrides,
        prescription_gy=np.int64(6),
        position_limits_mm=[1, 3],
        tandem_dwells=np.int32(0),
        sk_U=40000,
    )
    overrides["solver.tol"] = 1e-6
    assert s.scene_overrides == {"solver.increment_mm": 0.5}
    assert type(s.prescription_gy) is float and s.prescription_gy == 6.0
    assert s.position_limits_mm == (1.0, 3.0) and type(s.tandem_dwells) is int
    assert type(s.sk_U) is float


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("prescription_gy", -1, r"--prescription-gy -1: must be a number > 0"),
        ("prescription_gy", float("nan"), r"--prescription-gy nan"),
        ("prescription_gy", "7", r"--prescription-gy '7'"),
        ("dose_action_pct", 0, r"--dose-action-pct 0: must be a number > 0"),
        ("position_limits_mm", (2, 1), r"position_limits_mm \(2, 1\): .* recommended <= required"),
        ("position_limits_mm", (1,), r"position_limits_mm \(1,\)"),
        ("position_limits_mm", 1.0, r"position_limits_mm 1.0"),
        ("plan_step_mm", 0.0, r"plan_step_mm 0.0: must be a number of mm > 0"),
        ("tandem_dwells", -1, r"tandem_dwells -1: must be a whole number >= 0"),
        ("tandem_dwells", 2.5, r"tandem_dwells 2.5"),
        ("sk_U", 0.0, r"sk_U 0.0: must be an air-kerma strength in U > 0"),
        ("cable", "", r"cable '': must be a name, e.g. \"flexitron\""),
        ("channel", None, r"channel None: must be a name, e.g. \"ring\""),
        ("point_spec", {"depth_mm": 5}, r"point_spec .*: must be a ringqa.plan.DosePointSpec"),
        ("require_measured", "yes", r"require_measured 'yes': must be True, False or None"),
        ("scene_overrides", ["solver.tol"], r"scene_overrides \['solver.tol'\]: must map"),
        (
            "register",
            "affine",
            r"--register 'affine': unknown registration mode; choose one of "
            r"none, plane-height, rigid",
        ),
        ("stem_mm", 0.0, r"--stem-mm 0.0: must be a length in mm > 0"),
        ("centreline_correction", 3, r"--centreline-correction 3: give the path"),
    ],
)
def test_bad_values_name_the_field_and_the_fix(field, value, message):
    with pytest.raises(RingQAError, match=message):
        CommissionSettings(**{field: value})


def test_settings_are_frozen():
    s = CommissionSettings(point_spec=DosePointSpec(depth_mm=10.0))
    with pytest.raises(AttributeError):
        s.prescription_gy = 8.0  # type: ignore[misc]
    assert s.point_spec.depth_mm == 10.0
