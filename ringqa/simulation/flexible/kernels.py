"""Numba kernels of the flexible engine: Hermite beam elements, contact along them, Newton.

State ``q`` (``nd`` per node): position ``x`` (m) and tangent ``t = dr/dsigma`` (-) of every node,
node 0 the distal tip (``nd = 6``); with torsion (``nd = 7``) also the twist angle ``phi`` (rad) of
the cross-section about the tangent, measured from the centreline's rotation-minimising (Bishop)
frame, in which the twist rate is ``phi'`` exactly. Element e (length L, nodes e and e+1) is the
cubic Hermite curve

    r(xi) = h1 x_e + h2 t_e + h3 x_{e+1} + h4 t_{e+1},   xi = (sigma - sigma_e) / L in [0, 1],
    h1 = 1 - 3 xi^2 + 2 xi^3,  h2 = L (xi - 2 xi^2 + xi^3),
    h3 = 3 xi^2 - 2 xi^3,      h4 = L (xi^3 - xi^2)

(the gradient-deficient absolute-nodal-coordinate cable element). Strain energies:

- bending ``EI / 2 int |r''|^2 dsigma``: for an inextensible curve (|r'| = 1, so r'.r'' = 0)
  |r''| is exactly the curvature, so this is the Kirchhoff rod's bending energy; it is quadratic
  in q (the Hermite beam matrix EI / L^3 [12, 6L, -12, 6L; ...] on each coordinate);
- axial ``EA / 2 int (|r'| - 1)^2 dsigma``, the stiff inextensibility penalty, integrated with 2
  Gauss points (reduced: a cubic cannot keep |r'| = 1 everywhere along a circular arc, and full
  integration would lock the element's bending against the penalty);
- torsion (``nd = 7``) ``GJ / 2 int phi'^2 dsigma`` with ``phi`` linear along the element:
  ``GJ / (2 L) (phi_{e+1} - phi_e)^2``. For an isotropic rod the twist measured from the Bishop
  frame needs no bending-torsion coupling term (the Bishop frame does not twist, and an
  isotropic section's bending energy does not depend on the twist); the twist meets the
  centreline only through friction, as in the rigid engine (:mod:`ringqa.simulation.effects.
  torsion`): a twist rate ``dphi/dt`` slides the surface at ``r_o dphi/dt (t x n)`` and the
  friction moment ``r_o (n x F_t) . t`` loads ``phi``.

Contact and friction are the rigid engine's laws, called unchanged on the sample points
(:mod:`ringqa.simulation.effects.contact`, :mod:`ringqa.simulation.effects.friction`): the samples
are handed to those kernels as a "chain" of points (link i = sample i, fraction 0; ``ns = 3``
coordinates, 4 with torsion: the sample's twist, linear between the element's nodes), their forces
and 3x3 (4x4) stiffnesses read back and spread to the element's DOFs with h1..h4 (the twist with
``1 - xi, xi``). Everything here sees
arrays and scalars only (SI).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation.band import band_solve
from ringqa.simulation.effects.contact import SKIP_FAR, apply_normal, contact_geometry
from ringqa.simulation.effects.friction import friction_kernel

#: coordinates per node without / with torsion (position, tangent; and the twist angle)
ND = 6
ND_TWIST = 7
#: half-bandwidth of the Jacobian: an element couples its two nodes' 2 nd coordinates
#: (:func:`half_band`: 11, 13 with torsion)
KL = 2 * ND - 1
#: half-bandwidth of the sample points' scratch band (3 coordinates per "node", 4 with torsion)
KL_S = 5
#: largest change of a twist angle in one Newton step (rad)
TWIST_STEP = 1.0
#: Gauss points on [0, 1] (2-point rule) for the axial penalty
G1 = 0.5 - 0.5 / math.sqrt(3.0)
G2 = 0.5 + 0.5 / math.sqrt(3.0)


@njit(cache=True, error_model="numpy")
def half_band(nd):
    """Half-bandwidth of a band matrix whose "nodes" carry ``nd`` coordinates each and couple to
    their neighbours only (``2 nd - 1``)."""
    return 2 * nd - 1


@njit(cache=True, inline="always", error_model="numpy")
def ix(b0, nd, k, d):
    """Index of coordinate ``d`` of the element's k-th vector (0 x_e, 1 t_e, 2 x_f, 3 t_f), the
    element's first node starting at ``b0``."""
    return b0 + (k >> 1) * nd + (k & 1) * 3 + d


