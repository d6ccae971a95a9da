"""Save or compare engine outputs on fixed scenes (guards refactors against answer changes).

    .venv/bin/python benchmarks/compare_dwells.py save DIR      # before a change
    .venv/bin/python benchmarks/compare_dwells.py compare DIR   # after: max differences
    .venv/bin/python benchmarks/compare_dwells.py compare DIR ring13_torsion   # named scenes only

Scenes: every shipped scene in data/scenes/ as shipped; variants of ring13-push100 that switch
other kernel paths on (finer links, torsion, gravity, friction off, Coulomb + wall damping,
always-on stabilisation, the dynamic solver with backward Euler and with BDF2, stepwise motion
with pauses, backward stepping, retraction, the per-length wall law); and the Oncentra example's
own ring channel (the RT Plan's library centreline, the commissioning scene). Compares source
positions (m), tip positions, directions, push forces, contact forces and Newton iteration counts;
prints the work balance and warnings that differ. ``compare`` fails (exit 1) when a source or tip
position moves by more than ``TOL_M`` (1e-9 mm, the engine-refactor rule) or a status changes.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import (  # noqa: E402
    load_scene,
    scene_for_channel,
    scene_with_overrides,
    shipped_scenes,
)

SC = ROOT / "data" / "scenes"
EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
#: the refactor rule: positions identical to 1e-9 mm
TOL_M = 1e-12
VARIANTS = {
    "ring13_fine": {"discretisation.element_length_mm": {"thin": 1.5, "thick": 5.0}},
    "ring13_torsion": {"effects.torsion": True},
    "ring13_gravity": {"effects.gravity": True},
    "ring13_nofric": {"effects.friction": "none"},
    "ring13_coulomb_damp": {"effects.friction": "coulomb", "effects.wall_damping": True},
    "ring13_stab": {"solver.stabilisation": 1e-3},
    "ring13_dyn": {"solver.kind": "dynamic", "effects.inertia": True,
                   "effects.wall_damping": True, "motion.speed_mm_s": 500.0,
                   "solver.time_step_s": 1e-3},
    "ring13_bdf2": {"solver.kind": "dynamic", "solver.integrator": "bdf2",
                    "effects.wall_damping": True, "motion.speed_mm_s": 500.0,
                    "solver.time_step_s": 1e-3},
    "ring13_dyn_stepwise_torsion": {"solver.kind": "dynamic", "motion.kind": "stepwise",
                                    "motion.dwell_s": 0.01, "motion.step_mm": 10.0,
                                    "motion.span_mm": 40.0, "effects.torsion": True,
                                    "effects.gravity": True},
    "ring13_backward": {"motion.kind": "stepwise", "motion.backward": True,
                        "motion.step_mm": 5.0, "motion.span_mm": 40.0},
    "ring13_retract": {"motion.kind": "retract", "motion.step_mm": 5.0, "motion.span_mm": 40.0},
    "ring13_per_length": {"contact.stiffness_per_length": True},
}  # fmt: skip
KEYS = (
    "source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "newton_iters", "s_m", "offset_m",
    "contact_force_n",
)  # fmt: skip


def example_scene():
    """The commissioning scene of the shipped example: the RT Plan's ring channel, Flexitron."""
    from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

    app = applicator_from_rtplan(read_rtplan(EXAMPLE))
    return scene_for_channel(app.channel("ring"), cable="flexitron")


def case_names() -> list[str]:
    """The names :func:`cases` yields, in its order (without building the scenes)."""
    return [*shipped_scenes(), *VARIANTS, "oncentra_example_ring"]


def cases():
    for name in shipped_scenes():
        yield name, load_scene(SC / f"{name}.toml")
    base = load_scene(SC / "ring13-push100.toml")
    for name, ov in VARIANTS.items():
        yield name, scene_with_overrides(base, ov)
    yield "oncentra_example_ring", example_scene()


def outputs(res) -> dict:
    got = {k: np.asarray(getattr(res, k)) for k in KEYS}
    got["status"] = np.array(res.status)
    got["work"] = np.array([res.work[k] for k in sorted(res.work)])
    got["work_keys"] = np.array(sorted(res.work))
    got["warnings"] = np.array(list(res.warnings), dtype=str)
    got["total_newton_iters"] = np.array(res.settings["total_newton_iters"])
    got["n_stabilised_steps"] = np.array(res.settings["n_stabilised_steps"])
    return got


