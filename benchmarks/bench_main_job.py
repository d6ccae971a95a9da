"""CPU time of README's main job by phase, before vs after (issue 27: the 2 s warm run).

    .venv/bin/python benchmarks/bench_main_job.py                       # 3 reps, this checkout
    .venv/bin/python benchmarks/bench_main_job.py --baseline /work/main # ... and main, interleaved

Each rep runs, for each checkout (this one and ``--baseline``, through ``PYTHONPATH``,
interleaved), a fresh process that runs ``ringqa commission <example plan> --register
plane-height --out DIR --quiet`` in-process (``ringqa.cli.main``; the numba cache warm: one
warm-up run per checkout first) and takes the process's CPU time (``time.process_time``: less
sensitive to other users of the machine than wall time) at each phase:

- ``cli``: ``import ringqa.cli`` and the argument parser;
- ``input``: reading the input (``ringqa.cli.channels.channels_wanted``);
- ``commission``: registration, both simulations, doses, verdicts
  (``ringqa.cli.commission.commission_ahead``) with the pipeline's imports;
- ``report``: the staged output folder: tables, ``report.html``, ``report.pdf``
  (``ringqa.report.write_report``; its parts ``tables``, ``html``, ``pdf`` below it) with the
  report's imports (matplotlib, reportlab, plotly, pandas where first used);
- ``audit``: the audit trail's file hashes;
- every phase is this process's CPU (``this process``: all of it; with ``--free-core`` the
  critical path of a quiet machine); ``children``: the CPU of the forked children (used only
  where a core is free, or with ``--free-core``); ``total``: both (``resource.getrusage``).

``non-simulation`` = total - the CPU of reading the input (``load_input``, both calls), of the
simulations (``simulate_dwells``) and of the doses (without ``--free-core``: the commissioning
then runs in this process): the part issue 27 asks to bring to about 0.8 s. Also printed: the
modules imported and the heavy libraries imported. Medians over ``--reps``; ratios
after/before.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from _baseline import add_baseline_option
from _baseline import trees as baseline_trees

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"

WORKER = r"""
import importlib.abc, json, resource, sys, time
T = {}
N = {}
t_start = time.process_time()
PATCH = {}   # module name -> [(attribute, phase)]: wrapped when the module is first imported

def cpu():  # this process only (forked children: "children" below)
    return time.process_time()

def timed(fn, phase):
    def wrapper(*a, **k):
        t0 = cpu()
        try:
            return fn(*a, **k)
        finally:
            T[phase] = T.get(phase, 0.0) + cpu() - t0
            N[phase] = N.get(phase, 0) + 1
    return wrapper

