"""Commissioning of one ring applicator: measured vs simulated vs centreline, in distance and dose.

Steps (issue 5; Straathof et al. 2024, section 2.4):

1. Load the applicator (shipped name, folder, applicator JSON or RT Plan with Oncentra's library).
2. Reference dwells: the ring channel's MEASURED source path (relative positions 0, step, ...,
   most distal first). Without a measured path (the synthetic shipped rings) the reference is the
   centreline: relative positions every 5 mm on the circular part of the ring, and the comparison
   is simulated vs centreline (said in the result and the report).
3. Simulate the source cable at the advances ``s_ref - p`` (the cable length that would put the
   source centre at arc length ``s_ref - p`` if the cable followed the centreline).
4. Centreline dwells: the same relative positions at arc length ``s_ref - p``, direction = tangent.
5. Distances per dwell to the reference (3D, and split into along-channel, radial in the ring
   plane and out of the ring plane) and angles between source directions.
6. Standard plan on the reference dwells every 5 mm (+ the tandem where the applicator has one,
   identical in all three plans), equal times scaled to the prescription at Point A; the times are
   transferred unchanged to the simulated and centreline dwells; TG-43 doses at the dose points.
7. Verdicts: 1 mm recommended / 2 mm required on position, a dose action level (default 5 %).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ringqa.errors import RingQAError, SimulationError
from ringqa.plan import (
    PLAN_STEP_MM,
    PRESCRIPTION_GY,
    DosePoint,
    DosePointSpec,
    DwellSet,
    Plan,
    applicator_dose_points,
    path_directions,
    points_array_mm,
    relative_difference_pct,
    standard_plan,
)
from ringqa.provenance import Provenance
from ringqa.units import m_to_mm, mm_to_m

#: Position tolerances, mm: recommended and required (AAPM MPPG 13.a, 2023; TG-56).
POSITION_RECOMMENDED_MM = 1.0
POSITION_REQUIRED_MM = 2.0
#: Default dose-difference action level, %.
DOSE_ACTION_PCT = 5.0
#: Default number of tandem dwells (5 mm apart) when the tandem has no measured path
#: (the Oncentra 26/60 standard plan has 7).
TANDEM_DWELLS = 7

#: Afterloader each TG-43 source belongs to (for the cable-model note).
SOURCE_AFTERLOADER = {
    "flexisource": "flexitron",
    "mhdr-v2": "microselectron",
    "gammamed-plus": "gammamed",
    "vs2000": "varisource",
    "m-19": "saginova/bebig",
}


class SimulationJammedError(RingQAError):
    """The simulated cable jammed (or the engine failed) before reaching every dwell."""


@dataclass(frozen=True)
class Verdict:
    """One tolerance check, shown in the report.

    Attributes
    ----------
    check : str
        What is compared (``"position: simulated vs measured"``).
    value : float
        The checked value (max distance in mm, or max |dose difference| in %).
    unit : str
        ``"mm"`` or ``"%"``.
    limits : tuple of float
        (recommended, required) for positions; (action level,) for doses.
    status : str
        ``"PASS"``, ``"WARN"`` (within the required 2 mm but above the recommended 1 mm),
        ``"FAIL"`` (position beyond 2 mm) or ``"ACTION"`` (dose beyond the action level).
    text : str
        One sentence for the report.
    """

    check: str
    value: float
    unit: str
    limits: tuple[float, ...]
    status: str
    text: str

    def as_dict(self) -> dict:
        return {
            "check": self.check,
            "value": float(self.value),
            "unit": self.unit,
            "limits": [float(x) for x in self.limits],
            "status": self.status,
            "text": self.text,
        }


@dataclass(frozen=True, eq=False)
class CommissioningResult:
    """Everything one commissioning run produced (tables in mm, deg, Gy, %).

    Attributes
    ----------
    applicator : str
        Applicator name.
    input : str
        What the user gave (name or path); ``input_kind`` one of ``shipped``, ``file``,
        ``folder``, ``rtplan``, ``object``.
    reference : str
        ``"measured"`` (a measured source path) or ``"centreline"`` (none shipped: the comparison
        is simulated vs centreline).
    dwells : pandas.DataFrame
        One row per dwell and path (``measured``/``simulated``/``centreline``): columns
        ``applicator, dwell, relative_position_mm, path, x_mm, y_mm, z_mm, dir_x, dir_y, dir_z,
        dist_to_measured_mm, dist_to_reference_mm, along_mm, radial_mm, out_of_plane_mm,
        angle_deg, in_plan``.
    doses : pandas.DataFrame
        One row per dose point and plan: ``applicator, point, kind, plan, dose_gy, diff_pct,
        x_mm, y_mm, z_mm, tps_dose_gy``.
    plan_dwells : pandas.DataFrame
        The three standard plans' dwells with their (equal) times.
    summary : dict
        Per-applicator numbers (one row of summary.csv).
    verdicts : tuple of Verdict
    geometry : dict
        For plots: ``ring_centre_mm``, ``ring_normal``, ``ring_lateral``, ``ring_radius_mm``,
        ``centrelines_mm`` (channel name -> (k, 3)), ``s_ref_mm``.
    simulation : dict
        ``status, message, warnings, solve_time_s, n_elements, settings``.
    settings : dict
        Source, S_K, prescription, cable, tolerances, dose point definitions, scene settings.
    notes : tuple of str
        Statements the report must show (reference used, cable vs afterloader, ...).
    provenance : Provenance
    timings_s : dict
    """

    applicator: str
    input: str
    input_kind: str
    reference: str
    dwells: pd.DataFrame
    doses: pd.DataFrame
    plan_dwells: pd.DataFrame
    summary: dict
    verdicts: tuple[Verdict, ...]
    geometry: dict
    simulation: dict
    settings: dict
    notes: tuple[str, ...]
    provenance: Provenance
    timings_s: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """True when no verdict is FAIL or ACTION."""
        return all(v.status in ("PASS", "WARN") for v in self.verdicts)


# ------------------------------------------------------------------------------------------------
# loading


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


# ------------------------------------------------------------------------------------------------
# dwell sets


def _centreline_dwells(channel, rel_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centreline positions (mm) and tangents at arc length s_ref - p."""
    s_m = channel.s_ref_m - mm_to_m(np.asarray(rel_mm, dtype=float))
    pos = m_to_mm(np.asarray(channel.centreline.position(s_m), dtype=float).reshape(-1, 3))
    tan = np.asarray(channel.centreline.tangent(s_m), dtype=float).reshape(-1, 3)
    return pos, tan / np.linalg.norm(tan, axis=1)[:, None]


