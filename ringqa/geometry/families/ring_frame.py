"""The ring family's frame: a circle fitted to the ring channel, and its axes.

One fit, used wherever a frame is not given: an applicator file without ``ring_frame``
(:mod:`ringqa.io.applicator_file`), an RT Plan's applicator library
(:mod:`ringqa.io.plan_applicator`) and the stand-in dose points of the accuracy study for
analytic channels (:mod:`ringqa.accuracy.dose`).

The fit
-------
1. Plane: through the points' mean, normal = the singular vector of the smallest singular value
   of the centred points (SVD; total least squares).
2. Circle: an algebraic (Kasa) least-squares circle in that plane's coordinates,
   ``x^2 + y^2 = 2 a x + 2 b y + c``, centre ``(a, b)``, radius ``sqrt(c + a^2 + b^2)``.
   Exact for points on a circle; for noisy points it is close to the geometric fit when the
   points cover a good part of the circle.

The axes (DICOM patient coordinates, LPS: +x patient left, +y posterior, +z cranial)
----------------------------------------------------------------------------------------
- ``normal``: unit ring-plane normal pointing CRANIALLY: towards ``cranial_point_m`` (the
  tandem tip) when given, else away from ``caudal_point_m`` (the ring channel's entry) when
  given, else the SVD's sign (arbitrary).
- ``lateral``: unit vector in the ring plane towards the patient's LEFT: DICOM +x projected into
  the plane (``lateral="patient_left"``); if the plane is within 1e-6 of containing the normal to
  +x (a sagittal ring), +y projected instead. With ``lateral="points_mean"`` (a stand-in where
  the patient frame is unknown, as for analytic channels): from the centre towards the points'
  mean, or the first in-plane principal axis when the mean lies within 1e-12 m of the centre.
- ``anterior`` = ``lateral x normal`` (with lateral +x and normal +z this is -y: anterior in
  DICOM LPS). (lateral, -anterior, normal) = (left, posterior, cranial) is right-handed, like
  DICOM's (x, y, z).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from ringqa.geometry.centreline import GeometryError
from ringqa.geometry.frame import fit_circle

__all__ = ["RingFrame", "fit_ring_frame"]


@dataclass(frozen=True)
class RingFrame:
    """A ring's frame: the fitted circle and its axes (conventions in the module docstring).

    Attributes
    ----------
    centre_m : (3,) ndarray
        Circle centre, m.
    normal : (3,) ndarray
        Unit ring-plane normal (cranial when a cranial or caudal point was given).
    lateral : (3,) ndarray
        Unit in-plane vector towards the patient's left (or the stand-in direction).
    radius_m : float
        Circle radius, m.
    rms_m : float
        RMS distance of the fitted points from the circle, in the plane, m.
    """

    centre_m: np.ndarray
    normal: np.ndarray
    lateral: np.ndarray
    radius_m: float
    rms_m: float

    @property
    def anterior(self) -> np.ndarray:
        """Unit in-plane vector ``lateral x normal`` (anterior for a patient frame), (3,)."""
        return np.cross(self.lateral, self.normal)


def fit_ring_frame(
    points_m,
    *,
    cranial_point_m=None,
    caudal_point_m=None,
    lateral: Literal["patient_left", "points_mean"] = "patient_left",
) -> RingFrame:
    """Fit a ring frame to points on the ring's circle (see the module docstring).

    Parameters
    ----------
    points_m : (n, 3) array_like, n >= 3
        Points on the ring channel's circular part, m.
    cranial_point_m : (3,) array_like, optional
        A point cranial of the ring plane (the tandem tip): the normal points to its side.
    caudal_point_m : (3,) array_like, optional
        A point caudal of the ring plane (the channel entry): the normal points away from it.
        Used only without ``cranial_point_m``.
    lateral : {"patient_left", "points_mean"}
        ``"patient_left"``: DICOM +x projected into the ring plane (+y for a sagittal ring);
        ``"points_mean"``: from the centre towards the points' mean (stand-in frame).

    Returns
    -------
    RingFrame

    Raises
    ------
    GeometryError
        Bad points (see :func:`fit_circle`) or an unknown ``lateral``.
    """
    centre, normal, radius, rms = fit_circle(points_m)
    if cranial_point_m is not None:
        if float((np.asarray(cranial_point_m, dtype=float) - centre) @ normal) < 0:
            normal = -normal
    elif caudal_point_m is not None:
        if float((np.asarray(caudal_point_m, dtype=float) - centre) @ normal) > 0:
            normal = -normal
    if lateral == "patient_left":
        lat = np.array([1.0, 0.0, 0.0]) - normal[0] * normal
        if np.linalg.norm(lat) < 1e-6:  # the ring plane is sagittal: +x is its normal
            lat = np.array([0.0, 1.0, 0.0]) - normal[1] * normal
        lat = lat / np.linalg.norm(lat)
    elif lateral == "points_mean":
        p = np.asarray(points_m, dtype=float)
        lat = p.mean(axis=0) - centre
        lat = lat - np.dot(lat, normal) * normal
        if np.linalg.norm(lat) > 1e-12:
            lat = lat / np.linalg.norm(lat)
        else:  # points all round the circle: their first principal axis
            lat = np.linalg.svd(p - p.mean(axis=0))[2][0]
    else:
        raise GeometryError(
            f"fit_ring_frame: lateral = {lateral!r}; choose 'patient_left' or 'points_mean'"
        )
    return RingFrame(
        centre_m=centre, normal=normal, lateral=lat, radius_m=float(radius), rms_m=float(rms)
    )
