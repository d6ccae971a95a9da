"""Plans and dose points: standard plans, transfers between dwell sets, TG-43 dose.

Public API::

    from ringqa.plan import (DosePointSpec, DosePoint, applicator_dose_points,
                             dose_points_from_frame, DwellSet, Plan, standard_plan,
                             path_directions, resample_path, relative_difference_pct)
"""

from ringqa.plan.points import (
    POINT_NAMES,
    DosePoint,
    DosePointSpec,
    applicator_dose_points,
    dose_points_from_frame,
    points_array_mm,
)
from ringqa.plan.standard import (
    PLAN_STEP_MM,
    PRESCRIPTION_GY,
    SK_U,
    DwellSet,
    Plan,
    path_directions,
    relative_difference_pct,
    resample_path,
    standard_plan,
)

__all__ = [
    "PLAN_STEP_MM",
    "POINT_NAMES",
    "PRESCRIPTION_GY",
    "SK_U",
    "DosePoint",
    "DosePointSpec",
    "DwellSet",
    "Plan",
    "applicator_dose_points",
    "dose_points_from_frame",
    "path_directions",
    "points_array_mm",
    "relative_difference_pct",
    "resample_path",
    "standard_plan",
]
