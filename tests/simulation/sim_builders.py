"""Builders for the engine tests: exact analytic channels and simple instruments (imported by the
test modules of this folder; pytest puts the folder on sys.path)."""

from __future__ import annotations

import numpy as np

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.scene import (
    CableSection,
    ContactParams,
    Effects,
    Instrument,
    Scene,
    SolverSettings,
)


def rod(ei=5e-4, r_o=0.3e-3, element=3e-3, length=0.5, gj=4e-4, mass=0.04) -> Instrument:
    """A uniform rod (no capsule), the source centre at the tip."""
    return Instrument(
        "rod", (CableSection("rod", length, r_o, ei, gj, mass, element),), centre_from_tip_m=0.0
    )


def flexitron(l_thin=3e-3, l_thick=10e-3) -> Instrument:
    """The paper's Table 1 Flexitron cable (capsule 4.6 mm, thin 105 mm, thick 616 mm)."""
    return Instrument(
        "flexitron",
        (
            CableSection("capsule", 4.6e-3, 0.425e-3, 1.0, 1.0, 0.04, 4.6e-3, rigid=True),
            CableSection("thin", 0.105, 0.25e-3, 5.2e-5, 4.0e-5, 0.04, l_thin),
            CableSection("thick", 0.616, 0.425e-3, 1.8e-4, 1.4e-4, 0.04, l_thick),
        ),
        centre_from_tip_m=2.4e-3,
    )


def ring_channel():
    """A 13 mm-radius arc after a 50 mm straight entry, 264 degrees (the 26 mm ring's essence)."""
    return arc_channel(radius_m=0.013, angle_rad=np.deg2rad(264.0), entry_m=0.05)


def scene(channel, instrument, effects=None, contact=None, solver=None, **kw) -> Scene:
    """A Scene with defaults for the tests."""
    return Scene(
        "test",
        channel,
        instrument,
        effects=effects or Effects(friction="none"),
        contact=contact or ContactParams(),
        solver=solver or SolverSettings(),
        **kw,
    )
