"""The effects' kernels as they were before branch kernels made them cheaper (2026-11-29, main
9f17845), kept verbatim as the reference the new kernels must reproduce bit for bit
(tests/simulation/effects/test_kernels_identical.py). Not used by ringqa."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation.band import add_block


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
