"""Cold start and warm start-up of ``ringqa commission`` on the example, before vs after.

    .venv/bin/python benchmarks/bench_coldstart.py                      # 3 reps, this checkout
    .venv/bin/python benchmarks/bench_coldstart.py --reps 2 --baseline /path/to/old/checkout

Every figure is a fresh process (``subprocess``) with its own ``NUMBA_CACHE_DIR``:

- **first run**: ``ringqa commission`` on the Oncentra example with an EMPTY numba cache (median
  of ``--reps``), split into imports, numba compilation (sum of the top-level ``numba:compile``
  events: numba fires them only on a cache miss) and the rest (input, simulation, dose, report);
  also the number of kernels compiled;
- the CPU seconds of each run (the command and its compile helper, ``RUSAGE_CHILDREN``)
  and of its compiles in the command's process: less sensitive to load than wall times;
- **warm run**: the same command again on the cache the first run filled (median);
- **import**: ``import ringqa.cli`` and ``import ringqa.pipeline`` (what commission imports
  before it reads the input), median of 5.

The baseline is another checkout (default: the main checkout beside this worktree) run through
``PYTHONPATH`` in the same session, interleaved with this one, so load on the machine hits both
alike; each figure is printed with its ratio after/before. Wall times on a shared machine are
noisy: the kernel counts are load-independent, the times are not.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _baseline import add_baseline_option
from _baseline import trees as baseline_trees

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = Path("data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm")

#: runs ringqa commission in the child and prints one JSON line with its phase split
DRIVER = r"""
import json, sys, time
t0 = time.perf_counter()
import ringqa.cli
t_cli = time.perf_counter() - t0
from numba.core import event
depth = [0]; start = [0.0, 0.0]; comp = []; cpu = []
class L(event.Listener):
    def on_start(self, ev):
        if depth[0] == 0:
            start[0] = time.perf_counter()
            start[1] = time.process_time()
        depth[0] += 1
    def on_end(self, ev):
        depth[0] -= 1
        if depth[0] == 0:
            comp.append(time.perf_counter() - start[0])
            cpu.append(time.process_time() - start[1])
event.register("numba:compile", L())
rc = ringqa.cli.main(sys.argv[1:])
wall = time.perf_counter() - t0
print("BENCH" + json.dumps({"rc": rc, "in_process_s": wall, "cli_import_s": t_cli,
                            "compile_s": sum(comp), "compile_cpu_s": sum(cpu),
                            "n_compiled": len(comp)}))
