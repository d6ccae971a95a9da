"""Tiny scenes that touch every kernel once, so JIT time never enters ``solve_time_s``."""

from __future__ import annotations

import numpy as np

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.scene import (
    CableSection,
    Effects,
    Instrument,
    Motion,
    Scene,
    SolverSettings,
)


def tiny_scenes():
    """[(scene, advances_m)]: a 20 mm cable pushed 2 mm, with every effect on."""
    ch = arc_channel(radius_m=0.01, angle_rad=1.0, entry_m=0.01)
    inst = Instrument(
        "warmup",
        (
            CableSection("capsule", 4e-3, 0.4e-3, 1e-4, 1e-4, 0.04, 4e-3, rigid=True),
            CableSection("thin", 0.05, 0.25e-3, 5e-5, 4e-5, 0.04, 4e-3),
        ),
        centre_from_tip_m=2e-3,
    )
    base = Scene(
        "warmup",
        ch,
        inst,
        effects=Effects(
            torsion=True, friction="stribeck", wall_damping=True, gravity_m_s2=(0.0, -9.81, 0.0)
        ),
        motion=Motion(advances_m=(0.0, 0.002), speed_m_s=0.05),
        solver=SolverSettings(increment_m=1e-3, time_step_s=0.01, approach_m=0.006),
    )
    adv = np.array([0.0, 0.002])
    # BDF2 runs the same Newton kernel as backward Euler (its first step is one) plus step_work
    dyn = base.replace(solver=SolverSettings(kind="dynamic", increment_m=1e-3, time_step_s=0.01,
                                             approach_m=0.006, integrator="bdf2"))  # fmt: skip
    return [(base, adv), (dyn, adv)]
