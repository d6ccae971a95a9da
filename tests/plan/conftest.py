"""Fixtures for the plan tests: an idealised ring (circle of radius 13 mm in the z = 0 plane)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import tg43

RING_RADIUS_MM = 13.0


def ring_path_mm(radius_mm=RING_RADIUS_MM, step_mm=2.5, n=30, phi0_deg=150.0):
    """Positions on a circle in the z = 0 plane, most distal first.

    Relative position p sits at azimuth phi0 - p / R (rad): seen from +z, relative positions
    increase clockwise, so the distal direction (towards p = 0) is counter-clockwise.
    """
    p = np.arange(n) * step_mm
    phi = np.deg2rad(phi0_deg) - p / radius_mm
    return np.column_stack([radius_mm * np.cos(phi), radius_mm * np.sin(phi), np.zeros(n)])


@pytest.fixture(scope="session")
def ring_path():
    """The :func:`ring_path_mm` helper."""
    return ring_path_mm


@pytest.fixture(scope="session")
def mhdr():
    return tg43.load_source("mhdr-v2")


@pytest.fixture
def ring_frame():
    """Ring centre at the origin, cranial = +z, patient's left = +x, radius 13 mm (in metres)."""
    return SimpleNamespace(
        name="ideal ring",
        ring_centre_m=np.zeros(3),
        ring_normal=np.array([0.0, 0.0, 1.0]),
        ring_lateral=np.array([1.0, 0.0, 0.0]),
        ring_radius_m=RING_RADIUS_MM * 1e-3,
    )
