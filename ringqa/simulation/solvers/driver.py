"""The run: quasi-static load stepping or implicit (backward-Euler or BDF2) dynamics.

Both march the input advance ``u`` (the driven proximal end) along the schedule's waypoints and
solve each step with the same Newton kernel. The parts, one job each:

- :class:`~ringqa.simulation.model.Model`: the assembled problem (effects, arrays, state helpers);
- :mod:`.schedule`: the waypoints and the step sizes;
- :mod:`.integrators`: how a step is predicted, solved and turned into a velocity;
- :mod:`.stepper`: sub-stepping and the fallback stabilisation;
- :mod:`.monitor`: work balance, jams, penetration and counters;
- :mod:`.recorder`: the outputs at the requested advances and the trajectory.

Jams (push force above ``solver.jam_force_n``, or less than 10 % progress of the tip, which
carries the source, over ``solver.jam_length_m`` of forward input) end the run with status 1; a
step that fails at the smallest increment ends it with status -1. Neither raises.
"""

from __future__ import annotations

import time
from bisect import bisect_right
from dataclasses import asdict

import numpy as np

from ringqa.geometry.shape_checks import capsule_bow_m, capsule_pass_radius_m
from ringqa.provenance import Provenance
from ringqa.simulation import model as model_mod
from ringqa.simulation._kernels import restore_lengths
from ringqa.simulation.effects.base import Samples
from ringqa.simulation.model import Model
from ringqa.simulation.plausibility import (
    PAPER_STIFFNESS,
    check_wall_stiffness,
    flexible_ei_nm2,
    outside_lumen,
    outside_message,
    work_balance_warning,
)
from ringqa.simulation.result import (
    STATUS_FAILED,
    STATUS_SUCCESS,
    SimResult,
    SolverStats,
)
from ringqa.simulation.solvers import march as march_kernel
from ringqa.simulation.solvers import schedule as schedule_mod
from ringqa.simulation.solvers.integrators import combine, integrator_for
from ringqa.simulation.solvers.monitor import Monitor, max_penetration
from ringqa.simulation.solvers.newton import ITERATION_LIMIT, STALLED, newton
from ringqa.simulation.solvers.predictor import predict
from ringqa.simulation.solvers.recorder import Recorder, lump_to_nodes
from ringqa.simulation.solvers.schedule import Schedule
from ringqa.simulation.solvers.stepper import Stepper
from ringqa.units import m_to_mm

#: pseudo-time steps of the initial equilibrium's tethered walk before giving up
INITIAL_WALK_STEPS = 300
#: Penetration of the instrument into the wall, as a fraction of the clearance (lumen radius -
#: instrument radius), above which the run warns. Beyond the instrument's radius the run fails
#: (status -1): its axis has left the lumen.
PENETRATION_WARN = 0.1
#: A run that would take more load or time steps than this is refused before it starts: at the
#: engine's 2-10 ms per step it would run for 3-15 minutes without a useful answer (the accuracy
#: study shows 0.1 mm needs a few thousand steps on a ring).
MAX_STEPS = 100_000


def check_budget(schedule: Schedule, scene) -> None:
    """Refuse a run whose schedule needs more than :data:`MAX_STEPS` steps (names the number, the
    setting that causes it and a value that fits)."""
    n = schedule.estimated_steps()
    if n <= MAX_STEPS:
        return
    from ringqa.simulation.scene import SceneError

    travel_mm = m_to_mm(schedule.travel_m())
    if schedule.dynamic:
        setting, value, unit = "solver.time_step_s", scene.solver.time_step_s, "s"
    else:
        setting, value, unit = "solver.increment_mm", m_to_mm(scene.solver.increment_m), "mm"
    fits = value * n / MAX_STEPS
    raise SceneError(
        f"{setting} = {value:g} {unit}: the run would take about {n:,} steps over {travel_mm:.0f} "
        f"mm of input (at most {MAX_STEPS:,} are allowed, several minutes of solving); use "
        f"{setting} >= {fits:.2g} (the accuracy study, ringqa accuracy, says what a setting buys)"
    )


#: A rigid link (the source capsule) whose bow across the tightest bend it reaches exceeds the
#: lumen's free width 2c by more than this many clearances is refused: the excess is taken up by
#: sinking into the wall, its middle (pressed by twice an end's force) ~2/3 of it, so 0.5 c keeps
#: the sink near a third of the clearance (issue 18's limit: half). Below it the run warns
#: through its penetration.
RIGID_EXCESS_REFUSE = 0.5


