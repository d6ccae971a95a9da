"""Gravity: the weight of each lumped node mass, ``g`` given in the channel's frame (m/s^2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class GravityArgs(NamedTuple):
    """Kernel parameters: lumped node masses (N+1,) (kg) and the gravity vector (3,) (m/s^2)."""

    node_mass: np.ndarray
    g: np.ndarray


@njit(cache=True, inline="always", error_model="numpy")
def add_gravity(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`gravity_kernel`."""
    return gravity_kernel(q, st.nd, st.n_nodes, p.node_mass, p.g, r)


@njit(cache=True, error_model="numpy")
def gravity_kernel(q, nd, n_nodes, node_mass, g, r):
    """Weight ``m_i g`` on every node (no stiffness); returns the potential ``-sum m g.x`` (J)."""
    energy = 0.0
    for i in range(n_nodes):
        for a in range(3):
            r[nd * i + a] -= node_mass[i] * g[a]
            energy -= node_mass[i] * g[a] * q[nd * i + a]
    return energy


register_kernels(GravityArgs, add=add_gravity)


@dataclass(frozen=True)
class Gravity(Effect):
    """Gravity vector (3,) in m/s^2 acting on the node masses (kg)."""

    name = "gravity"
    energy = "stored"

    node_mass: np.ndarray
    g: np.ndarray

    @classmethod
    def build(cls, ctx: BuildContext) -> Gravity | None:
        """On when ``effects.gravity_m_s2`` is set (None: off)."""
        g = ctx.scene.effects.gravity_m_s2
        if g is None:
            return None
        arr = np.asarray(g, dtype=float)
        return cls(np.ascontiguousarray(ctx.chain.node_mass, dtype=np.float64), arr)

    def args(self) -> GravityArgs:
        return GravityArgs(self.node_mass, self.g)
