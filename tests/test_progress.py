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
