"""The load-step predictor's continuation rule: which steps extrapolate, and what it costs.

    .venv/bin/python benchmarks/bench_predictor.py [SCENE ...] [--main-job] [--error]
    .venv/bin/python benchmarks/bench_predictor.py --rule exact=0,0 --rule tol=1e-9,0 ...

A quasi-static forward load step extrapolates (``Model.predict``: half the previous step's Newton
correction added to the slide) only when it continues the previous one
(:func:`ringqa.simulation.solvers.predictor.continuation_scale`): it starts where that one ended,
that one converged within ``EXTRAPOLATE_MAX_ITERS``, and it is as long (``EXTRAPOLATE_RTOL``; a
step of another length extrapolates ``du / pred_du`` of the correction where that ratio is at
most ``EXTRAPOLATE_SCALE_MAX``). Each ``--rule NAME=RTOL,SCALE_MAX[,RETRY]`` runs every scene
with those settings (RETRY: ``PLAIN_RETRY_MAX_ITERS``, an integer or ``none``; default the
shipped one). Default rules: ``main=0,0,20`` (53719b4: exact equality, a retry budget of 20
after a stall), ``shipped=1e-9,0``, ``scaled=1e-9,1`` (the shorter last step of a leg
extrapolated too).

Every run goes through the Python load-step loop (``driver.USE_MARCH = False``, bit for bit the
compiled one: tests/simulation/solvers/test_march.py), with ``Model.predict`` and ``Model.solve``
wrapped to classify each predicted forward step before the predictor runs:

- ``same``: continues the previous step, ``du == pred_du`` exactly;
- ``round-off``: continues it, ``du != pred_du`` but ``|du - pred_du| <= 1e-9 |du|``;
- ``shorter (leg end)`` / ``shorter (reset)``: continues it, shorter: the last step into a waypoint
  (the schedule clipped it to the target) / the increment set back after grown steps;
- ``longer``: continues a shorter step (the first step after a leg's short last step, or a grown
  step);
- ``after hard``: the previous step was hard (> ``EXTRAPOLATE_MAX_ITERS`` iterations), failed, or
  there was none; ``other``: does not start where the last prediction ended (a sub-step).

Printed per run and rule: the steps of each class (``n/extrapolated``) with their mean Newton
iterations (the first attempt's solve, the plain retry included), the run's steps, iterations and
stabilised steps, and how far its dwells (source centre and tip) moved from the first rule's
(m). ``--error`` adds the numerical error of the compare_dwells scenes as ``ringqa commission``
measures it (the largest source-centre distance to the run refined once, first rule), mm.
``--main-job`` adds the README main job's engine runs (captured as
``benchmarks/bench_failed_steps.py`` does), ``--convergence`` the friction scenes of
tests/simulation/test_convergence.py's increment study (0.125-4 mm). docs/engine.md, "The
load-step predictor and round-off", has the numbers.
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import compare_dwells  # noqa: E402

from ringqa.accuracy import scaled_overrides  # noqa: E402
from ringqa.simulation import model as model_mod  # noqa: E402
from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.scenefile import scene_with_overrides  # noqa: E402
from ringqa.simulation.solvers import driver  # noqa: E402
from ringqa.simulation.solvers import schedule as schedule_mod  # noqa: E402

CLASSES = ("same", "round-off", "shorter (leg end)", "shorter (reset)", "longer", "after hard",
           "other")  # fmt: skip
#: the measurement's state (module state: one run at a time)
LOG: dict = {"steps": None, "pending": None, "clip": None}

#: the shipped plain-retry budget after a stall (a rule's third field replaces it)
RETRY = model_mod.PLAIN_RETRY_MAX_ITERS
_predict = model_mod.Model.predict
_solve = model_mod.Model.solve
_next_step = schedule_mod.Schedule.next_step


def _classify(model, du: float, u_new: float) -> str:
    pdu, pu = model._pred_du, model._pred_u
    if not np.isfinite(pu):
        return "after hard"
    if not abs(pu + du - u_new) <= 1e-9 * abs(du):
        return "other"
    if du == pdu:
        return "same"
    if abs(du - pdu) <= 1e-9 * abs(du):
        return "round-off"
    if du < pdu:
        clip = LOG["clip"]
        leg_end = clip is not None and clip[0] == du and clip[1]
        return "shorter (leg end)" if leg_end else "shorter (reset)"
    return "longer"


def _patched_next_step(self, u, leg, dwell_left):
    du, dt = _next_step(self, u, leg, dwell_left)
    LOG["clip"] = (du, abs(du) < self.inc * (1.0 - 1e-9))  # the target clipped the step
    return du, dt


def _patched_predict(self, q, du, u_new, slide):
    cls = None
    if LOG["steps"] is not None and slide and du > 0.0 and self.extrapolate:
        cls = _classify(self, du, u_new)
    _predict(self, q, du, u_new, slide)
    if cls is not None:
        LOG["pending"] = (cls, bool(self._extrapolated))


def _patched_solve(self, effects, q, st):
    out = _solve(self, effects, q, st)
    got = LOG["pending"]
    if got is not None and LOG["steps"] is not None:
        LOG["steps"].append((got[0], got[1], int(out[1]), int(out[0])))
    LOG["pending"] = None
    return out


def _install() -> None:
    driver.USE_MARCH = False
    model_mod.Model.predict = _patched_predict
    model_mod.Model.solve = _patched_solve
    schedule_mod.Schedule.next_step = _patched_next_step


def _run(scene, adv, rtol: float, scale_max: float, retry=RETRY):
    model_mod.EXTRAPOLATE_RTOL, model_mod.EXTRAPOLATE_SCALE_MAX = rtol, scale_max
    model_mod.PLAIN_RETRY_MAX_ITERS = retry
    LOG["steps"], LOG["pending"], LOG["clip"] = [], None, None
    try:
        res = simulate(scene, advances_mm=adv)
    finally:
        steps = LOG["steps"]
        LOG["steps"] = None
    return res, steps


def _cells(steps) -> str:
    by = defaultdict(list)
    for cls, ext, it, _ in steps:
        by[cls].append((ext, it))
    out = []
    for cls in CLASSES:
        v = by.get(cls)
        if v:
            n_ext = sum(1 for e, _ in v if e)
            out.append(f"{len(v)}/{n_ext}: {np.mean([i for _, i in v]):.2f}")
        else:
            out.append("-")
    return " | ".join(out)


def _moved(a, b) -> float:
    keys = ("source_pos_m", "tip_pos_m")
    d = np.concatenate([np.linalg.norm(getattr(a, k) - getattr(b, k), axis=1) for k in keys])
    return float(np.nanmax(d)) if np.any(np.isfinite(d)) else float("nan")


def _numerical_error_mm(scene, res) -> float:
    fine = simulate(scene_with_overrides(scene, scaled_overrides(scene, 0.5, 0.5)))
    return 1e3 * float(np.nanmax(np.linalg.norm(res.source_pos_m - fine.source_pos_m, axis=1)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenes", nargs="*", help="compare_dwells scene names (default: all)")
    ap.add_argument("--rule", action="append", default=None,
                    metavar="NAME=RTOL,SCALE_MAX[,RETRY]")  # fmt: skip
    ap.add_argument("--main-job", action="store_true", help="the README main job's runs too")
    ap.add_argument("--no-scenes", action="store_true", help="only the main job's runs")
    ap.add_argument("--error", action="store_true", help="numerical error of the scenes (slow)")
    ap.add_argument("--convergence", action="store_true",
                    help="tests/simulation/test_convergence.py's friction scenes")  # fmt: skip
    args = ap.parse_args(argv)
    rules = []
    for text in args.rule or ["main=0,0,20", "shipped=1e-9,0", "scaled=1e-9,1"]:
        name, _, vals = text.partition("=")
        fields = vals.split(",")
        retry = RETRY
        if len(fields) > 2:
            retry = None if fields[2] == "none" else int(fields[2])
        rules.append((name, float(fields[0]), float(fields[1]), retry))
    runs = []
    if not args.no_scenes:
        for name, scene in compare_dwells.cases():
            if (not args.scenes or name in args.scenes) and scene.solver.kind != "dynamic":
                runs.append((name, scene, None, True))
    if args.main_job:
        import pickle
        import tempfile

        import bench_failed_steps

        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "runs.pkl"
            bench_failed_steps.capture(path)
            with open(path, "rb") as f:
                captured = pickle.load(f)
        runs += [(f"main job run {i}", s, a, False) for i, (s, a) in enumerate(captured)]
    if args.convergence:
        from ringqa.simulation.scene import Effects, SolverSettings
        from tests.simulation.builders import flexitron, ring_channel
        from tests.simulation.builders import scene as make_scene

        adv = np.arange(60.0, 101.0, 5.0)
        for inc in (4e-3, 2e-3, 1e-3, 0.5e-3, 0.25e-3, 0.125e-3):
            sc = make_scene(ring_channel(), flexitron(), effects=Effects(friction="stribeck"),
                            solver=SolverSettings(increment_m=inc))  # fmt: skip
            runs.append((f"convergence, increment {inc * 1e3:g} mm", sc, adv, False))
    _install()  # (after the capture, which ran the job through ringqa.cli)
    print("classes: n/extrapolated: mean iterations, " + " | ".join(CLASSES))
    head = ["run", "rule", *CLASSES, "steps", "iterations", "stabilised", "moved (m)"]
    print("| " + " | ".join(head) + " | numerical error (mm) |")
    print("|" + "---|" * (len(head) + 1))
    totals: dict = defaultdict(lambda: np.zeros(3, dtype=np.int64))
    for name, scene, adv, err in runs:
        first = None
        for rule, rtol, scale_max, retry in rules:
            res, steps = _run(scene, adv, rtol, scale_max, retry)
            moved = "" if first is None else f"{_moved(res, first):.1e}"
            e = ""
            if first is None:
                first = res
                e = f"{_numerical_error_mm(scene, res):.4f}" if (err and args.error) else "-"
            st = res.stats
            totals[rule] += (st.n_steps, st.n_newton_iters, st.n_stabilised_steps)
            print(
                f"| {name} | {rule} | {_cells(steps)} | {st.n_steps} | {st.n_newton_iters} | "
                f"{st.n_stabilised_steps} | {moved} | {e} |",
                flush=True,
            )
    for rule, t in totals.items():
        print(f"all runs, {rule}: {t[0]} steps, {t[1]} iterations, {t[2]} stabilised")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
