"""Dose points defined relative to a ring applicator (Point A, vaginal points on the ring).

All points are built from the applicator's ring frame (``ring_centre``, ``ring_normal`` pointing
cranially, ``ring_lateral`` pointing to the patient's LEFT, ``ring_radius`` = channel centreline
radius), so they follow the applicator wherever it sits in the patient/library frame.

Definitions (``DosePointSpec`` defaults; every distance is configurable):

- **Point A left/right** (ABS, applicator based): on the ring normal through the ring centre (the
  tandem axis of the 60 degree sets), ``point_a_height_mm`` = 26.9 mm above the ring channel plane
  -- 20 mm cranial of the ring's cranial surface, which the Oncentra 26 mm / 60 degree plan puts
  6.9 mm above the channel plane -- and ``point_a_lateral_mm`` = 20 mm lateral of the axis.
- **Lateral ring surface left/right** (Berger et al. 2007): in the ring plane, along
  ``ring_lateral``, at ``ring radius + surface_offset_mm`` from the ring centre. The ring's lateral
  outer surface lies ``surface_offset_mm`` = 6.25 mm outside the channel centreline: measured on
  the surface mesh ("skin") of the Ring CT/MR 26 mm / 60 deg ring (part 110350-06) in the Oncentra
  library of data/examples/oncentra_ring26x60 (outer radius 19.25 mm in the ring plane around a
  13.0 mm centreline; tests/plan/test_plan_points.py repeats the measurement). ASSUMED the same
  for the 30 and 34 mm rings (same cap design); set it to your applicator's outer radius - R.
- **Lateral 5 mm left/right**: ``depth_mm`` = 5 mm further out along the same lateral line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import RingQAError
from ringqa.units import m_to_mm

#: The names of the six standard points, in report order.
POINT_NAMES = (
    "point_a_left",
    "point_a_right",
    "surface_left",
    "surface_right",
    "depth5_left",
    "depth5_right",
)


@dataclass(frozen=True)
class DosePointSpec:
    """Where the standard dose points sit relative to the ring (all in mm).

    Attributes
    ----------
    point_a_height_mm : float
        Height of Point A above the ring CHANNEL plane, along ``ring_normal`` (26.9 mm: 20 mm above
        the ring's cranial surface, as in the Oncentra 26/60 plan).
    point_a_lateral_mm : float
        Distance of Point A from the ring normal through the ring centre (20 mm).
    surface_offset_mm : float
        Distance of the ring's lateral outer surface outside the channel centreline, in the ring
        plane (6.25 mm, measured on the Oncentra library mesh of the 26 mm Ring CT/MR).
    depth_mm : float
        Depth of the deeper vaginal points beyond the lateral surface (5 mm).
    """

    point_a_height_mm: float = 26.9
    point_a_lateral_mm: float = 20.0
    surface_offset_mm: float = 6.25
    depth_mm: float = 5.0

    def __post_init__(self) -> None:
        for name in ("point_a_height_mm", "point_a_lateral_mm", "surface_offset_mm", "depth_mm"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise RingQAError(f"dose points: {name} = {value!r} must be a finite number >= 0")

    def as_dict(self) -> dict:
        """Plain dict (for provenance and results.json)."""
        return {
            "point_a_height_mm": self.point_a_height_mm,
            "point_a_lateral_mm": self.point_a_lateral_mm,
            "surface_offset_mm": self.surface_offset_mm,
            "depth_mm": self.depth_mm,
        }


@dataclass(frozen=True)
class DosePoint:
    """One named calculation point.

    Attributes
    ----------
    name : str
        E.g. ``"point_a_left"`` or a TPS point name (``"A1"``).
    position_mm : ndarray, shape (3,)
        Position in the applicator's frame, mm.
    kind : str
        ``"point_a"``, ``"surface"``, ``"depth5"`` or ``"tps"``.
    tps_dose_gy : float or None
        The dose the treatment planning system reported at this point (TPS points only).
    """

    name: str
    position_mm: np.ndarray
    kind: str
    tps_dose_gy: float | None = None


def _unit(vec, name: str) -> np.ndarray:
    v = np.asarray(vec, dtype=float).reshape(-1)
    n = float(np.linalg.norm(v)) if v.shape == (3,) else 0.0
    if v.shape != (3,) or not np.isfinite(n) or n < 1e-9:
        raise RingQAError(f"applicator: {name} must be a non-zero 3-vector, got {vec!r}")
    return v / n


def dose_points_from_frame(
    centre_mm, normal, lateral, ring_radius_mm: float, spec: DosePointSpec | None = None
) -> tuple[DosePoint, ...]:
    """The six standard dose points from a ring frame.

    Parameters
    ----------
    centre_mm : array_like, shape (3,)
        Ring centre (centre of the channel centreline circle), mm.
    normal : array_like, shape (3,)
        Ring normal pointing cranially (towards the tandem tip).
    lateral : array_like, shape (3,)
        In-plane unit vector towards the patient's left. Made orthogonal to ``normal``.
    ring_radius_mm : float
        Channel centreline radius, mm.
    spec : DosePointSpec, optional
        Point definitions (defaults: see the module docstring).

    Returns
    -------
    tuple of DosePoint
        In the order of :data:`POINT_NAMES`.
    """
    spec = spec or DosePointSpec()
    c = np.asarray(centre_mm, dtype=float).reshape(3)
    n = _unit(normal, "ring_normal")
    lat = _unit(lateral, "ring_lateral")
    lat = lat - np.dot(lat, n) * n
    lat = _unit(lat, "ring_lateral (component orthogonal to ring_normal)")
    r = float(ring_radius_mm)
    if not np.isfinite(r) or r <= 0:
        raise RingQAError(f"applicator: ring_radius = {ring_radius_mm!r} mm must be > 0")
    a_up = c + spec.point_a_height_mm * n
    r_surf = r + spec.surface_offset_mm
    r_deep = r_surf + spec.depth_mm
    pts = []
    for side, sign in (("left", 1.0), ("right", -1.0)):
        pts.append(("point_a", side, a_up + sign * spec.point_a_lateral_mm * lat))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        pts.append(("surface", side, c + sign * r_surf * lat))
    for side, sign in (("left", 1.0), ("right", -1.0)):
        pts.append(("depth5", side, c + sign * r_deep * lat))
    return tuple(DosePoint(f"{k}_{s}", p, k) for k, s, p in pts)


def applicator_dose_points(applicator, spec: DosePointSpec | None = None) -> tuple[DosePoint, ...]:
    """The standard dose points of an :class:`ringqa.geometry.Applicator` (mm).

    Point A left/right from the applicator's frame (``ring_centre_m``, ``ring_normal``,
    ``ring_lateral``: :func:`point_a_points`) when one of its channels belongs to a
    gynaecological family, then each channel family's own points
    (:meth:`ringqa.geometry.families.base.ApplicatorFamily.points`: the ring's lateral surface
    and 5 mm points, the ovoids' surface points, a free-form applicator's own points), each name
    once. For a ring this is the six points of :func:`dose_points_from_frame`, in that order.
    """
    from ringqa.geometry.families import family_named, family_of
    from ringqa.geometry.frame import frame_of

    spec = spec or DosePointSpec()
    try:
        frame = frame_of(applicator)
    except AttributeError:
        frame = None
    if frame is None or any(v is None for v in (frame.centre_m, frame.normal, frame.lateral,
                                                   frame.scale_m)):  # fmt: skip
        raise RingQAError(
            f"applicator {getattr(applicator, 'name', '?')}: no frame; dose points need the "
            "applicator's frame (define its centre, normal, lateral direction and radius)"
        )
    channels = tuple(getattr(applicator, "channels", ()) or ())
    families = [family_of(applicator, ch) for ch in channels]
    if not channels:  # a frame alone: its family's points (a ring's, by default)
        channels = (None,)
        families = [family_named(getattr(applicator, "family", "ring") or "ring")]
    pts: list[DosePoint] = []
    if any(f.gynae for f in families):
        pts += point_a_points(
            m_to_mm(np.asarray(frame.centre_m, dtype=float)), frame.normal, frame.lateral, spec
        )
    for ch, fam in zip(channels, families, strict=True):
        for p in fam.points(applicator, ch, spec):
            if all(p.name != q.name for q in pts):
                pts.append(DosePoint(p.name, np.asarray(p.position_mm, dtype=float), p.kind))
    return tuple(pts)


def point_a_points(centre_mm, normal, lateral, spec: DosePointSpec | None = None):
    """Point A left and right (:func:`dose_points_from_frame`'s first two points), mm.

    Parameters
    ----------
    centre_mm : (3,) array_like
        The frame's origin, mm.
    normal, lateral : (3,) array_like
        Cranial and patient-left axes (lateral made perpendicular to normal).
    spec : DosePointSpec, optional

    Returns
    -------
    list of DosePoint
    """
    spec = spec or DosePointSpec()
    c = np.asarray(centre_mm, dtype=float).reshape(3)
    n = _unit(normal, "ring_normal")
    lat = _unit(lateral, "ring_lateral")
    lat = lat - np.dot(lat, n) * n
    lat = _unit(lat, "ring_lateral (component orthogonal to ring_normal)")
    a_up = c + spec.point_a_height_mm * n
    return [
        DosePoint(f"point_a_{side}", a_up + sign * spec.point_a_lateral_mm * lat, "point_a")
        for side, sign in (("left", 1.0), ("right", -1.0))
    ]


def points_array_mm(points) -> np.ndarray:
    """Stack the positions of a sequence of DosePoint into an (n, 3) array, mm."""
    return np.array([p.position_mm for p in points], dtype=float).reshape(-1, 3)
