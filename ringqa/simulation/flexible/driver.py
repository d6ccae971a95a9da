"""The flexible engine's run: quasi-static load steps of the beam-element rod.

The same problem as the rigid engine (:mod:`ringqa.simulation.solvers.driver`): the instrument is
pushed (quasi-statically, load steps of ``solver.increment_m`` along the channel) by its proximal
end, clamped on the straight extension before the entry; contact with the lumen wall and
friction with the rigid engine's laws; the outputs at the requested advances in the same
:class:`~ringqa.simulation.result.SimResult`. What differs is the discretisation
(:mod:`.rod`, :mod:`.kernels`) and this driver: its own predictor (nodes and tangents slid along
the channel by the increment), its own Newton, a failed step cut into halves and then retried with
a viscous tether to the predictor (the fallback stabilisation, counted and reported).

Supported: quasi-static solver; contact; friction none / Coulomb / Stribeck; gravity; torsion
(``effects.torsion``: a twist angle per node, GJ on the elements, the friction moment; the driven
end's twist held, as the rigid engine's); constant or stepwise forward motion (pauses cost
nothing quasi-statically); jams (push force above
``solver.jam_force_n``, or the tip moving less than 10 % of the input over
``solver.jam_length_m``). Refused with a :class:`~ringqa.errors.SceneError` naming the key: the
dynamic solver (inertia), wall damping, retraction and backward stepping, an always-on
stabilisation, ``outputs.trajectory``.
"""

from __future__ import annotations

import time
from dataclasses import asdict

import numpy as np

from ringqa.errors import SceneError, SimulationError
from ringqa.provenance import Provenance
from ringqa.simulation import _kernels as CK
from ringqa.simulation.channel import ChannelTable
from ringqa.simulation.effects.friction import LAWS
from ringqa.simulation.flexible import kernels as FK
from ringqa.simulation.flexible.rod import build_rod, contact_samples
from ringqa.simulation.result import (
    STATUS_FAILED,
    STATUS_JAMMED,
    STATUS_SUCCESS,
    SimResult,
    SolverStats,
)
from ringqa.units import m_to_mm

#: largest number of halvings of a failed load step before the fallback tether
MAX_CUTS = 4
#: the fallback tether's stiffness per node, as a fraction of the wall stiffness (as the rigid
#: engine's: 1e-3 k_wall)
TETHER_FRACTION = 1.0e-3
#: Load-step predictor: the slide plus this fraction of the previous step's Newton correction
#: (its solution minus its slide) when the step continues the previous one (same increment,
#: solved whole in at most EXTRAPOLATE_MAX_ITERS iterations); as the rigid engine's predictor
EXTRAPOLATE_FRACTION = 0.5
EXTRAPOLATE_MAX_ITERS = 8
#: Newton's tolerance is at least this many times the axial penalty's round-off (FlexModel)
ROUNDOFF_FLOOR = 16.0
#: the tangent offset used to slide a node's tangent along the channel in the predictor (m)
TANGENT_PROBE_M = 0.5e-3


def check_supported(scene) -> None:
    """Refuse (SceneError, naming the key and the fix) what the flexible engine does not model."""
    fix = 'set model.formulation = "rigid" for it'
    if scene.solver.kind != "quasistatic":
        raise SceneError(f"solver.kind = {scene.solver.kind!r}: the flexible engine is "
                         f"quasi-static only (no inertia); {fix}")  # fmt: skip
    if scene.effects.inertia:
        raise SceneError(f"effects.inertia: not modelled by the flexible engine; {fix}")
    if scene.effects.wall_damping:
        raise SceneError(f"effects.wall_damping: not modelled by the flexible engine; {fix}")
    m = scene.motion
    if m.kind == "retract" or m.backward:
        raise SceneError(f"motion.kind = {m.kind!r} (backward = {m.backward}): the flexible engine "
                         f"pushes forward only; {fix}")  # fmt: skip
    if scene.outputs.trajectory:
        raise SceneError(f"outputs.trajectory: the flexible engine records the requested advances "
                         f"only; {fix}")  # fmt: skip
    if scene.solver.stabilisation != 0.0:
        raise SceneError(f"solver.stabilisation: an always-on tether is not modelled by the "
                         f"flexible engine (it uses one only as the fallback); {fix}")  # fmt: skip


