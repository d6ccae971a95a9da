"""TG-43 dose-kernel throughput: the issue-16 kernels against the frozen old ones (a script).

Run:  python benchmarks/bench_tg43.py [--quick]

Prints point-dwell evaluations per second, old kernel (``tests/tg43/frozen_kernels.py``, the
kernels as they were before issue 16) and new kernel (``tg43._kernels``) side by side in the same
run, with the ratio new/old:

1. the kernels on the same arrays (input checks and unit conversion excluded), for a small plan
   (10 dose points x 60 dwells) and a large grid (100 000 points x 60 dwells), the full
   (n_points, n_dwells) rate matrix and the weighted plan sum, on one thread and on two;
2. two threads against one for the new kernel as the grid grows (where ``parallel=True`` starts
   to pay: ``tg43.dose.PARALLEL_MIN_PAIRS``);
3. the public ``plan_dose_gy`` on the small plan, input checks included (the old one rebuilt from
   the same checks and the old kernel), and the plain numpy implementation of the same formula
   (``tg43.reference``) on the large grid;
4. MET / NOT MET for issue 16's target: >= 3e7 evaluations per second on one core.

Every figure is the median over interleaved repeats (old, new, old, new, ...), so that load from
other processes on the machine hits both alike; the ratios are the figures to quote.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import sys
import time
from pathlib import Path

import numba
import numpy as np

import tg43
from tg43 import _kernels
from tg43.dose import (
    _CHUNK_PAIRS,
    _GY_PER_CGY,
    _S_PER_H,
    PARALLEL_MIN_PAIRS,
    _as_xyz,
    _check_dwells,
    _check_sk,
    _check_source,
    _check_times,
    _rows_parallel,
    _tables,
    decay_factor,
)
from tg43.reference import dose_rate_per_sk_numpy

ROOT = Path(__file__).resolve().parents[1]
TARGET = 3e7  # evaluations per second on one core (issue 16)


def _frozen():
    """The frozen pre-issue-16 kernels (a test helper module, loaded by path under the name the
    tests import it by, so that both share numba's on-disk cache of its kernels)."""
    path = ROOT / "tests" / "tg43" / "frozen_kernels.py"
    spec = importlib.util.spec_from_file_location("frozen_kernels", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _case(n_points: int, n_dwells: int, rng):
    """Dwells within 15 mm of the origin, points 20-180 mm away (mm, unit directions)."""
    pos = rng.uniform(-15.0, 15.0, (n_dwells, 3))
    dirs = rng.normal(size=(n_dwells, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pts = rng.uniform(-80.0, 80.0, (n_points, 3))
    pts[:, 0] += 100.0  # keep every point outside the sources
    times = rng.uniform(1.0, 30.0, n_dwells)
    return pos, dirs, pts, times


def _medians(fns: dict, rounds: int, calls: int) -> dict:
    """Median seconds per call of each function, the functions interleaved in every round."""
    times = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            for _ in range(calls):
                fn()
            times[name].append((time.perf_counter() - t0) / calls)
    return {name: statistics.median(v) for name, v in times.items()}


def _with_threads(n: int, fn):
    def run():
        numba.set_num_threads(n)
        return fn()

    return run


class Kernels:
    """Old and new kernel calls on the same (SI) arrays for one grid."""

    def __init__(self, old, src, pos_mm, dirs, pts_mm, times):
        self.n_p, self.n_d = pts_mm.shape[0], pos_mm.shape[0]
        pts = pts_mm * 1e-3
        pos = pos_mm * 1e-3
        w = times * 0.01
        old_tab = old.old_tables(src)
        new_tab = _tables(src)
        dwells = _kernels.dwell_rows(pos, dirs)
        rate = np.empty((self.n_p, self.n_d))
        rate_new = np.empty((self.n_p, self.n_d))
        total = np.empty(self.n_p)
        total_new = np.empty(self.n_p)
        no1, no2 = np.empty(0), np.empty((0, 0))
        # the API's blocks of points, but at least two so that the small plan uses both threads
        chunk = max(1, min(_CHUNK_PAIRS // self.n_d, -(-self.n_p // 2)))
        self.calls = {
            ("matrix", "old"): lambda: old.rate_matrix(pts, pos, dirs, *old_tab, rate),
            ("matrix", "new", 1): lambda: _kernels.rows(
                0, self.n_p, pts, dwells, no1, *new_tab, rate_new, no1, True
            ),
            ("matrix", "new", 2): lambda: _rows_parallel(
                chunk, pts, dwells, no1, *new_tab, rate_new, no1, True
            ),
            ("sum", "old"): lambda: old.weighted_sum(pts, pos, dirs, w, *old_tab, total),
            ("sum", "new", 1): lambda: _kernels.rows(
                0, self.n_p, pts, dwells, w, *new_tab, no2, total_new, False
            ),
            ("sum", "new", 2): lambda: _rows_parallel(
                chunk, pts, dwells, w, *new_tab, no2, total_new, False
            ),
        }
        self.outputs = (rate, rate_new, total, total_new)

    def fns(self, output: str, threads: int) -> dict:
        """{'old': fn, 'new': fn} on ``threads`` threads (the old kernel is always parfor)."""
        return {
            "old": _with_threads(threads, self.calls[(output, "old")]),
            "new": _with_threads(threads, self.calls[(output, "new", min(threads, 2))]),
        }

    def max_rel_diff(self) -> float:
        """Max |new / old - 1| of the last outputs (both kernels have run)."""
        rate, rate_new, total, total_new = self.outputs
        return max(float(np.max(np.abs(rate_new / rate - 1))),
                   float(np.max(np.abs(total_new / total - 1))))  # fmt: skip


def _old_plan_dose_gy(old, old_tab, source, positions_mm, directions, times_s, sk_u, points_mm):
    """plan_dose_gy as it was before issue 16: today's (unchanged) checks + the old kernel."""
    _check_source(source)
    pos, dirs = _check_dwells(positions_mm, directions)
    pts = _as_xyz(points_mm, "points_mm", allow_single=True)
    times = _check_times(times_s, pos.shape[0])
    sk = _check_sk(sk_u) * decay_factor(None, None)
    weights = times * (sk / _S_PER_H * _GY_PER_CGY)
    out = np.empty(pts.shape[0])
    n_bad = old._run_threads(
        old.weighted_sum, False, pts * 1e-3, pos * 1e-3, dirs, weights, *old_tab, out
    )
    assert not n_bad
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, 20 000-point grid")
    args = parser.parse_args(argv)
    old = _frozen()
    src = tg43.load_source("flexisource")
    rng = np.random.default_rng(0)
    max_threads = numba.config.NUMBA_NUM_THREADS
    threads = [1, 2] if max_threads >= 2 else [1]
    large = 20_000 if args.quick else 100_000
    grids = [("small plan", 10, 60, 200 if args.quick else 1000, 20),
             ("large grid", large, 60, 5 if args.quick else 15, 1)]  # fmt: skip
    print(f"TG-43 kernels, {src.name}: point-dwell evaluations per second, median of interleaved "
          f"repeats (numba {numba.__version__}, {max_threads} threads available; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores: two-thread figures need the "
          "second core free)\n")  # fmt: skip
    print(f"{'grid':<24} {'output':<7} {'threads':>7} | {'old':>9} {'new':>9} | {'new/old':>7}")
    one_core: list[float] = []
    new_by_threads: dict = {}
    worst_diff = 0.0
    for label, n_p, n_d, rounds, calls in grids:
        pos, dirs, pts, times = _case(n_p, n_d, rng)
        k = Kernels(old, src, pos, dirs, pts, times)
        for output in ("matrix", "sum"):
            for n_t in threads:
                fns = k.fns(output, n_t)
                for fn in fns.values():  # compile / load, first touch
                    fn()
                med = _medians(fns, rounds, calls)
                n = n_p * n_d
                r_old, r_new = n / med["old"], n / med["new"]
                if n_t == 1:
                    one_core.append(r_new)
                new_by_threads[(label, output, n_t)] = r_new
                print(f"{label + f' ({n_p} x {n_d})':<24} {output:<7} {n_t:>7} | "
                      f"{r_old:9.3g} {r_new:9.3g} | {r_new / r_old:6.2f}x")  # fmt: skip
        worst_diff = max(worst_diff, k.max_rel_diff())
    numba.set_num_threads(max_threads)
    if len(threads) == 2:
        print("\nnew kernel, 2 threads / 1 thread:", ", ".join(
            f"{label} {output} {new_by_threads[(label, output, 2)] / new_by_threads[(label, output, 1)]:.2f}x"  # noqa: E501
            for label, *_ in grids for output in ("matrix", "sum")))  # fmt: skip
        print(f"\nnew plan sum, 2 threads / 1 thread by grid size (60 dwells; parallel=True "
              f"uses threads from {PARALLEL_MIN_PAIRS} pairs):")  # fmt: skip
        for n_p in (50, 150, 333, 1000, 3000) if not args.quick else (50, 333, 3000):
            pos, dirs, pts, times = _case(n_p, 60, rng)
            k = Kernels(old, src, pos, dirs, pts, times)
            fns = {
                1: _with_threads(1, k.calls[("sum", "new", 1)]),
                2: _with_threads(2, k.calls[("sum", "new", 2)]),
            }
            for fn in fns.values():
                fn()
            med = _medians(fns, 60 if args.quick else 300, max(1, 3000 // n_p))
            print(f"  {n_p * 60:>7} pairs: {med[1] / med[2]:.2f}x")
        numba.set_num_threads(max_threads)

    # the public API on the small plan, input checks included
    pos, dirs, pts, times = _case(10, 60, rng)
    old_tab = old.old_tables(src)
    fns = {
        "old": lambda: _old_plan_dose_gy(old, old_tab, src, pos, dirs, times, 1e4, pts),
        "new": lambda: tg43.plan_dose_gy(src, pos, dirs, times, 1e4, pts),
    }
    for fn in fns.values():
        fn()
    med = _medians(fns, 200 if args.quick else 1000, 10)
    print(f"\nplan_dose_gy, 10 points x 60 dwells, input checks included: old "
          f"{med['old'] * 1e6:.1f} us, new {med['new'] * 1e6:.1f} us per call "
          f"({med['old'] / med['new']:.2f}x)")  # fmt: skip

    # the plain numpy implementation of the same formula
    pos, dirs, pts, times = _case(20_000, 60, rng)
    new_matrix = lambda: tg43.dose_rate_per_sk(src, pos, dirs, pts)  # noqa: E731
    fns = {"numpy": lambda: dose_rate_per_sk_numpy(src, pos, dirs, pts), "new": new_matrix}
    med = _medians(fns, 3, 1)
    n = 20_000 * 60
    print(f"numpy implementation (tg43.reference), 20000 x 60 matrix: {n / med['numpy']:.3g}/s; "
          f"new kernel through dose_rate_per_sk {n / med['new']:.3g}/s "
          f"({med['numpy'] / med['new']:.1f}x faster)")  # fmt: skip

    print(f"\nmax |new / old - 1| over the outputs above: {worst_diff:.2g}; load average at the "
          f"end {os.getloadavg()[0]:.2f}")  # fmt: skip
    worst = min(one_core)
    verdict = "MET" if worst >= TARGET else "NOT MET"
    print(f"target >= {TARGET:.0e} evaluations/s on one core: {verdict} "
          f"(slowest one-core new figure {worst:.3g}/s)")  # fmt: skip


if __name__ == "__main__":
    main()
