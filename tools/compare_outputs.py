"""Did a refactoring change what ringqa writes? Run the yardstick jobs, then compare two runs.

    git worktree add /tmp/ringqa-old <old commit>         # or any checkout of the old code
    python tools/compare_outputs.py run --root /tmp/ringqa-old out/before
    python tools/compare_outputs.py run out/after         # this checkout
    python tools/compare_outputs.py compare out/before out/after

``run`` writes into DIR, running ``python -m ringqa`` in the checkout ROOT (default: this one;
``PYTHONPATH`` = ROOT, so ROOT's ringqa and data are used whatever is installed):

- ``oncentra/``: ``ringqa commission`` of the Oncentra 26/60 example RT Plan (the main job);
- ``ring26/``: ``ringqa commission ring26x60`` (a shipped applicator);
- ``acc13/``: ``ringqa accuracy ring13-push100`` on a small grid (factors 2, 1; two reference
  levels; one repeat): an analytic channel, so the dose points come from the fitted ring frame;
- ``acc26/``: ``ringqa accuracy ring26-flexitron`` (default factors, two levels, one repeat): the
  applicator's own dose points;
- ``sim/``, ``sim-jam/``: ``ringqa simulate ring26-flexitron`` (with ``trajectory.h5``), and the
  same jamming (``solver.jam_force_n = 0.05``);
- ``import/``: ``ringqa import`` of the example RT Plan.

``compare`` checks every file of BEFORE against AFTER and prints one line per file:

- CSV files byte for byte, except the columns that are timings (``solve_time_s`` in
  ``summary.csv``; ``time_s`` and ``pareto``, which follows from the times, in ``accuracy.csv``;
  ``time_s`` in ``reference.csv``): those are left out and every other cell compared as text;
- JSON files value for value (floats exactly), except the time stamp ``created_utc``, the timings
  (``timings_s``, ``solve_time_s``, ``wall_time_s``, ``time_s``, ``refined_solve_time_s``,
  ``total_solve_time_s``, ``added_wall_s``) and what follows from timings
  (``recommended``, ``recommendations``, ``recommended_overrides`` in ``study.json``: the
  cheapest run can change when times change), ``engine_fingerprint`` (a hash of the engine's
  source files) and, inside a sentence, the times it quotes (the cross-check's "(0.17 s; the
  command waited 0.01 s for it)"). A value that is NaN/inf (or the string ``"nan"``) on one
  side and ``null`` on the other is listed as a NaN SPELLING change, apart from real
  differences;
- ``runs.jsonl`` line by line (the runs in the order they ran) the same way, without ``key``
  (a hash that includes the engine's source files) and ``times_s``;
- ``provenance.inputs`` by file name and SHA-256 (the paths are absolute, so they name the
  checkout);
- ``recommended.toml`` line by line without its ``# claimed`` line (it holds the time);
- PDF files content stream by content stream (decompressed): the title page (date) and the
  settings page (solve time) are expected to differ, so the indices of differing streams are
  printed for a reader to judge;
- HDF5 files attribute by attribute and dataset by dataset (NaN equals NaN);
- the folder's ``.ringqa-output.json`` (what ringqa wrote there) by command and the files it
  lists (its pid, times, sizes and hashes follow from the run and the files compared above);
- other binary files (PNG) by size only.

Exit status: 0 when nothing but the listed volatile fields differs, 1 otherwise.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import os
import re
import subprocess
import sys
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLAN = "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"

JOBS = {
    "oncentra": ["commission", PLAN, "--quiet"],
    "ring26": ["commission", "ring26x60", "--quiet"],
    "acc13": ["accuracy", "ring13-push100", "--factors", "2,1", "--max-levels", "2",
              "--repeats", "1", "--fresh", "--quiet"],
    "acc26": ["accuracy", "ring26-flexitron", "--max-levels", "2", "--repeats", "1", "--fresh",
              "--quiet"],
    "sim": ["simulate", "ring26-flexitron", "--trajectory", "--quiet"],
    "sim-jam": ["simulate", "ring26-flexitron", "--set", "solver.jam_force_n=0.05", "--quiet"],
    "import": ["import", PLAN],
}  # fmt: skip

CSV_VOLATILE = {
    "summary.csv": {"solve_time_s"},
    "accuracy.csv": {"time_s", "pareto"},
    "reference.csv": {"time_s"},
}
JSON_VOLATILE = {"created_utc", "timings_s", "solve_time_s", "wall_time_s", "time_s",
                 "refined_solve_time_s", "total_solve_time_s", "added_wall_s",
                 "engine_fingerprint"}  # fmt: skip
#: the output folder's record of what ringqa wrote there (ringqa.outdir): its pid, times and the
#: files' sizes and hashes differ run to run (the files themselves are compared one by one)
MANIFEST = ".ringqa-output.json"
JSON_TIMING_DEPENDENT = {"recommended", "recommendations", "recommended_overrides"}


def run(out: Path, root: Path = ROOT) -> int:
    """Run every job of :data:`JOBS` with the ringqa of checkout ``root`` into ``out/<job>``."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    worst = 0
    for name, args in JOBS.items():
        cmd = [sys.executable, "-m", "ringqa", *args[:2], "--out", str(out / name), *args[2:]]
        proc = subprocess.run(cmd, cwd=root, env=env, capture_output=True, text=True)
        print(f"{name}: exit {proc.returncode}: {proc.stdout.strip().splitlines()[-1:]}")
        worst = max(worst, proc.returncode if name != "sim-jam" else 0)
    return worst


