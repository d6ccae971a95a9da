"""Say so while numba compiles: a notice and per-kernel progress on stderr (first run only).

numba compiles a kernel the first time it is called with a new type signature and keeps the
machine code in its on-disk cache; a later process loads it in milliseconds. With an empty cache
(a fresh install, a new numba version, an edited kernel file) the first ``ringqa commission`` spends
most of its time compiling (docs/speed.md). :func:`compile_notice` listens to numba's
``numba:compile`` event, which numba fires only on a cache miss, so nothing is printed when the
cache is warm. The first top-level compile prints one line saying what is happening and that
later runs start at once; each finished top-level kernel prints one progress line.
"""

from __future__ import annotations

import re
import sys
import time
from contextlib import contextmanager
from typing import TextIO

#: a rough figure for the first-run notice (s): the example's kernels on 2 cores with the compile
#: helper, about 10 s CPU in each process (docs/speed.md)
COMPILE_ESTIMATE_S = 20

#: kernel module prefix -> the group named in the progress line
GROUPS = (
    ("ringqa.geometry", "geometry"),
    ("ringqa.simulation", "simulation"),
    ("ringqa.needle", "needle"),
    ("tg43", "TG-43 dose"),
)

NOTICE = (
    "ringqa: compiling the numerical kernels once (first run with this numba cache, about "
    "{est} s in all{how}); later runs load them and start at once"
)


def kernel_label(dispatcher, args) -> str:
    """A short name for a compiled kernel: its group, function and, for the simulation's Newton
    and assembler, the effects it was specialised for.

    Parameters
    ----------
    dispatcher : numba dispatcher or None
    args : numba signature arguments (only its text is used)
    """
    fn = getattr(dispatcher, "py_func", None)
    if fn is None:
        return str(dispatcher)
    mod = getattr(fn, "__module__", "") or ""
    group = next((g for prefix, g in GROUPS if mod.startswith(prefix)), mod)
    label = f"{group}: {fn.__name__}"
    effects = re.findall(r"(\w+)Args\(", str(args))
    if effects and fn.__name__ in ("newton", "assemble", "newton_uncached"):
        names = [e.lower() for e in effects if e not in ("Channel",)]
        label += f" ({', '.join(dict.fromkeys(names))})"
    return label


class _Listener:
    """numba event listener (built lazily so that importing this module does not import numba)."""

    def __init__(self, stream: TextIO, estimate_s: float, helper: bool = False) -> None:
        self.stream = stream
        self.helper = helper
        self.estimate_s = estimate_s
        self.depth = 0
        self.announced = False
        self.t0 = 0.0
        self.t_first = 0.0
        self.compiled: list[tuple[str, float]] = []

    def start(self, ev) -> None:
        if self.depth == 0:
            self.t0 = time.perf_counter()
            if not self.announced:
                self.announced = True
                self.t_first = self.t0
                how = ", two processes" if self.helper else ""
                text = NOTICE.format(est=round(self.estimate_s), how=how)
                print(text, file=self.stream, flush=True)
        self.depth += 1

    def end(self, ev) -> None:
        self.depth -= 1
        if self.depth == 0:
            dt = time.perf_counter() - self.t0
            data = ev.data or {}
            label = kernel_label(data.get("dispatcher"), data.get("args"))
            self.compiled.append((label, dt))
            total = time.perf_counter() - self.t_first
            print(
                f"  compiled {label} in {dt:.1f} s ({len(self.compiled)} kernels, {total:.0f} s)",
                file=self.stream,
                flush=True,
            )


@contextmanager
def compile_notice(
    stream: TextIO | None = None, estimate_s: float = COMPILE_ESTIMATE_S, helper: bool = False
):
    """Print a notice and per-kernel progress to ``stream`` (stderr) while numba compiles.

    ``helper``: a compile helper process runs beside (the notice says so).

    Yields the listener; its ``compiled`` list holds ``(label, seconds)`` per top-level kernel
    compiled inside the block (empty when every kernel came from the cache).
    """
    from numba.core import event

    lis = _Listener(stream if stream is not None else sys.stderr, estimate_s, helper)

    class _L(event.Listener):
        def on_start(self, ev):
            lis.start(ev)

        def on_end(self, ev):
            lis.end(ev)

    listener = _L()
    event.register("numba:compile", listener)
    try:
        yield lis
    finally:
        event.unregister("numba:compile", listener)
