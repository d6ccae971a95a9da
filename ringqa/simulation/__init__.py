"""The rod-in-channel engine: a source cable pushed through an applicator channel."""

from ringqa.simulation.instruments import CABLE_PRESETS, CONTACT_PRESETS, cable_preset
from ringqa.simulation.scene import Scene

__all__ = ["CABLE_PRESETS", "CONTACT_PRESETS", "Scene", "cable_preset"]
