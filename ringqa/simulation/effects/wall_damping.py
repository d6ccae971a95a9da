"""Wall damping: ``c_w (3 - 2z) z^2 v_n`` in the transition zone, ``c_w v_n`` beyond (Khatait).

The total normal force (elastic + damping) is clamped at zero: the wall never pulls (the paper's
MATLAB code does not clamp, which makes a "sticky" wall). v_n is the change of the sample's
centre distance over the step divided by the step time.
"""

from __future__ import annotations

from dataclasses import dataclass

from ringqa.simulation.effects.base import CPAR, FLAG, positive


@dataclass(frozen=True)
class WallDamping:
    """Wall damping coefficient c_w (N s/m)."""

    c_w: float

    @classmethod
    def from_scene(cls, scene) -> WallDamping:
        """Read ``contact.damping_ns_m``."""
        return cls(positive("contact.damping_ns_m", scene.contact.damping_ns_m, allow_zero=True))

    def pack(self, flags, cpar) -> None:
        """Write the parameter into the kernel arrays and switch the effect on."""
        flags[FLAG["wall_damping"]] = 1
        cpar[CPAR["c_w"]] = self.c_w
