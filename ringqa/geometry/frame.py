"""The applicator frame of any family: an origin, a cranial axis, a lateral axis and a length.

Every applicator has a frame in DICOM patient coordinates (LPS: +x patient left, +y posterior,
+z cranial): ``centre_m`` (the origin the dose points are measured from), ``normal`` (unit,
cranial: towards the tandem tip / Point A), ``lateral`` (unit, towards the patient's left,
perpendicular to ``normal``) and ``scale_m`` (a length the family's plots and checks scale with:
the ring's radius for a ring). A family gives its own (:mod:`ringqa.geometry.families`; a ring's
is the circle fitted to its channel), or, where none is given, :func:`fit_frame` here.

The fit for channels without a family frame
-------------------------------------------
- ``normal``: the first principal axis (SVD) of every channel's centreline points, pointing from
  the channels' entries (proximal ends: caudal) towards their tips (cranial);
- ``centre_m``: the mean of the channels' tips (their distal ends);
- ``lateral``: DICOM +x with its ``normal`` component removed (+y for a channel along +x);
- ``scale_m``: the radius of the circle fitted to the points (:func:`fit_circle`: a plane by
  SVD, then an algebraic circle in it), kept within :data:`SCALE_RANGE_M` (a straight channel
  fits no circle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.geometry.centreline import GeometryError

__all__ = ["SCALE_RANGE_M", "Frame", "fit_circle", "fit_frame", "frame_of", "patient_left_in_plane"]

#: The range (m) a fitted frame's ``scale_m`` is kept in.
SCALE_RANGE_M = (0.005, 0.1)


@dataclass(frozen=True, eq=False)
class Frame:
    """An applicator frame (see the module docstring).

    Attributes
    ----------
    centre_m : (3,) ndarray
        Origin, m.
    normal : (3,) ndarray
        Unit cranial axis.
    lateral : (3,) ndarray
        Unit axis towards the patient's left, perpendicular to ``normal``.
    scale_m : float
        The family's length scale (the ring radius for a ring), m.
    """

    centre_m: np.ndarray
    normal: np.ndarray
    lateral: np.ndarray
    scale_m: float

    @property
    def anterior(self) -> np.ndarray:
        """Unit ``lateral x normal`` (anterior in DICOM LPS), (3,)."""
        return np.cross(self.lateral, self.normal)


def fit_circle(points_m) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Least-squares circle through 3-D points (plane by SVD, then an algebraic circle fit).

    Parameters
    ----------
    points_m : (n, 3) array_like, n >= 3
        Points in metres.

    Returns
    -------
    centre_m : (3,) ndarray
    normal : (3,) ndarray
        Unit plane normal, sign arbitrary (the caller orients it).
    radius_m : float
    rms_m : float
        Root-mean-square distance of the points from the circle, in the plane.

    Raises
    ------
    GeometryError
        Fewer than 3 points, not (n, 3), or not finite.
    """
    p = np.asarray(points_m, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3 or not np.isfinite(p).all():
        raise GeometryError("fit_circle: points_m must be finite (n >= 3, 3) in metres")
    c0 = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c0)
    e1, e2, nrm = vt[0], vt[1], vt[2]
    x = (p - c0) @ e1
    y = (p - c0) @ e2
    a = np.c_[2 * x, 2 * y, np.ones_like(x)]
    sol, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    cx, cy, c = sol
    radius = float(np.sqrt(c + cx * cx + cy * cy))
    centre = c0 + cx * e1 + cy * e2
    res = np.sqrt((x - cx) ** 2 + (y - cy) ** 2) - radius
    return centre, nrm, radius, float(np.sqrt(np.mean(res**2)))


def patient_left_in_plane(normal) -> np.ndarray:
    """DICOM +x with its component along the unit ``normal`` removed, normalised (+y when the
    normal is within 1e-6 of +x), (3,)."""
    n = np.asarray(normal, dtype=float)
    lat = np.array([1.0, 0.0, 0.0]) - n[0] * n
    if np.linalg.norm(lat) < 1e-6:
        lat = np.array([0.0, 1.0, 0.0]) - n[1] * n
    return lat / np.linalg.norm(lat)


def fit_frame(centrelines) -> Frame:
    """The frame of channels without a family frame (see the module docstring).

    Parameters
    ----------
    centrelines : sequence of Centreline
        Every channel's centreline (s from the entry to the tip).

    Returns
    -------
    Frame

    Raises
    ------
    GeometryError
        No centrelines.
    """
    cls = tuple(centrelines)
    if not cls:
        raise GeometryError("fit_frame: no channel centrelines to fit a frame to")
    pts = np.vstack([np.asarray(c.position(np.linspace(0.0, c.length_m, 101)), dtype=float)
                     for c in cls])  # fmt: skip
    tips = np.array([np.asarray(c.position(c.length_m), dtype=float) for c in cls])
    entries = np.array([np.asarray(c.position(0.0), dtype=float) for c in cls])
    axis = np.linalg.svd(pts - pts.mean(axis=0))[2][0]
    if float((tips.mean(axis=0) - entries.mean(axis=0)) @ axis) < 0.0:
        axis = -axis
    try:
        radius = fit_circle(pts)[2]
    except (GeometryError, np.linalg.LinAlgError, ValueError):  # pragma: no cover - degenerate
        radius = SCALE_RANGE_M[1]
    if not np.isfinite(radius):
        radius = SCALE_RANGE_M[1]
    scale = float(np.clip(radius, *SCALE_RANGE_M))
    return Frame(tips.mean(axis=0), axis, patient_left_in_plane(axis), scale)


def frame_of(app) -> Frame:
    """The frame of an applicator (``app.frame``), or of an object with the four frame fields
    (``ring_centre_m``, ``ring_normal``, ``ring_lateral``, ``ring_radius_m``: a stand-in)."""
    frame = getattr(app, "frame", None)
    if isinstance(frame, Frame):
        return frame
    return Frame(app.ring_centre_m, app.ring_normal, app.ring_lateral, app.ring_radius_m)
