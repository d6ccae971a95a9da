"""Torsion: one twist DOF per node, springs ``GJ / l`` per link (only with ``effects.torsion``).

The twist of an isotropic rod decouples from its centreline shape except through friction: the
contact velocity gains ``r_o dphi/dt (t x n)`` and the friction moment ``r_o (n x F_t) . t`` drives
the twist (the paper's eq. 4-5; :mod:`.friction`). The proximal end's rotation is fixed. A scene
without torsion carries no twist DOF at all (3 DOFs per node instead of 4).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.errors import SimulationError
from ringqa.simulation.band import badd
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class TorsionArgs(NamedTuple):
    """Kernel parameters: twist stiffness per link (N,) (N m / rad)."""

    twist_k: np.ndarray


@njit(cache=True, inline="always", error_model="numpy")
def add_torsion(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`torsion_kernel`."""
    return torsion_kernel(q, st.nd, st.n_nodes, st.kl, p.twist_k, r, B, jac)


@njit(cache=True, error_model="numpy")
def torsion_kernel(q, nd, n_nodes, kl, twist_k, r, B, jac):
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
            badd(B, kl, i0, i0, k)
            badd(B, kl, i1, i1, k)
            badd(B, kl, i0, i1, -k)
            badd(B, kl, i1, i0, -k)
    return energy


register_kernels(TorsionArgs, add=add_torsion)


@dataclass(frozen=True)
class Torsion(Effect):
    """Twist stiffness per link (N m / rad)."""

    name = "torsion"
    energy = "stored"

    twist_k: np.ndarray

    @classmethod
    def build(cls, ctx: BuildContext) -> Torsion | None:
        """On with ``effects.torsion``; every section then needs ``gj_nm2 > 0``."""
        if not ctx.scene.effects.torsion:
            return None
        return cls.from_chain(ctx.chain)

    @classmethod
    def from_chain(cls, chain) -> Torsion:
        """Validate the chain's twist stiffnesses (finite, > 0)."""
        k = np.ascontiguousarray(chain.twist_k, dtype=np.float64)
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise SimulationError(
                "instrument: torsion is on, so every section needs gj_nm2 > 0 (set gj_nm2)"
            )
        return cls(k)

    def args(self) -> TorsionArgs:
        return TorsionArgs(self.twist_k)
