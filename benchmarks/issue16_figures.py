"""Issue 16's must-show table in one run: every figure, its goal, before vs now, ratio, met.

    .venv/bin/python benchmarks/issue16_figures.py                           # this checkout
    .venv/bin/python benchmarks/issue16_figures.py --baseline ../old-checkout --reps 3

Each checkout (this one, and ``--baseline`` if given) is measured in fresh processes through
``PYTHONPATH``, interleaved rep by rep so that load on the machine hits both alike:

- **first run**: ``ringqa commission`` on the Oncentra example (``--register plane-height``) with an
  EMPTY numba cache (``NUMBA_CACHE_DIR`` in a new temporary folder), process wall;
- **warm**: the same command again on the cache the first run filled, process wall;
- **six rings**: ``ringqa commission --all-shipped`` on the warm cache, process wall;
- **example ring simulation**: the RT Plan's ring channel with the Flexitron, twice: with the
  paper's Table 1 links (3 mm thin, 10 mm thick: the scene of ``benchmarks/compare_dwells.py``
  and of the issue's "56 links") and at the commissioning settings that ``ringqa commission``
  runs (2 mm / 5 mm links, 1 mm increment: ``ringqa.pipeline.simulate.commission_scene``);
  median solve time of warm runs in one process, stabilised steps, and the dwells' largest
  distance to the same scene refined 4x (element lengths and increment / 4);
- **ring26-flexitron**: the shipped scene, median solve time, Newton iterations, and the largest
  dwell distance to its 4x refinement;
- **TG-43**: ``tg43.plan_dose_gy`` on 100 000 points x 60 dwells, one numba thread, point-dwell
  evaluations per second (median of 5; input checks included).

The table is markdown on stdout (docs/speed.md's "Issue 16's must-show table" is pasted from it);
``--json`` keeps the raw numbers. The first-run figure includes the compile helper process that
``ringqa`` starts on the second core (as a new user gets it). Wall times on a shared machine are
noisy: run it on a quiet machine.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"

#: the engine and dose figures, run inside the checkout measured (prints one JSON line)
DRIVER = r"""
import json, statistics, sys, time
import numpy as np
from ringqa.pipeline.simulate import commission_scene, default_engine, refine_scene
from ringqa.simulation import simulate
from ringqa.simulation.scenefile import load_scene, scene_for_channel
from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

reps = int(sys.argv[1])

def timed(scene):
    res = simulate(scene)  # warm-up (numba cache load)
    times = []
    for _ in range(reps):
        res = simulate(scene)
        times.append(res.solve_time_s)
    return res, statistics.median(times)

def err_mm(a, b):
    return float(np.max(np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1)) * 1e3)

out = {}
app = applicator_from_rtplan(read_rtplan(sys.argv[2]))
scenes = {"example": scene_for_channel(app.channel("ring"), cable="flexitron"),
          "example_comm": commission_scene(default_engine(), app.channel("ring"), "flexitron", {}),
          "ring26": load_scene("data/scenes/ring26-flexitron.toml")}
for name, scene in scenes.items():
    res, t = timed(scene)
    ref = simulate(refine_scene(scene, 0.25))
    out[name] = {"time_s": t, "iters": int(res.settings["total_newton_iters"]),
                 "stabilised": int(res.settings["n_stabilised_steps"]),
                 "status": int(res.status), "ref_status": int(ref.status),
                 "err_4x_mm": err_mm(res, ref)}

import tg43
src = tg43.load_source("flexisource")
rng = np.random.default_rng(16)
pts = rng.uniform(-60.0, 60.0, (100_000, 3))
pts[:, 2] += 200.0  # well outside the dwells (no point inside a source)
pos = np.column_stack([np.linspace(-15, 15, 60), np.zeros(60), np.zeros(60)])
dirs = np.tile([1.0, 0.0, 0.0], (60, 1))
times_s = np.full(60, 10.0)
tg43.plan_dose_gy(src, pos, dirs, times_s, 40820.0, pts[:10])
ts = []
for _ in range(5):
    t0 = time.perf_counter()
    tg43.plan_dose_gy(src, pos, dirs, times_s, 40820.0, pts)
    ts.append(time.perf_counter() - t0)