class FlexModel:
    """The flexible rod in its channel: discretisation, samples, arrays, state helpers."""

    def __init__(self, scene, advances_m: np.ndarray) -> None:
        check_supported(scene)
        self.scene = scene
        self.warnings: list[str] = []
        solver = scene.solver
        if solver.integrator == "bdf2":
            self.warnings.append(
                "solver.integrator = 'bdf2' applies to the dynamic solver only: ignored by the "
                "quasi-static load steps"
            )
        self.table = tb = ChannelTable.from_channel(getattr(scene, "simulated_channel",
                                                            scene.channel))  # fmt: skip
        inst = scene.instrument
        self.cft = float(inst.centre_from_tip_m)
        self.speed = float(scene.motion.speed_m_s)
        self.increment = float(solver.increment_m)
        m = scene.motion
        self.u_start = (-self.cft) if m.start_m is None else float(m.start_m)
        u_deep = max(float(np.max(advances_m)), self.u_start)
        need = u_deep + self.cft + float(solver.approach_m)
        rod = build_rod(inst, min(need, inst.length_m))
        if rod.sigma[-1] < u_deep + self.cft - 1e-9:
            raise SimulationError(
                f"instrument {inst.name!r}: too short to reach advance {u_deep * 1e3:.1f} mm"
            )
        self.rod = rod
        rigid = {k for k, sec in enumerate(inst.sections) if sec.rigid}
        self.rigid_elements = np.asarray(
            [e for e in range(rod.n_elements) if int(rod.el_section[e]) in rigid], dtype=np.int64
        )
        nn = rod.n_nodes
        self.n_nodes = nn
        # coordinates per node and per contact sample: a twist angle each with torsion only (a
        # scene without it carries no twist unknown at all)
        self.torsion = bool(scene.effects.torsion)
        self.nd = nd = FK.ND_TWIST if self.torsion else FK.ND
        self.ns = ns = 4 if self.torsion else 3
        if self.torsion and not np.all(rod.el_gj > 0.0):
            raise SceneError("effects.torsion: every instrument section needs gj_nm2 > 0 (set "
                             "gj_nm2, or switch torsion off)")  # fmt: skip
        self.n_all = nd * nn
        self.n_free = nd * (nn - 1)
        rb_min = float(np.min(tb.seg_rb))
        ro_max = float(np.max(rod.el_ro))
        if ro_max >= rb_min:
            raise SimulationError(
                f"instrument radius {ro_max * 1e3:.3f} mm does not fit the lumen "
                f"(r_b = {rb_min * 1e3:.3f} mm): check the lumen or the instrument"
            )
        self.clearance = rb_min - ro_max
        self.max_radius = ro_max
        eff = scene.effects
        self.contact_on = bool(eff.contact)
        c = scene.contact
        el, xi, ro, wt = contact_samples(
            rod, tb.min_radius_m(), self.clearance, float(solver.contact_bow_fraction),
            bool(c.stiffness_per_length),
        )  # fmt: skip
        self.samp_el, self.samp_xi, self.samp_ro, self.samp_wt = el, xi, ro, wt
        P = el.size
        self.P = P
        self.samp_link = np.arange(P, dtype=np.int64)
        self.samp_alpha = np.zeros(P)
        self.samp_s = np.zeros(P)
        self.samp_p = np.zeros((P, 3))
        self.samp_d = np.zeros(P)
        self.samp_n = np.zeros((P, 3))
        self.samp_H = np.zeros((P, 3, 3))
        self.samp_z = np.zeros(P)
        self.samp_w = np.zeros(P)
        self.samp_F = np.zeros(P)
        self.samp_dF = np.zeros(P)
        self.qs = np.zeros(ns * (P + 1))
        self.qs_prev = np.zeros(ns * (P + 1))
        self.qs_start = np.zeros(ns * (P + 1))
        self.rs = np.zeros(ns * (P + 1))
        self.Bs = np.zeros((ns * (P + 1), 2 * (2 * ns - 1) + 1))
        # contact law parameters (the rigid engine's Contact unit reads the same keys)
        self.k_wall = float(c.stiffness_n_m)
        self.transition = -1.0 if c.transition_m is None else float(c.transition_m)
        self.max_frac = float(c.transition_max_fraction)
        w_lumen = float(np.max(tb.seg_rb - tb.seg_ra))
        w = w_lumen if self.transition <= 0 else self.transition
        if self.contact_on and w > self.max_frac * self.clearance:
            self.warnings.append(
                f"contact transition zone {w * 1e3:.3f} mm reduced to "
                f"{self.max_frac * self.clearance * 1e3:.4f} mm "
                f"({self.max_frac:g} x the clearance {self.clearance * 1e3:.3f} mm)"
            )
        law = LAWS[eff.friction] if self.contact_on else 0
        if not self.contact_on and eff.friction != "none":
            self.warnings.append("friction needs contact: effects.friction ignored")
        self.law = law
        self.mu_s, self.mu_k = float(c.mu_s), float(c.mu_k)
        self.v_brk = float(c.v_brk_m_s)
        self.v_reg = (
            self.v_brk / 10.0 if c.friction_v_reg_m_s is None else float(c.friction_v_reg_m_s)
        )
        self.slip_min = float(c.friction_slip_min_m)
        # elements: bending, axial penalty, distributed load
        self.el_ea = np.full(rod.n_elements, float(solver.axial_stiffness_n))
        g = np.zeros(3) if eff.gravity_m_s2 is None else np.asarray(eff.gravity_m_s2, float)
        self.el_w = np.ascontiguousarray(rod.el_mu[:, None] * g[None, :])
        # arrays
        self.r = np.zeros(self.n_all)
        self.B = np.zeros((self.n_all, 2 * (2 * nd - 1) + 1))
        self.chords = np.zeros(rod.n_elements)
        self.out = np.zeros(3)
        self.f_ext = np.zeros(self.n_all)
        self.counters = np.zeros(3, dtype=np.int64)
        flex = rod.el_section != rod.el_section[0] if rod.n_elements > 1 else np.ones(1, bool)
        l_flex = rod.el_len[flex] if np.any(flex) else rod.el_len
        ei_flex = rod.el_ei[flex] if np.any(flex) else rod.el_ei
        self.l_ref = float(np.min(l_flex))
        # Newton's tolerance: the rigid engine's (tol x EI / l^2), but never below the round-off
        # floor of the axial penalty: an element's strain is known to ~eps |x| / l, so its force
        # to EA eps |x| / l (x the coordinates' size; 1e-8 N for a ring, 4e-7 N for a
        # cantilever 0.5 m from the origin with EA = 1e8 N)
        x_size = float(np.max(np.abs(tb.pos))) + float(rod.sigma[-1])
        floor = ROUNDOFF_FLOOR * np.finfo(float).eps * float(solver.axial_stiffness_n) * x_size
        self.tol_f = max(
            float(solver.tol) * max(float(np.max(ei_flex / l_flex**2)), 1e-2),
            floor / self.l_ref,
        )
        self.tol_m = self.tol_f * self.l_ref
        self.max_iter = int(solver.max_iter)
        self.max_step = 0.5 * self.clearance
        self.k_teth = TETHER_FRACTION * self.k_wall
        self._chan = tb.args()
        self.node_s = np.zeros(nn)
        #: the last whole load step's Newton correction and its increment (the predictor)
        self.last_correction: np.ndarray | None = None
        self.last_du = float("nan")
        self.node_s2 = np.zeros(nn)
        # the source: element and parameter at sigma = cft
        e_src = int(np.clip(np.searchsorted(rod.sigma, self.cft, side="right") - 1, 0,
                            rod.n_elements - 1))  # fmt: skip
        self.src_el = e_src
        self.src_xi = (self.cft - rod.sigma[e_src]) / rod.el_len[e_src]

    # -- state ---------------------------------------------------------------------------
    def initial_state(self, u: float) -> np.ndarray:
        """The rod laid along the (extended) centreline with the source centre at advance u."""
        q = np.zeros(self.n_all)
        sig = self.rod.sigma
        nd = self.nd
        for k in range(self.n_nodes):
            s = u + self.cft - sig[k]
            q[nd * k : nd * k + 3] = self.table.point(s)
            q[nd * k + 3 : nd * k + 6] = -self.table.tangent(s)
            self.node_s[k] = s
            self.node_s2[k] = s - TANGENT_PROBE_M
        for i in range(self.P):
            e = self.samp_el[i]
            self.samp_s[i] = u + self.cft - sig[e] - self.samp_xi[i] * self.rod.el_len[e]
        self.samp_z[:] = 0.0
        return q

    def prescribe(self, q: np.ndarray, u: float) -> None:
        """Clamp the driven proximal node on the approach axis for input advance ``u`` (its
        twist, with torsion, stays 0: the afterloader holds the cable's end)."""
        k = self.n_nodes - 1
        nd = self.nd
        s = u + self.cft - self.rod.sigma[k]
        q[nd * k : nd * k + 3] = self.table.point(s)
        q[nd * k + 3 : nd * k + 6] = -self.table.tangent(s)

    def predict(self, q: np.ndarray, du: float, u_new: float) -> None:
        """Predictor (in place): every node and its tangent slid ``du`` along the channel, the
        driven node clamped at ``u_new``, then each element's chord put back to its length before
        the slide, from the driven end towards the tip (a node slid at an offset from the
        centreline into a bend of another curvature changes its chord by ~1e-3, which the axial
        penalty EA = 1e6 N answers with ~1 kN), and a rigid element's tangents along its chord (a
        slid tangent off the chord by 1e-3 bends the stiff capsule with ~50 N). The twist angles
        are not slid (the Bishop frame does not twist along the channel)."""
        FK.chord_lengths(q, self.nd, self.chords)
        self.slide(q, du)
        self.prescribe(q, u_new)
        FK.restore_chords(q, self.nd, self.chords, self.rigid_elements)

    def slide(self, q: np.ndarray, du: float) -> None:
        """Every node and its tangent slid ``du`` along the channel (in place)."""
        nn = self.n_nodes
        nd = self.nd
        x = np.ascontiguousarray(q.reshape(nn, nd)[:, :3])
        t = q.reshape(nn, nd)[:, 3:6]
        tl = np.linalg.norm(t, axis=1)
        x2 = np.ascontiguousarray(x + TANGENT_PROBE_M * t / tl[:, None])
        out = np.empty_like(x)
        out2 = np.empty_like(x)
        s_out = np.empty(nn)
        s_out2 = np.empty(nn)
        h, pos, tan = self.table.h, self.table.pos, self.table.tan
        CK.slide_points(h, pos, tan, x, self.node_s, du, out, s_out)
        CK.slide_points(h, pos, tan, x2, self.node_s2, du, out2, s_out2)
        tn = out2 - out
        tn *= (tl / np.linalg.norm(tn, axis=1))[:, None]
        qv = q.reshape(nn, nd)
        qv[:, :3] = out
        qv[:, 3:6] = tn
        self.node_s[:] = s_out
        self.node_s2[:] = s_out2
        self.samp_s += du

    def solve(self, q, du: float, k_teth: float, q_ref: np.ndarray) -> tuple[int, int, float]:
        """Newton on the current load step (friction against ``self.qs_prev``)."""
        dt = abs(du) / self.speed if du != 0.0 else 1.0
        v_reg = max(self.v_reg, self.slip_min / dt)
        ch = self._chan
        st, it, res = FK.newton(
            q, self.nd, self.ns, self.rod.el_len, self.rod.el_ei, self.rod.el_gj, self.el_ea,
            self.el_w, self.samp_el,
            self.samp_xi, self.samp_link, self.samp_alpha, self.samp_ro, self.samp_wt, ch.h,
            ch.pos, ch.tan, ch.flat_normal, ch.kappa_min_flat, ch.seg_s, ch.seg_rb, ch.seg_ra,
            ch.seg_flat, self.transition, self.max_frac, self.k_wall, self.contact_on,
            self.samp_s, self.samp_p, self.samp_d, self.samp_n, self.samp_H, self.samp_z,
            self.samp_w, self.samp_F, self.samp_dF, self.qs, self.qs_prev, self.qs_start,
            self.rs, self.Bs, self.law if du != 0.0 else 0, self.mu_s, self.mu_k, self.v_brk,
            v_reg, dt, k_teth, q_ref, self.f_ext, self.n_free, self.r, self.B, self.out, self.tol_f,
            self.tol_m, self.max_iter, self.max_step, 1.0 / self.l_ref, self.counters,
        )  # fmt: skip
        return int(st), int(it), float(res)

    def sample_positions(self, q: np.ndarray, out: np.ndarray) -> None:
        """The contact samples' positions (and twists) of state ``q`` into ``out`` (flat,
        ns (P + 1))."""
        FK.sample_positions(q, self.nd, self.ns, self.rod.el_len, self.samp_el, self.samp_xi,
                            out)  # fmt: skip

    def push_force(self) -> float:
        """Axial force of the driver (N, > 0 pushing): the residual at the clamped node along
        the entry tangent."""
        k = self.n_nodes - 1
        return float(np.dot(self.r[self.nd * k : self.nd * k + 3], self.table.tan[0]))

    def source(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Source centre (3,), unit direction to the tip (3,), tip (3,) of state ``q``."""
        e = self.src_el
        L = float(self.rod.el_len[e])
        hh = np.empty(4)
        cc = np.empty(4)
        FK.hermite(self.src_xi, L, hh)
        FK.hermite_d1(self.src_xi, L, cc)
        nd = self.nd
        blk = np.concatenate((q[nd * e : nd * e + 6], q[nd * (e + 1) : nd * (e + 1) + 6]))
        blk = blk.reshape(4, 3)
        src = hh @ blk
        d = -(cc @ blk)
        d /= np.linalg.norm(d)
        return src, d, q[0:3].copy()

    def nodes(self, q: np.ndarray) -> np.ndarray:
        """Node positions (n_nodes, 3)."""
        return q.reshape(self.n_nodes, self.nd)[:, :3].copy()

    def twist(self, q: np.ndarray) -> np.ndarray:
        """Twist angle of every node (n_nodes,) (rad; zeros without torsion)."""
        if not self.torsion:
            return np.zeros(self.n_nodes)
        return q.reshape(self.n_nodes, self.nd)[:, 6].copy()


def _targets(scene, advances_m: np.ndarray, u_start: float) -> list[tuple[float, list[int]]]:
    """The requested advances in pushing order: (advance, indices of the requests there)."""
    order: dict[float, list[int]] = {}
    for i, a in enumerate(advances_m):
        order.setdefault(float(a), []).append(i)
    out = sorted(order.items())
    if out and out[0][0] < u_start - 1e-12:
        raise SceneError(
            f"motion.advances_mm: {out[0][0] * 1e3:.2f} mm lies before the start "
            f"{u_start * 1e3:.2f} mm (motion.start_mm); the flexible engine pushes forward only"
        )
    return out


def run_flexible(scene, advances_m: np.ndarray, progress: bool = False) -> SimResult:
    """Simulate ``scene`` with the flexible engine and report at ``advances_m`` (m).

    Same contract as :func:`ringqa.simulation.simulate` (status, never raises for a run that
    jams or fails; NaN rows for advances not reached).
    """
    del progress  # no progress bar: runs take a fraction of a second to seconds
    advances_m = np.atleast_1d(np.asarray(advances_m, dtype=float))
    model = FlexModel(scene, advances_m)
    targets = _targets(scene, advances_m, model.u_start)
    n_req = advances_m.size
    nn = model.n_nodes
    rec = {
        "src": np.full((n_req, 3), np.nan), "dir": np.full((n_req, 3), np.nan),
        "tip": np.full((n_req, 3), np.nan), "push": np.full(n_req, np.nan),
        "cf": np.full((n_req, nn), np.nan), "it": np.zeros(n_req, dtype=np.int64),
        "s": np.full(n_req, np.nan), "off": np.full(n_req, np.nan),
        "nodes": np.full((n_req, nn, 3), np.nan),
    }  # fmt: skip
    # compile (or load) the kernels on scratch copies before the clock starts
    q = model.initial_state(model.u_start)
    model.prescribe(q, model.u_start)
    model.sample_positions(q, model.qs_prev)
    model.qs_start[:] = model.qs_prev
    qw = q.copy()
    save = [a.copy() for a in (model.samp_s, model.samp_p, model.samp_z)]
    model.solve(qw, 1e-3, 0.0, qw.copy())
    model.solve(qw, 1e-3, 1.0, qw.copy())
    model.samp_s[:], model.samp_p[:], model.samp_z[:] = save
    model.counters[:] = 0
    FK.lump_forces(model.samp_el, model.samp_xi, model.samp_F, np.zeros(nn))

    t0 = time.perf_counter()
    u = model.u_start
    status, message = STATUS_SUCCESS, ""
    st, it, _ = model.solve(q, 0.0, 0.0, q)
    if st != 0:
        status = STATUS_FAILED
        message = f"initial state did not converge at advance {u * 1e3:.2f} mm (status {st})"
    iters_since = it
    total_iters = it
    n_steps = n_cut = n_stab = n_failed = 0
    w_input = w_friction = w_stab = 0.0
    e0 = float(model.out[0] + model.out[1])
    push = model.push_force()
    max_pen = 0.0
    jam_f = float(scene.solver.jam_force_n)
    jam_len = float(scene.solver.jam_length_m)
    tip_hist = [(u, float(model.samp_s[0]))]  # (input, the tip's arc length)
    for target, idx in targets if status == STATUS_SUCCESS else ():
        while status == STATUS_SUCCESS and target - u > 1e-12:
            du = min(model.increment, target - u)
            if target - u - du < 1e-3 * model.increment:
                du = target - u
            ok, q_new, its, sub, stab, wf, wst, nf = _take_step(model, q, u, du)
            iters_since += its
            total_iters += its
            n_failed += nf
            if not ok:
                status = STATUS_FAILED
                message = (f"Newton did not converge at advance {u * 1e3:.3f} mm even with "
                           f"{sub} sub-steps and the fallback tether")  # fmt: skip
                break
            n_steps += 1
            n_cut += sub > 1
            n_stab += stab
            q = q_new
            u += du
            new_push = model.push_force()
            w_input += new_push * du
            push = new_push
            w_friction += wf
            w_stab += wst
            max_pen = max(max_pen, float(np.max((model.samp_z - 1.0) * model.samp_w, initial=0.0)))
            if push > jam_f:
                status = STATUS_JAMMED
                message = (f"jammed: push force {push:.2f} N above solver.jam_force_n = "
                           f"{jam_f:g} N at advance {u * 1e3:.2f} mm")  # fmt: skip
            tip_hist.append((u, model.table.closest(q[0:3], tip_hist[-1][1])[0]))
            back = [h for h in tip_hist if h[0] <= u - jam_len + 1e-12]
            if status == STATUS_SUCCESS and back:
                u0, s0 = back[-1]
                if tip_hist[-1][1] - s0 < 0.1 * (u - u0):
                    status = STATUS_JAMMED
                    message = (f"jammed: the tip moved {(tip_hist[-1][1] - s0) * 1e3:.2f} mm "
                               f"over the last {(u - u0) * 1e3:.1f} mm of input "
                               f"(solver.jam_length_mm) at advance {u * 1e3:.2f} mm")  # fmt: skip
        if status != STATUS_SUCCESS:
            break
        src, d, tip = model.source(q)
        s, off = model.table.closest(src, u)
        cf = np.zeros(nn)
        FK.lump_forces(model.samp_el, model.samp_xi, model.samp_F, cf)
        for i in idx:
            rec["src"][i], rec["dir"][i], rec["tip"][i] = src, d, tip
            rec["push"][i] = push
            rec["cf"][i] = cf
            rec["it"][i] = iters_since
            rec["s"][i], rec["off"][i] = s, off
            rec["nodes"][i] = model.nodes(q)
        iters_since = 0
    solve_time = time.perf_counter() - t0
    n_missing = int(np.sum(np.isnan(rec["push"])))
    if status == STATUS_SUCCESS and max_pen > model.max_radius:
        status = STATUS_FAILED
        message = (f"the instrument sank {max_pen * 1e3:.3f} mm into the wall, more than its "
                   f"radius: raise contact.stiffness_n_m")  # fmt: skip
    if status == STATUS_SUCCESS:
        message = f"reached all {n_req} requested advances (flexible engine)"
    else:
        message += f"; {n_missing} of {n_req} requested advances not reached (NaN rows)"
    warnings = list(model.warnings)
    if n_stab:
        warnings.append(
            f"{n_stab} load step(s) needed the fallback stabilisation (flexible engine); its "
            f"work is {w_stab:.3g} J of {w_input:.3g} J input"
        )
    if 0.1 * model.clearance < max_pen <= model.max_radius:
        warnings.append(f"the instrument sank up to {max_pen * 1e3:.3f} mm into the wall "
                        f"({100 * max_pen / model.clearance:.0f} % of the clearance)")  # fmt: skip
    elastic = float(model.out[0] + model.out[1]) - e0
    denom = max(abs(w_input), 1e-30)
    work = {
        "input": w_input, "elastic": elastic, "friction": w_friction, "damping": 0.0,
        "stabilisation": w_stab, "kinetic": 0.0,
        "balance_error": abs(w_input - elastic - w_friction - w_stab) / denom,
    }  # fmt: skip
    c = model.counters
    settings = {
        "formulation": "flexible",
        "solver": asdict(scene.solver),
        "effects": asdict(scene.effects),
        "effects_assembled": ["bending", "axial"]
        + (["torsion"] if model.torsion else [])
        + (["gravity"] if np.any(model.el_w) else [])
        + (["contact"] if model.contact_on else [])
        + (["friction"] if model.law else []),
        "integrator": "quasistatic",
        "n_nodes": nn,
        "n_contact_samples": model.P,
        "model_length_m": float(model.rod.sigma[-1]),
        "dof_per_node": model.nd,
        "clearance_m": model.clearance,
        "time_step_s": None,
        "total_newton_iters": int(total_iters),
        "simulated_time_s": 0.0,
        "max_penetration_m": max_pen,
        "n_stabilised_steps": n_stab,
    }
    return SimResult(
        status=status,
        message=message,
        advances_mm=m_to_mm(advances_m),
        source_pos_m=rec["src"],
        source_dir=rec["dir"],
        tip_pos_m=rec["tip"],
        push_force_n=rec["push"],
        contact_force_n=rec["cf"],
        newton_iters=rec["it"],
        s_m=rec["s"],
        offset_m=rec["off"],
        n_elements=model.rod.n_elements,
        solve_time_s=solve_time,
        settings=settings,
        warnings=tuple(warnings),
        work=work,
        nodes_m=rec["nodes"],
        trajectory=None,
        max_penetration_m=max_pen,
        stats=SolverStats(
            n_steps=n_steps,
            n_newton_iters=int(total_iters),
            n_residuals=int(c[1]),
            n_jacobians=int(c[1]),
            n_solves=int(c[0]),
            n_halvings=int(c[2]),
            n_failed_attempts=n_failed,
            n_cut_steps=n_cut,
            n_stabilised_steps=n_stab,
        ),
        provenance=Provenance.now(settings={"scene": scene.name, **settings}),
    )


def _take_step(model: FlexModel, q: np.ndarray, u: float, du: float):
    """One load step from ``(q, u)`` by ``du``: whole, then cut in halves (up to
    :data:`MAX_CUTS` times), then each sub-step with the fallback tether.

    Returns (ok, q_new, iterations, sub-steps, stabilised (0/1), friction work, tether work,
    failed attempts).
    """
    iters = 0
    failed = 0
    save_s = model.samp_s.copy()
    save_ns = (model.node_s.copy(), model.node_s2.copy())
    corr = model.last_correction if model.last_du == du else None
    model.last_correction = None
    model.last_du = du
    for tether in (False, True):
        for cut in range(MAX_CUTS + 1):
            n_sub = 2**cut
            h = du / n_sub
            qc = q.copy()
            model.samp_s[:] = save_s
            model.node_s[:], model.node_s2[:] = save_ns[0].copy(), save_ns[1].copy()
            wf = wst = 0.0
            ok = True
            for k in range(n_sub):
                model.sample_positions(qc, model.qs_prev)
                model.qs_start[:] = model.qs_prev
                model.predict(qc, h, u + (k + 1) * h)
                q_plain = qc.copy()
                extrapolated = corr is not None and n_sub == 1 and not tether
                if extrapolated:
                    qc[: model.n_free] += EXTRAPOLATE_FRACTION * corr[: model.n_free]
                q_ref = qc.copy()
                kt = model.k_teth if tether else 0.0
                st, it, _ = model.solve(qc, h, kt, q_ref)
                iters += it
                if st != 0 and extrapolated:  # retried from the plain slide
                    failed += 1
                    model.samp_s[:] = save_s + h
                    qc[:] = q_plain
                    st, it, _ = model.solve(qc, h, kt, q_plain)
                    iters += it
                if st != 0:
                    ok = False
                    failed += 1
                    break
                if n_sub == 1 and not tether and it <= EXTRAPOLATE_MAX_ITERS and du > 0:
                    model.last_correction = qc - q_plain
                wf += model.out[2]
                if tether:
                    dx = (qc - q_ref).reshape(-1, model.nd)[:-1, :3]
                    wst += 0.5 * kt * float(np.sum(dx * dx))
            if ok:
                return True, qc, iters, n_sub, int(tether), wf, wst, failed
    return False, q, iters, 2**MAX_CUTS, 1, 0.0, 0.0, failed
