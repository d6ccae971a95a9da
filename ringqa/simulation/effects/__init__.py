"""Physical effects, one unit each: a public class (validate, unpack) and a private kernel.

bending (always), inextensibility (always), torsion, contact, friction, wall_damping, inertia,
gravity. The kernels are in :mod:`ringqa.simulation.effects._kernels`; the assembler
(:mod:`ringqa.simulation.solvers._kernels`) calls only the kernels of the switched-on effects.
"""

from ringqa.simulation.effects.axial import Inextensibility
from ringqa.simulation.effects.bending import Bending
from ringqa.simulation.effects.contact import Contact
from ringqa.simulation.effects.friction import Friction
from ringqa.simulation.effects.gravity import Gravity
from ringqa.simulation.effects.inertia import Inertia
from ringqa.simulation.effects.torsion import Torsion
from ringqa.simulation.effects.wall_damping import WallDamping

__all__ = [
    "Bending",
    "Contact",
    "Friction",
    "Gravity",
    "Inertia",
    "Inextensibility",
    "Torsion",
    "WallDamping",
]
