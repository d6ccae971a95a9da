"""The assembled problem one run solves: channel table, chain, contact samples, effects, arrays.

:class:`Model` turns a :class:`~ringqa.simulation.scene.Scene` into what the kernels take: the
discretised cable (:mod:`.chain`), the channel table (:mod:`.channel`), the contact sample points,
the effect units the scene calls for (:data:`ringqa.simulation.effects.EFFECTS`, in assembly
order) and their kernel args, and the work arrays. It also answers the questions the solvers and
the recorder ask about a state (source position, push force, stored energy, ...). It holds no
solver logic.
"""

from __future__ import annotations

import numpy as np

from ringqa.errors import SimulationError
from ringqa.simulation import _kernels as K
from ringqa.simulation._cache import ensure_fresh_kernel_cache
from ringqa.simulation.chain import build_chain, contact_samples
from ringqa.simulation.channel import ChannelTable
from ringqa.simulation.effects import EFFECTS, Bending, Contact, Tether
from ringqa.simulation.effects.base import BuildContext, Samples, Step, is_cacheable
from ringqa.simulation.effects.contact import refresh_far
from ringqa.simulation.solvers.newton import (
    ITERATION_LIMIT,
    NO_PROGRESS,
    newton,
    newton_uncached,
)
from ringqa.simulation.solvers.predictor import continuation_scale, predict

#: Load-step predictor: the fraction of the previous step's Newton correction added to the slide
#: (:meth:`Model.predict`). Measured on ring26-flexitron (Newton iterations, line-search halvings):
#: 0 (the plain slide) 643, 233; 0.3: 621, 94; 0.5: 602, 47; 0.6: 610, 49; 1.0: 672, 108 and a
#: stabilised step (the full correction, carried into the ring's entry where the contact set
#: changes from step to step, pushes nodes into the wall: first residuals up to 130 N).
EXTRAPOLATE_FRACTION = 0.5
#: ... and only after a step whose Newton solve converged within this many iterations (a harder
#: step is an event, a contact made or a buckle, whose correction does not carry over): with
#: 0.5, ring26-flexitron 602 -> 573 iterations and the Oncentra example's ring 960 iterations and
#: 6 stabilised steps -> 762 and 2 (plain slide: 815 and 2); 5: 641 and 789, 2; 10: 578 and 772, 1
EXTRAPOLATE_MAX_ITERS = 8
#: ... and only when the step continues the previous one: it starts where that one ended and is
#: as long, to this relative tolerance (:func:`~.solvers.predictor.continuation_scale`). 0 is
#: the exact equality used before 2026-11-29, under which a step ``target - u`` that fell a few
#: ulp short of the increment lost the extrapolation: 6 to 31 steps a run in 13 of the 17
#: quasi-static compare_dwells scenes, 4 and 6 in two of the README job's runs (ring13-push100
#: 318 -> 307 iterations, ring26-flexitron 518 -> 512; dwells moved <= 1.6e-9 m;
#: docs/engine.md "The load-step predictor and round-off")
EXTRAPOLATE_RTOL = 1e-9
#: ... and a step of another length (the last, shorter step into a waypoint) extrapolates
#: ``du / pred_du`` of the correction where that is at most this (0: never). Measured with 1
#: (the shorter steps scaled): 27695 -> 28043 iterations over the runs above and
#: tests/simulation/test_convergence.py's friction scenes, the README job's whole channel at
#: commissioning settings 1751 -> 2078 (with a retry budget of 20 also the Oncentra example's
#: ring +1 stabilised step): not used
EXTRAPOLATE_SCALE_MAX = 0.0
#: the plain-slide retry after an extrapolated start that stalled (:meth:`Model.solve`) gets at
#: most this many Newton iterations (None: ``solver.max_iter``, never more). Measured (2026-11-29,
#: docs/engine.md "Failed steps reach the fallback sooner"; 64 runs traced): the 5 retries after
#: a stall that rescued their step took 6-16 iterations, the 50 that failed 4-47; 20 was shipped
#: for ~1 % of the README job's engine CPU. None since: the retry is the solve the plain slide
#: would have had, so extrapolating (and the rule that decides it) cannot turn a step Newton
#: solves into a stabilised one. With 20 and :data:`EXTRAPOLATE_RTOL` the friction scene of
#: tests/simulation/test_convergence.py at 1 mm lost a 25-iteration rescue at 75 mm (5 -> 7
#: stabilised steps, a dwell 0.11 mm away; docs/engine.md "The load-step predictor and round-off")
PLAIN_RETRY_MAX_ITERS: int | None = None
#: ... and after an extrapolated start that failed the long way (the iteration limit or no
#: progress), at most this many (None: ``solver.max_iter``). The 6 rescues after such a failure
#: took 8-45 iterations (35, 42 and 45 in the tandem-and-ovoids example's ovoid runs), so any
#: budget below 45 changes answers; 12 takes the README job's whole-channel run from 3032 to 2356
#: iterations but turns those 3 rescues into stabilised steps (an ovoid channel 3 -> 6, its
#: dwells moved by up to 0.025 mm, half their numerical error): not the default
PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS: int | None = None


