"""What a run watches while it goes: the work balance, jams, the penetration and the counters."""

from __future__ import annotations

from bisect import bisect_right

import numpy as np
from numba import njit

from ringqa.simulation.result import STATUS_JAMMED, STATUS_SUCCESS


class Monitor:
    """Accumulates the run's work, counters and penetration and detects jams.

    Parameters
    ----------
    model : ringqa.simulation.model.Model
    history_free : bool
        Quasi-static without friction, damping or tether: the input work is integrated with the
        trapezoidal rule (O(du^2)); otherwise the step's forces are evaluated at its end, as
        backward Euler does, and so is the input.

    Attributes
    ----------
    work_in, work_friction, work_damping, work_stabilisation : float
        Input work and the work dissipated by friction, wall damping and the tether (J).
    push : float
        Push force after the last accepted step (N).
    total_iters : int
        Newton iterations over the run, failed attempts included.
    n_steps, n_stabilised, n_cut, n_failed_attempts : int
        Accepted steps; steps that needed the fallback stabilisation; steps cut into sub-steps;
        attempts that did not converge.
    max_penetration_m : float
        Deepest sink of a contact sample beyond the wall (m).
    """

    def __init__(self, model, history_free: bool) -> None:
        self.model = model
        self.history_free = history_free
        self.work_in = self.work_friction = self.work_damping = self.work_stabilisation = 0.0
        self.push = 0.0
        self.e_start = 0.0
        self.total_iters = 0
        self.n_steps = self.n_stabilised = self.n_cut = self.n_failed_attempts = 0
        self.max_penetration_m = 0.0
        self._hist_u: list[float] = []
        self._hist_s: list[float] = []

    def start(self, u: float, iters: int) -> None:
        """At the initial equilibrium (input advance ``u``, its Newton iterations)."""
        self.total_iters = iters
        self.push = self.model.push_force()
        self.e_start = self.model.stored_energy()
        self._hist_u = [u]
        self._hist_s = [float(self.model.samples.s[0])]  # the tip's arc length (sample 0: tip)

    def penetration(self, samp_z: np.ndarray, samp_w: np.ndarray) -> None:
        """After a solved sub-step: the samples' depths ``z`` and transition widths (m)."""
        pen = max_penetration(samp_z, samp_w)
        self.max_penetration_m = max(self.max_penetration_m, pen if self.model.contact_on else 0.0)

    def failed(self, outcome) -> None:
        """A step that could not be solved: count its work."""
        self.total_iters += outcome.iters
        self.n_failed_attempts += outcome.attempts

    def accepted(self, outcome, du: float) -> None:
        """An accepted step of input ``du`` (m): counters and work."""
        self.total_iters += outcome.iters
        self.n_steps += 1
        self.n_failed_attempts += outcome.attempts - 1
        if outcome.stabilised:
            self.n_stabilised += 1
        if outcome.sub > 1:
            self.n_cut += 1
        push_new = self.model.push_force()
        self.work_in += (0.5 * (self.push + push_new) if self.history_free else push_new) * du
        self.work_friction += outcome.friction_j
        self.work_damping += outcome.damping_j
        self.work_stabilisation += outcome.stabilisation_j
        self.push = push_new

    def jam(self, u: float, du: float) -> tuple[int, str]:
        """After an accepted step to input advance ``u``: (status, message) of a jam, or
        (STATUS_SUCCESS, "")."""
        solver = self.model.scene.solver
        push = self.push
        if push > solver.jam_force_n:
            return self.jam_message(u, None, None)
        if du > 0:
            s_src = float(self.model.samples.s[0])
            self._hist_u.append(u)
            self._hist_s.append(s_src)
            jl = solver.jam_length_m
            hu = self._hist_u
            if u - hu[0] >= jl:
                # bisect on the list (increasing: forward steps only), as np.searchsorted with
                # side="right", without converting the list to an array on every step
                k = bisect_right(hu, u - jl) - 1
                if s_src - self._hist_s[k] < 0.1 * (u - hu[k]):
                    return self.jam_message(u, s_src - self._hist_s[k], u - hu[k])
        else:
            self._hist_u = [u]
            self._hist_s = [float(self.model.samples.s[0])]
        return STATUS_SUCCESS, ""

    def jam_message(self, u: float, moved: float | None, over: float | None) -> tuple[int, str]:
        """(STATUS_JAMMED, message) of a jam at input advance ``u`` (m): the push force above
        ``solver.jam_force_n`` (``moved`` None), or the tip moved ``moved`` (m) over the last
        ``over`` (m) of input."""
        solver = self.model.scene.solver
        if moved is None:
            return STATUS_JAMMED, (
                f"jammed at advance {u * 1e3:.2f} mm: push force {self.push:.2f} N above "
                f"solver.jam_force_n = {solver.jam_force_n:g} N"
            )
        return STATUS_JAMMED, (
            f"jammed at advance {u * 1e3:.2f} mm: the tip moved {moved * 1e3:.2f} mm over the "
            f"last {over * 1e3:.1f} mm of input"
        )

    def work(self, v: np.ndarray, dynamic: bool) -> dict[str, float]:
        """The work balance at the end of the run (J; ``balance_error`` relative)."""
        m = self.model
        d_el = m.stored_energy() - self.e_start
        ke = m.kinetic(v) if dynamic else 0.0
        ke0 = 0.0
        spent = d_el + self.work_friction + self.work_damping + self.work_stabilisation + (ke - ke0)
        w_in = self.work_in
        bal = abs(w_in - spent) / max(abs(w_in), 1e-300) if w_in != 0 else 0.0
        return {
            "input": w_in,
            "elastic": d_el,
            "friction": self.work_friction,
            "damping": self.work_damping,
            "stabilisation": self.work_stabilisation,
            "kinetic": ke - ke0,
            "balance_error": bal,
        }


@njit(cache=True, error_model="numpy")
def max_penetration(samp_z, samp_w):
    """``max((z - 1) w, initial=0)`` over the samples (m): the deepest sink into the wall.

    A NaN propagates as in ``np.max``.
    """
    m = 0.0
    for i in range(samp_z.shape[0]):
        v = (samp_z[i] - 1.0) * samp_w[i]
        if v > m or v != v:
            m = v
            if v != v:
                break
    return m
