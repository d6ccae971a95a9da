"""What the commissioning simulation's numerical check costs and buys (issue 13; a script, not a
timed test).

    python benchmarks/bench_commission_numerics.py [--quick] [--only 3,5] [--fine] [--json OUT]

Sections (markdown tables on stdout; docs/commissioning.md quotes them):

1. **Cost and honesty of the numerical check**, per applicator (the Oncentra example and the six
   shipped rings): solve time of the commissioning run and of the refined run (the price of the
   error bar is the ratio), the reported error estimate (max over the dwells), and the true
   error of the reported positions against one much finer run (the estimate should bound it).
2. **Settings scan** on the example and ring26x60: the paper's 3/10 mm links and 1 mm increment,
   the commissioning 2/5 mm and 1 mm, and 1.5/3 mm with 0.5 mm: error vs the fine run and time.
3. **Modelled stem** on the example (its own microSelectron cable, plane-height registration as
   in the README; ``--cable flexitron`` for the Flexitron's): one engine run for each stem
   (60 mm default, 100, 150 mm, the whole channel) at 1, 1/2 and 1/4 of the commissioning
   settings (``--fine``: also 1/8): its cost (process CPU
   time, links, load steps, stabilised steps), its dwells' distance from the reported positions
   (60 mm, refined) and from the whole channel at 1/4, and the Point A and lateral-surface dose
   differences of the commissioning with those dwells (the pipeline's own doses, through an
   engine pinned to that one run).
4. **Lumen choice** on the example (plane-height registration, mHDR-v2 cable): the paper's U at
   the circle (shipped), a circular lumen, the old 1.2 mm flat on the bend's outside and a
   1.2 mm flat towards the ring's outside: median/max simulated vs reference, how far the
   simulated dwells move from the shipped lumen's, max |dose difference| at the ring surface.
5. **The stem in the numerical check** (issue 28): the example's check without and with the
   modelled stem's share (process CPU time of this process and its forked children, wall), the
   printed error (max/median) and its discretisation and stem shares, and whether it covers, at
   every dwell, the distance to the whole channel at 1/4 (and 1/8 with ``--fine``) of the
   settings: the smallest ratio printed/distance; also what a single whole-channel probe at the
   commissioning settings would have printed. The six shipped rings have a 60 mm stem: nothing
   is cut, the check is unchanged.
6. **What if the shaft were narrow** (an experiment, not a shipped setting: no sourced diameter):
   the example's whole channel with the lumen of the straight shaft the cut drops narrowed to
   ``--shaft-rb-mm`` (default 0.7 mm radius; the paper mentions a plastic tube insert in the
   stem): its runs at 1, 1/2, 1/4 of the settings, how far apart they are and from the reported
   (cut) positions.
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
from ringqa.pipeline import simulate as sim_module  # noqa: E402
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


def _pinned_engine(record: dict):
    """ringqa's engine with ``refine`` the identity and each scene simulated once (cached): a
    commissioning then reports ONE run at the scene's settings (the numerical check sees two equal
    runs, error 0); ``record`` gets that run's result and process CPU time."""
    import dataclasses as dc

    from ringqa.pipeline.simulate import default_engine
    from ringqa.simulation import simulate

    cache: dict = {}

    def sim(scene, advances_mm=None, progress=False):
        if id(scene) not in cache:
            t0 = time.process_time()
            cache[id(scene)] = (scene, simulate(scene, advances_mm=advances_mm))
            record.update(res=cache[id(scene)][1], cpu_s=time.process_time() - t0)
        return cache[id(scene)][1]

    return dc.replace(default_engine(), simulate=sim, refine=lambda scene, factor: scene)


def _commission_at(stem_mm, factor, cable="microselectron"):
    """The example commissioned (``cable``, plane-height) with its dwells from ONE run of
    ``stem_mm`` (None: the whole channel) at ``factor`` x the commissioning settings."""
    from ringqa.pipeline.simulate import COMMISSION_ELEMENT_MM, COMMISSION_INCREMENT_MM

    record: dict = {}
    over = {"discretisation.element_length_mm": {k: v * factor for k, v in
                                                 COMMISSION_ELEMENT_MM[cable].items()},
            "solver.increment_mm": COMMISSION_INCREMENT_MM * factor}  # fmt: skip
    settings = CommissionSettings(
        register="plane-height", stem_mm=stem_mm, scene_overrides=over, cable=cable
    )
    check, sim_module.STEM_CHECK = sim_module.STEM_CHECK, False  # this one run only
    try:
        res = commission(EXAMPLE, settings, engine=_pinned_engine(record))
    finally:
        sim_module.STEM_CHECK = check
    return res, record


