"""Inertia: lumped node masses (and polar inertia with torsion), backward-Euler time stepping.

``M (q - q_prev - dt v_prev) / dt^2`` joins the residual; implicit, so neither the wall stiffness
nor the friction regularisation limits the time step (mechanics.md item 10). The BDF2 integrator
uses the same term with the history combinations ``q_h``, ``v_h`` and the step ``2 dt / 3``
(``ringqa.simulation.solvers.driver.bdf2_history``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import SimulationError
from ringqa.simulation.effects.base import FLAG


@dataclass(frozen=True)
class Inertia:
    """Lumped masses (kg) and polar inertias (kg m^2) per node."""

    node_mass: np.ndarray
    node_rot: np.ndarray

    @classmethod
    def from_chain(cls, chain) -> Inertia:
        """Validate: every node needs a positive mass."""
        m = np.ascontiguousarray(chain.node_mass)
        if not np.all(m > 0):
            raise SimulationError(
                "instrument: inertia is on, so every section needs mass_per_length_kg_m > 0"
            )
        return cls(m, np.ascontiguousarray(chain.node_rot))

    def pack(self, flags, cpar) -> None:
        """Switch the effect on in the kernel arrays."""
        flags[FLAG["inertia"]] = 1