out["tg43_rate"] = pts.shape[0] * pos.shape[0] / statistics.median(ts)
print(json.dumps(out))
"""


def _env(tree: Path, cache: str) -> dict:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(tree), NUMBA_CACHE_DIR=cache, RINGQA_CONFIG="", NUMBA_NUM_THREADS="1")
    env.pop("RINGQA_COMPILE_NOTICE", None)
    return env


def _wall(tree: Path, cache: str, *args: str) -> float:
    with tempfile.TemporaryDirectory() as out:
        t0 = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "ringqa", "commission", *args, "--out", f"{out}/o"],
            cwd=tree, env=_env(tree, cache), check=True,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        return time.perf_counter() - t0


def measure(tree: Path, reps: int) -> dict:
    """One rep of every figure for the checkout ``tree``."""
    with tempfile.TemporaryDirectory() as cache:
        rec = {"first_s": _wall(tree, cache, EXAMPLE, "--register", "plane-height")}
        rec["warm_s"] = min(
            _wall(tree, cache, EXAMPLE, "--register", "plane-height") for _ in range(2)
        )
        rec["six_s"] = _wall(tree, cache, "--all-shipped")
        env = _env(tree, cache)
        line = subprocess.run(
            [sys.executable, "-c", DRIVER, str(reps), EXAMPLE], cwd=tree, env=env,
            check=True, capture_output=True, text=True,
        ).stdout.strip().splitlines()[-1]  # fmt: skip
        rec.update(json.loads(line))
    return rec


#: (label, key, goal text, limit: (comparison, value) or None, format)
FIGURES = (
    ("first run, empty numba cache (process wall)", "first_s", "<= 15 s", ("<=", 15.0),
     "{:.1f} s"),
    ("the example again, warm (process wall)", "warm_s", "<= 2.0 s", ("<=", 2.0), "{:.2f} s"),
    ("example ring simulation, Table 1 links: solve time", "example.time_s", "<= 0.10 s",
     ("<=", 0.10), "{:.3f} s"),
    ("example ring simulation, Table 1 links: stabilised steps", "example.stabilised", "0",
     ("<=", 0), "{:d}"),
    ("example ring simulation, Table 1 links: dwells vs 4x refined", "example.err_4x_mm",
     "<= 0.1 mm", ("<=", 0.1), "{:.3f} mm"),
    ("example ring simulation, commissioning links: solve time", "example_comm.time_s",
     "<= 0.10 s", ("<=", 0.10), "{:.3f} s"),
    ("example ring simulation, commissioning links: stabilised steps",
     "example_comm.stabilised", "0", ("<=", 0), "{:d}"),
    ("example ring simulation, commissioning links: dwells vs 4x refined",
     "example_comm.err_4x_mm", "<= 0.1 mm", ("<=", 0.1), "{:.3f} mm"),
    ("ring26-flexitron solve", "ring26.time_s", "<= 20 ms", ("<=", 0.020), "{:.4f} s"),
    ("ring26-flexitron: Newton iterations", "ring26.iters", "", None, "{:d}"),
    ("ring26-flexitron: dwells vs 4x refined", "ring26.err_4x_mm", "as before or better", None,
     "{:.3f} mm"),
    ("six shipped rings end to end, warm (process wall)", "six_s", "<= 4 s", ("<=", 4.0),
     "{:.2f} s"),
    ("TG-43, one thread (point-dwell evaluations/s)", "tg43_rate", ">= 3e7 /s", (">=", 3e7),
     "{:.2e}"),
)  # fmt: skip


def _met(value, limit) -> str:
    if limit is None:
        return ""
    op, bound = limit
    ok = value <= bound if op == "<=" else value >= bound
    return "yes" if ok else "**no**"


def _get(rec: dict, key: str):
    for part in key.split("."):
        rec = rec[part]
    return rec


def _median(recs: list[dict], key: str):
    vals = [_get(r, key) for r in recs]
    m = statistics.median(vals)
    return int(m) if all(isinstance(v, int) for v in vals) and m == int(m) else m


def table(now: list[dict], before: list[dict] | None) -> str:
    head = "| figure | goal | " + ("before | " if before else "") + "now | "
    head += ("ratio | " if before else "") + "met |"
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for label, key, goal, limit, fmt in FIGURES:
        v = _median(now, key)
        cells = [label, goal]
        if before:
            b = _median(before, key)
            cells.append(fmt.format(b))
        cells.append(fmt.format(v))
        if before:
            cells.append(f"{v / b:.2f}" if b else "")
        cells.append(_met(v, limit))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3, help="repetitions of every figure")
    ap.add_argument("--baseline", type=Path, help="another checkout, measured interleaved")
    ap.add_argument("--json", type=Path, help="write the raw numbers here")
    args = ap.parse_args(argv)
    trees = {"now": ROOT}
    if args.baseline:
        trees["before"] = args.baseline.resolve()
    recs: dict[str, list[dict]] = {k: [] for k in trees}
    for rep in range(args.reps):
        for name, tree in trees.items():
            recs[name].append(measure(tree, args.reps))
            print(f"rep {rep + 1}/{args.reps} {name}: done", file=sys.stderr, flush=True)
    if args.json:
        args.json.write_text(json.dumps(recs, indent=1))
    print(f"{os.cpu_count()} cores, {args.reps} reps, medians; "
          f"now = {ROOT}" + (f", before = {trees['before']}" if args.baseline else ""))  # fmt: skip
    print(table(recs["now"], recs.get("before")))
    return 0


if __name__ == "__main__":
    sys.exit(main())
