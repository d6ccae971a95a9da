"""``ringqa import PLAN.dcm --out DIR``: an RT Plan's contents as CSV/JSON files to inspect.

Writes (other tools read these files; docs/importers.md):

- ``DIR/dwells.csv``: ``channel, dwell, relative_position_mm, x_mm, y_mm, z_mm, time_s`` (plus
  ``dir_x, dir_y, dir_z`` when the plan has orientations, and ``channel_name``);
- ``DIR/points.csv``: ``name, x_mm, y_mm, z_mm, tps_dose_gy`` (plus ``dose_tag``);
- ``DIR/centreline_ch<N>.csv`` and ``DIR/measured_path_ch<N>.csv`` (``x_mm, y_mm, z_mm``, patient
  coordinates; centreline proximal -> distal, path most distal first with
  ``relative_position_mm``) for each channel N the embedded applicator library describes;
- ``DIR/plan.json`` (source, channels, library summary, notices) and ``DIR/provenance.json``.

Exits with status 2 and a one-line reason when the plan cannot be read correctly.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ringqa.cli._options import plain_help
from ringqa.errors import split_warning
from ringqa.jsonio import write_json
from ringqa.outdir import staged_output
from ringqa.provenance import Provenance


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "import",
        help="read a brachytherapy RT Plan and write its dwells, points and applicator as CSV",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("plan", type=Path, help="DICOM RT Plan file (RP*.dcm)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.io.export import write_plan_files
    from ringqa.io.rtplan import read_rtplan

    plan = read_rtplan(args.plan)
    prov = Provenance.now(inputs=[args.plan], settings={"command": "import"})
    with staged_output(args.out) as stage:
        written = write_plan_files(plan, stage)
        write_json(stage / "provenance.json", prov.as_dict(), indent=2, end="\n")
    for w in plan.warnings:  # also in plan.json "warnings"
        name, message = split_warning(w, "")
        if name:
            print(f"ringqa import: warning: [{name}] {message}", file=sys.stderr)
        else:
            print(f"ringqa import: note: {w}", file=sys.stderr)
    dwells = ", ".join(
        f"ch{c.number} {c.name}: {c.n_dwells} dwells {c.times_s.sum():.2f} s" for c in plan.channels
    )
    print(
        f"ringqa import: {args.plan.name}: {dwells}; {len(plan.points)} dose points; "
        f"{len(written) + 1} files -> {args.out}"
    )
    return 0
