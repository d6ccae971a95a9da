"""The needle scene: the shipped settings, the depth mapping, the clamped free length and the
checks on a channel before it runs (Must-show 5's physics side)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from ringqa.geometry import Centreline, Channel, Lumen, s_channel, s_channel_layout
from ringqa.geometry.s_channel import s_centreline_mm
from ringqa.needle.scene import (
    ChannelSpec,
    NeedleError,
    check_spec,
    depth_grid_mm,
    min_passable_radius_mm,
    needle_scene,
)
from ringqa.simulation import simulate
from ringqa.units import m_to_mm


def test_shipped_scene_holds_the_paper_channel(repo_root, needle_settings):
    """data/scenes/needle-paper.toml carries the points s_channel(35, 0, 2.6) interpolates
    (every 0.25 mm, to 1e-6 mm) and the 2.6 mm lumen (r_b 1.3, r_a 1.2 mm); its settings are the
    catheter preset at 5 mm/s, 0.825 mm links (cut to 120/146 = 0.822 mm), 0.25 mm increments."""
    data = tomllib.loads((repo_root / "data" / "scenes" / "needle-paper.toml").read_text())
    pts = np.asarray(data["channel"]["centreline_mm"])
    expected = s_centreline_mm(s_channel_layout(35.0, 0.0, 2.6), 0.25)
    assert pts.shape == expected.shape
    assert np.abs(pts - expected).max() < 1e-6
    assert (data["channel"]["r_b_mm"], data["channel"]["r_a_mm"]) == (1.3, 1.2)
    s = needle_settings
    assert s.instrument.name == "catheter"
    assert m_to_mm(s.motion.speed_m_s) == pytest.approx(5.0)
    assert m_to_mm(s.solver.increment_m) == pytest.approx(0.25)
    assert m_to_mm(s.instrument.sections[0].element_length_m) == pytest.approx(0.825)


def test_free_length_and_clamped_link(needle_settings):
    """The scene cuts the 120 mm free length into ceil(120 / 0.825) = 146 equal links of
    120/146 = 0.8219 mm and adds one clamped link behind it: 120.822 mm modelled; the tip is the
    reported point (centre_from_tip 0), the run starts at advance 0 and reports every 0.25 mm
    from 0 to 120 mm (481 depths)."""
    scene = needle_scene(s_channel(35.0), needle_settings)
    (sec,) = scene.instrument.sections
    assert m_to_mm(sec.element_length_m) == pytest.approx(120.0 / 146.0)
    assert m_to_mm(sec.length_m) == pytest.approx(120.0 + 120.0 / 146.0)
    assert scene.instrument.centre_from_tip_m == 0.0
    assert scene.motion.start_m == 0.0
    depth = m_to_mm(np.asarray(scene.motion.advances_m))
    assert depth.size == 481
    assert depth[[0, 1, -1]] == pytest.approx([0.0, 0.25, 120.0])


def test_depth_is_the_tips_travel_along_the_entry_straight(needle_settings):
    """Depth = advance: while the tip is in the 10 mm entry straight (no contact) it sits on the
    centreline at x = depth (1 um): at depth 0 at the start of the channel, the end of the guide."""
    scene = needle_scene(s_channel(35.0), needle_settings, depth_mm=8.0)
    res = simulate(scene)
    depth = m_to_mm(np.asarray(scene.motion.advances_m))
    tip = m_to_mm(np.asarray(res.tip_pos_m))
    assert tip[:, 0] == pytest.approx(depth, abs=1e-3)
    assert np.abs(tip[:, 1:]).max() < 1e-3


def test_depth_stops_at_a_short_channel(needle_settings):
    """A 100 mm channel: the insertion ends at its end (100 mm), not at 120 mm."""
    pts = np.c_[np.linspace(0.0, 0.1, 101), np.zeros(101), np.zeros(101)]
    ch = Channel("short", Centreline.from_points(pts), Lumen.circular(1.3e-3, 1.2e-3), 0.09)
    assert depth_grid_mm(needle_settings, ch)[-1] == pytest.approx(100.0)


def test_smallest_passable_radius(needle_settings):
    """EI / (2 rho^2) = 50 N (solver.jam_force_n) at rho = sqrt(1.2e-2 / 100) = 10.954 mm; with
    the catheter on the outer wall rho = r + (1.3 - 0.99) mm, so r_min = 10.644 mm at 2.6 mm."""
    assert min_passable_radius_mm(needle_settings, 2.6) == pytest.approx(10.644, abs=1e-3)
    check_spec(ChannelSpec(10.7, 0.0, 2.6), needle_settings)  # just passes


@pytest.mark.parametrize(
    ("spec", "match"),
    [
        (ChannelSpec(10.0, 0.0, 2.6), r"--radius-mm 10: too tight .*smallest radius 10\.7 mm"),
        (ChannelSpec(61.0, 0.0, 2.6), r"--radius-mm 61: .*largest radius 60\.8 mm"),
        (ChannelSpec(35.0, 0.0, 1.98), r"--diameter-mm 1\.98: .* wider than the catheter"),
        (ChannelSpec(35.0, 0.0, 1.5), r"--diameter-mm 1\.5: "),
        (ChannelSpec(35.0, -0.01, 2.6), r"--torsion-rad -0\.01: .* 0\.\.pi"),
        (ChannelSpec(35.0, 3.2, 2.6), r"--torsion-rad 3\.2: .* 0\.\.pi"),
        (ChannelSpec(math.nan, 0.0, 2.6), r"--radius-mm nan: expected a finite number"),
    ],
)
def test_channels_the_catheter_cannot_be_simulated_in(needle_settings, spec, match):
    with pytest.raises(NeedleError, match=match):
        check_spec(spec, needle_settings)
