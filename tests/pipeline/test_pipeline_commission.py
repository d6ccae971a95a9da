"""The commissioning pipeline on a stand-in ring with a stand-in engine (known displacements)."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ringqa.errors import RingQAError
from ringqa.pipeline import (
    CommissionSettings,
    SimulationJammedError,
    commission,
    commission_batch,
    deviation_components,
)
from tests.pipeline.fakes import stand_in_engine

DWELL_COLUMNS = ["applicator", "dwell", "path", "x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z",
                 "dist_to_measured_mm"]  # fmt: skip
DOSE_COLUMNS = ["applicator", "point", "plan", "dose_gy", "diff_pct"]


def _run(fakes, app=None, sim=None, **settings):
    return commission(
        app if app is not None else fakes.applicator(),
        CommissionSettings(**settings),
        engine=fakes.engine(sim or fakes.simulator()),
    )


def test_known_displacements_give_known_distances(fakes):
    """Measured path 0.5 mm outside the centreline, simulated 0.3 mm outside (same arc length):
    on the circle, centreline vs measured = 0.5 mm (radial -0.5), simulated vs measured = 0.2 mm
    (radial -0.2), along and out-of-plane 0. Exact up to the arc/stem junction, where 'outward'
    of the stem (x = 13 mm, y < 0) is not radial: there the 3D distances still hold exactly."""
    res = _run(fakes)
    d = res.dwells
    assert set(DWELL_COLUMNS) <= set(d.columns)
    assert sorted(d["path"].unique()) == ["centreline", "measured", "simulated"]
    assert (d.groupby("path").size() == 30).all()
    sim = d[d.path == "simulated"]
    cl = d[d.path == "centreline"]
    np.testing.assert_allclose(sim["dist_to_measured_mm"], 0.2, atol=1e-9)
    np.testing.assert_allclose(cl["dist_to_measured_mm"], 0.5, atol=1e-9)
    np.testing.assert_allclose(sim[sim.relative_position_mm < 54.9]["radial_mm"], -0.2, atol=1e-9)
    np.testing.assert_allclose(cl[cl.relative_position_mm < 54.9]["radial_mm"], -0.5, atol=1e-9)
    np.testing.assert_allclose(sim["along_mm"], 0.0, atol=1e-9)
    np.testing.assert_allclose(sim["out_of_plane_mm"], 0.0, atol=1e-12)
    assert res.summary.simulated.median_dist_mm == pytest.approx(0.2)
    assert res.summary.centreline.max_dist_mm == pytest.approx(0.5)
    assert [v.status for v in res.verdicts[:2]] == ["PASS", "PASS"]
    assert res.reference == "measured"


def test_simulator_gets_the_advances_s_ref_minus_p(fakes):
    """Advances = s_ref - p, p = 0, 2.5, ..., 72.5 mm, s_ref = 40 + 13 * 264 deg - 5 = 94.90 mm,
    pushed in increasing order (proximal -> distal)."""
    sim = fakes.simulator()
    res = _run(fakes, sim=sim)
    adv = sim.calls[0]
    s_ref = 40 + 13 * np.deg2rad(264) - 5
    np.testing.assert_allclose(np.sort(adv), s_ref - np.arange(30)[::-1] * 2.5)
    assert np.all(np.diff(adv) > 0)
    assert res.summary.s_ref_mm == pytest.approx(s_ref)


def test_out_of_plane_and_along_components(fakes):
    """Simulated source 0.4 mm cranial and 1 mm further along the channel (distal) than the
    measured path (which lies 0.3 mm outside, like the simulation): out_of_plane = +0.4 mm; on the
    circle the extra 1 mm of centreline arc turns by 1/13 rad at radius 13.3 mm, so
    along = 13.3 sin(1/13) = 1.0220 mm and radial = 13.3 (cos(1/13) - 1) = -0.0393 mm."""
    app = fakes.applicator(measured_offset_m=0.3e-3)
    res = _run(fakes, app=app, sim=fakes.simulator(z_m=0.4e-3, along_m=1e-3))
    sim = res.dwells[res.dwells.path == "simulated"]
    on_arc = sim["relative_position_mm"] < 53.0
    np.testing.assert_allclose(sim["out_of_plane_mm"], 0.4, atol=1e-9)
    np.testing.assert_allclose(sim[on_arc]["along_mm"], 13.3 * np.sin(1 / 13), atol=1e-9)
    np.testing.assert_allclose(sim[on_arc]["radial_mm"], 13.3 * (np.cos(1 / 13) - 1), atol=1e-9)


@given(
    d=st.tuples(*[st.floats(-3, 3)] * 3),
    phi=st.floats(0, 6.28),
    rho=st.floats(5, 20),
)
def test_components_add_up(d, phi, rho):
    """along^2 + radial^2 + out^2 = |d|^2 (an orthonormal split), for any reference dwell."""
    ref = np.array([[rho * np.cos(phi), rho * np.sin(phi), 0.7]])
    tangent = np.array([[-np.sin(phi), np.cos(phi), 0.0]])
    c = deviation_components(ref, tangent, ref + np.array(d), np.zeros(3), [0, 0, 1])
    total = c.along_mm**2 + c.radial_mm**2 + c.out_of_plane_mm**2
    np.testing.assert_allclose(total, c.dist_mm**2, atol=1e-9)
    assert c.out_of_plane_mm[0] == pytest.approx(d[2])


def test_doses_and_prescription(fakes):
    """Point A mean of the measured-path plan = 7 Gy within 0.1 %; the measured plan's own diffs
    are 0; moving every ring dwell outward (centreline is 0.5 mm INSIDE the measured path) lowers
    the lateral surface dose of the centreline plan relative to the measured plan."""
    res = _run(fakes)
    doses = res.doses
    assert set(DOSE_COLUMNS) <= set(doses.columns)
    ref = doses[doses.plan == "measured"]
    a = ref[ref.kind == "point_a"]["dose_gy"]
    assert a.mean() == pytest.approx(7.0, rel=1e-3)
    assert np.all(ref["diff_pct"].abs() < 1e-12)
    cl = doses[doses.plan == "centreline"].set_index("point")
    assert cl.loc["surface_left", "diff_pct"] < 0
    assert cl.loc["surface_right", "diff_pct"] < 0
    assert sorted(doses["plan"].unique()) == ["centreline", "measured", "simulated"]
    assert len(res.plan_dwells[res.plan_dwells.plan == "measured"]) == 15  # every 2nd of 30
    times = res.plan_dwells["time_s"].to_numpy()
    np.testing.assert_allclose(times, times[0])


def test_identical_simulation_gives_zero_dose_difference(fakes):
    """A simulated path identical to the measured one (positions and the measured path's
    finite-difference directions): 0.000 % at every point."""
    from ringqa.plan import path_directions

    app = fakes.applicator(measured_offset_m=0.3e-3)
    path = app.channel("ring").measured_path_m
    exact = (path[::-1], path_directions(path)[::-1])  # advances increase = most distal last
    res = _run(fakes, app=app, sim=fakes.simulator(exact=exact))
    sim = res.doses[res.doses.plan == "simulated"]
    assert np.all(np.round(sim["diff_pct"].abs(), 3) == 0.0)


def test_no_measured_path_compares_with_the_centreline(fakes):
    """No measured path: reference = centreline dwells every 5 mm while within 1 mm of the circle
    (from s_ref back over the 54.9 mm of circle, then the tangent stem stays within 1 mm for
    sqrt(14^2 - 13^2) = 5.2 mm: p = 0 ... 60 mm, 13 dwells); the result says so and
    dist_to_measured_mm is empty (no measurement), dist_to_reference_mm = 0.3 mm."""
    res = _run(fakes, app=fakes.applicator(n_measured=0))
    assert res.reference == "centreline"
    assert any("CENTRELINE" in n for n in res.notes)
    d = res.dwells
    assert sorted(d["path"].unique()) == ["centreline", "simulated"]
    assert (d.groupby("path").size() == 13).all()
    assert d["dist_to_measured_mm"].isna().all()
    np.testing.assert_allclose(d[d.path == "simulated"]["dist_to_reference_mm"], 0.3, atol=1e-9)
    assert res.verdicts[0].check == "position: simulated vs centreline"


def test_tandem_dwells_are_in_every_plan_unchanged(fakes):
    """With a tandem: 7 tandem dwells at 5 mm, identical in all plans and with the ring's time."""
    res = _run(fakes, app=fakes.applicator(tandem=True))
    pd_ = res.plan_dwells
    tan = pd_[pd_.channel == "tandem"]
    assert (tan.groupby("plan").size() == 7).all()
    xyz = {p: g[["x_mm", "y_mm", "z_mm"]].to_numpy() for p, g in tan.groupby("plan")}
    np.testing.assert_array_equal(xyz["measured"], xyz["simulated"])
    np.testing.assert_array_equal(xyz["measured"], xyz["centreline"])


