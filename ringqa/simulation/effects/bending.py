"""Bending: hinge springs ``k theta^2 / 2`` between the links (always on; mechanics.md item 9).

``theta_i`` is the angle between consecutive links; ``k = 1 / (l1 / (2 EI1) + l2 / (2 EI2))`` (the
moment is continuous across a section joint: ``EI / l`` for equal links), and at the clamp (the
driven last link) ``2 EI / l``. Gradient and Hessian are exact (f = theta / sin theta,
h = (sin - theta cos) / sin^3, series near 0), checked by finite differences in
tests/simulation/effects/test_jacobians.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.errors import SimulationError
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class BendingArgs(NamedTuple):
    """Kernel parameters: hinge stiffness at the interior nodes 1..N-1 (N-1,) (N m/rad)."""

    hinge_k: np.ndarray


@njit(cache=True, error_model="numpy")
def _theta_funcs(th):
    """f = theta / sin(theta) and h = (sin - theta cos) / sin^3 (smooth at theta = 0)."""
    if th < 1e-4:
        t2 = th * th
        return 1.0 + t2 / 6.0, 1.0 / 3.0 + 2.0 * t2 / 15.0
    s = math.sin(th)
    c = math.cos(th)
    return th / s, (s - th * c) / (s * s * s)


#: rows of the per-hinge values :func:`bending_kernel` keeps for the Jacobian (one column a hinge)
_U, _V, _AH, _BH, _C, _F, _HH, _K, _LA, _LB = 0, 3, 6, 9, 12, 13, 14, 15, 16, 17
_NX = 18


@njit(cache=True, error_model="numpy")
def _hinge_hessians(X, H, nh):
    """The 27 entries of every hinge's blocks ``Haa``, ``Hbb``, ``Hab`` (rows ``3 p + m``,
    ``9 + 3 p + m``, ``18 + 3 p + m`` of ``H`` (27, nh)) from its values in ``X`` (18, nh).

    One loop over the hinges per entry, so that the compiler vectorises it (the 27 divisions a
    hinge were most of the Jacobian's arithmetic); each entry is the expression the per-hinge
    loop evaluated, in the same order, so the values are the same bit for bit.
    """
    for pp in range(3):
        for m in range(3):
            dpm = 1.0 if pp == m else 0.0
            t = 3 * pp + m
            for h in range(nh):
                k = X[_K, h]
                f = X[_F, h]
                hh = X[_HH, h]
                c = X[_C, h]
                la = X[_LA, h]
                lb = X[_LB, h]
                upp = X[_U + pp, h]
                um = X[_U + m, h]
                vpp = X[_V + pp, h]
                vm = X[_V + m, h]
                app = X[_AH + pp, h]
                am = X[_AH + m, h]
                bpp = X[_BH + pp, h]
                bmm = X[_BH + m, h]
                H[t, h] = (
                    k * (hh * upp * um + f * (upp * am + app * um) + f * c * (dpm - app * am))
                ) / (la * la)
                H[9 + t, h] = (
                    k * (hh * vpp * vm + f * (vpp * bmm + bpp * vm) + f * c * (dpm - bpp * bmm))
                ) / (lb * lb)
                H[18 + t, h] = (k * (hh * upp * vm - f * (dpm - bpp * bmm - app * vm))) / (la * lb)


@njit(cache=True, inline="always", error_model="numpy")
def _add_hinge_blocks(Bf, W, kl, nd, n0, H, h):
    """Add hinge ``h``'s Jacobian (``Haa = H[0:9, h]``, ``Hbb = H[9:18, h]``, ``Hab =
    H[18:27, h]``, row-major 3x3) to the nodes ``n0, n0 + 1, n0 + 2`` (through the flat view
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
    e2 = np.uint64(2 * nd)
    c0 = np.uint64(kl + nd * n0)
    for a in range(3):
        # the rows (n0, a), (n1, a), (n2, a) from column (n0, 0) on: three blocks side by side
        r0 = np.uint64(nd * n0 + a) * step + c0
        r1 = np.uint64(nd * (n0 + 1) + a) * step + c0
        r2 = np.uint64(nd * (n0 + 2) + a) * step + c0
        for b in range(3):
            haa = H[3 * a + b, h]
            hbb = H[9 + 3 * a + b, h]
            hab = H[18 + 3 * a + b, h]
            hba = H[18 + 3 * b + a, h]
            ob = np.uint64(b)
            # x + (-1.0 * y) is x - y, bit for bit
            Bf[r0 + ob] += haa
            Bf[r0 + e + ob] = (Bf[r0 + e + ob] - haa) + hab
            Bf[r0 + e2 + ob] -= hab
            Bf[r1 + ob] = (Bf[r1 + ob] - haa) + hba
            Bf[r1 + e + ob] = (((Bf[r1 + e + ob] + haa) - hab) - hba) + hbb
            Bf[r1 + e2 + ob] = (Bf[r1 + e2 + ob] + hab) - hbb
            Bf[r2 + ob] -= hba
            Bf[r2 + e + ob] = (Bf[r2 + e + ob] + hba) - hbb
            Bf[r2 + e2 + ob] += hbb


@njit(cache=True, inline="always", error_model="numpy")
def add_bending(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`bending_kernel`."""
    return bending_kernel(q, st.nd, st.n_nodes, st.kl, p.hinge_k, r, B, jac)


@njit(cache=True, error_model="numpy")
def bending_kernel(q, nd, n_nodes, kl, hinge_k, r, B, jac):
    """Hinge bending energy ``k_i theta_i^2 / 2`` at every interior node; returns the energy.

    ``theta_i`` is the angle between links ``a = x_i - x_{i-1}`` and ``b = x_{i+1} - x_i``.

    Three passes (branch kernels, docs/engine.md "A cheaper iteration"): the residual hinge by
    hinge, keeping with ``jac`` each hinge's values in a (18, hinges) table; the Hessian blocks
    of all hinges (:func:`_hinge_hessians`, vectorised); their addition to ``B`` hinge by hinge.
    Every value is the same expression as in the one-pass form, and every entry of ``r`` and
    ``B`` receives the same terms in the same order, so the results are the same bit for bit
    (tests/simulation/effects/test_kernels_identical.py).
    """
    energy = 0.0
    nh = max(n_nodes - 2, 0)
    if jac:
        X = np.empty((_NX, nh))
        H = np.empty((27, nh))
    else:
        X = np.empty((0, 0))
        H = X
    for i in range(1, n_nodes - 1):
        h = i - 1
        k = hinge_k[h]
        if k == 0.0:
            if jac:
                for t in range(_NX):
                    X[t, h] = 0.0
            continue
        i0 = nd * (i - 1)
        i1 = nd * i
        i2 = nd * (i + 1)
        a0 = q[i1] - q[i0]
        a1 = q[i1 + 1] - q[i0 + 1]
        a2 = q[i1 + 2] - q[i0 + 2]
        b0 = q[i2] - q[i1]
        b1 = q[i2 + 1] - q[i1 + 1]
        b2 = q[i2 + 2] - q[i1 + 2]
        la = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        lb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        ah0 = a0 / la
        ah1 = a1 / la
        ah2 = a2 / la
        bh0 = b0 / lb
        bh1 = b1 / lb
        bh2 = b2 / lb
        c = ah0 * bh0 + ah1 * bh1 + ah2 * bh2
        cx0 = ah1 * bh2 - ah2 * bh1
        cx1 = ah2 * bh0 - ah0 * bh2
        cx2 = ah0 * bh1 - ah1 * bh0
        sn = math.sqrt(cx0 * cx0 + cx1 * cx1 + cx2 * cx2)
        th = math.atan2(sn, c)
        energy += 0.5 * k * th * th
        f, hh = _theta_funcs(th)
        u0 = bh0 - c * ah0
        u1 = bh1 - c * ah1
        u2 = bh2 - c * ah2
        v0 = ah0 - c * bh0
        v1 = ah1 - c * bh1
        v2 = ah2 - c * bh2
        # gradients wrt a and b of theta^2 / 2
        ga = -k * f * u0 / la
        gb = -k * f * v0 / lb
        r[i0] -= ga
        r[i1] += ga - gb
        r[i2] += gb
        ga = -k * f * u1 / la
        gb = -k * f * v1 / lb
        r[i0 + 1] -= ga
        r[i1 + 1] += ga - gb
        r[i2 + 1] += gb
        ga = -k * f * u2 / la
        gb = -k * f * v2 / lb
        r[i0 + 2] -= ga
        r[i1 + 2] += ga - gb
        r[i2 + 2] += gb
        if jac:
            X[_U, h] = u0
            X[_U + 1, h] = u1
            X[_U + 2, h] = u2
            X[_V, h] = v0
            X[_V + 1, h] = v1
            X[_V + 2, h] = v2
            X[_AH, h] = ah0
            X[_AH + 1, h] = ah1
            X[_AH + 2, h] = ah2
            X[_BH, h] = bh0
            X[_BH + 1, h] = bh1
            X[_BH + 2, h] = bh2
            X[_C, h] = c
            X[_F, h] = f
            X[_HH, h] = hh
            X[_K, h] = k
            X[_LA, h] = la
            X[_LB, h] = lb
    if jac and nh > 0:
        _hinge_hessians(X, H, nh)
        W = B.shape[1]
        Bf = B.reshape(-1)
        # nodes: x_{i-1} = -a, x_i = +a - b, x_{i+1} = +b
        for h in range(nh):
            if hinge_k[h] != 0.0:
                _add_hinge_blocks(Bf, W, kl, nd, h, H, h)
    return energy


register_kernels(BendingArgs, add=add_bending)


@dataclass(frozen=True)
class Bending(Effect):
    """Hinge stiffnesses at the interior nodes (N-1,) (N m / rad), the clamp's included."""

    name = "bending"
    energy = "stored"

    hinge_k: np.ndarray

    @classmethod
    def build(cls, ctx: BuildContext) -> Bending:
        """Always on: the chain's hinge stiffnesses with the clamped end's ``2 EI / l``."""
        return cls.from_chain(ctx.chain)

    @classmethod
    def from_chain(cls, chain, clamped_end: bool = True) -> Bending:
        """Validate the chain's hinge stiffnesses (finite, >= 0).

        With ``clamped_end`` the last link is held by the driver (rigid), so the hinge at the clamp
        has only the free half-link's compliance: ``k = 2 EI / l`` (this makes the cantilever
        converge at second order in l instead of first).
        """
        k = np.array(chain.hinge_k, dtype=np.float64)
        if clamped_end and k.size:
            k[-1] = 2.0 * chain.link_ei[-2] / chain.link_len[-2]
        if not np.all(np.isfinite(k)) or np.any(k < 0):
            raise SimulationError(
                "instrument: hinge stiffness must be finite and >= 0 (check ei_nm2)"
            )
        return cls(k)

    def args(self) -> BendingArgs:
        return BendingArgs(self.hinge_k)
