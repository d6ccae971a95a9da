"""Needle study speed and accuracy (issue 14, Must-show 4).

    .venv/bin/python benchmarks/bench_needle.py [--repeats 3] [--no-refined] [--model] [--json F]

1. The whole paper sweep (34 rows, 28 channels) as a user runs it: ``ringqa needle --sweep
   paper`` in a fresh process (warm numba cache), wall time; target < 60 s on the 2-core machine.
   Also in-process on two processes and on one (the pool's speed-up).
2. One channel: engine solve time (JIT excluded, median of --repeats) of the default channel
   (r = 35 mm, tau = 0, 2.6 mm) and of the hardest (r = 20 mm, 2.6 mm), and the paper's
   15-25 min for comparison.
3. Accuracy: every channel of the sweep again with the links and the increments halved twice
   (0.825 -> 0.206 mm, 0.25 -> 0.0625 mm); the largest relative change of the 1st and 2nd peak
   (and of the plateau) over the 34 rows; target within 2 %.
4. With --model: how much modelling choices move the peaks (not numerical errors): the paper's
   model (its contact law, k = 1e6 N/m per contact point and r_a = r_b - 0.1 mm, with its 3.3 mm
   links and 0.5 mm increments), the paper's contact law with the default links (a per-point
   wall stiffens as the links shrink), wall damping c_w = 10 N s/m on, and the paper's 3.3 mm
   links and 0.5 mm increments with the default (rigid) wall.

Prints times, ratios and MET / NOT MET; ``--json`` also writes the numbers.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SWEEP_TARGET_S = 60.0
PEAK_TARGET = 0.02
REFINED = {"discretisation.element_length_mm": 0.825 / 4, "solver.increment_mm": 0.25 / 4}
PAPER_CONTACT = {
    "contact.stiffness_per_length": False,
    "contact.stiffness_n_m": 1.0e6,
    "contact.transition_mm": 0.1,
    "contact.transition_max_fraction": 0.5,
    "solver.contact_bow_fraction": 0.1,
}
PAPER_LINKS = {"discretisation.element_length_mm": 3.3, "solver.increment_mm": 0.5}
DAMPING = {"effects.wall_damping": True}


def _status(ok: bool) -> str:
    return "MET" if ok else "NOT MET"


def sweep_cli_s() -> float:
    """Wall time of ``ringqa needle --sweep paper`` in a fresh process (s)."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "ringqa", "needle", "--sweep", "paper", "--out", tmp, "--quiet"],
            check=True,
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
        )
        return time.perf_counter() - t0


def one_channel(settings, radius, repeats):
    from ringqa.needle.run import run_channel
    from ringqa.needle.scene import ChannelSpec, paper_channel

    ch = paper_channel(ChannelSpec(radius, 0.0, 2.6), settings)
    run_channel(ch, settings)  # JIT / cache load
    runs = [run_channel(ch, settings) for _ in range(repeats)]
    return (
        statistics.median(r.solve_time_s for r in runs),
        statistics.median(r.wall_time_s for r in runs),
        runs[-1],
    )


