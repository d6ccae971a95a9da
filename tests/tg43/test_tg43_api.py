"""Public API behaviour: plan dose, decay, rotation invariance, direction flips, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tg43
from tg43 import TG43Error

ORIGIN = [[0.0, 0.0, 0.0]]
UP = [[0.0, 0.0, 1.0]]


def test_plan_dose_is_sk_times_rate_times_time(flexisource):
    """One dwell, S_K = 40000 U, 100 s at (1 cm, 90 deg): D = S_K Lambda t / 3600 cGy.

    Lambda = 1.1125 cGy h^-1 U^-1 -> 40000 * 1.1125 * 100 / 3600 cGy = 1236.11 cGy = 12.3611 Gy.
    """
    dose = tg43.plan_dose_gy(flexisource, ORIGIN, UP, [100.0], 40000.0, [[10.0, 0, 0]])
    assert dose[0] == pytest.approx(40000 * 1.1125 * 100 / 3600 / 100, rel=1e-9)


def test_parallel_kernel_gives_the_same_numbers(flexisource):
    """parallel=True on a grid above PARALLEL_MIN_PAIRS (points split over the threads) and on a
    small one (one thread) equals the one-thread results bit for bit."""
    from tg43.dose import PARALLEL_MIN_PAIRS

    rng = np.random.default_rng(1)
    pos = rng.uniform(-20, 20, (7, 3))
    dirs = rng.normal(size=(7, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t = rng.uniform(1, 20, 7)
    for n_p in (50, PARALLEL_MIN_PAIRS // 7 + 100):
        pts = rng.uniform(-60, 60, (n_p, 3)) + np.array([100.0, 0, 0])
        a = tg43.plan_dose_gy(flexisource, pos, dirs, t, 30000.0, pts)
        b = tg43.plan_dose_gy(flexisource, pos, dirs, t, 30000.0, pts, parallel=True)
        np.testing.assert_array_equal(a, b)
        a = tg43.dose_rate_per_sk(flexisource, pos, dirs, pts)
        b = tg43.dose_rate_per_sk(flexisource, pos, dirs, pts, parallel=True)
        np.testing.assert_array_equal(a, b)


def test_decay_halves_dose_after_one_half_life(flexisource):
    """73.83 days after the reference date S_K (and dose) is exactly half."""
    args = (flexisource, ORIGIN, UP, [10.0], 40000.0, [[10.0, 0, 0]])
    full = tg43.plan_dose_gy(*args)[0]
    half = tg43.plan_dose_gy(
        *args, reference_date="2026-01-01T00:00:00", treatment_date="2026-03-15T19:55:12"
    )[0]
    assert half / full == pytest.approx(0.5, rel=1e-9)
    assert tg43.decay_factor() == 1.0


def test_decay_refuses_treatment_before_reference(flexisource):
    with pytest.raises(TG43Error, match="before reference_date"):
        tg43.plan_dose_gy(
            flexisource, ORIGIN, UP, [1.0], 1.0, [[10.0, 0, 0]],
            reference_date="2026-02-01", treatment_date="2026-01-01",
        )  # fmt: skip
    with pytest.raises(TG43Error, match="reference_date: missing"):
        tg43.decay_factor(treatment_date="2026-01-01")


def _rotation(axis, angle):
    """Rodrigues rotation matrix."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


