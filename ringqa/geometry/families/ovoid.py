"""The ovoid family: Fletcher-type (Fletcher-Suit-Delclos, Henschke; Varian and Elekta) ovoids and
lunar ovoids (Venezia), left and right of a tandem.

An ovoid channel runs up a straight shaft and bends into the ovoid cap (Fletcher-type: a short
bend, the dwells along the cap's axis) or runs round a lunar cap (Venezia: an arc around the
tandem). One rule covers both: the ovoid's dose points sit on the cap's LATERAL surface at its
most lateral dwell.

- Span: the distal :data:`SPAN_MM` of the channel (the cap and the bend into it) without a
  measured path.
- Dose points (defined as the ring's lateral surface points are): at the centreline point
  (relative positions 0 .. span, every 0.5 mm) farthest from the applicator's axis (the most
  distal of equals, to 1e-6 mm), ``ovoid surface`` = that point moved
  :data:`OVOID_SURFACE_MM` (or the applicator's ``metadata["ovoid_surface_mm"]``) outwards,
  perpendicular to the axis, and ``ovoid 5 mm`` a further ``spec.depth_mm``. Named by the side
  the ovoid lies on: ``ovoid_surface_left``, ``ovoid_depth5_left``.
  :data:`OVOID_SURFACE_MM` = 10 mm: the radius of the smallest (20 mm) Fletcher cap with the
  channel on its axis. ASSUMED for every ovoid: set your cap's channel-to-lateral-surface
  distance in the applicator's metadata.
- Kinks: against :data:`~ringqa.geometry.families.base.KINK_SCALE_M` (an ovoid's tip bend is
  tight by design; it is a kink only when much tighter than the bend around it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.families.base import (
    KINK_SCALE_M,
    FamilyPoint,
    FamilyWords,
    channel_points_mm,
    lateral_side,
    radial_outward,
    span_on_grid_mm,
)
from ringqa.geometry.frame import frame_of
from ringqa.units import m_to_mm

__all__ = ["OVOID", "OVOID_SURFACE_MM", "SPAN_MM", "OvoidFamily"]

#: Distance (mm) from the ovoid channel to the cap's lateral surface (ASSUMED; see above).
OVOID_SURFACE_MM = 10.0
#: The ovoid's reference dwells without a measured path: its distal 20 mm (mm).
SPAN_MM = 20.0
#: Spacing (mm) of the centreline samples searched for the most lateral dwell.
_SEARCH_MM = 0.5


#: The report's words for this family.
WORDS = FamilyWords("ovoid", "ovoid channel", "the ovoid cap and its bend")


@dataclass(frozen=True)
class OvoidFamily:
    """The ovoid family (see the module docstring)."""

    name: str = "ovoid"
    words: FamilyWords = WORDS
    gynae: bool = True

    def span_mm(self, app, channel, step_mm: float) -> float:
        """The distal :data:`SPAN_MM` (within the channel), on the step grid."""
        return span_on_grid_mm(channel, SPAN_MM, step_mm)

    def points(self, app, channel, spec) -> tuple[FamilyPoint, ...]:
        """The ovoid's lateral surface point and the point ``spec.depth_mm`` beyond it."""
        span = min(SPAN_MM, m_to_mm(float(channel.s_ref_m)))
        rel = np.arange(0.0, span + 1e-9, _SEARCH_MM)
        pts = channel_points_mm(channel, rel)
        frame = frame_of(app)
        c = m_to_mm(np.asarray(frame.centre_m, dtype=float))
        n = np.asarray(frame.normal, dtype=float)
        d = pts - c
        radial = np.linalg.norm(d - np.outer(d @ n, n), axis=1)
        p = pts[int(np.argmax(np.round(radial, 6)))]  # ties (to 1e-6 mm): the most distal
        out = radial_outward(app, p)
        offset = float((getattr(app, "metadata", {}) or {}).get("ovoid_surface_mm",
                                                                 OVOID_SURFACE_MM))  # fmt: skip
        side = lateral_side(app, p)
        surface = p + offset * out
        return (
            FamilyPoint(f"ovoid_surface_{side}", "ovoid_surface", surface),
            FamilyPoint(f"ovoid_depth5_{side}", "ovoid_depth5", surface + spec.depth_mm * out),
        )

    def curvature_scale_m(self, app, channel) -> float:
        """:data:`~ringqa.geometry.families.base.KINK_SCALE_M`."""
        return KINK_SCALE_M

    def checks(self, app, channel) -> tuple[str, ...]:
        """None beyond the shared shape checks."""
        return ()


OVOID = OvoidFamily()
