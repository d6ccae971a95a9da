"""The modelled stem inside the numerical error (issue 28): when the commissioning run cuts the
channel's straight shaft to the modelled stem, the whole channel is run too (commissioning and
refined settings) and each dwell's error gains the whole channel's distance from the reported
positions plus its own error. Stand-in engine: the source sits on the centreline at the advance,
raised by a height that depends only on the run (whole or cut channel, refined or not), so every
expected number is a sum of those heights."""

from __future__ import annotations

import os
from types import SimpleNamespace

import numpy as np
import pytest

from ringqa.errors import SimulationError
from ringqa.geometry import Centreline, Channel, Lumen
from ringqa.pipeline.simulate import NUMERICAL_ERROR_WARN_MM, simulate_dwells
from tests.pipeline.fakes import fake_engine, sim_result

SHAFT_M = 0.150  # straight shaft before the bend: a 60 mm stem drops 90 mm of it


def _shaft_and_arc():
    """A 150 mm straight shaft along +y, then a 13 mm radius arc of 200 deg, lumen 1.5 mm."""
    s1 = np.linspace(0.0, SHAFT_M, int(SHAFT_M / 0.5e-3) + 1)
    shaft = np.column_stack([np.full_like(s1, 0.013), s1 - SHAFT_M, np.zeros_like(s1)])
    phi = np.linspace(0.0, np.deg2rad(200.0), 400)[1:]
    arc = np.column_stack([0.013 * np.cos(phi), 0.013 * np.sin(phi), np.zeros_like(phi)])
    cl = Centreline.from_points(np.vstack([shaft, arc]))
    return Channel("ring", cl, Lumen.circular(1.5e-3, 1.4e-3), cl.length_m - 5e-3)


def _height_simulator(heights_mm, jam_whole=False, refuse_whole=False):
    """Source on the scene's channel centreline at the advance, raised by
    ``heights_mm[(whole, refined)]`` (mm); ``jam_whole``: the whole channel's runs jam;
    ``refuse_whole``: the engine refuses the whole channel (a RingQAError)."""

    def simulate(scene, advances_mm=None, progress=False):
        adv = np.asarray(advances_mm, dtype=float)
        ch = scene.channel
        whole = ch.length_m > 0.15  # the cut channel is 60 + 45 mm long, the whole one 195 mm
        if whole and refuse_whole:
            raise SimulationError("the capsule cannot pass the shaft")
        refined = "refined" in scene.overrides
        pos = np.atleast_2d(ch.centreline.position(adv * 1e-3)).copy()
        pos[:, 2] += heights_mm[(whole, refined)] * 1e-3
        dirs = np.atleast_2d(ch.centreline.tangent(adv * 1e-3))
        status, msg = (1, "push force above 50 N") if whole and jam_whole else (0, "ok")
        return sim_result(status, msg, adv, pos, dirs, solve_time_s=0.01, n_elements=12,
                          settings={})  # fmt: skip

    return simulate


HEIGHTS = {(False, False): 0.03, (False, True): 0.0, (True, False): 0.10, (True, True): 0.25}


def _run(sim, **kw):
    ch = _shaft_and_arc()
    rel = np.arange(0.0, 40.0, 5.0)
    return simulate_dwells(SimpleNamespace(name="shaft"), ch, rel, cable="flexitron",
                           scene_overrides={}, engine=fake_engine(sim), stem_mm=60.0,
                           **kw)  # fmt: skip


def test_the_stem_share_is_the_whole_channels_distance_plus_its_own_error():
    """Cut channel: commissioning run 0.03 mm high, refined 0 (discretisation error 0.03 mm).
    Whole channel: 0.10 and 0.25 mm high. Its refined run lies 0.25 mm from the reported one and
    0.15 mm from its own commissioning run: each dwell's error is 0.03 + 0.25 + 0.15 = 0.43 mm,
    above the 0.1 mm warning level (WARN, said as the shaft's doing, not the links'); 4 runs."""
    got = _run(_height_simulator(HEIGHTS))
    n = got.numerics
    assert n.stem is not None and n.stem.ok
    assert n.stem.dropped_mm == pytest.approx(90.0, abs=0.5)
    np.testing.assert_allclose(n.stem.distance_mm, 0.25, atol=1e-5)
    np.testing.assert_allclose(n.stem.whole_error_mm, 0.15, atol=1e-5)
    np.testing.assert_allclose(n.discretisation_mm, 0.03, atol=1e-5)
    np.testing.assert_allclose(n.error_mm, 0.43, atol=1e-5)
    assert n.max_mm == pytest.approx(0.43, abs=1e-5) and n.warns
    assert n.n_runs == 4
    np.testing.assert_allclose(got.dwells.positions_mm[:, 2], 0.0, atol=1e-12)  # cut, refined
    assert n.text[0].startswith("Numerical error of the simulated positions, the modelled stem "
                                "included: up to 0.430 mm")  # fmt: skip
    assert n.text[1].startswith("Of that, the discretisation: up to 0.030 mm")
    assert f"leaves out {n.stem.dropped_mm:.1f} mm of straight shaft" in n.text[2]
    assert n.text[-1].startswith("WARNING") and "straight shaft" in n.text[-1]
    d = n.as_dict()["stem_check"]
    assert d["max_added_mm"] == pytest.approx(0.40) and d["max_distance_mm"] == pytest.approx(0.25)


