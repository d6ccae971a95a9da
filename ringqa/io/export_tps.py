"""Back to the planning system: the simulated source path as files a TPS and a physicist use.

``ringqa commission INPUT --out DIR --export`` writes into ``DIR/export/``:

- ``source_path_<channel>.csv`` for every simulated channel, columns exactly
  ``relative_position_mm, x_mm, y_mm, z_mm, dir_x, dir_y, dir_z``: the simulated source-centre
  positions and source directions (unit vectors from the cable towards the tip), in the INPUT's
  frame, most distal first, ``relative_position_mm`` the channel's relative position (0 at the
  first dwell position, nearest the tip), as an applicator library's source path is given.
  Registration moves only the reference path onto the channel (never the channel), so the
  simulated positions are already in the input's frame; nothing is transformed back.
- for an RT Plan input, ``RP_simulated.dcm``: a copy of the input plan whose ring channel's
  dwell positions (``ControlPoint3DPosition``, and ``ControlPointOrientation`` where present)
  are moved to the simulated ones; dwell times (cumulative weights, ``ChannelTotalTime``) are
  unchanged; new SOP Instance and Series Instance UIDs; ``RTPlanLabel``, ``RTPlanName``,
  ``RTPlanDescription`` and ``SeriesDescription`` say it is simulated for commissioning
  verification; ``ApprovalStatus`` UNAPPROVED. Every plan dwell must have been simulated (its
  relative position among the simulated ones, within :data:`MATCH_TOL_MM`); a plan whose ring
  channel was not simulated is refused (:class:`ExportError`).

The functions take the commissioning result duck-typed (``result.dwells``, ``result.settings``,
``result.geometry``, ``result.input``, ``result.input_kind``) so that this module stays in the io
layer.
"""

from __future__ import annotations

import csv
import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringqa.errors import RingQAError

log = logging.getLogger(__name__)

#: the columns of source_path_<channel>.csv, exactly
SOURCE_PATH_COLUMNS = ("relative_position_mm", "x_mm", "y_mm", "z_mm", "dir_x", "dir_y", "dir_z")
#: a plan dwell and a simulated dwell are the same when their relative positions differ by less
#: than this, mm (relative positions are stored to 1e-6 mm or better)
MATCH_TOL_MM = 1e-3
EXPORT_FOLDER = "export"
RTPLAN_NAME = "RP_simulated.dcm"
#: RTPlanLabel is a DICOM SH (at most 16 characters)
PLAN_LABEL = "SIMULATED QA"


class ExportError(RingQAError):
    """An export cannot be made (nothing simulated, or the plan's channel was not simulated)."""


@dataclass(frozen=True)
class SimulatedPath:
    """One channel's simulated dwells (mm, input frame).

    Attributes
    ----------
    channel : str
        Channel name (``"ring"``).
    relative_position_mm : (n,) ndarray
        Relative positions, most distal first.
    positions_mm : (n, 3) ndarray
        Source-centre positions.
    directions : (n, 3) ndarray
        Unit source directions (cable -> tip).
    """

    channel: str
    relative_position_mm: np.ndarray
    positions_mm: np.ndarray
    directions: np.ndarray


def simulated_paths(result) -> dict[str, SimulatedPath]:
    """The simulated channels of a commissioning result (channel name -> path).

    Raises
    ------
    ExportError
        The result has no simulated dwell.
    """
    dw = result.dwells
    sim = dw[dw["path"] == "simulated"] if "path" in dw else dw.iloc[0:0]
    if sim.empty:
        raise ExportError(
            f"{result.input}: --export: no simulated channel in this run, nothing to export "
            "(run without --export)"
        )
    sim = sim.sort_values("relative_position_mm")
    channel = str(result.settings.channel)
    path = SimulatedPath(
        channel,
        sim["relative_position_mm"].to_numpy(dtype=float),
        sim[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float),
        sim[["dir_x", "dir_y", "dir_z"]].to_numpy(dtype=float),
    )
    return {channel: path}


