"""CPU of the report's three figures as README's main job draws them, before vs after (issue 27).

    .venv/bin/python benchmarks/bench_figures.py                          # this checkout
    .venv/bin/python benchmarks/bench_figures.py --baseline /work/wt/base # ... and another,
                                                                          # alternating

The main job (``ringqa commission <example plan> --register plane-height --out DIR``) draws the
positions, deviations and dose-map figures in forked children
(``ringqa.report.pdf.AHEAD_GROUPS``), each compressed there as the PDF stores it, after the
command's process has prepared the report (``ringqa.report.prepare_report``: matplotlib's
import and a warm-up figure). This does the same: each checkout (through ``PYTHONPATH``)
commissions the example once in a process of its own and pickles the result; then each
measuring process (the checkouts alternate process by process) loads it, as the command's
process gets it from the commissioning child, prepares the report, then ``--reps`` times
forks one child per group that draws its figures with ``ringqa.report.pdf._draw_figures`` and
reports its own CPU time (``time.process_time``): per figure and per child. The command line's
lean matplotlib import (``ringqa.cli._lean_matplotlib``) is used where the checkout has it, as
the ``ringqa`` script does. Printed: medians and least values per figure and child, the
compressed sizes, and the ratio after/before. CPU time, not wall time: the machine may be
shared.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLAN = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"

#: what one process runs (argv: checkout root, reps); prints one JSON line per child
PROBE = r"""
import json, os, pickle, sys, time
root, reps, saved = sys.argv[1], int(sys.argv[2]), sys.argv[3]
if reps == 0:  # commission the example and keep the result
    from ringqa.pipeline import CommissionSettings, commission
    result = commission(os.path.join(root, PLAN), CommissionSettings(register="plane-height"),
                        progress=False)
    with open(saved, "wb") as f:
        pickle.dump(result, f)
    raise SystemExit(0)
try:
    from ringqa.cli._lean_matplotlib import lean_matplotlib_docs
    lean_matplotlib_docs()
except ImportError:
    pass
import ringqa.pipeline
with open(saved, "rb") as f:
    result = pickle.load(f)  # as the command's process gets it from the commissioning child
from ringqa.report import pdf, prepare_report
prepare_report()
for _ in range(reps):
    for group in pdf.AHEAD_GROUPS:
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(r)
            out = {}
            start = time.process_time()
            for name in group:
                t0 = time.process_time()
                image = pdf._draw_figures(result, (name,))[name]
                out[name] = time.process_time() - t0
                out[name + " kB"] = len(image.data) / 1000
            out["child " + "+".join(group)] = time.process_time() - start
            os.write(w, json.dumps(out).encode())
            os._exit(0)
        os.close(w)
        data = b""
        while chunk := os.read(r, 1 << 16):
            data += chunk
        os.waitpid(pid, 0)
        print("FIG" + data.decode(), flush=True)
""".replace("PLAN", repr(PLAN))


def run_tree(tree: Path, reps: int, saved: Path) -> list[dict]:
    """One process of checkout ``tree`` drawing ``reps`` times from the result pickled at
    ``saved`` (``reps`` 0: commission and pickle it): its children's reports."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, str(tree), str(reps), str(saved)],
        capture_output=True, text=True, env=env, cwd="/", timeout=900, check=False,
    )  # fmt: skip
    if proc.returncode != 0:
        raise SystemExit(f"{tree}: exit {proc.returncode}\n{proc.stderr[-3000:]}")
    return [json.loads(x[3:]) for x in proc.stdout.splitlines() if x.startswith("FIG")]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", type=Path, help="another checkout (its root) to compare with")
    ap.add_argument("--processes", type=int, default=3, help="processes per checkout (3)")
    ap.add_argument("--reps", type=int, default=3, help="forked draws per process (3)")
    args = ap.parse_args(argv)
    trees = {"after": ROOT}
    if args.baseline:
        trees = {"before": args.baseline.resolve(), "after": ROOT}
    samples: dict[str, dict[str, list[float]]] = {name: {} for name in trees}
    tmp = Path(tempfile.mkdtemp(prefix="bench_figures-"))
    saved = {name: tmp / f"{name}.pickle" for name in trees}
    for name, tree in trees.items():  # each checkout's own result, commissioned once
        run_tree(tree, 0, saved[name])
    for k in range(args.processes):
        for name, tree in trees.items():
            for child in run_tree(tree, args.reps, saved[name]):
                for key, value in child.items():
                    samples[name].setdefault(key, []).append(value)
            print(f"  {name} {k + 1}/{args.processes}", flush=True)
    shutil.rmtree(tmp, ignore_errors=True)
    load = os.getloadavg()[0]
    print(f"\nCPU seconds (sizes kB), median (least) of {args.processes} x {args.reps} draws; "
          f"load {load:.1f}")  # fmt: skip
    keys = sorted(samples["after"], key=lambda s: (not s.startswith("child"), s))
    print(f"{'':28s}" + "".join(f"{name:>18s}" for name in trees) + "   after/before")
    for key in keys:
        cells, medians = [], []
        for name in trees:
            values = samples[name].get(key, [])
            med = statistics.median(values) if values else float("nan")
            medians.append(med)
            cells.append(f"{med:9.3f} ({min(values) if values else float('nan'):6.3f})")
        ratio = f"   {medians[-1] / medians[0]:.2f}" if len(medians) == 2 else ""
        print(f"{key:28s}" + "".join(f"{c:>18s}" for c in cells) + ratio)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
