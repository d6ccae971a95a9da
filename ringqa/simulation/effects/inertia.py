"""Inertia: lumped node masses (and polar inertia with torsion), implicit time stepping.

``M (q - q_hist - dt v_hist) / dt^2`` joins the residual; implicit, so neither the wall stiffness
nor the friction regularisation limits the time step (mechanics.md item 10). Backward Euler takes
``q_hist, v_hist`` at the start of the step; BDF2 the history combinations ``q_h``, ``v_h`` and the
step ``2 dt / 3`` (:mod:`ringqa.simulation.solvers.integrators`). On with the dynamic solver only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from ringqa.errors import SimulationError
from ringqa.simulation.band import badd
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class InertiaArgs(NamedTuple):
    """Kernel parameters: lumped masses (N+1,) (kg), polar inertias (N+1,) (kg m^2); ``active``
    False suspends it (the initial static equilibrium)."""

    node_mass: np.ndarray
    node_rot: np.ndarray
    active: bool


@njit(cache=True, inline="always", error_model="numpy")
def add_inertia(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: unpack and call :func:`inertia_kernel` (if active)."""
    if not p.active:
        return 0.0
    return inertia_kernel(
        q, st.q_hist, st.v_hist, st.nd, st.n_nodes, st.kl, p.node_mass, p.node_rot, st.dt, r,
        B, jac,
    )  # fmt: skip


@njit(cache=True, error_model="numpy")
def inertia_kernel(q, q_prev, v_prev, nd, n_nodes, kl, node_mass, node_rot, dt, r, B, jac):
    """Implicit inertia ``M (q - q_prev - dt v_prev) / dt^2`` (lumped masses); returns 0."""
    inv = 1.0 / (dt * dt)
    for i in range(n_nodes):
        for a in range(nd):
            m = node_mass[i] if a < 3 else node_rot[i]
            idx = nd * i + a
            r[idx] += m * (q[idx] - q_prev[idx] - dt * v_prev[idx]) * inv
            if jac:
                badd(B, kl, idx, idx, m * inv)
    return 0.0


register_kernels(InertiaArgs, add=add_inertia)


@dataclass(frozen=True)
class Inertia(Effect):
    """Lumped masses (kg) and polar inertias (kg m^2) per node."""

    name = "inertia"
    history = True

    node_mass: np.ndarray
    node_rot: np.ndarray

    @classmethod
    def build(cls, ctx: BuildContext) -> Inertia | None:
        """On with the dynamic solver (which switches it on, with a warning if the scene did
        not); ignored, with a warning, by the quasi-static solver."""
        eff = ctx.scene.effects
        if ctx.dynamic and not eff.inertia:
            ctx.warnings.append("solver.kind = 'dynamic' switches inertia on")
        if eff.inertia and not ctx.dynamic:
            ctx.warnings.append(
                "effects.inertia is on but solver.kind = 'quasistatic': inertia ignored"
            )
        if not ctx.dynamic:
            return None
        return cls.from_chain(ctx.chain)

    @classmethod
    def from_chain(cls, chain) -> Inertia:
        """Validate: every node needs a positive mass."""
        m = np.ascontiguousarray(chain.node_mass)
        if not np.all(m > 0):
            raise SimulationError(
                "instrument: inertia is on, so every section needs mass_per_length_kg_m > 0"
            )
        return cls(m, np.ascontiguousarray(chain.node_rot))

    def args(self) -> InertiaArgs:
        return InertiaArgs(self.node_mass, self.node_rot, True)

    def suspended_args(self) -> InertiaArgs:
        return InertiaArgs(self.node_mass, self.node_rot, False)
