"""Memory and time on dense inputs (issue 25): centrelines and measured paths with many points.

Run: .venv/bin/python benchmarks/bench_memory.py [--keep DIR]

Writes the inputs (the ring26x60 ring's centreline sampled with n points, as an applicator file
with a ``centreline_file``; a measured path of n positions) into a temporary folder, then runs
each case in a fresh Python process (so the peak resident set belongs to that case alone) twice:
once for the wall time and the peak RSS (``resource.getrusage(...).ru_maxrss``, the whole
process, imports included), once under ``tracemalloc`` for the peak of Python's and numpy's own
allocations during the case. Prints one line per case and the issue's targets:

- a 10^6-point centreline is refused (or resampled) in < 5 s and < 500 MB;
- a 40 000-point centreline is accepted in < 500 MB.

Before issue 25 the spline allocated a dense n x n matrix (40 000 points: 11.9 GiB) and the
reference-path check all pairwise differences (20 000 positions: 21.6 GB).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: (case, points, expected outcome)
CASES = (
    ("applicator_centreline", 1_000_000, "refused"),
    ("centreline_points", 1_000_000, "refused"),
    ("applicator_centreline", 40_000, "accepted"),
    ("applicator_centreline", 100_000, "accepted"),
    ("measured_path", 20_000, "accepted"),
)
TIME_LIMIT_S = 5.0
RSS_LIMIT_MB = 500.0


def _ring():
    from ringqa.geometry import ring_applicator

    return ring_applicator(26, 60).channel("ring")


def write_inputs(folder: Path) -> None:
    """The inputs of every case (mm): an applicator file per centreline size, a path CSV."""
    import numpy as np

    from ringqa.io.applicator_file import applicator_to_dict, load_applicator

    ch = _ring()
    base = applicator_to_dict(load_applicator("ring26x60"))
    for n in sorted({n for c, n, _ in CASES if c == "applicator_centreline"}):
        s = np.linspace(0.0, ch.centreline.length_m, n)
        pts_mm = 1e3 * ch.centreline.position(s)
        np.savetxt(folder / f"centreline_{n}.csv", pts_mm, delimiter=",", fmt="%.9f",
                   header="x_mm,y_mm,z_mm", comments="")  # fmt: skip
        doc = json.loads(json.dumps(base))
        ring = next(c for c in doc["channels"] if c["name"] == "ring")
        ring.pop("centreline_mm")
        ring["centreline_file"] = f"centreline_{n}.csv"
        for key in [k for k in ring if k.startswith("measured")]:
            ring.pop(key)
        (folder / f"ring_{n}.json").write_text(json.dumps(doc))
    n = next(n for c, n, _ in CASES if c == "measured_path")
    s = np.linspace(ch.s_ref_m, ch.s_ref_m - 0.1, n)
    np.save(folder / f"path_{n}.npy", ch.centreline.position(s))


def run_case(case: str, n: int, folder: Path) -> str:
    """One case in this process; returns "accepted" or the refusal's first 100 characters."""
    import numpy as np

    from ringqa.errors import RingQAError

    try:
        if case == "applicator_centreline":
            from ringqa.io.applicator_file import load_applicator

            app = load_applicator(folder / f"ring_{n}.json")
            assert app.channel("ring").centreline.length_m > 0.1
        elif case == "centreline_points":
            from ringqa.geometry import Centreline

            x = np.linspace(0.0, 0.15, n)
            Centreline.from_points(np.c_[x, 0.01 * np.sin(50 * x), np.zeros(n)])
        elif case == "measured_path":
            from ringqa.geometry.registration import check_reference_path, reference_positions

            pts = np.load(folder / f"path_{n}.npy")
            ch = _ring()
            ref = reference_positions(pts, ch, step_m=0.1 / (n - 1))
            check_reference_path(pts, ch, 0.425e-3, relative_m=ref.relative_m)
        else:
            raise ValueError(case)
    except RingQAError as exc:
        return "refused: " + str(exc)[:100]
    return "accepted"


def child(case: str, n: int, folder: Path, trace: bool) -> None:
    """Run one case and print a JSON line (wall s, peak RSS MB, RSS after imports, traced MB)."""
    import resource
    import tracemalloc

    import numpy  # noqa: F401  (imports before the baseline)

    import ringqa.geometry
    import ringqa.geometry.registration
    import ringqa.io.applicator_file  # noqa: F401

    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if trace:
        tracemalloc.start()
    t0 = time.perf_counter()
    outcome = run_case(case, n, folder)
    wall = time.perf_counter() - t0
    traced = tracemalloc.get_traced_memory()[1] / 2**20 if trace else float("nan")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"wall_s": wall, "peak_rss_mb": peak, "import_rss_mb": base,
                      "traced_mb": traced, "outcome": outcome}))  # fmt: skip


def _spawn(case: str, n: int, folder: Path, trace: bool) -> dict:
    cmd = [sys.executable, __file__, "--child", case, str(n), str(folder)]
    out = subprocess.run(cmd + (["--trace"] if trace else []), capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"{case} {n}: {out.stderr[-2000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> int:
    if argv[:1] == ["--child"]:
        child(argv[1], int(argv[2]), Path(argv[3]), "--trace" in argv)
        return 0
    keep = Path(argv[argv.index("--keep") + 1]) if "--keep" in argv else None
    with tempfile.TemporaryDirectory() as tmp:
        folder = keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        write_inputs(folder)
        _spawn("centreline_points", 10, folder, False)  # numba's cache warm, outside the timings
        ok = True
        print(f"{'case':<24}{'points':>10}{'wall s':>9}{'peak RSS MB':>13}{'imports MB':>12}"
              f"{'traced MB':>11}  outcome")  # fmt: skip
        for case, n, want in CASES:
            r = _spawn(case, n, folder, False)
            t = _spawn(case, n, folder, True)
            got = "accepted" if r["outcome"] == "accepted" else "refused"
            met = got == want and r["peak_rss_mb"] < RSS_LIMIT_MB
            if n >= 1_000_000:
                met = met and r["wall_s"] < TIME_LIMIT_S
            ok &= met
            print(f"{case:<24}{n:>10,}{r['wall_s']:>9.2f}{r['peak_rss_mb']:>13.0f}"
                  f"{r['import_rss_mb']:>12.0f}{t['traced_mb']:>11.1f}  {r['outcome']}"
                  f"  [{'MET' if met else 'NOT MET'}: {want}]")  # fmt: skip
        verdict = "MET" if ok else "NOT MET"
        print(f"targets: 10^6 points refused in < {TIME_LIMIT_S:g} s and < {RSS_LIMIT_MB:g} MB; "
              f"40 000 accepted in < {RSS_LIMIT_MB:g} MB: {verdict}")  # fmt: skip
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