@njit(cache=True, error_model="numpy")
def hermite(xi, L, h):
    """Position shape functions h1..h4 at ``xi`` (element length L) into ``h`` (4,)."""
    x2 = xi * xi
    x3 = x2 * xi
    h[0] = 1.0 - 3.0 * x2 + 2.0 * x3
    h[1] = L * (xi - 2.0 * x2 + x3)
    h[2] = 3.0 * x2 - 2.0 * x3
    h[3] = L * (x3 - x2)


@njit(cache=True, error_model="numpy")
def hermite_d1(xi, L, c):
    """d/dsigma of h1..h4 at ``xi`` into ``c`` (4,)."""
    c[0] = (-6.0 * xi + 6.0 * xi * xi) / L
    c[1] = 1.0 - 4.0 * xi + 3.0 * xi * xi
    c[2] = (6.0 * xi - 6.0 * xi * xi) / L
    c[3] = -2.0 * xi + 3.0 * xi * xi


@njit(cache=True, error_model="numpy")
def elastic(q, nd, el_len, el_ei, el_gj, el_ea, el_w, r, B, jac):
    """Add bending, axial penalty, torsion (``nd = 7``) and distributed load (gravity) of every
    element.

    ``el_w`` (E, 3): the load per length on each element (N/m; gravity mu g); ``el_gj`` (E,):
    torsional stiffness (N m^2; read only with ``nd = 7``). Returns the stored energy (J; the
    load's potential included).
    """
    ne = el_len.shape[0]
    kl = half_band(nd)
    kb = np.empty((4, 4))
    c = np.empty(4)
    a = np.empty(3)
    Ha = np.empty((3, 3))
    energy = 0.0
    for e in range(ne):
        L = el_len[e]
        EI = el_ei[e]
        EA = el_ea[e]
        b0 = nd * e
        L2 = L * L
        L3 = L2 * L
        kb[0, 0] = 12.0 / L3
        kb[0, 1] = 6.0 / L2
        kb[0, 2] = -12.0 / L3
        kb[0, 3] = 6.0 / L2
        kb[1, 1] = 4.0 / L
        kb[1, 2] = -6.0 / L2
        kb[1, 3] = 2.0 / L
        kb[2, 2] = 12.0 / L3
        kb[2, 3] = -6.0 / L2
        kb[3, 3] = 4.0 / L
        for i in range(4):
            for j in range(i):
                kb[i, j] = kb[j, i]
        # bending: per coordinate d, the dofs (x_e[d], t_e[d], x_f[d], t_f[d]) at ix(b0, nd, k, d)
        for d in range(3):
            for i in range(4):
                row = ix(b0, nd, i, d)
                gi = 0.0
                for j in range(4):
                    gi += EI * kb[i, j] * q[ix(b0, nd, j, d)]
                r[row] += gi
                energy += 0.5 * gi * q[row]
                if jac:
                    for j in range(4):
                        col = ix(b0, nd, j, d)
                        B[row, kl + col - row] += EI * kb[i, j]
        # torsion: GJ / (2 L) (phi_f - phi_e)^2
        if nd == ND_TWIST:
            i0 = b0 + 6
            i1 = b0 + nd + 6
            kt = el_gj[e] / L
            dphi = q[i1] - q[i0]
            energy += 0.5 * kt * dphi * dphi
            r[i0] -= kt * dphi
            r[i1] += kt * dphi
            if jac:
                B[i0, kl] += kt
                B[i1, kl] += kt
                B[i0, kl + i1 - i0] -= kt
                B[i1, kl + i0 - i1] -= kt
        # axial penalty, 2 Gauss points of weight L / 2
        for g in range(2):
            xi = G1 if g == 0 else G2
            hermite_d1(xi, L, c)
            for d in range(3):
                a[d] = 0.0
                for k in range(4):
                    a[d] += c[k] * q[ix(b0, nd, k, d)]
            A = math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
            eps = A - 1.0
            wg = 0.5 * L
            energy += wg * 0.5 * EA * eps * eps
            f = wg * EA * eps / A
            for k in range(4):
                for d in range(3):
                    r[ix(b0, nd, k, d)] += c[k] * f * a[d]
            if jac:
                for d1 in range(3):
                    for d2 in range(3):
                        aa = a[d1] * a[d2] / (A * A)
                        Ha[d1, d2] = wg * EA * (aa + eps / A * ((1.0 if d1 == d2 else 0.0) - aa))
                for k in range(4):
                    for m in range(4):
                        ckm = c[k] * c[m]
                        for d1 in range(3):
                            row = ix(b0, nd, k, d1)
                            for d2 in range(3):
                                col = ix(b0, nd, m, d2)
                                B[row, kl + col - row] += ckm * Ha[d1, d2]
        # distributed load w (N/m): consistent nodal loads int h_k w dsigma
        wl = el_w[e]
        if wl[0] != 0.0 or wl[1] != 0.0 or wl[2] != 0.0:
            ints = (0.5 * L, L2 / 12.0, 0.5 * L, -L2 / 12.0)
            for k in range(4):
                for d in range(3):
                    fk = ints[k] * wl[d]
                    r[ix(b0, nd, k, d)] -= fk
                    energy -= fk * q[ix(b0, nd, k, d)]
    return energy


