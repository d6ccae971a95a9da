"""Physical effects, one module each: a kernel-args named tuple, its numba kernels and a public
unit that validates the scene's values and packs the args (:mod:`.base` says how they fit).

:data:`EFFECTS` lists the units in assembly order (the order their terms are added to the
residual): inextensibility and bending (always), torsion, contact, wall damping, friction,
gravity, inertia, and the solver's stabilisation tether. A model assembles only the units whose
``build`` returns one for its scene. To add an effect: write its module (args, kernels,
``register_kernels``, a unit with ``build``/``args``) and list it here, or, from outside the
package, :func:`register_effect` it (docs/architecture.md, "How to add an effect").
"""

from __future__ import annotations

from ringqa.simulation.effects.axial import Inextensibility
from ringqa.simulation.effects.base import BuildContext, Effect, Samples, Step, register_kernels
from ringqa.simulation.effects.bending import Bending
from ringqa.simulation.effects.contact import Contact
from ringqa.simulation.effects.friction import Friction
from ringqa.simulation.effects.gravity import Gravity
from ringqa.simulation.effects.inertia import Inertia
from ringqa.simulation.effects.tether import Tether
from ringqa.simulation.effects.torsion import Torsion
from ringqa.simulation.effects.wall_damping import WallDamping

#: the effect units in assembly order (contact before wall damping before friction: damping
#: adds to the contact's normal force, friction reads it)
EFFECTS: list[type[Effect]] = [
    Inextensibility,
    Bending,
    Torsion,
    Contact,
    WallDamping,
    Friction,
    Gravity,
    Inertia,
    Tether,
]


def register_effect(unit: type[Effect], before: type[Effect] | None = Tether) -> None:
    """Add an effect unit to the assembly (by default just before the stabilisation tether).

    Parameters
    ----------
    unit : type
        A subclass of :class:`~ringqa.simulation.effects.base.Effect` whose kernels are
        registered with :func:`~ringqa.simulation.effects.base.register_kernels`.
    before : type or None
        The unit it is assembled before; None appends it.
    """
    if unit in EFFECTS:
        return
    if before is None or before not in EFFECTS:
        EFFECTS.append(unit)
    else:
        EFFECTS.insert(EFFECTS.index(before), unit)


def unregister_effect(unit: type[Effect]) -> None:
    """Remove an effect unit added with :func:`register_effect` (no-op if absent)."""
    if unit in EFFECTS:
        EFFECTS.remove(unit)


__all__ = [
    "EFFECTS",
    "Bending",
    "BuildContext",
    "Contact",
    "Effect",
    "Friction",
    "Gravity",
    "Inertia",
    "Inextensibility",
    "Samples",
    "Step",
    "Tether",
    "Torsion",
    "WallDamping",
    "register_effect",
    "register_kernels",
    "unregister_effect",
]
