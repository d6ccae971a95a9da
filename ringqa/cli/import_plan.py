"""``ringqa import PLAN.dcm --out DIR``: an RT Plan's contents as CSV/JSON files to inspect.

Writes (other tools read these files; docs/importers.md):

- ``DIR/dwells.csv``: ``channel, dwell, relative_position_mm, x_mm, y_mm, z_mm, time_s`` (plus
  ``dir_x, dir_y, dir_z`` when the plan has orientations, and ``channel_name``);
- ``DIR/points.csv``: ``name, x_mm, y_mm, z_mm, tps_dose_gy`` (plus ``dose_tag``);
- ``DIR/centreline_ch<N>.csv`` and ``DIR/measured_path_ch<N>.csv`` (``x_mm, y_mm, z_mm``, patient
  coordinates; centreline proximal -> distal, path most distal first with
  ``relative_position_mm``) for each channel N the embedded applicator library describes;
- ``DIR/plan.json`` (source, channels, library summary, notices) and ``DIR/provenance.json``;
- with ``--structures RS.dcm`` (an RT Structure Set, :mod:`ringqa.io.rtstruct`): also
  ``DIR/centreline_ch<N>.csv`` of each channel's matched open contour (proximal -> distal) and
  ``DIR/structures.json`` (each channel's ROI and largest dwell-to-contour distance, the
  structure set's UID and notes); a structure set the plan does not reference, or a missing or
  ambiguous match, is refused.

Exits with status 2 and a one-line reason when the plan cannot be read correctly.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ringqa.cli._options import plain_help
from ringqa.errors import split_warning

# numpy (through ringqa.jsonio) and the output helpers are imported where they are used, so
# that building the command line (``ringqa --help``) does not import them


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "import",
        help="read a brachytherapy RT Plan and write its dwells, points and applicator as CSV",
        description=plain_help(__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("plan", type=Path, help="DICOM RT Plan file (RP*.dcm)")
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--structures",
        type=Path,
        default=None,
        metavar="RS.dcm",
        help="an RT Structure Set whose open contours are the plan's channels",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ringqa.io.export import write_plan_files
    from ringqa.io.rtplan import read_rtplan
    from ringqa.jsonio import write_json
    from ringqa.outdir import staged_output
    from ringqa.provenance import Provenance

    plan = read_rtplan(args.plan)
    structures = getattr(args, "structures", None)
    channels = None
    if structures is not None:
        channels = structure_centrelines(plan, structures)
    inputs = [args.plan] if structures is None else [args.plan, structures]
    prov = Provenance.now(inputs=inputs, settings={"command": "import"})
    with staged_output(args.out) as stage:
        written = write_plan_files(plan, stage)
        if channels is not None:
            written += write_structure_files(channels, stage)
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


def structure_centrelines(plan, structures_path):
    """``(record, {channel number: (n, 3) points mm, proximal -> distal})`` of the plan's
    channels matched in the structure set (:mod:`ringqa.io.rtstruct`; refusals raise)."""
    import numpy as np

    from ringqa.io.rtstruct import (
        check_referenced,
        match_channels,
        oriented_points_mm,
        read_rtstruct,
    )

    ss = read_rtstruct(structures_path)
    note = check_referenced(plan, ss)
    matches = match_channels(plan, ss)
    by_name = {c.roi_name: c.points_mm for c in ss.contours}
    points = {
        m.channel: oriented_points_mm(
            by_name[m.roi_name], np.asarray(plan.channel(m.channel).positions_mm, float)
        )
        for m in matches
    }
    record = {
        "structure_set": str(structures_path),
        "sop_instance_uid": ss.sop_instance_uid,
        "matches": [
            {"channel": m.channel, "roi": m.roi_name, "n_dwells": m.n_dwells,
             "max_dwell_distance_mm": m.max_distance_mm}
            for m in matches
        ],
        "notes": [note, *ss.notes],
    }  # fmt: skip
    return record, points


def write_structure_files(channels, stage: Path) -> list[str]:
    """``centreline_ch<N>.csv`` per matched channel and ``structures.json``; the names written."""
    from ringqa.jsonio import write_json

    record, points = channels
    names = []
    for number, pts in points.items():
        name = f"centreline_ch{number}.csv"
        rows = "\n".join(",".join(f"{v:.4f}" for v in p) for p in pts)
        (stage / name).write_text("x_mm,y_mm,z_mm\n" + rows + "\n", encoding="utf-8")
        names.append(name)
    write_json(stage / "structures.json", record, indent=2, end="\n")
    return [*names, "structures.json"]
