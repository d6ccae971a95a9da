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
def _link_terms(E, link_len, ea_n, LT, nl):
    """Per link (a loop the compiler vectorises: a square root and five divisions a link):
    ``LT[0]`` = |e|, ``LT[1]`` = k = EA / l, ``LT[2]`` = |e| - l, ``LT[3]`` = k (|e| - l) / |e|,
    ``LT[4:7]`` = e / |e|, from the link vectors ``E`` (3, nl) (m)."""
    for j in range(nl):
        e0 = E[0, j]
        e1 = E[1, j]
        e2 = E[2, j]
        L = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        k = ea_n / link_len[j]
        dl = L - link_len[j]
        LT[0, j] = L
        LT[1, j] = k
        LT[2, j] = dl
        LT[3, j] = k * dl / L
        LT[4, j] = e0 / L
        LT[5, j] = e1 / L
        LT[6, j] = e2 / L


@njit(cache=True, error_model="numpy")
def axial_kernel(q, nd, n_nodes, kl, link_len, ea_n, r, B, jac):
    """Axial penalty ``k_j / 2 (|e_j| - l_j)^2`` per link (``k_j = EA / l_j``); returns the
    energy (J).

    The link stiffness ``K = k e^ e^T + k dl / L (I - e^ e^T)`` is added to the blocks (j, j),
    (j+1, j+1) with + and (j, j+1), (j+1, j) with - through the flat view of ``B`` (as
    :func:`~ringqa.simulation.band.add_block_flat`), entry by entry from scalars. The square
    roots and divisions of all links come first (:func:`_link_terms`, vectorised), then the
    energy, ``r`` and ``B`` link by link: each entry of ``r`` and ``B`` receives the same terms
    in the same order as the one-pass kernel with four ``add_block`` calls gave it, bit for bit
    (tests/simulation/effects/test_kernels_identical.py).
    """
    energy = 0.0
    nl = n_nodes - 1
    if nl <= 0:
        return energy
    E = np.empty((3, nl))
    LT = np.empty((7, nl))
    for j in range(nl):
        for d in range(3):
            E[d, j] = q[nd * (j + 1) + d] - q[nd * j + d]
    _link_terms(E, link_len, ea_n, LT, nl)
    for j in range(nl):
        k = LT[1, j]
        dl = LT[2, j]
        energy += 0.5 * k * dl * dl
        f = LT[3, j]
        i0 = nd * j
        i1 = nd * (j + 1)
        for d in range(3):
            g = f * E[d, j]
            r[i0 + d] -= g
            r[i1 + d] += g
    if not jac:
        return energy
    W = B.shape[1]
    Bf = B.reshape(-1)
    step = np.uint64(W - 1)
    En = np.uint64(nd)
    for j in range(nl):
        k = LT[1, j]
        c2 = LT[3, j]  # k dl / L, the same expression as the force factor
        n0 = LT[4, j]
        n1 = LT[5, j]
        n2 = LT[6, j]
        i0 = nd * j
        i1 = nd * (j + 1)
        for a in range(3):
            ea = n0 if a == 0 else (n1 if a == 1 else n2)
            # B[i0 + a, kl + i0 + b - i0 - a] and B[i1 + a, ...] through the flat view
            base0 = np.uint64(i0 + a) * step + np.uint64(kl + i0)
            base1 = np.uint64(i1 + a) * step + np.uint64(kl + i0)
            for b in range(3):
                eb = n0 if b == 0 else (n1 if b == 1 else n2)
                K = k * ea * eb + c2 * ((1.0 if a == b else 0.0) - ea * eb)
                ob = np.uint64(b)
                Bf[base0 + ob] += 1.0 * K  # (j, j)
                Bf[base1 + En + ob] += 1.0 * K  # (j + 1, j + 1)
                Bf[base0 + En + ob] += -1.0 * K  # (j, j + 1)
                Bf[base1 + ob] += -1.0 * K  # (j + 1, j)
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