def _ring_arc_mm(app, channel, step_mm: float) -> float:
    """Largest relative position still on the ring's circle (within 1 mm of it), mm.

    Walks proximally from s_ref in ``step_mm`` steps while the centreline stays within 1 mm of
    the circle of radius ``ring_radius`` around ``ring_centre`` in the ring plane.
    """
    c = m_to_mm(np.asarray(app.ring_centre_m, dtype=float))
    n = np.asarray(app.ring_normal, dtype=float)
    r = m_to_mm(float(app.ring_radius_m))
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel = np.arange(0.0, s_ref_mm + 1e-9, step_mm)
    pos, _ = _centreline_dwells(channel, rel)
    d = pos - c
    h = d @ n
    rho = np.linalg.norm(d - np.outer(h, n), axis=1)
    on = (np.abs(rho - r) < 1.0) & (np.abs(h) < 1.0)
    if not on[0]:
        return 0.0
    k = int(np.argmin(on)) if not on.all() else on.size
    return float(rel[k - 1])


def _reference(app, channel, step_mm: float | None):
    """Reference dwells of the ring: (kind, rel_mm, pos_mm, dirs, step_mm)."""
    path = getattr(channel, "measured_path_m", None)
    if path is not None and len(path) < 2:
        raise RingQAError(
            f"applicator {app.name}, channel {channel.name}: the measured path has "
            f"{len(path)} position(s); it needs at least 2 (most distal first)"
        )
    if path is not None:
        step = getattr(channel, "measured_step_m", None)
        if step is None or not step > 0:
            raise RingQAError(
                f"applicator {app.name}, channel {channel.name}: the measured path has no step "
                "(give measured_step_mm in the applicator file)"
            )
        pos = m_to_mm(np.asarray(path, dtype=float))
        step_mm_path = m_to_mm(float(step))
        rel = np.arange(pos.shape[0]) * step_mm_path
        return "measured", rel, pos, path_directions(pos), step_mm_path
    step = PLAN_STEP_MM if step_mm is None else float(step_mm)
    arc = _ring_arc_mm(app, channel, step)
    if arc < step:
        raise RingQAError(
            f"applicator {app.name}: no measured source path and no circular ring part found "
            "near s_ref to place reference dwells (add the measured path, e.g. a path CSV in the "
            "applicator folder)"
        )
    rel = np.arange(0.0, arc + 1e-9, step)
    pos, tan = _centreline_dwells(channel, rel)
    return "centreline", rel, pos, tan, step


def _tandem_dwells(app, n_dwells: int, plan_step_mm: float) -> DwellSet | None:
    names = [c.name for c in app.channels]
    if "tandem" not in names or n_dwells <= 0:
        return None
    ch = app.channel("tandem")
    path = getattr(ch, "measured_path_m", None)
    step = getattr(ch, "measured_step_m", None)
    if path is not None and len(path) >= 2 and step:
        pos = m_to_mm(np.asarray(path, dtype=float))
        rel_path = np.arange(pos.shape[0]) * m_to_mm(float(step))
        keep = np.isclose(np.mod(rel_path + 1e-6, plan_step_mm), 0.0, atol=1e-5)
        keep &= np.cumsum(keep) <= n_dwells
        return DwellSet("tandem", rel_path[keep], pos[keep], path_directions(pos)[keep])
    rel = np.arange(n_dwells) * plan_step_mm
    rel = rel[rel <= m_to_mm(ch.s_ref_m)]
    pos, tan = _centreline_dwells(ch, rel)
    return DwellSet("tandem", rel, pos, tan)


# ------------------------------------------------------------------------------------------------
# deviations