def write_source_path(path: str | Path, sim: SimulatedPath) -> Path:
    """Write ``source_path_<channel>.csv`` (:data:`SOURCE_PATH_COLUMNS`, 6 decimals)."""
    p = Path(path)
    with open(p, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(SOURCE_PATH_COLUMNS)
        for r, x, d in zip(sim.relative_position_mm, sim.positions_mm, sim.directions,
                           strict=True):  # fmt: skip
            w.writerow([f"{v:.6f}" for v in (r, *x, *d)])
    return p


def plan_channel_number(result) -> int | None:
    """The RT Plan channel number of the simulated channel (None unless the input is a plan)."""
    if getattr(result, "input_kind", None) != "rtplan":
        return None
    info = (result.geometry.metadata.get("channels") or {}).get(result.settings.channel) or {}
    number = info.get("plan_channel")
    return None if number is None else int(number)


def _plan_channel_item(ds, number: int):
    for setup in ds.get("ApplicationSetupSequence", None) or []:
        for item in setup.get("ChannelSequence", None) or []:
            if int(item.get("ChannelNumber", -1)) == number:
                return item
    return None


def _matches(plan_path, number: int, item, sim: SimulatedPath) -> list[int]:
    """For every control point of ``item``, the index of the simulated dwell at its relative
    position (refuses a control point that was not simulated)."""
    out = []
    for j, cp in enumerate(item.get("BrachyControlPointSequence", None) or []):
        r = float(cp.ControlPointRelativePosition)
        k = int(np.argmin(np.abs(sim.relative_position_mm - r)))
        if abs(sim.relative_position_mm[k] - r) > MATCH_TOL_MM:
            raise ExportError(
                f"{plan_path}: channel {number}, control point {j} at relative position "
                f"{r:g} mm was not simulated (simulated: {sim.relative_position_mm[0]:g} to "
                f"{sim.relative_position_mm[-1]:g} mm); cannot export this plan (give the plan "
                "that was commissioned)"
            )
        out.append(k)
    return out


def _ds(v: float) -> str:
    """A DICOM DS string (at most 16 characters) to 0.0001 mm."""
    text = f"{round(float(v), 4):.4f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def simulated_rtplan(plan_path: str | Path, channel_number: int, sim: SimulatedPath):
    """The copy of an RT Plan with channel ``channel_number``'s dwells moved to ``sim``.

    Returns
    -------
    pydicom.Dataset
        The new plan (not written).

    Raises
    ------
    ExportError
        The plan has no channel ``channel_number`` with control points, or one of its dwells
        was not simulated.
    """
    import pydicom
    from pydicom.uid import generate_uid

    from ringqa import __version__

    ds = pydicom.dcmread(str(plan_path))
    item = _plan_channel_item(ds, channel_number)
    if item is None or not (item.get("BrachyControlPointSequence", None) or []):
        raise ExportError(
            f"{plan_path}: the plan has no channel {channel_number} with dwells, the channel "
            f"that was simulated ({sim.channel}); cannot export (give the plan that was "
            "commissioned)"
        )
    index = _matches(plan_path, channel_number, item, sim)
    for cp, k in zip(item.BrachyControlPointSequence, index, strict=True):
        cp.ControlPoint3DPosition = [_ds(v) for v in sim.positions_mm[k]]
        if "ControlPointOrientation" in cp:
            cp.ControlPointOrientation = [_ds(v) for v in sim.directions[k]]
    sop = generate_uid()
    ds.SOPInstanceUID = sop
    ds.file_meta.MediaStorageSOPInstanceUID = sop
    ds.SeriesInstanceUID = generate_uid()
    ds.RTPlanLabel = PLAN_LABEL
    ds.RTPlanName = "ringqa simulated - verification only"
    ds.SeriesDescription = "ringqa simulated dwells - commissioning verification only"
    ds.ApprovalStatus = "UNAPPROVED"
    for kw in ("ReviewDate", "ReviewTime", "ReviewerName"):
        if kw in ds:
            delattr(ds, kw)
    ds.RTPlanDescription = (
        f"SIMULATED FOR COMMISSIONING VERIFICATION ONLY - NOT FOR TREATMENT. Written by ringqa "
        f"{__version__}: a copy of the plan {Path(plan_path).name} whose channel "
        f"{channel_number} ({sim.channel}) dwell positions are moved to the source positions "
        "simulated by ringqa; dwell times unchanged."
    )
    return ds


def write_simulated_rtplan(path: str | Path, ds) -> Path:
    """Write the plan of :func:`simulated_rtplan` (DICOM file format enforced)."""
    p = Path(path)
    ds.save_as(str(p), enforce_file_format=True)
    return p


def check_export(result) -> tuple[dict[str, SimulatedPath], object | None]:
    """Everything an export writes, made and checked before anything is written.

    Returns
    -------
    (dict of SimulatedPath, pydicom.Dataset or None)
        The simulated paths and, for an RT Plan input, the simulated plan.

    Raises
    ------
    ExportError
        No simulated channel, or the RT Plan's channel was not simulated.
    """
    paths = simulated_paths(result)
    number = plan_channel_number(result)
    plan = None
    if number is not None:
        plan = simulated_rtplan(result.input, number, paths[result.settings.channel])
    elif getattr(result, "input_kind", None) == "rtplan":
        raise ExportError(
            f"{result.input}: the simulated channel {result.settings.channel!r} has no plan "
            "channel; cannot export an RT Plan (export without an RT Plan input)"
        )
    return paths, plan


def write_exports(result, folder: str | Path, checked=None) -> list[str]:
    """Write ``folder/export/``: ``source_path_<channel>.csv`` per simulated channel and, for an
    RT Plan input, ``RP_simulated.dcm``. ``checked``: the return of :func:`check_export` (made
    here when None). Returns the names written (relative to ``folder``)."""
    paths, plan = check_export(result) if checked is None else checked
    out = Path(folder) / EXPORT_FOLDER
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for name, sim in paths.items():
        write_source_path(out / f"source_path_{name}.csv", sim)
        written.append(f"{EXPORT_FOLDER}/source_path_{name}.csv")
    if plan is not None:
        write_simulated_rtplan(out / RTPLAN_NAME, plan)
        written.append(f"{EXPORT_FOLDER}/{RTPLAN_NAME}")
    log.info("export: %s", ", ".join(written))
    return written
