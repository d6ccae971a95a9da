"""The reference path through the pipeline: checks, registration, flags, relative positions, signed
offsets and the numerical error column (issue 13), on the stand-in ring with the stand-in engine.

The stand-in ring (tests/pipeline/fakes.py): a straight stem along +y joining a circle of radius
13 mm in the z = 0 plane; the stand-in simulator puts the source 0.3 mm outside the centreline.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ringqa.errors import RingQAError
from ringqa.pipeline import CommissionSettings, commission
from ringqa.pipeline.simulate import NUMERICAL_ERROR_WARN_MM
from tests.pipeline.fakes import S_REF


def _run(fakes, app=None, sim=None, engine=None, **settings):
    return commission(
        app if app is not None else fakes.applicator(),
        CommissionSettings(**settings),
        engine=engine or fakes.engine(sim or fakes.simulator()),
    )


def _rows(res, path):
    return res.dwells[res.dwells.path == path]


def test_planar_path_at_constant_height_is_found_and_registered(fakes):
    """A path 0.3 mm outside the centreline (as the stand-in simulation) but stored 0.8 mm above
    the ring plane: the check finds it planar at constant height 0.8 mm. As supplied, simulated
    vs reference = 0.8 mm everywhere; plane-height moves it 0.8 mm caudally, onto the simulated
    path: registered distances 0 (to 1e-9 mm), the dose differences shrink to what the source
    directions alone make, and the raw columns keep 0.8 mm. dist_to_measured_mm of the
    'registered' rows is the 0.8 mm shift."""
    app = fakes.applicator(measured_offset_m=0.3e-3, measured_z_m=0.8e-3)
    none, reg = _run(fakes, app=app), _run(fakes, app=app, register="plane-height")
    check = none.reference_check.raw
    assert check.planar and check.constant_height
    assert check.height_m == pytest.approx(0.8e-3, abs=1e-12)
    for res in (none, reg):
        assert res.summary.simulated.median_dist_mm == pytest.approx(0.8, abs=1e-9)
    assert none.summary.simulated_registered.max_dist_mm == pytest.approx(0.8, abs=1e-9)
    assert reg.summary.simulated_registered.max_dist_mm == pytest.approx(0.0, abs=1e-9)
    assert reg.summary.registration == "plane-height"
    assert set(reg.dwells.path) == {"measured", "registered", "simulated", "centreline"}
    np.testing.assert_allclose(_rows(reg, "registered")["z_mm"], 0.0, atol=1e-12)
    np.testing.assert_allclose(_rows(reg, "registered")["dist_to_measured_mm"], 0.8, atol=1e-9)
    sim = reg.doses[(reg.doses.plan == "simulated") & (reg.doses.kind != "tps")]
    # registered: same positions, only the directions differ (finite differences along the
    # path vs the simulated tangents): well under the 0.8 mm shift's dose difference
    assert sim["diff_registered_pct"].abs().max() < 0.25 * sim["diff_pct"].abs().max()
    assert any("planar" in line for line in none.reference_check.lines())
    assert any("plane-height" in line for line in none.reference_check.lines())


def test_without_registration_the_registered_columns_equal_the_raw(fakes):
    """--register none: every *_registered summary column equals its raw twin; no 'registered'
    rows; diff_registered_pct = diff_pct."""
    res = _run(fakes)
    row = res.summary.as_row()
    for key in [k for k in row if "_registered_" in k]:
        assert row[key] == pytest.approx(row[key.replace("_registered", "")], abs=1e-12), key
    assert "registered" not in set(res.dwells.path)
    np.testing.assert_array_equal(res.doses["diff_pct"], res.doses["diff_registered_pct"])
    assert row["registration"] == "none"


def test_infeasible_positions_are_flagged_and_named(fakes):
    """A path 1.3 mm outside the centreline in a 1.5 mm lumen: the Flexitron capsule (r = 0.425
    mm) can reach 1.5 - 0.425 = 1.075 mm (+ 0.05 mm tolerance): every position is infeasible;
    they stay in the comparison and the verdict texts name them."""
    res = _run(fakes, app=fakes.applicator(measured_offset_m=1.3e-3, n_measured=6))
    assert res.summary.n_reference_infeasible == 6
    assert set(res.dwells["reference_flag"]) == {"infeasible"}
    position = [v for v in res.verdicts if v.check.startswith("position:")]
    assert all("cannot lie in the lumen: 0, 2.5, 5, 7.5, 10, 12.5 mm" in v.text for v in position)
    assert all(v.value == pytest.approx(1.3 - (0.3 if "simulated" in v.check else 0.0))
               for v in position)  # fmt: skip


def test_positions_outside_the_channel_are_left_out(fakes):
    """The two most proximal of 12 positions moved 8 mm off the channel (more than the 5 mm
    limit): flagged outside_channel, not in the plan, not in the verdicts (which name them), and
    the distances are taken over the other 10."""
    app = fakes.applicator(n_measured=12, moved={10: [0, 0, 8e-3], 11: [0, 0, 8e-3]})
    res = _run(fakes, app=app)
    flags = _rows(res, "measured")["reference_flag"].to_numpy()
    assert list(flags) == [""] * 10 + ["outside_channel"] * 2
    assert not _rows(res, "measured")["in_plan"].to_numpy()[10:].any()
    assert res.summary.n_reference_outside == 2
    assert res.summary.centreline.max_dist_mm == pytest.approx(0.5, abs=1e-9)
    assert "Left out: 2 reference position(s) outside the channel (25, 27.5 mm)" in (
        res.verdicts[0].text
    )


def test_fewer_than_three_positions_on_the_channel_are_refused(fakes):
    """Of 4 positions, 2 lie 20 mm off the channel: 2 < 3 positions along the channel."""
    app = fakes.applicator(n_measured=4, moved={2: [0, 0, 0.02], 3: [0, 0, 0.02]})
    with pytest.raises(RingQAError, match=r"only 2 reference position\(s\) lie along the channel"):
        _run(fakes, app=app)


def test_uneven_relative_positions_are_kept(fakes):
    """Relative positions 0, 2.5, 5, 6, 10, 12.5, 15 mm (one uneven): the cable is pushed to
    s_ref - p for exactly these, the table keeps them, and the 5 mm plan takes 0, 5, 10, 15."""
    rel = np.array([0.0, 2.5, 5.0, 6.0, 10.0, 12.5, 15.0])
    sim = fakes.simulator()
    res = _run(fakes, app=fakes.applicator(relative_m=rel * 1e-3, n_measured=rel.size), sim=sim)
    np.testing.assert_allclose(np.sort(sim.calls[0]), np.sort(S_REF * 1e3 - rel), atol=1e-9)
    measured = _rows(res, "measured")
    np.testing.assert_allclose(measured["relative_position_mm"], rel)
    np.testing.assert_allclose(measured.loc[measured.in_plan, "relative_position_mm"],
                               [0, 5, 10, 15])  # fmt: skip


def test_signed_offsets_from_the_centreline(fakes):
    """Reference 0.5 mm outside, simulation 0.3 mm outside and 0.2 mm cranial, centreline on
    itself: radial_from_centreline_mm = 0.5 / 0.3 / 0 and height_mm = 0 / 0.2 / 0 on the circle
    (relative positions up to 54.9 mm), and the summary's medians on the ring say the same."""
    res = _run(fakes, sim=fakes.simulator(z_m=0.2e-3))
    for path, radial, height in (("measured", 0.5, 0.0), ("simulated", 0.3, 0.2),
                                 ("centreline", 0.0, 0.0)):  # fmt: skip
        rows = _rows(res, path)
        ring = rows[rows.relative_position_mm < 54.9]
        np.testing.assert_allclose(ring["radial_from_centreline_mm"], radial, atol=1e-9)
        np.testing.assert_allclose(ring["height_mm"], height, atol=1e-9)
    assert res.summary.median_radial == pytest.approx(
        {"reference": 0.5, "sim": 0.3, "centreline": 0.0}, abs=1e-9
    )
    assert res.summary.median_height["sim"] == pytest.approx(0.2, abs=1e-9)


