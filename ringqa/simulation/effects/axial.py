"""Inextensibility: a stiff axial penalty ``EA / l`` per link (always on).

The links of the paper's rigid-link model are inextensible; a penalty with EA = 1e6 N (default
``solver.axial_stiffness_n``) stretches a link by F / EA: 1e-6 strain at 1 N push, i.e. 0.1 um over
100 mm of cable. Its influence is measured in tests/simulation/test_validation.py.
"""

from __future__ import annotations

from dataclasses import dataclass

from ringqa.simulation.effects.base import CPAR, positive


@dataclass(frozen=True)
class Inextensibility:
    """Axial penalty stiffness EA (N) (kernel: ``effects._kernels.add_axial``)."""

    ea_n: float

    @classmethod
    def from_scene(cls, scene) -> Inextensibility:
        """Read ``solver.axial_stiffness_n``."""
        return cls(positive("solver.axial_stiffness_n", scene.solver.axial_stiffness_n))

    def pack(self, flags, cpar) -> None:
        """Write the parameters into the kernel arrays."""
        cpar[CPAR["k_axial"]] = self.ea_n
