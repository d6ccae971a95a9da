"""CPU time of README's main job by phase, before vs after (issue 27: the 2 s warm run).

    .venv/bin/python benchmarks/bench_main_job.py                       # 3 reps, this checkout
    .venv/bin/python benchmarks/bench_main_job.py --baseline /work/main # ... and main, interleaved
    .venv/bin/python benchmarks/bench_main_job.py --timeline --free-core --baseline DIR
                                        # every process traced; the idle 2-core wall modelled
    ... --bytecode written              # each checkout's bytecode written first (a user's
                                        # install; default as-is: see below)

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

``--timeline`` (for a loaded machine, where wall times mislead): the real command
(``console_main``, as the ``ringqa`` script) with a trace of every process: its start, each
fork, each wait for a forked call's result and each child stopped, the phases and the exit,
stamped with the wall clock and the process's own CPU time. From it, the wall time on an idle
machine is modelled (:func:`quiet_wall`): each process needs the CPU its trace records between
its forks and waits, a child is runnable from its fork, a parent waiting for a child is blocked
until the child exits, and the runnable processes share the cores. It printed 4.39 s (median,
load 6) for main at 18b4b26, which the lead measured at 3.8-4.0 s on the quiet machine: CPU
times under load run 10-15 % high, so compare checkouts interleaved, not with the quiet
figure. A second model counts each process's main thread only ("main threads"): the ringqa
script runs OpenBLAS with one thread, an older checkout's OpenBLAS threads spin while numpy is
imported (0.13-0.17 s of CPU of its start-up, on the core the start-up leaves idle), which the
first model puts on the critical path. Printed per process: its phases' CPU and when it forked
and waited; and, medians over
the runs, the CPU of each step on the critical path (:func:`critical_path`: the start-up
before the fork, reading the input, the commissioning run, the longest forked engine run, the
report in this process, the longest figure child).

Bytecode: under ``PYTHONDONTWRITEBYTECODE`` (set in some containers, CI images and this
project's sessions) an editable install compiles ringqa's ~150 modules from source on every
run, 0.1-0.25 s of CPU that a user's install (whose first run writes ``__pycache__``) does not
pay; ``ringqa warmup`` and a first run on an empty kernel cache now write them. The first line
printed says how many modules of each checkout lack bytecode; ``--bytecode written`` gives
every checkout its bytecode in a temporary folder (``PYTHONPYCACHEPREFIX``), so that only the
code's own differences are compared.
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


#: ``--timeline``: the real command (``ringqa.cli.console_main``, as the ``ringqa`` script runs
#: it) with every process's events written to a trace file: each process's start, every fork
#: (``os.fork``: the parent's and the child's side), every wait for a child's result
#: (``ForkedCall.result``), the end of every forked call in its child (``done``: the parent
#: kills a child once it has its result, often before the child's exit is traced), every child
#: stopped (``ForkedCall.cancel`` of a running child), the
#: phases below (begin/end) and each process's exit (``os._exit``), each stamped with the
#: monotonic wall clock, the process's own CPU time (a forked child's starts at zero) and its
#: main thread's CPU time (without helper threads such as OpenBLAS's).
TIMELINE_WORKER = r"""
import importlib.abc, importlib.util, json, os, sys, time
_fd = os.open(sys.argv[3], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)

def ev(kind, arg=None):
    line = json.dumps([os.getpid(), kind, arg, time.perf_counter(), time.process_time(),
                       time.thread_time()])
    os.write(_fd, (line + "\n").encode())

ev("start")
_fork, _exit = os.fork, os._exit

def fork():
    pid = _fork()
    ev("child", os.getppid()) if pid == 0 else ev("fork", pid)
    return pid

def exit_(code):
    ev("exit", code)
    _exit(code)

os.fork, os._exit = fork, exit_

def phase(fn, name):
    def wrapper(*a, **k):
        ev("begin", name)
        try:
            return fn(*a, **k)
        finally:
            ev("end", name)
    return wrapper