def check_rigid_links_fit(model: Model, advances_m: np.ndarray) -> None:
    """Refuse a scene whose rigid link (the source capsule) cannot pass the channel's tightest
    bend in the lumen: a straight rigid link of length ``l`` in a bend of radius ``R`` bows
    ``l^2 / (8 R)`` across the channel; the lumen leaves ``2 c`` (c = r_b - r_o). Flexible
    sections bend and only warn (their links can be refined); a rigid capsule cannot, and the
    engine would push it through by sinking it into the wall (issue 18: up to 2x the clearance
    with status ok). Raises SceneError naming the capsule, the bend, the lumen and the fix.
    """
    chain = model.chain
    rigid = ~np.isfinite(chain.link_ei)
    if not np.any(rigid):
        return
    table = model.table
    u_deep = max(float(np.max(advances_m)), model.u_start)
    s_tab = np.arange(table.pos.shape[0]) * table.h
    rb_min = float(np.min(table.seg_rb))
    for j in np.flatnonzero(rigid):
        front = u_deep + model.cft - float(chain.cum[j])
        kap = table.kappa[s_tab <= front + 1e-9]
        if kap.size == 0 or not np.max(kap) > 0:
            continue
        k_max = float(np.max(kap))
        length = float(chain.link_len[j])
        r_o = float(chain.link_ro[j])
        c = rb_min - r_o
        bow = capsule_bow_m(length, k_max)
        if bow - 2.0 * c > RIGID_EXCESS_REFUSE * c:
            from ringqa.simulation.scene import SceneError

            name = chain.section_names[int(chain.link_section[j])]
            fits = 2.0 + RIGID_EXCESS_REFUSE  # bow <= fits * c passes
            raise SceneError(
                f"instrument section {name!r} (rigid, {length * 1e3:.1f} mm long, radius "
                f"{r_o * 1e3:.3f} mm) cannot pass the channel's tightest bend "
                f"(radius {1e3 / k_max:.1f} mm) in a lumen of radius {rb_min * 1e3:.3f} mm: it "
                f"bows {bow * 1e3:.3f} mm across the channel, which leaves it "
                f"{2 * c * 1e3:.3f} mm; a lumen of radius >= "
                f"{(r_o + bow / fits) * 1e3:.3f} mm or a bend of radius >= "
                f"{capsule_pass_radius_m(length, r_o, rb_min, fits) * 1e3:.1f} mm lets it through "
                "(check the lumen diameter, the channel and the instrument preset)"
            )


def initial_equilibrium(model: Model, q: np.ndarray, v: np.ndarray, dt: float) -> tuple[int, int]:
    """Static equilibrium of the starting chain (in place); returns (Newton status, iterations).

    Friction, damping and inertia are suspended (no history). If the direct solve fails (e.g.
    gravity drops the whole cable onto the wall at once) the chain is walked there by pseudo-time
    steps: each solves with a viscous tether to the previous pseudo-state whose stiffness (10 x
    the heaviest node's weight per clearance) lets a node move about a tenth of the clearance per
    step; every 5 steps a plain solve is tried from the current state.
    """
    static = model.static_effects
    q0 = q.copy()
    st, it, _ = model.solve(static, q, model.step(q.copy(), v, dt))
    if st != 0:
        q[:] = q0
        g = next((u.g for u in model.units if u.name == "gravity"), np.zeros(3))
        weight = float(np.max(model.node_mass)) * float(np.linalg.norm(g))
        k_tether = 10.0 * max(weight, 1e-4) / model.clearance
        tethered = model.with_tether(k_tether, base=static)
        for i in range(INITIAL_WALK_STEPS):
            # with dt = 1: stiffness k_tether per node
            model.solve(tethered, q, model.step(q.copy(), v, 1.0, q_ref=q.copy()))
            if i % 5 == 4:
                qs = q.copy()
                st, k, _ = model.solve(static, q, model.step(q.copy(), v, dt))
                it += k
                if st == 0:
                    break
                q[:] = qs
    return st, it


