"""What the commissioning cross-check (the flexible engine beside the rigid runs) costs.

    .venv/bin/python benchmarks/bench_cross_check.py [--reps 5]

Runs ``ringqa commission`` on the shipped Oncentra example (``--register plane-height``, warm
numba cache) in this process, interleaved, in four modes: cross-check off / on, each with the
second core used (the forks of the numerical check and the cross-check, as on a quiet 2-core
machine: :func:`ringqa.parallel.second_core_free` forced True) and without (forced False:
what a loaded machine gets, everything one after the other). Per mode the median wall time of
the whole command and of its simulation step, and the CPU seconds (this process + its forked
children, ``RUSAGE_CHILDREN``); then the cross-check's added wall and CPU, absolute and as a
fraction of the command with it off. On a loaded machine go by the CPU figures and the ratios
(the wall figures stretch with the load; the load is printed).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa import parallel as forked  # noqa: E402
from ringqa.cli import main as ringqa_main  # noqa: E402

EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def one(out: Path, cross: bool, second_core: bool) -> tuple[float, float, float]:
    """(wall s, CPU s, the cross-check's wait s) of one commission run (the wait: how long the
    command waited for the flexible run after the rigid runs, results.json's ``added_wall_s``;
    0 with it off)."""
    forked.second_core_free = lambda: second_core  # the module function the pipeline asks
    args = ["commission", str(EXAMPLE), "--register", "plane-height", "--out", str(out),
            "--quiet", "--cross-check" if cross else "--no-cross-check"]  # fmt: skip
    c0, t0 = _cpu(), time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()):
        code = ringqa_main(args)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if code not in (0, 1):
        raise SystemExit(f"commission failed ({code})")
    xc = json.loads((out / "results.json").read_text())["numerical_check"]["cross_check"]
    if cross != (xc is not None) or (xc is not None and xc["concurrent"] != second_core):
        raise SystemExit(f"the cross-check did not run as asked: {xc}")
    return wall, cpu, 0.0 if xc is None else float(xc["added_wall_s"])


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args()
    modes = [(c, s) for s in (True, False) for c in (False, True)]
    times: dict = {m: [] for m in modes}
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        one(Path(tmp) / "warm", True, False)  # imports, kernel loads
        for k in range(args.reps):
            for m in modes:
                times[m].append(one(Path(tmp) / f"r{k}{m[0]:d}{m[1]:d}", *m))
    load1 = os.getloadavg()[0]
    print(f"example commission, {args.reps} runs a mode, {os.cpu_count()} cores, load "
          f"{load0:.1f} -> {load1:.1f} (1-min average)")  # fmt: skip
    print("| second core | cross-check | wall (median, min-max) | CPU s (median) | waited for it |")
    print("|---|---|---|---|---|")
    med = {}
    for m in modes:
        w = [t[0] for t in times[m]]
        c = [t[1] for t in times[m]]
        x = [t[2] for t in times[m]]
        med[m] = (statistics.median(w), statistics.median(c))
        print(f"| {'used' if m[1] else 'not used'} | {'on' if m[0] else 'off'} | "
              f"{med[m][0]:.2f} s ({min(w):.2f}-{max(w):.2f}) | {med[m][1]:.2f} | "
              f"{statistics.median(x):.2f} s |")  # fmt: skip
    for s in (True, False):
        off, on = med[(False, s)], med[(True, s)]
        print(f"second core {'used' if s else 'not used'}: the cross-check adds "
              f"{on[0] - off[0]:+.2f} s wall ({100 * (on[0] / off[0] - 1):+.0f} %) and "
              f"{on[1] - off[1]:+.2f} s CPU ({100 * (on[1] / off[1] - 1):+.0f} %)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