def forked_result(fn):
    def result(self):
        pid = self._pid
        ev("wait", pid)
        try:
            return fn(self)
        finally:
            ev("waited", pid)
    return result

def forked_init(init):
    # the call's end in the child ("done"): a parent that has read the result kills the child
    # at once, often before the child's exit is traced, which lost the child's CPU
    def __init__(self, fn, fork=True):
        def traced():
            try:
                return fn()
            finally:
                ev("done")
        init(self, traced, fork)
    return __init__

def forked_cancel(fn):
    def cancel(self):
        if self._pid:
            ev("kill", self._pid)
        return fn(self)
    return cancel

PATCH = {
    "ringqa.cli.channels": [("channels_wanted", "input")],
    "ringqa.cli.commission": [("commission_ahead", "commission"), ("audit_files", "audit")],
    "ringqa.report": [("write_report", "report"), ("prepare_report", "prepare report")],
    "ringqa.report.html": [("write_html", "html")],
    "ringqa.pipeline.inputs": [("load_input", "load")],
    "ringqa.pipeline.commission": [("simulate_dwells", "simulation")],
    "ringqa.pipeline.simulate": [("_run_with_retries", "engine run")],
}

class Hook(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name not in PATCH and name != "ringqa.parallel":
            return None
        sys.meta_path.remove(self)
        try:
            spec = importlib.util.find_spec(name)
        finally:
            sys.meta_path.insert(0, self)
        real = spec.loader.exec_module
        def exec_module(module):
            real(module)
            if name == "ringqa.parallel":
                fc = module.ForkedCall
                fc.__init__ = forked_init(fc.__init__)
                fc.result = forked_result(fc.result)
                fc.cancel = forked_cancel(fc.cancel)
                if FREE == "free-core":  # as on a quiet machine: the second core is used
                    module.second_core_free = lambda: True
            for attr, ph in PATCH.get(name, ()):
                if hasattr(module, attr):
                    setattr(module, attr, phase(getattr(module, attr), ph))
        spec.loader.exec_module = exec_module
        return spec

sys.meta_path.insert(0, Hook())
FREE = sys.argv[4]
sys.argv = ["ringqa", "commission", sys.argv[1], "--register", "plane-height", "--out",
            sys.argv[2], "--quiet"]
from ringqa.cli import console_main
console_main()
"""


#: ``--bytecode written``: the folder the measured processes keep their bytecode in (set by
#: :func:`main`; None: the environment as it is)
BYTECODE_DIR: Path | None = None


def environment(root: Path) -> dict[str, str]:
    """The environment of a measured process under ``root``: this one's, with ``PYTHONPATH``
    the checkout; with ``--bytecode written`` also without ``PYTHONDONTWRITEBYTECODE`` and with
    ``PYTHONPYCACHEPREFIX`` a temporary folder (the warm-up run writes every checkout's bytecode
    there, as a user's first run does beside the sources; the checkouts are not written)."""
    env = dict(os.environ, PYTHONPATH=str(root))
    if BYTECODE_DIR is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(BYTECODE_DIR)
    return env


def missing_bytecode(root: Path) -> int:
    """How many modules of ringqa and tg43 under ``root`` have no bytecode file where this
    environment's Python looks for it (each is compiled from source on every run when
    ``PYTHONDONTWRITEBYTECODE`` is set: ``ringqa warmup`` writes them)."""
    from importlib.util import cache_from_source

    files = [f for pkg in ("ringqa", "tg43") for f in (root / pkg).rglob("*.py")]
    return sum(not Path(cache_from_source(str(f))).is_file() for f in files)


def bytecode_note(trees: dict[str, Path]) -> str:
    """One line on how the measured processes get their bytecode."""
    if BYTECODE_DIR is not None:
        return ("bytecode: written once per checkout by the warm-up run into a temporary "
                "PYTHONPYCACHEPREFIX (as a user's first run does)")  # fmt: skip
    flag = os.environ.get("PYTHONDONTWRITEBYTECODE")
    missing = ", ".join(f"{k} {missing_bytecode(v)}" for k, v in trees.items())
    return (f"bytecode: as the environment has it (PYTHONDONTWRITEBYTECODE={flag or 'unset'}; "
            f"ringqa/tg43 modules without bytecode: {missing}; --bytecode written measures "
            "a user's install)")  # fmt: skip


def run_timeline(root: Path, out: Path, trace: Path, free_core: bool) -> list[list]:
    """One ``TIMELINE_WORKER`` run under ``root``; its trace events (pid, kind, arg, wall s,
    process CPU s)."""
    env = environment(root)
    trace.unlink(missing_ok=True)
    p = subprocess.run(
        [sys.executable, "-c", TIMELINE_WORKER, EXAMPLE, str(out), str(trace),
         "free-core" if free_core else "load"],
        env=env, cwd=root, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if p.returncode != 0:
        raise SystemExit(f"bench_main_job --timeline failed under {root}:\n{p.stderr[-3000:]}")
    return [json.loads(line) for line in trace.read_text().splitlines()]


def processes(events: list[list]) -> dict[int, list[list]]:
    """The events of each process, in order (its own CPU time never decreases)."""
    out: dict[int, list[list]] = {}
    for e in events:
        out.setdefault(e[0], []).append(e)
    return out


def quiet_wall(events: list[list], cores: int, field: int = 4) -> float:
    """The wall time the traced run would take on an otherwise idle machine with ``cores``
    cores: each process needs the CPU its trace records between its events; a child becomes
    runnable at its fork, a parent waiting for a child's result (``wait`` .. ``waited``) is
    blocked until that child exits (or is stopped: ``kill``); the runnable processes share the
    cores equally (at most one core each). Interpreter start-up before the first event is in
    the first process's CPU (process time counts from the process's start).

    ``field`` 4: each process's CPU (all its threads); 5: its main thread's only (the thread
    that runs Python: a library's helper threads, such as OpenBLAS's, which spin while numpy is
    imported, then count as if they ran on a core nobody needs - true on an idle core during
    the start-up, not beside the engine runs; the truth lies between the two)."""
    procs = processes(events)
    root = events[0][0]
    # per process: a list of (cpu needed before it, action) with actions fork/wait/kill/exit
    plan: dict[int, list[tuple[float, str, int | None]]] = {}
    for pid, evs in procs.items():
        steps, last = [], 0.0
        for e in evs:
            kind, arg, cpu = e[1], e[2], e[field]
            if kind in ("fork", "wait", "kill", "exit"):
                steps.append((max(cpu - last, 0.0), kind, arg))
                last = cpu
        if not steps or steps[-1][1] != "exit":
            steps.append((max(evs[-1][field] - last, 0.0), "exit", None))
        plan[pid] = steps
    t = 0.0
    running = {root}  # runnable now
    blocked: dict[int, int] = {}  # pid -> the child it waits for
    done: set[int] = set()
    need = {root: plan[root][0][0]}
    pos = {root: 0}
    while root not in done:
        if not running:
            raise SystemExit("timeline: every process blocked (a wait for an unknown child)")
        rate = min(1.0, cores / len(running))
        pid = min(running, key=lambda p: need[p])
        dt = need[pid] / rate
        t += dt
        for p in running:
            need[p] -= dt * rate
        need[pid] = 0.0
        # the process reached its next action
        _cpu, kind, arg = plan[pid][pos[pid]]
        pos[pid] += 1
        if kind == "exit":
            running.discard(pid)
            done.add(pid)
            for waiter, child in list(blocked.items()):
                if child == pid:
                    del blocked[waiter]
                    running.add(waiter)
        elif kind == "fork" and arg in plan:
            running.add(arg)
            pos[arg] = 0
            need[arg] = plan[arg][0][0]
        elif kind == "wait" and arg in plan and arg not in done:
            running.discard(pid)
            blocked[pid] = arg
        elif kind == "kill" and arg in plan and arg not in done:
            running.discard(arg)
            done.add(arg)
            for waiter, child in list(blocked.items()):
                if child == arg:
                    del blocked[waiter]
                    running.add(waiter)
        if pid in running and pos[pid] < len(plan[pid]):
            need[pid] = plan[pid][pos[pid]][0]
    return t


def describe(events: list[list]) -> list[str]:
    """One line per process: its parent, when it started and ended (wall, from the first
    event), its CPU, and its phases with the CPU each took."""
    procs = processes(events)
    t0 = events[0][3]
    parent = {e[0]: e[2] for e in events if e[1] == "child"}
    lines = []
    for pid, evs in procs.items():
        cpu = evs[-1][4]
        name = "main" if pid not in parent else f"child of {parent[pid]}"
        lines.append(f"  {pid} ({name}): wall {evs[0][3] - t0:6.2f} .. {evs[-1][3] - t0:6.2f} s, "
                     f"CPU {cpu:.2f} s")  # fmt: skip
        open_: dict[str, list[float]] = {}
        for _pid, kind, arg, wall, c, *_ in evs:
            if kind == "begin":
                open_.setdefault(arg, []).append(c)
            elif kind == "end" and open_.get(arg):
                c0 = open_[arg].pop()
                if not open_[arg]:
                    lines.append(f"      {arg:16s} CPU {c - c0:5.2f} s  (at CPU {c0:5.2f} s)")
            elif kind in ("fork", "wait", "waited", "kill"):
                lines.append(f"      {kind:6s} {arg:<9}  at CPU {c:5.2f} s, "
                             f"wall {wall - t0:6.2f} s")  # fmt: skip
    return lines


def _phase_cpu(evs: list[list], name: str) -> float:
    """CPU seconds of phase ``name`` (begin .. end, outermost) in one process's events."""
    total, begun = 0.0, []
    for _pid, kind, arg, _wall, cpu, *_ in evs:
        if kind == "begin" and arg == name:
            begun.append(cpu)
        elif kind == "end" and arg == name and begun:
            c0 = begun.pop()
            total += 0.0 if begun else cpu - c0
    return total


def critical_path(events: list[list]) -> dict[str, float]:
    """The CPU seconds of the steps on the main job's critical path (each in the process that
    makes it; 0 where that process did not fork): the command's start-up before it forks the
    commissioning, reading the input (the commissioning child), the commissioning run (its
    first engine run), the whole channel's refined run (the child's longest forked engine run),
    the report after the result (this process: tables, report.html, the PDF's layout and its
    waits), the figures' children (the longest), and the command's CPU after the report."""
    procs = processes(events)
    root = events[0][0]
    parent = {e[0]: e[2] for e in events if e[1] == "child"}
    mine = procs[root]
    first_fork = next((e[4] for e in mine if e[1] == "fork"), 0.0)
    kids = [p for p, q in parent.items() if q == root]
    child = next((p for p in kids if _phase_cpu(procs[p], "input") > 0), None)
    out = {"start-up before the fork": first_fork}
    if child is not None:
        out["reading the input (child)"] = _phase_cpu(procs[child], "input")
        runs = [e for e in procs[child] if e[1] in ("begin", "end") and e[2] == "engine run"]
        out["commissioning run (child)"] = runs[1][4] - runs[0][4] if len(runs) >= 2 else 0.0
        grand = [p for p, q in parent.items() if q == child]
        out["longest forked engine run"] = max(
            (_phase_cpu(procs[p], "engine run") for p in grand), default=0.0
        )
    out["report (this process)"] = _phase_cpu(mine, "report")
    figures = [p for p in kids if p != child]
    out["longest figure child"] = max((procs[p][-1][4] for p in figures), default=0.0)
    return out


def timeline(trees: dict[str, Path], reps: int, free_core: bool) -> int:
    """``--timeline``: per checkout, ``reps`` traced runs (after one warm-up run); the median
    (and the least: the run other users disturbed least) predicted quiet wall on 2 cores (and 1
    and unlimited) and total CPU, and the last run's processes."""
    med = statistics.median
    with tempfile.TemporaryDirectory(prefix="bench_main_job_") as tmp:
        rows: dict[str, dict[str, list[float]]] = {}
        last: dict[str, list[list]] = {}
        for name, root in trees.items():
            run_timeline(root, Path(tmp) / f"warm-{name}", Path(tmp) / "trace", free_core)
        for i in range(reps):
            for name, root in trees.items():
                ev = run_timeline(root, Path(tmp) / f"{name}{i}", Path(tmp) / "trace", free_core)
                last[name] = ev
                total = sum(p[-1][4] for p in processes(ev).values())
                r = rows.setdefault(name, {})
                for key, value in (("quiet 2 cores (model)", quiet_wall(ev, 2)),
                                   ("quiet 2 cores (model, main threads)", quiet_wall(ev, 2, 5)),
                                   ("quiet 1 core (model)", quiet_wall(ev, 1)),
                                   ("unlimited cores (model)", quiet_wall(ev, 64)),
                                   ("CPU, all processes", total),
                                   ("wall measured", ev[-1][3] - ev[0][3])):  # fmt: skip
                    r.setdefault(key, []).append(value)
                for key, value in critical_path(ev).items():
                    r.setdefault(f"CPU: {key}", []).append(value)
                print(f"  {name} {i + 1}/{reps}: model 2 cores {r['quiet 2 cores (model)'][-1]:.2f}"
                      f" s, CPU {total:.2f} s", flush=True)  # fmt: skip
    load = os.getloadavg()[0]
    print(f"\nseconds, medians ({os.cpu_count()} cores, load {load:.1f}; the model: each "
          "process's CPU between its forks and waits, on an idle machine)")  # fmt: skip
    print(f"{'':40s}" + "".join(f"{k:>9s}" for k in rows) + "  (least of the runs)")
    for key in next(iter(rows.values())):
        print(f"{key:40s}" + "".join(f"{med(v.get(key, [0.0])):9.2f}" for v in rows.values())
              + "  (" + ", ".join(f"{min(v.get(key, [0.0])):.2f}" for v in rows.values())
              + ")")  # fmt: skip
    for name, ev in last.items():
        print(f"\n{name}: processes of the last run")
        print("\n".join(describe(ev)))
    return 0


def run(root: Path, out: Path, free_core: bool) -> dict:
    """One worker process under ``root``; its record."""
    env = environment(root)
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
    ap.add_argument("--timeline", action="store_true",
                    help="run the real command (as the ringqa script) with a trace of every "
                    "process (forks, waits, phases, CPU) and predict its wall time on an idle "
                    "2-core machine from the CPU each process needs between its forks and "
                    "waits (for a loaded machine, where wall times mislead)")  # fmt: skip
    ap.add_argument("--bytecode", choices=("as-is", "written"), default="as-is",
                    help="as-is (default): the measured processes find ringqa's bytecode as the "
                    "environment leaves it (under PYTHONDONTWRITEBYTECODE an editable install "
                    "compiles its modules from source on every run); written: every checkout's "
                    "bytecode is written once, into a temporary folder, as on a user's "
                    "machine")  # fmt: skip
    add_baseline_option(ap)
    args = ap.parse_args(argv)
    trees = baseline_trees(args.baseline)
    global BYTECODE_DIR
    with tempfile.TemporaryDirectory(prefix="bench_main_job_pyc_") as pyc:
        BYTECODE_DIR = Path(pyc) if args.bytecode == "written" else None
        print(bytecode_note(trees), flush=True)
        if args.timeline:
            return timeline(trees, args.reps, args.free_core)
        return measure(trees, args)


def measure(trees: dict[str, Path], args: argparse.Namespace) -> int:
    """The in-process phases (without ``--timeline``): medians over ``args.reps`` runs."""
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
