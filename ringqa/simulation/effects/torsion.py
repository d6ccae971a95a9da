"""Torsion: one twist DOF per node, springs ``GJ / l`` per link (only with ``effects.torsion``).

The twist of an isotropic rod decouples from its centreline shape except through friction: the
contact velocity gains ``r_o dphi/dt (t x n)`` and the friction moment ``r_o (n x F_t) . t`` drives
the twist (the paper's eq. 4-5). The proximal end's rotation is fixed. A scene without torsion
carries no twist DOF at all (3 DOFs per node instead of 4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import SimulationError
from ringqa.simulation.effects.base import FLAG


@dataclass(frozen=True)
class Torsion:
    """Twist stiffness per link (N m / rad) (kernel: ``effects._kernels.add_torsion``)."""

    twist_k: np.ndarray

    @classmethod
    def from_chain(cls, chain) -> Torsion:
        """Validate the chain's twist stiffnesses (finite, > 0)."""
        k = np.ascontiguousarray(chain.twist_k, dtype=np.float64)
        if not np.all(np.isfinite(k)) or np.any(k <= 0):
            raise SimulationError(
                "instrument: torsion is on, so every section needs gj_nm2 > 0 (set gj_nm2)"
            )
        return cls(k)

    def pack(self, flags, cpar) -> None:
        """Switch the effect on in the kernel arrays."""
        flags[FLAG["torsion"]] = 1
