"""The issue-16 kernels against the frozen pre-issue-16 ones, and their building blocks.

The new kernel does the same arithmetic as the old one (same r, the same cells and fractions of
the tables, the same products in the same order) except for the two arctangents: FDLIBM's
polynomial inlined instead of libm's ``atan2`` call, within 2 ulp of it (tested below). A few
ulp in theta or in the subtended angle move the dose rate by ~1e-15 relative (F changes by at
most ~6 per rad near the axis), so the new results must equal the old ones within 1e-12
relative everywhere, NaN (inside the source) in the same places.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from frozen_kernels import _cell as frozen_cell
from frozen_kernels import build_lookup as frozen_build_lookup
from frozen_kernels import old_rate_matrix, old_weighted_sum
from hypothesis import given
from hypothesis import strategies as st
from numba import njit

import tg43
from tg43 import _kernels
from tg43._kernels import _atan2_upper, build_lookup
from tg43.dose import _evaluate, _tables

RTOL = 1e-12


@njit
def _atan2_all(y, x):
    out = np.empty(y.size)
    for i in range(y.size):
        out[i] = _atan2_upper(y[i], x[i])
    return out


def test_atan2_exact_at_the_quadrant_points():
    """atan2(0, 1) = 0, atan2(1, 1) = pi/4, atan2(1, 0) = pi/2, atan2(1, -1) = 3 pi/4 and
    atan2(0, -1) = pi, the doubles nearest to them (the hi + lo constants round to them)."""
    y = np.array([0.0, 1.0, 1.0, 1.0, 0.0, 2.5])
    x = np.array([1.0, 1.0, 0.0, -1.0, -1.0, 2.5])
    expected = [0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4, math.pi, math.pi / 4]
    np.testing.assert_array_equal(_atan2_all(y, x), expected)


def test_atan2_within_two_ulp_of_libm():
    """Random y >= 0 and x of either sign over the whole exponent range, and the reduction
    boundaries (y/|x| = tan(pi/8), 1, 1/tan(pi/8)): within 2 ulp of libm's atan2 (FDLIBM's
    polynomial is < 1 ulp; the reductions add at most one rounding)."""
    rng = np.random.default_rng(16)
    n = 200_000
    t8 = math.tan(math.pi / 8)
    y = np.concatenate([
        rng.uniform(0.0, 1.0, n),
        10.0 ** rng.uniform(-300, 300, n),
        np.repeat([t8, 1.0, 1.0 / t8], 1000) * (1 + rng.uniform(-1e-6, 1e-6, 3000)),
        [0.0, 1e-300, 5e-324],
    ])  # fmt: skip
    x = np.concatenate([
        rng.uniform(-1.0, 1.0, n),
        rng.choice([-1.0, 1.0], n) * 10.0 ** rng.uniform(-300, 300, n),
        rng.choice([-1.0, 1.0], 3000),
        [-3.0, 1.0, -1.0],
    ])  # fmt: skip
    got = _atan2_all(y, x)
    # libm's atan2 (what the old kernel called); np.arctan2 may use its own SIMD version
    ref = np.array([math.atan2(a, b) for a, b in zip(y.tolist(), x.tolist(), strict=True)])
    ulp = np.abs(got - ref) / np.spacing(np.maximum(np.abs(ref), 1e-300))
    assert ulp.max() <= 2.0, (y[np.argmax(ulp)], x[np.argmax(ulp)])


def test_lookup_table_of_a_small_grid():
    """Grid [0, 1, 3]: h = 0.5 (half the smallest spacing), bins start at 0, 0.5, ..., 3.5
    (ceil(3 / 0.5) + 2 = 8 bins). Bins 0 and 1 start in cell 0 = [0, 1), whose right node 1 is
    their split (x >= 1 is in cell 1); bins 2-7 start in cell 1 = [1, 3], the last cell (it also
    takes x beyond 3, extrapolation), so their split is inf."""
    lut, split, inv_h = build_lookup(np.array([0.0, 1.0, 3.0]))
    assert inv_h == 2.0
    np.testing.assert_array_equal(lut, [0, 0, 1, 1, 1, 1, 1, 1])
    np.testing.assert_array_equal(split, [1.0, 1.0] + [np.inf] * 6)


@njit
def _old_cells(x, grid, lut, inv_h, inv_dx):
    cell = np.empty(x.size, dtype=np.int64)
    frac = np.empty(x.size)
    for i in range(x.size):
        cell[i], frac[i] = frozen_cell(x[i], grid, lut, inv_h, inv_dx)
    return cell, frac


@pytest.mark.parametrize("name", tg43.known_sources())
def test_lookup_finds_the_cell_of_the_old_kernel(name):
    """For every table axis of every source, ``lut[bin] + (x >= split[bin])`` is the old
    kernel's cell at random x, at every node, one ulp either side of it, below and beyond the
    grid. That cell is the binary-search cell, except one ulp below a node where the bin
    arithmetic rounds up to the node's bin (both kernels then take the next cell with a fraction
    of -1e-16: the interpolated value moves by an ulp)."""
    src = tg43.load_source(name)
    rng = np.random.default_rng(3)
    for grid in (src.gl_r_cm * 1e-2, src.f_r_cm * 1e-2, np.deg2rad(src.f_theta_deg)):
        lut, split, inv_h = build_lookup(grid)
        x = np.concatenate([
            rng.uniform(grid[0], grid[-1], 5000), [grid[0] - 1.0, 2 * grid[-1]],
            grid, np.nextafter(grid, -np.inf), np.nextafter(grid, np.inf),
        ])  # fmt: skip
        scaled = np.clip((x - grid[0]) * inv_h, 0.0, lut.size - 1)
        b = scaled.astype(np.int64)
        got = lut[b] + (x >= split[b])
        old_lut, _, old_inv_dx = frozen_build_lookup(grid)
        old_cell, old_frac = _old_cells(x, grid, old_lut, inv_h, old_inv_dx)
        np.testing.assert_array_equal(got, old_cell)
        search = np.clip(np.searchsorted(grid, x, side="right") - 1, 0, grid.size - 2)
        off = got != search
        assert np.all(got[off] == search[off] + 1)
        assert np.all(old_frac[off] > -1e-15)


def _truncated(source):
    """The source with its g_L and F tables starting at 0.5 cm (points nearer are below the
    tables' range: g_L and F take their values at 0.5 cm)."""
    keep_g = source.gl_r_cm >= 0.5
    keep_f = source.f_r_cm >= 0.5
    return dataclasses.replace(
        source,
        gl_r_cm=source.gl_r_cm[keep_g].copy(),
        gl=source.gl[keep_g].copy(),
        f_r_cm=source.f_r_cm[keep_f].copy(),
        f=source.f[:, keep_f].copy(),
        f_flags=None,
        _cache={},
    )


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _compare(source, pos, dirs, pts):
    """New vs old (matrix and weighted sum): NaN in the same places, else within RTOL.

    Through ``tg43.dose._evaluate`` (the API minus its input checks), which returns NaN for
    points inside the source instead of raising, with the directions normalised as the API (and
    the old wrapper) does: near the axis y = sqrt(r^2 - z^2) is all rounding, so one ulp of a
    direction moves theta by 1e-8 rad there.
    """
    pos = np.asarray(pos, dtype=float)
    dirs = np.asarray(dirs, dtype=float)
    unit = dirs / np.linalg.norm(dirs, axis=1)[:, None]
    new_rate = _evaluate(source, pts, pos, unit, None, False)[1]
    old_rate = old_rate_matrix(source, pos, dirs, pts)
    np.testing.assert_array_equal(np.isnan(new_rate), np.isnan(old_rate))
    np.testing.assert_allclose(new_rate, old_rate, rtol=RTOL, atol=0.0)
    w = np.linspace(0.5, 1.5, pos.shape[0])
    new_sum = _evaluate(source, pts, pos, unit, w, False)[1]
    np.testing.assert_allclose(new_sum, old_weighted_sum(source, pos, dirs, w, pts), rtol=RTOL)
    return new_rate


_AXES = [(0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (0.0, -1.0, 0.0)]


@given(
    name=st.sampled_from(tg43.known_sources()),
    truncate=st.booleans(),
    direction=st.one_of(
        st.sampled_from(_AXES),
        st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(
            lambda v: sum(c * c for c in v) > 0.01
        ),
    ),
    centre=st.tuples(*[st.floats(-30, 30) for _ in range(3)]),
    r_scale=st.one_of(
        st.floats(1.0, 1.05),  # just outside r_min
        st.floats(1.05, 600.0),  # in the tables (r_min ... 10 cm) and beyond them
        st.floats(600.0, 6000.0),  # far beyond (g_L extrapolated to zero)
    ),
    theta_deg=st.one_of(st.sampled_from([0.0, 180.0, 90.0, 1e-7, 180.0 - 1e-7]), st.floats(0, 180)),
    phi=st.floats(0, 2 * math.pi),
    seed=st.integers(0, 2**32 - 1),
)
def test_new_kernel_equals_the_old_one(
    name, truncate, direction, centre, r_scale, theta_deg, phi, seed
):
    """One hypothesis-chosen point (at r = r_scale * r_min from a dwell, at theta, on the axis
    for theta 0 or 180 deg with an axis-aligned dwell) plus 40 random points (on the axes of
    the dwells, just outside r_min, inside the source, in and far beyond the tables) against
    four dwells; the old kernel's numbers within 1e-12 relative, NaN in the same places."""
    src = tg43.load_source(name)
    if truncate:
        src = _truncated(src)
    rng = np.random.default_rng(seed)
    u = _unit(direction)
    e1 = _unit(np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0]))
    e2 = np.cross(u, e1)
    c = np.asarray(centre)
    pos = np.vstack([c, c + rng.uniform(-20, 20, (3, 3))])
    dirs = np.vstack([u, rng.normal(size=(3, 3))])
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    r_min_mm = src.r_min_cm * 10.0
    th = math.radians(theta_deg)
    radial = math.cos(th) * u + math.sin(th) * (math.cos(phi) * e1 + math.sin(phi) * e2)
    pts = [c + r_scale * r_min_mm * radial]
    for _ in range(10):
        j = rng.integers(4)
        r = r_min_mm * rng.choice([1.0, rng.uniform(1.0, 1.01), rng.uniform(1, 100), 1e3])
        pts.append(pos[j] + rng.choice([-1.0, 1.0]) * r * dirs[j])  # on (or next to) the axis
        v = _unit(rng.normal(size=3))
        pts.append(pos[j] + r_min_mm * rng.uniform(0.5, 1.02) * v)  # inside / just outside
        pts.append(pos[j] + rng.uniform(0.0, 120.0) * v)  # in and just beyond the tables
        pts.append(pos[j] + 10.0 ** rng.uniform(2, 3.5) * v)  # far beyond
    _compare(src, pos, dirs, np.array(pts))


