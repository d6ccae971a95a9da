"""ringqa.progress: tqdm on a terminal, plain lines (no carriage returns) in a redirected log."""

from __future__ import annotations

import io

from ringqa.progress import PlainProgress, progress_bar


def test_not_a_terminal_gives_plain_lines():
    """A StringIO is no terminal: no '\\r'; with the interval at 0 every update is a line, and
    closing writes the final count (3 of 3 samples, 100 %)."""
    out = io.StringIO()
    bar = progress_bar(total=3, desc="ringqa sweep", unit="sample", file=out)
    assert isinstance(bar, PlainProgress)
    bar.interval_s = 0.0
    for _ in range(3):
        bar.update()
    bar.close()
    text = out.getvalue()
    assert "\r" not in text
    lines = text.strip().splitlines()
    assert lines[0].startswith("ringqa sweep: 1/3 sample (33 %)")
    assert lines[-1].startswith("ringqa sweep: 3/3 sample (100 %)")


def test_plain_lines_are_rate_limited_and_iteration_works():
    """The default interval (30 s) writes nothing during a quick loop but the closing line;
    iterating over a list yields every item."""
    out = io.StringIO()
    items = list(progress_bar(["a", "b", "c"], desc="reports", unit="applicator", file=out))
    assert items == ["a", "b", "c"]
    lines = out.getvalue().strip().splitlines()
    assert len(lines) == 1 and "3/3 applicator (100 %)" in lines[0]


def test_disabled_writes_nothing():
    out = io.StringIO()
    bar = progress_bar(total=2, desc="x", file=out, disable=True)
    bar.update(2)
    bar.close()
    assert out.getvalue() == ""


class _Clock:
    """A stand-in for time.perf_counter: advanced by hand (s)."""

    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _cost_bar(monkeypatch, costs, limits_s=None):
    import ringqa.progress as progress

    clock = _Clock()
    monkeypatch.setattr(progress.time, "perf_counter", clock)
    out = io.StringIO()
    monkeypatch.setattr(progress, "INTERVAL_S", 0.0)
    monkeypatch.delenv("RINGQA_PROGRESS_INTERVAL_S", raising=False)
    bar = progress.CostProgress(costs, desc="accuracy runs", file=out, limits_s=limits_s)
    return bar, clock, out


def test_cost_bar_moves_by_cost_not_by_count(monkeypatch):
    """Tasks of cost 1, 1, 8 units taking 2, 2, 16 s (2 s a unit): after the two cheap ones the
    bar shows 4 s / (4 s + 8 units x 2 s) = 20 % (a bar by count would show 2/3 = 67 % and then
    sit there for the longest task); at the end 100 %. The plain lines say 'N %'."""
    bar, clock, out = _cost_bar(monkeypatch, [1.0, 1.0, 8.0])
    for dt in (2.0, 2.0):
        clock.t += dt
        bar.update()
    assert abs(bar.fraction() - 0.2) < 1e-12
    assert bar.bar.n == 20.0
    clock.t += 16.0
    bar.update()
    assert bar.fraction() == 1.0
    bar.close()
    lines = out.getvalue().strip().splitlines()
    assert lines[1].startswith("accuracy runs: 20 %")
    assert lines[-1].startswith("accuracy runs: 100 %")


def test_cost_bar_follows_the_measured_rate(monkeypatch):
    """Predicted 1, 3, 4 units, but the first task (1 unit) took 5 s: the rate is 5 s a unit,
    so 5 s / (5 + 7 x 5 s) = 12.5 %; a first task read from a cache (0 s) sets no rate: the
    share is then by units, 1 / 8 = 12.5 % as well, and a later timed task sets the rate."""
    bar, clock, _ = _cost_bar(monkeypatch, [1.0, 3.0, 4.0])
    clock.t += 5.0
    bar.update()
    assert abs(bar.fraction() - 5.0 / 40.0) < 1e-12
    bar2, clock2, _ = _cost_bar(monkeypatch, [1.0, 3.0, 4.0])
    bar2.update()  # cached: no time passed
    assert abs(bar2.fraction() - 1.0 / 8.0) < 1e-12
    clock2.t += 6.0  # 3 units in 6 s: 2 s a unit; 6 s spent, 4 units x 2 s to come
    bar2.update()
    assert abs(bar2.fraction() - 6.0 / 14.0) < 1e-12


def test_cost_bar_leaves_out_what_will_not_run(monkeypatch):
    """A last task of 100 units with a 50 s limit at 1 s a unit (100 s predicted) will not be
    started: after the first task the bar is at 100 %; ``skip`` does the same by hand."""
    bar, clock, _ = _cost_bar(monkeypatch, [1.0, 100.0], limits_s=[None, 50.0])
    clock.t += 1.0
    bar.update()
    assert bar.fraction() == 1.0
    bar2, clock2, _ = _cost_bar(monkeypatch, [1.0, 100.0])
    clock2.t += 1.0
    bar2.update()
    assert abs(bar2.fraction() - 1.0 / 101.0) < 1e-12
    bar2.skip(1)
    assert bar2.fraction() == 1.0
