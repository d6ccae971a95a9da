"""Whole-pipeline speed: all six shipped rings end to end (simulation, doses, CSV, PDF).

    /work/venv/bin/python benchmarks/bench_pipeline.py [--runs 2] [--stand-in] [--json OUT.json]

Each run is a fresh Python process (as a user's ``ringqa commission --all-shipped``) sharing one
new, empty numba cache folder: run 1 is the FIRST (cold) run -- numba compiles and caches every
kernel --, later runs are warm. Reported per run: wall time of the whole process, and inside it
the time for importing, commissioning (``pipeline_s``; ``simulation_s`` summed over the rings)
and writing the CSV/JSON files and PDFs (``write_s``, :func:`ringqa.report.write_batch`), and the
CPU seconds of the process and its workers (``--workers N``: batch worker processes, default
ringqa's ``min(2, cores)``). Targets: warm < 30 s on the CI machine (issue 5), <= 4 s (issue 16).

Without the engine (ringqa.simulation.simulate absent) or with ``--stand-in``, a stand-in engine
puts the source on the centreline: the numbers then measure everything except the simulation.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _stand_in():
    from types import SimpleNamespace

    import numpy as np

    def simulate(scene, advances_mm=None, progress=False):
        cl = scene.channel.centreline
        adv = np.asarray(advances_mm, dtype=float)
        s = adv * 1e-3
        return SimpleNamespace(
            status=0,
            message="",
            advances_mm=adv,
            source_pos_m=np.atleast_2d(cl.position(s)),
            source_dir=np.atleast_2d(cl.tangent(s)),
            warnings=(),
            solve_time_s=0.0,
            n_elements=0,
            settings={},
        )

    return simulate


def worker(out_dir: str, stand_in: bool, workers: int | None = None) -> dict:
    """One end-to-end run in this process (``ringqa commission --all-shipped``'s calls, with
    ``workers`` processes; None: ringqa's default); returns stage timings (s)."""
    t0 = time.perf_counter()
    sys.path.insert(0, str(ROOT))
    import ringqa.simulation as simulation
    from ringqa.io.applicator_file import shipped_applicators
    from ringqa.pipeline import commission_batch, default_engine
    from ringqa.report import write_batch

    t_import = time.perf_counter() - t0
    real = getattr(simulation, "simulate", None)
    used_stand_in = stand_in or real is None
    sim = _stand_in() if used_stand_in else real
    t1 = time.perf_counter()
    engine = dataclasses.replace(default_engine(), simulate=sim)
    kw = {} if workers is None else {"workers": workers}
    batch = commission_batch(shipped_applicators(), progress=False, engine=engine, **kw)
    t_pipeline = time.perf_counter() - t1
    t2 = time.perf_counter()
    write_batch(batch, Path(out_dir), **kw)  # tables, JSON, every PDF and summary.pdf
    t_write = time.perf_counter() - t2
    sums = {"load_s": 0.0, "simulation_s": 0.0, "dose_s": 0.0}
    for r in batch.results:
        for k in sums:
            sums[k] += getattr(r.timings, k)
    return {
        "stand_in_engine": used_stand_in,
        "n_ok": len(batch.results),
        "failures": [list(f) for f in batch.failures],
        "import_s": t_import,
        "pipeline_s": t_pipeline,
        **sums,
        "write_s": t_write,
        "in_process_total_s": time.perf_counter() - t0,
    }


def _children_cpu_s() -> float:
    """User + system CPU seconds of the finished child processes (and theirs)."""
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=2, help="processes to run (1st = cold)")
    ap.add_argument("--stand-in", action="store_true", help="use the stand-in engine")
    ap.add_argument("--json", type=Path, help="write the numbers to this file")
    ap.add_argument(
        "--workers", type=int, default=None, help="batch worker processes (default: ringqa's)"
    )
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.worker, args.stand_in, args.workers)))
        return 0
    rows = []
    with tempfile.TemporaryDirectory(prefix="ringqa-bench-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba-cache"))
        for k in range(args.runs):
            out = Path(tmp) / f"out{k}"
            cmd = [sys.executable, __file__, "--worker", str(out)]
            if args.stand_in:
                cmd.append("--stand-in")
            if args.workers is not None:
                cmd += ["--workers", str(args.workers)]
            cpu0 = _children_cpu_s()
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=ROOT)
            wall = time.perf_counter() - t0
            cpu = _children_cpu_s() - cpu0
            if proc.returncode:
                print(proc.stderr, file=sys.stderr)
                return 1
            row = json.loads(proc.stdout.strip().splitlines()[-1])
            row["process_wall_s"] = wall
            row["cpu_s"] = cpu  # the process and its workers, user + system
            row["run"] = "cold (first run, empty numba cache)" if k == 0 else "warm"
            rows.append(row)
    print("ringqa commission, six shipped rings end to end (simulation, doses, CSV, PDF)")
    if rows and rows[0]["stand_in_engine"]:
        print("  NOTE: stand-in engine (source on the centreline): simulation time not included")
    keys = ["process_wall_s", "cpu_s", "import_s", "pipeline_s", "simulation_s", "write_s"]
    print(f"  workers: {args.workers or 'default'}; simulation_s: summed over the applicators")
    print("  run    " + "".join(f"{k:>15}" for k in keys))
    for row in rows:
        label = "cold " if row["run"].startswith("cold") else "warm "
        print("  " + label + "  " + "".join(f"{row[k]:15.2f}" for k in keys))
    warm = [r["process_wall_s"] for r in rows[1:]]
    if warm:
        verdict = "meets" if max(warm) < 30.0 else "MISSES"
        print(f"  warm whole run {min(warm):.1f} s: {verdict} the 30 s target")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