def warm_kernels(model: Model, schedule=None, monitor=None) -> None:
    """Compile (or load from numba's disk cache) the kernels this model runs, on scratch copies,
    so that JIT compilation never enters the run's ``solve_time_s``.

    The assembler and Newton are specialised for the model's tuple of effects: only the effects
    the scene calls for are compiled.
    """
    q = model.initial_state(model.u_start)
    sw = Samples(*(a.copy() for a in model.samples))
    st = model.step(q.copy(), np.zeros_like(q), 1.0)
    model.newton(
        model.effects, q.copy(), st, sw, model.n_free, model.tol_abs, 0, model.max_step,
        np.zeros_like(model.r), np.zeros_like(model.B), np.zeros_like(model.energies),
        np.zeros_like(model.counters),
    )  # fmt: skip
    march = (
        not model.dynamic
        and schedule is not None
        and marchable(model, model.scene, integrator_for(model), False)
    )
    if not march:
        # the Python loop calls Newton and the predictor once a step: bind their compiled
        # entry points (~0.5 ms of type lookups, once a run). A marched run calls them from
        # the compiled loop, and Python only for the initial equilibrium and a failed step's
        # retries: the dispatcher's few microseconds a call cost less than the binding.
        model.bind_compiled_newton(q)
    predict(
        q.copy(), True, 0.0, model.u_start, model.nd, model.n_nodes, model.chain.link_len,
        model.table.args(), sw.s.copy(), model._cum, model.cft, model._node_sample,
    )  # fmt: skip
    if not march:
        model.bind_compiled_predict(q)
    max_penetration(sw.z, sw.w)
    restore_lengths(q.copy(), model.nd, model.n_nodes, model.chain.link_len)  # the extrapolation
    lump_to_nodes(sw.link, sw.alpha, sw.F, np.zeros(model.n_nodes))
    if model.dynamic:
        combine(1.0, q, 0.0, q, q.copy())
    elif march:
        args = _march_args(model, schedule, monitor, q.copy(), np.zeros_like(q),
                           np.zeros(0), 2, 0)[0]  # fmt: skip
        march_kernel.march(*args)  # no waypoints: compiles (or loads) only
        z = np.zeros((0, 3))
        march_kernel.source_rows(
            np.zeros((0, model.n_all)), np.zeros(0), 0, model.nd, 0, 0.0, model.table.h,
            model.table.pos, model.table.tan, z, z.copy(), z.copy(), np.zeros(0), np.zeros(0),
        )  # fmt: skip


def run(
    scene, advances_m: np.ndarray, progress: bool = False, deadline: float | None = None
) -> SimResult:
    """Simulate ``scene`` and report at ``advances_m`` (see module docstring); ``deadline``: a
    :func:`time.perf_counter` time after which the run stops at the next load step with status
    -1 and ``settings["budget_exceeded"] = True`` (a sweep's per-sample budget; None: none)."""
    model = Model(scene, advances_m)
    history_free = (
        not any(u.name in ("friction", "wall_damping") for u in model.units)
        and model.stab == 0
        and not model.dynamic
    )
    integrator = integrator_for(model)
    schedule = Schedule(model, advances_m, history_free)
    check_budget(schedule, scene)
    check_rigid_links_fit(model, advances_m)
    check_wall_stiffness(scene, model.table, model.clearance, flexible_ei_nm2(model.chain.link_ei))
    monitor = Monitor(model, history_free)
    recorder = Recorder(model, advances_m, bool(scene.outputs.trajectory))
    stepper = Stepper(model, integrator, monitor, cut_grown=schedule.slide_grow)
    warm_kernels(model, schedule, monitor)

    t0 = time.perf_counter()
    u = model.u_start
    q = model.initial_state(u)
    model.prescribe(q, u)
    v = np.zeros(model.n_all)
    st, it = initial_equilibrium(model, q, v, model.time_step if model.dynamic else 1.0)
    model.refresh_far(q)
    model.d_prev[:] = model.samples.d
    status = STATUS_SUCCESS if st == 0 else STATUS_FAILED
    message = "" if st == 0 else f"initial state did not converge at advance {u * 1e3:.2f} mm"
    monitor.start(u, it)
    iters_since = it
    time_s = 0.0
    bar = _progress_bar(scene, schedule, u) if progress else None
    hist = None  # the integrator's history (BDF2)
    over = False
    fast = marchable(model, scene, integrator, progress)
    if fast and status == STATUS_SUCCESS:
        status, message, over, q, u, time_s = _marched(
            model, schedule, stepper, monitor, recorder, q, v, u, iters_since, deadline, t0
        )
    for leg in schedule.legs() if status == STATUS_SUCCESS and not fast else ():
        dwell_left = leg.dwell_s
        while status == STATUS_SUCCESS and (abs(leg.target_m - u) > 1e-12 or dwell_left > 1e-15):
            du, dt = schedule.next_step(u, leg, dwell_left)
            out = stepper.take(u, du, dt, q, v, hist)
            iters_since += out.iters
            if not out.ok:
                monitor.failed(out)
                status = STATUS_FAILED
                message = _not_converged_message(u, out)
                break
            monitor.accepted(out, du)
            q = out.q
            if model.dynamic:
                v, hist = out.v, out.hist
            u = u + du
            time_s += dt
            if du == 0.0:
                dwell_left -= dt
            if bar is not None:
                bar.update(min(round(abs(du) * 1e3, 3), max(bar.total - bar.n, 0.0)))
            recorder.step(q, u, time_s, monitor.push)
            schedule.adapt(out.sub, out.last_iters, out.rest_speed_m_s)
            status, message = monitor.jam(u, du)
            if deadline is not None and status == STATUS_SUCCESS and time.perf_counter() > deadline:
                status, over = STATUS_FAILED, True
                message = (
                    f"the run exceeded its time budget at advance {u * 1e3:.3f} mm "
                    f"({time.perf_counter() - t0:.1f} s of solving)"
                )
        if status != STATUS_SUCCESS:
            break
        schedule.arrived(leg)
        recorder.record(leg.requested, q, u, monitor.push, iters_since)
        iters_since = 0
    if bar is not None:
        bar.close()
    solve_time = time.perf_counter() - t0
    res = _result(scene, model, integrator, monitor, recorder, status, message, v, time_s,
                  solve_time)  # fmt: skip
    if over:
        res.settings["budget_exceeded"] = True
    return res


