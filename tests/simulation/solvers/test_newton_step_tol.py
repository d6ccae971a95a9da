"""Newton's step-size convergence test (solvers/newton.py, ``STEP_TOL_M``; issue 29).

Newton stops when ``max |r| <= tol_abs`` or, in its quadratic phase (the last step cut the
residual >= ``STEP_TOL_DROP`` times, the residual <= ``STEP_TOL_RES tol_abs``), when the Newton
correction at the state is at most ``STEP_TOL_M`` in every coordinate: the polishing iteration
(e.g. 5.3e-4 -> 4.9e-6 N, 108x, on ring26-flexitron, then a 2.2e-9 m correction) is skipped.
"""

from __future__ import annotations

import numpy as np

from ringqa.simulation.model import Model
from ringqa.simulation.scenefile import load_scene
from ringqa.simulation.solvers.driver import initial_equilibrium
from ringqa.simulation.solvers.newton import STEP_TOL_DROP, STEP_TOL_M, STEP_TOL_RES


def _steps_until_step_converged(scene, max_steps: int = 80):
    """Load steps of ``scene`` (its increment, the model's predictor and Newton) until one ends
    by the step-size test (its residual above ``tol_abs``); returns the model, that step's
    state and Step, iterations and residual."""
    model = Model(scene, scene.motion.advances_m)
    u = model.u_start
    q = model.initial_state(u)
    model.prescribe(q, u)
    v = np.zeros(model.n_all)
    assert initial_equilibrium(model, q, v, 1.0)[0] == 0
    model.d_prev[:] = model.samples.d
    du = model.increment
    for _ in range(max_steps):
        q_prev = q.copy()
        model.predict(q, du, u + du, True)
        st = model.step(q_prev, v, du / model.speed, q_ref=q.copy())
        status, it, res = model.solve(model.effects, q, st)
        assert status == 0
        if res > model.tol_abs:
            return model, q, st, it, res
        model.d_prev[:] = model.samples.d
        u += du
    raise AssertionError("no load step ended by the step-size test")


def test_a_step_converged_by_step_size_is_within_the_step_tolerance_of_the_full_solve():
    """ring13-push100 (Flexitron in a 13 mm ring, Stribeck friction): the first load step that
    Newton accepts by step size has its residual between ``tol_abs`` and ``STEP_TOL_RES``
    ``tol_abs``; solving it on to ``tol_abs`` (a fresh Newton call from there: at least one more
    iteration) moves no coordinate by more than 1.1 ``STEP_TOL_M``. Hand-derived bound: the
    continued solve's first step is the correction the test saw (<= ``STEP_TOL_M``; the chain
    update adds only its second-order length terms, ~l beta^2 / 2 with beta ~ 1e-8 m / 2 mm),
    and with Newton contracting at least ``STEP_TOL_DROP`` = 100 times a step the later steps
    add at most a geometric tail, 1 / (1 - 0.01) = 1.01 times the first in all. The remaining
    residual drops at least ``STEP_TOL_DROP`` times too."""
    model, q, st, it, res = _steps_until_step_converged(load_scene("ring13-push100"))
    assert it >= 2  # the test needs a previous full step
    assert model.tol_abs < res <= STEP_TOL_RES * model.tol_abs
    q_step = q.copy()
    status, more, res_full = model.solve(model.effects, q, st)
    assert status == 0 and more >= 1
    assert res_full <= model.tol_abs
    assert res_full * STEP_TOL_DROP <= res
    moved = np.max(np.abs(q - q_step))
    assert moved <= 1.1 * STEP_TOL_M, moved
