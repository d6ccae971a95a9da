"""Numba kernels of the physical effects: each adds its residual and Jacobian contribution.

Conventions (all SI): the state ``q`` holds ``nd`` numbers per node (x, y, z and, with torsion,
the twist angle phi), node 0 is the distal tip. The residual is ``r = dU/dq - f_ext`` (the force
the proximal driver and the solver must balance); the Jacobian ``dr/dq`` goes into the row-wise
band storage ``B[i, kl + j - i]`` (see ``ringqa.simulation._kernels``). Every ``add_*`` returns the
energy it stores (J) where that makes sense, for the work balance. ``jac`` False skips the
Jacobian (line search).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation._kernels import closest_point, normal_at, normal_rate


@njit(cache=True, inline="always")
def _badd(B, kl, i, j, v):
    B[i, kl + j - i] += v


@njit(cache=True)
def _add_block(B, kl, nd, ni, nj, w, K):
    """Add ``w * K`` (3x3) to the position block (node ni, node nj)."""
    bi = nd * ni
    bj = nd * nj
    for a in range(3):
        for b in range(3):
            B[bi + a, kl + bj + b - bi - a] += w * K[a, b]


@njit(cache=True, inline="always")
def _add_block_flat(Bf, W, kl, nd, ni, nj, w, K):
    """``_add_block`` through a flat view ``Bf = B.reshape(-1)`` (``W = B.shape[1]``).

    ``B[i, kl + j - i]`` is ``Bf[i (W - 1) + kl + j]``; unsigned offsets skip numba's
    negative-index wraparound test on every entry. Same additions in the same order.
    """
    step = np.uint64(W - 1)
    base = np.uint64(nd * ni) * step + np.uint64(kl + nd * nj)
    for a in range(3):
        ra = base + np.uint64(a) * step
        for b in range(3):
            Bf[ra + np.uint64(b)] += w * K[a, b]


# ------------------------------------------------------------------------------------------
# inextensibility (stiff axial penalty)


@njit(cache=True)
def add_axial(q, nd, n_nodes, link_len, k_axial, r, B, kl, jac):
    """Axial penalty ``k_j / 2 (|e_j| - l_j)^2`` per link (``k_j = EA_pen / l_j``)."""
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
        k = k_axial / link_len[j]
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
            _add_block(B, kl, nd, j, j, 1.0, K)
            _add_block(B, kl, nd, j + 1, j + 1, 1.0, K)
            _add_block(B, kl, nd, j, j + 1, -1.0, K)
            _add_block(B, kl, nd, j + 1, j, -1.0, K)
    return energy


# ------------------------------------------------------------------------------------------
# bending: hinge springs k_i theta_i^2 / 2


@njit(cache=True)
def _theta_funcs(th):
    """f = theta / sin(theta) and h = (sin - theta cos) / sin^3 (smooth at theta = 0)."""
    if th < 1e-4:
        t2 = th * th
        return 1.0 + t2 / 6.0, 1.0 / 3.0 + 2.0 * t2 / 15.0
    s = math.sin(th)
    c = math.cos(th)
    return th / s, (s - th * c) / (s * s * s)


@njit(cache=True)
def add_bending(q, nd, n_nodes, hinge_k, r, B, kl, jac):
    """Hinge bending energy ``k_i theta_i^2 / 2`` at every interior node.

    ``theta_i`` is the angle between links ``a = x_i - x_{i-1}`` and ``b = x_{i+1} - x_i``;
    gradient and Hessian are exact (derived in docs/engine.md, checked by finite differences in
    tests/simulation/test_effects.py).
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
    Hba = np.empty((3, 3))
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
        for p in range(3):
            for m in range(3):
                dpm = 1.0 if p == m else 0.0
                Haa[p, m] = (
                    k
                    * (
                        hh * u[p] * u[m]
                        + f * (u[p] * ah[m] + ah[p] * u[m])
                        + f * c * (dpm - ah[p] * ah[m])
                    )
                    / (la * la)
                )
                Hbb[p, m] = (
                    k
                    * (
                        hh * v[p] * v[m]
                        + f * (v[p] * bh[m] + bh[p] * v[m])
                        + f * c * (dpm - bh[p] * bh[m])
                    )
                    / (lb * lb)
                )
                Hab[p, m] = (
                    k * (hh * u[p] * v[m] - f * (dpm - bh[p] * bh[m] - ah[p] * v[m])) / (la * lb)
                )
        for p in range(3):
            for m in range(3):
                Hba[p, m] = Hab[m, p]
        # nodes: x_{i-1} = -a, x_i = +a - b, x_{i+1} = +b
        n0 = i - 1
        n1 = i
        n2 = i + 1
        _add_block_flat(Bf, W, kl, nd, n0, n0, 1.0, Haa)
        _add_block_flat(Bf, W, kl, nd, n0, n1, -1.0, Haa)
        _add_block_flat(Bf, W, kl, nd, n0, n1, 1.0, Hab)
        _add_block_flat(Bf, W, kl, nd, n0, n2, -1.0, Hab)
        _add_block_flat(Bf, W, kl, nd, n1, n0, -1.0, Haa)
        _add_block_flat(Bf, W, kl, nd, n1, n0, 1.0, Hba)
        _add_block_flat(Bf, W, kl, nd, n1, n1, 1.0, Haa)
        _add_block_flat(Bf, W, kl, nd, n1, n1, -1.0, Hab)
        _add_block_flat(Bf, W, kl, nd, n1, n1, -1.0, Hba)
        _add_block_flat(Bf, W, kl, nd, n1, n1, 1.0, Hbb)
        _add_block_flat(Bf, W, kl, nd, n1, n2, 1.0, Hab)
        _add_block_flat(Bf, W, kl, nd, n1, n2, -1.0, Hbb)
        _add_block_flat(Bf, W, kl, nd, n2, n0, -1.0, Hba)
        _add_block_flat(Bf, W, kl, nd, n2, n1, 1.0, Hba)
        _add_block_flat(Bf, W, kl, nd, n2, n1, -1.0, Hbb)
        _add_block_flat(Bf, W, kl, nd, n2, n2, 1.0, Hbb)
    return energy


