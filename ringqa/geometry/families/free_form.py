"""The free-form family: any centreline with a lumen (a patient-tailored, 3-D printed channel).

- Frame: the applicator's own when its file gives one, else fitted to the channels
  (:func:`ringqa.geometry.frame.fit_frame`).
- Span: without a measured path, the whole channel but its proximal :data:`ENTRY_MM` (the
  cable needs a few mm in the channel before the simulated dwells), or the applicator's
  ``metadata["simulate_mm"]``; on the plan step's grid.
- Dose points: the applicator's own (``metadata["dose_points"]``: ``[{"name", "position_mm"}]``,
  the first two set the standard plan's times), else none: then the RT Plan's points. Not a
  gynaecological family: no Point A (give it as a dose point where it applies).
- Kinks: against :data:`~ringqa.geometry.families.base.KINK_SCALE_M`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.families.base import KINK_SCALE_M, FamilyPoint, FamilyWords, span_on_grid_mm
from ringqa.units import m_to_mm

__all__ = ["ENTRY_MM", "FREE_FORM", "FreeFormFamily", "user_points"]

#: The proximal part of a free-form channel left out of the simulated span (mm).
ENTRY_MM = 20.0


def user_points(app) -> tuple[FamilyPoint, ...]:
    """The applicator's own dose points (``metadata["dose_points"]``), kind ``"user"``.

    Raises
    ------
    GeometryError
        A point without a name or a finite 3-vector ``position_mm``.
    """
    raw = (getattr(app, "metadata", {}) or {}).get("dose_points", ()) or ()
    out = []
    for i, p in enumerate(raw):
        name = p.get("name") if isinstance(p, dict) else None
        pos = np.asarray(p.get("position_mm", ()) if isinstance(p, dict) else (), dtype=float)
        if not isinstance(name, str) or not name or pos.shape != (3,) or not np.isfinite(pos).all():
            raise GeometryError(
                f"applicator {app.name}: dose_points[{i}] needs a name and position_mm [x, y, z] "
                f"(mm), got {p!r}"
            )
        out.append(FamilyPoint(name, "user", pos))
    return tuple(out)


#: The report's words for this family.
WORDS = FamilyWords("free-form channel", "channel", "the channel beyond its proximal entry")


@dataclass(frozen=True)
class FreeFormFamily:
    """The free-form family (see the module docstring)."""

    name: str = "free-form"
    words: FamilyWords = WORDS
    gynae: bool = False

    def span_mm(self, app, channel, step_mm: float) -> float:
        """Everything but the proximal :data:`ENTRY_MM`, or ``metadata["simulate_mm"]``."""
        given = (getattr(app, "metadata", {}) or {}).get("simulate_mm")
        span = float(given) if given is not None else m_to_mm(channel.s_ref_m) - ENTRY_MM
        return span_on_grid_mm(channel, span, step_mm)

    def points(self, app, channel, spec) -> tuple[FamilyPoint, ...]:
        """:func:`user_points` (once per applicator: only for its first channel)."""
        return user_points(app) if channel is None or channel is app.channels[0] else ()

    def curvature_scale_m(self, app, channel) -> float:
        """:data:`~ringqa.geometry.families.base.KINK_SCALE_M`."""
        return KINK_SCALE_M

    def checks(self, app, channel) -> tuple[str, ...]:
        """None beyond the shared shape checks (and the lumen-vs-cable clearance of the run)."""
        return ()


FREE_FORM = FreeFormFamily()
