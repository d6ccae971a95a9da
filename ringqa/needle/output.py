"""Write the needle study's files (through :func:`ringqa.outdir.staged_output`).

One channel (``ringqa needle``), in DIR:

- ``force_depth.csv``: ``depth_mm, force_n, force_raw_n`` (force_n filtered like the
  measurements, force_raw_n as simulated);
- ``force_depth.png``: the curve with the bends shaded and the landmarks (1)-(3);
- ``peaks.csv``: one row: ``radius_mm, torsion_rad, diameter_mm`` (NaN for a channel from a scene
  file), ``peak1_n, peak1_depth_mm, plateau_n, plateau_depth_mm, plateau_from_mm,
  plateau_to_mm, peak2_n, peak2_depth_mm, status, message``;
- ``run.json``: status, message, warnings, the channel, the depth mapping, the filter, the
  landmarks and their definitions, timings, the engine's settings, the whole engine scene in user
  units, software versions and provenance.

The sweep (``ringqa needle --sweep``), in DIR: ``peaks.csv`` (one row per study point,
:data:`ringqa.needle.sweep.PEAK_COLUMNS`), ``force_depth.csv`` (``family, radius_mm,
torsion_rad, diameter_mm, depth_mm, force_n, force_raw_n, nominal_diameter_mm``),
``figure8_force_depth.png`` (with the radius family), ``figure9_peaks.png`` and ``run.json``.
"""

from __future__ import annotations

import json
import math
import platform
from typing import Any

import numpy as np

from ringqa.needle import peaks as peak_defs
from ringqa.needle.figures import plot_figure8, plot_figure9, plot_force_depth
from ringqa.needle.run import NeedleRun
from ringqa.needle.scene import needle_scene
from ringqa.needle.sweep import SweepResult
from ringqa.outdir import staged_output
from ringqa.provenance import Provenance
from ringqa.simulation import Scene
from ringqa.simulation.scenefile import scene_to_dict

DEPTH_MAPPING = (
    "depth = insertion of the driven (clamped) end from its start position, mm = the engine's "
    "advance with motion.start_mm = 0 and no source offset: the catheter starts straight with "
    "its tip at s = 0 (the end of its straight guide, the start of the channel's entry straight)"
)
PEAK_DEFINITIONS = {
    "filter": (
        f"central moving average over {peak_defs.FILTER_WINDOW_MM:.3f} mm of depth (the paper's "
        f"{peak_defs.FILTER_SAMPLES} samples at {peak_defs.MEASUREMENT_RATE_HZ:g} Hz and "
        f"{peak_defs.MEASUREMENT_SPEED_MM_S:g} mm/s), applied before the landmarks are taken"
    ),
    "split": "midway between the end of bend 1 and the start of bend 2 (arc length = depth)",
    "peak1": "largest filtered force at depths below the split",
    "peak2": "largest filtered force at depths from the split on",
    "plateau": (
        "median filtered force over the depths between the two peaks where the force is within "
        f"{peak_defs.PLATEAU_BAND:g} x peak1 of its lowest value there; its depth is the middle "
        "of that region"
    ),
}


def versions() -> dict[str, str]:
    """Versions of the software that made a result."""
    import matplotlib
    import numba
    import pandas
    import scipy

    from ringqa import __version__

    return {
        "ringqa": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "pandas": pandas.__version__,
        "matplotlib": matplotlib.__version__,
    }


def worst_status(statuses) -> int:
    """-1 (a run failed) before 1 (a run jammed) before 0 (all succeeded)."""
    statuses = set(statuses)
    return -1 if -1 in statuses else (1 if 1 in statuses else 0)


def _clean(obj: Any):
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, np.bool_ | bool):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating | float):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, str | int) or obj is None:
        return obj
    return str(obj)


def peaks_row(run: NeedleRun, spec=None) -> dict[str, Any]:
    """The one-row peaks table of a single channel (``spec``: its ChannelSpec or None)."""
    geo = {
        "radius_mm": math.nan if spec is None else float(spec.radius_mm),
        "torsion_rad": math.nan if spec is None else float(spec.torsion_rad),
        "diameter_mm": math.nan if spec is None else float(spec.diameter_mm),
    }
    p = {k: v for k, v in run.peaks.as_dict().items() if k != "split_mm"}
    return {**geo, **p, "status": run.status, "message": run.message}


