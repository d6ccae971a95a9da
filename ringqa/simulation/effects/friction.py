"""Friction: Coulomb or Stribeck (the paper's Armstrong / Canudas de Wit form), regularised.

``mu(v) = sqrt(2e) (mu_s - mu_k) exp(-x^2) x + mu_k tanh(v / v_reg)``, x = v / (v_brk sqrt 2)
(Stribeck; Coulomb drops the first term), v_reg = v_brk / 10 unless
``contact.friction_v_reg_m_s`` is set. Quasi-statically the contact velocity is the tangential slip
over the load step divided by the step's time ``increment / motion.speed`` (an incremental slip
law: a node that slips less than ~ v_reg dt per step is sticking); dynamically it is the
integrator's velocity (backward Euler or BDF2). v_reg is floored at
``contact.friction_slip_min_m / dt`` (0.1 um of slip per step; BDF2 keeps it at the step dt, not
its kernel step 2 dt / 3) so that cutting a step does not sharpen the law without bound
(dynamically this is inactive at the default 1 ms step: 0.1 um / 1 ms = v_brk / 10).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.simulation.band import add_block, badd
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels

#: friction law codes of :class:`FrictionArgs`
LAWS = {"none": 0, "coulomb": 1, "stribeck": 2}


class FrictionArgs(NamedTuple):
    """Kernel parameters of the friction law (SI).

    Attributes
    ----------
    law : int
        1 Coulomb, 2 Stribeck (:data:`LAWS`).
    mu_s, mu_k : float
        Static (Stribeck peak) and kinetic coefficients.
    v_brk : float
        Breakaway velocity (m/s).
    v_reg : float
        Regularisation velocity of the tanh (m/s).
    slip_min : float
        Smallest slip per step the regularisation acts over (m).
    torsion : bool
        The chain carries twist DOFs (4 per node): friction loads them.
    active : bool
        False suspends friction (the initial static equilibrium).
    monotone : bool
        Jacobian only: the friction tangent along the slip is floored at zero (the falling
        branch of the Stribeck law, ``d mu / dv < 0``, is given a zero slope). The residual, and
        so the converged answer, is unchanged. Used on the pause steps of dynamic stepwise
        motion (:mod:`ringqa.simulation.solvers.stepper`).
    """

    law: int
    mu_s: float
    mu_k: float
    v_brk: float
    v_reg: float
    slip_min: float
    torsion: bool
    active: bool
    monotone: bool = False


@njit(cache=True, error_model="numpy")
def friction_phi(v, law, mu_s, mu_k, v_brk, v_reg):
    """``phi(v) = mu(v) / v`` and ``psi(v) = phi'(v) / v`` of the friction law (both smooth).

    law 1 (Coulomb): mu = mu_k tanh(v / v_reg);
    law 2 (Stribeck, the paper's form):
    mu = sqrt(2e) (mu_s - mu_k) exp(-x^2) x + mu_k tanh(v / v_reg), x = v / (v_brk sqrt 2);
    it peaks near mu_s at v = v_brk.
    """
    y = v / v_reg
    if y < 1e-3:
        y2 = y * y
        th_over = (1.0 - y2 / 3.0) / v_reg  # tanh(y)/v
        dpsi = (-2.0 / 3.0 + 0.4 * y2) / (v_reg * v_reg * v_reg)
    else:
        t = math.tanh(y)
        th_over = t / v
        sech2 = 1.0 - t * t
        dpsi = (y * sech2 - t) / (y * y * y) / (v_reg * v_reg * v_reg)
    phi = mu_k * th_over
    psi = mu_k * dpsi
    if law == 2:
        C = math.sqrt(2.0 * math.e) * (mu_s - mu_k) / (v_brk * math.sqrt(2.0))
        ex = math.exp(-v * v / (2.0 * v_brk * v_brk))
        phi += C * ex
        psi += -C * ex / (v_brk * v_brk)
    return phi, psi


@njit(cache=True, inline="always", error_model="numpy")
def twist_slip_direction(q, nd, j, n, tau):
    """``tau = t x n`` (in place): the direction in which a twist of link ``j`` slides its surface.

    ``t`` is the unit axis of link ``j`` (node ``j`` to ``j + 1``, positions in ``q`` with ``nd``
    coordinates per node), ``n`` (3,) the wall normal at the contact sample. A twist ``dphi`` moves
    the cable surface at radius r_o by ``r_o dphi tau``; the friction moment is ``r_o tau . F_t``.
    """
    t0 = q[nd * (j + 1)] - q[nd * j]
    t1 = q[nd * (j + 1) + 1] - q[nd * j + 1]
    t2 = q[nd * (j + 1) + 2] - q[nd * j + 2]
    tl = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    t0 /= tl
    t1 /= tl
    t2 /= tl
    tau[0] = t1 * n[2] - t2 * n[1]
    tau[1] = t2 * n[0] - t0 * n[2]
    tau[2] = t0 * n[1] - t1 * n[0]


@njit(cache=True, inline="always", error_model="numpy")
def add_friction(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: call :func:`friction_kernel` (if active) with the
    regularisation velocity ``max(v_reg, slip_min / h)``, h the actual step
    (``st.dt / st.floor_scale``), so cutting a step never sharpens the law below ``slip_min``."""
    if not p.active:
        return 0.0
    dt = st.dt
    v_reg = max(p.v_reg, p.slip_min * st.floor_scale / dt)
    return friction_kernel(
        q, st.q_hist, st.q_start, st.nd, st.kl, sw.link, sw.alpha, sw.ro, sw.p, sw.n, sw.H,
        sw.F, sw.dF, -p.law if p.monotone else p.law, p.mu_s, p.mu_k, p.v_brk, v_reg, dt,
        p.torsion, r, B, jac,
    )  # fmt: skip


@njit(cache=True, error_model="numpy")
def friction_kernel(
    q, q_prev, q_start, nd, kl, samp_link, samp_alpha, samp_ro, samp_p, samp_n, samp_H, samp_F,
    samp_dF, law, mu_s, mu_k, v_brk, v_reg, dt, torsion, r, B, jac,
):  # fmt: skip
    """Regularised friction at each contact sample: F_t = -F_n mu(|v|) v / |v|.

    The contact velocity is the tangential slip from the history ``q_prev`` divided by dt (the
    quasi-static incremental law; dt = increment / input speed), plus ``r_o dphi/dt (t x n)``
    with torsion; the friction moment about the link axis ``r_o (n x F_t) . t`` loads the twist
    DOFs. Jacobian exact except for the rotation of n and t within the step. Returns the
    dissipated work over the step (J, >= 0), taken over the step's actual slip (from
    ``q_start``; with backward Euler that is the slip the velocity comes from).

    ``law`` is 1 (Coulomb) or 2 (Stribeck); negative (-1, -2) the same law with the Jacobian's
    slope along the slip floored at zero (:attr:`FrictionArgs.monotone`; the signature stays the
    one ``ringqa warmup`` precompiles).
    """
    monotone = law < 0
    law = abs(law)
    work = 0.0
    A = np.empty((3, 3))
    K = np.empty((3, 3))
    P = np.empty((3, 3))
    wv = np.empty(3)
    ws = np.empty(3)
    v = np.empty(3)
    tau = np.empty(3)
    Ft = np.empty(3)
    Ktau = np.empty(3)
    for i in range(samp_link.shape[0]):
        F = samp_F[i]
        if F == 0.0:
            continue
        j = samp_link[i]
        al = samp_alpha[i]
        w0 = 1.0 - al
        w1 = al
        n = samp_n[i]
        wn = 0.0
        for a in range(3):
            pp = w0 * q_prev[nd * j + a] + w1 * q_prev[nd * (j + 1) + a]
            wv[a] = samp_p[i, a] - pp
            wn += wv[a] * n[a]
        for a in range(3):
            wv[a] -= wn * n[a]
        # the same tangential slip from the start of the step, for the work
        wsn = 0.0
        for a in range(3):
            pp = w0 * q_start[nd * j + a] + w1 * q_start[nd * (j + 1) + a]
            ws[a] = samp_p[i, a] - pp
            wsn += ws[a] * n[a]
        for a in range(3):
            ws[a] -= wsn * n[a]
        ro = samp_ro[i]
        if torsion:
            twist_slip_direction(q, nd, j, n, tau)
            dphi = w0 * (q[nd * j + 3] - q_prev[nd * j + 3]) + w1 * (
                q[nd * (j + 1) + 3] - q_prev[nd * (j + 1) + 3]
            )
            dphs = w0 * (q[nd * j + 3] - q_start[nd * j + 3]) + w1 * (
                q[nd * (j + 1) + 3] - q_start[nd * (j + 1) + 3]
            )
            for a in range(3):
                wv[a] += ro * dphi * tau[a]
                ws[a] += ro * dphs * tau[a]
        vm = 0.0
        for a in range(3):
            v[a] = wv[a] / dt
            vm += v[a] * v[a]
        vm = math.sqrt(vm)
        phi, psi = friction_phi(vm, law, mu_s, mu_k, v_brk, v_reg)
        for a in range(3):
            Ft[a] = -F * phi * v[a]
            work -= Ft[a] * ws[a]
        for a in range(3):
            r[nd * j + a] -= w0 * Ft[a]
            r[nd * (j + 1) + a] -= w1 * Ft[a]
        mt = 0.0
        if torsion:
            for a in range(3):
                mt += ro * tau[a] * Ft[a]
            r[nd * j + 3] -= w0 * mt
            r[nd * (j + 1) + 3] -= w1 * mt
        if not jac:
            continue
        if monotone and phi + psi * vm * vm < 0.0:
            # the law's slope along the slip, d mu / dv = phi + psi v^2, is negative (Stribeck's
            # falling branch): give the Jacobian a zero slope there instead
            psi = -phi / (vm * vm)
        # A = F (phi I + psi v v^T) / dt ;  d(-Ft)/dp = A P + phi v (dF n)^T, where
        # P = d(w_t)/dp = I - n n^T - n (H w)^T - (n.w) H  (H = dn/dp, the distance Hessian)
        Hd = samp_H[i]
        for a in range(3):
            hw = 0.0
            for c in range(3):
                hw += Hd[a, c] * (wv[c] + wn * n[c])
            for b in range(3):
                A[a, b] = F * ((phi if a == b else 0.0) + psi * v[a] * v[b]) / dt
        for a in range(3):
            for b in range(3):
                hwb = 0.0
                for c in range(3):
                    hwb += Hd[b, c] * (wv[c] + wn * n[c])
                P[a, b] = (1.0 if a == b else 0.0) - n[a] * n[b] - n[a] * hwb - wn * Hd[a, b]
        for a in range(3):
            for b in range(3):
                acc = 0.0
                for c in range(3):
                    acc += A[a, c] * P[c, b]
                K[a, b] = acc + phi * v[a] * samp_dF[i] * n[b]
        add_block(B, kl, nd, j, j, w0 * w0, K)
        add_block(B, kl, nd, j, j + 1, w0 * w1, K)
        add_block(B, kl, nd, j + 1, j, w0 * w1, K)
        add_block(B, kl, nd, j + 1, j + 1, w1 * w1, K)
        if torsion:
            # d(-Ft)/dphi_sample = A ro tau ; d(-m)/dp = ro tau^T K ; d(-m)/dphi = ro tau^T A ro tau
            for a in range(3):
                acc = 0.0
                for c in range(3):
                    acc += A[a, c] * tau[c]
                Ktau[a] = ro * acc
            kpp = 0.0
            for a in range(3):
                kpp += ro * tau[a] * Ktau[a]
            nodes = (j, j + 1)
            wts = (w0, w1)
            for x in range(2):
                for y in range(2):
                    ni = nodes[x]
                    nj = nodes[y]
                    ww = wts[x] * wts[y]
                    for a in range(3):
                        # position row, phi column
                        badd(B, kl, nd * ni + a, nd * nj + 3, ww * Ktau[a])
                        # phi row, position column
                        acc = 0.0
                        for c in range(3):
                            acc += ro * tau[c] * K[c, a]
                        badd(B, kl, nd * ni + 3, nd * nj + a, ww * acc)
                    badd(B, kl, nd * ni + 3, nd * nj + 3, ww * kpp)
    return work


register_kernels(FrictionArgs, add=add_friction)


@dataclass(frozen=True)
class Friction(Effect):
    """Friction law code (1 Coulomb, 2 Stribeck) and its coefficients (SI)."""

    name = "friction"
    energy = "dissipated"
    history = True

    law: int
    mu_s: float
    mu_k: float
    v_brk: float
    v_reg: float
    slip_min: float
    torsion: bool = False

    @classmethod
    def build(cls, ctx: BuildContext) -> Friction | None:
        """Reads ``effects.friction`` and ``contact.*``; None when friction is off (or contact
        is: then with a warning)."""
        eff = ctx.scene.effects
        if not eff.contact:
            if eff.friction != "none":
                ctx.warnings.append("friction needs contact: effects.friction ignored")
            return None
        law = LAWS[eff.friction]
        if law == 0:
            return None
        c = ctx.scene.contact
        v_brk = float(c.v_brk_m_s)
        v_reg = v_brk / 10.0 if c.friction_v_reg_m_s is None else float(c.friction_v_reg_m_s)
        return cls(law, float(c.mu_s), float(c.mu_k), v_brk, v_reg, float(c.friction_slip_min_m),
                   ctx.nd == 4)  # fmt: skip

    def args(self) -> FrictionArgs:
        return FrictionArgs(
            self.law, self.mu_s, self.mu_k, self.v_brk, self.v_reg, self.slip_min, self.torsion,
            True,
        )  # fmt: skip

    def suspended_args(self) -> FrictionArgs:
        return self.args()._replace(active=False)

    def monotone_args(self) -> FrictionArgs:
        """The args with the Jacobian's falling-branch slope floored at zero (``monotone``)."""
        return self.args()._replace(monotone=True)
