"""The engine's per-iteration kernels timed in compiled loops on states captured from a real solve.

    .venv/bin/python benchmarks/bench_kernels.py [SCENE] [--calls N] [--rounds R] [--every K]

A quasi-static run of SCENE (default ring26-flexitron) goes through the Python load-step loop
(``driver.USE_MARCH = False``, bit for bit the compiled loop) with ``Model.solve`` wrapped so
that the state every Newton solve starts from (the load step's prediction: q, the Step, the
contact samples) is copied. Every K-th of those states is then replayed in numba loops (no
dispatcher in between), each kind of call N times, R rounds, and the fastest round's mean is
printed (a loaded machine adds time, never removes it):

- ``assemble`` as Newton calls it: residual + Jacobian with fresh samples (the samples reset to
  the captured ones before every call: the step's first assembly, every sample searched), the
  same with the samples left from the previous call (a line-search trial: far samples skipped),
  residual only (the same), Jacobian only (``fresh=False``);
- ``band_solve`` on the captured state's Jacobian (the copy of B and rhs timed apart and
  subtracted);
- each effect kernel on its own (its ``add`` with and without the Jacobian, contact's
  geometry with all samples / far samples skipped);
- the whole Newton solve of the step (state reset before each).

Process CPU time is what the loops measure (one thread); under load the minimum over rounds is
the figure to compare, before/after in the same session.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numba import literal_unroll, njit

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.simulation import simulate  # noqa: E402
from ringqa.simulation.band import band_solve  # noqa: E402
from ringqa.simulation.effects.base import effect_add, effect_prepare  # noqa: E402
from ringqa.simulation.scenefile import load_scene  # noqa: E402
from ringqa.simulation.solvers.assemble import assemble  # noqa: E402
from ringqa.simulation.solvers.newton import newton  # noqa: E402


def _copy_nt(t):
    return type(t)(*[a.copy() if isinstance(a, np.ndarray) else a for a in t])


def capture(name: str):
    """(model, states): ``states`` a list of (effects, q, st, sw) at the start of every Newton
    solve of the quasi-static run of scene ``name`` (copies)."""
    import ringqa.simulation.model as mm
    import ringqa.simulation.solvers.driver as driver

    states = []
    models = []
    orig = mm.Model.solve

    def solve(self, effects, q, st):
        states.append((effects, q.copy(), _copy_nt(st), _copy_nt(self.samples)))
        if not models:
            models.append(self)
        return orig(self, effects, q, st)

    driver.USE_MARCH = False
    mm.Model.solve = solve
    try:
        simulate(load_scene(ROOT / "data" / "scenes" / f"{name}.toml"))
    finally:
        mm.Model.solve = orig
        driver.USE_MARCH = True
    return models[0], states


@njit
def _reset(sw, sw0):
    sw.s[:] = sw0.s
    sw.p[:, :] = sw0.p
    sw.d[:] = sw0.d
    sw.n[:, :] = sw0.n
    sw.H[:, :, :] = sw0.H
    sw.z[:] = sw0.z
    sw.w[:] = sw0.w
    sw.F[:] = sw0.F
    sw.dF[:] = sw0.dF


@njit
def loop_reset(sw, sw0, n):
    for _ in range(n):
        _reset(sw, sw0)


@njit
def loop_assemble(effects, q, st, sw, sw0, r, B, jac, fresh, energies, reset, n):
    for _ in range(n):
        if reset:
            _reset(sw, sw0)
        assemble(effects, q, st, sw, r, B, jac, fresh, energies)


@njit
def loop_copy(B0, B, rhs0, rhs, n):
    for _ in range(n):
        B[:, :] = B0
        rhs[:] = rhs0


@njit
def loop_solve(B0, B, rhs0, rhs, kl, n_free, n):
    ok = True
    for _ in range(n):
        B[:, :] = B0
        rhs[:] = rhs0
        ok = band_solve(B, kl, rhs, n_free)
    return ok


@njit
def loop_effect(effects, which, q, st, sw, r, B, jac, prep, n):
    """Effect number ``which``'s prepare (``prep``) or add, ``n`` times."""
    for _ in range(n):
        k = 0
        for p in literal_unroll(effects):
            if k == which:
                if prep:
                    effect_prepare(p, q, st, sw)
                else:
                    effect_add(p, q, st, sw, r, B, jac)
            k += 1


