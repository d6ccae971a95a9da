"""The physical-plausibility monitor (issue 25, ringqa.simulation.plausibility): a wall too soft
to hold the cable, a cable outside its lumen, a work balance that does not close.

The issue's two cases, reproduced with ``ringqa simulate --set`` before the fix:
- ``ring13-push100 --set contact.stiffness_n_m=1e-3``: jammed (status 1), source positions
  50 mm from the centreline of a 1.5 mm lumen, no warning;
- ``ring26-flexitron --set contact.stiffness_n_m=1e7 --set effects.friction=none``: status 0,
  work balance error 71 %, push forces up to 0.76 N where the 1e5 N/m wall gives 0.19 N, no
  warning.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from ringqa.errors import SceneError
from ringqa.geometry import Centreline, Channel, Lumen
from ringqa.simulation import simulate
from ringqa.simulation.plausibility import (
    OUTSIDE_MARGIN_M,
    WORK_BALANCE_WARN,
    outside_lumen,
    work_balance_warning,
)
from ringqa.simulation.scenefile import load_scene


def _straight_table(r_b_mm=1.5):
    from ringqa.simulation.channel import ChannelTable

    x = np.linspace(0.0, 0.1, 41)
    cl = Centreline.from_points(np.c_[x, np.zeros_like(x), np.zeros_like(x)])
    lumen = Lumen.circular(r_b_mm * 1e-3, (r_b_mm - 0.1) * 1e-3)
    return ChannelTable.from_channel(Channel(name="s", centreline=cl, lumen=lumen, s_ref_m=0.09))


def test_outside_lumen_uses_the_wall_plus_the_margin():
    """A straight channel (centreline the x axis, r_b 1.5 mm): a source 1.5 mm + 0.04 mm off the
    axis is within the 0.05 mm margin (None); a tip 1.5 + 0.3 mm off it is outside by 0.3 mm
    (1e-9 m: the table's closest point on a line), named with the advance of its row; a NaN
    row (an advance not reached) is skipped."""
    tab = _straight_table()
    s = np.array([0.05, np.nan])
    off = np.array([1.54e-3, np.nan])
    tips = np.array([[0.06, 0.0, 0.0], [np.nan, np.nan, np.nan]])
    assert outside_lumen(tab, s, off, tips, [10.0, 20.0]) is None
    tips[0, 2] = 1.8e-3
    out = outside_lumen(tab, s, off, tips, [10.0, 20.0])
    assert out is not None and out.what == "cable tip" and out.advance_mm == 10.0
    assert abs(out.beyond_m - 0.3e-3) < 1e-9 and abs(out.r_b_m - 1.5e-3) < 1e-15
    off[0] = 2.0e-3  # the source 0.5 mm outside: the worse of the two
    out = outside_lumen(tab, s, off, tips, [10.0, 20.0])
    assert out.what == "source centre" and abs(out.beyond_m - 0.5e-3) < 1e-15
    assert OUTSIDE_MARGIN_M == 0.05e-3


def test_work_balance_warning_threshold_and_wording():
    """5 % is the stated fraction: 4.9 % says nothing, 5.1 % warns, naming the error and the step
    setting; above the paper's 1e5 N/m it names the stiff wall and the paper's value."""
    sc = load_scene("ring26-flexitron")
    work = {"input": 1.0, "elastic": 0.951, "balance_error": 0.049}
    assert WORK_BALANCE_WARN == 0.05
    assert work_balance_warning(work, sc, 0) == ""
    work = {"input": 1.0, "elastic": 0.949, "balance_error": 0.051}
    msg = work_balance_warning(work, sc, 3)
    assert "5 %" in msg and "solver.increment_mm = 1 mm" in msg and "3 of them stabilised" in msg
    assert "halve" in msg and "stiff wall" not in msg  # the paper's wall: the step's fault
    stiff = load_scene("ring26-flexitron", overrides={"contact.stiffness_n_m": 1e6})
    msg = work_balance_warning(work, stiff, 0)
    assert "stiff wall (contact.stiffness_n_m = 1e+06 N/m)" in msg and "1e5 N/m" in msg


def test_an_absurdly_soft_wall_is_refused_before_the_run():
    """1e-3 N/m: the thin Flexitron section (EI 5.2e-5 N m^2) round the 13 mm ring presses with
    EI / (2 R^2) ~ 0.16 N and would sink ~160 m into the wall: refused (SceneError) naming
    the key, the stiffness that fits and the paper's 1e5 N/m, before any step is solved."""
    sc = load_scene("ring13-push100", overrides={"contact.stiffness_n_m": 1e-3})
    with pytest.raises(SceneError) as err:
        simulate(sc)
    msg = str(err.value)
    assert "contact.stiffness_n_m = 0.001 N/m" in msg and "too soft" in msg
    assert "1e5 N/m" in msg and "use >=" in msg


def test_a_jam_outside_the_lumen_is_a_failure():
    """20 N/m on ring13-push100 (sink estimate 8 mm, below the refusal's 10 lumen radii =
    15 mm), with solver.jam_force_n = 0.05 N so that the run jams once the cable has sunk
    through the wall (at 47 mm). Before issue 25 a jam was status 1 (a result, no penetration
    check) with positions outside; now status -1: the message names how far outside and how
    deep it sank, and keeps the jam's own message."""
    over = {"contact.stiffness_n_m": 20.0, "solver.jam_force_n": 0.05}
    res = simulate(load_scene("ring13-push100", overrides=over))
    assert res.status == -1
    assert "outside the lumen" in res.message and "left the channel" in res.message
    assert "sank" in res.message and "jammed at advance" in res.message
    assert np.nanmax(res.offset_m) > 1.5e-3 - 0.425e-3


def test_the_stiff_wall_work_imbalance_is_flagged_and_a_finer_increment_closes_it():
    """The issue's stiff case at 1e6 N/m per contact point (ring26-flexitron, frictionless,
    1 mm increments): the balance error is far above 5 % (measured 43 %; 71 % at 1e7 N/m) and
    warned about; at 0.1 mm increments the same scene closes to < 5 % (measured 0.09 %) and
    says nothing: the imbalance comes from the increment, too coarse for the stiff wall."""
    over = {"contact.stiffness_n_m": 1e6, "effects.friction": "none"}
    coarse = simulate(load_scene("ring26-flexitron", overrides=over))
    assert coarse.status == 0
    assert coarse.work["balance_error"] > 0.3
    assert any("work balance does not close" in w for w in coarse.warnings)
    fine = simulate(load_scene("ring26-flexitron", overrides={**over, "solver.increment_mm": 0.1}))
    assert fine.work["balance_error"] < WORK_BALANCE_WARN
    assert not any("work balance" in w for w in fine.warnings)


@pytest.mark.parametrize("name", ["ring26-flexitron", "ring13-push100", "needle-s-curve"])
def test_shipped_scenes_pass_the_monitor(name):
    """The shipped scenes (the presets' walls: 1e5 and 1e6 N/m) are neither refused nor warned
    about nor failed by the monitor (their balance errors: <= 0.3 %)."""
    res = simulate(load_scene(name))
    assert res.status == 0
    assert res.work["balance_error"] < WORK_BALANCE_WARN
    assert not any("work balance" in w or "outside the lumen" in w for w in res.warnings)


def test_cli_simulate_reports_the_imbalance_in_run_json_and_on_the_terminal(tmp_path, capsys):
    """``ringqa simulate ... --set`` (the issue's reproduction): exit 0 (a result), the warning
    in run.json's warnings and on the terminal (stderr)."""
    from ringqa.cli import main

    out = tmp_path / "stiff"
    rc = main(["simulate", "ring26-flexitron", "--out", str(out), "--set",
               "contact.stiffness_n_m=1e7", "--set", "effects.friction=none"])  # fmt: skip
    assert rc == 0
    run = json.loads((out / "run.json").read_text())
    assert any("work balance does not close" in w for w in run["warnings"])
    assert "work balance does not close" in capsys.readouterr().err


def test_cli_simulate_refuses_the_soft_wall_and_writes_nothing(tmp_path, capsys):
    """The issue's soft case: exit 2 with one line naming the key; no output folder."""
    from ringqa.cli import main

    out = tmp_path / "soft"
    rc = main(["simulate", "ring13-push100", "--out", str(out), "--set",
               "contact.stiffness_n_m=1e-3"])  # fmt: skip
    assert rc == 2
    err = capsys.readouterr().err
    assert "contact.stiffness_n_m" in err and "Traceback" not in err
    assert not out.exists()


def test_the_pipeline_matches_the_engine_s_work_balance_text():
    """The commissioning run recognises the engine's warning by its first words (it does not
    import the engine in a batch's parent process): the two constants must agree."""
    from ringqa.pipeline.simulate import WORK_BALANCE_WARNING
    from ringqa.simulation.plausibility import WORK_BALANCE_TEXT

    assert WORK_BALANCE_WARNING == WORK_BALANCE_TEXT


def test_the_flexible_engine_is_monitored_too():
    """model.formulation = "flexible" runs its own driver; simulate() applies the same monitor:
    the absurdly soft wall is refused before the run, naming the paper's value."""
    over = {"model.formulation": "flexible", "contact.stiffness_n_m": 1e-3}
    with pytest.raises(SceneError, match=r"too soft for this cable.*1e5 N/m"):
        simulate(load_scene("ring13-push100", overrides=over))


def test_checked_result_fails_outside_positions_and_warns_an_open_balance():
    """The generic check (used for the flexible engine's results): a result whose source lies
    0.5 mm outside a 1.5 mm lumen becomes failed with its message kept after the reason; a
    balance error of 20 % adds the warning; a plausible result is returned unchanged."""
    from ringqa.simulation.plausibility import checked_result
    from ringqa.simulation.result import SimResult

    tab = _straight_table()
    sc = load_scene("ring26-flexitron")
    nan3 = np.full((1, 3), np.nan)

    def result(offset_m, balance):
        return SimResult(
            status=0, message="reached all 1 requested advances", advances_mm=np.array([50.0]),
            source_pos_m=nan3, source_dir=nan3, tip_pos_m=nan3, push_force_n=np.array([0.1]),
            contact_force_n=np.zeros((1, 3)), newton_iters=np.array([3]),
            s_m=np.array([0.05]), offset_m=np.array([offset_m]), n_elements=2,
            solve_time_s=0.0, work={"input": 1.0, "elastic": 1.0 - balance,
                                    "balance_error": balance},
        )  # fmt: skip

    ok = result(1.0e-3, 0.001)
    assert checked_result(ok, sc, tab) is ok
    bad = checked_result(result(2.0e-3, 0.2), sc, tab)
    assert bad.status == -1
    assert bad.message.startswith("the source centre lies 2.00 mm from the centreline")
    assert bad.message.endswith("; reached all 1 requested advances")
    assert any(w.startswith("the work balance does not close") for w in bad.warnings)
