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

__all__ = ["INTERVAL_S", "PlainProgress", "plain_interval_s", "progress_bar"]

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
        if self.total:
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
