"""Save or compare engine outputs on fixed scenes (guards optimisations against answer changes).

    /work/venv/bin/python benchmarks/compare_dwells.py save DIR      # before a change
    /work/venv/bin/python benchmarks/compare_dwells.py compare DIR   # after: max differences

Scenes: data/scenes/ring13-push100.toml and ring26-flexitron.toml as shipped, plus variants of
ring13-push100 that switch other kernel paths on (finer links, torsion, gravity, friction off,
wall damping, always-on stabilisation, the dynamic solver). Compares source positions (m), tip
positions, directions, push forces and Newton iteration counts.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import load_scene  # noqa: E402

SC = ROOT / "data" / "scenes"
VARIANTS = {
    "ring13": {},
    "ring13_fine": {"discretisation.element_length_mm": {"thin": 1.5, "thick": 5.0}},
    "ring13_torsion": {"effects.torsion": True},
    "ring13_gravity": {"effects.gravity": True},
    "ring13_nofric": {"effects.friction": "none"},
    "ring13_coulomb_damp": {"effects.friction": "coulomb", "effects.wall_damping": True},
    "ring13_stab": {"solver.stabilisation": 1e-3},
    "ring13_dyn": {"solver.kind": "dynamic", "effects.inertia": True,
                   "effects.wall_damping": True, "motion.speed_mm_s": 500.0,
                   "solver.time_step_s": 1e-3},
}  # fmt: skip
KEYS = (
    "source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "newton_iters", "s_m", "offset_m",
    "contact_force_n",
)  # fmt: skip


def cases():
    base = load_scene(SC / "ring13-push100.toml")
    for name, ov in VARIANTS.items():
        yield name, (base.with_overrides(ov) if ov else base)
    yield "ring26", load_scene(SC / "ring26-flexitron.toml")


def main() -> int:
    mode, d = sys.argv[1], Path(sys.argv[2])
    d.mkdir(parents=True, exist_ok=True)
    worst = 0.0
    for name, scene in cases():
        res = simulate(scene)
        got = {k: np.asarray(getattr(res, k)) for k in KEYS}
        got["status"] = np.array(res.status)
        f = d / f"{name}.npz"
        if mode == "save":
            np.savez(f, **got)
            print(f"{name:22s} saved  status {res.status}  {res.solve_time_s * 1e3:8.1f} ms")
            continue
        ref = np.load(f)
        dp = float(np.nanmax(np.abs(got["source_pos_m"] - ref["source_pos_m"])))
        dt = float(np.nanmax(np.abs(got["tip_pos_m"] - ref["tip_pos_m"])))
        df = float(np.nanmax(np.abs(got["push_force_n"] - ref["push_force_n"])))
        same_it = bool(np.array_equal(got["newton_iters"], ref["newton_iters"]))
        others = max(
            float(np.nanmax(np.abs(got[k] - ref[k]), initial=0.0)) for k in KEYS if k in ref
        )
        nan_ref = np.isnan(ref["source_pos_m"])
        nan_same = bool(np.array_equal(np.isnan(got["source_pos_m"]), nan_ref))
        worst = max(worst, dp, dt)
        print(
            f"{name:22s} status {res.status}/{int(ref['status'])}  max|dsrc| {dp:.3e} m  "
            f"max|dtip| {dt:.3e} m  max|dF| {df:.3e} N  iters same {same_it}  "
            f"NaN same {nan_same}  all outputs {others:.1e}  {res.solve_time_s * 1e3:6.1f} ms"
        )
    if mode == "compare":
        print(f"worst position difference {worst:.3e} m ({'OK' if worst <= 1e-9 else 'FAIL'})")
        return 0 if worst <= 1e-9 else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