def test_jam_is_a_clean_error(fakes):
    with pytest.raises(SimulationJammedError, match=r"jammed after advance .* push force"):
        _run(fakes, sim=fakes.simulator(jam_after=5))


def test_lumen_smaller_than_cable(fakes):
    with pytest.raises(RingQAError, match="cannot pass"):
        _run(fakes, app=fakes.applicator(r_b=0.4e-3))


def test_settings_that_do_not_fit_the_applicator(fakes):
    """Valid settings the stand-in ring cannot take: a plan step of 4 mm is not a multiple of
    the measured path's 2.5 mm; the ring has no channel 'ovoid'."""
    with pytest.raises(RingQAError, match="multiple"):
        _run(fakes, plan_step_mm=4.0)
    with pytest.raises(RingQAError, match="no channel 'ovoid'"):
        _run(fakes, channel="ovoid")


def test_batch_reports_a_failure_and_completes_the_rest(fakes):
    """Three applicators, the middle one with a lumen too narrow: two results, one failure row."""
    apps = [fakes.applicator(name="a"), fakes.applicator(name="b", r_b=0.3e-3),
            fakes.applicator(name="c")]  # fmt: skip
    batch = commission_batch(apps, progress=False, engine=fakes.engine())
    assert [r.applicator for r in batch.results] == ["a", "c"]
    assert batch.failures[0][0] == "b" and "cannot pass" in batch.failures[0][1]
    assert list(batch.summary["verdict"] == "ERROR") == [False, True, False]
    assert not batch.ok


