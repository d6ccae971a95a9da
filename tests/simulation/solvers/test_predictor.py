"""The load-step predictor's extrapolation (ringqa.simulation.model.Model.predict, issue 16)."""

from __future__ import annotations

import numpy as np

import ringqa.simulation.model as model_mod
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene, scene_with_overrides


def _runs(monkeypatch, scene):
    """The scene solved with the plain slide predictor (fraction 0: the predictor before the
    change, bit for bit) and as shipped."""
    monkeypatch.setattr(model_mod, "EXTRAPOLATE_FRACTION", 0.0)
    plain = simulate(scene)
    monkeypatch.undo()
    return plain, simulate(scene)


def test_extrapolation_saves_newton_iterations_at_the_same_answer(monkeypatch):
    """ring26-flexitron (quasi-static, friction, 146 load steps of 1 mm): adding half of the
    previous step's Newton correction to the slide starts each steady step in the ring closer
    to its solution. Measured 643 -> 573 iterations (0.89) and 233 -> 55 line-search halvings;
    the bound 0.95 fails for the plain slide (ratio 1). Both runs converge every step to the
    same tolerance, so the dwells agree to the solver's error, far inside the 0.01 mm the
    accuracy rule allows (measured 1.2e-7 mm).
    """
    plain, new = _runs(monkeypatch, load_scene("ring26-flexitron"))
    assert plain.status == new.status == 0
    assert new.stats.n_newton_iters <= 0.95 * plain.stats.n_newton_iters
    assert new.stats.n_halvings < plain.stats.n_halvings
    assert new.stats.n_stabilised_steps == 0
    diff_mm = np.max(np.linalg.norm(new.source_pos_m - plain.source_pos_m, axis=1)) * 1e3
    assert diff_mm < 0.01


def test_retraction_keeps_the_plain_slide(monkeypatch):
    """Retracting reverses the friction, so the previous step's correction does not carry over
    (extrapolating moved ring13's retraction dwells 0.76 mm, another branch of its buckling
    episode): backward steps use the plain slide, and the retraction after an insertion that
    did extrapolate ends where the plain predictor's run ends to round-off (the insertion's
    states agree to the Newton tolerance, ~1e-10 m; a bound of 1e-9 m = 1e-6 mm)."""
    scene = scene_with_overrides(
        load_scene("ring13-push100"),
        {"motion.kind": "retract", "motion.step_mm": 5.0, "motion.span_mm": 40.0},
    )
    plain, new = _runs(monkeypatch, scene)
    assert plain.status == new.status == 0
    assert np.nanmax(np.abs(new.source_pos_m - plain.source_pos_m)) < 1e-9
    assert new.stats.n_stabilised_steps == plain.stats.n_stabilised_steps
