"""TG-43 dose-kernel throughput: numba kernel vs a straightforward numpy implementation.

Run:  python benchmarks/bench_tg43.py [--quick]

Prints, for n_points x n_dwells grids, the time per call (best of repeats, JIT excluded) and the
throughput in point-dwell evaluations per second, for

- ``dose_rate_per_sk`` (numba, one core): the full (n_points, n_dwells) matrix,
- ``plan_dose_gy`` (numba, one core): the summed plan dose (no matrix kept),
- ``plan_dose_gy(parallel=True)`` (numba, all cores),
- the numpy reference implementation of the same formula (tg43.reference).

Target (issue 2): >= 3e7 evaluations per second on one core.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import tg43
from tg43.reference import dose_rate_per_sk_numpy


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _case(n_points: int, n_dwells: int, rng):
    pos = rng.uniform(-15.0, 15.0, (n_dwells, 3))
    dirs = rng.normal(size=(n_dwells, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pts = rng.uniform(-80.0, 80.0, (n_points, 3))
    pts[:, 0] += 100.0  # keep every point outside the sources
    times = rng.uniform(1.0, 30.0, n_dwells)
    return pos, dirs, pts, times


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller grid")
    args = parser.parse_args(argv)
    src = tg43.load_source("flexisource")
    rng = np.random.default_rng(0)
    sizes = [(1_000, 10), (10_000, 10), (100_000, 10), (10_000, 100), (100_000, 100)]
    sizes.append((1_000_000, 10))
    if args.quick:
        sizes = sizes[:3]
    # warm up (JIT compile or cache load)
    pos, dirs, pts, times = _case(10, 2, rng)
    tg43.dose_rate_per_sk(src, pos, dirs, pts)
    tg43.plan_dose_gy(src, pos, dirs, times, 1e4, pts)
    tg43.plan_dose_gy(src, pos, dirs, times, 1e4, pts, parallel=True)

    print(f"{'points':>9} {'dwells':>6} | {'matrix':>10} {'sum':>10} {'sum||':>10} {'numpy':>10} "
          f"| {'numba/numpy':>11}   (evaluations per second)")  # fmt: skip
    for n_p, n_d in sizes:
        pos, dirs, pts, times = _case(n_p, n_d, rng)
        n = n_p * n_d
        rep = 3 if n <= 1e6 else 1
        t_mat = _best(lambda: tg43.dose_rate_per_sk(src, pos, dirs, pts), rep)  # noqa: B023
        t_sum = _best(lambda: tg43.plan_dose_gy(src, pos, dirs, times, 1e4, pts), rep)  # noqa: B023
        t_par = _best(
            lambda: tg43.plan_dose_gy(src, pos, dirs, times, 1e4, pts, parallel=True),  # noqa: B023
            rep,
        )
        t_np = float("nan")
        if n <= 1e6:
            t_np = _best(lambda: dose_rate_per_sk_numpy(src, pos, dirs, pts), 1)  # noqa: B023
        print(f"{n_p:>9} {n_d:>6} | {n / t_mat:10.3g} {n / t_sum:10.3g} {n / t_par:10.3g} "
              f"{n / t_np:10.3g} | {t_np / t_mat:11.1f}")  # fmt: skip


if __name__ == "__main__":
    main()
