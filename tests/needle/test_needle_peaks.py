"""The measurement filter and the 1st peak / plateau / 2nd peak extraction (ringqa.needle.peaks)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringqa.geometry import Centreline, Channel, Lumen, s_channel, s_channel_layout
from ringqa.needle.peaks import FILTER_WINDOW_MM, bend_windows_mm, force_peaks, moving_average


def test_filter_window_is_the_papers():
    """241 samples at 5 kHz and 5 mm/s: 241 / 5000 s x 5 mm/s = 0.241 mm of depth."""
    assert FILTER_WINDOW_MM == pytest.approx(0.241, abs=1e-12)


def test_moving_average_keeps_a_straight_line():
    """The average of a linear force over a centred window is its value at the centre (1e-12);
    at the ends the window shrinks to the data, so the first value is f(w/4) = 2 + 3 w/4."""
    x = np.linspace(0.0, 5.0, 201)
    f = 2.0 + 3.0 * x
    g = moving_average(x, f)
    inner = (x > 0.2) & (x < 4.8)
    assert g[inner] == pytest.approx(f[inner], abs=1e-12)
    assert g[0] == pytest.approx(2.0 + 3.0 * FILTER_WINDOW_MM / 4.0, abs=1e-12)


def test_moving_average_of_a_step():
    """A unit step at 1 mm sampled every 0.01 mm: its interpolant ramps over [0.99, 1.00]. At
    x = 1 the window [0.8795, 1.1205] holds 0.1205 mm of 1 plus half the ramp (0.005): average
    (0.1205 + 0.005) / 0.241 = 0.52075; 0.2 mm before the step it is still 0, 0.2 mm after 1."""
    x = np.round(np.arange(0.0, 2.0 + 1e-9, 0.01), 10)
    f = (x >= 1.0).astype(float)
    g = moving_average(x, f)
    assert g[100] == pytest.approx((0.1205 + 0.005) / 0.241, abs=1e-9)
    assert g[80] == 0.0 and g[120] == 1.0


def test_moving_average_equals_the_5_khz_moving_mean():
    """On a force sampled like the measurement (5 kHz at 5 mm/s: every 0.001 mm) the filter
    agrees with MATLAB's central movmean over 241 samples (the paper's) to 1e-4 of the peak
    (0.001 N; observed 7e-6 N): a 10 N peak of 2 mm width with a 0.5 N ripple of 0.3 mm
    period, which both filters damp (by up to 0.4 N here)."""
    x = np.arange(0.0, 20.0, 0.001)
    f = 10.0 * np.exp(-(((x - 10.0) / 2.0) ** 2)) + 0.5 * np.sin(2 * np.pi * x / 0.3)
    ours = moving_average(x, f)
    kernel = np.ones(241) / 241.0
    theirs = np.convolve(f, kernel, mode="same")
    inner = slice(200, -200)
    assert np.abs(ours[inner] - theirs[inner]).max() < 1e-3
    assert np.abs(ours[inner] - f[inner]).max() > 0.1  # the filter does something


def test_moving_average_leaves_unreached_depths_nan():
    """Depths a jammed run did not reach stay NaN; the reached part is filtered on its own."""
    x = np.linspace(0.0, 10.0, 41)
    f = np.where(x <= 6.0, 1.0, np.nan)
    g = moving_average(x, f)
    assert np.all(np.isnan(g[x > 6.0]))
    assert g[x <= 6.0] == pytest.approx(1.0)


def test_bends_of_the_paper_channel():
    """s_channel(35): bend 1 from 10 to 10 + 35 t1 = 25.24 mm, bend 2 from 80.91 to 96.15 mm
    (t1 = 24.94 deg, d2 = 55.68 mm); the half-curvature threshold finds them within 0.5 mm (the
    spline rounds the curvature jumps over ~0.5 mm). A straight channel has none."""
    lay = s_channel_layout(35.0)
    found = bend_windows_mm(s_channel(35.0))
    assert len(found) == 2
    for (a, b), (a0, b0) in zip(found, (lay.bend1_mm, lay.bend2_mm), strict=True):
        assert a == pytest.approx(a0, abs=0.5) and b == pytest.approx(b0, abs=0.5)
    pts = np.c_[np.linspace(0.0, 0.12, 121), np.zeros(121), np.zeros(121)]
    straight = Channel("straight", Centreline.from_points(pts), Lumen.circular(1.3e-3, 1.2e-3), 0.1)
    assert bend_windows_mm(straight) == []


def _synthetic():
    """0 to 10 mm; a rise to 10 N at 25 mm; down to a 4 N plateau from 35 to 80 mm with a
    +-0.2 N ripple; a rise to 13 N at 96 mm; down to 7 N at 120 mm (0.25 mm grid)."""
    x = np.arange(0.0, 120.0 + 1e-9, 0.25)
    knots = [(0, 0), (10, 0), (25, 10), (35, 4), (80, 4), (96, 13), (110, 7), (120, 7)]
    f = np.interp(x, *zip(*knots, strict=True))
    ripple = 0.2 * np.sin(2 * np.pi * x / 1.6) * ((x >= 35) & (x <= 80))
    return x, f + ripple


def test_peaks_of_a_synthetic_curve():
    """Bends (10, 25) and (81, 96) mm: split at 53 mm; 1st peak 10 N at 25 mm, 2nd 13 N at
    96 mm; the plateau region is where the force is within 0.1 x 10 N of its lowest value
    (3.8 N) between the peaks: 35-80 mm (plus the flanks down to 4.8 N), its median 4.0 N
    (0.05 N, the ripple is symmetric)."""
    x, f = _synthetic()
    p = force_peaks(x, f, [(10.0, 25.0), (81.0, 96.0)])
    assert p.split_mm == pytest.approx(53.0)
    assert (p.peak1_n, p.peak1_depth_mm) == pytest.approx((10.0, 25.0))
    assert (p.peak2_n, p.peak2_depth_mm) == pytest.approx((13.0, 96.0))
    assert p.plateau_n == pytest.approx(4.0, abs=0.05)
    assert 33.0 < p.plateau_from_mm < 35.5 and 80.0 < p.plateau_to_mm < 82.0
    assert p.plateau_depth_mm == pytest.approx(0.5 * (p.plateau_from_mm + p.plateau_to_mm))


def test_peaks_of_an_incomplete_or_bendless_run():
    """A run that stopped at 90 mm reports its 1st peak only (the 2nd peak's and the plateau's
    search windows were not covered); a channel with fewer than two bends reports nothing."""
    x, f = _synthetic()
    f = np.where(x <= 90.0, f, np.nan)
    p = force_peaks(x, f, [(10.0, 25.0), (81.0, 96.0)], complete=False)
    assert p.peak1_n == pytest.approx(10.0)
    assert math.isnan(p.peak2_n) and math.isnan(p.plateau_n)
    p = force_peaks(x, f, [(10.0, 25.0)])
    assert all(math.isnan(v) for v in p.as_dict().values())
