"""Progress for people: a tqdm bar on a terminal, plain lines in a redirected log.

:func:`progress_bar` takes tqdm's arguments. On a terminal it is tqdm's bar; when its stream is
not a terminal (a cron job's log, ``2> run.log``, a CI console) it writes no ``\\r``-redrawn bar
but one plain line at most every :data:`INTERVAL_S` seconds and one at the end::

    ringqa sweep: 12/256 sample (4 %), 31 s

so a log stays readable and still shows that the run is alive. ``RINGQA_PROGRESS_INTERVAL_S``
sets the interval (0: a line per update, e.g. for a supervising script that reads the pipe).
"""

from __future__ import annotations

import os
import sys
import time

__all__ = [
    "INTERVAL_S",
    "CostProgress",
    "PlainProgress",
    "plain_interval_s",
    "progress_bar",
    "status_line",
]

#: seconds between two plain progress lines (not on a terminal); RINGQA_PROGRESS_INTERVAL_S
#: overrides it
INTERVAL_S = 30.0


def plain_interval_s() -> float:
    """The plain lines' interval: ``RINGQA_PROGRESS_INTERVAL_S`` if set to a number >= 0, else
    :data:`INTERVAL_S`."""
    try:
        value = float(os.environ.get("RINGQA_PROGRESS_INTERVAL_S", INTERVAL_S))
    except ValueError:
        return INTERVAL_S
    return value if value >= 0 else INTERVAL_S


class PlainProgress:
    """A tqdm stand-in that writes a plain line every :data:`INTERVAL_S` seconds (and at the end).

    Supports what ringqa's callers use: iteration over an iterable, ``update``,
    ``set_postfix_str``, ``close``, ``n``, ``total`` and use as a context manager.
    """

    def __init__(self, iterable=None, *, total=None, desc="", unit="it", initial=0, file=None,
                 interval_s: float | None = None, **_):  # fmt: skip
        self.iterable = iterable
        if total is None and iterable is not None and hasattr(iterable, "__len__"):
            total = len(iterable)
        self.total = total
        self.desc = desc or ""
        self.unit = unit
        self.n = initial
        self.file = file or sys.stderr
        self.interval_s = plain_interval_s() if interval_s is None else interval_s
        self.postfix = ""
        self._t0 = time.perf_counter()
        self._last = self._t0
        self._closed = False

    def _line(self) -> str:
        elapsed = time.perf_counter() - self._t0
        done = f"{self.n:g}"
        if self.total and self.unit == "%":  # a bar in percent (CostProgress)
            done = f"{self.n:.0f} %"
        elif self.total:
            done += f"/{self.total:g} {self.unit} ({100.0 * self.n / self.total:.0f} %)"
        else:
            done += f" {self.unit}"
        post = f" {self.postfix}" if self.postfix else ""
        return f"{self.desc}: {done}, {elapsed:.0f} s{post}"

    def _maybe_write(self, force: bool = False) -> None:
        now = time.perf_counter()
        if force or now - self._last >= self.interval_s:
            self._last = now
            print(self._line(), file=self.file, flush=True)

    def update(self, n=1) -> None:
        self.n += n
        self._maybe_write()

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = str(s)

    def set_description(self, desc=None, refresh: bool = True) -> None:
        self.desc = desc or ""

    def refresh(self) -> None:
        pass

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._maybe_write(force=True)

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.update()
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress_bar(iterable=None, *, disable: bool | None = False, file=None, **kwargs):
    """tqdm's bar on a terminal; :class:`PlainProgress` lines elsewhere; nothing when
    ``disable`` is true.

    Parameters
    ----------
    iterable : iterable, optional
        What to iterate over (as tqdm).
    disable : bool or None
        True: no output at all (the caller's ``--quiet``).
    file : stream, optional
        Where to write (default ``sys.stderr``).
    **kwargs
        tqdm's other arguments (``total``, ``desc``, ``unit``, ``initial``, ``bar_format``...).
    """
    from tqdm import tqdm

    stream = file or sys.stderr
    if disable:
        return tqdm(iterable, disable=True, file=stream, **kwargs)
    try:
        terminal = stream.isatty()
    except (AttributeError, ValueError):
        terminal = False
    if terminal:
        return tqdm(iterable, file=stream, **kwargs)
    return PlainProgress(iterable, file=stream, **kwargs)


