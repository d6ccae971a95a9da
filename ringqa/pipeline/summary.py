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


def _max_diffs(std: pd.DataFrame, plans: StandardPlans, column: str) -> dict:
    out: dict[str, dict[str, float]] = {}
    for plan in (plans.simulated, plans.centreline):
        if plan is None:
            continue
        sub = std[std["plan"] == plan.name]
        out[plan.name] = {
            kind: _maxabs(sub.loc[sub["kind"] == kind, column].to_numpy()) for kind in POINT_KINDS
        }
    return out


def _masked(comp: DeviationComponents, mask: np.ndarray) -> DeviationComponents:
    return DeviationComponents(comp.dist_mm[mask], comp.along_mm[mask], comp.radial_mm[mask],
                               comp.out_of_plane_mm[mask])  # fmt: skip


def _median(a) -> float:
    a = np.asarray(a, dtype=float)
    return float(np.median(a)) if a.size else 0.0


def summarise(
    app_name: str,
    source_name: str,
    reference: ReferenceDwells,
    selection: PlanSelection,
    n_tandem: int,
    dev: Deviations,
    dev_raw: Deviations,
    doses: pd.DataFrame,
    plans: StandardPlans,
    simulation: SimulationInfo,
    verdicts: tuple[Verdict, ...],
    *,
    review,
    numerical_error_mm: np.ndarray,
    offsets: dict,
    on_ring: np.ndarray,
) -> Summary:
    """The summary row of one commissioning run.

    Parameters
    ----------
    app_name : str
    source_name : str
        TG-43 source name.
    reference : ReferenceDwells
        The reference as supplied.
    selection : PlanSelection
        Which dwells the ring's standard plan uses, and s_ref.
    n_tandem : int
        Tandem dwells in the standard plan.
    dev, dev_raw : Deviations
        Against the compared (registered) and the supplied reference.
    doses : pandas.DataFrame
        The dose table (TPS points are left out).
    plans : StandardPlans
        The simulated and centreline plans get their dose differences.
    simulation : SimulationInfo
        The simulation's status and solve time.
    verdicts : tuple of Verdict
    review : ReferenceReview
        Registration mode and flags (dwells outside the channel are left out of the numbers).
    numerical_error_mm : (n,) ndarray
        The simulation's numerical error per dwell.
    offsets : dict of str to CentrelineOffsets
        Signed offsets from the centreline per path (``measured``/``registered``/``simulated``/
        ``centreline``).
    on_ring : (n,) ndarray of bool
        Dwells on the ring's circle (their medians are reported).

    Returns
    -------
    Summary
    """
    ref_kind = reference.kind
    keep = review.compared
    std = doses[doses["kind"] != "tps"]
    a_ref = std[(std["plan"] == ref_kind) & (std["kind"] == "point_a")]["dose_gy"]
    measured = ref_kind == "measured"

    def numbers(d: Deviations, which: str):
        comp = d.simulated if which == "sim" else d.centreline
        ang = d.angle_simulated_deg if which == "sim" else d.angle_centreline_deg
        return _path_numbers(_masked(comp, keep), ang[keep])

    ref_path = "registered" if "registered" in offsets else ref_kind
    ring = on_ring & keep
    radial = {
        "reference": _median(offsets[ref_path].radial_mm[ring]),
        "sim": _median(offsets["simulated"].radial_mm[ring]),
        "centreline": _median(offsets["centreline"].radial_mm[ring]),
    }
    height = {
        "reference": _median(offsets[ref_path].height_mm[ring]),
        "sim": _median(offsets["simulated"].height_mm[ring]),
        "centreline": _median(offsets["centreline"].height_mm[ring]),
    }
    return Summary(
        applicator=app_name,
        reference=ref_kind,
        source=source_name,
        n_dwells=int(reference.relative_position_mm.size),
        n_plan_dwells_ring=int(selection.in_plan.sum()),
        n_plan_dwells_tandem=int(n_tandem),
        s_ref_mm=float(selection.s_ref_mm),
        simulated=numbers(dev_raw, "sim"),
        max_angle_sim_vs_centreline_deg=float(np.max(dev.angle_sim_vs_centreline_deg[keep])),
        centreline=numbers(dev_raw, "centreline") if measured else None,
        max_abs_diff_pct=_max_diffs(std, plans, "diff_pct"),
        point_a_mean_gy=float(a_ref.mean()),
        simulation_status=simulation.status,
        solve_time_s=simulation.solve_time_s,
        verdict=_overall_verdict(verdicts),
        registration=review.mode,
        n_reference_infeasible=review.count("infeasible"),
        n_reference_infeasible_raw=review.count("infeasible", raw=True),
        n_reference_outside=review.count("outside_channel"),
        simulated_registered=numbers(dev, "sim"),
        centreline_registered=numbers(dev, "centreline") if measured else None,
        max_abs_diff_registered_pct=_max_diffs(std, plans, "diff_registered_pct"),
        max_numerical_error_mm=float(np.max(numerical_error_mm)),
        median_numerical_error_mm=float(np.median(numerical_error_mm)),
        median_radial=radial,
        median_height=height,
    )
