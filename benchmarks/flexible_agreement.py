"""Cross-engine agreement: the rigid-link and the flexible-element engines on the same scenes.

For ring26-flexitron, ring13-push100, the Oncentra example's ring channel (at the commissioning
settings, 2/5 mm and 1 mm) and the needle in the paper's r = 35 mm S channel: both engines at
the scene's settings (x1) and refined (element lengths and increment x0.5, x0.25), the largest and
median distance between their source positions at every dwell, the largest push-force
difference, and each engine's own change from x0.5 to x0.25 (its numerical error there); solve
times (JIT excluded, single runs: on a loaded machine go by the ratios).

    .venv/bin/python benchmarks/flexible_agreement.py [--levels 1,0.5,0.25] [scene ...]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from compare_dwells import example_scene  # noqa: E402

from ringqa.pipeline.simulate import (  # noqa: E402
    COMMISSION_ELEMENT_MM,
    COMMISSION_INCREMENT_MM,
    refine_scene,
)
from ringqa.simulation import load_scene, scene_with_overrides, simulate  # noqa: E402

SC = ROOT / "data" / "scenes"
SCENES = ("ring26-flexitron", "ring13-push100", "example", "needle-paper")


def base_scene(name: str):
    """The scene at the settings the table starts from."""
    if name == "example":
        return scene_with_overrides(
            example_scene(),
            {
                "discretisation.element_length_mm": dict(COMMISSION_ELEMENT_MM["flexitron"]),
                "solver.increment_mm": COMMISSION_INCREMENT_MM,
            },
        )
    return load_scene(SC / f"{name}.toml")


def run(scene, form: str):
    s = scene_with_overrides(scene, {"model.formulation": form})
    t = time.perf_counter()
    res = simulate(s)
    return res, time.perf_counter() - t


def dist_mm(a, b) -> np.ndarray:
    return np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1) * 1e3


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--levels", default="1,0.5,0.25")
    args = ap.parse_args()
    levels = [float(x) for x in args.levels.split(",")]
    print("| scene | level | rigid time (iters, stab.) | flexible time (iters, stab.) | "
          "max / median distance (mm) | max push-force difference (N, % of peak) |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for name in args.scenes:
        base = base_scene(name)
        prev = {}
        for lev in levels:
            sc = base if lev == 1 else refine_scene(base, lev)
            rr, _ = run(sc, "rigid")
            rf, _ = run(sc, "flexible")
            d = dist_mm(rr, rf)
            df = float(np.nanmax(np.abs(rr.push_force_n - rf.push_force_n)))
            peak = float(np.nanmax(np.abs(rr.push_force_n)))
            print(
                f"| {name} | x{lev:g} | {rr.solve_time_s:.3f} s ({rr.stats.n_newton_iters}, "
                f"{rr.stats.n_stabilised_steps}) | {rf.solve_time_s:.3f} s "
                f"({rf.stats.n_newton_iters}, {rf.stats.n_stabilised_steps}) | "
                f"{np.nanmax(d):.4f} / {np.nanmedian(d):.4f} | {df:.4f} "
                f"({100 * df / peak:.2f} %) |",
                flush=True,
            )
            if prev:
                sr = dist_mm(rr, prev["rigid"])
                sf = dist_mm(rf, prev["flexible"])
                print(f"|  | x{lev:g} vs previous level, own change | rigid {np.nanmax(sr):.4f} / "
                      f"{np.nanmedian(sr):.4f} | flexible {np.nanmax(sf):.4f} / "
                      f"{np.nanmedian(sf):.4f} | | |", flush=True)  # fmt: skip
            prev = {"rigid": rr, "flexible": rf}
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
