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
5. Distances per dwell to the reference (3D, and split into along-channel, radial and
   out-of-plane parts in the applicator frame) and angles between source directions.
6. Standard plan on the reference dwells every 5 mm (+ the tandem where the applicator has one,
   identical in all three plans), equal times scaled to the prescription at Point A; the times are
   transferred unchanged to the simulated and centreline dwells; TG-43 doses at the dose points.
7. Verdicts: 1 mm recommended / 2 mm required on position, a dose action level (default 5 %).

The steps live in one module each, as public functions exchanging the frozen dataclasses named
below: :mod:`~ringqa.pipeline.inputs` (``load_input -> LoadedInput``, ``choose_source ->
SourceChoice``), :mod:`~ringqa.pipeline.dwells` (``reference_dwells -> ReferenceDwells``,
``plan_selection -> PlanSelection``, ``centreline_dwells -> PathDwells``),
:mod:`~ringqa.pipeline.simulate` (``simulate_dwells -> SimulatedDwells``, through an
:class:`Engine`), :mod:`~ringqa.pipeline.deviations` (``compare_with_reference -> Deviations``),
:mod:`~ringqa.pipeline.doses` (``standard_plans -> StandardPlans``, ``dose_tables ->
DoseTables``), :mod:`~ringqa.pipeline.verdicts` and :mod:`~ringqa.pipeline.summary`. The
settings are one :class:`~ringqa.pipeline.settings.CommissionSettings`; the result is the typed
:class:`~ringqa.pipeline.result.CommissioningResult`. This module runs the steps in order.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringqa.errors import RingQAError, named_warning, split_warning
from ringqa.geometry.families import family_name_of
from ringqa.geometry.frame import frame_of
from ringqa.pipeline.deviations import (
    DwellColumns,
    centreline_offsets,
    compare_with_reference,
    deviation_components,
    dwell_table,
)
from ringqa.pipeline.doses import dose_points, dose_tables, standard_plans
from ringqa.pipeline.dwells import (
    centreline_dwells,
    plan_selection,
    reference_dwells,
    reference_note,
    ring_arc_mm,
    ring_geometry,
    tandem_dwells,
)
from ringqa.pipeline.inputs import (
    channel_of,
    check_measured_path,
    choose_source,
    kink_notes,
    load_input,
    loaded_text,
)
from ringqa.pipeline.measured_points import (
    attach_measured,
    centreline_grid,
    compare_measured_points,
    has_dense_path,
    is_sparse,
)
from ringqa.pipeline.reference import review_reference
from ringqa.pipeline.result import CommissioningResult, RunSettings, Timings
from ringqa.pipeline.settings import CommissionSettings
from ringqa.pipeline.simulate import (
    NUMERICAL_ERROR_WARN_MM,
    WORK_BALANCE_WARNING,
    Engine,
    check_clearance,
    choose_cable,
    instrument_radii_m,
    simulate_dwells,
    simulation_notes,
)
from ringqa.pipeline.summary import summarise
from ringqa.pipeline.verdicts import (
    CHECK_TPS,
    check_tolerances,
    conclusion,
    verdict_meanings,
)
from ringqa.provenance import Provenance, display_path, tg43_data_files
from ringqa.units import m_to_mm

