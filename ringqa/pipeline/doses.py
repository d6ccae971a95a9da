"""The standard plans and their doses: the dose points, the three plans, the dose tables.

The reference plan has equal dwell times scaled to the prescription at Point A; the times are
transferred unchanged to the simulated and centreline dwells (the tandem's dwells are the same in
every plan) and each plan's TG-43 dose is compared with the reference plan's at the dose points.
An RT Plan's own dwells and times are also dosed at its TPS points.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from ringqa.pipeline.dwells import PathDwells, PlanSelection, ReferenceDwells
from ringqa.plan import (
    DosePoint,
    DwellSet,
    Plan,
    applicator_dose_points,
    points_array_mm,
    relative_difference_pct,
    standard_plan,
)
from ringqa.units import mm_to_m


@dataclass(frozen=True, eq=False)
class DosePoints:
    """Where doses are computed.

    Attributes
    ----------
    standard : tuple of DosePoint
        The applicator's standard points (Point A left/right first: they set the plan times).
    all : tuple of DosePoint
        The standard points, then the RT Plan's own (TPS) points.
    """

    standard: tuple[DosePoint, ...]
    all: tuple[DosePoint, ...]


@dataclass(frozen=True, eq=False)
class StandardPlans:
    """The standard plan on the reference path and the same dwell times on the other dwell sets.

    Attributes
    ----------
    reference : Plan
        Named ``"measured"`` or ``"centreline"``: the standard plan on the reference path as
        supplied (its times are every plan's times).
    registered : Plan or None
        The same times on the registered reference path (when registration moved it): the plan
        the other plans are compared with.
    simulated : Plan
    centreline : Plan or None
        Only when the reference is the measured path.
    """

    reference: Plan
    registered: Plan | None
    simulated: Plan
    centreline: Plan | None

    @property
    def compared_reference(self) -> Plan:
        """The plan the simulated and centreline plans are judged against."""
        return self.registered if self.registered is not None else self.reference

    @property
    def in_order(self) -> tuple[Plan, ...]:
        """The plans in table order: reference, registered, simulated, centreline (those
        there are)."""
        plans = (self.reference, self.registered, self.simulated, self.centreline)
        return tuple(p for p in plans if p is not None)


@dataclass(frozen=True, eq=False)
class DoseTables:
    """The dose and plan tables of a run.

    Attributes
    ----------
    doses : pandas.DataFrame
        :attr:`CommissioningResult.doses` (the RT Plan's own doses appended).
    plan_dwells : pandas.DataFrame
        :attr:`CommissioningResult.plan_dwells`.
    notes : tuple of str
        For the report (how the RT Plan's own dwells were oriented).
    """

    doses: pd.DataFrame
    plan_dwells: pd.DataFrame
    notes: tuple[str, ...]


def dose_points(app, rtplan, spec) -> DosePoints:
    """The standard dose points of the applicator, and those plus the RT Plan's TPS points.

    Parameters
    ----------
    app : Applicator
    rtplan : RTPlan or None
    spec : DosePointSpec

    Returns
    -------
    DosePoints
    """
    std_points = tuple(applicator_dose_points(app, spec))
    tps_points: tuple[DosePoint, ...] = ()
    if rtplan is not None:
        tps_points = tuple(
            DosePoint(p.name, np.asarray(p.position_mm, dtype=float), "tps", p.tps_dose_gy)
            for p in getattr(rtplan, "points", ())
        )
    return DosePoints(std_points, std_points + tps_points)


def standard_plans(
    reference: ReferenceDwells,
    registered: PathDwells | None,
    selection: PlanSelection,
    simulated: PathDwells,
    centreline: PathDwells,
    tandem: DwellSet | None,
    points: DosePoints,
    source,
    *,
    prescription_gy: float,
    sk_U: float,
    times_from: PathDwells | None = None,
) -> StandardPlans:
    """The reference plan and the same times on the simulated (and centreline) dwells.

    Parameters
    ----------
    reference : ReferenceDwells
        Its kind names the reference plan (the path as supplied).
    registered : PathDwells or None
        The registered reference dwells (None: not registered).
    selection : PlanSelection
        Which dwells the plans use.
    simulated, centreline : PathDwells
    tandem : DwellSet or None
        The tandem's dwells, the same in every plan.
    points : DosePoints
        The first two standard points (Point A left and right) set the times.
    source : tg43.Source
    prescription_gy : float
        Mean Point A dose, Gy.
    sk_U : float
        Air-kerma strength, U.
    times_from : PathDwells, optional
        Set the equal times to the prescription on THESE dwells (the simulated path, when a
        measured subset cannot carry the plan: :mod:`~ringqa.pipeline.measured_points`)
        instead of on the reference's; every plan then carries those times.

    Returns
    -------
    StandardPlans
    """
    in_plan = selection.in_plan
    ref = reference.dwells
    ring_ref = DwellSet(
        "ring", reference.relative_position_mm[in_plan], ref.positions_mm[in_plan],
        ref.directions[in_plan],
    )  # fmt: skip
    sets = [ring_ref] + ([tandem] if tandem is not None else [])
    ref_plan = standard_plan(
        sets, points_array_mm(points.standard[:2]), source, prescription_gy=prescription_gy,
        sk_U=sk_U, name=reference.kind,
    )  # fmt: skip
    if times_from is not None:
        basis = DwellSet(
            "ring",
            reference.relative_position_mm[in_plan],
            times_from.positions_mm[in_plan],
            times_from.directions[in_plan],
        )
        timed = standard_plan(
            [basis] + ([tandem] if tandem is not None else []),
            points_array_mm(points.standard[:2]),
            source,
            prescription_gy=prescription_gy,
            sk_U=sk_U,
            name=reference.kind,
        )
        ref_plan = replace(ref_plan, times_s=timed.times_s)

    def on(path: PathDwells, name: str) -> Plan:
        pos, dirs = path.positions_mm[in_plan], path.directions[in_plan]
        if tandem is not None:
            pos = np.vstack([pos, tandem.positions_mm])
            dirs = np.vstack([dirs, tandem.directions])
        return ref_plan.transfer(pos, dirs, name)

    cl_plan = on(centreline, "centreline") if reference.kind == "measured" else None
    reg_plan = on(registered, "registered") if registered is not None else None
    return StandardPlans(ref_plan, reg_plan, on(simulated, "simulated"), cl_plan)


def dose_tables(
    app,
    rtplan,
    plans: StandardPlans,
    points: DosePoints,
    source,
    sk_U: float,
    sk_given: bool = True,
) -> DoseTables:
    """The dose table (every plan at every point; the RT Plan's own doses) and the plan table.

    Parameters
    ----------
    app : Applicator
    rtplan : RTPlan or None
        Its own dwells and times are dosed at its TPS points.
    plans : StandardPlans
    points : DosePoints
    source : tg43.Source
    sk_U : float
        Air-kerma strength, U (the RT Plan's own when it has one).
    sk_given : bool
        ``sk_U`` came from the user or the plan; without it the plan's own dwells are not dosed
        (their doses scale with S_K, so a default would fake the TPS check).

    Returns
    -------
    DoseTables
    """
    doses = _dose_table(app.name, plans, points.all)
    notes: list[str] = []
    if rtplan is not None and sk_given:
        doses = _with_rtplan_doses(doses, rtplan, app, source, sk_U, notes)
    return DoseTables(doses, _plan_table(app.name, plans), tuple(notes))


def _dose_table(app_name: str, plans: StandardPlans, points) -> pd.DataFrame:
    """One row per dose point and plan: the dose and its difference from the reference plan's
    (``diff_pct``: the path as supplied) and from the registered reference plan's
    (``diff_registered_pct``; equal without registration).

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`CommissioningResult.doses` but for the RT Plan's own doses.
    """
    xyz = points_array_mm(points)
    doses_ref = plans.reference.dose_gy(xyz)
    doses = {id(plans.reference): doses_ref}
    for plan in plans.in_order[1:]:
        doses[id(plan)] = plan.dose_gy(xyz)
    doses_reg = doses[id(plans.compared_reference)]
    dose_rows = []
    for plan in plans.in_order:
        pname = plan.name
        d = doses[id(plan)]
        diff = relative_difference_pct(d, doses_ref)
        diff_reg = relative_difference_pct(d, doses_reg)
        for k, pt in enumerate(points):
            dose_rows.append(
                {
                    "applicator": app_name,
                    "point": pt.name,
                    "kind": pt.kind,
                    "plan": pname,
                    "dose_gy": d[k],
                    "diff_pct": diff[k],
                    "diff_registered_pct": diff_reg[k],
                    "x_mm": pt.position_mm[0],
                    "y_mm": pt.position_mm[1],
                    "z_mm": pt.position_mm[2],
                    "tps_dose_gy": np.nan if pt.tps_dose_gy is None else pt.tps_dose_gy,
                }
            )
    return pd.DataFrame(dose_rows)


def _with_rtplan_doses(doses, rtplan, app, source, sk_U, notes: list[str]) -> pd.DataFrame:
    """``doses`` with the RT Plan's own doses at its TPS points appended (their notes added)."""
    own, own_notes = _rtplan_own_doses(rtplan, app, source, float(sk_U))
    notes += own_notes
    if not own.empty:
        own.insert(0, "applicator", app.name)
        doses = pd.concat([doses, own], ignore_index=True)
    return doses


def _plan_table(app_name: str, plans: StandardPlans) -> pd.DataFrame:
    """The plans' dwells with their times: :attr:`CommissioningResult.plan_dwells`."""
    plan_rows = []
    for plan in plans.in_order:
        pname = plan.name
        for j in range(plan.n_dwells):
            plan_rows.append(
                {
                    "applicator": app_name,
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
    return pd.DataFrame(plan_rows)


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
            "diff_registered_pct": relative_difference_pct(dose, tps),  # vs the TPS, as diff_pct
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