def _run_record(run: NeedleRun, scene: Scene, settings: Scene, channel: dict, inputs) -> dict:
    return _clean(
        {
            "status": run.status,
            "success": run.status == 0,
            "message": run.message,
            "warnings": list(run.warnings),
            "channel": channel,
            "bends_mm": [list(b) for b in run.bends_mm],
            "depth": {
                "mapping": DEPTH_MAPPING,
                "insertion_mm": float(run.depth_mm[-1]),
                "n_depths": int(run.depth_mm.size),
                "increment_mm": float(run.depth_mm[1] - run.depth_mm[0])
                if run.depth_mm.size > 1
                else None,
            },
            "filter_window_mm": run.filter_window_mm,
            "peaks": run.peaks.as_dict(),
            "definitions": PEAK_DEFINITIONS,
            "timings": {"solve_time_s": run.solve_time_s, "wall_time_s": run.wall_time_s},
            "n_elements": run.n_elements,
            "engine_settings": run.settings,
            "settings_scene": settings.name,
            "scene": scene_to_dict(scene),
            "versions": versions(),
            "provenance": Provenance.now(inputs=inputs, settings={"scene": scene.name}).as_dict(),
        }
    )


def write_channel_outputs(
    out_dir, run: NeedleRun, channel, settings: Scene, spec=None, inputs=(), depth_mm=None
) -> dict:
    """Write one channel's files (module docstring) into ``out_dir``; returns the run record.

    Parameters
    ----------
    out_dir : str or Path
    run : NeedleRun
    channel : ringqa.geometry.Channel
        The channel simulated (for the scene written into run.json).
    settings : Scene
        The settings scene.
    spec : ChannelSpec, optional
        The paper channel's parameters, or None for a channel from a scene file.
    inputs : iterable of paths
        Input files to checksum into the provenance.
    depth_mm : float, optional
        The insertion depth asked for.
    """
    import pandas as pd

    scene = needle_scene(channel, settings, depth_mm)
    chan = (
        {"source": "scene file", "name": channel.name}
        if spec is None
        else {
            "source": "ringqa.geometry.s_channel",
            "name": channel.name,
            "radius_mm": spec.radius_mm,
            "torsion_rad": spec.torsion_rad,
            "diameter_mm": spec.diameter_mm,
        }
    )
    record = _run_record(run, scene, settings, chan, inputs)
    table = pd.DataFrame(
        {"depth_mm": run.depth_mm, "force_n": run.force_n, "force_raw_n": run.force_raw_n}
    )
    with staged_output(out_dir) as stage:
        table.to_csv(stage / "force_depth.csv", index=False, float_format="%.6f")
        pd.DataFrame([peaks_row(run, spec)]).to_csv(
            stage / "peaks.csv", index=False, float_format="%.6f"
        )
        plot_force_depth(run, stage / "force_depth.png")
        (stage / "run.json").write_text(json.dumps(record, indent=2))
    return record


def write_sweep_outputs(out_dir, sweep: SweepResult, inputs=()) -> dict:
    """Write the sweep's files (module docstring) into ``out_dir``; returns the run record."""
    peaks = sweep.peaks_table()
    forces = sweep.force_table()
    runs = list(sweep.runs.values())
    record = _clean(
        {
            "status": worst_status(r.status for r in runs),
            "n_rows": len(sweep.points),
            "n_simulated": len(runs),
            "statuses": {str(s): int(sum(r.status == s for r in runs)) for s in (0, 1, -1)},
            "families": sorted({p.family for p in sweep.points}),
            "workers": sweep.workers,
            "timings": {
                "wall_time_s": sweep.wall_time_s,
                "sum_solve_time_s": float(sum(r.solve_time_s for r in runs)),
                "max_solve_time_s": float(max(r.solve_time_s for r in runs)),
            },
            "depth_mapping": DEPTH_MAPPING,
            "definitions": PEAK_DEFINITIONS,
            "warnings": sorted({w for r in runs for w in r.warnings}),
            "settings": {k: v for k, v in scene_to_dict(sweep.settings).items() if k != "channel"},
            "versions": versions(),
            "provenance": Provenance.now(
                inputs=inputs, settings={"scene": sweep.settings.name}
            ).as_dict(),
        }
    )
    with staged_output(out_dir) as stage:
        peaks.to_csv(stage / "peaks.csv", index=False, float_format="%.6f")
        forces.to_csv(stage / "force_depth.csv", index=False, float_format="%.6f")
        if (peaks["family"] == "radius").any():
            plot_figure8(sweep, stage / "figure8_force_depth.png")
        plot_figure9(sweep, stage / "figure9_peaks.png")
        (stage / "run.json").write_text(json.dumps(record, indent=2))
    return record
