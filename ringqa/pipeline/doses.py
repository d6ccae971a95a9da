"""The standard plans and their doses: the dose points, the three plans, the dose tables.

The reference plan has equal dwell times scaled to the prescription at Point A; the times are
transferred unchanged to the simulated and centreline dwells (the tandem's dwells are the same in
every plan) and each plan's TG-43 dose is compared with the reference plan's at the dose points.
An RT Plan's own dwells and times are also dosed at its TPS points.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

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


def _dose_points(app, rtplan, spec) -> tuple[list, list]:
    """The standard dose points of the applicator, and those plus the RT Plan's TPS points."""
    std_points = list(applicator_dose_points(app, spec))
    tps_points = []
    if rtplan is not None:
        tps_points = [
            DosePoint(p.name, np.asarray(p.position_mm, dtype=float), "tps", p.tps_dose_gy)
            for p in getattr(rtplan, "points", ())
        ]
    return std_points, std_points + tps_points


def _standard_plans(
    ref_kind, rel, in_plan, ref, simulated, centreline, tandem, std_points, source, *,
    prescription_gy, sk_U,
) -> dict[str, Plan]:  # fmt: skip
    """The reference plan and the same times on the simulated (and centreline) dwells.

    Parameters
    ----------
    ref_kind : str
        ``"measured"`` or ``"centreline"``: the reference plan's name.
    rel : ndarray
        Relative positions of the reference dwells, mm.
    in_plan : ndarray of bool
        Which dwells the plans use.
    ref, simulated, centreline : (ndarray, ndarray)
        Positions (n, 3) in mm and unit source directions (n, 3) of each path.
    tandem : DwellSet or None
        The tandem's dwells, the same in every plan.
    std_points : list of DosePoint
        The standard dose points; the first two (Point A left and right) set the times.
    source : tg43.Source
    prescription_gy, sk_U : float
        Mean Point A dose, Gy, and air-kerma strength, U.

    Returns
    -------
    dict
        Plan name (``measured``/``centreline``, ``simulated``) -> Plan, the reference first.
    """
    ref_pos, ref_dir = ref
    sim_pos, sim_dir = simulated
    cl_pos, cl_dir = centreline
    ring_ref = DwellSet("ring", rel[in_plan], ref_pos[in_plan], ref_dir[in_plan])
    sets = [ring_ref] + ([tandem] if tandem is not None else [])
    ref_plan = standard_plan(
        sets, points_array_mm(std_points[:2]), source, prescription_gy=prescription_gy,
        sk_U=sk_U, name=ref_kind,
    )  # fmt: skip

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
    return plans


def _dose_table(app_name: str, plans: dict, ref_kind: str, points: list) -> pd.DataFrame:
    """One row per dose point and plan: the dose and its difference from the reference plan's.

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`CommissioningResult.doses` but for the RT Plan's own doses.
    """
    xyz = points_array_mm(points)
    doses_ref = plans[ref_kind].dose_gy(xyz)
    dose_rows = []
    for pname, plan in plans.items():
        d = doses_ref if pname == ref_kind else plan.dose_gy(xyz)
        diff = relative_difference_pct(d, doses_ref)
        for k, pt in enumerate(points):
            dose_rows.append(
                {
                    "applicator": app_name,
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
    return pd.DataFrame(dose_rows)


def _with_rtplan_doses(doses, rtplan, app, source, sk_U, notes: list[str]) -> pd.DataFrame:
    """``doses`` with the RT Plan's own doses at its TPS points appended (their notes added)."""
    own, own_notes = _rtplan_own_doses(rtplan, app, source, float(rtplan.source.sk_U or sk_U))
    notes += own_notes
    if not own.empty:
        own.insert(0, "applicator", app.name)
        doses = pd.concat([doses, own], ignore_index=True)
    return doses


def _plan_table(app_name: str, plans: dict) -> pd.DataFrame:
    """The plans' dwells with their times: :attr:`CommissioningResult.plan_dwells`."""
    plan_rows = []
    for pname, plan in plans.items():
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
