"""Write a simulation's results: ``dwells.csv``, ``run.json`` and the HDF5 trajectory.

File contract (issue 4; other tools read these):

- ``dwells.csv``: one row per requested cable advance with at least ``advance_mm, x_mm, y_mm,
  z_mm, dir_x, dir_y, dir_z, push_force_n, s_mm, offset_mm`` (source centre of activity in mm,
  unit source direction, push force in N, arc length of the closest centreline point and the
  distance of the source centre from the centreline in mm).
- ``run.json``: ``status`` (0 success, 1 jammed, -1 failed), ``message``, ``success``,
  ``solve_time_s`` (JIT excluded), ``n_elements``, ``newton_iters`` (per advance) and
  ``newton_iters_total``, ``warnings``, ``settings`` (the solver settings used), ``work``, ``scene``
  (the whole scene in user units; ``ringqa simulate`` can re-run it) and ``provenance``.
- ``trajectory.h5`` (on request): root attributes ``format_version``, ``software``, ``scene``
  (JSON); group ``dwells`` with one dataset per result array, each with a ``units`` attribute;
  group ``trajectory`` with the engine's full history when it kept one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ringqa.jsonio import json_text, to_jsonable
from ringqa.outdir import staged_output
from ringqa.provenance import Provenance
from ringqa.simulation.result import DWELL_COLUMNS
from ringqa.simulation.scenefile import scene_to_dict
from ringqa.units import m_to_mm

TRAJECTORY_FORMAT_VERSION = "1.0"

# result attribute -> (dataset name, units, factor to the stored unit)
_H5_FIELDS = (
    ("advances_mm", "advance", "mm", 1.0),
    ("source_pos_m", "source_position", "mm", None),
    ("source_dir", "source_direction", "1", 1.0),
    ("tip_pos_m", "tip_position", "mm", None),
    ("push_force_n", "push_force", "N", 1.0),
    ("contact_force_n", "contact_force", "N", 1.0),
    ("newton_iters", "newton_iterations", "1", 1.0),
    ("s_m", "s", "mm", None),
    ("offset_m", "offset", "mm", None),
    ("nodes_m", "nodes", "mm", None),
)


def dwell_table(result):
    """The contract dwell table of a :class:`SimResult` as a pandas DataFrame.

    Uses the result's own ``dwell_table()`` when it has one (checking the contract columns),
    else builds it from the arrays.
    """
    import pandas as pd

    if hasattr(result, "dwell_table"):
        table = result.dwell_table()
        missing = [c for c in DWELL_COLUMNS if c not in table.columns]
        if not missing:
            return table
    pos = np.asarray(result.source_pos_m, dtype=float).reshape(-1, 3)
    d = np.asarray(result.source_dir, dtype=float).reshape(-1, 3)
    return pd.DataFrame(
        {
            "advance_mm": np.asarray(result.advances_mm, dtype=float),
            "x_mm": m_to_mm(pos[:, 0]),
            "y_mm": m_to_mm(pos[:, 1]),
            "z_mm": m_to_mm(pos[:, 2]),
            "dir_x": d[:, 0],
            "dir_y": d[:, 1],
            "dir_z": d[:, 2],
            "push_force_n": np.asarray(result.push_force_n, dtype=float),
            "s_mm": m_to_mm(np.asarray(result.s_m, dtype=float)),
            "offset_mm": m_to_mm(np.asarray(result.offset_m, dtype=float)),
            "newton_iters": np.asarray(result.newton_iters, dtype=int),
        }
    )


def run_record(result, scene, inputs=()) -> dict:
    """The ``run.json`` content for a result (see the module docstring for the keys)."""
    iters = np.asarray(getattr(result, "newton_iters", []), dtype=int)
    scene_dict = scene_to_dict(scene)
    prov = Provenance.now(inputs=inputs, settings={"scene": scene.name})
    return to_jsonable(
        {
            "status": int(result.status),
            "success": int(result.status) == 0,
            "message": str(result.message),
            "scene_name": scene.name,
            "solve_time_s": float(result.solve_time_s),
            "n_elements": int(result.n_elements),
            "n_advances": len(np.atleast_1d(result.advances_mm)),
            "newton_iters": iters.tolist(),
            "newton_iters_total": int(iters.sum()) if iters.size else 0,
            "warnings": list(getattr(result, "warnings", ()) or ()),
            "settings": dict(getattr(result, "settings", {}) or {}),
            "work": dict(getattr(result, "work", {}) or {}),
            "scene": scene_dict,
            "provenance": prov.as_dict(),
        }
    )


def write_trajectory(path: Path, result, scene) -> None:
    """Write the HDF5 results file (units and format version as attributes)."""
    import h5py

    from ringqa import __version__

    with h5py.File(path, "w") as h5:
        h5.attrs["format_version"] = TRAJECTORY_FORMAT_VERSION
        h5.attrs["software"] = f"ringqa {__version__}"
        h5.attrs["scene"] = json_text(scene_to_dict(scene), indent=None)
        h5.attrs["status"] = int(result.status)
        h5.attrs["message"] = str(result.message)
        grp = h5.create_group("dwells")
        for attr, name, units, factor in _H5_FIELDS:
            if not hasattr(result, attr):
                continue
            data = np.asarray(getattr(result, attr))
            data = m_to_mm(data) if factor is None else data * factor
            ds = grp.create_dataset(name, data=data)
            ds.attrs["units"] = units
        traj = getattr(result, "trajectory", None)
        if traj:
            tg = h5.create_group("trajectory")
            units = dict(traj.get("units", {})) if isinstance(traj, dict) else {}
            for key, val in traj.items():
                if key == "units":
                    continue
                ds = tg.create_dataset(key, data=np.asarray(val))
                ds.attrs["units"] = units.get(key, _guess_units(key))


def _guess_units(key: str) -> str:
    for suffix, unit in (("_m", "m"), ("_mm", "mm"), ("_n", "N"), ("_s", "s"), ("_rad", "rad")):
        if key.endswith(suffix):
            return unit
    return "see ringqa docs/simulation.md"


def write_outputs(out_dir, result, scene, inputs=(), trajectory: bool | None = None) -> dict:
    """Write ``dwells.csv``, ``run.json`` and (if asked) ``trajectory.h5`` into ``out_dir``.

    Parameters
    ----------
    out_dir : str or Path
        Output folder (written atomically through :func:`ringqa.outdir.staged_output`).
    result : SimResult
    scene : Scene
    inputs : iterable of paths
        Input files to checksum into the provenance (the scene file).
    trajectory : bool, optional
        Write ``trajectory.h5``; default ``scene.outputs.trajectory``.

    Returns
    -------
    dict
        The ``run.json`` record.
    """
    record = run_record(result, scene, inputs)
    want_h5 = scene.outputs.trajectory if trajectory is None else trajectory
    with staged_output(out_dir) as stage:
        dwell_table(result).to_csv(stage / "dwells.csv", index=False, float_format="%.6f")
        (stage / "run.json").write_text(json_text(record, indent=2))
        if want_h5:
            write_trajectory(stage / "trajectory.h5", result, scene)
    return record
