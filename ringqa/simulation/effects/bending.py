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


@njit(cache=True, error_model="numpy")
def _links(E, LK, nl):
    """Every link's length and unit vector: ``LK[0]`` = |e|, ``LK[1:4]`` = e / |e| from the link
    vectors ``E`` (3, nl) (m) (a loop the compiler vectorises: square roots and divisions)."""
    for j in range(nl):
        e0 = E[0, j]
        e1 = E[1, j]
        e2 = E[2, j]
        L = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        LK[0, j] = L
        LK[1, j] = e0 / L
        LK[2, j] = e1 / L
        LK[3, j] = e2 / L


@njit(cache=True, error_model="numpy")
def _cos_sin(LK, CS, nh):
    """Every hinge's ``cos theta = a^.b^`` and ``sin theta = |a^ x b^|`` into ``CS`` (2, nh), from
    :func:`_links` (hinge h joins links h and h + 1; vectorised)."""
    for h in range(nh):
        ah0 = LK[1, h]
        ah1 = LK[2, h]
        ah2 = LK[3, h]
        bh0 = LK[1, h + 1]
        bh1 = LK[2, h + 1]
        bh2 = LK[3, h + 1]
        CS[0, h] = ah0 * bh0 + ah1 * bh1 + ah2 * bh2
        cx0 = ah1 * bh2 - ah2 * bh1
        cx1 = ah2 * bh0 - ah0 * bh2
        cx2 = ah0 * bh1 - ah1 * bh0
        CS[1, h] = math.sqrt(cx0 * cx0 + cx1 * cx1 + cx2 * cx2)


@njit(cache=True, error_model="numpy")
def _gradients(LK, CS, FH, hinge_k, G, nh):
    """Every hinge's gradient of ``k theta^2 / 2`` with respect to its links ``a`` and ``b``:
    ``G[0:3]`` and ``G[3:6]`` (N) (vectorised)."""
    for h in range(nh):
        k = hinge_k[h]
        c = CS[0, h]
        f = FH[0, h]
        la = LK[0, h]
        lb = LK[0, h + 1]
        for d in range(3):
            ah = LK[1 + d, h]
            bh = LK[1 + d, h + 1]
            G[d, h] = -k * f * (bh - c * ah) / la
            G[3 + d, h] = -k * f * (ah - c * bh) / lb


@njit(cache=True, error_model="numpy")
def _hinge_hessians(LK, CS, FH, hinge_k, H, nh):
    """The 27 entries of every hinge's blocks ``Haa``, ``Hbb``, ``Hab`` (rows ``3 p + m``,
    ``9 + 3 p + m``, ``18 + 3 p + m`` of ``H`` (27, nh)) from the per-link and per-hinge values
    of :func:`bending_kernel` (``u = b^ - c a^``, ``v = a^ - c b^`` recomputed as there).

    One loop over the hinges per entry, so that the compiler vectorises it (the 27 divisions a
    hinge were most of the Jacobian's arithmetic); each entry is the expression the per-hinge
    loop evaluated, in the same order, so the values are the same bit for bit.
    """
    for pp in range(3):
        for m in range(3):
            dpm = 1.0 if pp == m else 0.0
            t = 3 * pp + m
            for h in range(nh):
                k = hinge_k[h]
                f = FH[0, h]
                hh = FH[1, h]
                c = CS[0, h]
                la = LK[0, h]
                lb = LK[0, h + 1]
                app = LK[1 + pp, h]
                am = LK[1 + m, h]
                bpp = LK[1 + pp, h + 1]
                bmm = LK[1 + m, h + 1]
                upp = bpp - c * app
                um = bmm - c * am
                vpp = app - c * bpp
                vm = am - c * bmm
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

    In passes over all links or hinges (branch kernels, docs/engine.md "A cheaper iteration"):
    the link vectors, lengths and unit vectors (:func:`_links`, once a link instead of twice),
    the hinges' cos and sin (:func:`_cos_sin`), their angles (atan2) and energies, the
    gradients (:func:`_gradients`), their addition to ``r`` hinge by hinge; with ``jac`` the
    Hessian blocks (:func:`_hinge_hessians`) and their addition to ``B`` hinge by hinge. The
    passes without calls are loops the compiler vectorises (the square roots and the ~40
    divisions a hinge were most of the kernel's time).
    Every value is the same expression as in the one-pass form, and every entry of ``r`` and
    ``B`` receives the same terms in the same order, so the results are the same bit for bit
    (tests/simulation/effects/test_kernels_identical.py).
    """
    energy = 0.0
    nh = max(n_nodes - 2, 0)
    if nh == 0:
        return energy
    nl = n_nodes - 1
    E = np.empty((3, nl))
    LK = np.empty((4, nl))
    CS = np.empty((2, nh))
    FH = np.empty((2, nh))
    G = np.empty((6, nh))
    for j in range(nl):
        for d in range(3):
            E[d, j] = q[nd * (j + 1) + d] - q[nd * j + d]
    _links(E, LK, nl)
    _cos_sin(LK, CS, nh)
    for h in range(nh):
        k = hinge_k[h]
        if k == 0.0:
            FH[0, h] = 0.0
            FH[1, h] = 0.0
            continue
        th = math.atan2(CS[1, h], CS[0, h])
        energy += 0.5 * k * th * th
        f, hh = _theta_funcs(th)
        FH[0, h] = f
        FH[1, h] = hh
    _gradients(LK, CS, FH, hinge_k, G, nh)
    for h in range(nh):
        if hinge_k[h] == 0.0:
            continue
        i0 = nd * h
        i1 = i0 + nd
        i2 = i1 + nd
        for d in range(3):
            ga = G[d, h]
            gb = G[3 + d, h]
            r[i0 + d] -= ga
            r[i1 + d] += ga - gb
            r[i2 + d] += gb
    if jac:
        H = np.empty((27, nh))
        _hinge_hessians(LK, CS, FH, hinge_k, H, nh)
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