#: the times a sentence quotes: the cross-check's "it ran beside the rigid runs on the second core
#: (0.17 s; the command waited 0.01 s for it)" when forked, "it took 0.16 s" when it ran in the
#: command's own process (which of the two depends on the machine's load, not on the result)
TIMES_IN_TEXT = re.compile(
    r"it ran beside the rigid runs on the second core \(\d+(?:\.\d+)? s; the command waited "
    r"\d+(?:\.\d+)? s for it\)|it took \d+(?:\.\d+)? s"
)


def _timeless(text: str) -> str:
    return TIMES_IN_TEXT.sub("(<times>)", text)


def _is_nonfinite(v) -> bool:
    return (isinstance(v, float) and not math.isfinite(v)) or v in ("nan", "inf", "-inf")


def _json_diff(a, b, where: str, out: list[tuple[str, str]]) -> None:
    """Append (kind, path) for every difference; kind 'nan' for a NaN spelling change."""
    if isinstance(a, dict) and isinstance(b, dict):
        if where.endswith("provenance.inputs"):  # absolute paths: compare file names and digests
            a, b = _by_name(a), _by_name(b)
        if list(a) != list(b):
            out.append(("diff", f"{where}: keys {list(a)} != {list(b)}"))
        for k in a:
            if k in b and k not in JSON_VOLATILE:
                kind = "timing" if k in JSON_TIMING_DEPENDENT else None
                sub: list[tuple[str, str]] = []
                _json_diff(a[k], b[k], f"{where}.{k}", sub)
                out += [(kind or k2, p) for k2, p in sub]
        return
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(("diff", f"{where}: length {len(a)} != {len(b)}"))
            return
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _json_diff(x, y, f"{where}[{i}]", out)
        return
    if a == b and type(a) is type(b):
        return
    if isinstance(a, str) and isinstance(b, str) and _timeless(a) == _timeless(b):
        return  # the same sentence but for the times it quotes (the cross-check's)
    if (_is_nonfinite(a) and b is None) or (a is None and _is_nonfinite(b)):
        out.append(("nan", f"{where}: {a!r} -> {b!r}"))
    elif _is_nonfinite(a) and _is_nonfinite(b) and str(a) == str(b):
        return
    else:
        out.append(("diff", f"{where}: {a!r} != {b!r}"))


def _by_name(inputs: dict) -> dict:
    return {Path(k).name: v for k, v in inputs.items()}


def _load_json(path: Path):
    return json.loads(path.read_text(), parse_constant=float)


def _csv_rows(path: Path, drop: set[str]) -> list[list[str]]:
    rows = list(csv.reader(io.StringIO(path.read_text())))
    keep = [i for i, h in enumerate(rows[0]) if h not in drop] if rows else []
    return [[r[i] for i in keep] for r in rows]


def _pdf_streams(path: Path) -> list[bytes]:
    out = []
    # reportlab ends a binary stream with ``endstream`` right after its last byte (no end-of-line
    # before it), so the line break there is optional; the shortest match is the content
    for m in re.finditer(rb"stream\r?\n(.*?)(?:\r?\n)?endstream", path.read_bytes(), re.S):
        try:
            out.append(zlib.decompress(m.group(1)))
        except zlib.error:
            out.append(m.group(1))
    return out


