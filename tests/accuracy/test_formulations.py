"""The formulation axis of the accuracy study (ringqa.accuracy.formulations)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ringqa.accuracy import compare_formulations
from ringqa.accuracy.grid import AccuracyError
from ringqa.simulation import load_scene

SCENE = "data/scenes/ring13-push100.toml"


def _fake(orders):
    """A simulator whose dwells sit at exact + c f^p (f the scene's refinement factor read
    from its increment, p the formulation's order)."""

    def sim(scene):
        f = scene.solver.increment_m / 1e-3
        p, c = orders[scene.model.formulation]
        pos = np.zeros((5, 3))
        pos[:, 0] = 1e-3 * c * f**p  # m
        return SimpleNamespace(status=0, message="", source_pos_m=pos,
                               solve_time_s=0.01 / f, n_elements=int(40 / f))  # fmt: skip

    return sim


def test_orders_and_cost_from_the_ladder():
    """Successive changes of a run converging as c f^p give the observed order p exactly:
    d_k = c (f_k^p - f_{k+1}^p), so d_k / d_{k+1} = 2^p for halving factors."""
    sc = load_scene(SCENE)
    study = compare_formulations(
        sc, (2.0, 1.0, 0.5, 0.25), target_mm=0.1,
        simulator=_fake({"rigid": (2.0, 0.1), "flexible": (1.0, 0.05)}),
    )  # fmt: skip
    assert study.orders["rigid"] == pytest.approx([2.0, 2.0])
    assert study.orders["flexible"] == pytest.approx([1.0, 1.0])
    # rigid: err at f = 1 is 0.1 (1 - 1/16) = 0.094 <= 0.1 -> x1 (0.01 s); at 2: 0.39 > 0.1
    assert study.cheapest["rigid"] == pytest.approx((1.0, 0.01))
    # flexible: err at f = 2 is 0.05 (2 - 0.25) = 0.0875 -> x2 (0.005 s)
    assert study.cheapest["flexible"] == pytest.approx((2.0, 0.005))
    # finest levels: 0.1 / 16 vs 0.05 / 4 mm along x
    assert study.finest_agreement_mm == pytest.approx(abs(0.1 / 16 - 0.05 / 4))
    assert "observed order of convergence 2.00, 2.00" in study.text()


def test_needs_two_factors():
    with pytest.raises(AccuracyError, match="two refinement factors"):
        compare_formulations(load_scene(SCENE), (1.0,), simulator=_fake({}))
