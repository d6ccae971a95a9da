"""Gravity: the weight of each lumped node mass, ``g`` given in the channel's frame (m/s^2)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import SceneError
from ringqa.simulation.effects.base import FLAG


@dataclass(frozen=True)
class Gravity:
    """Gravity vector (3,) in m/s^2."""

    g: np.ndarray

    @classmethod
    def from_scene(cls, scene) -> Gravity | None:
        """Read ``effects.gravity_m_s2`` (None: off)."""
        g = scene.effects.gravity_m_s2
        if g is None:
            return None
        arr = np.asarray(g, dtype=float)
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise SceneError(
                "effects.gravity: expected three finite numbers (m/s^2), e.g. [0, -9.81, 0]"
            )
        return cls(arr)

    def pack(self, flags, cpar) -> None:
        """Switch the effect on in the kernel arrays."""
        flags[FLAG["gravity"]] = 1