def parse_args(argv=None) -> argparse.Namespace:
    """The command line (``--help`` prints it); a wrong mode, a missing ``compare`` folder or an
    unknown scene name is refused with a usage message (exit status 2), not a traceback."""
    ap = argparse.ArgumentParser(
        prog="compare_dwells.py",
        description=__doc__.split("\n\n")[0],
        epilog="Scenes: " + ", ".join(case_names()),
    )
    ap.add_argument("mode", choices=("save", "compare"),
                    help="save: write the outputs to DIR; compare: compare with them")  # fmt: skip
    ap.add_argument("dir", type=Path, metavar="DIR",
                    help="folder of the saved outputs (one .npz a scene)")  # fmt: skip
    ap.add_argument("scenes", nargs="*", metavar="SCENE",
                    help="only these scenes (default: all, listed below)")  # fmt: skip
    args = ap.parse_args(argv)
    unknown = sorted(set(args.scenes) - set(case_names()))
    if unknown:
        ap.error(f"unknown scene(s): {', '.join(unknown)} (the scenes are listed by --help)")
    if args.mode == "compare" and not args.dir.is_dir():
        ap.error(f"{args.dir}: no such folder (run 'save {args.dir}' first, before the change)")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    mode, d = args.mode, args.dir
    only = set(args.scenes)
    d.mkdir(parents=True, exist_ok=True)
    worst = 0.0
    bad = []
    for name, scene in cases():
        if only and name not in only:
            continue
        res = simulate(scene)
        got = outputs(res)
        f = d / f"{name}.npz"
        if mode == "save":
            np.savez(f, **got)
            print(
                f"{name:28s} saved  status {res.status}  {res.solve_time_s * 1e3:8.1f} ms  "
                f"iters {int(got['total_newton_iters'])}  stabilised "
                f"{int(got['n_stabilised_steps'])}"
            )
            continue
        if not f.is_file():
            print(f"{name:28s} no reference saved in {d}: skipped")
            continue
        ref = np.load(f)
        dp = float(np.nanmax(np.abs(got["source_pos_m"] - ref["source_pos_m"]), initial=0.0))
        dt = float(np.nanmax(np.abs(got["tip_pos_m"] - ref["tip_pos_m"]), initial=0.0))
        df = float(np.nanmax(np.abs(got["push_force_n"] - ref["push_force_n"]), initial=0.0))
        same_it = bool(np.array_equal(got["newton_iters"], ref["newton_iters"]))
        others = max(
            float(np.nanmax(np.abs(got[k] - ref[k]), initial=0.0)) for k in KEYS if k in ref
        )
        nan_same = bool(
            np.array_equal(np.isnan(got["source_pos_m"]), np.isnan(ref["source_pos_m"]))
        )
        dwork = float(np.max(np.abs(got["work"] - ref["work"]), initial=0.0))
        warn_same = list(got["warnings"]) == list(ref["warnings"])
        status_same = int(res.status) == int(ref["status"])
        worst = max(worst, dp, dt)
        if not (status_same and nan_same and dp <= TOL_M and dt <= TOL_M):
            bad.append(name)
        print(
            f"{name:28s} status {res.status}/{int(ref['status'])}  max|dsrc| {dp:.1e} m  "
            f"max|dtip| {dt:.1e} m  max|dF| {df:.1e} N  iters same {same_it}  NaN same "
            f"{nan_same}  outputs {others:.1e}  work {dwork:.1e} J  warnings same {warn_same}  "
            f"{res.solve_time_s * 1e3:6.1f} ms"
        )
        if not warn_same:
            print(f"    warnings now: {list(got['warnings'])}")
            print(f"    before:       {list(ref['warnings'])}")
    if mode == "compare":
        ok = not bad
        print(
            f"worst position difference {worst:.3e} m ({'OK' if ok else 'FAIL: ' + ', '.join(bad)})"
        )
        return 0 if ok else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
