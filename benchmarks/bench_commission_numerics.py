"""What the commissioning simulation's numerical check costs and buys (issue 13; a script, not a
timed test).

    python benchmarks/bench_commission_numerics.py [--quick] [--json OUT.json]

Sections (markdown tables on stdout; docs/commissioning.md quotes them):

1. **Cost and honesty of the numerical check**, per applicator (the Oncentra example and the six
   shipped rings): solve time of the commissioning run and of the refined run (the price of the
   error bar is the ratio), the reported error estimate (max over the dwells), and the true
   error of the reported positions against one much finer run (the estimate should bound it).
2. **Settings scan** on the example and ring26x60: the paper's 3/10 mm links and 1 mm increment,
   the commissioning 2/5 mm and 1 mm, and 1.5/3 mm with 0.5 mm: error vs the fine run and time.
3. **Modelled stem** on the example: the dwells with 60 mm (default), 100 mm and the whole
   195 mm shaft, each one run at the 4x-fine settings, against the 60 mm run.
4. **Lumen choice** on the example (plane-height registration, mHDR-v2 cable): the paper's U at
   the circle (shipped), a circular lumen, the old 1.2 mm flat on the bend's outside and a
   1.2 mm flat towards the ring's outside: median/max simulated vs reference, how far the
   simulated dwells move from the shipped lumen's, max |dose difference| at the ring surface.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.geometry.lumen import FlatSide, Lumen  # noqa: E402
from ringqa.pipeline import CommissionSettings, commission  # noqa: E402
from ringqa.pipeline.dwells import reference_dwells  # noqa: E402
from ringqa.pipeline.inputs import load_input  # noqa: E402
from ringqa.pipeline.simulate import simulate_dwells  # noqa: E402

EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
SHIPPED = ("ring26x45", "ring26x60", "ring30x45", "ring30x60", "ring34x45", "ring34x60")
#: The reference the reported positions are compared with: one run 4x finer than the
#: commissioning's refined run (links 1/2.5 mm, increment 0.5 mm) for the Flexitron cable; for the
#: microSelectron cable on the example, whose check resolves a branching path with runs at 0.4 and
#: 0.2 mm links, one run 2x finer than the reported one.
FINE = {
    "flexitron": ({"thin": 0.25, "thick": 0.625}, 0.125),
    "microselectron": ({"cable": 0.1}, 0.05),
}


def _app(name):
    return load_input(EXAMPLE if name == "example" else name).applicator


def _cable(name):
    return "microselectron" if name == "example" else "flexitron"


def _sim(app, overrides=None, cable="flexitron", stem_mm=60.0, channel=None):
    ring = channel or app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    return simulate_dwells(app, ring, rel, cable=cable, scene_overrides=overrides or {},
                           stem_mm=stem_mm)  # fmt: skip


def _pos(run) -> np.ndarray:
    return run if isinstance(run, np.ndarray) else run.dwells.positions_mm


def _dist(a, b) -> float:
    return float(np.max(np.linalg.norm(_pos(a) - _pos(b), axis=1)))


def _reference(app, cable="flexitron", stem_mm=60.0) -> np.ndarray:
    """Source centres (mm, the reference dwells' order) of ONE run at :data:`FINE` settings."""
    from ringqa.geometry.stem import trim_to_stem
    from ringqa.simulation import simulate
    from ringqa.simulation.scenefile import scene_for_channel, scene_with_overrides
    from ringqa.units import mm_to_m

    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    channel = trim_to_stem(ring, None if stem_mm is None else mm_to_m(stem_mm)).channel
    scene = scene_with_overrides(scene_for_channel(channel, cable), _fine(cable))
    res = simulate(scene, advances_mm=channel.s_ref_m * 1e3 - rel)
    return res.source_pos_m * 1e3


def _fine(cable):
    return {
        "discretisation.element_length_mm": FINE[cable][0],
        "solver.increment_mm": FINE[cable][1],
    }


def cost_and_honesty(names) -> list[dict]:
    rows = []
    for name in names:
        app, cable = _app(name), _cable(name)
        _sim(app, cable=cable)  # compile
        t0 = time.perf_counter()
        got = _sim(app, cable=cable)
        wall = time.perf_counter() - t0
        ref = _reference(app, cable)
        n = got.numerics
        rows.append({
            "applicator": name, "cable": cable, "runs": n.n_runs,
            "commissioning_s": n.solve_time_s, "refined_s": n.refined_solve_time_s,
            "cost_ratio": (n.solve_time_s + n.refined_solve_time_s) / n.solve_time_s,
            "wall_s": wall, "estimate_mm": n.max_mm, "true_error_mm": _dist(got, ref),
            "probes": n.n_probes, "resolved": n.resolved, "branch_mm": n.branch_mm,
            "stabilised": n.stabilised_steps,
        })  # fmt: skip
    return rows


def settings_scan(names) -> list[dict]:
    candidates = {
        "paper 3/10 mm, 1 mm": {"thin": 3.0, "thick": 10.0, "inc": 1.0},
        "commissioning 2/5 mm, 1 mm": {"thin": 2.0, "thick": 5.0, "inc": 1.0},
        "1.5/3 mm, 0.5 mm": {"thin": 1.5, "thick": 3.0, "inc": 0.5},
    }
    rows = []
    for name in names:
        app = _app(name)
        ref = _reference(app)
        for label, c in candidates.items():
            got = _sim(app, {"discretisation.element_length_mm": {"thin": c["thin"],
                                                                  "thick": c["thick"]},
                             "solver.increment_mm": c["inc"]})  # fmt: skip
            rows.append({"applicator": name, "settings": label,
                         "estimate_mm": got.numerics.max_mm, "true_error_mm": _dist(got, ref),
                         "time_s": got.numerics.solve_time_s + got.numerics.refined_solve_time_s,
                         "stabilised": got.numerics.stabilised_steps})  # fmt: skip
    return rows


def stem_sensitivity() -> list[dict]:
    app = _app("example")
    runs = {stem: _reference(app, stem_mm=stem) for stem in (60.0, 100.0, None)}
    return [{"stem_mm": "whole channel" if stem is None else stem,
             "vs_60_mm_max_mm": _dist(run, runs[60.0]),
             "median_mm": float(np.median(np.linalg.norm(run - runs[60.0], axis=1)))}
            for stem, run in runs.items()]  # fmt: skip


def _with_lumen(app, make):
    ring = app.channel("ring")
    lumen = make(ring.lumen)
    chans = tuple(dataclasses.replace(c, lumen=lumen) if c.name == "ring" else c
                  for c in app.channels)  # fmt: skip
    return dataclasses.replace(app, channels=chans)


def lumen_choice() -> list[dict]:
    app = _app("example")
    frame = FlatSide("ring_outside", app.ring_centre_m, app.ring_normal)

    def flat(value_m, side):
        def make(lum: Lumen) -> Lumen:
            seg = np.where(np.isfinite(lum.seg_flat), value_m, np.inf)
            return dataclasses.replace(lum, seg_flat=seg, flat_side=side, source="benchmark")

        return make

    variants = {
        "paper's U at the circle (shipped)": lambda lum: lum,
        "circular": lambda lum: dataclasses.replace(lum, seg_flat=np.full_like(lum.seg_flat,
                                                                               np.inf)),
        "1.2 mm flat, bend outside (old)": flat(1.2e-3, FlatSide()),
        "1.2 mm flat, ring outside": flat(1.2e-3, frame),
    }  # fmt: skip
    settings = CommissionSettings(register="plane-height", source="mhdr-v2")
    results = {k: commission(_with_lumen(app, make), settings) for k, make in variants.items()}
    base = results["paper's U at the circle (shipped)"]
    rows = []
    for label, res in results.items():
        s = res.summary
        sim = res.dwells[res.dwells.path == "simulated"][["x_mm", "y_mm", "z_mm"]].to_numpy()
        sim0 = base.dwells[base.dwells.path == "simulated"][["x_mm", "y_mm", "z_mm"]].to_numpy()
        rows.append({
            "lumen": label,
            "median_sim_vs_ref_mm": s.simulated_registered.median_dist_mm,
            "max_sim_vs_ref_mm": s.simulated_registered.max_dist_mm,
            "moves_sim_max_mm": float(np.max(np.linalg.norm(sim - sim0, axis=1))),
            "median_radial_sim_mm": s.median_radial["sim"],
            "surface_dose_diff_sim_pct": s.max_abs_diff_registered_pct["simulated"]["surface"],
            "numerical_error_mm": s.max_numerical_error_mm,
        })  # fmt: skip
    return rows


def _table(rows: list[dict]) -> str:
    keys = list(rows[0])
    out = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        out.append("| " + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v)
                                     for v in r.values()) + " |")  # fmt: skip
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the example and ring26x60 only")
    ap.add_argument("--json", type=Path, default=None, help="write the tables as JSON")
    args = ap.parse_args(argv)
    names = ("example", "ring26x60") if args.quick else ("example", *SHIPPED)
    report = {}
    for title, fn in (
        ("1. Cost and honesty of the numerical check", lambda: cost_and_honesty(names)),
        ("2. Settings scan (Flexitron cable)", lambda: settings_scan(("example", "ring26x60"))),
        ("3. Modelled stem (example, 4x-fine settings)", stem_sensitivity),
        ("4. Lumen choice (example, plane-height, mHDR-v2 cable)", lumen_choice),
    ):
        rows = fn()
        report[title] = rows
        print(f"\n## {title}\n\n{_table(rows)}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
