"""Wall contact: the three-region Khatait law at sample points along the links.

With a = r_a - r_o, b = r_b - r_o, w = b - a and z = (d - a) / w (d: the sample's distance from
the centreline, or its equivalent for a flat side): F_n = 0 (z <= 0), k w z^2 / 2 (0 < z <= 1),
k w (z - 1/2) (z > 1); C1-continuous. The transition width is capped at
``contact.transition_max_fraction`` of the clearance b, so a tight lumen (clearance 0.05 mm) keeps
a proportionate zone (a warning says so). Links are sampled (see
:func:`ringqa.simulation.chain.contact_samples`) so no link cuts through the wall.
"""

from __future__ import annotations

from dataclasses import dataclass

from ringqa.simulation.effects.base import CPAR, FLAG, positive


@dataclass(frozen=True)
class Contact:
    """Wall stiffness k (N/m), transition width (m, <= 0: from the lumen), cap fraction."""

    stiffness_n_m: float
    transition_m: float
    max_fraction: float

    @classmethod
    def from_scene(cls, scene) -> Contact:
        """Read ``contact.*`` and validate."""
        c = scene.contact
        k = positive("contact.stiffness_n_m", c.stiffness_n_m)
        tr = -1.0 if c.transition_m is None else positive("contact.transition_m", c.transition_m)
        frac = positive("contact.transition_max_fraction", c.transition_max_fraction)
        if frac >= 1.0:
            from ringqa.errors import SceneError

            raise SceneError("contact.transition_max_fraction: must be < 1 (e.g. 0.2)")
        return cls(k, tr, frac)

    def pack(self, flags, cpar) -> None:
        """Write the parameters into the kernel arrays and switch the effect on."""
        flags[FLAG["contact"]] = 1
        cpar[CPAR["k_wall"]] = self.stiffness_n_m
        cpar[CPAR["transition"]] = self.transition_m
        cpar[CPAR["transition_max_fraction"]] = self.max_fraction
