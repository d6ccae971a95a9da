"""The simulated source positions at the dwells: one run of the source-cable engine.

The cable is pushed to the advances ``s_ref - p`` of the reference dwells; a lumen narrower than
the cable is refused first, a run that fails to converge is repeated with a finer input
increment, and a jam is reported as :class:`SimulationJammedError` with where it stopped.

The engine is reached through an :class:`Engine` (its four functions), so tests and other engines
can stand in for :mod:`ringqa.simulation`: :func:`default_engine` is the real one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.errors import RingQAError, SimulationError
from ringqa.pipeline.dwells import PathDwells
from ringqa.pipeline.result import SimulationInfo
from ringqa.units import m_to_mm

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
class Engine:
    """The four engine functions the pipeline calls (:func:`default_engine`: ringqa's own).

    Attributes
    ----------
    simulate : callable
        ``simulate(scene, advances_mm=(n,) mm, progress=bool)`` -> a result with ``status``
        (0 ok, 1 jammed, -1 failed), ``message``, ``advances_mm`` (n,), ``source_pos_m`` (n, 3)
        and ``source_dir`` (n, 3); optionally ``warnings``, ``solve_time_s``, ``n_elements``,
        ``settings``.
    scene_for_channel : callable
        ``scene_for_channel(channel, cable)`` -> a scene (with ``instrument.sections[].r_o_m``,
        ``motion``, ``solver.increment_m``, ``instrument.afterloader`` where it has them).
    scene_with_overrides : callable
        ``scene_with_overrides(scene, {dotted key: value})`` -> a new scene.
    scene_to_dict : callable
        ``scene_to_dict(scene)`` -> the scene in user units (for provenance).
    """

    simulate: Callable[..., Any]
    scene_for_channel: Callable[..., Any]
    scene_with_overrides: Callable[[Any, Mapping[str, Any]], Any]
    scene_to_dict: Callable[[Any], dict]


def default_engine() -> Engine:
    """ringqa's engine: :func:`ringqa.simulation.simulate` and the scene functions of
    :mod:`ringqa.simulation.scenefile` (imported on first use: importing the pipeline stays
    light)."""
    from ringqa.simulation import simulate
    from ringqa.simulation.scenefile import scene_for_channel, scene_to_dict, scene_with_overrides

    return Engine(simulate, scene_for_channel, scene_with_overrides, scene_to_dict)


@dataclass(frozen=True, eq=False)
class SimulatedDwells:
    """The engine's source positions at the reference dwells, and how the run went.

    Attributes
    ----------
    dwells : PathDwells
        Source centres (n, 3) in mm and unit directions (n, 3), in the reference's order.
    info : SimulationInfo
    scene : dict
        The scene simulated, in user units (empty if it could not be written).
    afterloader : str
        The afterloader whose cable was simulated.
    notes : tuple of str
        For the report (a retry with a finer increment).
    """

    dwells: PathDwells
    info: SimulationInfo
    scene: dict
    afterloader: str
    notes: tuple[str, ...]


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


def _run_engine(simulate, scene, advances, progress: bool = False):
    res = simulate(scene, advances_mm=advances, progress=progress)
    status = int(getattr(res, "status", 0))
    pos_m = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
    ok = status == 0 and pos_m.shape[0] >= advances.size and bool(np.all(np.isfinite(pos_m)))
    return res, status, pos_m, ok


def simulate_dwells(
    app,
    channel,
    relative_position_mm,
    *,
    cable: str,
    scene_overrides: Mapping[str, Any],
    engine: Engine | None = None,
    progress: bool = False,
) -> SimulatedDwells:
    """Simulate the cable to the dwells at ``relative_position_mm`` (results in their order).

    Parameters
    ----------
    app : Applicator
    channel : Channel
        The channel simulated.
    relative_position_mm : (n,) array_like
        Relative positions p of the dwells, mm: the cable is pushed to the advances s_ref - p.
    cable : str
        Instrument preset.
    scene_overrides : mapping
        Dotted scene keys -> values (user units).
    engine : Engine, optional
        Default :func:`default_engine`.
    progress : bool
        Show the engine's progress bar.

    Returns
    -------
    SimulatedDwells

    Raises
    ------
    RingQAError
        The lumen is not wider than the cable.
    SimulationJammedError
        The cable jammed, or the engine failed even with a finer increment.
    """
    engine = engine or default_engine()
    rel_mm = relative_position_mm
    notes: list[str] = []
    scene = engine.scene_for_channel(channel, cable)
    if scene_overrides:
        scene = engine.scene_with_overrides(scene, dict(scene_overrides))
    _check_clearance(app, channel, scene)
    simulate = engine.simulate
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel_sorted = np.sort(np.unique(np.round(np.asarray(rel_mm, dtype=float), 9)))[::-1]
    advances = s_ref_mm - rel_sorted  # increasing: the cable is pushed in, proximal -> distal
    motion = getattr(scene, "motion", None)
    if getattr(motion, "backward", False) or getattr(motion, "kind", "") == "retract":
        advances = advances[::-1]  # backward stepping / retraction: most distal dwell first
    t0 = time.perf_counter()
    res, status, pos_m, ok = _run_engine(simulate, scene, advances, progress)
    inc_m = getattr(getattr(scene, "solver", None), "increment_m", None)
    if not ok and status == -1 and inc_m:
        first_message = str(getattr(res, "message", ""))
        for factor in RETRY_INCREMENT_FACTORS:
            inc_mm = m_to_mm(float(inc_m)) * factor
            retry = engine.scene_with_overrides(scene, {"solver.increment_mm": inc_mm})
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
    info = SimulationInfo(
        status=status,
        message=str(getattr(res, "message", "")),
        warnings=tuple(str(w) for w in getattr(res, "warnings", ())),
        solve_time_s=float(getattr(res, "solve_time_s", wall)),
        wall_time_s=wall,
        n_elements=int(getattr(res, "n_elements", 0) or 0),
        settings=dict(getattr(res, "settings", {}) or {}),
    )
    try:
        scene_dict = engine.scene_to_dict(scene)
    except Exception:  # provenance must not break a run
        scene_dict = {}
    afterloader = getattr(getattr(scene, "instrument", None), "afterloader", "") or cable
    return SimulatedDwells(
        dwells=PathDwells(m_to_mm(pos_m[idx]), d / np.linalg.norm(d, axis=1)[:, None]),
        info=info,
        scene=scene_dict,
        afterloader=afterloader,
        notes=tuple(notes),
    )


def simulation_notes(info: SimulationInfo, source, afterloader: str) -> list[str]:
    """The report's notes on a run: the engine's warnings, and a cable from another afterloader.

    Parameters
    ----------
    info : SimulationInfo
        The run (from :func:`simulate_dwells`).
    source : tg43.Source
        The plan's TG-43 source.
    afterloader : str
        The afterloader whose cable was simulated.
    """
    notes = []
    if info.warnings:
        notes.append("Simulation warnings: " + "; ".join(info.warnings))
    src_afterloader = SOURCE_AFTERLOADER.get(getattr(source, "name", ""), "")
    if src_afterloader and afterloader and src_afterloader != afterloader:
        notes.append(
            f"The cable model is the {afterloader} cable (the only published cable data), while "
            f"the source ({source.name}) belongs to a {src_afterloader} afterloader: the simulated "
            "positions assume the Flexitron cable's mechanics."
        )
    return notes
