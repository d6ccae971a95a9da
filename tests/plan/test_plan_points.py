"""Dose point definitions in the ring frame."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.errors import RingQAError
from ringqa.plan import POINT_NAMES, DosePointSpec, applicator_dose_points, dose_points_from_frame


def test_default_points_in_ideal_frame(ring_frame):
    """Centre 0, normal +z, left +x, R = 13 mm; defaults h = 26.9, a = 20, offset 4, depth 5.

    Expected by hand: A left (20, 0, 26.9), A right (-20, 0, 26.9), surface left (19.25, 0, 0),
    surface right (-19.25, 0, 0), 5 mm deeper (24.25, 0, 0) and (-24.25, 0, 0).
    """
    pts = applicator_dose_points(ring_frame)
    assert tuple(p.name for p in pts) == POINT_NAMES
    expected = [(20, 0, 26.9), (-20, 0, 26.9), (19.25, 0, 0), (-19.25, 0, 0), (24.25, 0, 0),
                (-24.25, 0, 0)]  # fmt: skip
    for p, e in zip(pts, expected, strict=True):
        np.testing.assert_allclose(p.position_mm, e, atol=1e-12)


@given(
    ax=st.floats(-1, 1), ay=st.floats(-1, 1), az=st.floats(0.2, 1),
    tilt=st.floats(-0.5, 0.5), cx=st.floats(-50, 50),
)  # fmt: skip
def test_points_follow_the_frame(ax, ay, az, tilt, cx):
    """In any frame: distances are frame invariant (A: |A - c| = sqrt(20^2 + 26.9^2) = 33.52 mm;
    the vaginal points lie in the ring plane at R + 6.25 and R + 11.25 mm), and left is
    +lateral."""
    n = np.array([ax, ay, az]) / np.linalg.norm([ax, ay, az])
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    lat = np.cross(n, helper)
    lat = lat / np.linalg.norm(lat) + tilt * n  # not orthogonal: must be projected
    c = np.array([cx, 1.0, -2.0])
    pts = {p.name: p.position_mm for p in dose_points_from_frame(c, n, lat, 13.0)}
    for side in ("left", "right"):
        assert np.linalg.norm(pts[f"point_a_{side}"] - c) == pytest.approx(np.hypot(20, 26.9))
        assert np.dot(pts[f"point_a_{side}"] - c, n) == pytest.approx(26.9)
        assert np.linalg.norm(pts[f"surface_{side}"] - c) == pytest.approx(19.25)
        assert np.dot(pts[f"surface_{side}"] - c, n) == pytest.approx(0.0, abs=1e-9)
        assert np.linalg.norm(pts[f"depth5_{side}"] - pts[f"surface_{side}"]) == pytest.approx(5)
    lat_unit = lat - np.dot(lat, n) * n
    assert (
        np.dot(pts["surface_left"] - c, lat_unit) > 0 > np.dot(pts["surface_right"] - c, lat_unit)
    )


def test_configurable_spec():
    """offset 6 mm, depth 10 mm: surface at 19 mm, deeper point at 29 mm from the centre."""
    spec = DosePointSpec(surface_offset_mm=6.0, depth_mm=10.0, point_a_height_mm=20.0)
    pts = {p.name: p for p in dose_points_from_frame([0, 0, 0], [0, 0, 1], [1, 0, 0], 13.0, spec)}
    np.testing.assert_allclose(pts["surface_left"].position_mm, [19, 0, 0])
    np.testing.assert_allclose(pts["depth5_right"].position_mm, [-29, 0, 0])
    np.testing.assert_allclose(pts["point_a_left"].position_mm, [20, 0, 20])


def test_bad_inputs_are_named():
    with pytest.raises(RingQAError, match="depth_mm"):
        DosePointSpec(depth_mm=-1)
    with pytest.raises(RingQAError, match="ring_lateral"):
        dose_points_from_frame([0, 0, 0], [0, 0, 1], [0, 0, 2], 13.0)
    with pytest.raises(RingQAError, match="ring_radius"):
        dose_points_from_frame([0, 0, 0], [0, 0, 1], [1, 0, 0], 0.0)


def test_surface_offset_is_the_oncentra_ring_mesh(repo_root):
    """The default lateral surface offset (6.25 mm) is the ring's outer radius in the ring plane
    minus the centreline radius, measured on the surface mesh ("skin") of the ring part in the
    Oncentra library of the shipped example: the mesh vertices within 10 deg of the lateral
    directions reach 19.25 mm from the ring axis around a 13.0 mm centreline circle (fitted)."""
    import re

    import pydicom

    from ringqa.geometry import fit_circle
    from ringqa.io.oncentra import decode_library, parse_library

    plan = repo_root / "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"
    ds = pydicom.dcmread(plan)
    text = decode_library(ds.ApplicationSetupSequence[0][0x300B, 0x100D].value)
    ring = parse_library(text).parts["110350-06"]  # "Interstitial Ring CT/MR d=26mm, 60 deg"
    start = text.index("<skin>", text.index("110350-06"))
    block = text[start : text.index("</skin>", start)]
    pos = np.vstack([np.array(t.split("\\"), dtype=float).reshape(-1, 3)
                     for t in re.findall(r"<positions>([^<]*)</positions>", block)])  # fmt: skip
    c, n, r, _ = fit_circle(ring.centre_curve[:60])  # the circle (the curve is stored tip first)
    assert r == pytest.approx(13.0, abs=1e-6)
    d = pos - c
    h = d @ n
    inplane = d - np.outer(h, n)
    rho = np.linalg.norm(inplane, axis=1)
    lateral = np.abs(inplane[:, 0]) > rho * np.cos(np.radians(10))  # x is lateral in the part
    near = lateral & (np.abs(h) < 15) & (rho > 4)
    assert rho[near].max() - r == pytest.approx(DosePointSpec().surface_offset_mm, abs=0.05)
