"""Builders for the engine tests: exact analytic channels and simple instruments (import them as
``from tests.simulation.builders import rod, scene``)."""

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


def model(sc, advance_m: float):
    """The engine's assembled problem for scene ``sc`` reaching ``advance_m`` (m)."""
    from ringqa.simulation.model import Model

    return Model(sc, np.array([advance_m]))


def assemble_at(m, effects, q, st, jac=True, fresh=True):
    """Residual (n_all,) and banded Jacobian of ``effects`` at ``q`` (fresh work arrays; the
    model's samples and energies are updated as the engine would)."""
    from ringqa.simulation.effects.base import is_cacheable
    from ringqa.simulation.solvers.assemble import assemble
    from ringqa.simulation.solvers.newton import assemble_uncached

    r = np.zeros(m.n_all)
    B = np.zeros_like(m.B)
    energies = m.energies if len(effects) == len(m.energies) else np.zeros(len(effects))
    fn = assemble if is_cacheable(effects) else assemble_uncached
    fn(effects, q, st, m.samples, r, B, jac, fresh, energies)
    return r, B


def dense(m, B, n):
    """The leading n x n block of a banded Jacobian as a dense matrix."""
    J = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - m.kl), min(n, i + m.kl + 1)):
            J[i, j] = B[i, m.kl + j - i]
    return J