@given(
    axis=st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(
        lambda v: sum(x * x for x in v) > 0.01
    ),
    angle=st.floats(0, 2 * math.pi),
    shift=st.tuples(*[st.floats(-50, 50) for _ in range(3)]),
)
def test_rotating_everything_together_leaves_doses_unchanged(axis, angle, shift):
    """D(R x + t) = D(x) for positions, directions (rotated only) and points together."""
    src = tg43.load_source("mhdr-v2")
    rng = np.random.default_rng(7)
    pos = rng.uniform(-15, 15, (5, 3))
    dirs = rng.normal(size=(5, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pts = rng.uniform(-40, 40, (30, 3))
    pts = pts[np.min(np.linalg.norm(pts[:, None] - pos[None], axis=2), axis=1) > 3.0]
    rot = _rotation(axis, angle)
    t = np.asarray(shift)
    before = tg43.dose_rate_per_sk(src, pos, dirs, pts)
    after = tg43.dose_rate_per_sk(src, pos @ rot.T + t, dirs @ rot.T, pts @ rot.T + t)
    np.testing.assert_allclose(after, before, rtol=1e-9)


@pytest.mark.parametrize("theta_deg", [10.0, 35.0, 60.0, 80.0])
def test_flipping_the_direction_swaps_theta_and_180_minus_theta(mhdr_v2, theta_deg):
    """A point at theta for direction +z is at 180 - theta for direction -z: the dose rate for
    the flipped source equals the dose rate at the mirrored point (z -> -z), and the ratio to
    the unflipped dose rate is F(r, 180 - theta) / F(r, theta) (G_L is symmetric)."""
    from tg43.reference import anisotropy_function

    th = math.radians(theta_deg)
    p = [[30 * math.sin(th), 0.0, 30 * math.cos(th)]]
    mirrored = [[30 * math.sin(th), 0.0, -30 * math.cos(th)]]
    down = [[0.0, 0.0, -1.0]]
    flipped = tg43.dose_rate_per_sk(mhdr_v2, ORIGIN, down, p)[0, 0]
    mirror = tg43.dose_rate_per_sk(mhdr_v2, ORIGIN, UP, mirrored)[0, 0]
    straight = tg43.dose_rate_per_sk(mhdr_v2, ORIGIN, UP, p)[0, 0]
    assert flipped == pytest.approx(mirror, rel=1e-12)
    f = anisotropy_function(mhdr_v2, 3.0, np.array([theta_deg, 180.0 - theta_deg]))
    assert flipped / straight == pytest.approx(f[1] / f[0], rel=1e-9)


def test_point_source_approximation_agrees_on_the_transverse_axis(flexisource):
    """On theta0 = 90 deg at 5 cm the 1D model (phi_an) and 2D model differ only by
    phi_an(r) / F(r, 90) = phi_an(r) (F(r, 90) = 1): within the few-percent anisotropy."""
    pts = [[50.0, 0.0, 0.0]]
    d2 = tg43.dose_rate_per_sk(flexisource, ORIGIN, UP, pts)[0, 0]
    d1 = tg43.dose_rate_per_sk_point_1d(flexisource, ORIGIN, pts)[0, 0]
    r_cm, phi = tg43.point_source_tables(flexisource)
    phi5 = np.interp(5.0, r_cm, phi)
    assert 0.9 < phi5 < 1.0
    assert d1 / d2 == pytest.approx(phi5, rel=2e-3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"positions_mm": [[np.nan, 0, 0]]}, "positions_mm: row 0 holds a NaN"),
        ({"points_mm": [[np.inf, 0, 0]]}, "points_mm: row 0 holds a NaN or infinite"),
        ({"directions": [[0.0, 0, 0]]}, "directions"),
        ({"directions": [[0.0, 0, 2.0]]}, "directions"),
        ({"times_s": [-1.0]}, "times_s"),
        ({"points_mm": [[0.1, 0, 0]]}, "inside the"),
        ({"positions_mm": [[0, 0]]}, r"positions_mm: shape must be \(n, 3\)"),
    ],
)
def test_bad_input_names_the_argument(flexisource, kwargs, match):
    args = {
        "positions_mm": ORIGIN,
        "directions": UP,
        "times_s": [1.0],
        "sk_U": 1000.0,
        "points_mm": [[10.0, 0, 0]],
    }
    args.update(kwargs)
    with pytest.raises(TG43Error, match=match):
        tg43.plan_dose_gy(flexisource, **args)


def test_unknown_source_lists_the_known_ones():
    with pytest.raises(TG43Error, match=r"unknown source 'selectron'.*flexisource"):
        tg43.load_source("selectron")


@pytest.mark.parametrize(
    ("file", "edit", "match"),
    [
        ("gL.csv", lambda t: t.replace("r_cm", "radius"), "gL.csv"),
        ("gL.csv", lambda t: "\n".join(t.splitlines()[:1] + t.splitlines()[2:][::-1]), "gL.csv"),
        ("F_r_theta.csv", lambda t: t.replace(",", ",,", 1), "F_r_theta.csv"),
        ("meta.json", lambda t: t.replace('"L_cm"', '"length"'), "meta.json"),
    ],
)
def test_malformed_source_files_are_refused_by_name(source_copy, file, edit, match):
    path = source_copy / file
    path.write_text(edit(path.read_text()))
    with pytest.raises(TG43Error, match=match):
        tg43.load_source(source_copy)


def test_folder_source_matches_the_shipped_one(source_copy, flexisource):
    own = tg43.load_source(source_copy)
    pts = [[10.0, 0, 5.0], [0.0, 0, 30.0]]
    shipped = tg43.dose_rate_per_sk(flexisource, ORIGIN, UP, pts)
    np.testing.assert_array_equal(tg43.dose_rate_per_sk(own, ORIGIN, UP, pts), shipped)
