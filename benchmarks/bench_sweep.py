"""What ``ringqa sweep`` costs per sample and how it scales with workers (issues 17 and 29; a
script, not a timed test).

    python benchmarks/bench_sweep.py [--workers 1,2] [--per-worker 32] [--before 8]
                                     [--spec data/sweeps/ring26-uncertainty.toml]
                                     [--max-seconds 480]

Sections (markdown on stdout):

1. **Seconds per sample, before and after** (one invocation): the spec's first ``--before``
   samples as full commissioning runs (``numerics = "full"``: the commissioning run, the refined
   run, probes and resolving runs where the path branches; what every sample cost before issue
   29) and the same samples as cheap samples (``numerics = "calibrated"``: one engine run at the
   commissioning settings), both on one worker: median, p95 and max of each sample's CPU and
   wall seconds.
2. **Scaling** (weak: ``--per-worker`` samples per worker): for each worker count a fresh
   LocalCluster of worker processes; the wall time of the samples only (the cluster's start,
   the nominal run and the calibration excluded: reported apart), samples per second,
   speed-up over one worker, efficiency = speed-up / workers, and busy = the samples' own wall
   times summed / (workers x wall) (1: no worker ever waited for work). The samples common to the
   1- and 2-worker runs must be identical to the last digit (the script exits 1 if not).
3. **Per-task overhead**: 200 empty tasks through the scheduler.

``--max-seconds`` bounds the whole run: a worker count whose projected time would pass it is
skipped and said so. Wall times on a shared machine are noisy: CPU seconds per sample are the
steadier number.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ringqa.sweep import load_spec, run_sweep  # noqa: E402
from ringqa.sweep.execute import connect  # noqa: E402

DEFAULT_SPEC = ROOT / "data" / "sweeps" / "ring26-uncertainty.toml"


def _noop(x):
    return x


def _run(spec_path: Path, sets: dict, n_workers: int, out: Path) -> dict:
    spec = load_spec(spec_path, sets)
    t0 = time.perf_counter()
    # the same local cluster `ringqa sweep --workers N` starts (one thread a worker)
    with connect(None, n_workers) as client:
        start_s = time.perf_counter() - t0
        res = run_sweep(spec, out, client=client)
        t1 = time.perf_counter()
        client.gather(client.map(_noop, range(200), pure=False))
        noop_s = (time.perf_counter() - t1) / 200
    t = res.record["timings_s"]
    s = res.samples
    return {
        "workers": n_workers,
        "samples": len(s.index),
        "ok": int(s.ok.sum()),
        "wall_s": t["samples_wall"],
        "calibration_s": t.get("calibration", 0.0),
        "nominal_s": t["nominal_run"],
        "cluster_s": start_s,
        "per_s": len(s.index) / t["samples_wall"],
        "cpu": np.asarray(s.cpu_seconds, float),
        "sec": np.asarray(s.seconds, float),
        "batch": res.record["execution"]["batch_size"],
        "noop_s": noop_s,
        "index": np.asarray(s.index),
        "x": s.arrays["x_mm"],
        "dev": s.arrays["deviation_mm"],
        "dose": s.arrays["dose_diff_pct"],
    }


def _stats(v: np.ndarray) -> str:
    v = v[np.isfinite(v)]
    if v.size == 0:
        return "- | - | -"
    return f"{np.median(v):.3f} | {np.percentile(v, 95):.3f} | {np.max(v):.3f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--spec", type=Path, default=DEFAULT_SPEC)
    ap.add_argument("--workers", default="1,2", help="worker counts, e.g. 1,2,4,8,16")
    ap.add_argument("--per-worker", type=int, default=32, help="samples per worker (weak scaling)")
    ap.add_argument("--before", type=int, default=8, help="samples run both ways (section 1)")
    ap.add_argument("--calibration", type=int, default=2, help="calibration_samples")
    ap.add_argument("--max-seconds", type=float, default=480.0)
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    counts = [int(w) for w in args.workers.split(",")]
    print(
        f"# bench_sweep: {args.spec.name}, {os.cpu_count()} cores, workers {counts}, "
        f"{args.per_worker} samples per worker\n"
    )
    same = True
    with tempfile.TemporaryDirectory() as tmp:
        if args.before > 0:
            base = {"samples": args.before, "calibration_samples": args.calibration}
            full = _run(args.spec, {**base, "numerics": "full"}, 1, Path(tmp) / "full")
            cheap = _run(args.spec, base, 1, Path(tmp) / "cheap")
            print(f"## 1. Seconds per sample, before and after ({args.before} samples, 1 worker)\n")
            print("| samples as | ok | CPU s: median | p95 | max | wall s: median | p95 | max |")
            print("|---|---|---|---|---|---|---|---|")
            for name, r in (("full commissioning runs (before)", full), ("cheap (after)", cheap)):
                print(
                    f"| {name} | {r['ok']}/{r['samples']} | {_stats(r['cpu'])} | "
                    f"{_stats(r['sec'])} |"
                )
            ratio = np.nanmedian(full["cpu"]) / np.nanmedian(cheap["cpu"])
            print(f"\nMedian CPU per sample {ratio:.1f}x less.\n", flush=True)
        rows = []
        for w in counts:
            spent = time.perf_counter() - t_start
            if rows:
                per_sample = rows[0]["wall_s"] / rows[0]["samples"]
                projected = 30.0 + 2.0 * w + per_sample * args.per_worker * 1.5
                if spent + projected > args.max_seconds:
                    print(f"(skipped {w} workers: {spent:.0f} s spent, ~{projected:.0f} s more)")
                    continue
            sets = {"samples": args.per_worker * w, "calibration_samples": args.calibration}
            rows.append(_run(args.spec, sets, w, Path(tmp) / f"w{w}"))
            r = rows[-1]
            print(
                f"- {w} worker(s): {r['samples']} samples in {r['wall_s']:.2f} s "
                f"(batch {r['batch']}; cluster start {r['cluster_s']:.1f} s, nominal "
                f"{r['nominal_s']:.1f} s, calibration {r['calibration_s']:.1f} s)",
                flush=True,
            )
        by_w = {r["workers"]: r for r in rows}
        if 1 in by_w and 2 in by_w:
            a, b = by_w[1], by_w[2]
            common = np.intersect1d(a["index"], b["index"])
            ia, ib = np.searchsorted(a["index"], common), np.searchsorted(b["index"], common)
            same = all(
                np.array_equal(a[k][ia], b[k][ib], equal_nan=True) for k in ("x", "dev", "dose")
            )
        print("\n## 2. Scaling (weak: samples = workers x per-worker; wall of the samples)\n")
        print(
            "| workers | samples | ok | wall, s | samples/s | speed-up | efficiency | "
            "busy | CPU s per sample: median | p95 | max |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        one = rows[0]["per_s"] if rows and rows[0]["workers"] == 1 else None
        for r in rows:
            sp = r["per_s"] / one if one else float("nan")
            print(
                f"| {r['workers']} | {r['samples']} | {r['ok']} | {r['wall_s']:.2f} | "
                f"{r['per_s']:.2f} | {sp:.2f}x | {sp / r['workers']:.2f} | "
                f"{np.nansum(r['sec']) / (r['workers'] * r['wall_s']):.2f} | {_stats(r['cpu'])} |"
            )
        if 1 in by_w and 2 in by_w:
            print(f"\n1 vs 2 workers, common samples identical to the last digit: {same}")
        print("\n## 3. Per-task overhead\n")
        for r in rows:
            print(f"- {r['workers']} worker(s): empty task round trip {1e3 * r['noop_s']:.1f} ms")
    print(f"\n(total {time.perf_counter() - t_start:.0f} s)")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
