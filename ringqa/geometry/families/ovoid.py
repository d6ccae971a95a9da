"""The ovoid family: Fletcher-type (Fletcher-Suit-Delclos, Henschke; Varian and Elekta) ovoids and
lunar ovoids (Venezia), left and right of a tandem.

An ovoid channel runs up a straight shaft and bends into the ovoid cap (Fletcher-type: a short
bend, the dwells along the cap's axis) or runs round a lunar cap (Venezia: an arc around the
tandem). One rule covers both: the ovoid's dose points sit on the cap's LATERAL surface beside
the middle of its most lateral stretch.

- Span: the distal :data:`SPAN_MM` of the channel (the cap and the bend into it) without a
  measured path.
- Dose points (defined as the ring's lateral surface points are: along the applicator frame's
  lateral axis): the ovoid's most lateral stretch is the run of centreline points (relative
  positions 0 .. span, every 0.5 mm) within :data:`CAP_TOLERANCE_MM` of the most lateral one,
  measured along the frame's lateral axis on the ovoid's side; its middle is the cap's middle
  (a Fletcher cap's straight loaded run, a lunar cap's apex). ``ovoid surface`` = that point
  moved :data:`OVOID_SURFACE_MM` (or the applicator's ``metadata["ovoid_surface_mm"]``)
  outwards along the lateral axis made perpendicular to the channel there (the cap's lateral
  surface, beside the cap and never beyond its tip), and ``ovoid 5 mm`` a further
  ``spec.depth_mm``. Named by the side the ovoid lies on: ``ovoid_surface_left``,
  ``ovoid_depth5_left``. :data:`OVOID_SURFACE_MM` = 10 mm: the radius of the smallest (20 mm)
  Fletcher cap with the channel on its axis. ASSUMED for every ovoid: set your cap's
  channel-to-lateral-surface distance in the applicator's metadata.
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
    span_on_grid_mm,
)
from ringqa.geometry.frame import frame_of
from ringqa.units import m_to_mm, mm_to_m

__all__ = ["CAP_TOLERANCE_MM", "OVOID", "OVOID_SURFACE_MM", "SPAN_MM", "OvoidFamily"]

#: Distance (mm) from the ovoid channel to the cap's lateral surface (ASSUMED; see above).
OVOID_SURFACE_MM = 10.0
#: The ovoid's reference dwells without a measured path: its distal 20 mm (mm).
SPAN_MM = 20.0
#: Spacing (mm) of the centreline samples searched for the most lateral stretch.
_SEARCH_MM = 0.5
#: Centreline points within this distance (mm, along the lateral axis) of the most lateral one
#: belong to the cap's most lateral stretch (a cap's straight run tilts by a few tenths of a mm).
CAP_TOLERANCE_MM = 0.5


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
        side = lateral_side(app, pts.mean(axis=0))
        lat = np.asarray(frame.lateral, dtype=float) * (1.0 if side == "left" else -1.0)
        mid = _most_lateral_middle_mm(rel, (pts - c) @ lat)
        s_mid = channel.s_ref_m - mm_to_m(mid)
        p = m_to_mm(np.asarray(channel.centreline.position(s_mid), dtype=float).reshape(3))
        t = np.asarray(channel.centreline.tangent(s_mid), dtype=float).reshape(3)
        out = lat - float(lat @ t) * t
        out = out / float(np.linalg.norm(out))
        offset = float((getattr(app, "metadata", {}) or {}).get("ovoid_surface_mm",
                                                                 OVOID_SURFACE_MM))  # fmt: skip
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


def _most_lateral_middle_mm(rel_mm, lateral_mm) -> float:
    """The relative position (mm) in the middle of the most lateral stretch: the contiguous run
    of samples around the most lateral one (the most distal of equals) whose lateral coordinate
    is within :data:`CAP_TOLERANCE_MM` of it.

    Parameters
    ----------
    rel_mm : (n,) array
        Relative positions of the samples, mm, increasing.
    lateral_mm : (n,) array
        Their coordinates along the ovoid side's lateral axis, mm.
    """
    lateral = np.asarray(lateral_mm, dtype=float)
    i = int(np.argmax(np.round(lateral, 6)))
    inside = lateral >= lateral[i] - CAP_TOLERANCE_MM
    lo, hi = i, i
    while lo > 0 and inside[lo - 1]:
        lo -= 1
    while hi < len(lateral) - 1 and inside[hi + 1]:
        hi += 1
    return 0.5 * (float(rel_mm[lo]) + float(rel_mm[hi]))


OVOID = OvoidFamily()