def compare_file(a: Path, b: Path) -> tuple[str, list[str]]:
    """('same' | 'volatile-only' | 'nan-spelling' | 'DIFFERENT' | 'info', details) for a pair."""
    name = a.name
    if name == MANIFEST:
        ma, mb = (json.loads(x.read_text()) for x in (a, b))
        keys = ("software", "version", "command")
        pa, pb = ([f["path"] for f in m.get("files", [])] for m in (ma, mb))
        if [ma.get(k) for k in keys] == [mb.get(k) for k in keys] and pa == pb:
            return "volatile-only", [f"the same {len(pa)} files listed (pid, times, hashes differ)"]
        return "DIFFERENT", [f"command or files listed differ: {pa} vs {pb}"]
    if a.suffix == ".csv":
        if a.read_bytes() == b.read_bytes():
            return "same", []
        drop = CSV_VOLATILE.get(name)
        if drop and _csv_rows(a, drop) == _csv_rows(b, drop):
            return "volatile-only", [f"only {', '.join(sorted(drop))} differ"]
        ra, rb = _csv_rows(a, drop or set()), _csv_rows(b, drop or set())
        bad = [i for i, (x, y) in enumerate(zip(ra, rb, strict=False)) if x != y]
        return "DIFFERENT", [f"{len(ra)} vs {len(rb)} rows; first differing rows {bad[:5]}"]
    if a.suffix == ".json":
        if a.read_bytes() == b.read_bytes():
            return "same", []
        diffs: list[tuple[str, str]] = []
        _json_diff(_load_json(a), _load_json(b), name, diffs)
        real = [p for k, p in diffs if k == "diff"]
        nans = [p for k, p in diffs if k == "nan"]
        timing = [p for k, p in diffs if k == "timing"]
        if real:
            return "DIFFERENT", real[:10]
        details = [f"NaN spelling: {p}" for p in nans[:10]]
        details += [f"timing-dependent: {p}" for p in timing[:5]]
        return ("nan-spelling" if nans else "volatile-only"), details
    if a.suffix == ".jsonl":
        la, lb = a.read_text().splitlines(), b.read_text().splitlines()
        if la == lb:
            return "same", []
        if len(la) != len(lb):
            return "DIFFERENT", [f"{len(la)} vs {len(lb)} runs"]
        diffs: list[tuple[str, str]] = []
        for i, (x, y) in enumerate(zip(la, lb, strict=True)):  # runs in the order they ran
            ra, rb = _load_json_line(x), _load_json_line(y)
            for rec in (ra, rb):  # the key hashes the engine's source; times vary
                rec.pop("key"), rec.pop("times_s")
            _json_diff(ra, rb, f"{name}[{i}]", diffs)
        real = [p for kind, p in diffs if kind == "diff"]
        nans = [f"NaN spelling: {p}" for kind, p in diffs if kind == "nan"]
        if real:
            return "DIFFERENT", real[:10]
        return ("nan-spelling", nans[:10]) if nans else ("volatile-only", ["keys and times"])
    if a.suffix == ".toml":
        keep = [x for x in a.read_text().splitlines() if not x.startswith("# claimed")]
        keep_b = [x for x in b.read_text().splitlines() if not x.startswith("# claimed")]
        return ("same", []) if keep == keep_b else ("DIFFERENT", ["recommended.toml differs"])
    if a.suffix == ".pdf":
        sa, sb = _pdf_streams(a), _pdf_streams(b)
        bad = [i for i, (x, y) in enumerate(zip(sa, sb, strict=False)) if x != y]
        return "info", [f"{len(sa)} vs {len(sb)} streams; differing streams {bad}"]
    if a.suffix == ".h5":
        bad = _h5_diff(a, b)
        return ("DIFFERENT", bad[:10]) if bad else ("same", ["every attribute and dataset"])
    return "info", [f"size {a.stat().st_size} vs {b.stat().st_size} bytes"]


def _h5_diff(a: Path, b: Path) -> list[str]:
    """Attributes and datasets of two HDF5 files that differ (NaN equals NaN)."""
    import h5py
    import numpy as np

    bad: list[str] = []

    def walk(ga, gb, where: str) -> None:
        for k in set(ga.attrs) | set(gb.attrs):
            if k not in ga.attrs or k not in gb.attrs or ga.attrs[k] != gb.attrs[k]:
                bad.append(f"{where}@{k}")
        for k in sorted(set(ga) | set(gb)):
            if k not in ga or k not in gb:
                bad.append(f"{where}/{k} missing")
            elif isinstance(ga[k], h5py.Group):
                walk(ga[k], gb[k], f"{where}/{k}")
            elif not np.array_equal(ga[k][()], gb[k][()], equal_nan=True):
                bad.append(f"{where}/{k}")
            else:
                changed = [x for x in ga[k].attrs if ga[k].attrs[x] != gb[k].attrs.get(x)]
                bad.extend(f"{where}/{k}@{x}" for x in changed)

    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        walk(fa, fb, "")
    return bad


def _load_json_line(line: str):
    return json.loads(line, parse_constant=float)


def compare(before: Path, after: Path) -> int:
    """Compare every file below ``before`` with its twin below ``after``; 1 if any differs."""
    status = 0
    files_a = sorted(p.relative_to(before) for p in before.rglob("*") if p.is_file())
    files_b = {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    for rel in files_a:
        if rel not in files_b:
            print(f"MISSING  {rel}")
            status = 1
            continue
        verdict, details = compare_file(before / rel, after / rel)
        print(f"{verdict:13s} {rel}" + "".join(f"\n    {d}" for d in details))
        status = max(status, int(verdict in ("DIFFERENT",)))
    for rel in sorted(files_b - set(files_a)):
        print(f"NEW      {rel}")
    return status


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run", help="run the yardstick jobs into DIR")
    r.add_argument("dir", type=Path)
    r.add_argument("--root", type=Path, default=ROOT, help="checkout to run (default: this one)")
    c = sub.add_parser("compare", help="compare two run folders")
    c.add_argument("before", type=Path)
    c.add_argument("after", type=Path)
    args = p.parse_args(argv)
    if args.cmd == "run":
        return run(args.dir.resolve(), args.root.resolve())
    return compare(args.before, args.after)


if __name__ == "__main__":
    sys.exit(main())
