"""Fewer load steps (issue 29): what the number of quasi-static load steps can save, measured.

    .venv/bin/python benchmarks/bench_load_steps.py dwells [SCENE]
    .venv/bin/python benchmarks/bench_load_steps.py approach [SCENE ...] [--main-job]

Nothing here changes the engine: each measurement patches the schedule or the predictor of the
Python load-step loop (``driver.USE_MARCH = False``, bit for bit the compiled loop) in this
process. docs/engine.md, "Fewer load steps (branch coarse, 2026-11-29)", has the numbers.

``dwells`` (default ring26-flexitron; scenes whose dwells are one increment apart, forward):
solve only every D-th dwell (D = 2, 3, 4) with steps of D
increments after the first dwell (the approach unchanged), and give the dwells between by dense
output. Printed per D: Newton iterations per step between dwells, how far the solved dwells
moved from the increment's path (the friction's path dependence), and the dense output's error
at the skipped dwells against their solved positions (linear in space; linear and quadratic in
channel coordinates: arc length and offset along the normal and binormal). Then the Newton
iterations of each odd dwell's step started from the midpoint of its neighbours' converged states
(an interpolated start) against the shipped predictor's.

``approach`` (default every quasi-static compare_dwells scene): the approach to the first dwell
records nothing; a hard step (more than one Newton iteration) there resets the step to
``--factor`` increments (2) instead of one, up to the settling point (the last point of the
increment grid from the start ``--settle`` increments (4) or more before the first dwell), from
where the steps are the increment's. Printed per scene: steps, iterations and stabilised steps
without / with it, how far it moves the dwells (source centre or tip, m), and the scene's
numerical error as ``ringqa commission`` measures it (the largest source-centre distance to the
run refined once: element lengths and increment halved), mm. ``--main-job`` adds the README main
job's engine runs (captured as ``benchmarks/bench_failed_steps.py`` does; no refined runs).
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
from ringqa.simulation import model as model_mod  # noqa: E402
from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation._kernels import restore_lengths  # noqa: E402
from ringqa.simulation.scenefile import scene_with_overrides  # noqa: E402
from ringqa.simulation.solvers import driver, recorder, stepper  # noqa: E402
from ringqa.simulation.solvers import schedule as schedule_mod  # noqa: E402

#: the patches' switches (module state: one measurement at a time)
PATCH: dict = {"dwell_step": None, "coarse": None, "start": None, "log": None, "states": None}

_next_step = schedule_mod.Schedule.next_step
_predict = model_mod.Model.predict
_take = stepper.Stepper.take
_record = recorder.Recorder.record


def _patched_next_step(self, u, leg, dwell_left):
    """The schedule with the measurement's rule (``PATCH``), else the engine's."""
    base = self.model.increment
    if PATCH["dwell_step"] is not None and leg.index > 0:  # D increments between dwells
        inc = PATCH["dwell_step"] * base
        du = min(max(leg.target_m - u, -inc), inc)
        return du, abs(du) / self.model.speed
    coarse = PATCH["coarse"]
    if coarse is not None and self.slide_grow and leg.index == 0 and leg.target_m > u:
        factor, settle = coarse
        if not hasattr(self, "_settle_u"):
            u0 = self.model.u_start
            self._settle_u = u0 + np.floor((leg.target_m - u0) / base - settle + 1e-9) * base
            self._taken = 0
        inc = self.inc
        # a hard step left the step at the increment: take `factor` increments instead (not
        # the run's first step), while the whole step stays before the settling point
        if self._taken > 0 and inc < factor * base and u + factor * base <= self._settle_u + 1e-12:
            inc = factor * base
        self._taken += 1
        du = min(max(leg.target_m - u, -inc), inc)
        return du, abs(du) / self.model.speed
    return _next_step(self, u, leg, dwell_left)


def _patched_predict(self, q, du, u_new, slide):
    """The engine's predictor, or the midpoint of two given states (``PATCH['start']``)."""
    _predict(self, q, du, u_new, slide)
    start = PATCH["start"]
    if start is not None:
        got = start.get(round(u_new * 1e9))
        if got is not None:
            q[:] = got
            restore_lengths(q, self.nd, self.n_nodes, self.chain.link_len)
            self._extrapolated = False


def _patched_take(self, u, du, dt, q, v, hist, first=None):
    out = _take(self, u, du, dt, q, v, hist, first)
    if PATCH["log"] is not None:
        PATCH["log"][round((u + du) * 1e9)] = out.iters
    return out