class Hook(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name not in PATCH:
            return None
        sys.meta_path.remove(self)
        try:
            spec = importlib.util.find_spec(name)
        finally:
            sys.meta_path.insert(0, self)
        real = spec.loader.exec_module
        def exec_module(module):
            real(module)
            for attr, phase in PATCH[name]:
                if phase == "free":
                    setattr(module, attr, lambda: True)
                elif hasattr(module, attr):
                    setattr(module, attr, timed(getattr(module, attr), phase))
        spec.loader.exec_module = exec_module
        return spec

import importlib.util
PATCH.update({
    "ringqa.cli.channels": [("channels_wanted", "input")],
    "ringqa.cli.commission": [("commission_ahead", "commission"), ("audit_files", "audit")],
    "ringqa.report": [("write_report", "report"), ("write_tables", "tables"), ("write_pdf", "pdf")],
    "ringqa.report.html": [("write_html", "html")],
    "ringqa.pipeline.inputs": [("load_input", "load")],
    "ringqa.pipeline.commission": [("simulate_dwells", "simulation"),
                                   ("standard_plans", "dose"), ("dose_tables", "dose")],
})
sys.meta_path.insert(0, Hook())
if sys.argv[3] == "free-core":  # as on a quiet machine: the second core is used
    PATCH["ringqa.parallel"] = [("second_core_free", "free")]
import ringqa.cli
ringqa.cli.build_parser()
T["cli"] = time.process_time() - t_start
code = ringqa.cli.main(["commission", sys.argv[1], "--register", "plane-height",
                        "--out", sys.argv[2], "--quiet"])
own = resource.getrusage(resource.RUSAGE_SELF)
kids = resource.getrusage(resource.RUSAGE_CHILDREN)
T["total"] = own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime
T["children"] = kids.ru_utime + kids.ru_stime
T["this process"] = own.ru_utime + own.ru_stime
rec = json.load(open(sys.argv[2] + "/results.json"))["timings_s"]
heavy = [m for m in ("matplotlib", "reportlab", "plotly", "pandas", "scipy", "PIL")
         if m in sys.modules]
print("BENCH" + json.dumps({"phases": T, "calls": N, "timings": rec, "modules": len(sys.modules),
                            "heavy": heavy, "code": code}))
"""


def run(root: Path, out: Path, free_core: bool) -> dict:
    """One worker process under ``root``; its record."""
    env = dict(os.environ, PYTHONPATH=str(root))
    p = subprocess.run(
        [sys.executable, "-c", WORKER, EXAMPLE, str(out), "free-core" if free_core else "load"],
        env=env, cwd=root, capture_output=True, text=True, check=False,
    )  # fmt: skip
    line = next((x for x in p.stdout.splitlines() if x.startswith("BENCH")), None)
    if line is None:
        raise SystemExit(f"bench_main_job failed under {root}:\n{p.stderr[-3000:]}")
    rec = json.loads(line[5:])
    ph = rec["phases"]
    ph["non-simulation"] = ph["total"] - sum(ph.get(k, 0.0) for k in ("load", "simulation", "dose"))
    return rec


PHASES = ("cli", "input", "load", "commission", "simulation", "dose", "report", "tables", "html",
          "pdf", "audit", "this process", "children", "total", "non-simulation")  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--free-core", action="store_true",
                    help="use the second core as on a quiet machine (ringqa forks its independent "
                    "work only when the load leaves a core free): 'this process' is then the "
                    "critical path")  # fmt: skip
    add_baseline_option(ap)
    args = ap.parse_args(argv)
    trees = baseline_trees(args.baseline)
    recs: dict[str, list[dict]] = {k: [] for k in trees}
    with tempfile.TemporaryDirectory(prefix="bench_main_job_") as tmp:
        for name, root in trees.items():
            # the numba cache and the page cache
            run(root, Path(tmp) / f"warm-{name}", args.free_core)
        for i in range(args.reps):
            for name, root in trees.items():
                rec = run(root, Path(tmp) / f"{name}{i}", args.free_core)
                recs[name].append(rec)
                ph = rec["phases"]
                print(f"  {name} {i + 1}/{args.reps}: total {ph['total']:.2f} CPU s, "
                      f"non-simulation {ph['non-simulation']:.2f}", flush=True)  # fmt: skip
    med = statistics.median
    table = {k: {p: med(r["phases"].get(p, 0.0) for r in v) for p in PHASES}
             for k, v in recs.items()}  # fmt: skip
    for k, v in recs.items():
        for t in ("load_s", "simulation_s", "dose_s"):
            table[k][f"results.json {t}"] = med(r["timings"][t] for r in v)
        table[k]["modules imported"] = med(r["modules"] for r in v)
    load = os.getloadavg()[0]
    head = f"CPU s, medians ({os.cpu_count()} cores, load {load:.1f})"
    ratio_head = "    ratio" if len(table) == 2 else ""
    print(f"\n{head:40s} " + "".join(f"{k:>9s}" for k in table) + ratio_head)
    for key in table["after"]:
        vals = [table[k][key] for k in table]
        ratio = f"{vals[1] / vals[0]:9.2f}" if len(vals) == 2 and vals[0] else ""
        print(f"{key:40s} " + "".join(f"{v:9.2f}" for v in vals) + ratio)
    for k, v in recs.items():
        print(f"{k}: heavy libraries imported: {', '.join(v[-1]['heavy'])}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
