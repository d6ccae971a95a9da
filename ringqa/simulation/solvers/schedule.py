"""The input's schedule: where the driven end goes and in what steps.

The requested advances become waypoints in travel order (:func:`waypoints`); the input stops at
every waypoint of stepwise motion and where it reverses (:func:`stop_points`). Quasi-statically
the steps are ``solver.increment_m`` long (a frictionless, undamped scene has no history, so the
increment doubles after easy steps up to ``JUMP_FACTOR`` increments: it "jumps" to the requested
advances; with friction or damping it doubles only after a step solved in
``SLIDE_GROW_MAX_ITERS`` Newton iteration, where the cable just slides along, and returns to the
increment at the first harder step); dynamically they are time steps of ``solver.time_step_s``
on a trapezoidal velocity profile (:func:`ramped_step`) with the pauses of stepwise motion
simulated.

A simulated pause (the input at rest) needs no input-time resolution: the cable only relaxes
under friction at rest, once the motion the stop left has died out. Its time step starts at
``solver.time_step_s`` and doubles after every pause step solved in one piece (without a cut) in
which no node moved faster than :data:`PAUSE_REST_SPEED_FRACTION` of ``motion.speed``, up to
:data:`PAUSE_MAX_FACTOR` time steps; a faster step sets it back to ``solver.time_step_s``, a cut
one shrinks it to the sub-step that worked (issue 18: docs/engine.md, "Dynamic pauses with
friction"). The rule is not "in few Newton iterations": with friction a pause step takes 10-40
at every step size (the tanh's stick region is ``v_reg h`` wide); and not "as soon as solved":
the cable still slides for 5-15 ms after the stop, and coarse steps there moved stress scene 2's
dwells by up to 0.56 mm. The
last pause step lands on the pause's end, where the dwell is recorded (a remainder under a
quarter step is taken with it). BDF2 takes the changing steps with its variable-step weights
(ratio 2 at most, below its zero-stability limit 1 + sqrt 2); the grown pause steps themselves
are backward Euler (:mod:`.stepper`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: a frictionless, undamped run may grow its load step up to this many increments ("jump")
JUMP_FACTOR = 8
#: a quasi-static run with friction or damping grows its load step (up to :data:`JUMP_FACTOR`
#: increments) only after a step that Newton solved in at most this many iterations from the
#: slid predictor: the cable just slides along the channel, kinetic friction everywhere, and the
#: step's end state does not depend on how the slide was cut (ring26's straight approach: 60 of
#: its 147 steps; dwells unchanged to 1e-12 mm); any harder step sets it back to the increment
SLIDE_GROW_MAX_ITERS = 1
#: dynamic runs: the input accelerates from rest to motion.speed over this time and decelerates
#: likewise into every stop (a jump to full speed in one time step is an impulse ~ 1/dt)
MOTION_RAMP_S = 0.01
#: dynamic pauses: the pause's time step may grow up to this many ``solver.time_step_s``
PAUSE_MAX_FACTOR = 16
#: dynamic pauses: the pause's step grows only while no node moved faster than this fraction of
#: ``motion.speed`` over the last pause step (the cable has nearly stopped: right after the
#: input stops its nodes still slide at up to 0.3-0.7 of the input speed for 5-15 ms)
PAUSE_REST_SPEED_FRACTION = 0.2


@dataclass(frozen=True)
class Leg:
    """One waypoint of the input path.

    Attributes
    ----------
    index : int
        Position in the path.
    target_m : float
        The advance to reach (m).
    requested : list of int
        Indices of the requested advances recorded there.
    stop_m : float
        Where the input next comes to rest (m).
    dwell_s : float
        Pause to simulate there (s; dynamic stepwise motion only).
    """

    index: int
    target_m: float
    requested: list
    stop_m: float
    dwell_s: float


class Schedule:
    """Step sizes for a model's run (see module docstring).

    Parameters
    ----------
    model : ringqa.simulation.model.Model
    advances_m : (n,) float
        Requested advances (m).
    history_free : bool
        The scene has no friction, damping or tether, and is quasi-static: steps may grow.
    """

    def __init__(self, model, advances_m: np.ndarray, history_free: bool) -> None:
        self.model = model
        self.scene = model.scene
        self.dynamic = model.dynamic
        self.path = waypoints(self.scene, advances_m, model.u_start)
        self.stops = stop_points(self.scene, self.path, model.u_start)
        self.history_free = history_free
        #: a history-dependent quasi-static run may grow its step while the cable just slides
        #: (not with the always-on tether: its dissipation is per step)
        self.slide_grow = not history_free and not self.dynamic and model.stab == 0
        self.inc = model.increment
        self.t_move = 0.0  # time since the input last started from rest (dynamic)
        self.pause_dt = model.time_step if self.dynamic else 0.0  # next pause step (s)
        self.in_pause = False  # the last step handed out was a pause step

    def legs(self):
        """The waypoints in travel order as :class:`Leg` s."""
        stepwise_pause = self.dynamic and self.scene.motion.kind == "stepwise"
        for i, (target, idx) in enumerate(self.path):
            yield Leg(
                i, target, idx, self.path[self.stops[i]][0],
                self.scene.motion.dwell_s if stepwise_pause else 0.0,
            )  # fmt: skip

    def travel_m(self) -> float:
        """Total input travel along the waypoints from the start (m)."""
        points = [self.model.u_start] + [p[0] for p in self.path]
        return float(np.sum(np.abs(np.diff(points))))

    def estimated_steps(self) -> int:
        """Steps the run will take at least: travel / increment quasi-statically; travel / speed
        / time step plus the simulated pauses dynamically (sub-steps come on top)."""
        travel = self.travel_m()
        if not self.dynamic:
            return int(np.ceil(travel / self.model.increment))
        n_pauses = sum(1 for leg in self.legs() if leg.dwell_s > 0)
        moving_s = travel / self.model.speed + MOTION_RAMP_S * len(self.path)
        return int(
            np.ceil((moving_s + n_pauses * self.scene.motion.dwell_s) / self.model.time_step)
        )

    def next_step(self, u: float, leg: Leg, dwell_left: float) -> tuple[float, float]:
        """(du (m), dt (s)) of the next step from input advance ``u`` on ``leg``."""
        target = leg.target_m
        if self.dynamic:
            remaining = target - u
            if abs(remaining) > 1e-12:
                du, dt = ramped_step(
                    abs(remaining), abs(leg.stop_m - u), self.t_move, self.model.speed,
                    self.model.time_step,
                )  # fmt: skip
                du = float(np.sign(remaining)) * du
                self.t_move += dt
                self.in_pause = False
                self.pause_dt = self.model.time_step
            else:
                du = 0.0
                dt = self.pause_dt
                if dwell_left < 1.25 * dt:  # land on the pause's end, no sliver step after
                    dt = dwell_left
                self.in_pause = True
            return du, dt
        inc = self.inc
        du = min(max(target - u, -inc), inc)  # np.clip without its per-call cost
        return du, abs(du) / self.model.speed

    def adapt(self, sub: int, last_iters: int, rest_speed_m_s: float = 0.0) -> None:
        """After an accepted step: grow a history-free run's increment (a sliding run's, a
        dynamic pause's time step) after an easy step, shrink it after a cut (harder) one.

        ``rest_speed_m_s``: a pause step's fastest node displacement over its time (m/s;
        :class:`~ringqa.simulation.solvers.stepper.StepOutcome`).
        """
        if self.dynamic:
            if self.in_pause:
                base = self.model.time_step
                if sub > 1:
                    self.pause_dt = max(base, self.pause_dt / sub)
                elif rest_speed_m_s > PAUSE_REST_SPEED_FRACTION * self.model.speed:
                    self.pause_dt = base
                else:
                    self.pause_dt = min(2.0 * self.pause_dt, PAUSE_MAX_FACTOR * base)
            return
        base = self.model.increment
        if self.history_free and sub == 1 and last_iters <= 6:
            self.inc = min(2 * self.inc, JUMP_FACTOR * base)
        elif not self.history_free:
            easy = self.slide_grow and sub == 1 and last_iters <= SLIDE_GROW_MAX_ITERS
            self.inc = min(2 * self.inc, JUMP_FACTOR * base) if easy else base
        elif sub > 1:
            self.inc = max(base, self.inc / sub)

    def arrived(self, leg: Leg) -> None:
        """At the end of a leg: a stop resets the ramp (the next move starts from rest)."""
        if self.stops[leg.index] == leg.index:
            self.t_move = 0.0


def ramped_step(rem_target, rem_stop, t_move, speed, dt):
    """(|du|, dt) of the next dynamic step on a trapezoidal input-velocity profile.

    Accelerates at ``speed / MOTION_RAMP_S`` from rest, cruises at ``speed`` and decelerates at
    the same rate so as to reach the next stop at rest; a step that would pass the target
    waypoint is shortened to land on it.
    """
    acc = speed / MOTION_RAMP_S
    v = min(speed, acc * (t_move + dt), np.sqrt(2.0 * acc * rem_stop))
    v = max(v, acc * dt)  # never crawl: at least one step's worth of acceleration
    if rem_target <= v * dt:
        return rem_target, (dt if rem_target >= rem_stop - 1e-15 else rem_target / v)
    return v * dt, dt


def waypoints(scene, advances_m: np.ndarray, u_start: float) -> list[tuple[float, list[int]]]:
    """The input path: (advance, indices of requested advances recorded there) in travel order."""
    kind = scene.motion.kind
    order = np.argsort(advances_m, kind="stable")
    uniq: dict[float, list[int]] = {}
    for i in order:
        uniq.setdefault(float(advances_m[i]), []).append(int(i))
    asc = sorted(uniq)
    backward = kind == "retract" or (kind == "stepwise" and scene.motion.backward)
    if not backward:
        return [(u, uniq[u]) for u in asc]
    desc = asc[::-1]
    return [(u, uniq[u]) for u in desc]


def stop_points(scene, path, u_start: float) -> list[int]:
    """For each waypoint index, the index of the waypoint where the input next comes to rest.

    Stepwise motion stops at every waypoint; otherwise the input stops where it reverses and at
    the last waypoint.
    """
    n = len(path)
    stop = [False] * n
    stop[-1] = True if n else False
    prev = u_start
    for i in range(n - 1):
        d_now = path[i][0] - prev
        d_next = path[i + 1][0] - path[i][0]
        if scene.motion.kind == "stepwise" or d_now * d_next < 0:
            stop[i] = True
        prev = path[i][0]
    out = [0] * n
    nxt = n - 1
    for i in range(n - 1, -1, -1):
        if stop[i]:
            nxt = i
        out[i] = nxt
    return out