def deviation_components(ref_mm, ref_dir, other_mm, centre_mm, normal) -> dict[str, np.ndarray]:
    """Split ``other - ref`` into along-channel, radial (in the ring plane) and out-of-plane parts.

    The frame at each reference dwell: ``out`` = ring normal (cranial positive); ``radial`` = the
    in-plane direction from the ring centre to the reference dwell (outward positive); ``along`` =
    the remaining in-plane direction, signed so that DISTAL is positive (along ``ref_dir``).

    Returns
    -------
    dict
        ``dist_mm``, ``along_mm``, ``radial_mm``, ``out_of_plane_mm``, each (n,).
    """
    ref = np.asarray(ref_mm, dtype=float)
    d = np.asarray(other_mm, dtype=float) - ref
    n = np.asarray(normal, dtype=float) / np.linalg.norm(normal)
    rad = ref - np.asarray(centre_mm, dtype=float)
    rad -= np.outer(rad @ n, n)
    norm = np.linalg.norm(rad, axis=1)
    rad = np.where(norm[:, None] > 1e-9, rad / np.maximum(norm, 1e-12)[:, None], 0.0)
    along = np.cross(n, rad)
    sign = np.sign(np.sum(along * np.asarray(ref_dir, dtype=float), axis=1))
    along *= np.where(sign == 0, 1.0, sign)[:, None]
    return {
        "dist_mm": np.linalg.norm(d, axis=1),
        "along_mm": np.sum(d * along, axis=1),
        "radial_mm": np.sum(d * rad, axis=1),
        "out_of_plane_mm": d @ n,
    }


def angle_deg(a, b) -> np.ndarray:
    """Angle between unit vectors row by row, degrees."""
    c = np.sum(np.asarray(a, dtype=float) * np.asarray(b, dtype=float), axis=1)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def _position_verdict(check: str, dist_mm: np.ndarray, rec: float, req: float) -> Verdict:
    worst = float(np.max(dist_mm)) if dist_mm.size else 0.0
    if worst <= rec:
        status, what = "PASS", f"within the recommended {rec:g} mm"
    elif worst <= req:
        status, what = (
            "WARN",
            f"within the required {req:g} mm but above the recommended {rec:g} mm",
        )
    else:
        status, what = "FAIL", f"beyond the required {req:g} mm"
    return Verdict(check, worst, "mm", (rec, req), status, f"{check}: max {worst:.2f} mm, {what}")


def _dose_verdict(check: str, diff_pct: np.ndarray, action: float) -> Verdict:
    worst = float(np.max(np.abs(diff_pct))) if diff_pct.size else 0.0
    status = "PASS" if worst <= action else "ACTION"
    word = "within" if status == "PASS" else "beyond"
    return Verdict(
        check, worst, "%", (action,), status,
        f"{check}: max |difference| {worst:.2f} %, {word} the {action:g} % action level",
    )  # fmt: skip


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


def _verdict_meanings(verdicts, ref_kind: str) -> list[str]:
    """What a physicist should conclude from the verdicts that are not PASS."""
    out = []
    for v in verdicts:
        if v.status == "PASS":
            continue
        if v.check == "position: centreline vs measured":
            out.append(
                f"Centreline vs measured {v.status}: planning on the channel centreline would "
                f"misplace dwells by up to {v.value:.1f} mm in this applicator; plan on the "
                "measured source path (or a validated source-path model) instead."
            )
        elif v.check == "position: simulated vs measured":
            out.append(
                f"Simulated vs measured {v.status}: the simulation does not reproduce the "
                f"measured path within tolerance (max {v.value:.1f} mm); it cannot replace the "
                "measurement for this applicator."
            )
        elif v.check.startswith("position: simulated vs centreline"):
            out.append(
                f"Simulated vs centreline {v.status}: the simulated source deviates from the "
                f"centreline by up to {v.value:.1f} mm; measure the source path of this "
                "applicator before planning on its centreline."
            )
        elif v.check.startswith("dose:"):
            out.append(
                f"{v.check} {v.status}: the dwell-position differences change the dose at the "
                f"dose points by up to {v.value:.1f} % (lateral ring-surface points are the most "
                "sensitive; see the dose table)."
            )
    return out


# ------------------------------------------------------------------------------------------------
# simulation


def _default_simulator():
    try:
        from ringqa.simulation import simulate
    except ImportError as exc:  # the engine has not landed in this build
        raise SimulationError(
            "the source-cable simulation engine (ringqa.simulation.simulate) is not available "
            "in this installation"
        ) from exc
    return simulate


def _default_scene_factory(channel, cable: str):
    from ringqa.simulation import Scene

    if not hasattr(Scene, "for_channel"):
        raise SimulationError("ringqa.simulation.Scene.for_channel is not available in this build")
    return Scene.for_channel(channel, cable=cable)


def _cable_radius_m(scene) -> float | None:
    inst = getattr(scene, "instrument", None)
    sections = getattr(inst, "sections", None)
    if not sections:
        return None
    return max(float(s.r_o_m) for s in sections)


