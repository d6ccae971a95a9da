"""Bending: hinge springs ``EI / l`` between the links (always on; mechanics.md item 9)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import SimulationError


@dataclass(frozen=True)
class Bending:
    """Hinge bending energy ``k_i theta_i^2 / 2`` (kernel: ``effects._kernels.add_bending``).

    Attributes
    ----------
    hinge_k : (N-1,) float64
        Hinge stiffness at the interior nodes (N m / rad), from
        :func:`~ringqa.simulation.chain.build_chain`.
    """

    hinge_k: np.ndarray

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