def plain_retry_iters(status: int, max_iter: int) -> int:
    """The plain-slide retry's iteration limit after an extrapolated start failed with Newton
    status ``status``: :data:`PLAIN_RETRY_MAX_ITERS`, or :data:`PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS`
    after the iteration limit or no progress; never more than ``max_iter``."""
    crawled = status in (ITERATION_LIMIT, NO_PROGRESS)
    limit = PLAIN_RETRY_AFTER_CRAWL_MAX_ITERS if crawled else PLAIN_RETRY_MAX_ITERS
    return max_iter if limit is None else min(max_iter, limit)


#: counters of :func:`ringqa.simulation.solvers.newton.newton`
N_COUNTERS = 4

#: channel tables of the channels simulated last, by ``id`` (with the channel itself, so that an
#: id is not reused while its entry lives): the commissioning run, its refined run, the probes
#: and a benchmark's repeats simulate the same channel object, and sampling its centreline and
#: lumen (:meth:`ChannelTable.from_channel`) took ~1.5 ms of each ``simulate()`` outside the solve
_TABLES: dict[int, tuple[object, ChannelTable]] = {}
#: entries kept in :data:`_TABLES`
TABLES_KEPT = 8


def channel_table(channel) -> ChannelTable:
    """:meth:`ChannelTable.from_channel` of ``channel``, once per channel object while it is
    among the last :data:`TABLES_KEPT` (only frozen dataclass channels, e.g.
    :class:`ringqa.geometry.Channel`, are kept: their fields cannot be rebound). The kernels only
    read the table."""
    import dataclasses

    params = getattr(channel, "__dataclass_params__", None)
    if not (dataclasses.is_dataclass(channel) and params is not None and params.frozen):
        return ChannelTable.from_channel(channel)
    key = id(channel)
    hit = _TABLES.pop(key, None)
    if hit is not None and hit[0] is channel:
        _TABLES[key] = hit  # most recent last
        return hit[1]
    table = ChannelTable.from_channel(channel)
    _TABLES[key] = (channel, table)
    while len(_TABLES) > TABLES_KEPT:
        _TABLES.pop(next(iter(_TABLES)))
    return table


