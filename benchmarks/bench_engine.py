"""Issue-4 performance report for the rod-in-channel engine (a script, not a timed test).

    /work/venv/bin/python benchmarks/bench_engine.py [--quick] [--json OUT.json]

Scene: data/scenes/ring13-push100.toml -- the Flexitron cable (paper Table 1, Stribeck friction,
quasi-static) pushed 100 mm into a ring of centreline radius 13 mm. Reports:

1. time (engine's solve_time_s: JIT excluded; median of repeats), element count, Newton
   iterations, and the max dwell-position error against the same scene 4x refined (element
   lengths and increment / 4): the issue's target is <= 0.05 s and <= 0.05 mm;
2. scaling: time against element count (element lengths x 2, 1, 1/2, 1/4) with the fitted
   exponent (1 = linear);
3. the cost of each effect: time with it on vs off on the same scene;
4. the same for the dynamic solver (0.5 m/s, inertia, wall damping; dt and elements / 4 refined).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import load_scene  # noqa: E402

SCENE = ROOT / "data" / "scenes" / "ring13-push100.toml"


def timed(scene, repeats: int):
    times, res = [], None
    for _ in range(repeats):
        res = simulate(scene)
        times.append(res.solve_time_s)
        if res.solve_time_s > 5.0:
            break
    return res, statistics.median(times)


def err_mm(a, b) -> float:
    if a.status != 0 or b.status != 0:
        return float("nan")
    return float(np.max(np.linalg.norm((a.source_pos_m - b.source_pos_m) * 1e3, axis=1)))


def refined(scene, f: float, step_key: str):
    thin = scene.instrument.sections[1].element_length_m * 1e3
    thick = scene.instrument.sections[2].element_length_m * 1e3
    step = (
        scene.solver.time_step_s
        if step_key == "solver.time_step_s"
        else (scene.solver.increment_m * 1e3)
    )
    return scene.with_overrides(
        {"discretisation.element_length_mm": {"thin": thin * f, "thick": thick * f},
         step_key: step * f}
    )  # fmt: skip


def row(name, res, t, err=None) -> dict:
    r = {
        "case": name,
        "status": int(res.status),
        "time_s": round(t, 5),
        "n_elements": int(res.n_elements),
        "newton_iters": int(np.sum(res.newton_iters)),
    }
    if err is not None:
        r["max_err_vs_4x_mm"] = round(err, 5)
    print(
        f"{name:48s} status {r['status']:2d}  {t * 1e3:9.2f} ms  {r['n_elements']:5d} el  "
        f"{r['newton_iters']:6d} it" + (f"  err {err:.4f} mm" if err is not None else "")
    )
    return r


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="1 repeat, fewer cases")
    ap.add_argument("--json", type=Path, help="write the results as JSON here")
    args = ap.parse_args()
    reps = 1 if args.quick else 5
    base = load_scene(SCENE)
    t0 = time.perf_counter()
    simulate(base)  # compile (JIT) once; solve_time_s excludes it anyway
    print(f"first call (incl. JIT/cache load): {time.perf_counter() - t0:.2f} s")
    out: dict = {"scene": str(SCENE.relative_to(ROOT)), "repeats": reps}

    print("\n1. quasi-static, paper Table 1 settings vs 4x refined")
    res, t = timed(base, reps)
    ref, t_ref = timed(refined(base, 0.25, "solver.increment_mm"), 1)
    out["quasistatic"] = [row("default (3/10 mm, inc 1 mm)", res, t, err_mm(res, ref)),
                          row("4x refined (0.75/2.5 mm, inc 0.25 mm)", ref, t_ref)]  # fmt: skip
    half = base.with_overrides({"discretisation.element_length_mm": {"thin": 1.5, "thick": 5.0}})
    rh, th = timed(half, reps)
    rhr, thr = timed(refined(half, 0.25, "solver.increment_mm"), 1)
    out["quasistatic"] += [row("links 1.5/5 mm (inc 1 mm)", rh, th, err_mm(rh, rhr)),
                           row("its 4x refined (0.375/1.25/0.25 mm)", rhr, thr)]  # fmt: skip

    print("\n2. scaling with element count (increment fixed)")
    pts = []
    for f in (2.0, 1.0, 0.5, 0.25):
        s = base.with_overrides(
            {"discretisation.element_length_mm": {"thin": 3.0 * f, "thick": 10.0 * f}}
        )
        r, tt = timed(s, reps)
        pts.append((r.n_elements, tt, r.status))
        row(f"elements x{1 / f:g}", r, tt)
    good = [(n, tt) for n, tt, st in pts if st == 0 and tt > 0]
    if len(good) >= 2:
        k = np.polyfit(np.log([n for n, _ in good]), np.log([tt for _, tt in good]), 1)[0]
        print(f"   fitted exponent time ~ n_elements^{k:.2f} (1 = linear)")
        out["scaling"] = {"points": pts, "exponent": float(k)}

    print("\n3. cost of each effect (on vs off, same scene)")
    cases = {
        "friction none": {"effects.friction": "none"},
        "friction coulomb": {"effects.friction": "coulomb"},
        "friction stribeck (default)": {},
        "torsion on": {"effects.torsion": True},
        "gravity on": {"effects.gravity": True},
        "contact off (free rod, no wall)": {"effects.contact": False},
        "stabilisation 1e-3": {"solver.stabilisation": 1e-3},
    }
    if args.quick:
        cases = dict(list(cases.items())[:3])
    out["effects"] = []
    for name, ov in cases.items():
        s = base.with_overrides(ov) if ov else base
        r, tt = timed(s, reps)
        out["effects"].append(row(name, r, tt, err_mm(r, res)))

    print("\n4. dynamic solver (0.5 m/s, inertia, wall damping) vs 4x refined (dt, elements)")
    dyn = base.with_overrides(
        {"solver.kind": "dynamic", "effects.inertia": True, "effects.wall_damping": True,
         "motion.speed_mm_s": 500.0, "solver.time_step_s": 1e-3}
    )  # fmt: skip
    simulate(dyn)
    rd, td = timed(dyn, reps)
    rdr, tdr = timed(refined(dyn, 0.25, "solver.time_step_s"), 1)
    out["dynamic"] = [row("dynamic dt 1 ms (3/10 mm)", rd, td, err_mm(rd, rdr)),
                      row("dynamic 4x refined (dt 0.25 ms)", rdr, tdr),
                      {"dynamic_vs_quasistatic_mm": err_mm(rd, res)}]  # fmt: skip
    print(f"   dynamic vs quasi-static dwell difference: {err_mm(rd, res):.4f} mm")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
