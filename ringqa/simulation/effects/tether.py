"""The stabilisation tether: an artificial viscosity towards the step's predictor (numerical).

``coef (x - x_ref) / dt`` on every node's position, ``x_ref`` the load step's predictor (the
previous chain slid along the channel), so steady sliding costs nothing and only departures from
it (snap-through, buckling) are damped. It is no physics: the quasi-static solver switches it on
for a step that does not converge without it (the fallback stabilisation,
:mod:`ringqa.simulation.solvers.stepper`) and on every step with ``solver.stabilisation > 0``;
every model uses it as a pseudo-time tether when the initial equilibrium needs a walk. Its work
is accounted for by the solver (``work['stabilisation']``). Dynamic steps run with it off.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from ringqa.simulation.band import badd
from ringqa.simulation.effects.base import BuildContext, Effect, register_kernels


class TetherArgs(NamedTuple):
    """Kernel parameter: viscosity coefficient (N s/m per node); 0 switches it off."""

    coef: float


@njit(cache=True, inline="always", error_model="numpy")
def add_tether(p, q, st, sw, r, B, jac):
    """The effect's uniform signature: call :func:`tether_kernel` when the tether is on
    (its coefficient scaled by ``st.floor_scale``)."""
    if p.coef == 0.0:
        return 0.0
    return tether_kernel(q, st.q_ref, st.nd, st.n_nodes, st.kl, p.coef * st.floor_scale, st.dt,
                         r, B, jac)  # fmt: skip


@njit(cache=True, error_model="numpy")
def tether_kernel(q, q_ref, nd, n_nodes, kl, coef, dt, r, B, jac):
    """``coef (x - x_ref) / dt`` on every node; returns 0."""
    for i in range(n_nodes):
        for a in range(3):
            idx = nd * i + a
            r[idx] += coef * (q[idx] - q_ref[idx]) / dt
            if jac:
                badd(B, kl, idx, idx, coef / dt)
    return 0.0


register_kernels(TetherArgs, add=add_tether)


@dataclass(frozen=True)
class Tether(Effect):
    """The always-on viscosity ``solver.stabilisation`` (N s/m; 0: only as the fallback)."""

    name = "tether"

    coef: float

    @classmethod
    def build(cls, ctx: BuildContext) -> Tether:
        """Carried by every model (the initial equilibrium may need it, the quasi-static fallback
        may switch it on); ``solver.stabilisation`` applies to quasi-static runs only."""
        return cls(0.0 if ctx.dynamic else float(ctx.scene.solver.stabilisation))

    def args(self) -> TetherArgs:
        return TetherArgs(self.coef)

    def with_coef(self, coef: float) -> TetherArgs:
        """Args with another coefficient (the fallback, the initial equilibrium's tether)."""
        return TetherArgs(float(coef))
