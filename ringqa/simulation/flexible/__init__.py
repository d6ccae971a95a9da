"""The flexible engine: the instrument as flexible beam elements (``model.formulation =
"flexible"``), a second discretisation independent of the rigid links and hinge springs.

Cubic Hermite (absolute-nodal-coordinate cable) elements with nodal positions and tangents,
bending ``EI/2 int |r''|^2`` and a stiff axial penalty from the elements' strains
(:mod:`.kernels`), contact sampled along every element with the rigid engine's wall and friction
laws, quasi-static load steps with its own predictor and Newton (:mod:`.driver`). Called by
:func:`ringqa.simulation.simulate` for such scenes; returns the same
:class:`~ringqa.simulation.result.SimResult`.
"""

from ringqa.simulation.flexible.driver import FlexModel, check_supported, run_flexible
from ringqa.simulation.flexible.rod import FlexRod, build_rod, contact_samples

__all__ = [
    "FlexModel",
    "FlexRod",
    "build_rod",
    "check_supported",
    "contact_samples",
    "run_flexible",
]