def _check_clearance(app, channel, scene) -> None:
    """Refuse a lumen narrower than the cable (or source capsule) before simulating."""
    r_cable = _cable_radius_m(scene)
    lumen = getattr(channel, "lumen", None)
    if r_cable is None or lumen is None or not hasattr(lumen, "kernel_arrays"):
        return
    seg_rb = np.asarray(lumen.kernel_arrays()[1], dtype=float)
    if seg_rb.size and float(seg_rb.min()) <= r_cable:
        raise RingQAError(
            f"applicator {app.name}, channel {channel.name}: lumen radius "
            f"{m_to_mm(float(seg_rb.min())):.2f} mm is not larger than the cable/source radius "
            f"{m_to_mm(r_cable):.2f} mm: the cable cannot pass (check the lumen diameter in the "
            "applicator file or the instrument preset)"
        )


#: Refinements of the input increment tried when the engine FAILS to converge (status -1; a
#: jam, status 1, is a result and is not retried): the scene's increment times these factors.
RETRY_INCREMENT_FACTORS = (0.5, 0.25)


def _run_engine(simulate, scene, advances, progress=False):
    res = simulate(scene, advances_mm=advances, progress=progress)
    status = int(getattr(res, "status", 0))
    pos_m = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
    ok = status == 0 and pos_m.shape[0] >= advances.size and bool(np.all(np.isfinite(pos_m)))
    return res, status, pos_m, ok


def _simulate(
    app, channel, rel_mm, *, cable, scene_overrides, simulator, scene_factory, notes, progress
):
    scene = (scene_factory or _default_scene_factory)(channel, cable)
    if scene_overrides:
        scene = scene.with_overrides(dict(scene_overrides))
    _check_clearance(app, channel, scene)
    simulate = simulator or _default_simulator()
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel_sorted = np.sort(np.unique(np.round(np.asarray(rel_mm, dtype=float), 9)))[::-1]
    advances = s_ref_mm - rel_sorted  # increasing: the cable is pushed in, proximal -> distal
    motion = getattr(scene, "motion", None)
    if getattr(motion, "backward", False) or getattr(motion, "kind", "") == "retract":
        advances = advances[::-1]  # backward stepping / retraction: most distal dwell first
    t0 = time.perf_counter()
    res, status, pos_m, ok = _run_engine(simulate, scene, advances, progress)
    inc_m = getattr(getattr(scene, "solver", None), "increment_m", None)
    if not ok and status == -1 and inc_m and hasattr(scene, "with_overrides"):
        first_message = str(getattr(res, "message", ""))
        for factor in RETRY_INCREMENT_FACTORS:
            inc_mm = m_to_mm(float(inc_m)) * factor
            retry = scene.with_overrides({"solver.increment_mm": inc_mm})
            res, status, pos_m, ok = _run_engine(simulate, retry, advances, progress)
            if ok:
                notes.append(
                    f"The simulation did not converge with an input increment of "
                    f"{m_to_mm(float(inc_m)):g} mm ({first_message}); it was repeated with "
                    f"{inc_mm:g} mm, which converged (solver.increment_mm = {inc_mm:g})."
                )
                scene = retry
                break
    wall = time.perf_counter() - t0
    got_adv = np.asarray(getattr(res, "advances_mm", advances), dtype=float).reshape(-1)
    dirs = np.asarray(res.source_dir, dtype=float).reshape(-1, 3)
    if not ok:
        n = min(pos_m.shape[0], got_adv.size)
        finite = np.all(np.isfinite(pos_m[:n]), axis=1)
        reached = got_adv[:n][finite]
        where = (
            f"after advance {reached[-1]:.1f} mm (relative position "
            f"{s_ref_mm - reached[-1]:.1f} mm; {reached.size} of {advances.size} dwells reached)"
            if reached.size
            else "before the first dwell"
        )
        kind = "jammed" if status == 1 else "failed"
        raise SimulationJammedError(
            f"applicator {app.name}: the simulated source cable {kind} {where}: "
            f"{getattr(res, 'message', '') or 'no message'} (check the lumen and the scene "
            "settings, e.g. --set solver.increment_mm=0.25 or --set effects.friction=coulomb)"
        )
    lookup = {round(float(a), 6): i for i, a in enumerate(got_adv)}
    idx = []
    for a in s_ref_mm - np.asarray(rel_mm, dtype=float):
        i = lookup.get(round(float(a), 6))
        if i is None:  # tolerate rounding in the engine's echo of the advances
            i = int(np.argmin(np.abs(got_adv - a)))
            if abs(got_adv[i] - a) > 1e-3:
                raise SimulationError(f"the simulation did not report advance {a:.3f} mm")
        idx.append(i)
    idx = np.asarray(idx)
    d = dirs[idx]
    info = {
        "status": status,
        "message": str(getattr(res, "message", "")),
        "warnings": [str(w) for w in getattr(res, "warnings", ())],
        "solve_time_s": float(getattr(res, "solve_time_s", wall)),
        "wall_time_s": wall,
        "n_elements": int(getattr(res, "n_elements", 0) or 0),
        "settings": dict(getattr(res, "settings", {}) or {}),
    }
    scene_dict = {}
    if hasattr(scene, "to_dict"):
        try:
            scene_dict = scene.to_dict()
        except Exception:  # provenance must not break a run
            scene_dict = {}
    afterloader = getattr(getattr(scene, "instrument", None), "afterloader", "") or cable
    return (
        m_to_mm(pos_m[idx]),
        d / np.linalg.norm(d, axis=1)[:, None],
        info,
        scene_dict,
        afterloader,
    )


