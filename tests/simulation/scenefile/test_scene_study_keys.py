"""instrument.ei_scale and lumen.diameter_delta_mm are ordinary scene keys: scene files, --set,
the configuration's [scene] table; the engine sees the scaled EI and the widened lumen."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.config import read_config_file
from ringqa.errors import SceneError
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene, scene_to_dict, scene_with_overrides


def test_keys_round_trip_through_the_writer():
    """Written and read back, a scene keeps ei_scale 1.25 and +0.3 mm once (not twice): the
    simulated channel's r_b is the applicator's + 0.15 mm."""
    base = load_scene("ring26-flexitron")
    scene = scene_with_overrides(
        base, {"instrument.ei_scale": 1.25, "lumen.diameter_delta_mm": 0.3}
    )
    again = load_scene(scene_to_dict(scene))
    assert again.instrument.ei_scale == 1.25
    np.testing.assert_allclose(
        again.simulated_channel.lumen.seg_rb - base.channel.lumen.seg_rb, 0.15e-3, atol=1e-12
    )
    # sections keep their own EI; the factor is applied once, by the engine
    assert again.instrument.sections[1].ei_nm2 == base.instrument.sections[1].ei_nm2
    assert "ei_scale" not in scene_to_dict(base)["instrument"]  # default: files unchanged
    assert "lumen" not in scene_to_dict(base)


def test_bad_values_refused_by_name():
    with pytest.raises(SceneError, match=r"instrument\.ei_scale: .*> 0"):
        load_scene("ring26-flexitron", {"instrument.ei_scale": 0.0})
    with pytest.raises(SceneError, match=r"lumen\.diameter_delta_mm"):
        load_scene("ring26-flexitron", {"lumen.diameter_delta_mm": -5.0})
    with pytest.raises(SceneError, match=r"lumen\.nope: unknown key"):
        load_scene("ring26-flexitron", {"lumen.nope": 1.0})


def test_configuration_scene_table_accepts_them(tmp_path):
    cfg = tmp_path / "cable.toml"
    cfg.write_text("[scene]\ninstrument.ei_scale = 1.2\nlumen.diameter_delta_mm = 0.1\n")
    assert read_config_file(cfg) == {
        "scene.instrument.ei_scale": 1.2,
        "scene.lumen.diameter_delta_mm": 0.1,
    }


def test_engine_uses_the_scaled_ei():
    """EI x 2 through the key gives bit for bit the run of a scene whose sections carry 2 EI
    (the engine multiplies the same two numbers), and a different run from the nominal one."""
    from dataclasses import replace

    base = load_scene("ring26-flexitron", {"motion.advances_mm": [120.0, 140.0]})
    keyed = scene_with_overrides(base, {"instrument.ei_scale": 2.0})
    inst = base.instrument
    doubled = base.replace(instrument=replace(inst, sections=tuple(
        replace(s, ei_nm2=s.ei_nm2 * 2.0) for s in inst.sections)))  # fmt: skip
    a, b, c = simulate(keyed), simulate(doubled), simulate(base)
    np.testing.assert_array_equal(a.source_pos_m, b.source_pos_m)
    assert np.max(np.abs(a.source_pos_m - c.source_pos_m)) > 1e-6


def test_flexible_engine_uses_the_scaled_ei_and_widened_lumen():
    """The flexible formulation honours both keys as the rigid one does: EI x 2 through the key
    equals sections carrying 2 EI bit for bit; +0.2 mm of lumen moves the dwells."""
    from dataclasses import replace

    base = load_scene("ring26-flexitron", {"motion.advances_mm": [120.0, 140.0],
                                           "model.formulation": "flexible"})  # fmt: skip
    keyed = scene_with_overrides(base, {"instrument.ei_scale": 2.0})
    inst = base.instrument
    doubled = base.replace(instrument=replace(inst, sections=tuple(
        replace(s, ei_nm2=s.ei_nm2 * 2.0) for s in inst.sections)))  # fmt: skip
    np.testing.assert_array_equal(simulate(keyed).source_pos_m, simulate(doubled).source_pos_m)
    wide = scene_with_overrides(base, {"lumen.diameter_delta_mm": 0.2})
    assert np.max(np.abs(simulate(wide).source_pos_m - simulate(base).source_pos_m)) > 1e-6