# ------------------------------------------------------------------------------------------
# torsion: twist springs between consecutive nodes


@njit(cache=True)
def add_torsion(q, nd, n_nodes, twist_k, r, B, kl, jac):
    """Twist energy ``k_j / 2 (phi_{j+1} - phi_j)^2`` per link (``k_j = GJ / l_j``)."""
    energy = 0.0
    for j in range(n_nodes - 1):
        i0 = nd * j + 3
        i1 = nd * (j + 1) + 3
        k = twist_k[j]
        dphi = q[i1] - q[i0]
        energy += 0.5 * k * dphi * dphi
        r[i0] -= k * dphi
        r[i1] += k * dphi
        if jac:
            _badd(B, kl, i0, i0, k)
            _badd(B, kl, i1, i1, k)
            _badd(B, kl, i0, i1, -k)
            _badd(B, kl, i1, i0, -k)
    return energy


# ------------------------------------------------------------------------------------------
# gravity and inertia


@njit(cache=True)
def add_gravity(q, nd, n_nodes, node_mass, g, r):
    """Weight ``m_i g`` on every node (lumped); returns the potential energy ``-sum m g.x``."""
    energy = 0.0
    for i in range(n_nodes):
        for a in range(3):
            r[nd * i + a] -= node_mass[i] * g[a]
            energy -= node_mass[i] * g[a] * q[nd * i + a]
    return energy


@njit(cache=True)
def add_inertia(q, q_prev, v_prev, nd, n_nodes, node_mass, node_rot, dt, r, B, kl, jac):
    """Backward-Euler inertia ``M (q - q_prev - dt v_prev) / dt^2`` (lumped masses)."""
    inv = 1.0 / (dt * dt)
    for i in range(n_nodes):
        for a in range(nd):
            m = node_mass[i] if a < 3 else node_rot[i]
            idx = nd * i + a
            r[idx] += m * (q[idx] - q_prev[idx] - dt * v_prev[idx]) * inv
            if jac:
                _badd(B, kl, idx, idx, m * inv)
    return 0.0


@njit(cache=True)
def add_viscous(q, q_ref, nd, n_nodes, coef, dt, r, B, kl, jac):
    """Stabilisation: artificial viscosity ``coef (x - x_ref) / dt`` on every node (N s/m).

    ``x_ref`` is the load step's predictor (the previous chain slid along the channel), so steady
    sliding costs nothing and only departures from it (snap-through, buckling) are damped.
    """
    for i in range(n_nodes):
        for a in range(3):
            idx = nd * i + a
            r[idx] += coef * (q[idx] - q_ref[idx]) / dt
            if jac:
                _badd(B, kl, idx, idx, coef / dt)
    return 0.0


# ------------------------------------------------------------------------------------------
# contact: sample points along the links, Khatait three-region normal force


#: lumen changes (a step in r_b, the start of a flat side) are tapered over this length (m)
LUMEN_RAMP_M = 1.0e-3
#: the U-shaped lumen's corners (circle meets flat) are rounded over this fraction of the clearance
CORNER_FRACTION = 0.05


@njit(cache=True)
def _seg_params(seg_rb, seg_ra, seg_flat, g, ro):
    rb = seg_rb[g]
    flat = seg_flat[g]
    if not flat < rb:
        flat = rb + 0.5 * (rb - ro)  # a flat side too far out to matter (a circle)
    return rb, seg_ra[g], flat


@njit(cache=True)
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


