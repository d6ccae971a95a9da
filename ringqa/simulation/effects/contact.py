"""Wall contact: the three-region Khatait law at sample points along the links.

With a = r_a - r_o, b = r_b - r_o, w = b - a and z = (d - a) / w (d: the sample's distance from
the centreline, or its equivalent for a flat side): F_n = 0 (z <= 0), k w z^2 / 2 (0 < z <= 1),
k w (z - 1/2) (z > 1); C1-continuous. The transition width is capped at
``contact.transition_max_fraction`` of the clearance b, so a tight lumen (clearance 0.05 mm) keeps
a proportionate zone (a warning says so). Links are sampled (see
:func:`ringqa.simulation.chain.contact_samples`) so no link cuts through the wall.

Two kernels: :func:`prepare_contact` finds every sample's closest centreline point, wall distance,
normal, Hessian and elastic force (wall damping then adds to the force, :mod:`.wall_damping`);
:func:`add_contact` applies the final normal forces to the nodes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.simulation._kernels import closest_point, normal_at, normal_rate
from ringqa.simulation.band import add_block
from ringqa.simulation.channel import ChannelArgs
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class ContactArgs(NamedTuple):
    """Kernel parameters of the wall contact (SI).

    Attributes
    ----------
    chan : ChannelArgs
        The channel table and lumen segments.
    transition : float
        Transition width r_b - r_a (m); <= 0: from the lumen.
    max_frac : float
        The transition width is at most this fraction of the clearance.
    k_wall : float
        Wall stiffness k (N/m) per contact sample of weight 1.
    skip_far : bool
        Skip the closest-point search of samples that cannot have reached the wall since their
        last exact evaluation (:data:`FAR_SAFETY`); with wall damping the model refreshes their
        distances after every solved step (:func:`refresh_far`).
    """

    chan: ChannelArgs
    transition: float
    max_frac: float
    k_wall: float
    skip_far: bool


#: :func:`contact_geometry` modes: skip the far samples / evaluate only them (0: every sample)
SKIP_FAR = 1
ONLY_FAR = 2
#: lumen changes (a step in r_b, the start of a flat side) are tapered over this length (m)
LUMEN_RAMP_M = 1.0e-3
#: the U-shaped lumen's corners (circle meets flat) are rounded over this fraction of the clearance
CORNER_FRACTION = 0.05
#: a sample out of contact by the gap g (m) at its last exact evaluation is skipped while it has
#: moved less than g / FAR_SAFETY since: its distance to the wall changes at most
#: (1 + lumen taper slope x ds/dp) times as fast as the sample moves (module docstring)
FAR_SAFETY = 2.0


@njit(cache=True, error_model="numpy")
def _seg_params(seg_rb, seg_ra, seg_flat, g, ro):
    rb = seg_rb[g]
    flat = seg_flat[g]
    if not flat < rb:
        flat = rb + 0.5 * (rb - ro)  # a flat side too far out to matter (a circle)
    return rb, seg_ra[g], flat


@njit(cache=True, error_model="numpy")
def _lumen_at(seg_s, seg_rb, seg_ra, seg_flat, g, s, ro):
    """(r_b, r_a, flat) at arc length s in segment g, tapered linearly over LUMEN_RAMP_M
    around each break (real channels have no infinitely sharp steps; a sharp one makes the wall
    distance jump and Newton cycle). Circular segments return flat = +inf unless tapering."""
    nseg = seg_rb.shape[0]
    half = 0.5 * LUMEN_RAMP_M
    if g > 0 and s - seg_s[g] < half:
        t = 0.5 + (s - seg_s[g]) / LUMEN_RAMP_M
        r0, a0, f0 = _seg_params(seg_rb, seg_ra, seg_flat, g - 1, ro)
        r1, a1, f1 = _seg_params(seg_rb, seg_ra, seg_flat, g, ro)
    elif g < nseg - 1 and seg_s[g + 1] - s < half:
        t = 0.5 - (seg_s[g + 1] - s) / LUMEN_RAMP_M
        r0, a0, f0 = _seg_params(seg_rb, seg_ra, seg_flat, g, ro)
        r1, a1, f1 = _seg_params(seg_rb, seg_ra, seg_flat, g + 1, ro)
    else:
        return seg_rb[g], seg_ra[g], seg_flat[g]
    return (1 - t) * r0 + t * r1, (1 - t) * a0 + t * a1, (1 - t) * f0 + t * f1


@njit(cache=True, inline="always", error_model="numpy")
def prepare_contact(p, q, st, sw):
    """The effect's uniform signature: call :func:`contact_geometry` on the samples."""
    ch = p.chan
    return contact_geometry(
        q, st.nd, sw.link, sw.alpha, sw.ro, sw.wt, ch.h, ch.pos, ch.tan, ch.flat_normal,
        ch.kappa_min_flat, ch.seg_s, ch.seg_rb, ch.seg_ra, ch.seg_flat, p.transition, p.max_frac,
        p.k_wall, sw.s, sw.p, sw.d, sw.n, sw.H, sw.z, sw.w, sw.F, sw.dF,
        SKIP_FAR if p.skip_far else 0,
    )  # fmt: skip