__all__ = [
    "ChannelChoice",
    "ChannelRuns",
    "channel_choice",
    "channel_label",
    "commission",
    "commission_channels",
    "default_channels",
    "load_commission_input",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class ChannelRuns:
    """Every channel of one input commissioned (:func:`commission_channels`).

    Attributes
    ----------
    results : tuple of CommissioningResult
        One per channel simulated, in the applicator's channel order.
    not_simulated : tuple of str
        One sentence per channel that has dwells in the plan but no centreline (never silently
        dropped: the report and the command line say it).
    """

    results: tuple[CommissioningResult, ...]
    not_simulated: tuple[str, ...] = ()

    @property
    def passed(self) -> bool:
        """Every channel passed (and none was left unsimulated)."""
        return not self.not_simulated and all(r.passed for r in self.results)


def default_channels(app) -> tuple[str, ...]:
    """The channels commissioned when none is named: a ring applicator's ring channel (its
    tandem is the ring set's straight tandem: its dwells are the same in every plan, as
    before); any other applicator's every channel."""
    names = tuple(c.name for c in app.channels)
    if getattr(app, "family", "ring") == "ring" and "ring" in names:
        return ("ring",)
    return names


@dataclass(frozen=True)
class ChannelChoice:
    """The channels a run commissions when none is named (:func:`channel_choice`).

    Attributes
    ----------
    names : tuple of str
        The applicator's channel names to commission, in the applicator's order.
    skipped : tuple of str
        One sentence per channel with dwells that is NOT commissioned, and why (no reference
        source path where one is required); the channels without a centreline are
        :func:`unsimulated_channels`.
    """

    names: tuple[str, ...]
    skipped: tuple[str, ...] = ()


def _needs_reference(kind: str, require_measured) -> bool:
    """A channel of an input of ``kind`` must have a reference (measured) source path
    (:func:`~ringqa.pipeline.inputs.check_measured_path`'s rule)."""
    if require_measured is None:
        return kind in ("folder", "file", "rtplan", "rtplan+rtstruct")
    return bool(require_measured)


def channel_choice(loaded, require_measured=None) -> ChannelChoice:
    """The channels commissioned by default (issue 30): for an RT Plan, every plan channel with
    dwells that has a centreline in the applicator (the plan's own channels: the example's ring
    AND its tandem); without a plan, :func:`default_channels`. A channel without a reference
    source path where one is required (user files, unless ``require_measured`` is False: the
    command line's ``--centreline-reference``) is not commissioned but named in ``skipped``,
    never dropped.

    Parameters
    ----------
    loaded : LoadedInput
    require_measured : bool or None
        As :attr:`CommissionSettings.require_measured`.

    Returns
    -------
    ChannelChoice
    """
    app = loaded.applicator
    plan = getattr(loaded, "rtplan", None)
    with_dwells = {
        str(ch.number): ch
        for ch in (getattr(plan, "channels", ()) or ())
        if len(np.asarray(ch.positions_mm).reshape(-1, 3))
    }
    candidates = [c for c in app.channels if str(getattr(c, "label", "")) in with_dwells]
    if not candidates:
        return ChannelChoice(default_channels(app))
    needs = _needs_reference(loaded.kind, require_measured)
    names, skipped = [], []
    for c in candidates:
        if needs and getattr(c, "measured_path_m", None) is None:
            ch = with_dwells[str(c.label)]
            skipped.append(
                f"Channel {c.label} ({ch.name or c.name}) has "
                f"{len(np.asarray(ch.positions_mm).reshape(-1, 3))} dwells and a centreline but "
                "no reference source path: NOT COMMISSIONED (--centreline-reference compares it "
                f"with its centreline; --channel {c.label} names it)."
            )
        else:
            names.append(c.name)
    return ChannelChoice(tuple(names), tuple(skipped))


def channel_label(channel) -> str:
    """The ``channel`` column's value: the plan's channel number (``Channel.label``), else the
    channel's name."""
    return str(getattr(channel, "label", "") or channel.name)


def _channel_name(app, wanted: str) -> str:
    """``wanted`` when the applicator has it (or when it is a ring applicator: the error names
    its channels), else a channel label naming one, else the first default channel when
    ``wanted`` is the default ``"ring"``."""
    names = [c.name for c in app.channels]
    if wanted in names:
        return wanted
    for c in app.channels:
        if getattr(c, "label", "") == wanted:
            return c.name
    if wanted == "ring" and getattr(app, "family", "ring") != "ring":
        return default_channels(app)[0]
    return wanted


def commission_channels(
    input,
    settings: CommissionSettings | None = None,
    *,
    channels=None,
    engine: Engine | None = None,
    progress: bool = False,
) -> ChannelRuns:
    """Commission every channel of ``input`` (or those named), each with its own simulation,
    comparison and numerical error.

    Parameters
    ----------
    input : str, pathlib.Path or Applicator
        As :func:`commission`.
    settings : CommissionSettings, optional
        ``settings.channel`` is ignored: ``channels`` names them.
    channels : sequence of str, optional
        Channel names or plan channel numbers (default :func:`default_channels`).
    engine, progress
        As :func:`commission`.

    Returns
    -------
    ChannelRuns

    Raises
    ------
    RingQAError
        A named channel the applicator does not have; the errors of :func:`commission`.
    """
    import dataclasses

    cfg = CommissionSettings() if settings is None else settings
    t_start = time.perf_counter()
    loaded = _load(input, cfg)
    load_s = time.perf_counter() - t_start
    app = loaded.applicator
    skipped: tuple[str, ...] = ()
    if channels:
        wanted = tuple(str(c) for c in channels)
    else:
        choice = channel_choice(loaded, cfg.require_measured)
        wanted, skipped = choice.names or default_channels(app), choice.skipped
    names = tuple(dict.fromkeys(_channel_name(app, w) for w in wanted))
    for n in names:
        channel_of(app, n)  # refuses an unknown channel, naming those there are
    if cfg.measured is not None and len(names) > 1:
        raise RingQAError(
            f"--measured {cfg.measured}: {len(names)} channels ({', '.join(names)}) are "
            "commissioned; a measured path belongs to one: name it with --channel"
        )
    results = tuple(
        _commission_loaded(input, loaded, dataclasses.replace(cfg, channel=n), engine=engine,
                           progress=progress, t_start=time.perf_counter(), load_s=load_s)
        for n in names
    )  # fmt: skip
    return ChannelRuns(results, (*unsimulated_channels(loaded), *skipped))


def load_commission_input(input, settings: CommissionSettings | None = None):
    """``input`` loaded as :func:`commission` loads it (:func:`load_input` with the settings'
    structure set and lumen); hand it back as ``commission(..., loaded=)``."""
    return _load(input, CommissionSettings() if settings is None else settings)


def _load(input, cfg):
    """:func:`load_input` of ``input`` (with the settings' structure set and lumen)."""
    if cfg.structures is None and cfg.lumen_mm is None:
        return load_input(input)
    return load_input(input, cfg.structures, cfg.lumen_mm)


def unsimulated_channels(loaded) -> tuple[str, ...]:
    """One sentence per RT Plan channel with dwells but no centreline in the applicator."""
    plan = getattr(loaded, "rtplan", None)
    if plan is None or not hasattr(plan, "channels"):
        return ()
    labels = {getattr(c, "label", "") for c in loaded.applicator.channels}
    out = []
    for ch in getattr(plan, "channels", ()) or ():
        n = len(np.asarray(ch.positions_mm).reshape(-1, 3))
        if n and str(ch.number) not in labels:
            out.append(
                f"Channel {ch.number} ({ch.name or 'unnamed'}) has {n} dwells but no centreline "
                "(not in the applicator library or the structure set): NOT SIMULATED."
            )
    return tuple(out)


def commission(
    input,
    settings: CommissionSettings | None = None,
    *,
    engine: Engine | None = None,
    progress: bool = False,
    loaded=None,
    load_s: float = 0.0,
) -> CommissioningResult:
    """Commission one channel of an applicator (see the module docstring for the steps):
    ``settings.channel`` (a name or a plan channel number; the default ``"ring"`` means the
    first of :func:`default_channels` for an applicator of another family).

    Parameters
    ----------
    input : str, pathlib.Path or Applicator
        A shipped applicator name (``"ring26x60"``), a folder of CSV/JSON files, an applicator
        JSON file, an RT Plan (``.dcm``) with Oncentra's applicator library, or an Applicator.
    settings : CommissionSettings, optional
        Plan, tolerances, source and scene settings (default: the command line's defaults).
    engine : Engine, optional
        The simulation engine (default :func:`~ringqa.pipeline.simulate.default_engine`; tests
        and other engines give their own).
    progress : bool
        Show the engine's progress bar (tqdm, on stderr).
    loaded : LoadedInput, optional
        ``input`` already loaded (:func:`~ringqa.pipeline.inputs.load_input` with the settings'
        structure set and lumen; e.g. when the command line has chosen its channels from it);
        ``load_s``: the seconds that took (the result's ``timings``).

    Returns
    -------
    CommissioningResult

    Raises
    ------
    RingQAError
        Unreadable input, missing ring frame or channel, lumen narrower than the cable, a jammed
        simulation (:class:`~ringqa.pipeline.simulate.SimulationJammedError`).
    """
    import dataclasses

    cfg = CommissionSettings() if settings is None else settings
    t_start = time.perf_counter() - (0.0 if loaded is None else load_s)  # total_s counts it
    if loaded is None:
        loaded = _load(input, cfg)
        load_s = time.perf_counter() - t_start
    others: tuple[str, ...] = ()
    if cfg.channel == "ring":  # no channel named: the default choice's first channel
        choice = channel_choice(loaded, cfg.require_measured)
        if choice.names and "ring" not in choice.names:
            cfg = dataclasses.replace(cfg, channel=choice.names[0])
        others = choice.skipped
    name = _channel_name(loaded.applicator, cfg.channel)
    if name != cfg.channel:
        cfg = dataclasses.replace(cfg, channel=name)
    return _commission_loaded(input, loaded, cfg, engine=engine, progress=progress,
                              t_start=t_start, load_s=load_s, others=others)  # fmt: skip


def _commission_loaded(input, loaded, cfg, *, engine, progress, t_start, load_s, others=()):
    """:func:`commission` of an input already loaded, for the channel ``cfg.channel``;
    ``others``: sentences on the plan's channels this run leaves out (named warnings
    ``plan.channel_not_commissioned``)."""
    app = loaded.applicator
    shown = display_path(input) if isinstance(input, str | Path) else input  # no install path
    log.info("%s: loaded %s (%s) in %.2f s", shown, app.name, loaded.kind, load_s)
    files = loaded.files
    correction_notes: tuple[str, ...] = ()
    if cfg.centreline_correction is not None:
        from ringqa.io.correction import apply_centreline_correction

        channel_of(app, cfg.channel)  # names the channels when it is missing
        correction = apply_centreline_correction(app, cfg.centreline_correction, cfg.channel)
        app = correction.applicator
        files = (*files, Path(correction.path))
        correction_notes = (correction_note(correction),)
    ring = channel_of(app, cfg.channel)
    own = (app, ring)  # the input's own channel (a library path that can carry the plan)
    if cfg.measured is not None:  # --measured FILE: the clinic's path in place of the input's
        attached = attach_measured(app, ring, cfg.measured)
        app, ring = attached.applicator, attached.channel
        files = (*files, Path(cfg.measured))
    check_measured_path(input, ring, cfg.channel, loaded.kind, cfg.require_measured)
    src = choose_source(cfg.source, cfg.sk_U, loaded.rtplan)
    cable = choose_cable(cfg.cable, src.source.name)
    capsule_r_m, cable_r_m = instrument_radii_m(engine, ring, cable.preset)
    check_clearance(app, ring, cable_r_m)
    reference = reference_dwells(app, ring, cfg.plan_step_mm)
    sparse = None  # a measured subset: compared at its own positions (pipeline.measured_points)
    plan_path = ""
    sparse_ring = ring
    if is_sparse(reference, cfg.plan_step_mm):
        sparse = (reference, review_reference(app, ring, reference, cfg.register, capsule_r_m))
        if cfg.measured is not None and has_dense_path(*own, cfg.plan_step_mm):
            app, ring = own  # the plan on the input's own (vendor/library) path
            reference = reference_dwells(app, ring, cfg.plan_step_mm)
            plan_path = "library"
        else:
            reference = centreline_grid(app, ring, cfg.plan_step_mm)
            plan_path = "simulated"
    review = review_reference(app, ring, reference, cfg.register, capsule_r_m)
    compared_ref = review.registered
    registered = compared_ref.dwells if cfg.register != "none" and reference.kind == "measured" \
        else None  # fmt: skip
    selection = plan_selection(app, ring, reference, cfg.plan_step_mm, review.compared)

    log.info(
        "%s: simulating the %s cable at %d positions (%s reference)",
        app.name, cable.preset, len(reference.relative_position_mm), reference.kind,
    )  # fmt: skip
    t0 = time.perf_counter()
    simulated = simulate_dwells(
        app, ring, reference.relative_position_mm, cable=cable.preset,
        scene_overrides=cfg.scene_overrides, engine=engine, progress=progress,
        stem_mm=cfg.stem_mm,
        cross_check=cfg.cross_check,
    )  # fmt: skip
    simulation_s = time.perf_counter() - t0
    log.info("%s: simulated in %.2f s", app.name, simulation_s)
    rel = reference.relative_position_mm
    centreline = centreline_dwells(ring, rel)
    dev = compare_with_reference(app, compared_ref.dwells, simulated.dwells, centreline)
    dev_raw = compare_with_reference(app, reference.dwells, simulated.dwells, centreline)
    paths = {reference.kind: reference.dwells, "simulated": simulated.dwells,
             "centreline": centreline}  # fmt: skip
    if registered is not None:
        paths["registered"] = registered
    offsets = {name: centreline_offsets(app, ring, p.positions_mm) for name, p in paths.items()}
    supplied = None
    if registered is not None:
        supplied = deviation_components(
            registered.positions_mm, registered.directions, reference.dwells.positions_mm,
            m_to_mm(np.asarray(frame_of(app).centre_m, dtype=float)), frame_of(app).normal,
        )  # fmt: skip
    columns = DwellColumns(review.flags, simulated.numerics.error_mm, offsets, supplied)
    dwells = dwell_table(app.name, reference, registered and compared_ref, selection,
                         simulated.dwells, centreline, dev, dev_raw, columns)  # fmt: skip

    t0 = time.perf_counter()
    points = dose_points(app, loaded.rtplan, cfg.point_spec)
    tandem = (
        None if ring.name == "tandem" else tandem_dwells(app, cfg.tandem_dwells, cfg.plan_step_mm)
    )
    plans = standard_plans(
        reference, registered, selection, simulated.dwells, centreline, tandem, points,
        src.source, prescription_gy=cfg.prescription_gy, sk_U=src.sk_U,
        times_from=simulated.dwells if plan_path == "simulated" else None,
    )  # fmt: skip
    tables = dose_tables(app, loaded.rtplan, plans, points, src.source, src.sk_U, src.sk_given)
    dose_s = time.perf_counter() - t0

    numerics = simulated.numerics
    verdicts = check_tolerances(
        reference.kind, dev, tables.doses, plans, cfg.position_limits_mm, cfg.dose_action_pct,
        relative_position_mm=rel, flags=review.flags, numerical_error_mm=numerics.max_mm,
        numerical_warn_mm=NUMERICAL_ERROR_WARN_MM,
        cross_check=numerics.cross_check,
    )  # fmt: skip
    measured_points = None
    if sparse is not None:
        measured_points = compare_measured_points(
            app, ring, *sparse, cable=cable.preset, scene_overrides=cfg.scene_overrides,
            limits_mm=cfg.position_limits_mm, engine=engine, stem_mm=cfg.stem_mm,
            sd_mm=None if getattr(sparse_ring, "measured_sd_m", None) is None
            else m_to_mm(sparse_ring.measured_sd_m),
            method=getattr(sparse_ring, "measured_method", ""), plan_path=plan_path,
            plan_source=reference.source if plan_path == "library" else "",
        )  # fmt: skip
        verdicts = (*verdicts, measured_points.verdict())
    n_tandem = 0 if tandem is None else len(tandem.relative_position_mm)
    on_ring = rel <= ring_arc_mm(app, ring, 0.5) + 1e-9
    label = channel_label(ring)
    summary = summarise(
        app.name, src.source.name, reference, selection, n_tandem, dev, dev_raw, tables.doses,
        plans, simulated.info, verdicts, review=review, numerical_error_mm=numerics.error_mm,
        offsets=offsets, on_ring=on_ring,
    )  # fmt: skip
    tandem_note = (
        f"The standard plan includes {n_tandem} tandem dwells ({cfg.plan_step_mm:g} mm apart); "
        "the tandem is not simulated, so its dwells are the same in all plans."
    )
    warnings = collect_warnings(loaded, app, cfg, src, cable.preset, verdicts)
    warnings += tuple(named_warning("plan.channel_not_commissioned", t) for t in others)
    warnings += tuple(  # the engine's work balance (issue 25): on the terminal and page 1
        named_warning("simulation.work_balance", w)
        for w in simulated.info.warnings
        if w.startswith(WORK_BALANCE_WARNING)
    )
    notes = (
        *(f"Warning [{n}]: {m}" for n, m in map(split_warning, warnings)),
        *(n for n in src.notes if split_warning(n, "")[0] == ""),
        loaded_text(app, ring, loaded.kind),
        *getattr(loaded, "notes", ()),
        *correction_notes,
        *kink_notes(app, ring),
        *((reference_note(reference),) if plan_path != "simulated" else ()),
        *(() if measured_points is None else measured_points.lines()),
        *simulated.notes,
        *simulation_notes(simulated.info, cable),
        *tables.notes,
        *((tandem_note,) if tandem is not None else ()),
        *verdict_meanings(verdicts),
    )
    used = RunSettings(
        source=src.source.name, sk_U=src.sk_U, prescription_gy=cfg.prescription_gy,
        cable=cable.preset, channel=cfg.channel, register=cfg.register, stem_mm=cfg.stem_mm,
        plan_step_mm=cfg.plan_step_mm, tandem_dwells=cfg.tandem_dwells,
        position_limits_mm=cfg.position_limits_mm, dose_action_pct=cfg.dose_action_pct,
        dose_points=cfg.point_spec, scene_overrides=dict(cfg.scene_overrides),
        scene=simulated.scene,
        centreline_correction=None if cfg.centreline_correction is None
        else str(cfg.centreline_correction),
        calibration=None if cfg.calibration is None else dict(cfg.calibration),
        cross_check=cfg.cross_check,
    )  # fmt: skip
    if cfg.calibration is not None and cfg.calibration.get("file"):
        if Path(cfg.calibration["file"]).is_file():  # its SHA-256 in the provenance too
            files = (*files, Path(cfg.calibration["file"]))
    folder = getattr(src.source, "folder", None)
    provenance = Provenance.now(
        inputs=files, settings=used.as_dict(),
        data=tg43_data_files(folder) if folder is not None else (),
    )  # fmt: skip
    return CommissioningResult(
        applicator=app.name,
        input=str(input) if isinstance(input, str | Path) else app.name,
        input_kind=loaded.kind,
        reference=reference.kind,
        dwells=dwells,
        doses=tables.doses,
        plan_dwells=tables.plan_dwells,
        summary=summary,
        verdicts=verdicts,
        geometry=ring_geometry(app, selection.s_ref_mm),
        simulation=simulated.info,
        settings=used,
        notes=notes,
        provenance=provenance,
        timings=Timings(load_s, simulation_s, dose_s, time.perf_counter() - t_start),
        reference_check=review,
        numerics=numerics,
        conclusion=conclusion(verdicts),
        settings_origin=dict(cfg.settings_origin),
        warnings=warnings,
        channel=label,
        measured_points=None if measured_points is None else measured_points.as_dict(),
        family=family_name_of(app, ring),
        frame_family=str(getattr(app, "family", "ring") or "ring"),
    )


def collect_warnings(loaded, app, cfg, src, preset: str, verdicts) -> tuple[str, ...]:
    """Every named warning of the input stages (:func:`ringqa.errors.named_warning` strings):
    the RT Plan reader's (``plan.*``; unnamed ones ``plan.reader``), the input files' notes
    (``csv.encoding``, ``input.note``), the source choice (``plan.source_model``), bends the
    source capsule cannot pass (``channel.tight_bend``), plan channels with dwells but no
    centreline (``plan.channel_not_simulated``) and a plan whose own dwells miss the TPS doses
    (``plan.tps_dose``)."""
    from ringqa.geometry.shape_checks import tight_bend_warning
    from ringqa.simulation.instruments import CABLE_PRESETS

    out: list[str] = []
    for w in getattr(loaded.rtplan, "warnings", ()) or ():
        name, msg = split_warning(w, "plan.reader")
        if name == "plan.no_sk" and cfg.sk_U is not None:
            continue  # given with --sk-u
        out.append(named_warning(name, "RT Plan: " + msg))
    for n in app.metadata.get("notes", ()) or ():
        out.append(named_warning("csv.encoding" if "read as" in str(n) else "input.note", str(n)))
    out += [n for n in src.notes if split_warning(n, "")[0]]
    inst = CABLE_PRESETS.get(preset)
    if inst is not None:
        capsule = inst.sections[0]
        for ch in app.channels:
            text = tight_bend_warning(ch, capsule.length_m, capsule.r_o_m,
                                      f"applicator {app.name}, channel {ch.name}")  # fmt: skip
            if text:
                out.append(named_warning("channel.tight_bend", text))
    for text in unsimulated_channels(loaded):
        out.append(named_warning("plan.channel_not_simulated", text))
    for v in verdicts:
        if v.check == CHECK_TPS and v.status == "ACTION":
            out.append(named_warning("plan.tps_dose", v.text))
    return tuple(out)


def correction_note(correction) -> str:
    """The report's statement of a centreline correction (:mod:`ringqa.io.correction`)."""
    d = correction.splice.as_mm_dict()
    return (
        f"Centreline correction: {Path(correction.path).name} replaces the {correction.channel} "
        f"channel's library centreline from {d['old_start_mm']:.1f} to {d['old_end_mm']:.1f} mm "
        f"(blends {d['blend_start_mm']:.1f}/{d['blend_end_mm']:.1f} mm; gaps at the joins "
        f"{d['gap_start_mm']:.2f}/{d['gap_end_mm']:.2f} mm; largest shift "
        f"{d['max_shift_mm']:.2f} mm; length change {d['length_change_mm']:+.2f} mm)."
    )
