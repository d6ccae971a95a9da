"""The engine's work balance warning (issue 25) in a commissioning run: a named warning
``simulation.work_balance`` (terminal, results.json, the report's page 1), said once."""

from __future__ import annotations

from ringqa.errors import split_warning
from ringqa.pipeline import commission
from ringqa.pipeline.settings import CommissionSettings

TEXT = (
    "the work balance does not close: the input work 0.0234 J differs from the stored, "
    "dissipated and kinetic energy by 43 % (more than 5 %; ...)"
)


def test_the_work_balance_warning_is_named_and_said_once(fakes):
    """The fake engine returns the warning: the run's warnings hold it as
    simulation.work_balance, the notes once (as the named warning, not again among the
    'Simulation warnings')."""
    sim = fakes.simulator(warnings=(TEXT, "another engine warning"))
    res = commission(fakes.applicator(), CommissionSettings(), engine=fakes.engine(sim))
    named = [split_warning(w) for w in res.warnings]
    assert ("simulation.work_balance", TEXT) in named
    assert sum(TEXT in n for n in res.notes) == 1
    assert any("another engine warning" in n for n in res.notes)


def test_no_warning_without_an_imbalance(fakes):
    """An engine without the warning: no simulation.work_balance."""
    res = commission(fakes.applicator(), CommissionSettings(), engine=fakes.engine())
    assert not any(split_warning(w)[0] == "simulation.work_balance" for w in res.warnings)
