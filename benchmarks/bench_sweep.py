"""What ``ringqa sweep`` does per second on Dask, and what a cluster would do (issue 17; a
script, not a timed test).

    python benchmarks/bench_sweep.py [--samples 24] [--input ring26x60] [--sweep-json J]

Sections (markdown on stdout):

1. **Throughput**: the same small sweep (``--samples`` samples varying mu_k, the lumen diameter
   and EI, batches of 2) on a LocalCluster of 1 and of 2 worker processes: wall time of the
   samples (cluster start and the nominal run excluded), simulations per second, the sum of
   the samples' own times, and the numbers of the two runs compared (they must be equal).
2. **Per-task overhead**: 200 empty tasks through the scheduler (submit -> result in this
   process), and the overhead per task of the sweep itself: (workers x wall - sum of the
   samples' times) / tasks.
3. **Projection**: a 10,000-sample design study on 64 workers, from the measured per-sample
   time (this run's, or the mean of a real sweep's ``sweep.json`` given with ``--sweep-json``,
   e.g. the 256-sample Oncentra sweep) and the measured overhead:
   ``T = 10000 (t_sample + overhead / batch) / 64`` with t_sample the mean CPU time of a
   sample (a dedicated core's time; wall times here include waiting for other processes) and
   the overhead the empty-task round trip.

Wall times on a shared machine are noisy: the script says "measured under load" next to them;
the per-sample counts (runs per sample, samples per task) are exact.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.sweep import run_sweep  # noqa: E402
from ringqa.sweep.spec import spec_from_dict  # noqa: E402

PARAMS = {
    "contact.mu_k": {"distribution": "uniform", "low": 0.15, "high": 0.2},
    "lumen.diameter_delta_mm": {"distribution": "uniform", "low": 0.0, "high": 0.2},
    "instrument.ei_scale": {"distribution": "normal", "mean": 1.0, "sd": 0.05},
}


def _noop(x):
    return x


def _sweep(n_workers: int, spec, out: Path) -> dict:
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        res = run_sweep(spec, out, client=client)
        t0 = time.perf_counter()
        futs = client.map(_noop, range(200), pure=False)
        client.gather(futs)
        noop_s = (time.perf_counter() - t0) / 200
    t = res.record["timings_s"]
    n = len(res.samples.index)
    n_tasks = -(-n // spec.batch_size)
    return {
        "workers": n_workers,
        "samples": n,
        "wall_s": t["samples_wall"],
        "per_s": n / t["samples_wall"],
        "wall_sum_s": t["samples_wall_sum"],
        "mean_sample_s": t["mean_per_sample"],
        "cpu_sample_s": t["mean_cpu_per_sample"],
        "overhead_per_task_s": max(
            0.0, (n_workers * t["samples_wall"] - t["samples_wall_sum"]) / n_tasks
        ),
        "noop_task_s": noop_s,
        "x": res.samples.arrays["x_mm"],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=24)
    ap.add_argument("--input", default="ring26x60")
    ap.add_argument("--sweep-json", type=Path, default=None)
    args = ap.parse_args(argv)
    spec = spec_from_dict(
        {
            "input": args.input,
            "samples": args.samples,
            "seed": 1,
            "batch_size": 2,
            "parameters": PARAMS,
        }
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1, 2):
            rows.append(_sweep(n, spec, Path(tmp) / f"w{n}"))
    same = np.array_equal(rows[0]["x"], rows[1]["x"], equal_nan=True)
    print(
        f"## 1. Throughput ({args.input}, {args.samples} samples, batches of 2; "
        "measured under load)\n"
    )
    print(
        "| workers | wall of the samples, s | simulations/s | sum of sample wall times, s |"
        " mean wall per sample, s | mean CPU per sample, s |"
    )
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['workers']} | {r['wall_s']:.2f} | {r['per_s']:.2f} | {r['wall_sum_s']:.2f} |"
            f" {r['mean_sample_s']:.3f} | {r['cpu_sample_s']:.3f} |"
        )
    print(
        f"\nSpeed-up 1 -> 2 workers: {rows[1]['per_s'] / rows[0]['per_s']:.2f}x; "
        f"positions of the two runs bit-identical: {same}\n"
    )
    print("## 2. Per-task overhead (measured under load)\n")
    for r in rows:
        print(
            f"- {r['workers']} worker(s): empty task round trip {1e3 * r['noop_task_s']:.1f} ms;"
            f" sweep overhead per task {1e3 * r['overhead_per_task_s']:.0f} ms"
        )
    # CPU time per sample: what a dedicated core spends (the wall times here include waiting
    # for the other engineers' processes); overhead: the empty-task round trip
    t_sample = float(np.mean([r["cpu_sample_s"] for r in rows]))
    source = f"{args.input}, mean CPU time of this run's samples"
    if args.sweep_json is not None:
        rec = json.loads(args.sweep_json.read_text())
        t = rec["timings_s"]
        t_sample = float(t.get("mean_cpu_per_sample") or t["mean_per_sample"])
        source = f"{rec['spec'].get('input')}, {rec['n_ok']} samples ({args.sweep_json})"
    overhead = max(r["noop_task_s"] for r in rows)
    batch = spec.batch_size
    total = 10_000 * (t_sample + overhead / batch) / 64
    print("\n## 3. Projection: 10,000 samples on 64 workers\n")
    print(
        f"t_sample = {t_sample:.3f} s ({source}), overhead {1e3 * overhead:.0f} ms per task of "
        f"{batch}: T = 10000 x ({t_sample:.3f} + {overhead:.3f}/{batch}) / 64 = {total:.0f} s "
        f"= {total / 60:.1f} min (plus the cluster's start and one nominal run)"
    )
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