# ------------------------------------------------------------------------------------------------
# RT Plan: its own dwells at its own points


def _rtplan_own_doses(rtplan, app, source, sk_U) -> tuple[pd.DataFrame, list[str]]:
    """Our TG-43 dose of the RT Plan's own dwells and times at its TPS points."""
    notes = []
    pts = [p for p in getattr(rtplan, "points", ()) if p.position_mm is not None]
    if not pts:
        return pd.DataFrame(), notes
    pos, dirs, times = [], [], []
    for ch in rtplan.channels:
        p = np.asarray(ch.positions_mm, dtype=float).reshape(-1, 3)
        if p.shape[0] == 0:
            continue
        if ch.directions is not None:
            d = np.asarray(ch.directions, dtype=float).reshape(-1, 3)
        else:
            d = _nearest_tangents(app, p)
        pos.append(p)
        dirs.append(d)
        times.append(np.asarray(ch.times_s, dtype=float).reshape(-1))
    if not pos:
        return pd.DataFrame(), notes
    if any(ch.directions is None for ch in rtplan.channels):
        notes.append(
            "The RT Plan has no source orientations: its dwells are oriented along the nearest "
            "applicator centreline tangent (distally) for the dose at the TPS points."
        )
    plan = Plan(
        "rtplan",
        ("rtplan",) * sum(len(t) for t in times),
        np.zeros(sum(len(t) for t in times)),
        np.concatenate(pos),
        np.concatenate(dirs),
        np.concatenate(times),
        source,
        sk_U,
    )
    xyz = np.array([p.position_mm for p in pts], dtype=float)
    dose = plan.dose_gy(xyz)
    tps = np.array([np.nan if p.tps_dose_gy is None else p.tps_dose_gy for p in pts], dtype=float)
    df = pd.DataFrame(
        {
            "point": [p.name for p in pts],
            "kind": "tps",
            "plan": "rtplan",
            "dose_gy": dose,
            "diff_pct": relative_difference_pct(dose, tps),
            "x_mm": xyz[:, 0],
            "y_mm": xyz[:, 1],
            "z_mm": xyz[:, 2],
            "tps_dose_gy": tps,
        }
    )
    return df, notes


def _nearest_tangents(app, pos_mm: np.ndarray) -> np.ndarray:
    best_d = np.full(pos_mm.shape[0], np.inf)
    best_t = np.zeros_like(pos_mm)
    for ch in app.channels:
        s, dist = ch.centreline.closest(mm_to_m(pos_mm))
        t = np.asarray(ch.centreline.tangent(np.asarray(s)), dtype=float).reshape(-1, 3)
        better = np.asarray(dist) < best_d
        best_d = np.where(better, dist, best_d)
        best_t[better] = t[better]
    return best_t / np.linalg.norm(best_t, axis=1)[:, None]


# ------------------------------------------------------------------------------------------------
# the pipeline


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


