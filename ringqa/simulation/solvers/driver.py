"""The solvers: quasi-static load stepping and implicit (backward-Euler or BDF2) dynamics.

Both march the input advance ``u`` (the driven proximal end) along a list of waypoints and solve
the equilibrium (quasi-static) or the implicit equation of motion (dynamic) with the same Newton
kernel (:func:`ringqa.simulation.solvers._kernels.newton`). What differs:

- quasi-static: increments of ``solver.increment_m``; the step's "time" is
  ``increment / motion.speed`` (used only by friction, wall damping and the stabilisation);
  predictor: the previous chain slid along the channel by the increment; a failed step is cut in
  half (down to 1/256 of the increment); a frictionless, undamped scene has no history, so the
  increment doubles after easy steps (up to ``JUMP_FACTOR`` increments): it "jumps" to the
  requested advances;
- dynamic: time steps of ``solver.time_step_s`` at ``motion.speed``; inertia on; predictor
  ``q + dt v``; a failed step is sub-stepped. ``solver.integrator = "bdf2"`` takes each step as a
  backward-Euler step against a modified history (:func:`bdf2_history`): the Newton kernel is
  unchanged; the first step, and a step more than ``BDF2_MAX_RATIO`` times longer than the
  previous one, are backward Euler. The friction slip floor (``slip_min / dt``) and the
  stabilisation tether (``c / dt``) keep their per-step values, and the step's friction and
  wall-damping work are recomputed over the actual displacement (``_kernels.step_work``), so the
  work balance reads as with backward Euler.

Jams (push force above ``solver.jam_force_n``, or less than 10 % progress of the tip, which
carries the source, over
``solver.jam_length_m`` of forward input) end the run with status 1; a step that fails at the
smallest increment ends it with status -1. Neither raises.
"""

from __future__ import annotations

import time
from dataclasses import asdict

import numpy as np

from ringqa.errors import SceneError, SimulationError
from ringqa.provenance import Provenance
from ringqa.simulation import _kernels as K
from ringqa.simulation._cache import ensure_fresh_kernel_cache
from ringqa.simulation.chain import build_chain, contact_samples
from ringqa.simulation.channel import KAPPA_MIN_FLAT, ChannelTable
from ringqa.simulation.effects import (
    Bending,
    Contact,
    Friction,
    Gravity,
    Inertia,
    Inextensibility,
    Torsion,
    WallDamping,
)
from ringqa.simulation.effects.base import CPAR, FLAG, N_CPAR, N_FLAGS, positive
from ringqa.simulation.result import STATUS_FAILED, STATUS_JAMMED, STATUS_SUCCESS, SimResult
from ringqa.simulation.scene import INTEGRATORS
from ringqa.simulation.solvers import _kernels as SK
from ringqa.units import m_to_mm

#: a frictionless, undamped run may grow its load step up to this many increments ("jump")
JUMP_FACTOR = 8
#: smallest step as a fraction of the requested increment before the run is declared failed
MIN_CUT = 1.0 / 256.0
#: sub-steps tried without stabilisation before the fallback stabilisation is switched on
FALLBACK_AFTER = 1
#: fallback stabilisation: a viscous tether to the predictor of stiffness (coefficient / dt)
#: equal to this fraction of the wall stiffness per node
FALLBACK_STIFFNESS_FRACTION = 1e-3
#: BDF2: a step more than this many times longer than the previous one is taken with backward
#: Euler instead (variable-step BDF2 is zero-stable for step ratios below 1 + sqrt(2); the
#: ramped input's short landing steps and the sub-steps of a failed step change the ratio)
BDF2_MAX_RATIO = 2.0


