"""A run that would take an absurd number of steps is refused before it starts (issue 18).

Quasi-static: 100 mm of push at 0.0005 mm increments = 200 000 steps > MAX_STEPS (100 000):
refused, naming the setting, the step count and a value that fits (0.001 mm). Dynamic: 100 mm
at 0.5 m/s is 0.2 s of motion (+ ramps); at 1e-6 s steps that is > 200 000 steps: refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.errors import RingQAError
from ringqa.simulation import simulate
from ringqa.simulation.scene import SolverSettings
from ringqa.simulation.solvers.driver import MAX_STEPS
from tests.simulation.builders import flexitron, ring_channel, scene


@pytest.fixture(scope="module")
def ring():
    return ring_channel()


def test_a_quasi_static_run_beyond_the_budget_is_refused(ring):
    sc = scene(ring, flexitron(), solver=SolverSettings(increment_m=0.5e-6))
    with pytest.raises(RingQAError) as err:
        simulate(sc, np.array([100.0]))
    msg = str(err.value)
    assert "solver.increment_mm = 0.0005 mm" in msg
    assert f"{MAX_STEPS:,}" in msg and ">= 0.001" in msg


def test_a_dynamic_run_beyond_the_budget_is_refused(ring):
    sc = scene(ring, flexitron(), solver=SolverSettings(kind="dynamic", time_step_s=1e-6))
    with pytest.raises(RingQAError, match=r"solver.time_step_s = 1e-06 s: the run would take"):
        simulate(sc, np.array([100.0]))


def test_a_run_within_the_budget_starts(ring):
    """1 mm increments over 100 mm: 100 steps, far inside the budget, and the run succeeds."""
    res = simulate(scene(ring, flexitron()), np.array([100.0]))
    assert res.success