def test_backward_stepping_gets_decreasing_advances(fakes):
    """A scene with motion.backward = True is given the advances most distal first; the dwell
    positions are matched by advance, so the distances are unchanged (0.2 mm)."""
    base = fakes.scene_factory()

    def factory(channel, cable):
        scene = base(channel, cable)
        scene.motion = SimpleNamespace(kind="stepwise", backward=True)
        return scene

    sim = fakes.simulator()
    res = commission(fakes.applicator(), engine=fakes.engine(sim, factory))
    assert np.all(np.diff(sim.calls[0]) < 0)
    sim_rows = res.dwells[res.dwells.path == "simulated"]
    np.testing.assert_allclose(sim_rows["dist_to_measured_mm"], 0.2, atol=1e-9)


def test_engine_warnings_reach_the_notes(fakes):
    res = _run(fakes, sim=fakes.simulator(warnings=("Newton did not converge at 12.5 mm",)))
    assert any("Newton did not converge at 12.5 mm" in n for n in res.notes)


def test_non_convergence_is_retried_with_a_finer_increment(fakes):
    """The engine fails (status -1, NaN rows) unless the increment is <= 0.5 mm: the pipeline
    repeats the run at 0.5 mm (default 1 mm x 0.5), succeeds, and says so in the notes; the
    refined run of the numerical check starts from that converged scene (the stand-in's refine
    keeps its increment: 0.5 mm again). With an engine that never converges the error names the
    dwells reached."""
    base, good = fakes.scene_factory(), fakes.simulator()

    def factory(channel, cable):
        scene = base(channel, cable)
        scene.solver = SimpleNamespace(increment_m=1e-3)
        return scene

    def with_overrides(scene, d):
        new = factory(scene.channel, scene.cable)
        new.solver = SimpleNamespace(increment_m=d.get("solver.increment_mm", 1.0) * 1e-3)
        return new

    tried = []

    def picky(scene, advances_mm=None, progress=False):
        tried.append(scene.solver.increment_m)
        res = good(scene, advances_mm=advances_mm)
        if scene.solver.increment_m > 0.6e-3 or picky.never:
            pos = res.source_pos_m.copy()
            pos[-4:] = np.nan
            res = dataclasses.replace(res, status=-1, message="Newton did not converge",
                                      source_pos_m=pos)  # fmt: skip
        return res

    engine = dataclasses.replace(fakes.engine(picky, factory), scene_with_overrides=with_overrides)
    picky.never = False
    res = commission(fakes.applicator(), engine=engine)
    assert tried == [1e-3, 0.5e-3, 0.5e-3]
    assert any("repeated with 0.5 mm" in n for n in res.notes)
    picky.never = True
    with pytest.raises(SimulationJammedError, match=r"failed after .* 26 of 30 dwells reached"):
        commission(fakes.applicator(), engine=engine)


def test_real_applicator_with_a_lumen_narrower_than_the_cable():
    """ring26x60 with its ring lumen replaced by a 0.6 mm bore: the Flexitron cable's thick
    section (r_o = 0.425 mm) cannot pass; refused before any simulation."""
    import dataclasses

    from ringqa.geometry import Lumen
    from ringqa.io.applicator_file import load_applicator

    app = load_applicator("ring26x60")
    ring = dataclasses.replace(app.channel("ring"), lumen=Lumen.circular(0.3e-3, 0.25e-3))
    app = dataclasses.replace(
        app, channels=tuple(ring if c.name == "ring" else c for c in app.channels)
    )

    def never(*a, **k):
        raise AssertionError("must not simulate")

    with pytest.raises(RingQAError, match=r"lumen radius 0.30 mm .* 0.42 mm: the cable cannot"):
        commission(app, engine=stand_in_engine(never))
