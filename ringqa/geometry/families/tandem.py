"""The tandem (intra-uterine) family: a straight or curved-tip tube along the uterine axis.

- Frame (:func:`tandem_frame`): the tandem's axis is its mean tangent over the distal
  :data:`AXIS_MM` (entry -> tip: cranial); the origin is the point of that axis nearest to the
  ovoids' or ring's dwell region (the mean of the other channels' relative-position-0 points:
  the vaginal fornices), else the tandem point :data:`AXIS_MM` proximal of its tip; lateral is
  from the right ovoid towards the left one (made perpendicular to the axis), else patient left.
  Point A lies ``spec.point_a_height_mm`` cranial of the origin and ``spec.point_a_lateral_mm``
  to either side (ABS/ICRU 89: 2 cm above the fornices/flange, 2 cm lateral); the plan's own
  A points are always dosed beside it.
- Span: the distal :data:`SPAN_MM` of the tandem (its curved tip and the dwells of a standard
  loading), without a measured path.
- Dose points: none of its own (Point A and the plan's points).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.families.base import (
    KINK_SCALE_M,
    FamilyPoint,
    FamilyWords,
    channel_points_mm,
    channel_tip_mm,
    span_on_grid_mm,
)
from ringqa.geometry.frame import Frame, patient_left_in_plane
from ringqa.units import mm_to_m

__all__ = ["AXIS_MM", "SPAN_MM", "TANDEM", "TandemFamily", "tandem_frame"]

#: Length of the tandem's distal part whose mean tangent is the axis (mm).
AXIS_MM = 60.0
#: The tandem's reference dwells without a measured path: the distal 60 mm (mm).
SPAN_MM = 60.0


def tandem_frame(tandem, others=(), left=None, right=None) -> Frame:
    """The frame of a tandem-based applicator (see the module docstring).

    Parameters
    ----------
    tandem : Channel
    others : sequence of Channel
        The ovoid or ring channels (their relative position 0 sets the origin).
    left, right : Channel, optional
        The left and right ovoid (they set the lateral axis).

    Returns
    -------
    Frame
        ``scale_m``: the distance from the origin to the tandem tip (kept within 5-100 mm).
    """
    rel = np.linspace(0.0, min(AXIS_MM, tandem.s_ref_m * 1e3), 13)
    pts = channel_points_mm(tandem, rel)
    axis = pts[0] - pts[-1]
    if np.linalg.norm(axis) < 1e-9:
        t = np.asarray(tandem.centreline.tangent(tandem.s_ref_m), dtype=float)
        axis = t
    axis = axis / np.linalg.norm(axis)
    tip = channel_tip_mm(tandem)
    if others:
        fornix = np.mean([channel_tip_mm(c) for c in others], axis=0)
        origin = tip + float((fornix - tip) @ axis) * axis
    else:
        origin = pts[-1]
    lateral = None
    if left is not None and right is not None:
        d = channel_tip_mm(left) - channel_tip_mm(right)
        d = d - float(d @ axis) * axis
        if np.linalg.norm(d) > 1e-6:
            lateral = d / np.linalg.norm(d)
    if lateral is None:
        lateral = patient_left_in_plane(axis)
    scale = min(max(float(np.linalg.norm(tip - origin)), 5.0), 100.0)
    return Frame(mm_to_m(origin), axis, lateral, mm_to_m(scale))


#: The report's words for this family.
WORDS = FamilyWords(
    "tandem",
    "tandem channel",
    "the distal part of the tandem",
    "plane across the tandem axis",
    "tandem axis",
    "frame origin",
)


@dataclass(frozen=True)
class TandemFamily:
    """The tandem family (see the module docstring)."""

    name: str = "tandem"
    words: FamilyWords = WORDS
    gynae: bool = True

    def span_mm(self, app, channel, step_mm: float) -> float:
        """The distal :data:`SPAN_MM` (within the channel), on the step grid."""
        return span_on_grid_mm(channel, SPAN_MM, step_mm)

    def points(self, app, channel, spec) -> tuple[FamilyPoint, ...]:
        """None (Point A comes from the frame)."""
        return ()

    def curvature_scale_m(self, app, channel) -> float:
        """:data:`~ringqa.geometry.families.base.KINK_SCALE_M`."""
        return KINK_SCALE_M

    def checks(self, app, channel) -> tuple[str, ...]:
        """None beyond the shared shape checks."""
        return ()


TANDEM = TandemFamily()