#: quasi-static runs take their load steps in the compiled loop where they can (:func:`marchable`);
#: False runs every step through the Python loop (the reference: benchmarks/bench_engine.py
#: --march compares the two)
USE_MARCH = True


def marchable(model: Model, scene, integrator, progress: bool) -> bool:
    """The run's load steps can go through the compiled loop (:mod:`.march`): quasi-static,
    no always-on tether, no wall damping's far-sample refresh, no kept trajectory or progress
    bar, every effect ringqa's own (disk-cached Newton)."""
    return (
        USE_MARCH
        and not integrator.dynamic
        and model.stab == 0.0
        and not progress
        and not bool(scene.outputs.trajectory)
        and not model._refresh_far
        and model.newton is newton
    )


def _march_args(model: Model, schedule: Schedule, monitor: Monitor, q, v, targets, hist_cap,
                max_steps: int):  # fmt: skip
    """The arguments of :func:`.march.march` for this run (scalars from the monitor, schedule and
    model; the modules' constants read now, so that a test may patch them), with its record
    arrays; returns (args, fs, ist, hist_u, hist_s, records)."""
    n_legs = targets.shape[0]
    fs = np.zeros(march_kernel.N_FS)
    ist = np.zeros(march_kernel.N_IST, dtype=np.int64)
    hist_u = np.zeros(max(hist_cap, len(monitor._hist_u), 2))
    hist_s = np.zeros_like(hist_u)
    rec = (
        np.full((n_legs, model.n_all), np.nan),
        np.full(n_legs, np.nan),
        np.zeros(n_legs, dtype=np.int64),
        np.zeros((n_legs, model.n_nodes)),
        np.full(n_legs, np.nan),
    )
    names = model.names
    solver = model.scene.solver
    args = (
        model.effects, q, v, model.samples, model.d_prev, model.r, model.B, model.energies,
        model.counters, model.nd, model.n_nodes, model.kl, model.n_free, model.tol_abs,
        model.max_iter, model.max_step, model.chain.link_len, model._chan, model._cum, model.cft,
        model._node_sample, np.ascontiguousarray(model.table.tan[0]), bool(model.extrapolate),
        float(model_mod.EXTRAPOLATE_FRACTION), int(model_mod.EXTRAPOLATE_MAX_ITERS),
        float(model_mod.EXTRAPOLATE_RTOL), float(model_mod.EXTRAPOLATE_SCALE_MAX),
        model_mod.plain_retry_iters(STALLED, int(model.max_iter)),
        model_mod.plain_retry_iters(ITERATION_LIMIT, int(model.max_iter)), model._pred_plain,
        model._pred_hints, targets, bool(schedule.history_free), bool(schedule.slide_grow),
        float(model.increment), float(schedule_mod.JUMP_FACTOR),
        int(schedule_mod.SLIDE_GROW_MAX_ITERS), float(model.speed),
        names.index("friction") if "friction" in names else -1,
        names.index("wall_damping") if "wall_damping" in names else -1, bool(model.contact_on),
        float(solver.jam_force_n), float(solver.jam_length_m), hist_u, hist_s, fs, ist,
        int(max_steps), *rec,
    )  # fmt: skip
    return args, fs, ist, hist_u, hist_s, rec


