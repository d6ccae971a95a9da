"""``model.formulation``: the scene key (file, ``--set``, round trip) and the dispatch."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.errors import SceneError
from ringqa.simulation import load_scene, scene_to_dict, scene_with_overrides, simulate
from ringqa.simulation.scenefile import load_scene as load

SCENE = "data/scenes/arc-frictionless.toml"


def test_default_is_rigid_and_not_written():
    sc = load_scene(SCENE)
    assert sc.model.formulation == "rigid"
    assert "model" not in scene_to_dict(sc)


def test_set_flexible_round_trips():
    sc = load(SCENE, overrides={"model.formulation": "flexible"})
    assert sc.model.formulation == "flexible"
    d = scene_to_dict(sc)
    assert d["model"] == {"formulation": "flexible"}
    again = scene_with_overrides(sc, {"solver.increment_mm": 0.25})
    assert again.model.formulation == "flexible"


def test_unknown_formulation_names_the_key():
    with pytest.raises(SceneError, match=r"model\.formulation.*rigid, flexible"):
        load(SCENE, overrides={"model.formulation": "floppy"})


@pytest.mark.parametrize(
    "over, key",
    [
        ({"effects.wall_damping": True}, "effects.wall_damping"),
        ({"solver.kind": "dynamic"}, "solver.kind"),
        ({"solver.stabilisation": 1e-3}, "solver.stabilisation"),
    ],
)
def test_unsupported_effects_are_refused_by_name(over, key):
    """The flexible engine never silently ignores an effect it does not model."""
    sc = load(SCENE, overrides={"model.formulation": "flexible", **over})
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        simulate(sc, advances_mm=[20.0])


def test_simulate_dispatches_to_the_flexible_engine():
    sc = load(SCENE, overrides={"model.formulation": "flexible"})
    res = simulate(sc, advances_mm=[10.0, 20.0])
    assert res.success, res.message
    assert res.settings["formulation"] == "flexible"
    assert res.settings["dof_per_node"] == 6
    # still in the straight entry: the rod lies on the centreline, pushed by nothing
    assert np.all(np.abs(res.push_force_n) < 1e-6)
    assert np.all(res.offset_m < 1e-9)


def test_trajectory_is_refused_by_name():
    sc = load(SCENE, overrides={"model.formulation": "flexible", "outputs.trajectory": True})
    with pytest.raises(SceneError, match=r"outputs\.trajectory"):
        simulate(sc, advances_mm=[20.0])


def test_a_push_force_above_the_limit_is_a_jam():
    """arc-frictionless peaks at 0.61 N; with solver.jam_force_n = 0.2 N the run ends jammed
    (status 1, never an exception) with NaN rows for the advances not reached, as the rigid
    engine reports it."""
    sc = load(SCENE, overrides={"model.formulation": "flexible", "solver.jam_force_n": 0.2})
    res = simulate(sc, advances_mm=[35.0, 70.0])
    assert res.status == 1, res.message
    assert "jam_force_n" in res.message
    assert np.isfinite(res.push_force_n[0]) and np.isnan(res.push_force_n[-1])
