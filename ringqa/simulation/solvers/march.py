"""The quasi-static load-step loop in one compiled kernel (the run's easy steps without Python).

A quasi-static run spends most of its steps on the same few operations: choose the step
(:mod:`.schedule`), predict it (:func:`~.predictor.predict` and the extrapolation of
:meth:`ringqa.simulation.model.Model.predict`), solve it (:func:`~.newton.newton`), account for
it (:class:`~.monitor.Monitor`: push force, work, penetration, jams) and record the requested
advances (:class:`~.recorder.Recorder`). :func:`march` does exactly those, in the same order
and with the same arithmetic, for as many steps as it can, so the answers are bit for bit those
of the Python loop in :mod:`.driver` (``benchmarks/compare_dwells.py``). It stops and hands the
run back to Python for:

- a step whose first attempt Newton does not solve (:data:`STEP_FAILED`): the driver finishes
  that step with :meth:`.stepper.Stepper.take` (cut into sub-steps, the fallback
  stabilisation), told what the first attempt cost, and calls :func:`march` again;
- a jam (:data:`JAM_FORCE`, :data:`JAM_PROGRESS`), the end of the path (:data:`DONE`), and
  after ``max_steps`` accepted steps (:data:`PAUSED`: the driver checks a sample's time budget).

The kernel is specialised for the model's tuple of effects like Newton (a scene without
friction compiles one without it). Models it does not take (:func:`marchable`): dynamic runs,
an always-on stabilisation tether, wall damping (its far-sample refresh), a kept trajectory or
a progress bar, and effects defined outside ringqa (not disk-cacheable): those run the Python
loop, which stays the reference implementation.

The run's scalars travel in two small arrays, ``fs`` (float64, indices ``F_*``) and ``ist``
(int64, indices ``I_*``), shared with the driver, which syncs them with the monitor, the
schedule and the model around a Python-handled step.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation._kernels import closest_point, curve_eval, restore_lengths
from ringqa.simulation.effects.base import Step
from ringqa.simulation.solvers.monitor import max_penetration
from ringqa.simulation.solvers.newton import ITERATION_LIMIT, NO_PROGRESS, newton
from ringqa.simulation.solvers.predictor import continuation_scale, predict
from ringqa.simulation.solvers.recorder import lump_to_nodes

#: :func:`march`'s return codes
DONE, STEP_FAILED, JAM_FORCE, JAM_PROGRESS, PAUSED = 0, 1, 2, 3, 4
#: ``fs`` indices: input advance u (m), the schedule's increment (m), push force (N), input,
#: friction and damping work (J), the predictor's last du and u (m), deepest penetration (m),
#: simulated time (s), the step handed back (du (m), dt (s)) and a failed step's residual (N),
#: a jam's figures (tip progress (m), input length (m))
(F_U, F_INC, F_PUSH, F_WORK_IN, F_WORK_FR, F_WORK_DAMP, F_PRED_DU, F_PRED_U, F_MAX_PEN, F_TIME,
 F_DU, F_DT, F_RES, F_JAM_MOVED, F_JAM_OVER) = range(15)  # fmt: skip
N_FS = 15
#: ``ist`` indices: Newton iterations of the run, accepted steps, iterations since the last
#: recorded waypoint, the current waypoint, the predictor extrapolated, entries of the jam
#: history, a failed first attempt's iterations and Newton status
(I_ITERS, I_STEPS, I_SINCE, I_LEG, I_EXTRAPOLATED, I_HIST, I_FAIL_ITERS,
 I_FAIL_STATUS) = range(8)  # fmt: skip
N_IST = 8


@njit(cache=True, error_model="numpy")
def _push_force(r, nd, n_nodes, t0):
    """:meth:`ringqa.simulation.model.Model.push_force` (``np.dot`` as numpy's: BLAS ddot)."""
    f = 0.0
    for k in range(n_nodes - 2, n_nodes):
        f += np.dot(r[nd * k : nd * k + 3], t0)
    return f


@njit(cache=True, error_model="numpy")
def march(
    effects, q, v, sw, d_prev, r, B, energies, counters, nd, n_nodes, kl, n_free, tol_abs,
    max_iter, max_step, link_len, chan, cum, cft, node_sample, t0, extrapolate, ext_fraction,
    ext_max_iters, ext_rtol, ext_scale_max, plain_max_iter, plain_max_iter_crawled, pred_plain,
    pred_hints, targets, history_free, slide_grow, base_inc, jump_factor, slide_grow_max_iters,
    speed, i_fr, i_damp, contact_on, jam_force, jam_length, hist_u, hist_s, fs, ist, max_steps,
    rec_q, rec_push, rec_iters, rec_contact, rec_u,
):  # fmt: skip
    """March the quasi-static load steps from ``fs[F_U]`` along the waypoints ``targets`` from
    ``ist[I_LEG]`` on (module docstring); returns a code (:data:`DONE` ...).

    Parameters
    ----------
    effects : tuple
        The model's effects' kernel args.
    q : (n_all,) float64
        State at ``fs[F_U]``, advanced in place.
    v : (n_all,) float64
        Velocities (zeros: quasi-static).
    sw : Samples
        Contact samples (updated in place).
    d_prev : (P,) float64
        The samples' distances at the start of the step (updated in place).
    r, B, energies, counters
        Newton's work arrays and counters (:meth:`Model.solve`).
    nd, n_nodes, kl, n_free, tol_abs, max_iter, max_step
        Layout and Newton settings.
    link_len, chan, cum, cft, node_sample
        The predictor's args (:func:`~.predictor.predict`).
    t0 : (3,) float64
        The channel's tangent at its entry (push force direction).
    extrapolate : bool
        The predictor extrapolates (:attr:`Model.extrapolate`).
    ext_fraction, ext_max_iters, ext_rtol, ext_scale_max : float, int, float, float
        :data:`~ringqa.simulation.model.EXTRAPOLATE_FRACTION`, ``..._MAX_ITERS``, ``..._RTOL``
        and ``..._SCALE_MAX`` (:func:`~.predictor.continuation_scale`).
    plain_max_iter, plain_max_iter_crawled : int
        Iteration limits of the plain-slide retry after a failed extrapolated start, and after
        one that failed at the iteration limit or without progress
        (:func:`~ringqa.simulation.model.plain_retry_iters`).
    pred_plain, pred_hints : (n_all,), (P,) float64
        The model's last plain slide prediction and its sample hints (shared, in place).
    targets : (L,) float64
        The waypoints' advances (m) in travel order.
    history_free, slide_grow : bool
        :class:`~.schedule.Schedule`'s step growth rules.
    base_inc, jump_factor, slide_grow_max_iters, speed
        ``solver.increment_m``, :data:`~.schedule.JUMP_FACTOR`,
        :data:`~.schedule.SLIDE_GROW_MAX_ITERS`, ``motion.speed_m_s``.
    i_fr, i_damp : int
        Index of the friction and wall-damping effects in ``effects`` (-1: none).
    contact_on : bool
        The model has wall contact (penetration).
    jam_force, jam_length : float
        ``solver.jam_force_n`` (N), ``solver.jam_length_m`` (m).
    hist_u, hist_s : (H,) float64
        The jam monitor's history of forward steps (input, tip arc length), ``ist[I_HIST]``
        entries used.
    fs, ist : float64, int64 arrays
        The run's scalars (module docstring), in and out.
    max_steps : int
        Return :data:`PAUSED` after this many accepted steps (<= 0: no limit).
    rec_q, rec_push, rec_iters, rec_contact, rec_u : (L, ...) arrays
        Per waypoint reached: the state, push force, Newton iterations since the previous
        one, the contact force lumped to the nodes and the input advance.
    """
    n_all = q.shape[0]
    n_legs = targets.shape[0]
    q_prev = np.empty(n_all)
    q_ref = np.empty(n_all)
    corr = np.empty(n_all)
    s_saved = np.empty(sw.s.shape[0])
    u = fs[F_U]
    inc = fs[F_INC]
    push = fs[F_PUSH]
    pred_du = fs[F_PRED_DU]
    pred_u = fs[F_PRED_U]
    max_pen = fs[F_MAX_PEN]
    n_taken = 0
    code = DONE
    leg = ist[I_LEG]
    while leg < n_legs:
        target = targets[leg]
        while abs(target - u) > 1e-12:
            du = min(max(target - u, -inc), inc)
            dt = abs(du) / speed
            # Stepper.take, first attempt, one sub-step
            for i in range(n_all):
                q_prev[i] = q[i]
            for i in range(s_saved.shape[0]):
                s_saved[i] = sw.s[i]
            u_new = u + du
            # Model.predict
            scale = 0.0
            if du > 0.0 and extrapolate:
                scale = continuation_scale(du, u_new, pred_du, pred_u, ext_rtol, ext_scale_max)
            ext = scale > 0.0
            if ext:
                for i in range(n_all):
                    corr[i] = q[i] - pred_plain[i]
            predict(q, True, du, u_new, nd, n_nodes, link_len, chan, sw.s, cum, cft, node_sample)
            extrapolated = False
            if extrapolate:
                for i in range(n_all):
                    pred_plain[i] = q[i]
                pred_du = du
                pred_u = u_new
                extrapolated = ext
                if ext:
                    for i in range(sw.s.shape[0]):
                        pred_hints[i] = sw.s[i]
                    f_ext = ext_fraction * scale
                    for i in range(n_all):
                        q[i] += f_ext * corr[i]
                    restore_lengths(q, nd, n_nodes, link_len)
            for i in range(n_all):
                q_ref[i] = q[i]
            st = Step(nd, n_nodes, kl, q_prev, v, q_prev, q_ref, d_prev, d_prev, dt, 1.0)
            # Model.solve
            status, it, res = newton(effects, q, st, sw, n_free, tol_abs, max_iter, max_step,
                                     r, B, energies, counters)  # fmt: skip
            if status != 0 and extrapolated:
                for i in range(n_all):
                    q[i] = pred_plain[i]
                for i in range(sw.s.shape[0]):
                    sw.s[i] = pred_hints[i]
                crawled = status == ITERATION_LIMIT or status == NO_PROGRESS
                lim = plain_max_iter_crawled if crawled else plain_max_iter
                status, it2, res = newton(effects, q, st, sw, n_free, tol_abs, lim,
                                          max_step, r, B, energies, counters)  # fmt: skip
                it = it + it2
            if status != 0 or it > ext_max_iters:
                pred_u = np.nan
            if status != 0:
                # hand the step back to the stepper: the start of the step restored
                for i in range(n_all):
                    q[i] = q_prev[i]
                for i in range(s_saved.shape[0]):
                    sw.s[i] = s_saved[i]
                fs[F_DU] = du
                fs[F_DT] = dt
                fs[F_RES] = res
                ist[I_FAIL_ITERS] = it
                ist[I_FAIL_STATUS] = status
                ist[I_EXTRAPOLATED] = 0
                code = STEP_FAILED
                break
            for i in range(d_prev.shape[0]):
                d_prev[i] = sw.d[i]
            pen = max_penetration(sw.z, sw.w)
            pen = pen if contact_on else 0.0
            if pen > max_pen:
                max_pen = pen
            fr = 0.0
            if i_fr >= 0:
                fr += energies[i_fr]
            damp = 0.0
            if i_damp >= 0:
                damp += energies[i_damp]
            # Monitor.accepted
            ist[I_ITERS] += it
            ist[I_STEPS] += 1
            ist[I_SINCE] += it
            push_new = _push_force(r, nd, n_nodes, t0)
            if history_free:
                fs[F_WORK_IN] += 0.5 * (push + push_new) * du
            else:
                fs[F_WORK_IN] += push_new * du
            fs[F_WORK_FR] += fr
            fs[F_WORK_DAMP] += damp
            push = push_new
            u = u + du
            fs[F_TIME] += dt
            # Schedule.adapt (one sub-step)
            if history_free and it <= 6:
                inc = min(2 * inc, jump_factor * base_inc)
            elif not history_free:
                if slide_grow and it <= slide_grow_max_iters:
                    inc = min(2 * inc, jump_factor * base_inc)
                else:
                    inc = base_inc
            # Monitor.jam
            if push > jam_force:
                code = JAM_FORCE
                break
            if du > 0:
                s_src = sw.s[0]
                nh = ist[I_HIST]
                if nh == hist_u.shape[0]:  # full: drop what no later check can reach
                    k0 = _bisect_right(hist_u, nh, u - jam_length) - 1
                    if k0 > 0:
                        for i in range(nh - k0):
                            hist_u[i] = hist_u[i + k0]
                            hist_s[i] = hist_s[i + k0]
                        nh -= k0
                hist_u[nh] = u
                hist_s[nh] = s_src
                nh += 1
                ist[I_HIST] = nh
                if u - hist_u[0] >= jam_length:
                    k = _bisect_right(hist_u, nh, u - jam_length) - 1
                    if s_src - hist_s[k] < 0.1 * (u - hist_u[k]):
                        fs[F_JAM_MOVED] = s_src - hist_s[k]
                        fs[F_JAM_OVER] = u - hist_u[k]
                        code = JAM_PROGRESS
                        break
            else:
                hist_u[0] = u
                hist_s[0] = sw.s[0]
                ist[I_HIST] = 1
            n_taken += 1
            if max_steps > 0 and n_taken >= max_steps:
                code = PAUSED
                break
        if code != DONE:
            break
        # arrived: record the waypoint (Recorder.record)
        for i in range(n_all):
            rec_q[leg, i] = q[i]
        rec_push[leg] = push
        rec_iters[leg] = ist[I_SINCE]
        rec_u[leg] = u
        for i in range(n_nodes):
            rec_contact[leg, i] = 0.0
        lump_to_nodes(sw.link, sw.alpha, sw.F, rec_contact[leg])
        ist[I_SINCE] = 0
        leg += 1
    ist[I_LEG] = leg
    fs[F_U] = u
    fs[F_INC] = inc
    fs[F_PUSH] = push
    fs[F_PRED_DU] = pred_du
    fs[F_PRED_U] = pred_u
    fs[F_MAX_PEN] = max_pen
    return code


@njit(cache=True, error_model="numpy")
def _bisect_right(a, n, x):
    """``bisect.bisect_right(a[:n], x)``."""
    lo = 0
    hi = n
    while lo < hi:
        mid = (lo + hi) // 2
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


@njit(cache=True, error_model="numpy")
def source_rows(rec_q, rec_u, n_rows, nd, j, back, h, pos, tan, src, dirn, tip, s_out, off_out):
    """:meth:`Model.source` and :meth:`ChannelTable.closest` of the first ``n_rows`` recorded
    states (the same arithmetic: norms as ``sqrt(np.dot(e, e))``).

    ``j``: the link carrying the source centre, ``back``: the centre's distance behind node
    ``j`` (m, ``cft - cum[j]``); outputs source centre, unit direction to the tip, tip (rows, 3),
    the centre's closest arc length and distance from the centreline (rows,) (m).
    """
    e = np.empty(3)
    p = np.empty(3)
    work = np.empty(9)
    c = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    for k in range(n_rows):
        for a in range(3):
            e[a] = rec_q[k, nd * j + a] - rec_q[k, nd * (j + 1) + a]
        le = math.sqrt(np.dot(e, e))
        for a in range(3):
            d = e[a] / le
            dirn[k, a] = d
            p[a] = rec_q[k, nd * j + a] - back * d
            src[k, a] = p[a]
            tip[k, a] = rec_q[k, a]
        s = closest_point(h, pos, tan, p, rec_u[k], 0.01, work)
        curve_eval(h, pos, tan, s, c, d1, d2)
        for a in range(3):
            e[a] = p[a] - c[a]
        s_out[k] = s
        off_out[k] = math.sqrt(np.dot(e, e))
