"""The coarse approach (issue 29, "Fewer load steps"): what it saves and what it moves, per scene,
beside each scene's numerical error.

    .venv/bin/python benchmarks/bench_load_steps.py                   # every compare_dwells scene
    .venv/bin/python benchmarks/bench_load_steps.py ring26-flexitron  # named scenes only
    .venv/bin/python benchmarks/bench_load_steps.py --saved DIR       # and against saved outputs

For each scene of ``benchmarks/compare_dwells.py``, in one process: the run with the engine's
rule (``schedule.APPROACH_COARSE_FACTOR`` as shipped) and with it off (factor 1: the
increment-only approach), their load steps, Newton iterations and stabilised steps, and how far
the rule moves the dwells: source centres and tips (the larger, m) and source directions (deg).
Beside it the scene's numerical error as ``ringqa commission`` measures it: the largest
source-centre distance between the run and the run refined once (every flexible element length
and the increment or time step halved, ``ringqa.pipeline.simulate.REFINE_FACTOR``), in mm, and
the change as a fraction of that error. ``--saved DIR`` adds the change against outputs saved
with ``compare_dwells.py save DIR`` (another checkout's). Dynamic scenes are not affected by the
rule (quasi-static runs only); they are listed with their error for completeness.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import compare_dwells  # noqa: E402

from ringqa.accuracy import scaled_overrides  # noqa: E402
from ringqa.pipeline.simulate import REFINE_FACTOR  # noqa: E402
from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import scene_with_overrides  # noqa: E402
from ringqa.simulation.solvers import schedule  # noqa: E402


def _moved(a, b) -> tuple[float, float]:
    """(largest source-centre or tip distance (m), largest source-direction angle (deg))."""
    d = max(
        float(np.nanmax(np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1), initial=0.0)),
        float(np.nanmax(np.linalg.norm(a.tip_pos_m - b.tip_pos_m, axis=1), initial=0.0)),
    )
    cos = np.clip(np.sum(a.source_dir * b.source_dir, axis=1), -1.0, 1.0)
    ang = float(np.nanmax(np.degrees(np.arccos(cos)), initial=0.0))
    return d, ang


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", help="only these scenes (compare_dwells' names)")
    ap.add_argument("--saved", type=Path, help="also compare with outputs saved in DIR")
    args = ap.parse_args(argv)
    factor = schedule.APPROACH_COARSE_FACTOR
    print(
        f"rule: APPROACH_COARSE_FACTOR = {factor}, APPROACH_SETTLE_INCREMENTS = "
        f"{schedule.APPROACH_SETTLE_INCREMENTS}; off = factor 1"
    )
    print(
        f"{'scene':28s} {'steps off/on':>13s} {'iters off/on':>13s} {'stab':>5s} "
        f"{'moved (m)':>9s} {'dir (deg)':>9s} {'num. error (mm)':>15s} {'moved/error':>11s}"
        + ("  vs saved (m)" if args.saved else "")
    )
    tot = [0, 0]
    for name, scene in compare_dwells.cases():
        if args.scenes and name not in args.scenes:
            continue
        schedule.APPROACH_COARSE_FACTOR = 1
        off = simulate(scene)
        schedule.APPROACH_COARSE_FACTOR = factor
        on = simulate(scene)
        refined = simulate(
            scene_with_overrides(scene, scaled_overrides(scene, REFINE_FACTOR, REFINE_FACTOR))
        )
        moved, ang = _moved(on, off)
        err_mm = 1e3 * float(
            np.nanmax(np.linalg.norm(on.source_pos_m - refined.source_pos_m, axis=1))
        )
        it_off, it_on = off.stats.n_newton_iters, on.stats.n_newton_iters
        tot[0] += it_off
        tot[1] += it_on
        line = (
            f"{name:28s} {off.stats.n_steps:6d}/{on.stats.n_steps:<6d} {it_off:6d}/{it_on:<6d} "
            f"{off.stats.n_stabilised_steps:2d}/{on.stats.n_stabilised_steps:<2d} {moved:9.1e} "
            f"{ang:9.1e} {err_mm:15.4f} {1e3 * moved / err_mm:11.1e}"
        )
        if args.saved:
            f = args.saved / f"{name}.npz"
            if f.is_file():
                ref = np.load(f)
                d = max(
                    float(np.nanmax(np.abs(on.source_pos_m - ref["source_pos_m"]), initial=0)),
                    float(np.nanmax(np.abs(on.tip_pos_m - ref["tip_pos_m"]), initial=0)),
                )
                line += f"  {d:9.1e} (iters {int(ref['total_newton_iters'])})"
        if on.status != off.status:
            line += f"  STATUS {off.status} -> {on.status}"
        print(line, flush=True)
    print(f"{'all':28s} {'':13s} {tot[0]:6d}/{tot[1]:<6d}")
    schedule.APPROACH_COARSE_FACTOR = factor
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