class Model:
    """The assembled problem: channel table, chain, samples, switched-on effects, work arrays.

    Parameters
    ----------
    scene : ringqa.simulation.scene.Scene
    advances_m : (n,) float
        Requested advances (m).

    Attributes
    ----------
    links, chan, samples, swork, par : tuple
        The kernels' argument groups (their contents, units and shapes: the
        :mod:`ringqa.simulation.solvers._kernels` module docstring): ``links`` = (nd, n_nodes,
        kl, link_len, hinge_k, twist_k, node_mass, node_rot), ``chan`` = the channel table
        (h, pos, tan, nor, KAPPA_MIN_FLAT, seg_s, seg_rb, seg_ra, seg_flat), ``samples`` =
        (samp_link, samp_alpha, samp_ro, samp_wt, samp_s, samp_d_prev), ``swork`` = (samp_p,
        samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF), ``par`` = (cpar, flags, g).
        Built once here; they hold the same arrays as the attributes of those names, so the
        arrays are changed in place only (``model.samp_s[:] = ...``), never rebound.
    """

    def __init__(self, scene, advances_m: np.ndarray) -> None:
        ensure_fresh_kernel_cache()
        self.scene = scene
        self.warnings: list[str] = []
        eff = scene.effects
        solver = scene.solver
        if solver.kind not in ("quasistatic", "dynamic"):
            raise SceneError(f"solver.kind: {solver.kind!r} is not 'quasistatic' or 'dynamic'")
        self.dynamic = solver.kind == "dynamic"
        integrator = solver.integrator
        if integrator not in INTEGRATORS:
            raise SceneError(
                f"solver.integrator: {integrator!r} is not one of {', '.join(INTEGRATORS)}"
            )
        self.bdf2 = self.dynamic and integrator == "bdf2"
        if integrator == "bdf2" and not self.dynamic:
            self.warnings.append(
                "solver.integrator = 'bdf2' applies to the dynamic solver only: ignored by the "
                "quasi-static load steps"
            )
        if self.dynamic and not eff.inertia:
            self.warnings.append("solver.kind = 'dynamic' switches inertia on")
        self.inertia_on = self.dynamic
        if eff.inertia and not self.dynamic:
            self.warnings.append(
                "effects.inertia is on but solver.kind = 'quasistatic': inertia ignored"
            )
        self.table = ChannelTable.from_channel(scene.channel)
        inst = scene.instrument
        self.cft = positive("instrument.centre_from_tip_m", inst.centre_from_tip_m, True)
        self.speed = positive("motion.speed_m_s", scene.motion.speed_m_s)
        self.increment = positive("solver.increment_m", solver.increment_m)
        self.time_step = positive("solver.time_step_s", solver.time_step_s)
        self.tol = positive("solver.tol", solver.tol)
        self.max_iter = int(positive("solver.max_iter", solver.max_iter))
        self.stab = positive("solver.stabilisation", solver.stabilisation, allow_zero=True)
        approach = positive("solver.approach_m", solver.approach_m)
        m = scene.motion
        self.u_start = (-self.cft) if m.start_m is None else float(m.start_m)
        u_deep = max(float(np.max(advances_m)), self.u_start)
        # model length: the deepest tip position + the approach, extended so that the two driven
        # proximal nodes always stay on the straight extension before the entry (s <= 0)
        need = u_deep + self.cft + approach
        chain = build_chain(inst, min(need, inst.length_m))
        if chain.cum[-2] < u_deep + self.cft:
            chain = build_chain(inst, min(need + chain.link_len[-1], inst.length_m))
        if chain.cum[-2] < u_deep + self.cft - 1e-9:
            raise SimulationError(
                f"instrument {inst.name!r}: too short to reach advance {u_deep * 1e3:.1f} mm"
            )
        self.chain = chain
        # effects
        self.torsion = Torsion.from_chain(chain) if eff.torsion else None
        self.nd = 4 if self.torsion is not None else 3
        self.bending = Bending.from_chain(chain)
        self.axial = Inextensibility.from_scene(scene)
        self.contact = Contact.from_scene(scene) if eff.contact else None
        self.friction = Friction.from_scene(scene) if eff.contact else None
        if not eff.contact and eff.friction != "none":
            self.warnings.append("friction needs contact: effects.friction ignored")
        self.damping = WallDamping.from_scene(scene) if (eff.contact and eff.wall_damping) else None
        self.gravity = Gravity.from_scene(scene)
        self.inertia = Inertia.from_chain(chain) if self.inertia_on else None
        self.flags = np.zeros(N_FLAGS, dtype=np.int64)
        self.cpar = np.zeros(N_CPAR, dtype=np.float64)
        self.g = np.zeros(3)
        for unit in (
            self.axial, self.torsion, self.contact, self.friction, self.damping, self.gravity,
            self.inertia,
        ):  # fmt: skip
            if unit is not None:
                unit.pack(self.flags, self.cpar)
        if self.gravity is not None:
            self.g[:] = self.gravity.g
        if self.stab > 0 and not self.dynamic:
            self.flags[FLAG["stabilisation"]] = 1
            self.cpar[CPAR["stabilisation"]] = self.stab
        # contact samples along the links
        tb = self.table
        rb_min = float(np.min(tb.seg_rb))
        ro_max = float(np.max(chain.link_ro))
        if ro_max >= rb_min:
            raise SimulationError(
                f"instrument radius {ro_max * 1e3:.3f} mm does not fit the lumen "
                f"(r_b = {rb_min * 1e3:.3f} mm): check the lumen or the instrument"
            )
        flat_min = float(np.min(tb.seg_flat))
        if flat_min <= ro_max:
            raise SimulationError(
                f"instrument radius {ro_max * 1e3:.3f} mm does not fit the U-shaped lumen "
                f"(flat side {flat_min * 1e3:.3f} mm from the centreline): check the lumen"
            )
        self.clearance = rb_min - ro_max
        # guard: a straight link cannot fit a bend at all when its bow l^2/(8R) exceeds the
        # lumen's width 2c; check each section against the tightest bend it can reach
        for k, name in enumerate(chain.section_names):
            sel = chain.link_section == k
            if not np.any(sel) or not np.all(np.isfinite(chain.link_ei[sel])):
                continue
            l_max = float(np.max(chain.link_len[sel]))
            front = u_deep + self.cft - float(chain.cum[np.argmax(sel)])
            s_tab = np.arange(self.table.pos.shape[0]) * self.table.h
            kap = self.table.kappa[s_tab <= front + 1e-9]
            if kap.size == 0 or np.max(kap) <= 0:
                continue
            c_sec = rb_min - float(np.max(chain.link_ro[sel]))
            bow = l_max**2 * float(np.max(kap)) / 8.0
            if bow > 2.0 * c_sec:
                self.warnings.append(
                    f"section {name!r}: {l_max * 1e3:.1f} mm links bow {bow * 1e3:.2f} mm across "
                    f"the tightest bend they reach, more than the lumen's free width "
                    f"{2 * c_sec * 1e3:.2f} mm: they cannot fit; use links <= "
                    f"{np.sqrt(16 * c_sec / np.max(kap)) * 1e3:.1f} mm "
                    "(discretisation.element_length_mm)"
                )
        self.samp_link, self.samp_alpha, self.samp_ro, self.samp_wt = contact_samples(
            chain, tb.min_radius_m(), self.clearance, float(solver.contact_bow_fraction)
        )
        if not scene.contact.stiffness_per_length:
            self.samp_wt[:] = 1.0  # the paper's law: k and c_w at every contact point
        self._node_sample = np.ascontiguousarray(
            np.searchsorted(self.samp_link, np.arange(chain.n_nodes - 1)), dtype=np.int64
        )
        self._cum = np.ascontiguousarray(chain.cum, dtype=np.float64)
        # the link that carries the source centre (the capsule)
        self._src_link = int(
            np.clip(np.searchsorted(chain.cum, self.cft, side="right") - 1, 0, chain.n_nodes - 2)
        )
        if self.contact is not None:
            w_lumen = float(np.max(tb.seg_rb - tb.seg_ra))
            w = w_lumen if self.contact.transition_m <= 0 else self.contact.transition_m
            if w > self.contact.max_fraction * self.clearance:
                self.warnings.append(
                    f"contact transition zone {w * 1e3:.3f} mm reduced to "
                    f"{self.contact.max_fraction * self.clearance * 1e3:.4f} mm "
                    f"({self.contact.max_fraction:g} x the clearance {self.clearance * 1e3:.3f} mm)"
                )
        # arrays
        nn = chain.n_nodes
        nd = self.nd
        self.n_nodes = nn
        self.n_all = nd * nn
        self.n_free = nd * (nn - 2)
        self.kl = 3 * nd - 1
        self.r = np.zeros(self.n_all)
        self.B = np.zeros((self.n_all, 3 * self.kl + 1))
        P = self.samp_link.size
        self.samp_s = np.zeros(P)
        self.samp_d_prev = np.zeros(P)
        self.samp_p = np.zeros((P, 3))
        self.samp_d = np.zeros(P)
        self.samp_n = np.zeros((P, 3))
        self.samp_H = np.zeros((P, 3, 3))
        self.samp_z = np.zeros(P)
        self.samp_w = np.zeros(P)
        self.samp_F = np.zeros(P)
        self.samp_dF = np.zeros(P)
        self.energies = np.zeros(8)
        self.node_mass = np.ascontiguousarray(chain.node_mass)
        self.node_rot = np.ascontiguousarray(chain.node_rot)
        self.twist_k = np.ascontiguousarray(chain.twist_k)
        # the kernels' argument groups (solvers/_kernels module docstring): built once, they hold
        # the live arrays above, so those are only ever changed in place, never rebound
        self.links = (
            nd, nn, self.kl, chain.link_len, self.bending.hinge_k, self.twist_k, self.node_mass,
            self.node_rot,
        )  # fmt: skip
        self.chan = (
            tb.h, tb.pos, tb.tan, tb.nor, KAPPA_MIN_FLAT, tb.seg_s, tb.seg_rb, tb.seg_ra,
            tb.seg_flat,
        )  # fmt: skip
        self.samples = (
            self.samp_link, self.samp_alpha, self.samp_ro, self.samp_wt, self.samp_s,
            self.samp_d_prev,
        )  # fmt: skip
        self.swork = (
            self.samp_p, self.samp_d, self.samp_n, self.samp_H, self.samp_z, self.samp_w,
            self.samp_F, self.samp_dF,
        )  # fmt: skip
        self.par = (self.cpar, self.flags, self.g)
        f_ref = float(np.max(self.bending.hinge_k / chain.link_len[1:]))
        self.tol_abs = self.tol * max(f_ref, 1e-2)
        self.max_step = 0.5 * self.clearance

    # -- state helpers ---------------------------------------------------------------------
    def initial_state(self, u: float) -> np.ndarray:
        """Chain laid along the (extended) centreline with the source centre at advance ``u``."""
        q = np.zeros(self.n_all)
        for k in range(self.n_nodes):
            q[self.nd * k : self.nd * k + 3] = self.table.point(u + self.cft - self.chain.cum[k])
        self.set_hints(q)
        return q

    def set_hints(self, q: np.ndarray) -> None:
        """Closest-point hints of every contact sample for state ``q`` (a global search)."""
        work = np.empty(9)
        nd = self.nd
        for i in range(self.samp_link.size):
            j = self.samp_link[i]
            a = self.samp_alpha[i]
            p = (1 - a) * q[nd * j : nd * j + 3] + a * q[nd * (j + 1) : nd * (j + 1) + 3]
            self.samp_s[i] = K.closest_point(
                self.table.h, self.table.pos, self.table.tan, np.ascontiguousarray(p), 0.0, -1.0,
                work,
            )  # fmt: skip

    def prescribe(self, q: np.ndarray, u: float) -> None:
        """Put the two driven proximal nodes on the approach axis for input advance ``u``."""
        for k in (self.n_nodes - 2, self.n_nodes - 1):
            q[self.nd * k : self.nd * k + 3] = self.table.point(u + self.cft - self.chain.cum[k])
            if self.nd == 4:
                q[self.nd * k + 3] = 0.0

    def nodes(self, q: np.ndarray) -> np.ndarray:
        """Node positions (n_nodes, 3)."""
        return q.reshape(self.n_nodes, self.nd)[:, :3].copy()

    def slide(self, q: np.ndarray, du: float) -> np.ndarray:
        """Predictor: every free node slid ``du`` along the channel keeping its offset."""
        x = self.nodes(q)
        hints = np.empty(self.n_nodes)
        # node hints: a sample sits on every node j at alpha = 0
        hints[:-1] = self.samp_s[self._node_sample]
        hints[-1] = hints[-2] - self.chain.link_len[-1]
        out = np.empty_like(x)
        s_out = np.empty(self.n_nodes)
        K.slide_points(self.table.h, self.table.pos, self.table.tan, x, hints, du, out, s_out)
        qn = q.copy()
        qv = qn.reshape(self.n_nodes, self.nd)
        qv[:-2, :3] = out[:-2]
        self.samp_s += du
        return qn

    def predict(self, q: np.ndarray, du: float, u_new: float, slide: bool) -> None:
        """In place: ``slide`` (if True), ``prescribe(q, u_new)``, ``restore_lengths`` in one
        kernel call (the same arithmetic; saves the Python overhead of a load step)."""
        SK.predict(
            q, slide, du, u_new, self.links, self.chan, self.samples, self._cum, self.cft,
            self._node_sample,
        )  # fmt: skip

    def restore_lengths(self, q: np.ndarray) -> None:
        """Put every free node back at its link length from its proximal neighbour (in place).

        Walks from the driven end to the tip: ``x_j = x_{j+1} + l_j (x_j - x_{j+1}) / |...|``.
        A predicted chain whose links are off by nanometres would otherwise carry axial penalty
        forces far above the free cable's buckling load and send Newton astray.
        """
        K.restore_lengths(q, self.nd, self.n_nodes, self.chain.link_len)

    def solve(self, q, q_prev, v_prev, dt, q_ref=None):
        """Run the Newton kernel in place on ``q``; returns (status, iterations, residual)."""
        return SK.newton(
            q, self.n_free, q_prev, v_prev, q_prev if q_ref is None else q_ref, self.links,
            self.chan, self.samples, self.swork, self.par, dt, self.tol_abs, self.max_iter,
            self.max_step, self.r, self.B, self.energies,
        )  # fmt: skip

    def solve_bdf2(self, q, q_n, v_n, hist, coef, h, q_ref, work):
        """One BDF2 step: the Newton kernel against the history combination (``bdf2_history``).

        Parameters
        ----------
        q : (n_all,) float
            Predicted state, solved in place (m; twist rad).
        q_n, v_n : (n_all,) float
            State and velocity at the start of the step (m, m/s).
        hist : tuple
            ``(q, v, contact distances, step)`` before the previous step.
        coef : tuple
            ``(a, b, h_eff)`` from :func:`bdf2_history`.
        h : float
            This step (s).
        q_ref : (n_all,) float
            The predictor (the stabilisation tether's anchor).
        work : (2,) float
            Output when converged: the step's friction and wall-damping work over the actual
            displacement (J; ``_kernels.step_work``).

        Returns
        -------
        status, iterations, residual, q_h
            The kernel's three results and the history state the velocity is taken against
            (``v = (q - q_h) / h_eff``). The friction slip floor and the tether keep their
            per-step values (scaled for ``h_eff`` during the solve and put back);
            ``samp_d_prev`` is left at the start-of-step distances.
        """
        a_h, b_h, h_eff = coef
        q_h = np.empty_like(q_n)
        v_h = np.empty_like(q_n)
        SK.combine(a_h, q_n, b_h, hist[0], q_h)
        SK.combine(a_h, v_n, b_h, hist[1], v_h)
        d_n = self.samp_d_prev.copy()
        SK.combine(a_h, d_n, b_h, hist[2], self.samp_d_prev)
        d_h = self.samp_d_prev.copy()
        i_slip, i_stab = CPAR["slip_min"], CPAR["stabilisation"]
        saved = (self.cpar[i_slip], self.cpar[i_stab])
        self.cpar[i_slip] *= h_eff / h
        self.cpar[i_stab] *= h_eff / h
        st, it, res = self.solve(q, q_h, v_h, h_eff, q_ref)
        if st == 0:
            SK.step_work(
                q, q_n, q_h, self.links, self.samples, self.swork, d_n, d_h, self.par, h_eff, work
            )
        self.cpar[i_slip], self.cpar[i_stab] = saved
        self.samp_d_prev[:] = d_n
        return st, it, res, q_h

    def set_stabilisation(self, coef: float) -> None:
        """Switch the stabilisation (viscosity ``coef`` N s/m per node) on (> 0) or off."""
        self.flags[FLAG["stabilisation"]] = 1 if coef > 0 else 0
        self.cpar[CPAR["stabilisation"]] = coef

    def fallback_stab(self, dt: float) -> float:
        """Fallback viscosity (N s/m): tether stiffness ``FALLBACK_STIFFNESS_FRACTION k_wall``."""
        k = self.contact.stiffness_n_m if self.contact is not None else 1e5
        return FALLBACK_STIFFNESS_FRACTION * k * dt

    def push_force(self) -> float:
        """Axial force the driver applies (N, > 0 pushing), from the residual at driven nodes."""
        t0 = self.table.tan[0]
        nd = self.nd
        f = 0.0
        for k in (self.n_nodes - 2, self.n_nodes - 1):
            f += float(np.dot(self.r[nd * k : nd * k + 3], t0))
        return f

    def source(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Source centre (3,), unit direction to the tip (3,), tip (3,)."""
        x = self.nodes(q)
        cum = self.chain.cum
        j = self._src_link
        e = x[j] - x[j + 1]
        le = np.linalg.norm(e)
        d = e / le
        src = x[j] - (self.cft - cum[j]) * d
        return src, d, x[0].copy()

    def node_contact(self) -> np.ndarray:
        """Normal force magnitude lumped to the nodes (n_nodes,)."""
        out = np.zeros(self.n_nodes)
        SK.lump_to_nodes(self.samp_link, self.samp_alpha, self.samp_F, out)
        return out

    def stored_energy(self) -> float:
        """Elastic + contact + gravity potential energy of the last assembled state (J)."""
        return float(np.sum(self.energies[:5]))

    def kinetic(self, v: np.ndarray) -> float:
        """Kinetic energy (J) for node velocities ``v`` (flat like q)."""
        vv = v.reshape(self.n_nodes, self.nd)
        ke = 0.5 * float(np.sum(self.node_mass[:, None] * vv[:, :3] ** 2))
        if self.nd == 4:
            ke += 0.5 * float(np.sum(self.node_rot * vv[:, 3] ** 2))
        return ke


def initial_equilibrium(model: Model, q: np.ndarray, v: np.ndarray, dt: float) -> tuple[int, int]:
    """Static equilibrium of the starting chain (in place); returns (Newton status, iterations).

    Friction, damping and inertia are off (no history). If the direct solve fails (e.g. gravity
    drops the whole cable onto the wall at once) the chain is walked there by pseudo-time steps:
    each solves with a viscous tether to the previous pseudo-state whose stiffness (10 x the
    heaviest node's weight per clearance) lets a node move about a tenth of the clearance per
    step; every 5 steps a plain solve is tried from the current state.
    """
    flags_saved = model.flags.copy()
    for name in ("inertia", "friction", "wall_damping", "stabilisation"):
        model.flags[FLAG[name]] = 0
    q0 = q.copy()
    st, it, _ = model.solve(q, q.copy(), v, dt)
    if st != 0:
        q[:] = q0
        weight = float(np.max(model.node_mass)) * float(np.linalg.norm(model.g))
        k_tether = 10.0 * max(weight, 1e-4) / model.clearance
        for i in range(300):
            model.set_stabilisation(k_tether)  # with dt = 1: stiffness k_tether per node
            model.solve(q, q.copy(), v, 1.0, q.copy())
            model.set_stabilisation(0.0)
            if i % 5 == 4:
                qs = q.copy()
                st, k, _ = model.solve(q, q.copy(), v, dt)
                it += k
                if st == 0:
                    break
                q[:] = qs
    model.flags[:] = flags_saved
    return st, it


def bdf2_history(h: float, h_old: float | None) -> tuple[float, float, float] | None:
    """Variable-step BDF2 as a backward-Euler step against a modified history.

    BDF2 with steps ``h_old`` (t_{n-1} -> t_n) and ``h`` (t_n -> t_{n+1}), ratio ``w = h / h_old``:
    ``v_{n+1} = (q_{n+1} - q_h) / h_eff`` with ``q_h = a q_n - b q_{n-1}``,
    ``h_eff = h (1 + w) / (1 + 2 w)``, ``a = (1 + w)^2 / (1 + 2 w)``, ``b = w^2 / (1 + 2 w)``
    (``a - b = 1``); equal steps (w = 1): ``q_h = (4 q_n - q_{n-1}) / 3``, ``h_eff = 2 h / 3``.
    The acceleration is the same formula on the velocities (``v_h = a v_n - b v_{n-1}``) and the
    wall-damping velocity on the contact distances, so the backward-Euler Newton kernel called with
    ``(q_prev, v_prev, dt, samp_d_prev) = (q_h, v_h, h_eff, d_h)`` takes a BDF2 step.

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


#: dynamic runs: the input accelerates from rest to motion.speed over this time and decelerates
#: likewise into every stop (a jump to full speed in one time step is an impulse ~ 1/dt)
MOTION_RAMP_S = 0.01


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
    if kind not in ("constant", "stepwise", "retract"):
        raise SceneError(f"motion.kind: {kind!r} is not constant, stepwise or retract")
    backward = kind == "retract" or (kind == "stepwise" and scene.motion.backward)
    if not backward:
        return [(u, uniq[u]) for u in asc]
    desc = asc[::-1]
    return [(u, uniq[u]) for u in desc]


def run(scene, advances_m: np.ndarray, progress: bool = False) -> SimResult:
    """Simulate ``scene`` and report at ``advances_m`` (see module docstring)."""
    model = Model(scene, advances_m)
    dynamic = model.dynamic
    n_req = advances_m.size
    nn = model.n_nodes
    out_src = np.full((n_req, 3), np.nan)
    out_dir = np.full((n_req, 3), np.nan)
    out_tip = np.full((n_req, 3), np.nan)
    out_push = np.full(n_req, np.nan)
    out_contact = np.full((n_req, nn), np.nan)
    out_iters = np.zeros(n_req, dtype=np.int64)
    out_s = np.full(n_req, np.nan)
    out_off = np.full(n_req, np.nan)
    out_nodes = np.full((n_req, nn, 3), np.nan)
    traj = {"advance_m": [], "time_s": [], "nodes_m": [], "push_force_n": []}
    keep_traj = bool(scene.outputs.trajectory)

    t0 = time.perf_counter()
    q = model.initial_state(model.u_start)
    model.prescribe(q, model.u_start)
    v = np.zeros(model.n_all)
    dt0 = model.time_step if dynamic else 1.0
    # initial equilibrium (no history: q_prev = q, static)
    st, it = initial_equilibrium(model, q, v, dt0)
    model.samp_d_prev[:] = model.samp_d
    status = STATUS_SUCCESS if st == 0 else STATUS_FAILED
    message = ""
    total_iters = it
    iters_since = it
    u = model.u_start
    time_s = 0.0
    push = model.push_force()
    e_start = model.stored_energy()
    w_in = w_fr = w_damp = w_stab = 0.0
    ke0 = 0.0
    history_u = [u]
    history_s = [float(model.samp_s[0])]  # the tip's closest arc length (sample 0 is the tip)
    frictionless = (
        model.friction is None and model.damping is None and model.stab == 0 and not dynamic
    )
    inc = model.increment
    n_stabilised = 0
    max_pen = 0.0
    path = waypoints(scene, advances_m, model.u_start)
    bar = None
    if progress:
        from tqdm import tqdm

        total = sum(
            abs(b - a)
            for a, b in zip([u] + [p[0] for p in path[:-1]], [p[0] for p in path], strict=True)
        )
        bar = tqdm(total=round(total * 1e3, 3), unit="mm", desc=scene.name or "simulate")

    def record(idx_list, q_now):
        src, d, tip = model.source(q_now)
        s, off = model.table.closest(src, u)
        contact = model.node_contact()
        nodes = model.nodes(q_now)
        for i in idx_list:
            out_src[i] = src
            out_dir[i] = d
            out_tip[i] = tip
            out_push[i] = push
            out_contact[i] = contact
            out_iters[i] = iters_since
            out_s[i] = s
            out_off[i] = off
            out_nodes[i] = nodes

    if status != STATUS_SUCCESS:
        message = f"initial state did not converge at advance {u * 1e3:.2f} mm"
    stops = stop_points(scene, path, model.u_start)
    t_move = 0.0  # time since the input last started from rest (dynamic)
    # BDF2: (q, v, contact distances, step) before the last accepted (sub-)step; None at the start
    hist = None
    work2 = np.zeros(2)
    for i_path, (target, idx) in enumerate(path if status == STATUS_SUCCESS else []):
        dwell_left = scene.motion.dwell_s if (dynamic and scene.motion.kind == "stepwise") else 0.0
        u_stop = path[stops[i_path]][0]
        while status == STATUS_SUCCESS and (abs(target - u) > 1e-12 or dwell_left > 1e-15):
            # size of this step
            if dynamic:
                remaining = target - u
                if abs(remaining) > 1e-12:
                    du, dt = ramped_step(
                        abs(remaining), abs(u_stop - u), t_move, model.speed, model.time_step
                    )
                    du = float(np.sign(remaining)) * du
                    t_move += dt
                else:
                    du = 0.0
                    dt = min(model.time_step, dwell_left)
            else:
                du = min(max(target - u, -inc), inc)  # np.clip without its per-call cost
                dt = abs(du) / model.speed
            q_prev = q.copy()
            v_prev = v.copy()
            s_saved = model.samp_s.copy()
            dprev_saved = model.samp_d_prev.copy()
            ok = False
            sub = 1
            stab = model.stab
            fallback = False
            while True:
                # try the step in `sub` equal sub-steps (with the stabilisation `stab`)
                q_try = q_prev.copy()
                v_try = v_prev.copy()
                model.samp_s[:] = s_saved
                model.samp_d_prev[:] = dprev_saved
                model.set_stabilisation(stab)
                iters_step = 0
                fr_step = 0.0
                damp_step = 0.0
                stab_step = 0.0
                good = True
                hist_try = hist
                for k in range(sub):
                    qp = q_try.copy()
                    if dynamic:
                        q_try = q_try + (dt / sub) * v_try
                    else:
                        q_try = q_try.copy()
                    model.predict(q_try, du / sub, u + du * (k + 1) / sub, not dynamic)
                    q_ref = q_try.copy()
                    coef = None
                    if model.bdf2:
                        h = dt / sub
                        coef = bdf2_history(h, None if hist_try is None else hist_try[3])
                    if coef is None:
                        st, it, res = model.solve(q_try, qp, v_try, dt / sub, q_ref)
                    else:
                        st, it, res, q_h = model.solve_bdf2(
                            q_try, qp, v_try, hist_try, coef, h, q_ref, work2
                        )
                        h_eff = coef[2]
                    iters_step += it
                    if st != 0:
                        good = False
                        break
                    if model.bdf2:
                        hist_try = (qp, v_try, model.samp_d_prev.copy(), dt / sub)
                    if coef is not None:
                        v_try = (q_try - q_h) / h_eff
                    elif dynamic:
                        v_try = (q_try - qp) / (dt / sub)
                    model.samp_d_prev[:] = model.samp_d
                    pen = SK.max_penetration(model.samp_z, model.samp_w)
                    max_pen = max(max_pen, pen if model.contact is not None else 0.0)
                    if coef is None:
                        fr_step += model.energies[5]
                        damp_step += model.energies[6]
                    else:
                        fr_step += work2[0]
                        damp_step += work2[1]
                    if stab > 0 and not dynamic:
                        dq = (q_try - q_ref).reshape(nn, model.nd)[:, :3]
                        stab_step += stab * float(np.sum(dq**2)) / (dt / sub)
                if good:
                    ok = True
                    break
                total_iters += iters_step
                iters_since += iters_step
                if not fallback and not dynamic and stab == 0.0 and sub >= FALLBACK_AFTER:
                    # snap-through / stall: retry the step with the fallback stabilisation
                    fallback = True
                    stab = model.fallback_stab(dt)
                    sub = 1
                    continue
                if sub >= int(1 / MIN_CUT):
                    break
                sub *= 2
            model.set_stabilisation(model.stab)
            if ok and fallback:
                n_stabilised += 1
            if not ok:
                status = STATUS_FAILED
                message = (
                    f"Newton did not converge at advance {u * 1e3:.3f} mm even with "
                    f"{sub} sub-steps (status {st}, residual {res:.3g} N)"
                )
                q = q_prev
                break
            total_iters += iters_step
            iters_since += iters_step
            # bookkeeping
            push_new = model.push_force()
            # conservative runs: trapezoidal input work (O(du^2)); with dissipation the friction and
            # damping work of a step are evaluated at its end (backward Euler), so is the input
            w_in += (0.5 * (push + push_new) if frictionless else push_new) * du
            w_fr += fr_step
            w_damp += damp_step
            w_stab += stab_step
            push = push_new
            q = q_try
            if dynamic:
                v = v_try
                hist = hist_try
            u = u + du
            time_s += dt
            if du == 0.0:
                dwell_left -= dt
            if bar is not None:
                bar.update(round(abs(du) * 1e3, 3))
            if keep_traj:
                traj["advance_m"].append(u)
                traj["time_s"].append(time_s)
                traj["nodes_m"].append(model.nodes(q))
                traj["push_force_n"].append(push)
            if frictionless and sub == 1 and it <= 6:
                inc = min(2 * inc, JUMP_FACTOR * model.increment)
            elif not frictionless:
                inc = model.increment
            elif sub > 1:
                inc = max(model.increment, inc / sub)
            # jam detection
            if push > scene.solver.jam_force_n:
                status = STATUS_JAMMED
                message = (
                    f"jammed at advance {u * 1e3:.2f} mm: push force {push:.2f} N above "
                    f"solver.jam_force_n = {scene.solver.jam_force_n:g} N"
                )
                break
            if du > 0:
                s_src = float(model.samp_s[0])
                history_u.append(u)
                history_s.append(s_src)
                jl = scene.solver.jam_length_m
                if u - history_u[0] >= jl:
                    k = int(np.searchsorted(history_u, u - jl, side="right") - 1)
                    if s_src - history_s[k] < 0.1 * (u - history_u[k]):
                        status = STATUS_JAMMED
                        message = (
                            f"jammed at advance {u * 1e3:.2f} mm: the tip moved "
                            f"{(s_src - history_s[k]) * 1e3:.2f} mm over the last "
                            f"{(u - history_u[k]) * 1e3:.1f} mm of input"
                        )
                        break
            else:
                history_u = [u]
                history_s = [float(model.samp_s[0])]
        if status != STATUS_SUCCESS:
            break
        if stops[i_path] == i_path:
            t_move = 0.0  # the input stopped here: the next move starts from rest
        record(idx, q)
        iters_since = 0
    if bar is not None:
        bar.close()
    solve_time = time.perf_counter() - t0
    if status == STATUS_SUCCESS:
        message = f"reached all {n_req} requested advances"
    else:
        missing = int(np.sum(np.isnan(out_push)))
        message += f"; {missing} of {n_req} requested advances not reached (NaN rows)"
    if max_pen > 0.1 * model.clearance:
        model.warnings.append(
            f"the instrument sank up to {max_pen * 1e3:.3f} mm into the wall "
            f"({100 * max_pen / model.clearance:.0f} % of the clearance): raise "
            "contact.stiffness_n_m for a tight lumen"
        )
    if n_stabilised:
        model.warnings.append(
            f"{n_stabilised} load step(s) needed the fallback stabilisation (snap-through or "
            f"stall); its work is {w_stab:.3g} J of {w_in:.3g} J input (work['stabilisation'])"
        )
    # work balance
    e_end = model.stored_energy()
    ke = model.kinetic(v) if dynamic else 0.0
    d_el = e_end - e_start
    spent = d_el + w_fr + w_damp + w_stab + (ke - ke0)
    bal = abs(w_in - spent) / max(abs(w_in), 1e-300) if w_in != 0 else 0.0
    work = {
        "input": w_in,
        "elastic": d_el,
        "friction": w_fr,
        "damping": w_damp,
        "stabilisation": w_stab,
        "kinetic": ke - ke0,
        "balance_error": bal,
    }
    settings = {
        "solver": asdict(scene.solver),
        "effects": asdict(scene.effects),
        "n_nodes": nn,
        "n_contact_samples": int(model.samp_link.size),
        "model_length_m": float(model.chain.cum[-1]),
        "dof_per_node": model.nd,
        "clearance_m": model.clearance,
        "time_step_s": model.time_step if dynamic else None,
        "total_newton_iters": int(total_iters),
        "simulated_time_s": time_s,
        "max_penetration_m": max_pen,
        "n_stabilised_steps": n_stabilised,
    }
    trajectory = None
    if keep_traj:
        trajectory = {k: np.asarray(v_) for k, v_ in traj.items()}
    return SimResult(
        status=status,
        message=message,
        advances_mm=m_to_mm(np.asarray(advances_m, dtype=float)),
        source_pos_m=out_src,
        source_dir=out_dir,
        tip_pos_m=out_tip,
        push_force_n=out_push,
        contact_force_n=out_contact,
        newton_iters=out_iters,
        s_m=out_s,
        offset_m=out_off,
        n_elements=model.chain.n_links,
        solve_time_s=solve_time,
        settings=settings,
        warnings=tuple(model.warnings),
        work=work,
        nodes_m=out_nodes,
        trajectory=trajectory,
        max_penetration_m=max_pen,
        provenance=Provenance.now(settings={"scene": scene.name, **settings}),
    )
