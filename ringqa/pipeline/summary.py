"""The per-applicator summary: one row of ``summary.csv`` with the overall verdict.

Largest distances, angles and dose differences of the compared paths and plans, the mean Point A
dose, the simulation's status and time, and the worst verdict (FAIL, WARN or PASS).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ringqa.pipeline.deviations import DeviationComponents, Deviations
from ringqa.pipeline.doses import StandardPlans
from ringqa.pipeline.dwells import PlanSelection, ReferenceDwells
from ringqa.pipeline.result import PathNumbers, SimulationInfo, Summary, Verdict

#: The standard point kinds whose largest dose difference the summary reports.
POINT_KINDS = ("point_a", "surface", "depth5")


def _maxabs(a) -> float:
    return float(np.max(np.abs(a))) if np.size(a) else float("nan")


def _path_numbers(comp: DeviationComponents, angle_deg: np.ndarray) -> PathNumbers:
    """Median and largest distance, largest components and angle of one path."""
    return PathNumbers(
        median_dist_mm=float(np.median(comp.dist_mm)),
        max_dist_mm=float(np.max(comp.dist_mm)),
        max_along_mm=_maxabs(comp.along_mm),
        max_radial_mm=_maxabs(comp.radial_mm),
        max_out_of_plane_mm=_maxabs(comp.out_of_plane_mm),
        max_angle_deg=float(np.max(angle_deg)),
    )


def _overall_verdict(verdicts) -> str:
    """FAIL when any check is FAIL or ACTION, else WARN when any is WARN, else PASS."""
    return (
        "FAIL" if any(v.status in ("FAIL", "ACTION") for v in verdicts)
        else "WARN" if any(v.status == "WARN" for v in verdicts) else "PASS"
    )  # fmt: skip


def summarise(
    app_name: str,
    source_name: str,
    reference: ReferenceDwells,
    selection: PlanSelection,
    n_tandem: int,
    dev: Deviations,
    doses: pd.DataFrame,
    plans: StandardPlans,
    simulation: SimulationInfo,
    verdicts: tuple[Verdict, ...],
) -> Summary:
    """The summary row of one commissioning run.

    Parameters
    ----------
    app_name : str
    source_name : str
        TG-43 source name.
    reference : ReferenceDwells
    selection : PlanSelection
        Which dwells the ring's standard plan uses, and s_ref.
    n_tandem : int
        Tandem dwells in the standard plan.
    dev : Deviations
    doses : pandas.DataFrame
        The dose table (TPS points are left out).
    plans : StandardPlans
        Each plan but the reference gets its dose differences.
    simulation : SimulationInfo
        The simulation's status and solve time.
    verdicts : tuple of Verdict

    Returns
    -------
    Summary
    """
    ref_kind = reference.kind
    std = doses[doses["kind"] != "tps"]
    diffs: dict[str, dict[str, float]] = {}
    for plan in plans.in_order[1:]:
        sub = std[std["plan"] == plan.name]
        diffs[plan.name] = {
            kind: _maxabs(sub.loc[sub["kind"] == kind, "diff_pct"].to_numpy())
            for kind in POINT_KINDS
        }
    a_ref = std[(std["plan"] == ref_kind) & (std["kind"] == "point_a")]["dose_gy"]
    return Summary(
        applicator=app_name,
        reference=ref_kind,
        source=source_name,
        n_dwells=int(reference.relative_position_mm.size),
        n_plan_dwells_ring=int(selection.in_plan.sum()),
        n_plan_dwells_tandem=int(n_tandem),
        s_ref_mm=float(selection.s_ref_mm),
        simulated=_path_numbers(dev.simulated, dev.angle_simulated_deg),
        max_angle_sim_vs_centreline_deg=float(np.max(dev.angle_sim_vs_centreline_deg)),
        centreline=(
            _path_numbers(dev.centreline, dev.angle_centreline_deg)
            if ref_kind == "measured"
            else None
        ),
        max_abs_diff_pct=diffs,
        point_a_mean_gy=float(a_ref.mean()),
        simulation_status=simulation.status,
        solve_time_s=simulation.solve_time_s,
        verdict=_overall_verdict(verdicts),
    )