@njit(cache=True)
def contact_geometry(
    q,
    nd,
    samp_link,
    samp_alpha,
    samp_ro,
    samp_wt,
    h,
    pos,
    tan,
    nor,
    kappa_min_flat,
    seg_s,
    seg_rb,
    seg_ra,
    seg_flat,
    transition,
    max_frac,
    k_wall,
    samp_s,
    samp_p,
    samp_d,
    samp_n,
    samp_H,
    samp_z,
    samp_w,
    samp_F,
    samp_dF,
):
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


@njit(cache=True)
def add_wall_damping(samp_d, samp_d_prev, samp_z, samp_w, samp_wt, c_w, dt, samp_F, samp_dF):
    """Khatait wall damping ``c_w (3 - 2z) z^2 v_n`` (``c_w v_n`` beyond the wall), v_n = dd/dt.

    Returns the damping power times dt (the work of this term over the step, J).
    """
    work = 0.0
    for i in range(samp_d.shape[0]):
        z = samp_z[i]
        if z <= 0.0:
            continue
        vn = (samp_d[i] - samp_d_prev[i]) / dt
        if z <= 1.0:
            sh = (3.0 - 2.0 * z) * z * z
            dsh = (6.0 * z - 6.0 * z * z) / samp_w[i]
        else:
            sh = 1.0
            dsh = 0.0
        cw = c_w * samp_wt[i]
        fd = cw * sh * vn
        samp_F[i] += fd
        samp_dF[i] += cw * (dsh * vn + sh / dt)
        work += fd * (samp_d[i] - samp_d_prev[i])
    return work


@njit(cache=True)
def clamp_normal(samp_F, samp_dF):
    """The wall never pulls: a negative total normal force (damping) is clamped to zero."""
    for i in range(samp_F.shape[0]):
        if samp_F[i] < 0.0:
            samp_F[i] = 0.0
            samp_dF[i] = 0.0


@njit(cache=True)
def apply_normal(nd, samp_link, samp_alpha, samp_n, samp_H, samp_F, samp_dF, r, B, kl, jac):
    """Add the normal forces (residual ``F grad d``) and their stiffness to the nodes."""
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
            _add_block(B, kl, nd, j, j, w0 * w0, K)
            _add_block(B, kl, nd, j, j + 1, w0 * w1, K)
            _add_block(B, kl, nd, j + 1, j, w0 * w1, K)
            _add_block(B, kl, nd, j + 1, j + 1, w1 * w1, K)


# ------------------------------------------------------------------------------------------
# friction


@njit(cache=True)
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


@njit(cache=True, inline="always")
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


@njit(cache=True)
def add_friction(
    q,
    q_prev,
    nd,
    samp_link,
    samp_alpha,
    samp_ro,
    samp_p,
    samp_n,
    samp_H,
    samp_F,
    samp_dF,
    law,
    mu_s,
    mu_k,
    v_brk,
    v_reg,
    dt,
    torsion,
    r,
    B,
    kl,
    jac,
):
    """Regularised friction at each contact sample: F_t = -F_n mu(|v|) v / |v|.

    The contact velocity is the tangential slip over the step divided by dt (the quasi-static
    incremental law; dt = increment / input speed), plus ``r_o dphi/dt (t x n)`` with torsion;
    the friction moment about the link axis ``r_o (n x F_t) . t`` loads the twist DOFs.
    Jacobian exact except for the rotation of n and t within the step. Returns the dissipated
    work over the step (J, >= 0).
    """
    work = 0.0
    A = np.empty((3, 3))
    K = np.empty((3, 3))
    P = np.empty((3, 3))
    wv = np.empty(3)
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
        ro = samp_ro[i]
        if torsion:
            twist_slip_direction(q, nd, j, n, tau)
            dphi = w0 * (q[nd * j + 3] - q_prev[nd * j + 3]) + w1 * (
                q[nd * (j + 1) + 3] - q_prev[nd * (j + 1) + 3]
            )
            for a in range(3):
                wv[a] += ro * dphi * tau[a]
        vm = 0.0
        for a in range(3):
            v[a] = wv[a] / dt
            vm += v[a] * v[a]
        vm = math.sqrt(vm)
        phi, psi = friction_phi(vm, law, mu_s, mu_k, v_brk, v_reg)
        for a in range(3):
            Ft[a] = -F * phi * v[a]
            work -= Ft[a] * wv[a]
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
        _add_block(B, kl, nd, j, j, w0 * w0, K)
        _add_block(B, kl, nd, j, j + 1, w0 * w1, K)
        _add_block(B, kl, nd, j + 1, j, w0 * w1, K)
        _add_block(B, kl, nd, j + 1, j + 1, w1 * w1, K)
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
                        _badd(B, kl, nd * ni + a, nd * nj + 3, ww * Ktau[a])
                        # phi row, position column
                        acc = 0.0
                        for c in range(3):
                            acc += ro * tau[c] * K[c, a]
                        _badd(B, kl, nd * ni + 3, nd * nj + a, ww * acc)
                    _badd(B, kl, nd * ni + 3, nd * nj + 3, ww * kpp)
    return work