@njit
def loop_newton(effects, q0, q, st, sw, sw0, n_free, tol, max_iter, max_step, r, B, en, cnt, n):
    its = 0
    for _ in range(n):
        q[:] = q0
        _reset(sw, sw0)
        _status, it, _res = newton(effects, q, st, sw, n_free, tol, max_iter, max_step, r, B, en,
                                 cnt)  # fmt: skip
        its += it
    return its


def best_us(fn, args, calls: int, rounds: int) -> float:
    """Fastest round's mean (us a call) of ``fn(*args, calls)``."""
    fn(*args, 1)
    best = np.inf
    for _ in range(rounds):
        t0 = time.process_time()
        fn(*args, calls)
        best = min(best, (time.process_time() - t0) / calls)
    return best * 1e6


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="ring26-flexitron")
    ap.add_argument("--calls", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--every", type=int, default=8)
    a = ap.parse_args()
    model, states = capture(a.scene)
    states = states[:: a.every]
    names = model.names
    rows: dict[str, list[float]] = {}

    def add(label, v):
        rows.setdefault(label, []).append(v)

    n, R = a.calls, a.rounds
    for effects, q0, st, sw0 in states:
        q = q0.copy()
        sw = _copy_nt(sw0)
        r = np.zeros_like(model.r)
        B = np.zeros_like(model.B)
        en = np.zeros_like(model.energies)
        add("reset samples (subtracted below)", best_us(loop_reset, (sw, sw0), n, R))
        t = best_us(loop_assemble, (effects, q, st, sw, sw0, r, B, True, True, en, True), n, R)
        reset = rows["reset samples (subtracted below)"][-1]
        add("assemble r + J, every sample searched", t - reset)
        add(
            "assemble r + J, far samples skipped",
            best_us(loop_assemble, (effects, q, st, sw, sw0, r, B, True, True, en, False), n, R),
        )
        add(
            "assemble r only, far samples skipped",
            best_us(loop_assemble, (effects, q, st, sw, sw0, r, B, False, True, en, False), n, R),
        )
        add(
            "assemble J only (fresh=False)",
            best_us(loop_assemble, (effects, q, st, sw, sw0, r, B, True, False, en, False), n, R),
        )
        # the Jacobian and residual at this state for the LU
        _reset(sw, sw0)
        assemble(effects, q, st, sw, r, B, True, True, en)
        B0 = B.copy()
        rhs0 = -r
        Bw = B.copy()
        rw = rhs0.copy()
        c = best_us(loop_copy, (B0, Bw, rhs0, rw), n, R)
        t = best_us(loop_solve, (B0, Bw, rhs0, rw, model.kl, model.n_free), n, R)
        add("band_solve (LU + substitution)", t - c)
        for k, nm in enumerate(names):
            if nm == "contact":
                _reset(sw, sw0)
                add(
                    "  contact geometry, far samples skipped",
                    best_us(loop_effect, (effects, k, q, st, sw, r, B, True, True), n, R),
                )
            add(
                f"  {nm} add, r + J",
                best_us(loop_effect, (effects, k, q, st, sw, r, B, True, False), n, R),
            )
            add(
                f"  {nm} add, r only",
                best_us(loop_effect, (effects, k, q, st, sw, r, B, False, False), n, R),
            )
        cnt = np.zeros_like(model.counters)
        args = (effects, q0, q, st, sw, sw0, model.n_free, model.tol_abs, model.max_iter,
                model.max_step, r, B, en, cnt)  # fmt: skip
        t = best_us(loop_newton, args, max(n // 20, 2), R)
        its = loop_newton(*args, 1)
        add("Newton solve of the step (us)", t)
        add("  its iterations", float(its))
    print(
        f"{a.scene}: {len(states)} captured load-step states (every {a.every}-th), "
        f"{n} calls x {R} rounds each; us a call (fastest round), mean and max over the states"
    )
    print("| call | mean us | max us |")
    print("|---|---|---|")
    for label, v in rows.items():
        print(f"| {label} | {np.mean(v):.2f} | {np.max(v):.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