"""

IMPORT = r"""
import time
t0 = time.perf_counter()
import {mod}
print("BENCH%r" % (time.perf_counter() - t0))
"""


def _env(root: Path, cache: str) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(root)
    env["NUMBA_CACHE_DIR"] = cache
    return env


def commission_run(root: Path, cache: str) -> dict:
    """One ``ringqa commission`` on the example in a fresh process; wall and phase split (s)."""
    with tempfile.TemporaryDirectory() as out:
        args = [str(root / EXAMPLE), "--register", "plane-height", "--out", f"{out}/o"]
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = _now()
        p = subprocess.run(
            [sys.executable, "-c", DRIVER, "commission", *args],
            env=_env(root, cache), cwd=root, capture_output=True, text=True, check=False,
        )  # fmt: skip
        wall = _now() - t0
        ru1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    line = next((x for x in p.stdout.splitlines() if x.startswith("BENCH")), None)
    if line is None:
        raise SystemExit(f"commission failed under {root}:\n{p.stderr[-2000:]}")
    rec = json.loads(line[5:])
    rec["wall_s"] = wall
    # CPU of the command and of its compile helper (less sensitive to load than the wall)
    rec["cpu_s"] = (ru1.ru_utime - ru0.ru_utime) + (ru1.ru_stime - ru0.ru_stime)
    rec["noticed"] = "compiling the numerical kernels once" in p.stderr
    return rec


def import_time(root: Path, mod: str, cache: str) -> float:
    """Seconds to import ``mod`` in a fresh process."""
    p = subprocess.run(
        [sys.executable, "-c", IMPORT.format(mod=mod)],
        env=_env(root, cache), capture_output=True, text=True, check=True,
    )  # fmt: skip
    return float(next(x for x in p.stdout.splitlines() if x.startswith("BENCH"))[5:])


def _now() -> float:
    import time

    return time.perf_counter()


def _med(xs):
    return statistics.median(xs) if xs else float("nan")


def measure(trees: dict[str, Path], reps: int) -> dict[str, dict]:
    """Interleaved measurements of every tree (name -> figures)."""
    res: dict[str, dict] = {
        k: {"cold": [], "warm": [], "imp_cli": [], "imp_pipe": []} for k in trees
    }
    caches = {k: tempfile.mkdtemp(prefix=f"bench_coldstart_{k}_") for k in trees}
    for i in range(reps):
        for name, root in trees.items():
            fresh = tempfile.mkdtemp(prefix=f"bench_coldstart_{name}_cold{i}_")
            rec = commission_run(root, fresh)
            res[name]["cold"].append(rec)
            caches[name] = fresh  # the filled cache serves the warm runs
            print(
                f"  {name} first run {i + 1}/{reps}: {rec['wall_s']:.1f} s "
                f"(compile {rec['compile_s']:.1f} s, {rec['n_compiled']} kernels)",
                flush=True,
            )
    for i in range(reps):
        for name, root in trees.items():
            rec = commission_run(root, caches[name])
            res[name]["warm"].append(rec)
            print(
                f"  {name} warm run {i + 1}/{reps}: {rec['wall_s']:.1f} s "
                f"({rec['n_compiled']} kernels compiled)",
                flush=True,
            )
    for _ in range(5):
        for name, root in trees.items():
            res[name]["imp_cli"].append(import_time(root, "ringqa.cli", caches[name]))
            res[name]["imp_pipe"].append(import_time(root, "ringqa.pipeline", caches[name]))
    return res


def figures(r: dict) -> dict[str, float]:
    """The medians printed in the table (s, or counts)."""
    cold, warm = r["cold"], r["warm"]
    return {
        "first run, empty cache (s)": _med([c["wall_s"] for c in cold]),
        "  CPU of it, all processes (s)": _med([c["cpu_s"] for c in cold]),
        "  of which numba compile (s)": _med([c["compile_s"] for c in cold]),
        "  numba compile CPU, the command's process (s)": _med([c["compile_cpu_s"] for c in cold]),
        "  of which imports of ringqa.cli (s)": _med([c["cli_import_s"] for c in cold]),
        "  rest: input, simulation, dose, report (s)": _med(
            [c["in_process_s"] - c["compile_s"] - c["cli_import_s"] for c in cold]
        ),
        "kernels compiled on the first run": _med([c["n_compiled"] for c in cold]),
        "warm run (s)": _med([c["wall_s"] for c in warm]),
        "  CPU of it (s)": _med([c["cpu_s"] for c in warm]),
        "kernels compiled on the warm run": _med([c["n_compiled"] for c in warm]),
        "import ringqa.cli (s)": _med(r["imp_cli"]),
        "import ringqa.pipeline (s)": _med(r["imp_pipe"]),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    add_baseline_option(ap)
    args = ap.parse_args(argv)
    trees = baseline_trees(args.baseline)
    print(f"bench_coldstart: {args.reps} rep(s), {os.cpu_count()} cores; "
          f"trees: {', '.join(f'{k}={v}' for k, v in trees.items())}", flush=True)  # fmt: skip
    res = measure(trees, args.reps)
    figs = {k: figures(v) for k, v in res.items()}
    after = figs["after"]
    before = figs.get("before")
    notice = all(c["noticed"] for c in res["after"]["cold"]) and not any(
        c["noticed"] for c in res["after"]["warm"]
    )
    print()
    print(f"{'figure (medians; wall times measured under load)':50s} {'before':>9s} "
          f"{'after':>9s} {'ratio':>7s}")  # fmt: skip
    for key, val in after.items():
        b = before[key] if before else float("nan")
        ratio = val / b if before and b else float("nan")
        print(f"{key:50s} {b:9.2f} {val:9.2f} {ratio:7.2f}")
    print(f"compile notice on the first run only: {notice}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
