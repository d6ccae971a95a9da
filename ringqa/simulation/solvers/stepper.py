"""Take one load or time step: sub-stepping and the fallback stabilisation.

A step that Newton does not solve is retried, first (quasi-statically) in one piece with the
fallback stabilisation (a viscous tether to the predictor of stiffness
``FALLBACK_STIFFNESS_FRACTION x k_wall`` per node, which carries the solver through snap-through:
the cable buckling and snapping in the straight part, the paper's source stalling), then cut in
halves down to ``MIN_CUT`` of the step. Each stabilised step is counted; the tether's work is
accounted for. A step the schedule grew past ``solver.increment_m`` while the cable slid along
is first cut into increment-long sub-steps: only a failure at the increment calls for the
fallback.

Dynamic steps with friction (issue 18: stepwise motion's simulated pauses took 15-50 Newton
iterations per step and failed attempts every few steps):

- a pause step (the input at rest, ``du = 0``) is predicted at rest (``q_n``, a stick
  predictor) instead of ``q_n + h v_n``: the cable is nearly stuck, and the regularised law's
  stick region is only ``v_reg h`` (0.1 um at 1 ms) wide, so extrapolating the last step's creep
  or slip velocity starts Newton in the law's saturated (or falling) part, from which it
  overshoots the stick region;
- the friction Jacobian's slope along the slip is floored at zero where the Stribeck law falls
  (``d mu / dv < 0`` between v_brk and a few v_brk: there the exact tangent makes the step's
  Jacobian indefinite, since the falling slope ``F |mu'| / dt`` dwarfs the inertia ``m / dt^2``
  and the Newton direction is not a descent direction of |r|^2); the residual is unchanged, so
  the converged answer is the same law's. On for pause steps only (from their first attempt):
  retrying other failed dynamic steps with it converged them to another root of the (then
  non-unique) implicit step and worsened a BDF2 run's work balance from 0.7 % to 1.05 %;
- a pause step longer than ``solver.time_step_s`` (the schedule grows the pause's step once the
  cable has come to rest: :mod:`.schedule`) is taken with backward Euler also in a BDF2 run (the
  integrator without its history; the history it leaves is the ordinary one, so the next step
  is BDF2 again). BDF2's two-step history at rest carries the last steps' creep into the step
  (``v_h = a v_n - b v_{n-1}``): on stress scene 42 (Coulomb, wall damping, 90 ms pauses) the
  grown BDF2 pause steps were cut 50 times, as backward Euler 29; and the answer moved less
  against a 4x finer run (docs/engine.md, "Dynamic pauses with friction").
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

#: smallest step as a fraction of the requested increment before the run is declared failed
MIN_CUT = 1.0 / 256.0
#: sub-steps tried without stabilisation before the fallback stabilisation is switched on
FALLBACK_AFTER = 1
#: fallback stabilisation: a viscous tether to the predictor of stiffness (coefficient / dt)
#: equal to this fraction of the wall stiffness per node
FALLBACK_STIFFNESS_FRACTION = 1e-3


class StepOutcome(NamedTuple):
    """What one step (all its attempts) came to (a named tuple: one is made per step).

    Attributes
    ----------
    ok : bool
        The step was solved (possibly cut or stabilised).
    q, v : (n_all,) ndarray
        State and velocity at its end (the start's when not ok).
    hist : object
        The integrator's history after it.
    iters : int
        Newton iterations over all attempts.
    last_iters : int
        Newton iterations of the last sub-step solved or tried.
    sub : int
        Sub-steps of the last attempt.
    stabilised : bool
        The fallback stabilisation was needed.
    attempts : int
        Attempts made (1: solved at once).
    friction_j, damping_j, stabilisation_j : float
        The step's friction, wall-damping and tether work (J).
    status, res : int, float
        Newton's status and residual (N) of the last sub-step tried.
    rest_speed_m_s : float
        A pause step's largest node displacement over the step divided by its time (m/s):
        how fast the cable still moves with the input at rest (0 for other steps and when
        not ok; :meth:`ringqa.simulation.solvers.schedule.Schedule.adapt` grows the pause's
        step only once it is small).
    """

    ok: bool
    q: np.ndarray
    v: np.ndarray
    hist: Any
    iters: int
    last_iters: int
    sub: int
    stabilised: bool
    attempts: int
    friction_j: float
    damping_j: float
    stabilisation_j: float
    status: int
    res: float
    rest_speed_m_s: float = 0.0


class Stepper:
    """Solves steps for a model with an integrator (see module docstring).

    Parameters
    ----------
    model : ringqa.simulation.model.Model
    integrator : ringqa.simulation.solvers.integrators.Integrator
    monitor : ringqa.simulation.solvers.monitor.Monitor
        Told the penetration after every solved sub-step.
    cut_grown : bool
        A failed step longer than ``solver.increment_m`` is cut into increment-long sub-steps
        before the fallback stabilisation (the schedule grows a history-dependent quasi-static
        run's step while the cable slides: :attr:`.schedule.Schedule.slide_grow`). Not for a
        history-free run's "jumps": with it, the frictionless arc's mean push force came out
        1.63 N instead of EI / (2 rho^2) = 1.43 N (tests/simulation/test_validation.py; within
        2 % without it).
    """

    def __init__(self, model, integrator, monitor, cut_grown: bool = False) -> None:
        self.model = model
        self.integrator = integrator
        self.monitor = monitor
        self.cut_grown = cut_grown

    def take(self, u: float, du: float, dt: float, q, v, hist, first=None) -> StepOutcome:
        """Advance the input by ``du`` (m) over ``dt`` (s) from state ``q``, velocity ``v``.

        ``first``: ``(iterations, status, residual)`` of a first attempt (the whole step, no
        stabilisation) that was already made and failed, the state left at the step's start
        (the compiled load-step loop, :mod:`.march`): the step goes on from its second attempt
        as if this call had made the first.
        """
        model = self.model
        integ = self.integrator
        sw = model.samples
        q_prev = q.copy()
        v_prev = v.copy()
        s_saved = sw.s.copy()
        dprev_saved = model.d_prev.copy()
        sub = 1
        stab = model.stab
        fallback = False
        # a simulated pause (dynamic, the input at rest): stick predictor and the friction
        # Jacobian with its falling branch floored (module docstring)
        pause = integ.dynamic and du == 0.0
        monotone = pause and model.monotone_effects is not None
        be = pause and dt > model.time_step * (1.0 + 1e-9)
        # a step the schedule grew past the increment (the cable sliding along) that fails is
        # first cut back to increment-long sub-steps: only a failure at the increment calls
        # for the fallback stabilisation
        fallback_after = FALLBACK_AFTER
        if self.cut_grown and abs(du) > model.increment * (1.0 + 1e-9):
            fallback_after = max(FALLBACK_AFTER, int(np.ceil(abs(du) / model.increment - 1e-9)))
        iters_total = 0
        attempts = 0
        skip = first is not None
        if skip:
            iters_total, attempts = int(first[0]), 1
            last_iters, last_status, last_res = int(first[0]), int(first[1]), float(first[2])
        while True:
            if skip:
                skip = False
            else:
                ok, got = self._attempt(
                    u, du, dt, q_prev, v_prev, s_saved, dprev_saved, hist, sub, stab, pause,
                    monotone, be, fallback,
                )  # fmt: skip
                attempts += 1
                iters_total += got[0]
                if ok:
                    return got[1]._replace(iters=iters_total, attempts=attempts)
                last_iters, last_status, last_res = got[4], got[2], got[3]
            if not fallback and not integ.dynamic and stab == 0.0 and sub >= fallback_after:
                # snap-through / stall: retry the step with the fallback stabilisation
                fallback = True
                stab = FALLBACK_STIFFNESS_FRACTION * model.wall_stiffness_n_m * dt
                sub = 1
                continue
            if sub >= int(1 / MIN_CUT):
                return StepOutcome(
                    False, q_prev, v_prev, hist, iters_total, last_iters, sub, fallback,
                    attempts, 0.0, 0.0, 0.0, last_status, last_res,
                )  # fmt: skip
            sub *= 2

    def _attempt(
        self, u, du, dt, q_prev, v_prev, s_saved, dprev_saved, hist, sub, stab, pause, monotone,
        be, fallback,
    ):  # fmt: skip
        """One attempt at the step in ``sub`` equal sub-steps with the stabilisation ``stab``:
        ``(ok, (iterations, outcome or None, status, residual, last sub-step's iterations))``."""
        model = self.model
        integ = self.integrator
        sw = model.samples
        q_try = q_prev.copy()
        v_try = v_prev.copy()
        sw.s[:] = s_saved
        model.d_prev[:] = dprev_saved
        effects = model.effects if stab == model.stab else model.with_tether(stab)
        if monotone:
            effects = model.monotone_effects
        iters_step = 0
        fr_step = damp_step = stab_step = 0.0
        hist_try = hist
        h = dt / sub
        for k in range(sub):
            qp = q_try.copy()
            q_try = q_try.copy() if pause else integ.predictor(q_try, v_try, h)
            model.predict(q_try, du / sub, u + du * (k + 1) / sub, integ.slides)
            q_ref = q_try.copy()
            # a grown pause step is backward Euler (BDF2 without its history; docstring)
            out = integ.solve(effects, q_try, qp, v_try, h, q_ref, None if be else hist_try)
            iters_step += out.iters
            if out.status != 0:
                return False, (iters_step, None, out.status, out.res, out.iters)
            hist_try = out.hist
            v_try = out.v
            model.refresh_far(q_try)  # exact distance history for wall damping
            model.d_prev[:] = sw.d
            self.monitor.penetration(sw.z, sw.w)
            fr_step += out.friction_j
            damp_step += out.damping_j
            if stab > 0 and not integ.dynamic:
                dq = (q_try - q_ref).reshape(model.n_nodes, model.nd)[:, :3]
                stab_step += stab * float(np.sum(dq**2)) / h
        speed = 0.0
        if pause:
            dq = (q_try - q_prev).reshape(model.n_nodes, model.nd)[:, :3]
            speed = float(np.max(np.abs(dq))) / dt
        outcome = StepOutcome(
            True, q_try, v_try, hist_try, iters_step, out.iters, sub, fallback, 0, fr_step,
            damp_step, stab_step, 0, out.res, speed,
        )  # fmt: skip
        return True, (iters_step, outcome, 0, out.res, out.iters)