def test_no_cut_no_stem_check():
    """The check switched off: no whole-channel runs, the error is the discretisation's
    (0.03 mm), PASS. The whole channel simulated (stem_mm None): nothing cut, no whole-channel
    runs; its own two runs differ by 0.25 - 0.10 = 0.15 mm, so it is refined once more."""
    n = _run(_height_simulator(HEIGHTS), stem_check=False).numerics
    assert n.stem is None and n.n_runs == 2 and not n.warns
    assert n.max_mm == pytest.approx(0.03, abs=1e-5) and 0.03 <= NUMERICAL_ERROR_WARN_MM
    ch = _shaft_and_arc()
    n = simulate_dwells(SimpleNamespace(name="shaft"), ch, np.arange(0.0, 40.0, 5.0),
                        cable="flexitron", scene_overrides={},
                        engine=fake_engine(_height_simulator(HEIGHTS)),
                        stem_mm=None).numerics  # fmt: skip
    # the whole channel simulated: its own runs differ by 0.15 mm > 0.1 mm, so it is refined
    # once more; the stand-in's refined runs agree (0 mm)
    assert n.stem is None and n.n_runs == 3 and n.max_mm == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(
    ("kw", "why"),
    [
        ({"jam_whole": True}, "did not reach every dwell"),
        ({"refuse_whole": True}, "cannot pass the shaft"),
    ],
)
def test_a_whole_channel_run_that_jams_is_said_not_hidden(kw, why):
    """The whole channel jams, or the engine refuses it: the commissioning still reports the cut
    channel's positions and error (0.03 mm), and the text says why the stem's share is NOT
    included."""
    n = _run(_height_simulator(HEIGHTS, **kw)).numerics
    assert n.stem is not None and not n.stem.ok
    assert n.max_mm == pytest.approx(0.03, abs=1e-5)
    assert any("does NOT include it" in t and why in t for t in n.text)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_the_stem_check_is_bit_identical_with_its_run_forked(monkeypatch):
    """ring26x60 (the real engine) with a 30 mm stem, so that 30 mm of its 60 mm straight stem
    is cut: the whole channel's refined run (the longest) in a forked child, started right after
    the commissioning run (which has loaded the kernels the child uses), while the refined run,
    the probes and the whole channel's other run go here, gives exactly the errors of running
    everything in turn (tolerance 0)."""
    from ringqa import parallel as forked_mod
    from ringqa.io.applicator_file import load_applicator
    from ringqa.parallel import ForkedCall
    from ringqa.pipeline import simulate
    from ringqa.pipeline.dwells import reference_dwells

    app = load_applicator("ring26x60")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    forked = []
    real_init = ForkedCall.__init__

    runs_here = []  # runs made in this process when each ForkedCall was made
    real_run = simulate._run_with_retries

    def spy(self, fn, fork=True):
        real_init(self, fn, fork)
        forked.append((self.forked, len(runs_here)))

    def counted(*a, **k):
        runs_here.append(1)
        return real_run(*a, **k)

    def run():
        return simulate.simulate_dwells(app, ring, rel, cable="flexitron", scene_overrides={},
                                        stem_mm=30.0)  # fmt: skip

    monkeypatch.setattr(ForkedCall, "__init__", spy)
    monkeypatch.setattr(simulate, "_run_with_retries", counted)
    monkeypatch.setattr(simulate, "kernels_cached", lambda: True)
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: True)
    together = run()
    assert together.numerics.stem is not None and together.numerics.stem.ok
    # the refined run is not forked (made here after the commissioning run); the whole
    # channel's refined run is, once the commissioning run (one run here) is done
    assert forked[:2] == [(False, 0), (True, 1)]
    monkeypatch.setattr(simulate, "CONCURRENT_RUNS", False)
    forked.clear()
    in_turn = run()
    assert not any(f for f, _ in forked)
    np.testing.assert_array_equal(together.dwells.positions_mm, in_turn.dwells.positions_mm)
    np.testing.assert_array_equal(together.numerics.error_mm, in_turn.numerics.error_mm)
    np.testing.assert_array_equal(together.numerics.stem.added_mm, in_turn.numerics.stem.added_mm)
    assert together.numerics.n_runs == in_turn.numerics.n_runs
