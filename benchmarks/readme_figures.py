"""Every time README.md quotes for its Quick start, measured on this machine, with the machine.

    python benchmarks/readme_figures.py                 # warm runs only (about 1 min)
    python benchmarks/readme_figures.py --cold          # + the first run on an empty numba cache
    python benchmarks/readme_figures.py --cold --suite  # + the test suite (3-10 min)
    python benchmarks/readme_figures.py --cold --write  # ... and put the table into README.md

What is measured (wall time of a fresh ``ringqa`` process, as a user starts it):

- the main job of README's Quick start (``ringqa commission <example plan> --register
  plane-height --out DIR --quiet``), warm numba cache: median (min-max) of ``--repeat`` runs, and
  where its time goes (medians): the start-up (interpreter, imports, the command line: from the
  process's launch to the log's first time-stamped line, each run has ``--log-file``), the
  commissioning (to the log's first audit line, which is written when the result is there: in
  it, results.json ``timings_s``: reading the input, simulation, doses), the report and files
  (to the log's exit-status line) and the exit;
- the same on an empty numba cache (``--cold``; ``NUMBA_CACHE_DIR`` set to an empty folder):
  the first run a newcomer waits for;
- ``ringqa commission --all-shipped`` warm (the six rings, two worker processes);
- ``python -m pytest -q`` (``--suite``).

The machine: CPU count, the 1-minute load average before and after, Python, the time. Numbers
from a loaded machine are printed but marked: README quotes a quiet machine (a 1-minute load
under 1 when the measurement starts; the load after includes this script's own runs).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "data" / "examples" / "oncentra_ring26x60" / "RP_ring26x60_oncentra43.dcm"
RINGQA = [sys.executable, "-m", "ringqa"]


def _run(args: list[str], env: dict | None = None) -> float:
    t0 = time.perf_counter()
    subprocess.run(args, check=True, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)  # fmt: skip
    return time.perf_counter() - t0


def _main_job(out: Path, log: Path | None = None) -> list[str]:
    logged = [] if log is None else ["--log-file", str(log)]
    return [*RINGQA, *logged, "commission", str(EXAMPLE), "--register", "plane-height", "--out",
            str(out), "--quiet"]  # fmt: skip


def _stamp(line: str) -> float | None:
    """The time (s since the epoch) of a ``--log-file`` line stamped to the millisecond
    (``2026-11-29 00:50:45,619 DEBUG ...``), else None."""
    m = re.match(r"(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d),(\d{3}) ", line)
    if m is None:
        return None
    return time.mktime(time.strptime(m.group(1), "%Y-%m-%d %H:%M:%S")) + int(m.group(2)) / 1e3


def _phases(log: Path, launched: float, ended: float) -> dict[str, float]:
    """Wall seconds of the main job's phases from its ``--log-file``: ``start-up`` (launch to
    the first stamped line: interpreter, imports, arguments, log set-up), ``commissioning`` (to
    the first audit line ``input: ``, logged when the result is there), ``report`` (to the
    ``exit status`` line: tables, report.html, report.pdf, the audit's hashes) and ``exit``."""
    first = result = done = None
    for line in log.read_text(encoding="utf-8").splitlines():
        t = _stamp(line)
        if t is None:
            continue
        first = t if first is None else first
        if result is None and "ringqa.cli.commission: input: " in line:
            result = t
        if "ringqa.cli.commission: exit status" in line:
            done = t
    if first is None or result is None or done is None:
        raise SystemExit(f"{log}: the main job's log lacks its time stamps")
    return {"start-up": first - launched, "commissioning": result - first,
            "report": done - result, "exit": ended - done}  # fmt: skip


def _run_logged(out: Path, log: Path) -> tuple[float, dict[str, float]]:
    """The main job with ``--log-file``: its wall time and :func:`_phases`."""
    log.unlink(missing_ok=True)
    launched = time.time()
    t = _run(_main_job(out, log))
    return t, _phases(log, launched, launched + t)


def _spread(times: list[float]) -> str:
    med, lo, hi = statistics.median(times), min(times), max(times)
    return f"{med:.1f} s ({lo:.1f}-{hi:.1f} s, {len(times)} runs)"


def measure(cold: bool, suite: bool, repeat: int) -> list[tuple[str, str]]:
    rows: list[tuple[str, str]] = []
    with tempfile.TemporaryDirectory(prefix="ringqa-readme-") as tmp:
        tmp = Path(tmp)
        if cold:
            env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp / "numba-cache"))
            t = _run(_main_job(tmp / "cold"), env)
            rows.append(("first run of the main job (empty numba cache)", f"{t:.1f} s"))
        _run(_main_job(tmp / "warmup"))  # the default cache filled, files in the page cache
        logged = [_run_logged(tmp / f"warm{k}", tmp / f"warm{k}.log") for k in range(repeat)]
        warm = [t for t, _ in logged]
        med = statistics.median
        phase = {k: med(p[k] for _, p in logged) for k in logged[0][1]}
        timings = [json.loads((tmp / f"warm{k}" / "results.json").read_text())["timings_s"]
                   for k in range(repeat)]  # fmt: skip
        inner = {k: med(t[k] for t in timings) for k in ("load_s", "simulation_s", "dose_s")}
        rows.append(("the main job again (warm cache)", _spread(warm)))
        rows.append((
            "... of which: start-up (interpreter, imports, command line); the commissioning "
            "(in it: reading the input, the simulation - the runs of the numerical check, its "
            "whole-channel stem check and the flexible cross-check, partly on the second core - "
            "and the doses); the report and files (tables, report.html, report.pdf); the exit "
            "(medians)",
            f"{phase['start-up']:.2f} s; {phase['commissioning']:.2f} s (input "
            f"{inner['load_s']:.2f} s, simulation {inner['simulation_s']:.2f} s, doses "
            f"{inner['dose_s']:.2f} s); {phase['report']:.2f} s; {phase['exit']:.2f} s",
        ))  # fmt: skip
        shipped = [_run([*RINGQA, "commission", "--all-shipped", "--out", str(tmp / f"all{k}"),
                         "--quiet"]) for k in range(max(1, repeat // 2))]  # fmt: skip
        rows.append(("all six shipped rings (`--all-shipped`), warm", _spread(shipped)))
        if suite:
            t = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"])
            rows.append(("the test suite (`python -m pytest -q`)", f"{t / 60:.1f} min"))
    return rows


def machine(load_before: float) -> str:
    load_after = os.getloadavg()[0]
    return (
        f"{os.cpu_count()} cores, load {load_before:.2f} before / {load_after:.2f} after "
        f"(1-min average), Python {platform.python_version()}, "
        f"{time.strftime('%Y-%m-%d', time.gmtime())}"
    )


def table(rows, where: str) -> str:
    lines = ["| what | time |", "|---|---|"]
    lines += [f"| {what} | {t} |" for what, t in rows]
    lines.append(f"| machine | {where} |")
    lines.append("| command | `python benchmarks/readme_figures.py --cold --write` |")
    return "\n".join(lines)


def write_readme(text: str) -> None:
    path = ROOT / "README.md"
    readme = path.read_text(encoding="utf-8")
    block = re.compile(r"(<!-- readme-figures -->\n).*?(<!-- /readme-figures -->)", re.S)
    new, n = block.subn(lambda m: m.group(1) + text + "\n" + m.group(2), readme)
    if n != 1:
        raise SystemExit("README.md: no <!-- readme-figures --> block")
    path.write_text(new, encoding="utf-8")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cold", action="store_true", help="also the first run (empty numba cache)")
    p.add_argument("--suite", action="store_true", help="also the test suite")
    p.add_argument("--repeat", type=int, default=5, help="warm runs (default 5)")
    p.add_argument("--write", action="store_true", help="write the table into README.md")
    args = p.parse_args()
    if shutil.which("ringqa") is None and not (ROOT / "ringqa").is_dir():
        raise SystemExit("ringqa is not installed")
    load = os.getloadavg()[0]
    rows = measure(args.cold, args.suite, args.repeat)
    where = machine(load)
    # quiet = nothing else running when it started (the load before); the load after includes
    # this script's own runs (the main job forks a second process, the batch two workers)
    if load > 1.0:
        where += " - NOT QUIET: not for README"
    text = table(rows, where)
    print(text)
    if args.write:
        write_readme(text)


if __name__ == "__main__":
    main()
