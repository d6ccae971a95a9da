"""The README main job's engine runs: Newton iterations, failed attempts and solve CPU per run.

    .venv/bin/python benchmarks/bench_failed_steps.py                     # this checkout
    .venv/bin/python benchmarks/bench_failed_steps.py --baseline DIR -n 3 # alternate with DIR

The main job (``ringqa commission data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm
--register plane-height``) runs the engine several times (the commissioning run, its refined
run, the probes, the whole channel for the stem check at both settings, the flexible
cross-check). The runs are captured once, by running the job with its runs in one process and
recording each engine run's ``(scene, advances_mm)`` (at the pipeline's ``_run_with_retries``,
in the order they start). Each run is then
solved in fresh processes of this checkout (and of ``--baseline DIR``, alternated): after a
warm-up run, the minimum CPU time (``time.process_time``) of 3 ``simulate()`` calls, and the
solver's counters. Printed: per run iterations, residual assemblies, failed attempts /
stabilised steps and the median CPU over the processes, before -> after with the ratio
(docs/engine.md, "Failed steps reach the fallback sooner").
"""

from __future__ import annotations

import argparse
import json
import pickle
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"

_CHILD = r"""
import json, pickle, sys, time
sys.path.insert(0, sys.argv[1])
from ringqa.simulation import simulate
out = []
for scene, adv in pickle.load(open(sys.argv[2], "rb")):
    r = simulate(scene, advances_mm=adv)
    ts = []
    for _ in range(3):
        t = time.process_time(); r = simulate(scene, advances_mm=adv)
        ts.append(time.process_time() - t)
    st = r.stats
    out.append({"cpu_s": min(ts), "iters": int(st.n_newton_iters), "residuals": int(st.n_residuals),
                "failed": int(st.n_failed_attempts), "stabilised": int(st.n_stabilised_steps),
                "elements": int(r.n_elements)})
print(json.dumps(out))
"""


def capture(path: Path) -> int:
    """Run the main job with its engine runs in one process (the command may run the job in a
    forked child: each run is written to a file as it starts); pickle the runs to ``path``."""
    sys.path.insert(0, str(ROOT))
    import os
    import time

    import ringqa.pipeline.simulate as ps

    ps.CONCURRENT_RUNS = False
    inner = ps._run_with_retries
    with tempfile.TemporaryDirectory() as tmp:
        spool = Path(tmp)

        def recorded(engine, scene, advances, progress):
            name = f"{time.monotonic_ns():020d}_{os.getpid()}.pkl"
            with open(spool / name, "wb") as f:
                pickle.dump((scene, advances), f)
            return inner(engine, scene, advances, progress)

        ps._run_with_retries = recorded
        from ringqa.cli import main

        main(["commission", str(EXAMPLE), "--register", "plane-height", "--out", tmp + "/o"])
        runs = [pickle.loads(f.read_bytes()) for f in sorted(spool.glob("*.pkl"))]
    with open(path, "wb") as f:
        pickle.dump(runs, f)
    return len(runs)


def measure(checkout: Path, runs: Path) -> list[dict]:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(checkout), str(runs)],
        capture_output=True, text=True, check=True, cwd=tempfile.gettempdir(),
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, help="a checkout to alternate with (before)")
    ap.add_argument("-n", type=int, default=1, help="processes per checkout (default 1)")
    args = ap.parse_args(argv)
    if args.baseline is not None and not (args.baseline / "ringqa").is_dir():
        ap.error(f"{args.baseline}: not a ringqa checkout (no ringqa/ folder)")
    with tempfile.TemporaryDirectory() as tmp:
        runs = Path(tmp) / "runs.pkl"
        print(f"captured {capture(runs)} engine runs of the main job", flush=True)
        after, before = [], []
        for _ in range(args.n):
            if args.baseline is not None:
                before.append(measure(args.baseline, runs))
            after.append(measure(ROOT, runs))
    ref = before or after
    head = ("run", "links", "iterations", "residual assemblies", "failed / stabilised",
            "solve CPU", "ratio")  # fmt: skip
    print("| " + " | ".join(head) + " |")
    print("|---|---|---|---|---|---|---|")
    tot_b = tot_a = 0.0
    for i in range(len(after[0])):
        a = after[0][i]
        b = ref[0][i]
        cb = statistics.median(p[i]["cpu_s"] for p in ref)
        ca = statistics.median(p[i]["cpu_s"] for p in after)
        tot_b += cb
        tot_a += ca
        print(
            f"| {i} | {a['elements']} | {b['iters']} -> {a['iters']} | {b['residuals']} -> "
            f"{a['residuals']} | {b['failed']}/{b['stabilised']} -> {a['failed']}/"
            f"{a['stabilised']} | {cb * 1e3:.0f} -> {ca * 1e3:.0f} ms | x{ca / cb:.3f} |"
        )
    print(f"| all | | | | | {tot_b * 1e3:.0f} -> {tot_a * 1e3:.0f} ms | x{tot_a / tot_b:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