@njit(cache=True, error_model="numpy")
def sample_positions(q, nd, ns, el_len, samp_el, samp_xi, out):
    """Positions of the contact samples (P, 3) into ``out`` as a flat (ns (P + 1),) array (the
    last point a dummy: the contact kernels read a "next node" of every sample). With
    ``ns = 4`` (torsion) each sample also gets its twist (linear along the element) and the
    dummy continues the last two samples' line (the friction kernel reads the "link" from a
    sample to the next as the cable's axis there); with ``ns = 3`` the dummy repeats the last
    sample."""
    h = np.empty(4)
    for i in range(samp_el.shape[0]):
        e = samp_el[i]
        hermite(samp_xi[i], el_len[e], h)
        b0 = nd * e
        for d in range(3):
            v = 0.0
            for k in range(4):
                v += h[k] * q[ix(b0, nd, k, d)]
            out[ns * i + d] = v
        if ns == 4:
            xi = samp_xi[i]
            out[ns * i + 3] = (1.0 - xi) * q[b0 + 6] + xi * q[b0 + nd + 6]
    P = samp_el.shape[0]
    for d in range(ns):
        out[ns * P + d] = out[ns * (P - 1) + d]
    if ns == 4 and P > 1:
        for d in range(3):
            out[ns * P + d] = 2.0 * out[ns * (P - 1) + d] - out[ns * (P - 2) + d]


@njit(cache=True, error_model="numpy")
def scatter_samples(nd, ns, el_len, samp_el, samp_xi, rs, Bs, r, B, jac):
    """Spread the samples' residuals ``rs`` and ns x ns stiffnesses (the diagonal blocks of the
    scratch band ``Bs``) to the elements' DOFs: positions with the shape functions h1..h4, a
    sample's twist (``ns = 4``) with ``1 - xi, xi`` to its element's two twist angles."""
    h = np.empty(4)
    w_phi = np.empty(2)
    kl = half_band(nd)
    kls = half_band(ns)
    for i in range(samp_el.shape[0]):
        bi = ns * i
        nz = False
        for d in range(ns):
            if rs[bi + d] != 0.0:
                nz = True
        if jac and not nz:
            for d1 in range(ns):
                for d2 in range(ns):
                    if Bs[bi + d1, kls + d2 - d1] != 0.0:
                        nz = True
        if not nz:
            continue
        e = samp_el[i]
        hermite(samp_xi[i], el_len[e], h)
        b0 = nd * e
        for k in range(4):
            for d in range(3):
                r[ix(b0, nd, k, d)] += h[k] * rs[bi + d]
        if ns == 4:
            w_phi[0] = 1.0 - samp_xi[i]
            w_phi[1] = samp_xi[i]
            for k in range(2):
                r[b0 + k * nd + 6] += w_phi[k] * rs[bi + 3]
        if jac:
            for k in range(4):
                for m in range(4):
                    hkm = h[k] * h[m]
                    if hkm == 0.0:
                        continue
                    for d1 in range(3):
                        row = ix(b0, nd, k, d1)
                        for d2 in range(3):
                            col = ix(b0, nd, m, d2)
                            B[row, kl + col - row] += hkm * Bs[bi + d1, kls + d2 - d1]
            if ns == 4:
                for k in range(2):
                    pk = b0 + k * nd + 6
                    for m in range(4):
                        for d in range(3):
                            col = ix(b0, nd, m, d)
                            # twist row, position column; position row, twist column
                            B[pk, kl + col - pk] += w_phi[k] * h[m] * Bs[bi + 3, kls + d - 3]
                            B[col, kl + pk - col] += h[m] * w_phi[k] * Bs[bi + d, kls + 3 - d]
                    for m in range(2):
                        pm = b0 + m * nd + 6
                        B[pk, kl + pm - pk] += w_phi[k] * w_phi[m] * Bs[bi + 3, kls]