def compare(base, other, cols=("peak1_n", "peak2_n", "plateau_n")):
    """Largest |other / base - 1| per landmark over the rows, and where."""
    out = {}
    for c in cols:
        rel = (other[c].to_numpy() / base[c].to_numpy()) - 1.0
        i = int(np.nanargmax(np.abs(rel)))
        row = base.iloc[i]
        out[c] = (
            float(rel[i]),
            f"{row['family']} r={row['radius_mm']:g} tau={row['torsion_rad']:.2f} "
            f"D={row['diameter_mm']:g}",
            float(np.nanmedian(np.abs(rel))),
        )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-refined", action="store_true", help="skip the refined sweep")
    ap.add_argument("--model", action="store_true", help="also the modelling-choice sweeps")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()

    from ringqa.needle.scene import load_settings
    from ringqa.needle.sweep import run_sweep

    report: dict = {}
    settings = load_settings()
    print("== 1. the whole paper sweep (34 rows, 28 channels) ==")
    cli = [sweep_cli_s() for _ in range(args.repeats)]
    t_cli = statistics.median(cli)
    print(
        f"ringqa needle --sweep paper (fresh process, warm cache): median {t_cli:.1f} s of "
        f"{args.repeats} ({', '.join(f'{t:.1f}' for t in cli)}); target < {SWEEP_TARGET_S:g} s: "
        f"{_status(t_cli < SWEEP_TARGET_S)}"
    )
    base = run_sweep(settings, "paper", workers=2, progress=False)
    serial = run_sweep(settings, "paper", workers=1, progress=False)
    solves = [r.solve_time_s for r in base.runs.values()]
    print(
        f"in-process: 2 workers {base.wall_time_s:.1f} s, 1 worker {serial.wall_time_s:.1f} s "
        f"(speed-up x{serial.wall_time_s / base.wall_time_s:.2f}); sum of engine solve times "
        f"{sum(solves):.1f} s, largest {max(solves):.2f} s"
    )
    report["sweep"] = {
        "cli_s": cli,
        "cli_median_s": t_cli,
        "met": t_cli < SWEEP_TARGET_S,
        "in_process_2_workers_s": base.wall_time_s,
        "in_process_1_worker_s": serial.wall_time_s,
        "sum_solve_s": sum(solves),
    }

    print("\n== 2. one channel (solve time, JIT excluded) ==")
    for radius in (35.0, 20.0):
        solve, wall, run = one_channel(settings, radius, args.repeats)
        print(
            f"r = {radius:g} mm, 2.6 mm: solve {solve:.3f} s, run incl. set-up {wall:.3f} s "
            f"({run.n_elements} links, {run.depth_mm.size} depths); the paper: 15-25 min "
            f"(x{15 * 60 / solve:.0f}-{25 * 60 / solve:.0f})"
        )
        report[f"one_channel_r{radius:g}_s"] = solve

    base_t = base.peaks_table()
    if not args.no_refined:
        print("\n== 3. peaks against the refined sweep (links and increments halved twice) ==")
        fine = run_sweep(load_settings(overrides=REFINED), "paper", workers=2, progress=False)
        fine_t = fine.peaks_table()
        dev = compare(fine_t, base_t)
        worst = max(abs(dev["peak1_n"][0]), abs(dev["peak2_n"][0]))
        for c, (rel, where, med) in dev.items():
            print(f"{c}: largest {100 * rel:+.2f} % ({where}), median |dev| {100 * med:.2f} %")
        print(
            f"refined sweep {fine.wall_time_s:.1f} s; peaks within {100 * PEAK_TARGET:g} %: "
            f"{_status(worst <= PEAK_TARGET)} (largest {100 * worst:.2f} %)"
        )
        report["refined"] = {"deviation": dev, "met": worst <= PEAK_TARGET}

    if args.model:
        print("\n== 4. modelling choices (peaks relative to the default settings) ==")
        for label, over in (
            ("the paper's model (its contact law, 3.3 mm links)", {**PAPER_CONTACT, **PAPER_LINKS}),
            ("paper contact law (k 1e6 per point, r_a = r_b - 0.1 mm)", PAPER_CONTACT),
            ("wall damping c_w = 10 N s/m on", DAMPING),
            ("paper's 3.3 mm links, 0.5 mm increments", PAPER_LINKS),
        ):
            other = run_sweep(load_settings(overrides=over), "paper", workers=2, progress=False)
            dev = compare(base_t, other.peaks_table())
            text = "; ".join(
                f"{c} {100 * rel:+.2f} % at {where} (median {100 * med:.2f} %)"
                for c, (rel, where, med) in dev.items()
            )
            print(f"{label}: {text}; sweep {other.wall_time_s:.1f} s")
            report[label] = dev
    if args.json:
        args.json.write_text(json.dumps(report, indent=2, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