@njit(cache=True, error_model="numpy")
def contact_geometry(
    q, nd, samp_link, samp_alpha, samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s,
    seg_rb, seg_ra, seg_flat, transition, max_frac, k_wall, samp_s, samp_p, samp_d, samp_n,
    samp_H, samp_z, samp_w, samp_F, samp_dF, mode,
):  # fmt: skip
    """Distance to the wall and elastic normal force at every contact sample point.

    For sample i on link j at fraction alpha: p = (1 - alpha) x_j + alpha x_{j+1}; the closest
    centreline point (hint = previous s) gives the offset o; the effective centre distance d is
    |o| (circle) or, where the lumen has a flat side at distance ``flat`` on the outside of the
    bend (-normal), a C1 smooth maximum of ``|o|`` and ``-o.nor + r_b - flat`` (corner rounded
    over 5 % of the clearance; ``kappa_min_flat < 0`` ignores flat sides). With
    b = r_b - r_o, w = min(r_b - r_a, max_frac b), a = b - w and z = (d - a) / w:
    F = 0 (z <= 0), k w z^2 / 2 (0 < z <= 1), k w (z - 1/2) (z > 1) (Khatait et al. 2014), which is
    C1, k scaled by ``samp_wt`` (the cable length the sample stands for / the reference length:
    a wall stiffness per unit length). ``samp_n`` = grad d (outward wall normal), ``samp_H`` =
    Hessian of d, both computed only for samples in contact (z > 0; zero elsewhere: a sample
    without force or stiffness needs neither).

    ``mode``: 0 evaluates every sample. :data:`SKIP_FAR` (1): a sample whose last exact
    evaluation found it out of contact by the gap ``g = -z w`` (m) and that has moved less than
    ``g / FAR_SAFETY`` from the position ``samp_p`` of that evaluation is still out of contact:
    it gets F = dF = 0 (n and H are still zero from that evaluation) and keeps its ``samp_p``,
    ``samp_s``, ``samp_d``, ``samp_z``, ``samp_w`` (the reference of the test; ``samp_s`` is then
    a stale hint for the next search, at most ~g / FAR_SAFETY away). A sample with z >= 0 (in
    contact, or never evaluated: all zeros) is always evaluated, and so is sample 0 (the tip: the
    jam monitor follows its ``samp_s``). :data:`ONLY_FAR` (2): only the samples mode 1 would skip
    are evaluated, every other sample is left as it is (:func:`refresh_far`).
    Returns the elastic contact energy.
    """
    work = np.empty(9)
    nv = np.empty(3)
    dnv = np.empty(3)
    ga = np.empty(3)
    gb = np.empty(3)
    Ha = np.empty((3, 3))
    energy = 0.0
    nseg = seg_rb.shape[0]
    for i in range(samp_link.shape[0]):
        j = samp_link[i]
        al = samp_alpha[i]
        if mode != 0 and samp_z[i] < 0.0 and i > 0:
            gap = -samp_z[i] * samp_w[i] / FAR_SAFETY
            mv = 0.0
            for a in range(3):
                x = (1.0 - al) * q[nd * j + a] + al * q[nd * (j + 1) + a] - samp_p[i, a]
                mv += x * x
            if mv < gap * gap:
                if mode == SKIP_FAR:
                    samp_F[i] = 0.0
                    samp_dF[i] = 0.0
                    continue
            elif mode == ONLY_FAR:
                continue
        elif mode == ONLY_FAR:
            continue
        for a in range(3):
            samp_p[i, a] = (1.0 - al) * q[nd * j + a] + al * q[nd * (j + 1) + a]
        s = closest_point(h, pos, tan, samp_p[i], samp_s[i], 0.01, work)
        samp_s[i] = s
        c = work[0:3]
        d1 = work[3:6]
        d2 = work[6:9]
        o0 = samp_p[i, 0] - c[0]
        o1 = samp_p[i, 1] - c[1]
        o2 = samp_p[i, 2] - c[2]
        D = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2] - (o0 * d2[0] + o1 * d2[1] + o2 * d2[2])
        dc = math.sqrt(o0 * o0 + o1 * o1 + o2 * o2)
        # lumen segment
        g = 0
        while g < nseg - 1 and s >= seg_s[g + 1]:
            g += 1
        ro = samp_ro[i]
        rb, ra, flat = _lumen_at(seg_s, seg_rb, seg_ra, seg_flat, g, s, ro)
        b = rb - ro
        w = (rb - ra) if transition <= 0.0 else transition
        if w > max_frac * b:
            w = max_frac * b
        aa = b - w
        samp_w[i] = w
        blended = False
        if flat < rb and kappa_min_flat >= 0.0:
            # the flat side lies on the outside of the bend (-nor); where the centreline is
            # nearly straight (an S-bend's inflection) the normal flips, so the flat fades out
            # smoothly between curvature 2 kappa_min_flat and kappa_min_flat
            kap = math.sqrt(d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2])
            if kap < 2.0 * kappa_min_flat:
                fade = (kap - kappa_min_flat) / kappa_min_flat
                fade = 0.0 if fade < 0.0 else fade
                fade = fade * fade * (3.0 - 2.0 * fade)
                flat = fade * flat + (1.0 - fade) * (rb + 0.5 * b)
        dcirc = dc
        wa = wb = cc = 0.0
        if flat < rb and kappa_min_flat >= 0.0:
            # flat side at distance `flat` along -nor: equivalent centre distance
            # b = -o.nor + r_b - flat, grad -nor, Hessian -(dnor/ds) c'^T / D; the corner
            # (circle meets flat) is rounded by a C1 smooth maximum of width eps
            normal_at(h, nor, s, nv)
            normal_rate(h, nor, s, dnv)
            dflat = -(o0 * nv[0] + o1 * nv[1] + o2 * nv[2]) + rb - flat
            eps = CORNER_FRACTION * b
            Dd = dc - dflat
            S = math.sqrt(Dd * Dd + eps * eps)
            wa = 0.5 * (1.0 + Dd / S)
            wb = 0.5 * (1.0 - Dd / S)
            cc = 0.5 * eps * eps / (S * S * S)
            dc = 0.5 * (dc + dflat + S)
            blended = True
        z = (dc - aa) / w
        if z > 0.0:
            # in contact: the distance's gradient (outward wall normal) and Hessian; a sample
            # with z <= 0 carries no force and no stiffness, so nothing reads them
            # circle: d = |o|, grad = o/|o|, Hessian (I - n n^T - c' c'^T / D) / |o|
            if dcirc > 1e-12:
                for a in range(3):
                    ga[a] = (o0, o1, o2)[a] / dcirc
                for a in range(3):
                    for bb in range(3):
                        dab = 1.0 if a == bb else 0.0
                        Ha[a, bb] = (dab - ga[a] * ga[bb] - d1[a] * d1[bb] / D) / dcirc
            else:
                for a in range(3):
                    ga[a] = 0.0
                    for bb in range(3):
                        Ha[a, bb] = 0.0
            if blended:
                for a in range(3):
                    gb[a] = -nv[a]
                for a in range(3):
                    samp_n[i, a] = wa * ga[a] + wb * gb[a]
                    for bb in range(3):
                        Hb = -dnv[a] * d1[bb] / D
                        samp_H[i, a, bb] = (
                            wa * Ha[a, bb] + wb * Hb + cc * (ga[a] - gb[a]) * (ga[bb] - gb[bb])
                        )
            else:
                for a in range(3):
                    samp_n[i, a] = ga[a]
                    for bb in range(3):
                        samp_H[i, a, bb] = Ha[a, bb]
        else:
            for a in range(3):
                samp_n[i, a] = 0.0
                for bb in range(3):
                    samp_H[i, a, bb] = 0.0
        samp_d[i] = dc
        samp_z[i] = z
        kw = k_wall * samp_wt[i]  # the wall stiffness of the cable length this sample stands for
        if z <= 0.0:
            samp_F[i] = 0.0
            samp_dF[i] = 0.0
        elif z <= 1.0:
            samp_F[i] = 0.5 * kw * w * z * z
            samp_dF[i] = kw * z
            energy += kw * w * w * z * z * z / 6.0
        else:
            samp_F[i] = kw * w * (z - 0.5)
            samp_dF[i] = kw
            energy += kw * w * w * (0.5 * z * z - 0.5 * z + 1.0 / 6.0)
    return energy