@njit(cache=True, error_model="numpy")
def assemble(
    q, nd, ns, el_len, el_ei, el_gj, el_ea, el_w, samp_el, samp_xi, samp_link, samp_alpha, samp_ro,
    samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb, seg_ra, seg_flat, transition,
    max_frac, k_wall, contact_on, samp_s, samp_p, samp_d, samp_n, samp_H, samp_z, samp_w, samp_F,
    samp_dF, qs, qs_prev, qs_start, rs, Bs, law, mu_s, mu_k, v_brk, v_reg, dt, k_teth, q_ref,
    f_ext, n_free, r, B, jac, out,
):  # fmt: skip
    """Residual ``dU/dq - f_ext`` (and, when ``jac``, its banded Jacobian) of the whole rod
    (``nd`` coordinates per node, ``ns`` per contact sample: 6 and 3, with torsion 7 and 4).

    ``out`` (3,) receives the stored energy (elastic + gravity potential), the contact energy
    and the friction work over the step (from ``qs_start``). ``law`` 0: no friction. ``k_teth``
    > 0 adds a tether ``k_teth (x - x_ref)`` on every free node's position (the fallback
    stabilisation). ``f_ext`` (n_all,): external nodal loads (N; N m on tangents), e.g. a
    cantilever's tip load.
    """
    r[:] = 0.0
    if jac:
        B[:, :] = 0.0
    out[0] = elastic(q, nd, el_len, el_ei, el_gj, el_ea, el_w, r, B, jac)
    for i in range(f_ext.shape[0]):
        if f_ext[i] != 0.0:
            r[i] -= f_ext[i]
            out[0] -= f_ext[i] * q[i]
    out[1] = 0.0
    out[2] = 0.0
    if contact_on:
        sample_positions(q, nd, ns, el_len, samp_el, samp_xi, qs)
        kls = half_band(ns)
        out[1] = contact_geometry(
            qs, ns, samp_link, samp_alpha, samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat,
            seg_s, seg_rb, seg_ra, seg_flat, transition, max_frac, k_wall, samp_s, samp_p,
            samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF, SKIP_FAR,
        )  # fmt: skip
        rs[:] = 0.0
        if jac:
            Bs[:, :] = 0.0
        apply_normal(ns, kls, samp_link, samp_alpha, samp_n, samp_H, samp_F, samp_dF, rs, Bs,
                     jac)  # fmt: skip
        if law != 0:
            out[2] = friction_kernel(
                qs, qs_prev, qs_start, ns, kls, samp_link, samp_alpha, samp_ro, samp_p, samp_n,
                samp_H, samp_F, samp_dF, law, mu_s, mu_k, v_brk, v_reg, dt, ns == 4, rs, Bs, jac,
            )  # fmt: skip
        scatter_samples(nd, ns, el_len, samp_el, samp_xi, rs, Bs, r, B, jac)
    if k_teth > 0.0:
        nn = q.shape[0] // nd
        kl = half_band(nd)
        for k in range(nn - 1):
            for d in range(3):
                i = nd * k + d
                if i < n_free:
                    r[i] += k_teth * (q[i] - q_ref[i])
                    if jac:
                        B[i, kl] += k_teth