def _patched_record(self, idx, q, u, push, iters):
    if PATCH["states"] is not None:
        PATCH["states"][round(u * 1e9)] = q.copy()
    return _record(self, idx, q, u, push, iters)


def _install() -> None:
    driver.USE_MARCH = False
    schedule_mod.Schedule.next_step = _patched_next_step
    model_mod.Model.predict = _patched_predict
    stepper.Stepper.take = _patched_take
    recorder.Recorder.record = _patched_record


class _Frames:
    """Channel coordinates (arc length, offsets along the normal and binormal) of points."""

    def __init__(self, scene, advances_m) -> None:
        self.tb = model_mod.Model(scene, advances_m).table

    def _frame(self, s):
        tb = self.tb
        k = s / tb.h
        i = int(np.clip(np.floor(k), 0, tb.pos.shape[0] - 2))
        f = k - i
        t = (1 - f) * tb.tan[i] + f * tb.tan[i + 1]
        t /= np.linalg.norm(t)
        n = (1 - f) * tb.nor[i] + f * tb.nor[i + 1]
        n -= t * np.dot(n, t)
        n /= np.linalg.norm(n)
        return tb.point(s), n, np.cross(t, n)

    def to(self, p, hint):
        s, _ = self.tb.closest(p, hint)
        c, n, b = self._frame(s)
        return np.array([s, (p - c) @ n, (p - c) @ b])

    def back(self, x):
        c, n, b = self._frame(x[0])
        return c + x[1] * n + x[2] * b


def dwells(name: str) -> None:
    scene = dict(compare_dwells.cases())[name]
    adv = np.asarray(scene.motion.advances_m, dtype=float)
    spacing = np.diff(np.sort(adv))
    if not np.allclose(spacing, scene.solver.increment_m, rtol=1e-6, atol=1e-12):
        print(f"{name}: skipped (dwells not one increment apart: the measurement assumes it)")
        return
    PATCH["log"], PATCH["states"] = {}, {}
    ref = simulate(scene)
    log, states = PATCH["log"], PATCH["states"]
    PATCH["log"] = PATCH["states"] = None
    keys = sorted(states)
    first = keys[0]
    steps_between = [log[k] for k in keys[1:]]
    ds = np.diff(ref.s_m) / np.diff(adv)  # source advance along the centreline per input
    print(
        f"{name}: {ref.stats.n_steps} steps, {ref.stats.n_newton_iters} Newton iterations; "
        f"{len(steps_between)} steps between dwells, {np.mean(steps_between):.2f} iterations a "
        f"step; the source advances {ds.min():.3f}-{ds.max():.3f} mm per mm of input between "
        f"dwells (neighbouring rates up to {np.max(np.abs(np.diff(ds))):.3f} apart)"
    )
    frames = _Frames(scene, adv)
    print("| D | iterations a step between solved dwells | solved dwells moved, max / median "
          "(mm) | dense output error at the others, max / median (mm): linear | channel "
          "coordinates, linear | quadratic |")  # fmt: skip
    print("|---|---|---|---|---|---|")
    for d in (2, 3, 4):
        idx = np.arange(0, adv.size, d)
        if idx[-1] != adv.size - 1:
            idx = np.append(idx, adv.size - 1)
        PATCH["dwell_step"] = d
        got = simulate(scene, advances_mm=adv[idx] * 1e3)
        PATCH["dwell_step"] = None
        moved = np.linalg.norm(got.source_pos_m - ref.source_pos_m[idx], axis=1) * 1e3
        per_step = float(np.mean(got.newton_iters[1:] / np.maximum(np.diff(idx), 1) * d))
        src, ua = got.source_pos_m, adv[idx]
        chan = [frames.to(src[k], got.s_m[k]) for k in range(idx.size)]
        err: dict[str, list] = {"lin": [], "chan": [], "quad": []}
        for j in range(adv.size):
            if j in idx:
                continue
            k = int(np.searchsorted(idx, j)) - 1
            a = (adv[j] - ua[k]) / (ua[k + 1] - ua[k])
            true = ref.source_pos_m[j]
            err["lin"].append(np.linalg.norm((1 - a) * src[k] + a * src[k + 1] - true))
            err["chan"].append(np.linalg.norm(frames.back((1 - a) * chan[k] + a * chan[k + 1])
                                              - true))  # fmt: skip
            ks = [k - 1, k, k + 1] if k >= 1 else [k, k + 1, k + 2]
            if ks[-1] < idx.size:
                uu = ua[ks]
                w = [np.prod([(adv[j] - uu[m]) / (uu[i] - uu[m]) for m in range(3) if m != i])
                     for i in range(3)]  # fmt: skip
                x = sum(w[i] * chan[ks[i]] for i in range(3))
                err["quad"].append(np.linalg.norm(frames.back(x) - true))
        cells = " | ".join(
            f"{1e3 * np.max(v):.4f} / {1e3 * np.median(v):.4f}" for v in err.values()
        )
        print(f"| {d} | {per_step:.2f} | {moved.max():.4f} / {np.median(moved):.4f} | {cells} |")
    # an interpolated start: each odd dwell's step from the midpoint of its neighbours' states
    odd = [keys[i] for i in range(1, len(keys) - 1, 2)]
    PATCH["start"] = {k: 0.5 * (states[keys[i - 1]] + states[keys[i + 1]])
                      for i, k in enumerate(keys) if k in odd}  # fmt: skip
    PATCH["log"] = {}
    mid = simulate(scene)
    PATCH["start"] = None
    it_mid = [PATCH["log"][k] for k in odd]
    PATCH["log"] = None
    moved = float(np.nanmax(np.abs(mid.source_pos_m - ref.source_pos_m)))
    print(
        f"interpolated start (midpoint of the neighbours' converged states, restored lengths) at "
        f"{len(odd)} odd dwells: {np.mean(it_mid):.2f} iterations a step, the shipped predictor "
        f"{np.mean([log[k] for k in odd]):.2f} (the first dwell {first / 1e6:.3f} mm; answers "
        f"within {moved:.1e} m)"
    )