def _sim_pos(res) -> np.ndarray:
    return res.dwells[res.dwells.path == "simulated"][["x_mm", "y_mm", "z_mm"]].to_numpy()


def _doses(res) -> tuple[float, float]:
    d = res.summary.max_abs_diff_registered_pct["simulated"]
    return float(d["point_a"]), float(d["surface"])


def stem_sensitivity(fine: bool = False, cable: str = "microselectron") -> list[dict]:
    factors = (1.0, 0.5, 0.25, 0.125) if fine else (1.0, 0.5, 0.25)
    reported = commission(EXAMPLE, CommissionSettings(register="plane-height", cable=cable))
    rep = _sim_pos(reported)
    runs = {}
    for stem in (60.0, 100.0, 150.0, None):
        for f in factors:
            runs[(stem, f)] = _commission_at(stem, f, cable)
    whole = _sim_pos(runs[(None, 0.25)][0])
    point_a, surface = _doses(reported)
    rows = [{"stem_mm": "60 (reported)", "factor": "check", "cpu_s": float("nan"), "links": "",
             "steps": "", "stabilised": "", "vs_reported_max_mm": 0.0,
             "vs_reported_median_mm": 0.0,
             "vs_whole_x0.25_max_mm": float(np.max(np.linalg.norm(rep - whole, axis=1))),
             "vs_whole_x0.25_median_mm": float(np.median(np.linalg.norm(rep - whole, axis=1))),
             "point_a_pct": point_a, "surface_pct": surface}]  # fmt: skip
    for (stem, f), (res, rec) in runs.items():
        pos = _sim_pos(res)
        d_rep = np.linalg.norm(pos - rep, axis=1)
        d_whole = np.linalg.norm(pos - whole, axis=1)
        point_a, surface = _doses(res)
        st = rec["res"].stats
        rows.append({
            "stem_mm": "whole channel" if stem is None else f"{stem:g}", "factor": f,
            "cpu_s": rec["cpu_s"], "links": int(rec["res"].n_elements), "steps": st.n_steps,
            "stabilised": st.n_stabilised_steps, "vs_reported_max_mm": float(np.max(d_rep)),
            "vs_reported_median_mm": float(np.median(d_rep)),
            "vs_whole_x0.25_max_mm": float(np.max(d_whole)),
            "vs_whole_x0.25_median_mm": float(np.median(d_whole)),
            "point_a_pct": point_a, "surface_pct": surface,
        })  # fmt: skip
    _STEM_RUNS.update({k: _sim_pos(v[0]) for k, v in runs.items()})
    return rows


#: section 3's dwells per (stem_mm, factor), for section 5
_STEM_RUNS: dict = {}


