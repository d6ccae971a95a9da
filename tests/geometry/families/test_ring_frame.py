"""The one ring-frame fit (ringqa.geometry.fit_ring_frame): circle, plane and axes conventions.

The test circle: radius 13 mm around c = (10, -20, 30) mm in the plane with unit normal
n = (0, 0.6, 0.8) (tilted 36.87 deg from the z = 0 plane about x); in-plane axes u = (1, 0, 0)
and v = n x u = (0, 0.8, -0.6). Points at phi = 0.2 ... 4.0 rad (about 218 deg of arc):
p = c + R (cos phi u + sin phi v), all in metres.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.geometry import GeometryError, RingFrame, fit_ring_frame

R_M = 13e-3
C_M = np.array([10e-3, -20e-3, 30e-3])
N = np.array([0.0, 0.6, 0.8])
U = np.array([1.0, 0.0, 0.0])
V = np.cross(N, U)
PHI = np.linspace(0.2, 4.0, 30)
POINTS_M = C_M + R_M * (np.outer(np.cos(PHI), U) + np.outer(np.sin(PHI), V))


def test_known_circle_in_a_tilted_plane():
    """Centre, radius and normal to 1e-9 (m / unit vector); rms 0 (the points are exact);
    the normal points towards a cranial point c + 5 mm n (here +n)."""
    f = fit_ring_frame(POINTS_M, cranial_point_m=C_M + 5e-3 * N)
    assert isinstance(f, RingFrame)
    np.testing.assert_allclose(f.centre_m, C_M, atol=1e-9)
    assert f.radius_m == pytest.approx(R_M, abs=1e-9)
    np.testing.assert_allclose(f.normal, N, atol=1e-9)
    assert f.rms_m < 1e-12


def test_normal_sign_from_cranial_or_caudal_point():
    """A cranial point below the plane (c - 5 mm n) turns the normal to -n; a caudal point below
    the plane keeps +n; the cranial point wins when both are given."""
    below = C_M - 5e-3 * N
    np.testing.assert_allclose(fit_ring_frame(POINTS_M, cranial_point_m=below).normal, -N,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(fit_ring_frame(POINTS_M, caudal_point_m=below).normal, N, atol=1e-9)
    both = fit_ring_frame(POINTS_M, cranial_point_m=below, caudal_point_m=below)
    np.testing.assert_allclose(both.normal, -N, atol=1e-9)


def test_axes_convention_patient_left():
    """lateral = DICOM +x projected into the plane: +x lies in this plane, so lateral = (1, 0, 0);
    anterior = lateral x normal = (1, 0, 0) x (0, 0.6, 0.8) = (0, -0.8, 0.6); (left, posterior,
    cranial) is right-handed like DICOM's (x, y, z): lateral x (-anterior) = normal."""
    f = fit_ring_frame(POINTS_M, cranial_point_m=C_M + 5e-3 * N)
    np.testing.assert_allclose(f.lateral, U, atol=1e-9)
    np.testing.assert_allclose(f.anterior, [0.0, -0.8, 0.6], atol=1e-9)
    np.testing.assert_allclose(np.cross(f.lateral, -f.anterior), f.normal, atol=1e-12)


def test_sagittal_ring_falls_back_to_posterior():
    """A ring in the plane x = const (normal +x): +x has no in-plane part, so lateral = +y
    projected = (0, 1, 0)."""
    pts = np.column_stack([np.full(PHI.size, 0.01), R_M * np.cos(PHI), R_M * np.sin(PHI)])
    f = fit_ring_frame(pts, caudal_point_m=[-1.0, 0.0, 0.0])
    np.testing.assert_allclose(f.normal, [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(f.lateral, [0.0, 1.0, 0.0], atol=1e-12)


def test_points_mean_stand_in():
    """lateral = 'points_mean': from the centre towards the points' mean. The arc is symmetric
    about phi = 2.1 rad, so that direction is cos(2.1) u + sin(2.1) v."""
    f = fit_ring_frame(POINTS_M, lateral="points_mean")
    np.testing.assert_allclose(f.lateral, np.cos(2.1) * U + np.sin(2.1) * V, atol=1e-9)
    assert abs(f.lateral @ f.normal) < 1e-12


def test_bad_input_names_the_argument():
    with pytest.raises(GeometryError, match="points_m"):
        fit_ring_frame(POINTS_M[:2])
    with pytest.raises(GeometryError, match="lateral"):
        fit_ring_frame(POINTS_M, lateral="left")  # type: ignore[arg-type]
