"""Geometry function G_L and its behaviour near the source axis.

Hand-derived values (L = 0.35 cm, r0 = 1 cm, theta0 = 90 deg):
- G_L(1, 90) = 2 atan(L / 2) / L = 2 atan(0.175) / 0.35 = 0.989975 cm^-2.
- G_L(2, 90) / G_L(1, 90) = [2 atan(0.0875) / (0.35 * 2)] / 0.989975 = 0.251890.
- G_L(2, 0) / G_L(1, 90) = [1 / (4 - 0.030625)] / 0.989975 = 0.254480 (exact on-axis limit).
Through the public API the dose rate at those points is Lambda * ratio * g_L(r) * F(r, theta),
with g_L(2) = 1.0037, F(2, 90) = 1, F(2, 0) = 0.6256 read from the Flexisource tables.
"""

from __future__ import annotations

import numpy as np
import pytest

import tg43
from tg43.reference import geometry_factor_line

ORIGIN = [[0.0, 0.0, 0.0]]
UP = [[0.0, 0.0, 1.0]]


def test_geometry_factor_reference_values():
    g0 = geometry_factor_line(1.0, np.pi / 2, 0.35)
    assert g0 == pytest.approx(0.989975, abs=5e-7)
    assert geometry_factor_line(2.0, np.pi / 2, 0.35) / g0 == pytest.approx(0.251890, abs=5e-7)
    assert geometry_factor_line(2.0, 0.0, 0.35) / g0 == pytest.approx(0.254480, abs=5e-7)


def test_kernel_geometry_through_public_api():
    """Dose rate = Lambda x G ratio x g_L x F at (1, 90), (2, 90), (2, 0) and (2, 180) deg."""
    src = tg43.load_source("flexisource")
    lam = src.dose_rate_constant
    pts = [[10.0, 0, 0], [20.0, 0, 0], [0, 0, 20.0], [0, 0, -20.0]]
    got = tg43.dose_rate_per_sk(src, ORIGIN, UP, pts)[:, 0]
    expected = [
        lam,
        lam * 0.251890 * 1.0037,
        lam * 0.254480 * 1.0037 * 0.6256,
        lam * 0.254480 * 1.0037 * 0.5138,
    ]
    np.testing.assert_allclose(got, expected, rtol=2e-6)


@pytest.mark.parametrize("name", ["flexisource", "mhdr-v2", "vs2000"])
@pytest.mark.parametrize("r_mm", [3.0, 5.0, 12.0, 47.0, 130.0])
def test_dose_rate_continuous_at_the_axis(name, r_mm):
    """theta -> 0 and theta -> 180 deg: tiny off-axis angles agree with the exact on-axis value.

    Up to theta = 3e-8 rad the whole dose rate moves by < 1e-6 relative (F's steepest slope near
    the axis, VS2000 ~ 6 per rad, contributes < 2e-7). For the geometry factor alone (dose rate
    divided by the interpolated F) the off-axis formula at 1e-6 rad must meet the on-axis limit
    1 / (r^2 - L^2/4) within 1e-7 (the true change is O(theta^2); theta itself is only known to
    ~1e-8 rad near the axis from rounding of y = sqrt(r^2 - z^2)); a wrong on-axis limit (e.g.
    1/r^2) would jump by percent.
    """
    from tg43.reference import anisotropy_function

    src = tg43.load_source(name)
    for sign in (1.0, -1.0):
        eps = np.array([0.0, 1e-9, 1e-8, 3e-8, 1e-6, 1e-5])
        pts = np.column_stack([r_mm * np.sin(eps), np.zeros(eps.size), sign * r_mm * np.cos(eps)])
        rate = tg43.dose_rate_per_sk(src, ORIGIN, UP, pts)[:, 0]
        rel = np.abs(rate[1:4] / rate[0] - 1.0)
        assert rel.max() < 1e-6, (name, r_mm, sign, rel)
        theta_deg = np.rad2deg(np.where(sign > 0, eps, np.pi - eps))
        geom = rate / anisotropy_function(src, r_mm / 10.0, theta_deg)
        assert np.abs(geom[1:] / geom[0] - 1.0).max() < 1e-7, (name, r_mm, sign)


def test_on_axis_limit_equals_geometry_formula():
    """On the axis G_L = 1 / (r^2 - L^2/4): for VS2000 (L = 0.5 cm) at r = 0.5 cm this is
    1 / (0.25 - 0.0625) = 5.3333 cm^-2, four times the point-source 1/r^2 = 4 would be wrong."""
    src = tg43.load_source("vs2000")
    g0 = geometry_factor_line(1.0, np.pi / 2, 0.5)  # 2 atan(0.25)/0.5 = 0.979915
    assert g0 == pytest.approx(2 * np.arctan(0.25) / 0.5)
    got = tg43.dose_rate_per_sk(src, ORIGIN, UP, [[0, 0, 5.0]])[0, 0]
    g_l = np.interp(0.5, src.gl_r_cm, src.gl)
    f = src.f[0, list(src.f_r_cm).index(0.5)]
    assert got == pytest.approx(src.dose_rate_constant * (1 / 0.1875) / g0 * g_l * f, rel=1e-12)


def test_extrapolation_beyond_table_is_linear_and_never_negative():
    """Beyond the largest r, g_L continues the line through its last two values; far away the
    dose rate is clamped at 0 instead of going negative."""
    src = tg43.load_source("flexisource")
    r = np.array([12.0, 14.0])
    g_expected = 0.9349 + (r - 10.0) * (0.9349 - 0.968) / 2.0
    got = tg43.dose_rate_per_sk(src, ORIGIN, UP, np.column_stack([r * 10, 0 * r, 0 * r]))[:, 0]
    geom = geometry_factor_line(r, np.pi / 2, 0.35) / geometry_factor_line(1.0, np.pi / 2, 0.35)
    np.testing.assert_allclose(got, src.dose_rate_constant * geom * g_expected, rtol=1e-12)
    far = tg43.dose_rate_per_sk(src, ORIGIN, UP, [[2000.0, 0, 0]])[0, 0]
    assert far == 0.0


def test_numba_and_numpy_implementations_agree():
    """The kernel (lookup tables, atan2 for beta) and the plain NumPy formula (binary search,
    two-angle beta) are written independently; random geometry, agreement to 1e-10."""
    from tg43.reference import dose_rate_per_sk_numpy

    rng = np.random.default_rng(7)
    for name in tg43.known_sources():
        src = tg43.load_source(name)
        pos = rng.uniform(-20, 20, (17, 3))
        dirs = rng.normal(size=(17, 3))
        dirs /= np.linalg.norm(dirs, axis=1)[:, None]
        pts = rng.uniform(-150, 150, (300, 3))
        a = tg43.dose_rate_per_sk(src, pos, dirs, pts)
        b = dose_rate_per_sk_numpy(src, pos, dirs, pts)
        np.testing.assert_allclose(a, b, rtol=1e-10, err_msg=name)