def _cpu_s() -> float:
    """Process CPU time of this process and its reaped children (the forked runs), s."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def stem_in_the_check(fine: bool = False, cable: str = "microselectron") -> list[dict]:
    app = _app("example")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    refs = {f: _STEM_RUNS.get((None, f)) for f in ((0.25, 0.125) if fine else (0.25,))}
    for f, pos in list(refs.items()):
        if pos is None:
            refs[f] = _sim_pos(_commission_at(None, f, cable)[0])
    simulate_dwells(app, ring, rel, cable=cable, scene_overrides={}, stem_mm=60.0)
    rows = []
    for check in (False, True):
        cpu, t0 = _cpu_s(), time.perf_counter()
        got = simulate_dwells(app, ring, rel, cable=cable, scene_overrides={},
                              stem_mm=60.0, stem_check=check)  # fmt: skip
        wall, cpu = time.perf_counter() - t0, _cpu_s() - cpu
        n = got.numerics
        row = {"stem_check": check, "runs": n.n_runs, "cpu_s": cpu, "wall_s": wall,
               "printed_max_mm": n.max_mm, "printed_median_mm": n.median_mm,
               "discretisation_max_mm": float(np.max(n.discretisation_mm)),
               "stem_share_max_mm": 0.0 if n.stem is None else n.stem.max_mm}  # fmt: skip
        for f, whole in refs.items():
            d = np.linalg.norm(got.dwells.positions_mm - whole, axis=1)
            row[f"whole_x{f}_max_mm"] = float(np.max(d))
            row[f"min_printed/dist_x{f}"] = float(np.min(n.error_mm / d))
            row[f"dwells_short_x{f}"] = int(np.sum(n.error_mm < d))
        rows.append(row)
    # what a single whole-channel probe at the commissioning settings would have printed
    w1 = _STEM_RUNS.get((None, 1.0))
    if w1 is None:
        w1 = _sim_pos(_commission_at(None, 1.0, cable)[0])
    printed = n.discretisation_mm + np.linalg.norm(w1 - got.dwells.positions_mm, axis=1)
    row = {k: float("nan") for k in rows[0]}
    row.update({"stem_check": "one probe at x1 (not used)", "runs": 5,
                "printed_max_mm": float(np.max(printed)),
                "printed_median_mm": float(np.median(printed))})  # fmt: skip
    for f, whole in refs.items():
        d = np.linalg.norm(got.dwells.positions_mm - whole, axis=1)
        row[f"whole_x{f}_max_mm"] = float(np.max(d))
        row[f"min_printed/dist_x{f}"] = float(np.min(printed / d))
        row[f"dwells_short_x{f}"] = int(np.sum(printed < d))
    rows.append(row)
    return rows


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


def narrow_shaft(rb_mm: float = 0.7, cable: str = "microselectron") -> list[dict]:
    from ringqa.geometry.stem import trim_to_stem
    from ringqa.pipeline.simulate import commission_scene, default_engine, refine_scene
    from ringqa.simulation import simulate
    from ringqa.units import mm_to_m

    app = _app("example")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    rep = simulate_dwells(app, ring, rel, cable=cable, scene_overrides={}, stem_mm=60.0,
                          stem_check=False).dwells.positions_mm  # fmt: skip
    cut = trim_to_stem(ring, mm_to_m(60.0)).dropped_m
    lum, rb = ring.lumen, mm_to_m(rb_mm)
    narrow = Lumen(np.r_[-np.inf, cut, lum.seg_s[1:]], np.r_[rb, lum.seg_rb],
                   np.r_[rb - 1e-4, lum.seg_ra], np.r_[np.inf, lum.seg_flat], lum.flat_side,
                   "benchmark: narrow shaft")  # fmt: skip
    ch = dataclasses.replace(ring, lumen=narrow)
    base = commission_scene(default_engine(), ch, cable, {})
    adv = ch.s_ref_m * 1e3 - rel
    order = np.argsort(adv)
    rows, prev = [], None
    for f in (1.0, 0.5, 0.25):
        t0 = time.process_time()
        res = simulate(base if f == 1.0 else refine_scene(base, f), advances_mm=adv[order])
        cpu = time.process_time() - t0
        pos = np.empty((rel.size, 3))
        pos[order] = res.source_pos_m * 1e3
        d = np.linalg.norm(pos - rep, axis=1)
        rows.append({"shaft_rb_mm": rb_mm, "factor": f, "cpu_s": cpu,
                     "stabilised": res.stats.n_stabilised_steps, "steps": res.stats.n_steps,
                     "vs_reported_max_mm": float(np.max(d)),
                     "vs_reported_median_mm": float(np.median(d)),
                     "vs_previous_max_mm": float("nan") if prev is None
                     else float(np.max(np.linalg.norm(pos - prev, axis=1)))})  # fmt: skip
        prev = pos
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
    ap.add_argument(
        "--cable",
        default="microselectron",
        help="sections 3 and 5: the cable simulated (default the example's own)",
    )
    ap.add_argument("--shaft-rb-mm", type=float, default=0.7, help="section 6's shaft radius")
    ap.add_argument("--only", default="", help="comma-separated section numbers, e.g. 3,5")
    ap.add_argument(
        "--fine",
        action="store_true",
        help="sections 3 and 5: also 1/8 of the settings (about 2 CPU minutes more)",
    )
    args = ap.parse_args(argv)
    names = ("example", "ring26x60") if args.quick else ("example", *SHIPPED)
    only = {int(x) for x in args.only.split(",") if x.strip()}
    report = {}
    for number, title, fn in (
        (1, "1. Cost and honesty of the numerical check", lambda: cost_and_honesty(names)),
        (2, "2. Settings scan (Flexitron cable)", lambda: settings_scan(("example", "ring26x60"))),
        (3, "3. Modelled stem (example, own cable, one run each)",
         lambda: stem_sensitivity(args.fine, args.cable)),
        (4, "4. Lumen choice (example, plane-height, mHDR-v2 cable)", lumen_choice),
        (5, "5. The stem in the numerical check (example)",
         lambda: stem_in_the_check(args.fine, args.cable)),
        (6, "6. What if the shaft were narrow (example, experiment)",
         lambda: narrow_shaft(args.shaft_rb_mm, args.cable)),
    ):  # fmt: skip
        if only and number not in only:
            continue
        rows = fn()
        report[title] = rows
        print(f"\n## {title}\n\n{_table(rows)}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
