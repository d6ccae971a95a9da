"""The ring family (Elekta Ring CT/MR, Varian ring): the rules gathered from the pipeline.

- Frame: the circle fitted to the ring channel (:mod:`ringqa.geometry.families.ring_frame`);
  its centre, cranial normal, lateral (patient left) and radius are the applicator's frame
  fields.
- Span: without a measured path the reference dwells lie on the circular part of the ring:
  walking proximally from s_ref in ``step_mm`` steps while the centreline stays within
  :data:`ON_CIRCLE_MM` of the circle (radially and out of its plane).
- Dose points (Berger et al. 2007): the lateral ring surface left/right, in the ring plane along
  the lateral axis at ``ring radius + spec.surface_offset_mm`` from the ring centre, and the
  points ``spec.depth_mm`` further out (:mod:`ringqa.plan.points` has the measurements behind
  the defaults). Point A comes from the frame, as for every gynaecological family.
- Kinks: judged against the ring's radius.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.families.base import FamilyPoint, FamilyWords, channel_points_mm
from ringqa.units import m_to_mm

__all__ = ["ON_CIRCLE_MM", "RING", "RingFamily", "ring_arc_mm"]

#: A centreline point is on the ring's circle within this distance (mm).
ON_CIRCLE_MM = 1.0


def ring_arc_mm(app, channel, step_mm: float) -> float:
    """Largest relative position still on the ring's circle (within 1 mm of it), mm.

    Walks proximally from s_ref in ``step_mm`` steps while the centreline stays within 1 mm of
    the circle of radius ``ring_radius`` around ``ring_centre`` in the ring plane.
    """
    c = m_to_mm(np.asarray(app.ring_centre_m, dtype=float))
    n = np.asarray(app.ring_normal, dtype=float)
    r = m_to_mm(float(app.ring_radius_m))
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel = np.arange(0.0, s_ref_mm + 1e-9, step_mm)
    d = channel_points_mm(channel, rel) - c
    h = d @ n
    rho = np.linalg.norm(d - np.outer(h, n), axis=1)
    on = (np.abs(rho - r) < ON_CIRCLE_MM) & (np.abs(h) < ON_CIRCLE_MM)
    if not on[0]:
        return 0.0
    k = int(np.argmin(on)) if not on.all() else on.size
    return float(rel[k - 1])


def _unit(vec, name: str) -> np.ndarray:
    v = np.asarray(vec, dtype=float).reshape(-1)
    n = float(np.linalg.norm(v)) if v.shape == (3,) else 0.0
    if v.shape != (3,) or not np.isfinite(n) or n < 1e-9:
        raise GeometryError(f"applicator: {name} must be a non-zero 3-vector, got {vec!r}")
    return v / n


#: The report's words for this family.
WORDS = FamilyWords(
    "ring applicator",
    "ring channel",
    "the circular part of the ring",
    "ring plane",
    "ring axis",
    "ring channel plane",
)


@dataclass(frozen=True)
class RingFamily:
    """The ring family (see the module docstring)."""

    name: str = "ring"
    words: FamilyWords = WORDS
    gynae: bool = True

    def span_mm(self, app, channel, step_mm: float) -> float:
        """:func:`ring_arc_mm`."""
        return ring_arc_mm(app, channel, step_mm)

    def points(self, app, channel, spec) -> tuple[FamilyPoint, ...]:
        """Lateral ring surface and 5 mm deeper, left and right (mm)."""
        c = m_to_mm(np.asarray(app.ring_centre_m, dtype=float)).reshape(3)
        n = _unit(app.ring_normal, "ring_normal")
        lat = _unit(app.ring_lateral, "ring_lateral")
        lat = lat - np.dot(lat, n) * n
        lat = _unit(lat, "ring_lateral (component orthogonal to ring_normal)")
        r = float(m_to_mm(float(app.ring_radius_m)))
        r_surf = r + spec.surface_offset_mm
        r_deep = r_surf + spec.depth_mm
        pts = []
        for kind, radius in (("surface", r_surf), ("depth5", r_deep)):
            for side, sign in (("left", 1.0), ("right", -1.0)):
                pts.append(FamilyPoint(f"{kind}_{side}", kind, c + sign * radius * lat))
        return tuple(pts)

    def curvature_scale_m(self, app, channel) -> float:
        """The ring's radius."""
        return float(app.ring_radius_m)

    def checks(self, app, channel) -> tuple[str, ...]:
        """None beyond the shared shape checks."""
        return ()


RING = RingFamily()
