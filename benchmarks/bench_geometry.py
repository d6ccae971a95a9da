"""Speed of the geometry kernels the engine calls per node per Newton iteration.

Run: python benchmarks/bench_geometry.py  (prints ns per call; target < 1000 ns for a hinted
closest_point with a 2 mm window and for frame_at).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

from ringqa.geometry import Centreline, Lumen
from ringqa.geometry import _kernels as K


@njit(cache=True)
def _loop_closest(knots, coef, s_tab, pos_tab, pts, hints, window, reps):
    acc = 0.0
    for _ in range(reps):
        for i in range(pts.shape[0]):
            s, d = K.closest_point(knots, coef, s_tab, pos_tab, pts[i], hints[i], window)
            acc += s + d
    return acc


@njit(cache=True)
def _loop_frame(knots, coef, s_tab, nor_tab, s_arr, reps):
    acc = 0.0
    for _ in range(reps):
        for i in range(s_arr.shape[0]):
            p, t, n = K.frame_at(knots, coef, s_tab, nor_tab, s_arr[i])
            acc += p[0] + t[0] + n[0]
    return acc


@njit(cache=True)
def _loop_wall(seg_s, seg_rb, seg_flat, s_arr, offs, nors, reps):
    acc = 0.0
    for _ in range(reps):
        for i in range(s_arr.shape[0]):
            d, n0, _n1, _n2 = K.wall_distance(seg_s, seg_rb, seg_flat, s_arr[i], offs[i], nors[i])
            acc += d + n0
    return acc


def main() -> None:
    r = 0.013
    th = np.linspace(0.0, 4.6, 120)
    pts = np.c_[r * np.cos(th), r * np.sin(th), 0.002 * th]
    cl = Centreline.from_points(pts)
    t = cl.table
    rng = np.random.default_rng(1)
    n = 2000
    s_true = rng.uniform(0.002, cl.length_m - 0.002, n)
    q = cl.position(s_true) + rng.normal(0, 3e-4, (n, 3))
    hints = s_true + rng.normal(0, 2e-4, n)
    for window, label in ((2e-3, "closest_point, 2 mm window"), (-1.0, "closest_point, global")):
        _loop_closest(t.knots, t.coef, t.s, t.pos, q, hints, window, 1)
        reps = 20
        t0 = time.perf_counter()
        _loop_closest(t.knots, t.coef, t.s, t.pos, q, hints, window, reps)
        dt = time.perf_counter() - t0
        print(f"{label}: {dt / (reps * n) * 1e9:.0f} ns/call")
    _loop_frame(t.knots, t.coef, t.s, t.nor, s_true, 1)
    t0 = time.perf_counter()
    _loop_frame(t.knots, t.coef, t.s, t.nor, s_true, 50)
    print(f"frame_at: {(time.perf_counter() - t0) / (50 * n) * 1e9:.0f} ns/call")
    lum = Lumen.u_shaped(1.5e-3, 1.4e-3, 1.2e-3)
    seg_s, seg_rb, _, seg_flat = lum.kernel_arrays()
    _, _, nors = cl.frame(s_true)
    offs = np.ascontiguousarray(rng.normal(0, 1e-3, (n, 3)))
    _loop_wall(seg_s, seg_rb, seg_flat, s_true, offs, nors, 1)
    t0 = time.perf_counter()
    _loop_wall(seg_s, seg_rb, seg_flat, s_true, offs, nors, 50)
    print(f"wall_distance: {(time.perf_counter() - t0) / (50 * n) * 1e9:.0f} ns/call")


if __name__ == "__main__":
    main()