@njit(cache=True, error_model="numpy")
def _merit(r, nd, n_free, tan_scale):
    m = 0.0
    for i in range(n_free):
        v = r[i] * (tan_scale if (i % nd) >= 3 else 1.0)
        m += v * v
    return m


@njit(cache=True, error_model="numpy")
def _converged(r, nd, n_free, tol_f, tol_m):
    """Position residuals (N) within ``tol_f``, tangent and twist residuals (N m) within
    ``tol_m``."""
    worst = 0.0
    for i in range(n_free):
        v = abs(r[i])
        if (i % nd) >= 3:
            if v > tol_m:
                return False, v / tol_m * tol_f
        elif v > tol_f:
            return False, v
        if v > worst:
            worst = v
    return True, worst


@njit(cache=True, error_model="numpy")
def project_strains(q0, q, nd, el_len, n_free, l_ref, M, lam):
    """Second-order correction of a Newton update ``q0 -> q`` (in place on ``q``): the smallest
    change (positions in m, tangents weighted by ``l_ref``) that gives every Gauss point's axial
    strain its LINEARISED value ``eps(q0) + deps/dq (q - q0)`` (one Gauss-Newton step on the
    2E strain conditions; ``M`` (2E, 10) and ``lam`` (2E,) scratch).

    Why: bending a cubic element, or rotating it, changes its arc length at second order, which
    the Newton step cannot see; the stiff axial penalty would answer that stretch with forces
    far above the bending forces and the iteration would zig-zag (the Maratos effect of penalty
    methods). The correction is second order in the step, so Newton keeps its quadratic
    convergence. The rigid engine does the same for its links (keeping each link's linearised
    length, ``solvers/newton.update_chain``).
    """
    ne = el_len.shape[0]
    m = 2 * ne
    kl = 3
    c = np.empty(4)
    ah = np.empty((m, 3))
    cc = np.empty((m, 4))
    M[:, :] = 0.0
    w_t = 1.0 / (l_ref * l_ref)  # inverse weight of a tangent block
    nfb = (n_free // nd) * 2  # free 3-blocks: x and t of every free node
    for e in range(ne):
        L = el_len[e]
        b0 = nd * e
        for g in range(2):
            i = 2 * e + g
            hermite_d1(G1 if g == 0 else G2, L, c)
            a00 = a01 = a02 = 0.0
            a0 = a1 = a2 = 0.0
            for k in range(4):
                bk = ix(b0, nd, k, 0)
                a00 += c[k] * q0[bk]
                a01 += c[k] * q0[bk + 1]
                a02 += c[k] * q0[bk + 2]
                a0 += c[k] * q[bk]
                a1 += c[k] * q[bk + 1]
                a2 += c[k] * q[bk + 2]
            A0 = math.sqrt(a00 * a00 + a01 * a01 + a02 * a02)
            A1 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            lin = A0 + (a00 * (a0 - a00) + a01 * (a1 - a01) + a02 * (a2 - a02)) / A0
            lam[i] = A1 - lin
            ah[i, 0] = a0 / A1
            ah[i, 1] = a1 / A1
            ah[i, 2] = a2 / A1
            for k in range(4):
                cc[i, k] = c[k]
    # M = A W^-1 A^T over the free blocks; rows i (element e) and j (element f) share a block
    for i in range(m):
        e = i // 2
        for j in range(max(0, i - kl), min(m, i + kl + 1)):
            f = j // 2
            acc = 0.0
            dot = ah[i, 0] * ah[j, 0] + ah[i, 1] * ah[j, 1] + ah[i, 2] * ah[j, 2]
            for k in range(4):
                blk = 2 * e + k
                kf = blk - 2 * f
                if blk >= nfb:
                    continue
                if 0 <= kf < 4:
                    wi = w_t if (k % 2) == 1 else 1.0
                    acc += cc[i, k] * cc[j, kf] * wi * dot
            M[i, kl + j - i] = acc
    if not band_solve(M, kl, lam, m):
        return
    for i in range(m):
        e = i // 2
        for k in range(4):
            blk = 2 * e + k
            if blk >= nfb:
                continue
            wi = w_t if (k % 2) == 1 else 1.0
            base = ix(nd * e, nd, k, 0)
            for d in range(3):
                q[base + d] -= wi * cc[i, k] * lam[i] * ah[i, d]


#: largest change of a tangent in one Newton step (rad, about): the strain correction
#: (:func:`project_strains`) is a Gauss-Newton step, accurate for strains ~ beta^2 / 2 << 1
TANGENT_STEP = 0.25
#: full Newton steps the watchdog lets raise the merit before it returns to the best state
WATCHDOG = 8


@njit(cache=True, error_model="numpy")
def newton(
    q, nd, ns, el_len, el_ei, el_gj, el_ea, el_w, samp_el, samp_xi, samp_link, samp_alpha, samp_ro,
    samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb, seg_ra, seg_flat, transition,
    max_frac, k_wall, contact_on, samp_s, samp_p, samp_d, samp_n, samp_H, samp_z, samp_w, samp_F,
    samp_dF, qs, qs_prev, qs_start, rs, Bs, law, mu_s, mu_k, v_brk, v_reg, dt, k_teth, q_ref,
    f_ext, n_free, r, B, out, tol_f, tol_m, max_iter, max_step, tan_scale, counters,
):  # fmt: skip
    """Newton with a watchdog (in place on ``q``).

    Full Newton steps, each limited to ``max_step`` (m) on the positions, 0.25 on the tangents
    and :data:`TWIST_STEP` on the twist angles (``nd = 7``). A full step may raise the merit
    (the scaled |r|^2) for up to :data:`WATCHDOG` steps in a row: bending a cubic element
    changes its arc length at second order, which a Newton step cannot see, so a step that is
    right to first order stretches the elements and the stiff axial penalty answers with forces
    far above the bending forces; the next step removes that (the Maratos effect of penalty
    methods: a monotone line search would cut every such step). If the merit is still above the
    best state's after the watchdog's steps, the iteration returns to the best state and takes
    an Armijo line-search step from it. Converged when every position residual is <= ``tol_f``
    (N) and every tangent (and twist) residual <= ``tol_m`` (N m). ``counters``: iterations,
    assemblies, halvings (added to).

    Returns
    -------
    status : int
        0 converged, 3 iteration limit, 4 line search failed (stall), 5 no progress, 6 singular.
    iters : int
    res : float
        The last largest residual (N).
    """
    Bw = np.empty_like(B)
    rhs = np.empty(n_free)
    q_best = q.copy()
    Pm = np.empty((2 * el_len.shape[0], 10))
    lam = np.empty(2 * el_len.shape[0])
    assemble(q, nd, ns, el_len, el_ei, el_gj, el_ea, el_w, samp_el, samp_xi, samp_link, samp_alpha,
             samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb, seg_ra, seg_flat,
             transition, max_frac, k_wall, contact_on, samp_s, samp_p, samp_d, samp_n, samp_H,
             samp_z, samp_w, samp_F, samp_dF, qs, qs_prev, qs_start, rs, Bs, law, mu_s, mu_k,
             v_brk, v_reg, dt, k_teth, q_ref, f_ext, n_free, r, B, True, out)  # fmt: skip
    counters[1] += 1
    merit = _merit(r, nd, n_free, tan_scale)
    kl = half_band(nd)
    best = merit
    since_best = 0
    watch = 0
    res = 0.0
    for it in range(max_iter):
        ok, res = _converged(r, nd, n_free, tol_f, tol_m)
        if ok:
            return 0, it, res
        if watch >= WATCHDOG:
            # back to the best state, then a line-search step from it
            q[:] = q_best
            assemble(q, nd, ns, el_len, el_ei, el_gj, el_ea, el_w, samp_el, samp_xi, samp_link,
                     samp_alpha, samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb,
                     seg_ra, seg_flat, transition, max_frac, k_wall, contact_on, samp_s, samp_p,
                     samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF, qs, qs_prev,
                     qs_start, rs, Bs, law, mu_s, mu_k, v_brk, v_reg, dt, k_teth, q_ref, f_ext,
                     n_free, r, B, True, out)  # fmt: skip
            counters[1] += 1
            merit = best
        counters[0] += 1
        Bw[:, :] = B
        for i in range(n_free):
            rhs[i] = -r[i]
        if not band_solve(Bw, kl, rhs, n_free):
            return 6, it, res
        # trust region
        sc = 1.0
        for i in range(n_free):
            c6 = i % nd
            lim = max_step if c6 < 3 else (TANGENT_STEP if c6 < 6 else TWIST_STEP)
            v = abs(rhs[i])
            if v * sc > lim:
                sc = lim / v
        q0 = q.copy()
        alpha = sc
        searching = watch >= WATCHDOG
        accepted = False
        for _ls in range(9 if searching else 1):
            for i in range(n_free):
                q[i] = q0[i] + alpha * rhs[i]
            project_strains(q0, q, nd, el_len, n_free, 1.0 / tan_scale, Pm, lam)
            assemble(q, nd, ns, el_len, el_ei, el_gj, el_ea, el_w, samp_el, samp_xi, samp_link,
                     samp_alpha, samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb,
                     seg_ra, seg_flat, transition, max_frac, k_wall, contact_on, samp_s, samp_p,
                     samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF, qs, qs_prev,
                     qs_start, rs, Bs, law, mu_s, mu_k, v_brk, v_reg, dt, k_teth, q_ref, f_ext,
                     n_free, r, B, True, out)  # fmt: skip
            counters[1] += 1
            m_new = _merit(r, nd, n_free, tan_scale)
            if not searching or m_new <= (1.0 - 1e-4 * alpha) * merit:
                accepted = True
                merit = m_new
                break
            alpha *= 0.5
            counters[2] += 1
        if not accepted:
            ok, res = _converged(r, nd, n_free, tol_f, tol_m)
            if ok:
                return 0, it + 1, res
            return 4, it + 1, res
        if merit < (1.0 - 1e-4) * best:
            if merit < 0.25 * best:
                since_best = 0
            else:
                since_best += 1
            best = merit
            q_best[:] = q
            watch = 0
        else:
            watch += 1
            since_best += 1
        if since_best >= 20:
            return 5, it + 1, res
    ok, res = _converged(r, nd, n_free, tol_f, tol_m)
    return (0 if ok else 3), max_iter, res


@njit(cache=True, error_model="numpy")
def lump_forces(samp_el, samp_xi, samp_F, out):
    """Sample normal forces lumped to the element's two nodes by (1 - xi, xi) (N)."""
    out[:] = 0.0
    for i in range(samp_el.shape[0]):
        e = samp_el[i]
        out[e] += (1.0 - samp_xi[i]) * samp_F[i]
        out[e + 1] += samp_xi[i] * samp_F[i]


@njit(cache=True, error_model="numpy")
def chord_lengths(q, nd, out):
    """Each element's chord |x_e - x_{e+1}| (m) into ``out`` (E,)."""
    for e in range(out.shape[0]):
        acc = 0.0
        for d in range(3):
            v = q[nd * e + d] - q[nd * (e + 1) + d]
            acc += v * v
        out[e] = math.sqrt(acc)


@njit(cache=True, error_model="numpy")
def restore_chords(q, nd, chords, rigid_el):
    """The predictor's repair (in place): each element's chord put back to ``chords`` from the
    driven end towards the tip (node e moved along x_e - x_{e+1}), then the tangents of each
    element in ``rigid_el`` along its chord (their lengths kept)."""
    ne = chords.shape[0]
    for e in range(ne - 1, -1, -1):
        acc = 0.0
        for d in range(3):
            v = q[nd * e + d] - q[nd * (e + 1) + d]
            acc += v * v
        f = chords[e] / math.sqrt(acc)
        for d in range(3):
            q[nd * e + d] = q[nd * (e + 1) + d] + f * (q[nd * e + d] - q[nd * (e + 1) + d])
    ch = np.empty(3)
    for j in range(rigid_el.shape[0]):
        e = rigid_el[j]
        acc = 0.0
        for d in range(3):
            ch[d] = q[nd * e + d] - q[nd * (e + 1) + d]
            acc += ch[d] * ch[d]
        cl = math.sqrt(acc)
        for k in (e, e + 1):
            tl = 0.0
            for d in range(3):
                tl += q[nd * k + 3 + d] * q[nd * k + 3 + d]
            tl = math.sqrt(tl)
            for d in range(3):
                q[nd * k + 3 + d] = -ch[d] / cl * tl