def test_numerical_error_is_the_distance_between_the_two_runs(fakes):
    """The commissioning run puts the source 0.04 mm further cranially than the refined run:
    numerical_error_mm = 0.04 on every simulated row, 0 on the others; the refined positions are
    the ones reported (z = 0); the numerics verdict passes (0.04 <= 0.1 mm)."""
    res = _run(fakes, sim=fakes.simulator(coarse_z_m=0.04e-3))
    sim = _rows(res, "simulated")
    np.testing.assert_allclose(sim["numerical_error_mm"], 0.04, atol=1e-9)
    np.testing.assert_allclose(sim["z_mm"], 0.0, atol=1e-12)
    assert (res.dwells[res.dwells.path != "simulated"]["numerical_error_mm"] == 0).all()
    assert res.summary.max_numerical_error_mm == pytest.approx(0.04, abs=1e-9)
    assert res.numerics.n_runs == 2
    assert res.verdicts[-1].check.startswith("numerics") and res.verdicts[-1].status == "PASS"


def test_a_large_numerical_error_refines_again(fakes):
    """0.3 mm between the commissioning and the refined run (> 0.1 mm): a third run at the next
    refinement; the last two agree (error 0), and the notes say the run was refined again."""
    res = _run(fakes, sim=fakes.simulator(coarse_z_m=0.3e-3))
    assert res.numerics.n_runs == 3
    assert res.numerics.max_mm == pytest.approx(0.0, abs=1e-12)
    assert any("refined 1 more time" in n for n in res.notes)


def test_an_error_that_does_not_shrink_is_a_warning(fakes):
    """A stand-in whose every refinement moves the source 0.2 mm up or down (error 0.4 mm at every
    level): 4 runs (2 extra refinements at most), the numerics verdict WARNs, the text says the
    positions are uncertain, and the conclusion mentions it."""
    base, refined = fakes.simulator(), []

    def flip(scene, factor):
        new = dataclasses.replace(scene) if dataclasses.is_dataclass(scene) else scene
        refined.append(factor)
        return new

    def sim(scene, advances_mm=None, progress=False):
        res = base(scene, advances_mm=advances_mm)
        pos = res.source_pos_m.copy()
        pos[:, 2] += 0.2e-3 * (-1) ** len(refined)
        return dataclasses.replace(res, source_pos_m=pos)

    engine = dataclasses.replace(fakes.engine(sim), refine=flip)
    res = _run(fakes, engine=engine)
    assert res.numerics.n_runs == 4
    assert res.numerics.max_mm == pytest.approx(0.4, abs=1e-9)
    assert res.numerics.max_mm > NUMERICAL_ERROR_WARN_MM
    assert res.verdicts[-1].status == "WARN"
    assert any(t.startswith("WARNING") for t in res.numerics.text)
    assert "numerical error" in res.conclusion