def _numerical_error_mm(scene, res) -> float:
    fine = simulate(scene_with_overrides(scene, scaled_overrides(scene, 0.5, 0.5)))
    return 1e3 * float(np.nanmax(np.linalg.norm(res.source_pos_m - fine.source_pos_m, axis=1)))


def approach(names: list[str], factor: int, settle: int, main_job: bool) -> None:
    runs = []
    for name, scene in compare_dwells.cases():
        if (not names or name in names) and scene.solver.kind != "dynamic":
            runs.append((name, scene, None, True))
    if main_job:
        import pickle
        import tempfile

        import bench_failed_steps

        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "runs.pkl"
            bench_failed_steps.capture(path)
            with open(path, "rb") as f:
                captured = pickle.load(f)
        driver.USE_MARCH = False  # (the capture ran the job through ringqa.cli)
        runs += [(f"main job run {i}", s, a, False) for i, (s, a) in enumerate(captured)]
    print(f"coarse approach: {factor} increments after a hard step, settling {settle} increments")
    print("| run | steps off -> on | iterations | stabilised | moved (m) | numerical error (mm) |")
    print("|---|---|---|---|---|---|")
    for name, scene, adv, err in runs:
        PATCH["coarse"] = None
        off = simulate(scene, advances_mm=adv)
        PATCH["coarse"] = (factor, settle)
        on = simulate(scene, advances_mm=adv)
        PATCH["coarse"] = None
        moved = max(
            float(np.nanmax(np.linalg.norm(on.source_pos_m - off.source_pos_m, axis=1))),
            float(np.nanmax(np.linalg.norm(on.tip_pos_m - off.tip_pos_m, axis=1))),
        )
        a, b = off.stats, on.stats
        e = f"{_numerical_error_mm(scene, off):.4f}" if err else "-"
        print(
            f"| {name} | {a.n_steps} -> {b.n_steps} | {a.n_newton_iters} -> {b.n_newton_iters} "
            f"| {a.n_stabilised_steps} -> {b.n_stabilised_steps} | {moved:.1e} | {e} |",
            flush=True,
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mode", choices=("dwells", "approach"))
    ap.add_argument("scenes", nargs="*", help="compare_dwells scene names")
    ap.add_argument("--factor", type=int, default=2, help="approach: increments a coarse step")
    ap.add_argument("--settle", type=int, default=4, help="approach: settling increments")
    ap.add_argument("--main-job", action="store_true", help="approach: the main job's runs too")
    args = ap.parse_args(argv)
    _install()
    if args.mode == "dwells":
        for name in args.scenes or ["ring26-flexitron"]:
            dwells(name)
    else:
        approach(args.scenes, args.factor, args.settle, args.main_job)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
