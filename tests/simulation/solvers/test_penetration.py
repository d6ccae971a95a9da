"""Penetration into the wall: a warning above 10 % of the clearance, a failed run when the
instrument's axis leaves the lumen (penetration beyond its radius).

The ring scene with a wall 1000x softer than the default (100 N/m): the cable, pushed round the
13 mm ring, sinks 2.4 mm into the wall, more than its 0.425 mm radius: the positions are not in
the lumen, so the run fails (status -1) and says why. With the default wall
(1e5 N/m) the same run succeeds without a penetration warning.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.simulation import simulate
from ringqa.simulation.scene import ContactParams
from tests.simulation.builders import flexitron, ring_channel, scene

ADV = np.array([100.0])


@pytest.fixture(scope="module")
def ring():
    return ring_channel()


def test_a_wall_the_cable_sinks_through_fails_the_run(ring):
    res = simulate(scene(ring, flexitron(), contact=ContactParams(stiffness_n_m=100.0)), ADV)
    assert res.status == -1
    assert "more than its" in res.message and "left the lumen" in res.message
    assert res.max_penetration_m > 1.0e-3


def test_the_default_wall_holds(ring):
    res = simulate(scene(ring, flexitron()), ADV)
    assert res.status == 0
    assert not any("sank" in w for w in res.warnings)