class Model:
    """The assembled problem (see module docstring).

    Parameters
    ----------
    scene : ringqa.simulation.scene.Scene
    advances_m : (n,) float
        Requested advances (m): the model is long enough for the deepest.

    Attributes
    ----------
    units : tuple of Effect
        The effect units assembled, in assembly order.
    effects : tuple
        Their kernel args (what :func:`~ringqa.simulation.solvers.newton.newton` takes).
    static_effects : tuple
        The same with the history effects (friction, wall damping, inertia) suspended and the
        tether off: the initial static equilibrium.
    samples : Samples
        The contact sample points and their last results.
    d_prev : (P,) float64
        The samples' wall distances at the start of the current step (m).
    nd, n_nodes, n_all, n_free, kl : int
        Coordinates per node, nodes, state size, unknowns, Jacobian half-bandwidth.
    """

    def __init__(self, scene, advances_m: np.ndarray) -> None:
        ensure_fresh_kernel_cache()
        self.scene = scene
        self.warnings: list[str] = []
        solver = scene.solver
        self.dynamic = solver.kind == "dynamic"
        if solver.integrator == "bdf2" and not self.dynamic:
            self.warnings.append(
                "solver.integrator = 'bdf2' applies to the dynamic solver only: ignored by the "
                "quasi-static load steps"
            )
        self.table = channel_table(getattr(scene, "simulated_channel", scene.channel))
        inst = scene.instrument
        # the scene's values were validated where it was built (scene.py / scene_keys.py)
        self.cft = float(inst.centre_from_tip_m)
        self.speed = float(scene.motion.speed_m_s)
        self.increment = float(solver.increment_m)
        self.time_step = float(solver.time_step_s)
        self.tol = float(solver.tol)
        self.max_iter = int(solver.max_iter)
        self.stab = float(solver.stabilisation)
        approach = float(solver.approach_m)
        m = scene.motion
        self.u_start = (-self.cft) if m.start_m is None else float(m.start_m)
        u_deep = max(float(np.max(advances_m)), self.u_start)
        self.chain = chain = self._chain(inst, u_deep, approach)
        self.nd = nd = 4 if scene.effects.torsion else 3
        self.clearance = self._clearance(chain)
        self.max_radius = float(np.max(chain.link_ro))
        self._check_bends(chain, u_deep)
        link, alpha, ro, wt = contact_samples(
            chain, self.table.min_radius_m(), self.clearance, float(solver.contact_bow_fraction)
        )
        if not scene.contact.stiffness_per_length:
            wt[:] = 1.0  # the paper's law: k and c_w at every contact point
        self.samples = Samples.empty(link, alpha, ro, wt)
        P = link.size
        self.d_prev = np.zeros(P)
        self._node_sample = np.ascontiguousarray(
            np.searchsorted(link, np.arange(chain.n_nodes - 1)), dtype=np.int64
        )
        self._cum = np.ascontiguousarray(chain.cum, dtype=np.float64)
        # the link that carries the source centre (the capsule)
        self._src_link = int(
            np.clip(np.searchsorted(chain.cum, self.cft, side="right") - 1, 0, chain.n_nodes - 2)
        )
        # the effects the scene calls for, in assembly order
        ctx = BuildContext(scene, chain, self.table, self.dynamic, nd, self.clearance)
        units = []
        for cls in EFFECTS:
            unit = cls.build(ctx)
            if unit is not None:
                units.append(unit)
        self.warnings.extend(ctx.warnings)
        self.units = tuple(units)
        self.effects = tuple(u.args() for u in units)
        #: Newton for these effects (disk-cached unless an effect comes from outside ringqa)
        self.newton = newton if is_cacheable(self.effects) else newton_uncached
        self._newton_call = self.newton
        self._predict_call = predict
        self.static_effects = tuple(
            u.with_coef(0.0) if isinstance(u, Tether) else u.suspended_args() for u in units
        )
        self._tether = next(i for i, u in enumerate(units) if isinstance(u, Tether))
        self.contact_on = any(isinstance(u, Contact) for u in units)
        self.names = tuple(u.name for u in units)
        #: wall damping reads the distance history, which skipped far samples would leave
        #: stale: refresh them after every solved step (:meth:`refresh_far`)
        self._refresh_far = (
            self.contact_on
            and self.unit("contact").skip_far
            and "wall_damping" in self.names
            and self.unit("wall_damping").c_w != 0.0
        )
        self._contact_args = self.unit("contact").args() if self.contact_on else None
        #: the effects with the friction Jacobian's falling branch floored (None: no friction)
        self.monotone_effects = (
            self.effects_with(friction=self.unit("friction").monotone_args())
            if "friction" in self.names and self.dynamic
            else None
        )
        self._stored = [i for i, u in enumerate(units) if u.energy == "stored"]
        self._work = {u.name: i for i, u in enumerate(units) if u.energy == "dissipated"}
        # arrays
        nn = chain.n_nodes
        self.n_nodes = nn
        self.n_all = nd * nn
        self.n_free = nd * (nn - 2)
        self.kl = 3 * nd - 1
        self.r = np.zeros(self.n_all)
        self.B = np.zeros((self.n_all, 3 * self.kl + 1))
        self.energies = np.zeros(len(units))
        self.counters = np.zeros(N_COUNTERS, dtype=np.int64)
        self.node_mass = np.ascontiguousarray(chain.node_mass)
        self.node_rot = np.ascontiguousarray(chain.node_rot)
        self._chan = self.table.args()
        bending = next(u for u in units if isinstance(u, Bending))
        f_ref = float(np.max(bending.hinge_k / chain.link_len[1:]))
        self.tol_abs = self.tol * max(f_ref, 1e-2)
        self.max_step = 0.5 * self.clearance
        #: load-step predictor: extrapolate the previous step's correction (:meth:`predict`)
        self.extrapolate = EXTRAPOLATE_FRACTION > 0 and self.stab == 0.0 and not self.dynamic
        self._pred_plain = np.zeros(self.n_all)
        self._pred_du = np.nan
        self._pred_u = np.nan
        self._pred_hints = np.zeros(self.samples.s.size)
        self._extrapolated = False

    # -- construction helpers ------------------------------------------------------------
    def _chain(self, inst, u_deep: float, approach: float):
        """The chain: the deepest tip position + the approach, extended so that the two driven
        proximal nodes always stay on the straight extension before the entry (s <= 0)."""
        need = u_deep + self.cft + approach
        chain = build_chain(inst, min(need, inst.length_m))
        if chain.cum[-2] < u_deep + self.cft:
            chain = build_chain(inst, min(need + chain.link_len[-1], inst.length_m))
        if chain.cum[-2] < u_deep + self.cft - 1e-9:
            raise SimulationError(
                f"instrument {inst.name!r}: too short to reach advance {u_deep * 1e3:.1f} mm"
            )
        return chain

    def _clearance(self, chain) -> float:
        """Smallest clearance r_b - r_o (m); refuses an instrument that does not fit."""
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
        return rb_min - ro_max

    def _check_bends(self, chain, u_deep: float) -> None:
        """Warn where a straight link cannot fit a bend at all: its bow ``l^2 / (8 R)`` exceeds
        the lumen's width 2c (each section against the tightest bend it can reach)."""
        rb_min = float(np.min(self.table.seg_rb))
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

    # -- effects -------------------------------------------------------------------------
    def effects_with(self, base: tuple | None = None, **args) -> tuple:
        """The effects' args (``base``, default :attr:`effects`) with some units' args replaced,
        by unit name: ``model.effects_with(gravity=GravityArgs(mass, g))``."""
        out = list(self.effects if base is None else base)
        for name, a in args.items():
            if name not in self.names:
                raise KeyError(f"effect {name!r} is not assembled in this model ({self.names})")
            out[self.names.index(name)] = a
        return tuple(out)

    def with_tether(self, coef: float, base: tuple | None = None) -> tuple:
        """The effects' args with the stabilisation tether's coefficient set to ``coef``."""
        return self.effects_with(base, tether=self.units[self._tether].with_coef(coef))

    def unit(self, name: str):
        """The assembled effect unit called ``name``."""
        return self.units[self.names.index(name)]

    def refresh_far(self, q: np.ndarray) -> None:
        """Bring the far contact samples' distances up to date at the solved state ``q``
        (:func:`ringqa.simulation.effects.contact.refresh_far`; only with wall damping)."""
        if self._refresh_far:
            refresh_far(self._contact_args, q, self.nd, self.samples)

    def work_of(self, name: str) -> float:
        """The last assembly's step work (J) of a dissipative effect (0 if not assembled)."""
        i = self._work.get(name)
        return 0.0 if i is None else float(self.energies[i])

    # -- the Newton solve ----------------------------------------------------------------
    def step(
        self, q_hist, v_hist, dt, q_ref=None, q_start=None, d_hist=None, floor_scale=1.0
    ) -> Step:
        """The :class:`Step` for a solve: history ``q_hist``, ``v_hist`` (and ``d_hist``, default
        the start-of-step distances ``d_prev``), kernel step ``dt`` (s), tether anchor ``q_ref``
        (default ``q_hist``), start of the step ``q_start`` (default ``q_hist``)."""
        return Step(
            self.nd,
            self.n_nodes,
            self.kl,
            q_hist,
            v_hist,
            q_hist if q_start is None else q_start,
            q_hist if q_ref is None else q_ref,
            self.d_prev if d_hist is None else d_hist,
            self.d_prev,
            float(dt),
            float(floor_scale),
        )

    def solve(self, effects, q: np.ndarray, st: Step) -> tuple[int, int, float]:
        """Newton in place on ``q``; returns (status, iterations, residual (N))."""
        out = self._newton_call(
            effects, q, st, self.samples, self.n_free, self.tol_abs, self.max_iter,
            self.max_step, self.r, self.B, self.energies, self.counters,
        )  # fmt: skip
        if out[0] != 0 and self._extrapolated:
            # the extrapolated start failed: try the plain slide before the step is retried
            # (with the fallback stabilisation), with fewer iterations (plain_retry_iters)
            q[:] = self._pred_plain
            self.samples.s[:] = self._pred_hints
            again = self._newton_call(
                effects, q, st, self.samples, self.n_free, self.tol_abs,
                plain_retry_iters(out[0], self.max_iter), self.max_step, self.r, self.B,
                self.energies, self.counters,
            )  # fmt: skip
            out = (again[0], out[1] + again[1], again[2])
        self._extrapolated = False
        if out[0] != 0 or out[1] > EXTRAPOLATE_MAX_ITERS:
            self._pred_u = np.nan  # a hard step: the next one starts from the plain slide
        return out

    def bind_compiled_newton(self, q: np.ndarray) -> None:
        """Call Newton's compiled entry point for this model's argument types directly.

        numba's dispatcher finds the specialisation from the argument types on every call, which
        for the named tuples of effects, step and samples costs ~6 us, more than a cheap load step
        (the entry point itself ~1 us). The types do not change during a run (the effects' args
        only change values), so the specialisation is looked up once, after compiling it.
        """
        st = self.step(q.copy(), np.zeros_like(q), 1.0)
        args = (self.effects, q, st, self.samples, self.n_free, self.tol_abs, 0, self.max_step,
                self.r, self.B, self.energies, self.counters)  # fmt: skip
        try:
            types = tuple(self.newton.typeof_pyval(a) for a in args)
            entry = self.newton.overloads[types].entry_point
        except (KeyError, AttributeError):  # pragma: no cover - other numba versions
            return
        self._newton_call = entry

    def bind_compiled_predict(self, q: np.ndarray) -> None:
        """Call the predictor kernel's compiled entry point directly (as
        :meth:`bind_compiled_newton`: the channel's named tuple made the dispatcher's type
        lookup cost several microseconds per load step)."""
        args = (q, True, 0.0, 0.0, self.nd, self.n_nodes, self.chain.link_len, self._chan,
                self.samples.s, self._cum, self.cft, self._node_sample)  # fmt: skip
        try:
            types = tuple(predict.typeof_pyval(a) for a in args)
            self._predict_call = predict.overloads[types].entry_point
        except (KeyError, AttributeError):  # pragma: no cover - not compiled / other numba
            self._predict_call = predict

    # -- states --------------------------------------------------------------------------
    def initial_state(self, u: float) -> np.ndarray:
        """Chain laid along the (extended) centreline with the source centre at advance ``u``."""
        q = np.zeros(self.n_all)
        tb = self.table
        K.chain_on_centreline(tb.h, tb.pos, tb.tan, u + self.cft - self._cum, self.nd, q)
        self.set_hints(q)
        return q

    def set_hints(self, q: np.ndarray) -> None:
        """Closest-point hints of every contact sample for state ``q`` (a global search)."""
        sw = self.samples
        tb = self.table
        K.sample_hints(tb.h, tb.pos, tb.tan, q, self.nd, sw.link, sw.alpha, sw.s)

    def prescribe(self, q: np.ndarray, u: float) -> None:
        """Put the two driven proximal nodes on the approach axis for input advance ``u``."""
        for k in (self.n_nodes - 2, self.n_nodes - 1):
            q[self.nd * k : self.nd * k + 3] = self.table.point(u + self.cft - self.chain.cum[k])
            if self.nd == 4:
                q[self.nd * k + 3] = 0.0

    def predict(self, q: np.ndarray, du: float, u_new: float, slide: bool) -> None:
        """In place: slide the free nodes ``du`` along the channel (if ``slide``), put the driven
        nodes at input advance ``u_new``, restore the link lengths (one kernel call).

        Quasi-static forward load steps without an always-on tether also extrapolate (retraction
        reverses the friction and stays with the plain slide): when this step
        continues the previous one (the same ``du`` to :data:`EXTRAPOLATE_RTOL`, so that a step
        round-off short of the increment still continues it; it starts where that one ended:
        :func:`~.solvers.predictor.continuation_scale`, the compiled loop's rule too)
        :data:`EXTRAPOLATE_FRACTION` of the previous step's Newton correction (its solution minus
        its plain slide prediction) is added and the link lengths restored. A retried or cut step
        does not continue the previous one: it starts from the plain slide; so does a solve from an
        extrapolated start that fails (:meth:`solve` tries the plain slide before it returns).
        """
        scale = (
            continuation_scale.py_func(
                du, u_new, self._pred_du, self._pred_u, EXTRAPOLATE_RTOL, EXTRAPOLATE_SCALE_MAX
            )
            if slide and du > 0.0 and self.extrapolate
            else 0.0
        )
        ext = scale > 0.0
        if ext:
            corr = q - self._pred_plain
        self._predict_call(
            q, bool(slide), float(du), float(u_new), self.nd, self.n_nodes, self.chain.link_len,
            self._chan, self.samples.s, self._cum, self.cft, self._node_sample,
        )  # fmt: skip
        if slide and self.extrapolate:
            self._pred_plain[:] = q
            self._pred_du = du
            self._pred_u = u_new
            self._extrapolated = ext
            if ext:
                self._pred_hints[:] = self.samples.s
                q += (EXTRAPOLATE_FRACTION * scale) * corr
                K.restore_lengths(q, self.nd, self.n_nodes, self.chain.link_len)

    def nodes(self, q: np.ndarray) -> np.ndarray:
        """Node positions (n_nodes, 3)."""
        return q.reshape(self.n_nodes, self.nd)[:, :3].copy()

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

    def stored_energy(self) -> float:
        """Elastic + contact + gravity potential energy of the last assembled state (J)."""
        return float(sum(self.energies[i] for i in self._stored))

    def kinetic(self, v: np.ndarray) -> float:
        """Kinetic energy (J) for node velocities ``v`` (flat like q)."""
        vv = v.reshape(self.n_nodes, self.nd)
        ke = 0.5 * float(np.sum(self.node_mass[:, None] * vv[:, :3] ** 2))
        if self.nd == 4:
            ke += 0.5 * float(np.sum(self.node_rot * vv[:, 3] ** 2))
        return ke

    @property
    def wall_stiffness_n_m(self) -> float:
        """The contact's wall stiffness k (N/m; 1e5 when contact is off)."""
        contact = next((u for u in self.units if isinstance(u, Contact)), None)
        return contact.stiffness_n_m if contact is not None else 1e5
