"""Using the second core (issue 16): the numerical check's engine runs two at a time in a forked
child, a batch's applicators and PDFs in forked workers; the results are those of running
everything one after the other."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

from ringqa import parallel as forked_mod
from ringqa.cli import main
from ringqa.io.applicator_file import load_applicator
from ringqa.parallel import ForkedCall
from ringqa.pipeline import commission_batch, simulate
from ringqa.pipeline.dwells import reference_dwells
from ringqa.report import write_batch
from tests.pipeline.fakes import fake_engine, make_applicator

needs_fork = pytest.mark.skipif(
    not hasattr(os, "fork") or (os.cpu_count() or 1) < 2, reason="needs fork and 2 cores"
)


@needs_fork
def test_a_forked_call_runs_in_the_child_and_falls_back_here():
    """The call runs in another process (another pid); its exception is raised here; a result
    that cannot be pickled (a lambda) and an exception that cannot be rebuilt here make the call
    here instead, so the caller sees the sequential outcome (the value, or the exception)."""
    assert ForkedCall(os.getpid).result() != os.getpid()
    assert ForkedCall(lambda: lambda: 7).result()() == 7
    parent = os.getpid()

    def fails():
        raise ValueError(f"raised in {'this process' if os.getpid() == parent else 'the child'}")

    with pytest.raises(ValueError, match="raised in the child"):
        ForkedCall(fails).result()

    class Odd(Exception):
        def __init__(self, a, b):  # unpickles wrongly (args = the message only)
            super().__init__(f"{a} {b} in {'here' if os.getpid() == parent else 'child'}")

    def odd():
        raise Odd(1, 2)

    with pytest.raises(Odd, match="1 2 in here"):
        ForkedCall(odd).result()
    off = ForkedCall(os.getpid, fork=False)
    assert not off.forked and off.result() == os.getpid()


@needs_fork
def test_the_numerical_check_is_bit_identical_with_its_runs_forked(monkeypatch):
    """ring26x60 (shipped, the real engine): the commissioning and the refined run at once
    (the refined one in a child) give exactly the positions, errors and run count of running
    them in turn (tolerance 0: the child runs the same code on the same scene)."""
    app = load_applicator("ring26x60")
    ring = app.channel("ring")
    rel = reference_dwells(app, ring, 5.0).relative_position_mm
    forked = []
    real_init = ForkedCall.__init__

    def spy(self, fn, fork=True):
        real_init(self, fn, fork)
        forked.append(self.forked)

    def run():
        return simulate.simulate_dwells(app, ring, rel, cable="flexitron", scene_overrides={},
                                        stem_mm=60.0)  # fmt: skip

    monkeypatch.setattr(ForkedCall, "__init__", spy)
    # forked even when this session compiled a kernel (a command forks only on a warm cache)
    monkeypatch.setattr(simulate, "kernels_cached", lambda: True)
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: True)
    together = run()
    assert forked[0] is True  # the refined run went to a child
    monkeypatch.setattr(simulate, "CONCURRENT_RUNS", False)
    forked.clear()
    in_turn = run()
    assert not any(forked)
    np.testing.assert_array_equal(together.dwells.positions_mm, in_turn.dwells.positions_mm)
    np.testing.assert_array_equal(together.dwells.directions, in_turn.dwells.directions)
    np.testing.assert_array_equal(together.numerics.error_mm, in_turn.numerics.error_mm)
    assert together.numerics.n_runs == in_turn.numerics.n_runs == 2


def _apps():
    return [make_applicator(name="a"), make_applicator(name="b", r_b=0.3e-3),
            make_applicator(name="c", n_measured=0)]  # fmt: skip


@needs_fork
def test_a_batch_with_two_workers_equals_one_worker(tmp_path):
    """Three stand-in applicators, the middle one failing (lumen narrower than the cable): with
    2 workers the results, their order, the failure and every CSV/JSON file written are those
    of 1 worker, and every applicator gets its report.pdf."""
    one = commission_batch(_apps(), progress=False, engine=fake_engine(), workers=1)
    two = commission_batch(_apps(), progress=False, engine=fake_engine(), workers=2)
    assert [r.applicator for r in two.results] == [r.applicator for r in one.results] == ["a", "c"]
    assert two.failures == one.failures and "cannot pass" in two.failures[0][1]
    pd.testing.assert_frame_equal(two.summary, one.summary)
    for a, b in zip(one.results, two.results, strict=True):
        pd.testing.assert_frame_equal(a.dwells, b.dwells, check_exact=True)
        pd.testing.assert_frame_equal(a.doses, b.doses, check_exact=True)
    write_batch(one, tmp_path / "one", workers=1)
    write_batch(one, tmp_path / "two", workers=2)
    files = sorted(p.relative_to(tmp_path / "one") for p in (tmp_path / "one").rglob("*"))
    assert files == sorted(p.relative_to(tmp_path / "two") for p in (tmp_path / "two").rglob("*"))
    for rel in files:
        if rel.suffix in (".csv", ".json") and rel.name != ".ringqa-output.json":
            assert (tmp_path / "one" / rel).read_bytes() == (tmp_path / "two" / rel).read_bytes()
    for name in ("a", "c"):
        assert (tmp_path / "two" / name / "report.pdf").read_bytes()[:5] == b"%PDF-"


def test_workers_below_one_are_refused(tmp_path, capsys):
    """--workers 0: one line naming the option and the fix, exit 2, nothing written."""
    code = main(["commission", "ring26x60", "ring30x60", "--workers", "0", "--out",
                 str(tmp_path / "out")])  # fmt: skip
    assert code == 2
    assert "--workers 0" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@needs_fork
def test_commissioning_ahead_of_the_report_gives_the_in_process_result(monkeypatch):
    """`ringqa commission` on one input commissions in a forked child while it prepares the
    report: the result is exactly the in-process one (ring26x60, real engine, every dwell and
    dose column, tolerance 0), and a bad input's error reaches the caller with its message."""
    from ringqa.cli import commission as cli
    from ringqa.errors import RingQAError
    from ringqa.pipeline import commission
    from ringqa.pipeline.settings import CommissionSettings

    monkeypatch.setattr(cli, "_real_std_streams", lambda: True)
    monkeypatch.setattr(simulate, "kernels_cached", lambda: True)
    monkeypatch.setattr(forked_mod, "second_core_free", lambda: True)
    forked = []
    real_init = ForkedCall.__init__

    def spy(self, fn, fork=True):
        real_init(self, fn, fork)
        forked.append(self.forked)

    monkeypatch.setattr(ForkedCall, "__init__", spy)
    ahead = cli.commission_ahead("ring26x60", CommissionSettings(), False)
    assert forked[0] is True
    here = commission("ring26x60", CommissionSettings())
    pd.testing.assert_frame_equal(ahead.dwells, here.dwells, check_exact=True)
    pd.testing.assert_frame_equal(ahead.doses, here.doses, check_exact=True)
    assert [v.status for v in ahead.verdicts] == [v.status for v in here.verdicts]
    with pytest.raises(RingQAError, match="no-such-ring"):
        cli.commission_ahead("no-such-ring", CommissionSettings(), False)