@pytest.mark.parametrize("name", tg43.known_sources())
def test_new_kernel_equals_the_old_one_at_the_table_nodes(name):
    """Points at every (r, theta) node of the F table (r > r_min) and of the consensus QA grid,
    where the new theta (a different arctangent) may fall on the other side of a node than the
    old one: bilinear interpolation is continuous, so the numbers still agree within 1e-12."""
    src = tg43.load_source(name)
    rr, tt = np.meshgrid(src.f_r_cm[src.f_r_cm > src.r_min_cm], np.deg2rad(src.f_theta_deg))
    pts = np.column_stack([rr.ravel() * np.sin(tt.ravel()), 0 * rr.ravel(),
                           rr.ravel() * np.cos(tt.ravel())]) * 10.0  # fmt: skip
    if src.has_qa_table:
        zz, yy = np.meshgrid(src.qa_z_cm, src.qa_y_cm, indexing="ij")
        qa = np.column_stack([yy.ravel(), 0 * yy.ravel(), zz.ravel()]) * 10.0
        pts = np.vstack([pts, qa])
    rate = _compare(src, [[0.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]], pts)
    assert np.isfinite(rate[: rr.size]).all()


def test_parallel_kernel_is_the_serial_one_bit_for_bit():
    """rows_parallel (blocks of 7 points over the threads) and rows (one pass) give identical
    arrays, matrix and weighted sums, NaN rows included (one point inside a source)."""
    src = tg43.load_source("vs2000")
    rng = np.random.default_rng(5)
    pts = rng.uniform(-60, 60, (301, 3)) * 1e-3
    pts[17] = 0.0  # at the centre of dwell 0
    pos = np.vstack([np.zeros(3), rng.uniform(-20, 20, (8, 3))]) * 1e-3
    dirs = rng.normal(size=(9, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dw = _kernels.dwell_rows(pos, dirs)
    w = rng.uniform(0.1, 2.0, 9)
    tables = _tables(src)
    for matrix in (True, False):
        outs = []
        for run in (
            lambda *a: _kernels.rows(0, pts.shape[0], *a),
            lambda *a: _kernels.rows_parallel(7, *a),
        ):
            rates = np.empty((301, 9) if matrix else (0, 0))
            sums = np.empty(0 if matrix else 301)
            n_bad = run(pts, dw, w, *tables, rates, sums, matrix)
            outs.append((n_bad, rates if matrix else sums))
        assert outs[0][0] == outs[1][0] >= 1
        np.testing.assert_array_equal(outs[0][1], outs[1][1])