def commission(
    input,
    *,
    scene_overrides: Mapping | None = None,
    source=None,
    prescription_gy: float = PRESCRIPTION_GY,
    sk_U: float | None = None,
    cable: str = "flexitron",
    channel: str = "ring",
    point_spec: DosePointSpec | None = None,
    plan_step_mm: float = PLAN_STEP_MM,
    tandem_dwells: int = TANDEM_DWELLS,
    position_limits_mm: tuple[float, float] = (POSITION_RECOMMENDED_MM, POSITION_REQUIRED_MM),
    dose_action_pct: float = DOSE_ACTION_PCT,
    require_measured: bool | None = None,
    progress: bool = False,
    simulator: Callable | None = None,
    scene_factory: Callable | None = None,
) -> CommissioningResult:
    """Commission one ring applicator (see the module docstring for the steps).

    Parameters
    ----------
    input : str, pathlib.Path or Applicator
        A shipped applicator name (``"ring26x60"``), a folder of CSV/JSON files, an applicator
        JSON file, an RT Plan (``.dcm``) with Oncentra's applicator library, or an Applicator.
    scene_overrides : mapping, optional
        Dotted scene keys -> values (as ``--set``), e.g. ``{"solver.increment_mm": 0.5}``.
    source : str or tg43.Source, optional
        TG-43 source; default: the RT Plan's source, else ``"flexisource"``.
    prescription_gy : float
        Mean Point A dose of the standard plan, Gy (7).
    sk_U : float, optional
        Air-kerma strength, U (default: the RT Plan's, else 40820 U; doses do not depend on it).
    cable : str
        Instrument preset for the simulation (``"flexitron"``).
    channel : str
        The channel to simulate (``"ring"``).
    point_spec : DosePointSpec, optional
        Dose point definitions.
    plan_step_mm : float
        Dwell spacing of the standard plan (5 mm); must be a multiple of the measured step.
    tandem_dwells : int
        Tandem dwells in the standard plan when the tandem has no measured path (7).
    position_limits_mm : (float, float)
        Recommended and required source-position tolerance, mm (1, 2).
    dose_action_pct : float
        Dose-difference action level, % (5).
    require_measured : bool, optional
        Refuse an applicator without a measured source path. Default: True for user files
        (folder, JSON, RT Plan), False for shipped applicators and Applicator objects (which are
        then compared simulated vs centreline).
    progress : bool
        Show the engine's progress bar (tqdm, on stderr).
    simulator, scene_factory : callable, optional
        Replace ``ringqa.simulation.simulate`` / ``Scene.for_channel(channel, cable=...)``
        (tests, other engines). ``simulator(scene, advances_mm=..., progress=...)`` must return
        an object with ``status, message, advances_mm, source_pos_m, source_dir``.

    Returns
    -------
    CommissioningResult

    Raises
    ------
    RingQAError
        Unreadable input, missing ring frame or channel, lumen narrower than the cable, a jammed
        simulation (:class:`SimulationJammedError`), bad settings.
    """
    t_start = time.perf_counter()
    timings: dict[str, float] = {}
    notes: list[str] = []
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
    app, rtplan, kind, input_files = _load_input(input)
    timings["load_s"] = time.perf_counter() - t_start
    ring = _channel(app, channel)
    if require_measured is None:
        require_measured = kind in ("folder", "file", "rtplan")
    if require_measured and getattr(ring, "measured_path_m", None) is None:
        raise RingQAError(
            f"{input}: no measured source path for channel {channel!r} (add the measured path, "
            "e.g. a CSV with x_mm,y_mm,z_mm, most distal position first, or allow the "
            "comparison with the centreline: --centreline-reference)"
        )
    src = _source_for(source, rtplan, notes)
    if sk_U is None:
        sk_U = float(getattr(getattr(rtplan, "source", None), "sk_U", 0.0) or 40820.0)

    # reference dwells and the plan's 5 mm subset
    ref_kind, rel, ref_pos, ref_dir, ref_step = _reference(app, ring, plan_step_mm)
    ratio = plan_step_mm / ref_step
    if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
        raise RingQAError(
            f"applicator {app.name}: the plan step {plan_step_mm:g} mm is not a multiple of the "
            f"measured path's step {ref_step:g} mm (choose a plan step that is)"
        )
    in_plan = np.zeros(rel.size, dtype=bool)
    in_plan[:: round(ratio)] = True
    s_ref_mm = m_to_mm(ring.s_ref_m)
    if np.any(rel > s_ref_mm + 1e-9):
        n_out = int(np.sum(rel > s_ref_mm + 1e-9))
        raise RingQAError(
            f"applicator {app.name}: {n_out} measured positions lie beyond the channel entry "
            f"(relative position > s_ref = {s_ref_mm:.1f} mm): check s_ref / the measured path"
        )
    notes.append(_loaded_text(app, ring, kind))
    if ref_kind == "centreline":
        notes.append(
            "No measured source path ships with this applicator: the reference is the channel "
            "CENTRELINE, and the comparison is simulated vs centreline (no measurement involved)."
        )
    else:
        notes.append(
            f"Reference: the measured source path ({rel.size} positions, {ref_step:g} mm apart)."
        )

    # simulation and centreline dwells
    t0 = time.perf_counter()
    sim_pos, sim_dir, sim_info, scene_dict, afterloader = _simulate(
        app, ring, rel, cable=cable, scene_overrides=scene_overrides, simulator=simulator,
        scene_factory=scene_factory, notes=notes, progress=progress,
    )  # fmt: skip
    timings["simulation_s"] = time.perf_counter() - t0
    cl_pos, cl_dir = _centreline_dwells(ring, rel)
    if sim_info["warnings"]:
        notes.append("Simulation warnings: " + "; ".join(sim_info["warnings"]))
    src_afterloader = SOURCE_AFTERLOADER.get(getattr(src, "name", ""), "")
    if src_afterloader and afterloader and src_afterloader != afterloader:
        notes.append(
            f"The cable model is the {afterloader} cable (the only published cable data), while "
            f"the source ({src.name}) belongs to a {src_afterloader} afterloader: the simulated "
            "positions assume the Flexitron cable's mechanics."
        )

    # distances
    centre = m_to_mm(np.asarray(app.ring_centre_m, dtype=float))
    normal = np.asarray(app.ring_normal, dtype=float)
    comp_sim = deviation_components(ref_pos, ref_dir, sim_pos, centre, normal)
    comp_cl = deviation_components(ref_pos, ref_dir, cl_pos, centre, normal)
    ang_sim = angle_deg(sim_dir, ref_dir)
    ang_cl = angle_deg(cl_dir, ref_dir)
    ang_sim_cl = angle_deg(sim_dir, cl_dir)

    rows = []
    paths = [("simulated", sim_pos, sim_dir, comp_sim, ang_sim)]
    if ref_kind == "measured":
        zero = {k: np.zeros(rel.size) for k in comp_sim}
        paths = [
            ("measured", ref_pos, ref_dir, zero, np.zeros(rel.size)),
            *paths,
            ("centreline", cl_pos, cl_dir, comp_cl, ang_cl),
        ]
    else:
        zero = {k: np.zeros(rel.size) for k in comp_sim}
        paths = [("centreline", cl_pos, cl_dir, zero, np.zeros(rel.size)), *paths]
    for name, pos, dirs, comp, ang in paths:
        for i in range(rel.size):
            rows.append(
                {
                    "applicator": app.name,
                    "dwell": i + 1,
                    "relative_position_mm": rel[i],
                    "path": name,
                    "x_mm": pos[i, 0],
                    "y_mm": pos[i, 1],
                    "z_mm": pos[i, 2],
                    "dir_x": dirs[i, 0],
                    "dir_y": dirs[i, 1],
                    "dir_z": dirs[i, 2],
                    "dist_to_measured_mm": comp["dist_mm"][i] if ref_kind == "measured" else np.nan,
                    "dist_to_reference_mm": comp["dist_mm"][i],
                    "along_mm": comp["along_mm"][i],
                    "radial_mm": comp["radial_mm"][i],
                    "out_of_plane_mm": comp["out_of_plane_mm"][i],
                    "angle_deg": ang[i],
                    "in_plan": bool(in_plan[i]),
                }
            )
    dwells = pd.DataFrame(rows)

    # plans and doses
    t0 = time.perf_counter()
    spec = point_spec or DosePointSpec()
    std_points = list(applicator_dose_points(app, spec))
    tps_points = []
    if rtplan is not None:
        tps_points = [
            DosePoint(p.name, np.asarray(p.position_mm, dtype=float), "tps", p.tps_dose_gy)
            for p in getattr(rtplan, "points", ())
        ]
    all_points = std_points + tps_points
    xyz = points_array_mm(all_points)
    tandem = _tandem_dwells(app, tandem_dwells, plan_step_mm)
    ring_ref = DwellSet("ring", rel[in_plan], ref_pos[in_plan], ref_dir[in_plan])
    sets = [ring_ref] + ([tandem] if tandem is not None else [])
    ref_plan = standard_plan(
        sets, points_array_mm(std_points[:2]), src, prescription_gy=prescription_gy, sk_U=sk_U,
        name=ref_kind,
    )  # fmt: skip
    n_t = 0 if tandem is None else len(tandem.relative_position_mm)

    def _with_tandem(p_ring, d_ring):
        if tandem is None:
            return p_ring, d_ring
        return (np.vstack([p_ring, tandem.positions_mm]), np.vstack([d_ring, tandem.directions]))

    plans = {ref_kind: ref_plan}
    plans["simulated"] = ref_plan.transfer(*_with_tandem(sim_pos[in_plan], sim_dir[in_plan]),
                                           "simulated")  # fmt: skip
    if ref_kind == "measured":
        plans["centreline"] = ref_plan.transfer(
            *_with_tandem(cl_pos[in_plan], cl_dir[in_plan]), "centreline"
        )
    doses_ref = ref_plan.dose_gy(xyz)
    dose_rows = []
    for pname, plan in plans.items():
        d = doses_ref if pname == ref_kind else plan.dose_gy(xyz)
        diff = relative_difference_pct(d, doses_ref)
        for k, pt in enumerate(all_points):
            dose_rows.append(
                {
                    "applicator": app.name,
                    "point": pt.name,
                    "kind": pt.kind,
                    "plan": pname,
                    "dose_gy": d[k],
                    "diff_pct": diff[k],
                    "x_mm": pt.position_mm[0],
                    "y_mm": pt.position_mm[1],
                    "z_mm": pt.position_mm[2],
                    "tps_dose_gy": np.nan if pt.tps_dose_gy is None else pt.tps_dose_gy,
                }
            )
    doses = pd.DataFrame(dose_rows)
    if rtplan is not None:
        own, own_notes = _rtplan_own_doses(rtplan, app, src, float(rtplan.source.sk_U or sk_U))
        notes += own_notes
        if not own.empty:
            own.insert(0, "applicator", app.name)
            doses = pd.concat([doses, own], ignore_index=True)
    plan_rows = []
    for pname, plan in plans.items():
        for j in range(plan.n_dwells):
            plan_rows.append(
                {
                    "applicator": app.name,
                    "plan": pname,
                    "channel": plan.channels[j],
                    "relative_position_mm": plan.relative_position_mm[j],
                    "x_mm": plan.positions_mm[j, 0],
                    "y_mm": plan.positions_mm[j, 1],
                    "z_mm": plan.positions_mm[j, 2],
                    "dir_x": plan.directions[j, 0],
                    "dir_y": plan.directions[j, 1],
                    "dir_z": plan.directions[j, 2],
                    "time_s": plan.times_s[j],
                }
            )
    plan_dwells = pd.DataFrame(plan_rows)
    timings["dose_s"] = time.perf_counter() - t0
    if tandem is not None:
        notes.append(
            f"The standard plan includes {n_t} tandem dwells ({plan_step_mm:g} mm apart); the "
            "tandem is not simulated, so its dwells are the same in all plans."
        )

    # verdicts and summary
    verdicts = []
    if ref_kind == "measured":
        verdicts.append(_position_verdict("position: centreline vs measured", comp_cl["dist_mm"],
                                          rec, req))  # fmt: skip
        verdicts.append(_position_verdict("position: simulated vs measured", comp_sim["dist_mm"],
                                          rec, req))  # fmt: skip
    else:
        verdicts.append(_position_verdict("position: simulated vs centreline",
                                          comp_sim["dist_mm"], rec, req))  # fmt: skip
    std = doses[doses["kind"] != "tps"]
    for pname in plans:
        if pname == ref_kind:
            continue
        sub = std[std["plan"] == pname]
        verdicts.append(
            _dose_verdict(f"dose: {pname} vs {ref_kind} plan", sub["diff_pct"].to_numpy(),
                          float(dose_action_pct))
        )  # fmt: skip
    notes += _verdict_meanings(verdicts, ref_kind)

    def _maxabs(a):
        return float(np.max(np.abs(a))) if np.size(a) else float("nan")

    summary = {
        "applicator": app.name,
        "reference": ref_kind,
        "source": src.name,
        "n_dwells": int(rel.size),
        "n_plan_dwells_ring": int(in_plan.sum()),
        "n_plan_dwells_tandem": int(n_t),
        "s_ref_mm": float(s_ref_mm),
        "median_dist_sim_mm": float(np.median(comp_sim["dist_mm"])),
        "max_dist_sim_mm": float(np.max(comp_sim["dist_mm"])),
        "max_along_sim_mm": _maxabs(comp_sim["along_mm"]),
        "max_radial_sim_mm": _maxabs(comp_sim["radial_mm"]),
        "max_out_of_plane_sim_mm": _maxabs(comp_sim["out_of_plane_mm"]),
        "max_angle_sim_deg": float(np.max(ang_sim)),
        "max_angle_sim_vs_centreline_deg": float(np.max(ang_sim_cl)),
    }
    if ref_kind == "measured":
        summary.update(
            {
                "median_dist_centreline_mm": float(np.median(comp_cl["dist_mm"])),
                "max_dist_centreline_mm": float(np.max(comp_cl["dist_mm"])),
                "max_along_centreline_mm": _maxabs(comp_cl["along_mm"]),
                "max_radial_centreline_mm": _maxabs(comp_cl["radial_mm"]),
                "max_out_of_plane_centreline_mm": _maxabs(comp_cl["out_of_plane_mm"]),
                "max_angle_centreline_deg": float(np.max(ang_cl)),
            }
        )
    for pname in plans:
        if pname == ref_kind:
            continue
        sub = std[std["plan"] == pname]
        for kind_ in ("point_a", "surface", "depth5"):
            summary[f"max_abs_diff_{kind_}_{pname}_pct"] = _maxabs(
                sub.loc[sub["kind"] == kind_, "diff_pct"].to_numpy()
            )
    a_ref = std[(std["plan"] == ref_kind) & (std["kind"] == "point_a")]["dose_gy"]
    summary["point_a_mean_gy"] = float(a_ref.mean())
    summary["simulation_status"] = sim_info["status"]
    summary["solve_time_s"] = sim_info["solve_time_s"]
    summary["verdict"] = (
        "FAIL" if any(v.status in ("FAIL", "ACTION") for v in verdicts)
        else "WARN" if any(v.status == "WARN" for v in verdicts) else "PASS"
    )  # fmt: skip

    geometry = {
        "ring_centre_mm": centre.tolist(),
        "ring_normal": np.asarray(app.ring_normal, dtype=float).tolist(),
        "ring_lateral": np.asarray(app.ring_lateral, dtype=float).tolist(),
        "ring_radius_mm": m_to_mm(float(app.ring_radius_m)),
        "s_ref_mm": float(s_ref_mm),
        "centrelines_mm": {c.name: _dense_centreline_mm(c) for c in app.channels},
        "metadata": dict(getattr(app, "metadata", {}) or {}),
    }
    settings = {
        "source": src.name,
        "sk_U": float(sk_U),
        "prescription_gy": float(prescription_gy),
        "cable": cable,
        "channel": channel,
        "plan_step_mm": float(plan_step_mm),
        "tandem_dwells": int(tandem_dwells),
        "position_limits_mm": [rec, req],
        "dose_action_pct": float(dose_action_pct),
        "dose_points": spec.as_dict(),
        "scene_overrides": dict(scene_overrides or {}),
        "scene": scene_dict,
    }
    prov = Provenance.now(inputs=input_files, settings=settings)
    timings["total_s"] = time.perf_counter() - t_start
    return CommissioningResult(
        applicator=app.name,
        input=str(input) if isinstance(input, str | Path) else app.name,
        input_kind=kind,
        reference=ref_kind,
        dwells=dwells,
        doses=doses,
        plan_dwells=plan_dwells,
        summary=summary,
        verdicts=tuple(verdicts),
        geometry=geometry,
        simulation=sim_info,
        settings=settings,
        notes=tuple(notes),
        provenance=prov,
        timings_s=timings,
    )


def _dense_centreline_mm(channel, spacing_mm: float = 0.5) -> list:
    length_mm = m_to_mm(float(channel.centreline.length_m))
    s = np.linspace(0.0, length_mm, max(2, int(length_mm / spacing_mm) + 1))
    return m_to_mm(np.asarray(channel.centreline.position(mm_to_m(s)), dtype=float)).tolist()
