"""Inextensibility: a stiff axial penalty ``EA / l`` per link (always on).

The links of the paper's rigid-link model are inextensible; a penalty with EA = 1e6 N (default
``solver.axial_stiffness_n``) stretches a link by F / EA: 1e-6 strain at 1 N push, i.e. 0.1 um over
100 mm of cable. Its influence is measured in tests/simulation/test_validation.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.simulation.band import add_block
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class AxialArgs(NamedTuple):
    """Kernel parameters: link lengths (N,) (m) and the penalty's EA (N)."""

    link_len: np.ndarray
    ea_n: float


@njit(cache=True, inline="always", error_model="numpy")
def add_axial(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`axial_kernel`."""
    return axial_kernel(q, st.nd, st.n_nodes, st.kl, p.link_len, p.ea_n, r, B, jac)


@njit(cache=True, error_model="numpy")
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


register_kernels(AxialArgs, add=add_axial)


@dataclass(frozen=True)
class Inextensibility(Effect):
    """Axial penalty stiffness EA (N) on links of the given lengths (m)."""

    name = "inextensibility"
    energy = "stored"

    link_len: np.ndarray
    ea_n: float

    @classmethod
    def build(cls, ctx: BuildContext) -> Inextensibility:
        """Always on; reads ``solver.axial_stiffness_n``."""
        ea = float(ctx.scene.solver.axial_stiffness_n)
        return cls(np.ascontiguousarray(ctx.chain.link_len, dtype=np.float64), ea)

    def args(self) -> AxialArgs:
        return AxialArgs(self.link_len, self.ea_n)
