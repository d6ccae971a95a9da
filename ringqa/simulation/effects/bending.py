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


@njit(cache=True, inline="always", error_model="numpy")
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


@njit(cache=True, inline="always", error_model="numpy")
def add_bending(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`bending_kernel`."""
    return bending_kernel(q, st.nd, st.n_nodes, st.kl, p.hinge_k, r, B, jac)


@njit(cache=True, error_model="numpy")
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
