"""CPU time of the PDF reports, before vs after (issue 16: the report speed).

    .venv/bin/python benchmarks/bench_report.py                     # 3 reps, this checkout
    .venv/bin/python benchmarks/bench_report.py --baseline /path/to/old/checkout

For each checkout (this one and ``--baseline``, through ``PYTHONPATH``, interleaved) a fresh
process commissions the Oncentra example (``--register plane-height``) and the six shipped
rings once, then writes their PDFs (``write_pdf`` of each result and the six rings' summary PDF)
``--passes`` times. Printed, as medians over ``--reps`` processes: the CPU seconds
(``time.process_time``, less sensitive to other users of the machine than wall times) of the
first pass (it pays matplotlib's import and first-draw set-up, as a ``ringqa commission`` does)
and of a later pass, the example's PDF alone (first, as in the warm example run), and the PDFs'
total size; with the ratio after/before.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

from _baseline import add_baseline_option
from _baseline import trees as baseline_trees

ROOT = Path(__file__).resolve().parents[1]

WORKER = r"""
import json, sys, time, tempfile
from pathlib import Path
from ringqa.io.applicator_file import shipped_applicators
from ringqa.pipeline import CommissionSettings, commission, commission_batch
from ringqa.report import write_batch_pdf, write_pdf

root = Path(sys.argv[1]); passes = int(sys.argv[2])
example = root / "data/examples/oncentra_ring26x60/RP_ring26x60_oncentra43.dcm"
ex = commission(str(example), CommissionSettings(register="plane-height"), progress=False)
batch = commission_batch(shipped_applicators(), progress=False)
out = Path(tempfile.mkdtemp(prefix="bench_report_"))
rec = {"example_s": None, "passes_s": [], "bytes": 0}
for k in range(passes):
    t0 = time.process_time()
    write_pdf(ex, out / "example.pdf")
    if k == 0:
        rec["example_s"] = time.process_time() - t0
    for r in batch.results:
        write_pdf(r, out / f"{r.applicator}.pdf")
    write_batch_pdf(batch, out / "summary.pdf")
    rec["passes_s"].append(time.process_time() - t0)
rec["bytes"] = sum(p.stat().st_size for p in out.glob("*.pdf"))
rec["n_pdfs"] = len(list(out.glob("*.pdf")))
print("BENCH" + json.dumps(rec))
"""


def run(root: Path, passes: int) -> dict:
    """One worker process under ``root``; its record."""
    env = dict(os.environ, PYTHONPATH=str(root))
    p = subprocess.run(
        [sys.executable, "-c", WORKER, str(root), str(passes)],
        env=env, cwd=root, capture_output=True, text=True, check=False,
    )  # fmt: skip
    line = next((x for x in p.stdout.splitlines() if x.startswith("BENCH")), None)
    if line is None:
        raise SystemExit(f"bench_report failed under {root}:\n{p.stderr[-2000:]}")
    return json.loads(line[5:])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--passes", type=int, default=3)
    add_baseline_option(ap)
    args = ap.parse_args(argv)
    trees = baseline_trees(args.baseline)
    recs: dict[str, list[dict]] = {k: [] for k in trees}
    for i in range(args.reps):
        for name, root in trees.items():
            rec = run(root, args.passes)
            recs[name].append(rec)
            print(f"  {name} {i + 1}/{args.reps}: passes {[round(x, 2) for x in rec['passes_s']]}"
                  f" CPU s", flush=True)  # fmt: skip

    def figs(rs):
        med = statistics.median
        return {
            "first pass: example + six rings + summary (CPU s)": med(r["passes_s"][0] for r in rs),
            "later pass (CPU s)": med(med(r["passes_s"][1:] or r["passes_s"]) for r in rs),
            "the example's PDF, first in the process (CPU s)": med(r["example_s"] for r in rs),
            "PDFs' total size (MB)": med(r["bytes"] for r in rs) / 1e6,
            "PDFs written per pass": med(r["n_pdfs"] for r in rs),
        }

    table = {k: figs(v) for k, v in recs.items()}
    head = f"figure (medians, {os.cpu_count()} cores)"
    ratio_head = "    ratio" if len(table) == 2 else ""
    print(f"\n{head:52s} " + "".join(f"{k:>9s}" for k in table) + ratio_head)
    for key in table["after"]:
        vals = [table[k][key] for k in table]
        ratio = f"{vals[1] / vals[0]:9.2f}" if len(vals) == 2 and vals[0] else ""
        print(f"{key:52s} " + "".join(f"{v:9.2f}" for v in vals) + ratio)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
