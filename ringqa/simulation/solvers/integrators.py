"""Time integrators behind one small interface (after scipy's ``OdeSolver``): how one (sub-)step
is predicted, solved by Newton and turned into a velocity.

- :class:`QuasiStatic`: load steps; the predictor slides the previous chain along the channel by
  the increment; the step's "time" ``increment / speed`` enters only friction, wall damping and
  the tether; no velocity.
- :class:`BackwardEuler`: implicit dynamics, first order; predictor ``q + dt v``.
- :class:`BDF2`: the two-step backward differentiation formula, second order, taken as a
  backward-Euler step against a modified history (:func:`bdf2_history`): the Newton kernel and
  the effects are unchanged; the first step, and a step more than :data:`BDF2_MAX_RATIO` times
  longer than the previous one, are backward Euler.

:data:`INTEGRATORS` maps ``solver.integrator`` names to the dynamic integrators;
:func:`integrator_for` picks the one a model needs.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import numpy as np
from numba import njit

#: BDF2: a step more than this many times longer than the previous one is taken with backward
#: Euler instead (variable-step BDF2 is zero-stable for step ratios below 1 + sqrt(2); the
#: ramped input's short landing steps and the sub-steps of a failed step change the ratio)
BDF2_MAX_RATIO = 2.0


class SubstepResult(NamedTuple):
    """One solved (sub-)step (a named tuple: one is made per sub-step).

    Attributes
    ----------
    status : int
        Newton's status (0 converged; :mod:`.newton`).
    iters : int
        Newton iterations.
    res : float
        Final residual (N).
    v : (n_all,) ndarray
        Velocity at the end of the step (m/s; zeros quasi-statically).
    hist : object
        The integrator's history after this step (BDF2: ``(q, v, d, h)`` before it).
    friction_j, damping_j : float
        The step's friction and wall-damping work (J).
    """

    status: int
    iters: int
    res: float
    v: np.ndarray
    hist: Any
    friction_j: float
    damping_j: float


class Integrator:
    """Predict and solve one (sub-)step of length ``h`` (s) from ``(q_n, v_n)``.

    Subclasses set :attr:`dynamic` (velocities and inertia) and :attr:`slides` (the predictor
    slides the chain along the channel) and implement :meth:`solve`.
    """

    name: ClassVar[str] = ""
    dynamic: ClassVar[bool] = True
    slides: ClassVar[bool] = False

    def __init__(self, model) -> None:
        self.model = model

    def predictor(self, q_n: np.ndarray, v_n: np.ndarray, h: float) -> np.ndarray:
        """The predicted state before the driven end is moved (a new array)."""
        return q_n + h * v_n if self.dynamic else q_n.copy()

    def solve(self, effects, q, q_n, v_n, h, q_ref, hist) -> SubstepResult:  # pragma: no cover
        """Solve the step in place on ``q`` (the prediction)."""
        raise NotImplementedError

    def _works(self) -> tuple[float, float]:
        m = self.model
        return m.work_of("friction"), m.work_of("wall_damping")


class QuasiStatic(Integrator):
    """Quasi-static load steps (no inertia; the step's time is ``increment / speed``)."""

    name = "quasistatic"
    dynamic = False
    slides = True

    def solve(self, effects, q, q_n, v_n, h, q_ref, hist) -> SubstepResult:
        m = self.model
        st, it, res = m.solve(effects, q, m.step(q_n, v_n, h, q_ref))
        fr, dp = self._works()
        return SubstepResult(st, it, res, v_n, hist, fr, dp)


class BackwardEuler(Integrator):
    """Implicit Euler: ``v = (q - q_n) / h``; first order."""

    name = "backward_euler"

    def solve(self, effects, q, q_n, v_n, h, q_ref, hist) -> SubstepResult:
        m = self.model
        st, it, res = m.solve(effects, q, m.step(q_n, v_n, h, q_ref))
        v = (q - q_n) / h if st == 0 else v_n
        fr, dp = self._works()
        return SubstepResult(st, it, res, v, hist, fr, dp)


class BDF2(Integrator):
    """Variable-step BDF2 as backward Euler against a modified history; second order."""

    name = "bdf2"

    def solve(self, effects, q, q_n, v_n, h, q_ref, hist) -> SubstepResult:
        m = self.model
        coef = bdf2_history(h, None if hist is None else hist[3])
        new_hist = (q_n, v_n, m.d_prev.copy(), h)
        if coef is None:
            st, it, res = m.solve(effects, q, m.step(q_n, v_n, h, q_ref))
            v = (q - q_n) / h if st == 0 else v_n
        else:
            a_h, b_h, h_eff = coef
            q_h = np.empty_like(q_n)
            v_h = np.empty_like(q_n)
            d_h = np.empty_like(m.d_prev)
            combine(a_h, q_n, b_h, hist[0], q_h)
            combine(a_h, v_n, b_h, hist[1], v_h)
            combine(a_h, m.d_prev, b_h, hist[2], d_h)
            # the friction slip floor keeps the actual step's value: scale h_eff / h
            st_ = m.step(q_h, v_h, h_eff, q_ref, q_start=q_n, d_hist=d_h, floor_scale=h_eff / h)
            st, it, res = m.solve(effects, q, st_)
            v = (q - q_h) / h_eff if st == 0 else v_n
        fr, dp = self._works()
        return SubstepResult(st, it, res, v, new_hist, fr, dp)


#: the dynamic integrators by ``solver.integrator`` name
INTEGRATORS: dict[str, type[Integrator]] = {"backward_euler": BackwardEuler, "bdf2": BDF2}


def integrator_for(model) -> Integrator:
    """The integrator a model's scene asks for (quasi-static, or the dynamic one named)."""
    if not model.dynamic:
        return QuasiStatic(model)
    return INTEGRATORS[model.scene.solver.integrator](model)


def bdf2_history(h: float, h_old: float | None) -> tuple[float, float, float] | None:
    """Variable-step BDF2 as a backward-Euler step against a modified history.

    BDF2 with steps ``h_old`` (t_{n-1} -> t_n) and ``h`` (t_n -> t_{n+1}), ratio ``w = h / h_old``:
    ``v_{n+1} = (q_{n+1} - q_h) / h_eff`` with ``q_h = a q_n - b q_{n-1}``,
    ``h_eff = h (1 + w) / (1 + 2 w)``, ``a = (1 + w)^2 / (1 + 2 w)``, ``b = w^2 / (1 + 2 w)``
    (``a - b = 1``); equal steps (w = 1): ``q_h = (4 q_n - q_{n-1}) / 3``, ``h_eff = 2 h / 3``.
    The acceleration is the same formula on the velocities (``v_h = a v_n - b v_{n-1}``) and the
    wall-damping velocity on the contact distances, so the backward-Euler Newton kernel called with
    ``(q_hist, v_hist, dt, d_hist) = (q_h, v_h, h_eff, d_h)`` takes a BDF2 step.

    Parameters
    ----------
    h : float
        This step (s).
    h_old : float or None
        The previous step (s); None when there is none (the first step).

    Returns
    -------
    (a, b, h_eff) or None
        The history weights and the step (s) to hand the kernel; None when the step is to be taken
        with backward Euler (no previous step, or ``h > BDF2_MAX_RATIO h_old``).
    """
    if h_old is None or not h_old > 0.0 or h > BDF2_MAX_RATIO * h_old:
        return None
    w = h / h_old
    den = 1.0 + 2.0 * w
    return (1.0 + w) ** 2 / den, w * w / den, h * (1.0 + w) / den


@njit(cache=True, error_model="numpy")
def combine(a, x, b, y, out):
    """``out = a x - b y`` elementwise (BDF2's history combinations; one call, no temporaries)."""
    for i in range(x.shape[0]):
        out[i] = a * x[i] - b * y[i]
