"""Regenerate the shipped parametric ring applicators in data/applicators/.

Usage (from the repository root)::

    python tools/make_applicators.py          # writes data/applicators/ring{26,30,34}x{45,60}.json
    python tools/make_applicators.py --check  # exits 1 if a shipped file differs from a rebuild

Each file holds the ring channel and the tandem of :func:`ringqa.geometry.ring_applicator`
(coordinates rounded to 1e-6 mm). See data/applicators/README.md for the format and assumptions.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ringqa.geometry import ring_applicator
from ringqa.io.applicator_file import applicator_to_dict, save_applicator

SIZES = ((26, 45), (26, 60), (30, 45), (30, 60), (34, 45), (34, 60))
DECIMALS = 6
#: A rebuild may differ from the shipped file by one rounding unit where a coordinate sits on a
#: rounding boundary (numpy/scipy builds differ in the last bits); anything larger is a change.
CHECK_TOL = 2.0 * 10.0**-DECIMALS


def same(fresh, shipped, tol: float = CHECK_TOL) -> bool:
    """True when two JSON trees are equal, numbers within ``tol`` (mm)."""
    if isinstance(fresh, dict):
        return (
            isinstance(shipped, dict)
            and fresh.keys() == shipped.keys()
            and all(same(fresh[k], shipped[k], tol) for k in fresh)
        )
    if isinstance(fresh, list):
        return (
            isinstance(shipped, list)
            and len(fresh) == len(shipped)
            and all(same(a, b, tol) for a, b in zip(fresh, shipped, strict=True))
        )
    if isinstance(fresh, bool) or not isinstance(fresh, int | float):
        return fresh == shipped
    return isinstance(shipped, int | float) and abs(fresh - shipped) <= tol


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--out", default=str(Path(__file__).resolve().parents[1] / "data" / "applicators")
    )
    ap.add_argument("--check", action="store_true", help="compare instead of writing")
    args = ap.parse_args(argv)
    out = Path(args.out)
    bad = 0
    for d, a in SIZES:
        app = ring_applicator(d, a)
        target = out / f"{app.name}.json"
        if args.check:
            fresh = json.loads(json.dumps(applicator_to_dict(app, DECIMALS)))
            shipped = json.loads(target.read_text()) if target.is_file() else None
            if shipped is None or not same(fresh, shipped):
                print(f"{target}: differs from a rebuild")
                bad += 1
        else:
            save_applicator(app, target, decimals=DECIMALS)
            print(f"wrote {target}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
