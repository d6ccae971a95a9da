"""Parametric ring applicators, Channel and Applicator."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.geometry import (
    Applicator,
    Channel,
    GeometryError,
    Lumen,
    fit_circle,
    ring_applicator,
    tandem_channel,
)

SIZES = [(26, 45), (26, 60), (30, 45), (30, 60), (34, 45), (34, 60)]


@pytest.fixture(scope="module")
def rings():
    """The six parametric rings, built once."""
    return {(d, a): ring_applicator(d, a) for d, a in SIZES}


def ring_part_s(app):
    """Arc lengths of the circle part (stem + transition .. tip) of the ring channel (m)."""
    info = app.metadata["construction"]
    ch = app.channel("ring")
    s0 = (info["stem_mm"] + info["transition_mm"]) * 1e-3
    return np.linspace(s0, ch.centreline.length_m, 400)


def stem_angle_deg(app):
    """Angle between the stem (first 50 mm, fitted line) and the ring plane (deg)."""
    cl = app.channel("ring").centreline
    p = cl.position(np.linspace(0.0, 0.05, 101))
    _, _, vt = np.linalg.svd(p - p.mean(axis=0))
    return float(np.rad2deg(np.arcsin(abs(vt[0] @ app.ring_normal))))


def check_ring_geometry(app, diameter_mm, angle_deg):
    """Must-show 4: radius = diameter/2 within 0.05 mm over the ring part, in the ring plane,
    stem angle within 0.5 degrees."""
    cl = app.channel("ring").centreline
    p = cl.position(ring_part_s(app)) - app.ring_centre_m
    height = p @ app.ring_normal
    radial = np.linalg.norm(p - height[:, None] * app.ring_normal, axis=1)
    assert np.abs(radial * 1e3 - diameter_mm / 2).max() < 0.05
    assert np.abs(height).max() * 1e3 < 0.05
    assert abs(app.ring_radius_m * 1e3 - diameter_mm / 2) < 1e-9
    assert abs(stem_angle_deg(app) - angle_deg) < 0.5


@pytest.mark.parametrize(("diameter", "angle"), SIZES)
def test_ring_radius_and_angle(rings, diameter, angle):
    """Centreline radius = diameter/2 (13, 15, 17 mm) within 0.05 mm and in the ring plane over
    the circle part; stem-to-plane angle = 45/60 deg within 0.5 deg."""
    app = rings[(diameter, angle)]
    check_ring_geometry(app, diameter, angle)
    assert app.name == f"ring{diameter}x{angle}"
    assert app.metadata["diameter_mm"] == diameter and app.metadata["angle_deg"] == angle


@pytest.mark.parametrize(("diameter", "angle"), SIZES)
def test_curvature_is_continuous(rings, diameter, angle):
    """The curvature runs 0 (stem) -> 1/R (circle) without jumps: between samples 0.05 mm apart
    it changes by < 0.002 1/mm (a C1-only join would jump by 1/R = 0.059-0.077 1/mm), it is
    < 1e-3 1/mm on the stem and 1/R within 1 % on the circle (beyond 2 mm from the join)."""
    app = rings[(diameter, angle)]
    cl = app.channel("ring").centreline
    info = app.metadata["construction"]
    s = np.arange(0.0, cl.length_m, 0.05e-3)
    k = cl.curvature(s) * 1e-3
    assert np.abs(np.diff(k)).max() < 0.002
    stem = s < (info["stem_mm"] - 2.0) * 1e-3
    assert k[stem].max() < 1e-3
    circ = s > (info["stem_mm"] + info["transition_mm"] + 2.0) * 1e-3
    assert np.abs(k[circ] * diameter / 2 - 1).max() < 0.01


def test_ring_conventions(rings):
    """26/60: the circle runs 264 deg (59.9 mm) to the tip, s_ref = tip - 5 mm, the tip at 265.5
    deg azimuth (x = 13 cos 265.5 = -1.020 mm, y = 13 sin 265.5 = -12.960 mm), the stem starts
    caudally/anteriorly (z < 0, y < 0), the lumen is the paper's U after the stem (flat at the
    1.5 mm circle, facing the ring's outside) and circular on it."""
    app = rings[(26, 60)]
    ring = app.channel("ring")
    cl = ring.centreline
    assert cl.length_m * 1e3 == pytest.approx(60 + 28 + 13 * np.deg2rad(264), abs=0.01)
    assert ring.s_ref_m == pytest.approx(cl.length_m - 5e-3, abs=1e-12)
    tip = cl.position(cl.length_m) * 1e3
    assert tip == pytest.approx([-1.020, -12.960, 0.0], abs=1e-3)
    start = cl.position(0.0)
    assert start[2] < -0.05 and start[1] < -0.04
    assert ring.lumen.radii_at(0.03) == pytest.approx((1.5e-3, 1.4e-3, np.inf))
    assert ring.lumen.radii_at(0.1) == pytest.approx((1.5e-3, 1.4e-3, 1.5e-3))
    assert ring.lumen.flat_side.towards == "ring_outside" and "Straathof" in ring.lumen.source
    assert app.channel_names == ("ring", "tandem")