def _sync_in(fs, ist, hist_u, hist_s, model, schedule, monitor, u, time_s, iters_since) -> None:
    """The run's scalars from the Python objects into the kernel's arrays."""
    M = march_kernel
    fs[M.F_U] = u
    fs[M.F_INC] = schedule.inc
    fs[M.F_PUSH] = monitor.push
    fs[M.F_WORK_IN] = monitor.work_in
    fs[M.F_WORK_FR] = monitor.work_friction
    fs[M.F_WORK_DAMP] = monitor.work_damping
    fs[M.F_PRED_DU] = model._pred_du
    fs[M.F_PRED_U] = model._pred_u
    fs[M.F_MAX_PEN] = monitor.max_penetration_m
    fs[M.F_TIME] = time_s
    ist[M.I_ITERS] = monitor.total_iters
    ist[M.I_STEPS] = monitor.n_steps
    ist[M.I_SINCE] = iters_since
    hu, hs = monitor._hist_u, monitor._hist_s
    if len(hu) > hist_u.size:  # drop what no later jam test reaches (as the kernel does)
        k0 = max(bisect_right(hu, u - model.scene.solver.jam_length_m) - 1, 0)
        hu, hs = hu[k0:], hs[k0:]
        monitor._hist_u, monitor._hist_s = hu, hs
    n = len(hu)
    hist_u[:n] = hu
    hist_s[:n] = hs
    ist[M.I_HIST] = n


def _sync_out(fs, ist, hist_u, hist_s, model, schedule, monitor) -> tuple[float, float, int]:
    """The kernel's scalars back into the Python objects; returns (u, time_s, iters_since)."""
    M = march_kernel
    schedule.inc = float(fs[M.F_INC])
    monitor.push = float(fs[M.F_PUSH])
    monitor.work_in = float(fs[M.F_WORK_IN])
    monitor.work_friction = float(fs[M.F_WORK_FR])
    monitor.work_damping = float(fs[M.F_WORK_DAMP])
    monitor.max_penetration_m = float(fs[M.F_MAX_PEN])
    monitor.total_iters = int(ist[M.I_ITERS])
    monitor.n_steps = int(ist[M.I_STEPS])
    n = int(ist[M.I_HIST])
    monitor._hist_u = [float(x) for x in hist_u[:n]]
    monitor._hist_s = [float(x) for x in hist_s[:n]]
    model._pred_du = float(fs[M.F_PRED_DU])
    model._pred_u = float(fs[M.F_PRED_U])
    model._extrapolated = False
    return float(fs[M.F_U]), float(fs[M.F_TIME]), int(ist[M.I_SINCE])


