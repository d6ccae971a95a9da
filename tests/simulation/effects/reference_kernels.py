"""The effects' kernels as they were before branch kernels made them cheaper (2026-11-29, main
9f17845), kept verbatim as the reference the new kernels must reproduce bit for bit
(tests/simulation/effects/test_kernels_identical.py). Not used by ringqa."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation._kernels import closest_point, normal_at, normal_rate
from ringqa.simulation.band import add_block
from ringqa.simulation.effects.contact import (
    CORNER_FRACTION,
    FAR_SAFETY,
    LUMEN_RAMP_M,
    ONLY_FAR,
    SKIP_FAR,
)


@njit(error_model="numpy")
def _theta_funcs(th):
    """f = theta / sin(theta) and h = (sin - theta cos) / sin^3 (smooth at theta = 0)."""
    if th < 1e-4:
        t2 = th * th
        return 1.0 + t2 / 6.0, 1.0 / 3.0 + 2.0 * t2 / 15.0
    s = math.sin(th)
    c = math.cos(th)
    return th / s, (s - th * c) / (s * s * s)


@njit(inline="always", error_model="numpy")
def _add_hinge_blocks(Bf, W, kl, nd, n0, Haa, Hab, Hbb):
    """Add one hinge's Jacobian to the nodes ``n0, n0 + 1, n0 + 2`` (through the flat view
    ``Bf``, as :func:`~ringqa.simulation.band.add_block_flat`): with ``Hba = Hab^T`` and the
    nodes at ``-a``, ``a - b``, ``b``, the nine position blocks are

        (n0, n0) +Haa          (n0, n1) -Haa +Hab           (n0, n2) -Hab
        (n1, n0) -Haa +Hba     (n1, n1) +Haa -Hab -Hba +Hbb (n1, n2) +Hab -Hbb
        (n2, n0) -Hba          (n2, n1) +Hba -Hbb           (n2, n2) +Hbb

    each entry's terms added in this order, one at a time: the same sums, rounded the same
    way, as sixteen ``add_block_flat`` calls in that order, in one pass over the entries.
    """
    step = np.uint64(W - 1)
    e = np.uint64(nd)
    for a in range(3):
        for b in range(3):
            haa = Haa[a, b]
            hab = Hab[a, b]
            hba = Hab[b, a]
            hbb = Hbb[a, b]
            col = np.uint64(kl + nd * n0 + b)
            r0 = np.uint64(nd * n0 + a) * step + col
            r1 = np.uint64(nd * (n0 + 1) + a) * step + col
            r2 = np.uint64(nd * (n0 + 2) + a) * step + col
            Bf[r0] += 1.0 * haa
            v = Bf[r0 + e]
            v += -1.0 * haa
            v += 1.0 * hab
            Bf[r0 + e] = v
            Bf[r0 + 2 * e] += -1.0 * hab
            v = Bf[r1]
            v += -1.0 * haa
            v += 1.0 * hba
            Bf[r1] = v
            v = Bf[r1 + e]
            v += 1.0 * haa
            v += -1.0 * hab
            v += -1.0 * hba
            v += 1.0 * hbb
            Bf[r1 + e] = v
            v = Bf[r1 + 2 * e]
            v += 1.0 * hab
            v += -1.0 * hbb
            Bf[r1 + 2 * e] = v
            Bf[r2] += -1.0 * hba
            v = Bf[r2 + e]
            v += 1.0 * hba
            v += -1.0 * hbb
            Bf[r2 + e] = v
            Bf[r2 + 2 * e] += 1.0 * hbb


@njit(error_model="numpy")
def bending_kernel(q, nd, n_nodes, kl, hinge_k, r, B, jac):
    """Hinge bending energy ``k_i theta_i^2 / 2`` at every interior node; returns the energy.

    ``theta_i`` is the angle between links ``a = x_i - x_{i-1}`` and ``b = x_{i+1} - x_i``.
    """
    energy = 0.0
    W = B.shape[1]
    Bf = B.reshape(-1)
    a = np.empty(3)
    b = np.empty(3)
    ah = np.empty(3)
    bh = np.empty(3)
    u = np.empty(3)
    v = np.empty(3)
    Haa = np.empty((3, 3))
    Hab = np.empty((3, 3))
    Hbb = np.empty((3, 3))
    for i in range(1, n_nodes - 1):
        k = hinge_k[i - 1]
        if k == 0.0:
            continue
        i0 = nd * (i - 1)
        i1 = nd * i
        i2 = nd * (i + 1)
        la = 0.0
        lb = 0.0
        for d in range(3):
            a[d] = q[i1 + d] - q[i0 + d]
            b[d] = q[i2 + d] - q[i1 + d]
            la += a[d] * a[d]
            lb += b[d] * b[d]
        la = math.sqrt(la)
        lb = math.sqrt(lb)
        c = 0.0
        for d in range(3):
            ah[d] = a[d] / la
            bh[d] = b[d] / lb
            c += ah[d] * bh[d]
        cx0 = ah[1] * bh[2] - ah[2] * bh[1]
        cx1 = ah[2] * bh[0] - ah[0] * bh[2]
        cx2 = ah[0] * bh[1] - ah[1] * bh[0]
        sn = math.sqrt(cx0 * cx0 + cx1 * cx1 + cx2 * cx2)
        th = math.atan2(sn, c)
        energy += 0.5 * k * th * th
        f, hh = _theta_funcs(th)
        for d in range(3):
            u[d] = bh[d] - c * ah[d]
            v[d] = ah[d] - c * bh[d]
        # gradients wrt a and b of theta^2 / 2
        for d in range(3):
            ga = -k * f * u[d] / la
            gb = -k * f * v[d] / lb
            r[i0 + d] -= ga
            r[i1 + d] += ga - gb
            r[i2 + d] += gb
        if not jac:
            continue
        for pp in range(3):
            for m in range(3):
                dpm = 1.0 if pp == m else 0.0
                Haa[pp, m] = (
                    k
                    * (
                        hh * u[pp] * u[m]
                        + f * (u[pp] * ah[m] + ah[pp] * u[m])
                        + f * c * (dpm - ah[pp] * ah[m])
                    )
                    / (la * la)
                )
                Hbb[pp, m] = (
                    k
                    * (
                        hh * v[pp] * v[m]
                        + f * (v[pp] * bh[m] + bh[pp] * v[m])
                        + f * c * (dpm - bh[pp] * bh[m])
                    )
                    / (lb * lb)
                )
                Hab[pp, m] = (
                    k * (hh * u[pp] * v[m] - f * (dpm - bh[pp] * bh[m] - ah[pp] * v[m])) / (la * lb)
                )
        # nodes: x_{i-1} = -a, x_i = +a - b, x_{i+1} = +b
        _add_hinge_blocks(Bf, W, kl, nd, i - 1, Haa, Hab, Hbb)
    return energy


@njit(error_model="numpy")
def axial_kernel(q, nd, n_nodes, kl, link_len, ea_n, r, B, jac):
    """Axial penalty ``k_j / 2 (|e_j| - l_j)^2`` per link (``k_j = EA / l_j``); returns the
    energy (J)."""
    energy = 0.0
    K = np.empty((3, 3))
    e = np.empty(3)
    for j in range(n_nodes - 1):
        i0 = nd * j
        i1 = nd * (j + 1)
        L = 0.0
        for a in range(3):
            e[a] = q[i1 + a] - q[i0 + a]
            L += e[a] * e[a]
        L = math.sqrt(L)
        k = ea_n / link_len[j]
        dl = L - link_len[j]
        energy += 0.5 * k * dl * dl
        f = k * dl / L
        for a in range(3):
            g = f * e[a]
            r[i0 + a] -= g
            r[i1 + a] += g
        if jac:
            c2 = k * dl / L
            for a in range(3):
                for b in range(3):
                    ea = e[a] / L
                    eb = e[b] / L
                    K[a, b] = k * ea * eb + c2 * ((1.0 if a == b else 0.0) - ea * eb)
            add_block(B, kl, nd, j, j, 1.0, K)
            add_block(B, kl, nd, j + 1, j + 1, 1.0, K)
            add_block(B, kl, nd, j, j + 1, -1.0, K)
            add_block(B, kl, nd, j + 1, j, -1.0, K)
    return energy


@njit(error_model="numpy")
def _seg_params(seg_rb, seg_ra, seg_flat, g, ro):
    rb = seg_rb[g]
    flat = seg_flat[g]
    if not flat < rb:
        flat = rb + 0.5 * (rb - ro)  # a flat side too far out to matter (a circle)
    return rb, seg_ra[g], flat


@njit(error_model="numpy")
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


@njit(error_model="numpy")
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
