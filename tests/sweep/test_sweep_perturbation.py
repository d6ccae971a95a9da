"""The perturbation keys act on the channel and cable as documented (pipeline.uncertainty)."""

from __future__ import annotations

import numpy as np

from ringqa.io.applicator_file import load_applicator
from ringqa.pipeline.uncertainty import Perturbation, perturbed_engine, smooth_displacement


def _channel():
    app = load_applicator("ring26x60")
    return next(c for c in app.channels if c.name == "ring")


def test_lumen_diameter_key_widens_the_simulated_channel():
    """Scene key lumen.diameter_delta_mm = +0.2 mm: the channel the engine samples has r_b and
    r_a 0.1 mm = 1e-4 m larger; the scene's own channel is kept as given."""
    from ringqa.pipeline.simulate import default_engine

    eng = default_engine()
    ch = _channel()
    scene = eng.scene_with_overrides(
        eng.scene_for_channel(ch, "flexitron"), {"lumen.diameter_delta_mm": 0.2}
    )
    sim = scene.simulated_channel
    np.testing.assert_allclose(sim.lumen.seg_rb - ch.lumen.seg_rb, 1e-4, atol=1e-12)
    np.testing.assert_allclose(sim.lumen.seg_ra - ch.lumen.seg_ra, 1e-4, atol=1e-12)
    assert scene.channel is ch


def test_centreline_perturbed_as_documented():
    """A 0.3 mm displacement: the
    centreline moves across itself by 0.3 mm at most (the spline through the moved points may
    overshoot them slightly: 5 %; and reaches at least 0.28 mm) and its entry stays put."""
    ch = _channel()
    seen = {}

    def base_scene(channel, cable):
        seen["channel"] = channel
        return None

    from dataclasses import replace

    from ringqa.pipeline.simulate import default_engine

    eng = replace(default_engine(), scene_for_channel=base_scene)
    p = Perturbation(centreline_displacement_mm=0.3, shape_seed=(1, 2))
    perturbed_engine(p, eng).scene_for_channel(ch, "x")
    moved = seen["channel"].centreline
    s = np.linspace(0, ch.centreline.length_m, 400)
    diff = moved.position(s * moved.length_m / ch.centreline.length_m) - ch.centreline.position(s)
    t = ch.centreline.tangent(s)
    across = np.linalg.norm(diff - np.sum(diff * t, axis=1)[:, None] * t, axis=1)
    assert np.linalg.norm(diff[0]) < 1e-6
    # the displacement is across the channel: its largest value is the amplitude (the arc
    # length grows slightly, so points are compared at the same fraction of the length)
    assert 0.28e-3 < across.max() < 0.3e-3 * 1.05


def test_displacement_shape_is_seeded_and_normalised():
    s = np.linspace(0, 0.2, 101)
    a = smooth_displacement(s, 0.2, np.random.default_rng([3, 4]))
    b = smooth_displacement(s, 0.2, np.random.default_rng([3, 4]))
    np.testing.assert_array_equal(a, b)
    assert abs(np.linalg.norm(a, axis=1).max() - 1.0) < 1e-12
    assert np.allclose(a[[0, -1]], 0.0, atol=1e-12)


def test_ei_scale_multiplies_every_section():
    """Scene key instrument.ei_scale = 1.1: every flexible link of the engine's chain has 1.1x
    the EI of the unscaled scene's (the rigid capsule stays rigid)."""
    from ringqa.pipeline.simulate import default_engine
    from ringqa.simulation.chain import build_chain

    eng = default_engine()
    ch = _channel()
    base = eng.scene_for_channel(ch, "flexitron")
    scaled = eng.scene_with_overrides(base, {"instrument.ei_scale": 1.1})
    a = build_chain(base.instrument, 0.2).link_ei
    b = build_chain(scaled.instrument, 0.2).link_ei
    flexible = np.isfinite(a)
    assert flexible.sum() > 10 and np.array_equal(np.isfinite(b), flexible)
    np.testing.assert_allclose(b[flexible] / a[flexible], 1.1, rtol=1e-12)


def test_sample_settings_split_scene_keys_from_perturbations():
    """A sample's scene keys (lumen.diameter_delta_mm is one) go to
    CommissionSettings.scene_overrides with the fixed [set] keys; the perturbation key goes to
    the Perturbation; [settings] fields are mapped
    (sk_u -> sk_U, centreline_reference -> require_measured=False)."""
    from ringqa.sweep.runner import Job, commission_settings

    job = Job(
        "ring26x60",
        {"stem_mm": 80.0, "sk_u": 40000.0, "centreline_reference": True},
        {"solver.increment_mm": 0.5},
        ("contact.mu_k", "lumen.diameter_delta_mm", "motion.backward",
         "centreline.displacement_mm"),
        3,
    )  # fmt: skip
    settings, pert = commission_settings(job, [0.18, 0.1, True, 0.2])
    assert settings.scene_overrides == {
        "solver.increment_mm": 0.5,
        "contact.mu_k": 0.18,
        "lumen.diameter_delta_mm": 0.1,
        "motion.backward": True,
    }
    assert pert == {"centreline.displacement_mm": 0.2}
    assert (settings.stem_mm, settings.sk_U, settings.require_measured) == (80.0, 40000.0, False)
