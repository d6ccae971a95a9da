"""Gravity: the weight of each lumped node mass, ``g`` given in the channel's frame (m/s^2)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.errors import SceneError
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class GravityArgs(NamedTuple):
    """Kernel parameters: lumped node masses (N+1,) (kg) and the gravity vector (3,) (m/s^2)."""

    node_mass: np.ndarray
    g: np.ndarray


@njit(cache=True)
def add_gravity(p, q, st, sw, r, B, jac):
    """Weight ``m_i g`` on every node (no stiffness); returns the potential ``-sum m g.x`` (J)."""
    nd = st.nd
    node_mass = p.node_mass
    g = p.g
    energy = 0.0
    for i in range(st.n_nodes):
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
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise SceneError(
                "effects.gravity: expected three finite numbers (m/s^2), e.g. [0, -9.81, 0]"
            )
        return cls(np.ascontiguousarray(ctx.chain.node_mass, dtype=np.float64), arr)

    def args(self) -> GravityArgs:
        return GravityArgs(self.node_mass, self.g)
