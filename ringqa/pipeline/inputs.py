"""What the user gave: the applicator, RT Plan, channel and source, and the settings checked.

An input is a shipped applicator name, a folder, an applicator JSON file, an RT Plan (``.dcm``,
with Oncentra's applicator library) or an Applicator object; bad inputs and settings are refused
here with a message that says what to change.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ringqa.errors import RingQAError
from ringqa.units import m_to_mm


def _checked_limits(prescription_gy, position_limits_mm, dose_action_pct) -> tuple[float, float]:
    """Refuse a bad prescription, position tolerance or dose action level.

    Returns
    -------
    (float, float)
        The recommended and required position tolerance, mm.
    """
    if not (np.isfinite(prescription_gy) and prescription_gy > 0):
        raise RingQAError(f"--prescription-gy {prescription_gy!r}: must be a number > 0")
    rec, req = (float(x) for x in position_limits_mm)
    if not (np.isfinite(rec) and np.isfinite(req) and 0 < rec <= req):
        raise RingQAError(
            f"position_limits_mm {position_limits_mm!r}: give (recommended, required) with "
            "0 < recommended <= required, e.g. (1, 2)"
        )
    if not (np.isfinite(dose_action_pct) and dose_action_pct > 0):
        raise RingQAError(f"--dose-action-pct {dose_action_pct!r}: must be a number > 0")
    return rec, req


def _load_input(item):
    """(applicator, rtplan or None, kind, input files) for a name, path or Applicator object."""
    if not isinstance(item, str | Path):
        if hasattr(item, "channels") and hasattr(item, "channel"):
            return item, None, "object", []
        raise RingQAError(
            f"input {item!r}: give a shipped applicator name, a folder, an applicator JSON file "
            "or an RT Plan (.dcm)"
        )
    path = Path(item).expanduser()
    if path.suffix.lower() == ".dcm" or (path.is_file() and _is_dicom(path)):
        if not path.is_file():
            raise RingQAError(f"input {path}: RT Plan file not found (check the path)")
        from ringqa.io.rtplan import applicator_from_rtplan, read_rtplan

        rtplan = read_rtplan(path)
        return applicator_from_rtplan(rtplan), rtplan, "rtplan", [path]
    from ringqa.io.applicator_file import load_applicator

    app = load_applicator(item)
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.is_file())
        return app, None, "folder", files
    if path.is_file():
        return app, None, "file", [path]
    return app, None, "shipped", _shipped_file(str(item))


def _shipped_file(name: str) -> list[Path]:
    try:
        from ringqa.paths import data_dir

        p = data_dir() / "applicators" / f"{name}.json"
        return [p] if p.is_file() else []
    except FileNotFoundError:
        return []


def _is_dicom(path: Path) -> bool:
    try:
        with open(path, "rb") as fh:
            head = fh.read(132)
        return head[128:132] == b"DICM"
    except OSError:
        return False


def _channel(app, name: str):
    names = [c.name for c in app.channels]
    if name not in names:
        raise RingQAError(
            f"applicator {app.name}: no channel {name!r} (it has {', '.join(names) or 'none'})"
        )
    return app.channel(name)


def _check_measured_path(input, ring, channel: str, kind: str, require_measured) -> None:
    """Refuse a channel without a measured source path where one is required.

    ``require_measured`` None means: required for user files (folder, JSON, RT Plan), not for
    shipped applicators and Applicator objects.
    """
    if require_measured is None:
        require_measured = kind in ("folder", "file", "rtplan")
    if require_measured and getattr(ring, "measured_path_m", None) is None:
        raise RingQAError(
            f"{input}: no measured source path for channel {channel!r} (add the measured path, "
            "e.g. a CSV with x_mm,y_mm,z_mm, most distal position first, or allow the "
            "comparison with the centreline: --centreline-reference)"
        )


def _source_for(source, rtplan, notes: list[str]):
    import tg43

    if isinstance(source, tg43.Source):
        return source
    if source is not None:
        return tg43.load_source(source)
    if rtplan is not None:
        name = getattr(rtplan.source, "tg43_name", None)
        if name:
            return tg43.load_source(name)
        notes.append(
            f"The RT Plan's source ({getattr(rtplan.source, 'model', '?')}) has no TG-43 data in "
            "ringqa; the Flexisource data were used (choose one with --source)."
        )
    return tg43.load_source("flexisource")


def _loaded_text(app, ring, kind: str) -> str:
    """One sentence: what was loaded (channels, lengths, lumen, measured path)."""
    parts = []
    for ch in app.channels:
        text = f"{ch.name} channel {m_to_mm(float(ch.centreline.length_m)):.1f} mm long"
        lumen = getattr(ch, "lumen", None)
        if lumen is not None and hasattr(lumen, "kernel_arrays"):
            rb = np.asarray(lumen.kernel_arrays()[1], dtype=float)
            if rb.size:
                lo, hi = 2 * m_to_mm(float(rb.min())), 2 * m_to_mm(float(rb.max()))
                text += (
                    f", lumen {lo:.2f} mm"
                    if abs(hi - lo) < 1e-9
                    else f", lumen {lo:.2f}-{hi:.2f} mm"
                )
        path = getattr(ch, "measured_path_m", None)
        if path is not None:
            step = getattr(ch, "measured_step_m", None)
            step_txt = f" at {m_to_mm(float(step)):g} mm" if step else ""
            text += f", measured path {len(path)} positions{step_txt}"
        else:
            text += ", no measured path"
        parts.append(text)
    radius = m_to_mm(float(app.ring_radius_m))
    s_ref = m_to_mm(ring.s_ref_m)
    return (
        f"Loaded ({kind}): {app.name}; " + "; ".join(parts)
        + f"; ring centreline radius {radius:.2f} mm; s_ref ({ring.name}) = {s_ref:.2f} mm."
    )  # fmt: skip