def _marched(model, schedule, stepper, monitor, recorder, q, v, u, iters_since, deadline, t0):
    """The load steps of a :func:`marchable` run through :func:`.march.march`, a step its first
    attempt does not solve through the :class:`Stepper` (as the Python loop in :func:`run`,
    with the same answers). Returns (status, message, over budget, q, u, time_s)."""
    M = march_kernel
    legs = list(schedule.legs())
    targets = np.array([leg.target_m for leg in legs], dtype=np.float64)
    hist_cap = schedule.estimated_steps() + 2 * len(legs) + 8
    max_steps = 0 if deadline is None else 8
    args, fs, ist, hist_u, hist_s, rec = _march_args(
        model, schedule, monitor, q, v, targets, hist_cap, max_steps
    )
    time_s = 0.0
    _sync_in(fs, ist, hist_u, hist_s, model, schedule, monitor, u, time_s, iters_since)
    status, message, over = STATUS_SUCCESS, "", False
    while True:
        code = march_kernel.march(*args)
        if code == M.DONE:
            break
        u, time_s, iters_since = _sync_out(fs, ist, hist_u, hist_s, model, schedule, monitor)
        if code == M.JAM_FORCE:
            status, message = monitor.jam_message(u, None, None)
            break
        if code == M.JAM_PROGRESS:
            status, message = monitor.jam_message(
                u, float(fs[M.F_JAM_MOVED]), float(fs[M.F_JAM_OVER])
            )
            break
        if code == M.STEP_FAILED:
            du, dt = float(fs[M.F_DU]), float(fs[M.F_DT])
            first = (int(ist[M.I_FAIL_ITERS]), int(ist[M.I_FAIL_STATUS]), float(fs[M.F_RES]))
            out = stepper.take(u, du, dt, q, v, None, first=first)
            iters_since += out.iters
            if not out.ok:
                monitor.failed(out)
                status = STATUS_FAILED
                message = _not_converged_message(u, out)
                break
            monitor.accepted(out, du)
            q[:] = out.q
            u = u + du
            time_s += dt
            schedule.adapt(out.sub, out.last_iters, out.rest_speed_m_s)
            status, message = monitor.jam(u, du)
            if status != STATUS_SUCCESS:
                break
        if deadline is not None and time.perf_counter() > deadline:
            status, over = STATUS_FAILED, True
            message = (
                f"the run exceeded its time budget at advance {u * 1e3:.3f} mm "
                f"({time.perf_counter() - t0:.1f} s of solving)"
            )
            break
        _sync_in(fs, ist, hist_u, hist_s, model, schedule, monitor, u, time_s, iters_since)
    u, time_s, _ = _sync_out(fs, ist, hist_u, hist_s, model, schedule, monitor)
    _record_marched(model, recorder, legs, int(ist[M.I_LEG]), rec)
    return status, message, over, q, u, time_s


def _record_marched(model: Model, recorder: Recorder, legs, n_done: int, rec) -> None:
    """The waypoints :func:`.march.march` reached into the recorder (as
    :meth:`Recorder.record` at each)."""
    if n_done == 0:
        return
    rec_q, rec_push, rec_iters, rec_contact, rec_u = rec
    n = n_done
    src = np.empty((n, 3))
    dirn = np.empty((n, 3))
    tip = np.empty((n, 3))
    s = np.empty(n)
    off = np.empty(n)
    j = model._src_link
    tb = model.table
    march_kernel.source_rows(
        rec_q, rec_u, n, model.nd, j, model.cft - model.chain.cum[j], tb.h, tb.pos, tb.tan, src,
        dirn, tip, s, off,
    )  # fmt: skip
    idx = np.array([i for leg in legs[:n] for i in leg.requested], dtype=np.int64)
    row = np.repeat(np.arange(n), [len(leg.requested) for leg in legs[:n]])
    recorder.source_pos_m[idx] = src[row]
    recorder.source_dir[idx] = dirn[row]
    recorder.tip_pos_m[idx] = tip[row]
    recorder.push_force_n[idx] = rec_push[row]
    recorder.contact_force_n[idx] = rec_contact[row]
    recorder.newton_iters[idx] = rec_iters[row]
    recorder.s_m[idx] = s[row]
    recorder.offset_m[idx] = off[row]
    recorder.nodes_m[idx] = rec_q[row].reshape(row.size, model.n_nodes, model.nd)[:, :, :3]


