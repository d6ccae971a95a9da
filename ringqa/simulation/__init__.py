"""The rod-in-channel engine: a source cable pushed through an applicator channel.

``simulate(scene, advances_mm=None, progress=False) -> SimResult`` (see :mod:`.engine`); scenes
from files or channels with :func:`load_scene`, :func:`scene_for_channel`, changed with
:func:`scene_with_overrides` and written back with :func:`scene_to_dict`.
"""

from ringqa.simulation.engine import simulate
from ringqa.simulation.instruments import CABLE_PRESETS, CONTACT_PRESETS, cable_preset
from ringqa.simulation.result import SimResult
from ringqa.simulation.scene import Scene
from ringqa.simulation.scenefile import (
    load_scene,
    scene_for_channel,
    scene_to_dict,
    scene_with_overrides,
)

__all__ = [
    "CABLE_PRESETS",
    "CONTACT_PRESETS",
    "Scene",
    "SimResult",
    "cable_preset",
    "load_scene",
    "scene_for_channel",
    "scene_to_dict",
    "scene_with_overrides",
    "simulate",
]
