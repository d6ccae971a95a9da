"""Write what an RT Plan holds as ringqa's CSV/JSON files (the contract of issue 3).

``write_plan_files(plan, out_dir)`` writes ``dwells.csv``, ``points.csv``,
``centreline_ch<N>.csv`` / ``measured_path_ch<N>.csv`` (for channels the embedded applicator
library describes) and ``plan.json``; ``ringqa import`` calls it inside a staging folder. The
point files are in the format :func:`ringqa.io.points.read_points` reads.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ringqa.io.points import write_points
from ringqa.jsonio import csv_encoding, write_json
from ringqa.units import mm_to_m


def _fmt(v) -> str:
    return "" if v is None else f"{float(v):.6f}"


def _write_rows(path: Path, rows: list) -> None:
    """A CSV file (UTF-8 with a byte-order mark when a value is not ASCII: Excel)."""
    with open(path, "w", newline="", encoding=csv_encoding(rows)) as fh:
        csv.writer(fh).writerows(rows)


def write_plan_files(plan, out: Path) -> list[str]:
    """Write the contract files of ``plan`` (an :class:`~ringqa.io.rtplan.RTPlan`) into ``out``.

    Returns the file names written.
    """
    written = []
    has_dir = any(c.directions is not None for c in plan.channels)
    cols = ["channel", "dwell", "relative_position_mm", "x_mm", "y_mm", "z_mm", "time_s"]
    cols += ["dir_x", "dir_y", "dir_z"] if has_dir else []
    cols += ["channel_name"]
    rows = [cols]
    for ch in plan.channels:
        for k in range(ch.n_dwells):
            row = [ch.number, k, _fmt(ch.relative_position_mm[k])]
            row += [_fmt(v) for v in ch.positions_mm[k]] + [_fmt(ch.times_s[k])]
            if has_dir:
                d = ch.directions[k] if ch.directions is not None else (None,) * 3
                row += [_fmt(v) for v in d]
            rows.append([*row, ch.name])
    _write_rows(out / "dwells.csv", rows)
    written.append("dwells.csv")
    rows = [["name", "x_mm", "y_mm", "z_mm", "tps_dose_gy", "dose_tag"]]
    for pt in plan.points:
        xyz = [_fmt(v) for v in pt.position_mm]
        rows.append([pt.name, *xyz, _fmt(pt.tps_dose_gy), pt.dose_tag or ""])
    _write_rows(out / "points.csv", rows)
    written.append("points.csv")
    library_summary = {}
    for number, lc in sorted((plan.library or {}).items()):
        name = f"centreline_ch{number}.csv"
        write_points(out / name, mm_to_m(lc.centreline_mm))
        written.append(name)
        entry = {
            "name": lc.name,
            "role": lc.role,
            "description": lc.description,
            "part_id": lc.part_id,
            "lumen_diameter_mm": lc.lumen_diameter_mm,
            "centreline_points": len(lc.centreline_mm),
            "marker_mm": None
            if lc.marker_mm is None
            else [round(float(v), 6) for v in lc.marker_mm],
            "measured_path": lc.measured_path_name,
        }
        if lc.measured_path_mm is not None:
            name = f"measured_path_ch{number}.csv"
            step = lc.measured_step_mm
            rel = None if step is None else np.arange(len(lc.measured_path_mm)) * step
            write_points(out / name, mm_to_m(lc.measured_path_mm), rel)
            written.append(name)
            entry["measured_step_mm"] = step
        library_summary[str(number)] = entry
    src = plan.source
    summary = {
        "plan": plan.path,
        "plan_label": plan.plan_label,
        "treatment_type": plan.treatment_type,
        "prescription_gy": plan.prescription_gy,
        "applicator_name": plan.applicator_name,
        "source": {
            "isotope": src.isotope,
            "model": src.model,
            "tg43_name": src.tg43_name,
            "sk_U": src.sk_U,
            "reference_date": None if src.reference_date is None else str(src.reference_date),
            "half_life_days": src.half_life_days,
        },
        "channels": [
            {
                "number": c.number,
                "name": c.name,
                "n_dwells": c.n_dwells,
                "total_time_s": c.total_time_s,
                "length_mm": c.length_mm,
                "step_mm": c.step_mm,
                "applicator_length_mm": c.applicator_length_mm,
                "has_orientations": c.directions is not None,
                "number_of_pulses": c.number_of_pulses,
            }
            for c in plan.channels
        ],
        "library": library_summary or None,
        "warnings": list(plan.warnings),
    }
    write_json(out / "plan.json", summary, indent=2, end="\n")
    written.append("plan.json")
    return written
