"""The two engines (rigid links, flexible elements) agree on a shipped scene."""

from __future__ import annotations

import numpy as np

from ringqa.accuracy import scaled_overrides
from ringqa.simulation import load_scene, scene_with_overrides, simulate


def test_rigid_and_flexible_agree_on_ring13():
    """ring13-push100 (Flexitron, Stribeck friction, a 13 mm ring) at x0.5 of its settings
    (thin/thick links 1/5 mm, 0.5 mm increments): two discretisations that share only the
    channel and the contact/friction laws put the source within 0.05 mm of each other at all 61
    dwells (measured 0.0093 mm; each engine's own change from x1 to x0.5 is 0.026 / 0.009 mm,
    so 0.05 mm is twice their combined numerical error), and the push forces within 2 % of the
    peak (measured 0.26 %)."""
    base = load_scene("data/scenes/ring13-push100.toml")
    sc = scene_with_overrides(base, scaled_overrides(base, 0.5, 0.5))
    rr = simulate(sc)
    rf = simulate(scene_with_overrides(sc, {"model.formulation": "flexible"}))
    assert rr.success and rf.success, (rr.message, rf.message)
    d = np.linalg.norm(rr.source_pos_m - rf.source_pos_m, axis=1)
    assert np.max(d) < 0.05e-3
    peak = np.max(rr.push_force_n)
    assert np.max(np.abs(rr.push_force_n - rf.push_force_n)) < 0.02 * peak
    # the directions agree too (the capsule's axis), within 0.5 degree
    cosang = np.sum(rr.source_dir * rf.source_dir, axis=1)
    assert np.all(cosang > np.cos(np.deg2rad(0.5)))
