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
  verification; ``ApprovalStatus`` UNAPPROVED; ``Manufacturer``, ``ManufacturerModelName`` and
  ``SoftwareVersions`` name ringqa and its version (the plan's maker is no longer the TPS).

Each plan dwell is matched to the commissioned dwell at its **3D position**
(``ControlPoint3DPosition`` against the reference path's dwells, the library path of an RT Plan:
nearest within :data:`MATCH_DISTANCE_MM`), and its relative position must agree with that
dwell's within :data:`RELATIVE_TOL_MM`: a plan whose relative positions disagree with its 3D
positions is refused naming the channel and control point (matching by relative position alone
put dwells 26.8 mm from where they belong, without a word). A plan dwell that was not simulated,
or a plan whose ring channel was not simulated, is refused too (:class:`ExportError`).
:func:`export_listing` lists the written files with their SHA-256 for ``results.json``.

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
#: than this, mm (relative positions are stored to 1e-6 mm or better; used when no reference
#: positions are known)
MATCH_TOL_MM = 1e-3
#: a plan dwell farther than this from every commissioned (reference) dwell position was not
#: commissioned, mm (the required position tolerance)
MATCH_DISTANCE_MM = 2.0
#: the largest difference accepted between a plan dwell's relative position and that of the
#: commissioned dwell at its 3D position, mm (Oncentra's agree to 1e-6 mm)
RELATIVE_TOL_MM = 0.1
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
    reference_mm : (n, 3) ndarray or None
        The reference path's positions of the same dwells (the supplied path, input frame):
        what a plan's ``ControlPoint3DPosition`` is matched against.
    """

    channel: str
    relative_position_mm: np.ndarray
    positions_mm: np.ndarray
    directions: np.ndarray
    reference_mm: np.ndarray | None = None


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
    reference = None
    kinds = set(dw["path"])
    ref_kind = next((k for k in ("measured", "centreline") if k in kinds), None)
    if ref_kind is not None and "dwell" in dw:
        ref = dw[dw["path"] == ref_kind].set_index("dwell")
        if set(sim["dwell"]) <= set(ref.index):
            reference = ref.loc[sim["dwell"], ["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)
    path = SimulatedPath(
        channel,
        sim["relative_position_mm"].to_numpy(dtype=float),
        sim[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float),
        sim[["dir_x", "dir_y", "dir_z"]].to_numpy(dtype=float),
        reference,
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
    """For every control point of ``item``, the index of the simulated dwell at its 3D position
    (the nearest reference dwell within :data:`MATCH_DISTANCE_MM`, whose relative position must
    agree within :data:`RELATIVE_TOL_MM`); by relative position alone when no reference
    positions are known. Refuses a control point that was not simulated, and one whose relative
    and 3D positions disagree."""
    out = []
    rel = sim.relative_position_mm
    span = f"simulated: {rel[0]:g} to {rel[-1]:g} mm"
    for j, cp in enumerate(item.get("BrachyControlPointSequence", None) or []):
        r = float(cp.ControlPointRelativePosition)
        where = f"{plan_path}: channel {number}, control point {j}"
        xyz = _position(cp)
        if sim.reference_mm is None or xyz is None:
            k = int(np.argmin(np.abs(rel - r)))
            if abs(rel[k] - r) > MATCH_TOL_MM:
                raise ExportError(
                    f"{where} at relative position {r:g} mm was not simulated ({span}); cannot "
                    "export this plan (give the plan that was commissioned)"
                )
            out.append(k)
            continue
        dist = np.linalg.norm(sim.reference_mm - xyz, axis=1)
        k = int(np.argmin(dist))
        shown = ", ".join(f"{v:.2f}" for v in xyz)
        if dist[k] > MATCH_DISTANCE_MM:
            raise ExportError(
                f"{where} at relative position {r:g} mm was not simulated: its 3D position "
                f"({shown}) mm lies {dist[k]:.2f} mm from the nearest commissioned dwell "
                f"(at most {MATCH_DISTANCE_MM:g} mm; {span}); cannot export this plan (give the "
                "plan that was commissioned)"
            )
        if abs(rel[k] - r) > RELATIVE_TOL_MM:
            raise ExportError(
                f"{where}: its relative position {r:g} mm disagrees with its 3D position "
                f"({shown}) mm, which is the commissioned dwell at relative position "
                f"{rel[k]:g} mm ({dist[k]:.3f} mm away): {abs(rel[k] - r):.2f} mm apart, beyond "
                f"{RELATIVE_TOL_MM:g} mm; cannot export this plan (export it again from the TPS "
                "so that relative and 3D positions agree)"
            )
        out.append(k)
    return out


def _position(cp) -> np.ndarray | None:
    """A control point's ``ControlPoint3DPosition`` (mm), None when absent or not 3 numbers."""
    value = cp.get("ControlPoint3DPosition", None)
    try:
        xyz = np.asarray([float(v) for v in value], dtype=float)
    except (TypeError, ValueError):
        return None
    return xyz if xyz.shape == (3,) and np.isfinite(xyz).all() else None


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
    ds.Manufacturer = "ringqa"
    ds.ManufacturerModelName = "ringqa"
    ds.SoftwareVersions = f"ringqa {__version__}"
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


def export_listing(folder: str | Path, written: list[str]) -> list[dict]:
    """The files of an export with their size and SHA-256, for ``results.json`` ``export``.

    Parameters
    ----------
    folder : path
        The output folder the names are relative to.
    written : list of str
        What :func:`write_exports` returned.

    Returns
    -------
    list of dict
        ``{"path": "export/RP_simulated.dcm", "size": bytes, "sha256": hex}`` per file.
    """
    import hashlib

    out = []
    for name in written:
        data = (Path(folder) / name).read_bytes()
        out.append({"path": name, "size": len(data), "sha256": hashlib.sha256(data).hexdigest()})
    return out


def add_export_listing(folder: str | Path, written: list[str]) -> list[dict]:
    """Add the export's files (:func:`export_listing`) to ``folder/results.json``: ``export``
    (path, size, SHA-256 each) and their names appended to ``files``. Returns the listing."""
    import json

    from ringqa.jsonio import write_json

    listing = export_listing(folder, written)
    path = Path(folder) / "results.json"
    if path.is_file():
        record = json.loads(path.read_text(encoding="utf-8"))
        record["export"] = listing
        record["files"] = [*record.get("files", []), *written]
        write_json(path, record, indent=2)
    return listing


def export_note(checked) -> list[str]:
    """The report's one line naming the export's files (empty without an export).

    Parameters
    ----------
    checked : tuple or None
        What :func:`check_export` returned.
    """
    if checked is None:
        return []
    paths, plan = checked
    names = [f"{EXPORT_FOLDER}/source_path_{name}.csv" for name in paths]
    names += [f"{EXPORT_FOLDER}/{RTPLAN_NAME}"] if plan is not None else []
    return [
        f"Exported for the planning system: {', '.join(names)} (SHA-256 of each in results.json "
        "'export'; the RT Plan is for commissioning verification only, not for treatment)."
    ]