@njit(cache=True, inline="always", error_model="numpy")
def add_contact(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: call :func:`apply_normal` (returns 0: the elastic energy
    comes from :func:`prepare_contact`)."""
    apply_normal(st.nd, st.kl, sw.link, sw.alpha, sw.n, sw.H, sw.F, sw.dF, r, B, jac)
    return 0.0


@njit(cache=True, error_model="numpy")
def apply_normal(nd, kl, samp_link, samp_alpha, samp_n, samp_H, samp_F, samp_dF, r, B, jac):
    """Add the normal forces (residual ``F grad d``) and their stiffness to the nodes (the forces
    :func:`contact_geometry` left, after wall damping and its clamp)."""
    K = np.empty((3, 3))
    for i in range(samp_link.shape[0]):
        F = samp_F[i]
        dF = samp_dF[i]
        if F == 0.0 and dF == 0.0:
            continue
        j = samp_link[i]
        al = samp_alpha[i]
        w0 = 1.0 - al
        w1 = al
        for a in range(3):
            g = F * samp_n[i, a]
            r[nd * j + a] += w0 * g
            r[nd * (j + 1) + a] += w1 * g
        if jac:
            for a in range(3):
                for b in range(3):
                    K[a, b] = dF * samp_n[i, a] * samp_n[i, b] + F * samp_H[i, a, b]
            add_block(B, kl, nd, j, j, w0 * w0, K)
            add_block(B, kl, nd, j, j + 1, w0 * w1, K)
            add_block(B, kl, nd, j + 1, j, w0 * w1, K)
            add_block(B, kl, nd, j + 1, j + 1, w1 * w1, K)


register_kernels(ContactArgs, add=add_contact, prepare=prepare_contact)


def refresh_far(p: ContactArgs, q: np.ndarray, nd: int, sw) -> None:
    """Evaluate exactly, at ``q``, the samples that :func:`contact_geometry` with ``skip_far``
    would skip there (mode :data:`ONLY_FAR`); every other sample's values stay as they are.

    A skipped sample keeps the distance of its last exact evaluation; a step's contact force does
    not depend on it (the sample is out of contact), but wall damping's velocity at a later
    contact does, through the distance history (``Model.d_prev``). Called once per solved step
    before that history is stored, it makes the history exact while the step's residual
    assemblies (tens per step) keep skipping. The refreshed samples are still out of contact, so
    their force stays zero and the converged state is unchanged.
    """
    ch = p.chan
    contact_geometry(
        q, nd, sw.link, sw.alpha, sw.ro, sw.wt, ch.h, ch.pos, ch.tan, ch.flat_normal,
        ch.kappa_min_flat, ch.seg_s, ch.seg_rb, ch.seg_ra, ch.seg_flat, p.transition, p.max_frac,
        p.k_wall, sw.s, sw.p, sw.d, sw.n, sw.H, sw.z, sw.w, sw.F, sw.dF, ONLY_FAR,
    )  # fmt: skip


@dataclass(frozen=True)
class Contact(Effect):
    """Wall stiffness k (N/m), transition width (m, <= 0: from the lumen), cap fraction."""

    name = "contact"
    energy = "stored"

    chan: ChannelArgs
    stiffness_n_m: float
    transition_m: float
    max_fraction: float
    skip_far: bool = True

    @classmethod
    def build(cls, ctx: BuildContext) -> Contact | None:
        """On with ``effects.contact``; reads ``contact.*`` and warns when the transition zone is
        cut to ``transition_max_fraction`` of the clearance."""
        if not ctx.scene.effects.contact:
            return None
        c = ctx.scene.contact
        k = float(c.stiffness_n_m)
        tr = -1.0 if c.transition_m is None else float(c.transition_m)
        frac = float(c.transition_max_fraction)
        tb = ctx.table
        w_lumen = float(np.max(tb.seg_rb - tb.seg_ra))
        w = w_lumen if tr <= 0 else tr
        if w > frac * ctx.clearance_m:
            ctx.warnings.append(
                f"contact transition zone {w * 1e3:.3f} mm reduced to "
                f"{frac * ctx.clearance_m * 1e3:.4f} mm "
                f"({frac:g} x the clearance {ctx.clearance_m * 1e3:.3f} mm)"
            )
        # wall damping reads the samples' distance history: with it the model brings the
        # skipped samples' distances up to date after every step (Model.refresh_far)
        return cls(tb.args(), k, tr, frac, True)

    def args(self) -> ContactArgs:
        return ContactArgs(
            self.chan, self.transition_m, self.max_fraction, self.stiffness_n_m, self.skip_far
        )