def _result(scene, model, integrator, monitor, recorder, status, message, v, time_s, solve_time):
    """The :class:`SimResult` of a finished run (messages, warnings, work, settings, counters)."""
    n_req = recorder.push_force_n.size
    max_pen = monitor.max_penetration_m
    if status == STATUS_SUCCESS:
        message = f"reached all {n_req} requested advances"
    else:
        message += f"; {recorder.n_missing} of {n_req} requested advances not reached (NaN rows)"
    if status != STATUS_FAILED and max_pen > model.max_radius:  # a jam in the wall: no result
        sank = (
            f"the instrument sank {max_pen * 1e3:.3f} mm into the wall, more than its "
            f"{model.max_radius * 1e3:.3f} mm radius: its axis left the lumen, so its positions "
            f"mean nothing (raise contact.stiffness_n_m; {PAPER_STIFFNESS})"
        )
        message = sank if status == STATUS_SUCCESS else f"{sank}; {message}"
        status = STATUS_FAILED
    advances_mm = m_to_mm(np.asarray(recorder.advances_m, dtype=float))
    outside = outside_lumen(
        model.table, recorder.s_m, recorder.offset_m, recorder.tip_pos_m, advances_mm
    )
    if outside is not None:  # whatever the status: a jam outside the lumen is no result either
        why = outside_message(outside, model.wall_stiffness_n_m, PAPER_STIFFNESS not in message)
        message = why if status == STATUS_SUCCESS else f"{why}; {message}"
        status = STATUS_FAILED
    work = monitor.work(v, model.dynamic)
    warnings = list(model.warnings)
    unbalanced = work_balance_warning(work, scene, monitor.n_stabilised)
    if unbalanced:
        warnings.append(unbalanced)
    if PENETRATION_WARN * model.clearance < max_pen <= model.max_radius:
        warnings.append(
            f"the instrument sank up to {max_pen * 1e3:.3f} mm into the wall "
            f"({100 * max_pen / model.clearance:.0f} % of the clearance): raise "
            f"contact.stiffness_n_m for a tight lumen ({PAPER_STIFFNESS})"
        )
    if monitor.n_stabilised:
        warnings.append(
            f"{monitor.n_stabilised} load step(s) needed the fallback stabilisation (snap-through "
            f"or stall); its work is {work['stabilisation']:.3g} J of {work['input']:.3g} J input "
            "(work['stabilisation'])"
        )
    c = model.counters
    stats = SolverStats(
        n_steps=monitor.n_steps,
        n_newton_iters=int(monitor.total_iters),
        n_residuals=int(c[0]),
        n_jacobians=int(c[1]),
        n_solves=int(c[2]),
        n_halvings=int(c[3]),
        n_failed_attempts=monitor.n_failed_attempts,
        n_cut_steps=monitor.n_cut,
        n_stabilised_steps=monitor.n_stabilised,
    )
    settings = {
        "solver": asdict(scene.solver),
        "effects": asdict(scene.effects),
        "effects_assembled": list(model.names),
        "integrator": integrator.name,
        "n_nodes": model.n_nodes,
        "n_contact_samples": int(model.samples.link.size),
        "model_length_m": float(model.chain.cum[-1]),
        "dof_per_node": model.nd,
        "clearance_m": model.clearance,
        "time_step_s": model.time_step if model.dynamic else None,
        "total_newton_iters": int(monitor.total_iters),
        "simulated_time_s": time_s,
        "max_penetration_m": max_pen,
        "n_stabilised_steps": monitor.n_stabilised,
    }
    return SimResult(
        status=status,
        message=message,
        advances_mm=advances_mm,
        source_pos_m=recorder.source_pos_m,
        source_dir=recorder.source_dir,
        tip_pos_m=recorder.tip_pos_m,
        push_force_n=recorder.push_force_n,
        contact_force_n=recorder.contact_force_n,
        newton_iters=recorder.newton_iters,
        s_m=recorder.s_m,
        offset_m=recorder.offset_m,
        n_elements=model.chain.n_links,
        solve_time_s=solve_time,
        settings=settings,
        warnings=tuple(warnings),
        work=work,
        nodes_m=recorder.nodes_m,
        trajectory=recorder.trajectory(),
        max_penetration_m=max_pen,
        stats=stats,
        provenance=Provenance.now(settings={"scene": scene.name, **settings}),
    )


def _progress_bar(scene, schedule, u_start: float):
    """A tqdm bar over the input length (mm)."""
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    path = schedule.path
    total = sum(
        abs(b - a)
        for a, b in zip([u_start] + [p[0] for p in path[:-1]], [p[0] for p in path], strict=True)
    )
    return tqdm(
        total=round(total * 1e3, 3),
        unit="mm",
        desc=scene.name or "simulate",
        # the advance is a float: print it in mm to 0.1 (not 77.24000000000001/146.44)
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} mm "
        "[{elapsed}<{remaining}]",
    )


def _not_converged_message(u: float, out) -> str:
    """The run's message when a load step failed even with sub-steps (both loops say the same).

    Parameters
    ----------
    u : float
        The advance the step started from, m.
    out : ringqa.simulation.solvers.stepper.StepOutcome
        The failed step (its sub-steps, Newton status and last residual, N).
    """
    return (
        f"Newton did not converge at advance {u * 1e3:.3f} mm even with "
        f"{out.sub} sub-steps (status {out.status}, residual {out.res:.3g} N)"
    )