def status_line(text: str, on: bool = True, file=None) -> None:
    """One line on stderr saying what a long command does now (a step before its bar starts,
    e.g. ``ringqa sweep: starting 2 worker processes``), on a terminal and in a log alike;
    nothing when ``on`` is false (``--quiet``)."""
    if on:
        print(text, file=file or sys.stderr, flush=True)


#: tqdm's bar for a bar in percent of the predicted work (:class:`CostProgress`)
PERCENT_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}{postfix}]"


class CostProgress:
    """A bar over tasks of unequal cost, in percent of the predicted work: the k-th ``update()``
    says task k (in the order given) has finished.

    Each task has a predicted cost in relative units (e.g. elements x steps of a run). The
    bar shows the seconds spent over the seconds spent plus the predicted seconds of the
    tasks still to come, these being their units times the measured seconds per unit of the
    tasks finished so far (tasks that took under :data:`MIN_TIMED_S`, e.g. read from a cache,
    do not set the rate). So one expensive task at the end moves the bar in proportion to its
    cost, not by one of N steps, and the estimate follows the measured cost as the run goes.
    ``skip(k)``: task k will not run (its cost leaves the prediction); a task whose predicted
    seconds exceed its ``limits_s`` entry is left out of the prediction likewise (a caller that
    does not start a task predicted to take too long); ``close()`` shows 100 %.

    Parameters
    ----------
    costs : sequence of float
        Predicted relative cost of each task (> 0), in the order they finish.
    on : bool
        False: no output (a silent stand-in).
    desc : str
        The bar's label.
    file : stream, optional
        Where to write (default ``sys.stderr``).
    limits_s : sequence of float or None, optional
        Per task: left out of the prediction when its predicted seconds exceed this (None: never).
    """

    #: a task faster than this (s) does not set the measured rate (a cached result)
    MIN_TIMED_S = 0.05

    def __init__(self, costs, on: bool = True, desc: str = "", file=None, limits_s=None) -> None:
        self.costs = [max(float(c), 1e-12) for c in costs]
        self.limits_s = list(limits_s) if limits_s is not None else [None] * len(self.costs)
        self.skipped: set[int] = set()
        self.k = 0
        self.spent_s = 0.0
        self.timed_s = 0.0
        self.timed_units = 0.0
        self.done_units = 0.0
        self._last = time.perf_counter()
        self.bar = progress_bar(total=100.0, desc=desc, unit="%", disable=not on, file=file,
                                bar_format=PERCENT_FORMAT)  # fmt: skip

    def fraction(self) -> float:
        """The share of the predicted work done (0..1)."""
        rate = self.timed_s / self.timed_units if self.timed_units > 0 else 0.0  # s per unit

        def expected(i: int) -> bool:
            limit = self.limits_s[i] if i < len(self.limits_s) else None
            too_long = rate > 0 and limit is not None and self.costs[i] * rate > limit
            return i >= self.k and i not in self.skipped and not too_long

        left = sum(c for i, c in enumerate(self.costs) if expected(i))
        if rate > 0 and self.timed_s > 0:
            done, todo = self.spent_s, left * rate
        else:
            done, todo = self.done_units, left
        return 1.0 if done + todo <= 0 else done / (done + todo)

    def _show(self) -> None:
        target = round(100.0 * self.fraction(), 1)
        if target > self.bar.n:  # never backwards
            self.bar.update(target - self.bar.n)

    def update(self, n: int = 1) -> None:
        """``n`` more tasks have finished (in the order of ``costs``)."""
        now = time.perf_counter()
        dt, self._last = now - self._last, now
        units = 0.0
        for _ in range(int(n)):
            while self.k in self.skipped:
                self.k += 1
            if self.k < len(self.costs):
                units += self.costs[self.k]
            self.k += 1
        self.spent_s += dt
        self.done_units += units
        if dt >= self.MIN_TIMED_S and units > 0:
            self.timed_s += dt
            self.timed_units += units
        self._show()

    def skip(self, k: int) -> None:
        """Task ``k`` will not run."""
        self.skipped.add(int(k))
        self._show()

    def close(self) -> None:
        """The work is over: 100 %."""
        if self.bar.n < 100.0:
            self.bar.update(100.0 - self.bar.n)
        self.bar.close()
