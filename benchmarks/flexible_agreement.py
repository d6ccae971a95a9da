"""Cross-engine agreement: the rigid-link and the flexible-element engines on the same scenes.

For ring26-flexitron, ring13-push100, the Oncentra example's ring channel (at the commissioning
settings, 2/5 mm and 1 mm) and the needle in the paper's r = 35 mm S channel: both engines at
the scene's settings (x1) and refined (element lengths and increment x0.5, x0.25), the largest and
median distance between their source positions at every dwell, the largest push-force
difference, and each engine's own change from x0.5 to x0.25 (its numerical error there); solve
times (JIT excluded, single runs: on a loaded machine go by the ratios).

    .venv/bin/python benchmarks/flexible_agreement.py [--levels 1,0.5,0.25] [scene ...]
    .venv/bin/python benchmarks/flexible_agreement.py --cross-check [scene ...]

``--cross-check``: the settings of commission's cross-check instead
(:func:`ringqa.pipeline.simulate.cross_check_overrides`: every element length x
CROSS_CHECK_ELEMENT_FACTOR, the increment unchanged) on each scene at its commissioning settings
(the Flexitron rings at the commissioning element lengths 2/5 mm and 1 mm increments; the needle
at its own): that run's distance to the flexible and the rigid engine's x0.25 runs (its own
numerical error, and the disagreement a commissioning run would see), and its CPU time against
the flexible run at the commissioning element lengths. ``example-commission`` is the run
``ringqa commission`` makes on the shipped example (microSelectron cable, 60 mm stem).
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
    CROSS_CHECK_FLEXIBLE_ERROR_MM,
    commission_scene,
    cross_check_overrides,
    default_engine,
    refine_scene,
)
from ringqa.simulation import load_scene, scene_with_overrides, simulate  # noqa: E402

SC = ROOT / "data" / "scenes"
SCENES = ("ring26-flexitron", "ring13-push100", "example", "needle-paper")
CROSS_SCENES = ("ring26-flexitron", "ring13-push100", "example-commission", "needle-paper")


def commission_example():
    """The scene ``ringqa commission`` simulates for the shipped example: its ring channel cut to
    the 60 mm stem, the microSelectron cable, the commissioning settings."""
    from ringqa.geometry.stem import trim_to_stem
    from ringqa.pipeline.inputs import load_input

    app = load_input(str(ROOT / "data" / "examples" / "oncentra_ring26x60" /
                         "RP_ring26x60_oncentra43.dcm")).applicator  # fmt: skip
    channel = trim_to_stem(app.channel("ring"), 60e-3).channel
    return commission_scene(default_engine(), channel, "microselectron", {})


def commission_level(name: str):
    """A scene at its commissioning settings (what the cross-check starts from)."""
    if name == "example-commission":
        return commission_example()
    base = base_scene(name)
    if name.startswith("ring"):  # Flexitron rings: commission's element lengths and increment
        base = scene_with_overrides(base, {
            "discretisation.element_length_mm": dict(COMMISSION_ELEMENT_MM["flexitron"]),
            "solver.increment_mm": COMMISSION_INCREMENT_MM,
        })  # fmt: skip
    return base


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


def cpu_run(scene, form: str):
    """(result, CPU s) of one run (a warm-up run first: JIT excluded)."""
    s = scene_with_overrides(scene, {"model.formulation": form})
    t = time.process_time()
    res = simulate(s)
    return res, time.process_time() - t


def cross_check_table(names) -> int:
    """The ``--cross-check`` table (see the module text)."""
    engine = default_engine()
    print(
        "| scene | cross-check settings | its CPU s (flexible at commissioning settings) | "
        "vs flexible x0.25: max / median (mm) | vs rigid x0.25: max / median (mm) | "
        "flexible at commissioning settings vs flexible x0.25 / rigid x0.25, max (mm) |"
    )
    print("|---|---|---|---|---|---|")
    worst = 0.0
    for name in names:
        base = commission_level(name)
        over = cross_check_overrides(engine, base)
        xs = scene_with_overrides(base, over)
        cpu_run(xs, "flexible")  # warm (kernel loads)
        rx, tx = cpu_run(xs, "flexible")
        r1, t1 = cpu_run(base, "flexible")
        fine = refine_scene(base, 0.25)
        rf, _ = cpu_run(fine, "flexible")
        rr, _ = cpu_run(fine, "rigid")
        dff, drr = dist_mm(rx, rf), dist_mm(rx, rr)
        worst = max(worst, float(np.nanmax(dff)))
        keys = ", ".join(f"{k.split('.')[-1]} {v:g}" for k, v in over.items()
                         if k != "model.formulation")  # fmt: skip
        print(f"| {name} | {keys} | {tx:.3f} ({t1:.3f}) | {np.nanmax(dff):.4f} / "
              f"{np.nanmedian(dff):.4f} | {np.nanmax(drr):.4f} / {np.nanmedian(drr):.4f} | "
              f"{np.nanmax(dist_mm(r1, rf)):.4f} / {np.nanmax(dist_mm(r1, rr)):.4f} |",
              flush=True)  # fmt: skip
    print(
        f"largest distance to the flexible x0.25 run: {worst:.4f} mm "
        f"(CROSS_CHECK_FLEXIBLE_ERROR_MM = {CROSS_CHECK_FLEXIBLE_ERROR_MM} mm)"
    )
    return 0


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--levels", default="1,0.5,0.25")
    ap.add_argument(
        "--cross-check",
        action="store_true",
        help="the cross-check's settings instead of the levels (module text)",
    )
    args = ap.parse_args()
    if args.cross_check:
        return cross_check_table(args.scenes or list(CROSS_SCENES))
    args.scenes = args.scenes or list(SCENES)
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