def test_tandem_along_the_normal_through_the_centre(rings):
    """The tandem is the straight line x = y = 0 from z = -60 mm to z = +60 mm (length 120 mm),
    lumen r_b 1.25 mm, s_ref 5 mm below its tip."""
    tan = rings[(30, 45)].channel("tandem")
    s = np.linspace(0.0, tan.length_m, 50)
    p = tan.centreline.position(s) * 1e3
    assert np.abs(p[:, :2]).max() < 1e-9
    assert p[:, 2] == pytest.approx(s * 1e3 - 60.0, abs=1e-9)
    assert tan.lumen.radii_at(0.0)[0] == pytest.approx(1.25e-3)
    assert tan.s_ref_m == pytest.approx(0.115)


def test_fit_circle_recovers_the_ring(rings):
    """A least-squares circle through the ring part gives centre 0, normal +-z, radius 13 mm."""
    app = rings[(26, 60)]
    p = app.channel("ring").centreline.position(ring_part_s(app))
    c, n, r, rms = fit_circle(p)
    assert np.abs(c).max() < 1e-6 and abs(abs(n[2]) - 1) < 1e-9
    assert r == pytest.approx(0.013, abs=1e-6) and rms < 1e-6


def test_channel_and_applicator_validation(rings):
    """Bad channels/applicators raise GeometryError naming the field."""
    ring = rings[(26, 60)].channel("ring")
    lum = Lumen.circular(1.5e-3, 1.4e-3)
    with pytest.raises(GeometryError, match="s_ref_m"):
        Channel("ring", ring.centreline, lum, 1.0)
    with pytest.raises(GeometryError, match="measured_path_m"):
        Channel("ring", ring.centreline, lum, 0.1, measured_path_m=np.zeros((3, 2)))
    with pytest.raises(GeometryError, match="measured_step_m"):
        Channel("ring", ring.centreline, lum, 0.1, measured_step_m=-1.0)
    kw = dict(ring_centre_m=np.zeros(3), ring_normal=[0, 0, 1.0], ring_lateral=[1.0, 0, 0],
              ring_radius_m=0.013)  # fmt: skip
    with pytest.raises(GeometryError, match="duplicated"):
        Applicator("x", (ring, ring), **kw)
    with pytest.raises(GeometryError, match="ring_normal"):
        Applicator("x", (ring,), **{**kw, "ring_normal": [0, 0, 2.0]})
    with pytest.raises(GeometryError, match="ring_lateral"):
        Applicator("x", (ring,), **{**kw, "ring_lateral": [0, 0.6, 0.8]})
    with pytest.raises(GeometryError, match="metres"):
        Applicator("x", (ring,), **{**kw, "ring_radius_m": 13.0})
    app = Applicator("x", (ring,), **kw)
    with pytest.raises(GeometryError, match="available: ring"):
        app.channel("tandem")
    assert np.allclose(app.ring_anterior, [0, -1, 0])
    with pytest.raises(GeometryError, match="angle_deg"):
        ring_applicator(26, 0)
    with pytest.raises(GeometryError, match="tandem_channel"):
        tandem_channel(length_mm=3.0)


@pytest.mark.parametrize(("diameter", "angle"), SIZES)
def test_normal_never_flips(rings, diameter, angle):
    """The normal field is continuous along the whole channel (consecutive normals 0.05 mm apart
    differ by < 1 deg): on the straight stem it is transported from the transition, so the
    spline's curvature ripple (< 1 1/m) near the stem/transition join cannot flip it. On the
    circle it points to the ring centre (the flat of the U-lumen is outside)."""
    app = rings[(diameter, angle)]
    for ch in app.channels:
        cl = ch.centreline
        s = np.arange(0.0, cl.length_m, 0.05e-3)
        n = cl.normal(s)
        assert np.sum(n[1:] * n[:-1], axis=1).min() > np.cos(np.deg2rad(1.0))
    cl = app.channel("ring").centreline
    s = cl.length_m - 0.01
    p = cl.position(s)
    assert cl.normal(s) == pytest.approx(-p / np.linalg.norm(p), abs=1e-6)
