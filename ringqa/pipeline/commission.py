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

The steps live in one module each: :mod:`~ringqa.pipeline.inputs` (what was given, checked),
:mod:`~ringqa.pipeline.dwells` (reference, centreline and tandem dwells),
:mod:`~ringqa.pipeline.simulate` (the engine run), :mod:`~ringqa.pipeline.deviations`
(distances and angles), :mod:`~ringqa.pipeline.doses` (plans and doses),
:mod:`~ringqa.pipeline.verdicts` and :mod:`~ringqa.pipeline.summary`; the results are the
dataclasses of :mod:`~ringqa.pipeline.result`. This module runs them in order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from pathlib import Path

from ringqa.pipeline.deviations import _deviations, _dwell_table, angle_deg, deviation_components
from ringqa.pipeline.doses import (
    _dose_points,
    _dose_table,
    _plan_table,
    _standard_plans,
    _with_rtplan_doses,
)
from ringqa.pipeline.dwells import (
    TANDEM_DWELLS,
    _centreline_dwells,
    _geometry,
    _plan_subset,
    _reference,
    _reference_note,
    _tandem_dwells,
)
from ringqa.pipeline.inputs import (
    _channel,
    _check_measured_path,
    _checked_limits,
    _load_input,
    _loaded_text,
    _source_for,
)
from ringqa.pipeline.result import CommissioningResult, Verdict
from ringqa.pipeline.simulate import (
    RETRY_INCREMENT_FACTORS,
    SOURCE_AFTERLOADER,
    SimulationJammedError,
    _simulate,
    _simulation_notes,
)
from ringqa.pipeline.summary import _summary
from ringqa.pipeline.verdicts import (
    DOSE_ACTION_PCT,
    POSITION_RECOMMENDED_MM,
    POSITION_REQUIRED_MM,
    _verdict_meanings,
    _verdicts,
)
from ringqa.plan import PLAN_STEP_MM, PRESCRIPTION_GY, DosePointSpec
from ringqa.provenance import Provenance

__all__ = [
    "DOSE_ACTION_PCT",
    "POSITION_RECOMMENDED_MM",
    "POSITION_REQUIRED_MM",
    "RETRY_INCREMENT_FACTORS",
    "SOURCE_AFTERLOADER",
    "TANDEM_DWELLS",
    "CommissioningResult",
    "SimulationJammedError",
    "Verdict",
    "angle_deg",
    "commission",
    "deviation_components",
]


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
    rec, req = _checked_limits(prescription_gy, position_limits_mm, dose_action_pct)
    app, rtplan, kind, input_files = _load_input(input)
    timings["load_s"] = time.perf_counter() - t_start
    ring = _channel(app, channel)
    _check_measured_path(input, ring, channel, kind, require_measured)
    src = _source_for(source, rtplan, notes)
    if sk_U is None:
        sk_U = float(getattr(getattr(rtplan, "source", None), "sk_U", 0.0) or 40820.0)

    # reference dwells and the plan's 5 mm subset
    ref_kind, rel, ref_pos, ref_dir, ref_step = _reference(app, ring, plan_step_mm)
    in_plan, s_ref_mm = _plan_subset(app, ring, rel, ref_step, plan_step_mm)
    notes.append(_loaded_text(app, ring, kind))
    notes.append(_reference_note(ref_kind, rel, ref_step))

    # simulation and centreline dwells
    t0 = time.perf_counter()
    sim_pos, sim_dir, sim_info, scene_dict, afterloader = _simulate(
        app, ring, rel, cable=cable, scene_overrides=scene_overrides, simulator=simulator,
        scene_factory=scene_factory, notes=notes, progress=progress,
    )  # fmt: skip
    timings["simulation_s"] = time.perf_counter() - t0
    cl_pos, cl_dir = _centreline_dwells(ring, rel)
    notes += _simulation_notes(sim_info, src, afterloader)

    # distances
    ref, simulated, centreline = (ref_pos, ref_dir), (sim_pos, sim_dir), (cl_pos, cl_dir)
    dev = _deviations(app, ref, simulated, centreline)
    dwells = _dwell_table(app.name, rel, in_plan, ref_kind, ref, simulated, centreline, dev)

    # plans and doses
    t0 = time.perf_counter()
    spec = point_spec or DosePointSpec()
    std_points, all_points = _dose_points(app, rtplan, spec)
    tandem = _tandem_dwells(app, tandem_dwells, plan_step_mm)
    plans = _standard_plans(
        ref_kind, rel, in_plan, ref, simulated, centreline, tandem, std_points, src,
        prescription_gy=prescription_gy, sk_U=sk_U,
    )  # fmt: skip
    n_t = 0 if tandem is None else len(tandem.relative_position_mm)
    doses = _dose_table(app.name, plans, ref_kind, all_points)
    if rtplan is not None:
        doses = _with_rtplan_doses(doses, rtplan, app, src, sk_U, notes)
    plan_dwells = _plan_table(app.name, plans)
    timings["dose_s"] = time.perf_counter() - t0
    if tandem is not None:
        notes.append(
            f"The standard plan includes {n_t} tandem dwells ({plan_step_mm:g} mm apart); the "
            "tandem is not simulated, so its dwells are the same in all plans."
        )

    # verdicts and summary
    verdicts = _verdicts(ref_kind, dev, doses, plans, rec, req, dose_action_pct)
    notes += _verdict_meanings(verdicts, ref_kind)
    summary = _summary(
        app, src, ref_kind, rel, in_plan, n_t, s_ref_mm, dev, doses, plans, sim_info, verdicts
    )

    geometry = _geometry(app, s_ref_mm)
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
