"""The per-applicator summary: one row of ``summary.csv`` with the overall verdict.

Largest distances, angles and dose differences of the compared paths and plans, the mean Point A
dose, the simulation's status and time, and the worst verdict (FAIL, WARN or PASS).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ringqa.pipeline.deviations import Deviations


def _maxabs(a):
    return float(np.max(np.abs(a))) if np.size(a) else float("nan")


def _path_numbers(tag: str, comp: dict, angle_deg: np.ndarray) -> dict:
    """Median and largest distance, largest components and angle of one path (``tag``)."""
    return {
        f"median_dist_{tag}_mm": float(np.median(comp["dist_mm"])),
        f"max_dist_{tag}_mm": float(np.max(comp["dist_mm"])),
        f"max_along_{tag}_mm": _maxabs(comp["along_mm"]),
        f"max_radial_{tag}_mm": _maxabs(comp["radial_mm"]),
        f"max_out_of_plane_{tag}_mm": _maxabs(comp["out_of_plane_mm"]),
        f"max_angle_{tag}_deg": float(np.max(angle_deg)),
    }


def _overall_verdict(verdicts) -> str:
    """FAIL when any check is FAIL or ACTION, else WARN when any is WARN, else PASS."""
    return (
        "FAIL" if any(v.status in ("FAIL", "ACTION") for v in verdicts)
        else "WARN" if any(v.status == "WARN" for v in verdicts) else "PASS"
    )  # fmt: skip


def _summary(
    app,
    source,
    ref_kind: str,
    rel: np.ndarray,
    in_plan: np.ndarray,
    n_tandem: int,
    s_ref_mm: float,
    dev: Deviations,
    doses: pd.DataFrame,
    plan_names,
    sim_info: dict,
    verdicts,
) -> dict:
    """The summary row of one commissioning run.

    Parameters
    ----------
    app : Applicator
    source : tg43.Source
    ref_kind : str
        ``"measured"`` or ``"centreline"``.
    rel : ndarray
        Relative positions of the reference dwells, mm.
    in_plan : ndarray of bool
        Which dwells the ring's standard plan uses.
    n_tandem : int
        Tandem dwells in the standard plan.
    s_ref_mm : float
        The ring channel's reference arc length, mm.
    dev : Deviations
    doses : pandas.DataFrame
        The dose table (TPS points are left out).
    plan_names : iterable of str
        The plans; each but the reference gets its dose differences.
    sim_info : dict
        The simulation's ``status`` and ``solve_time_s``.
    verdicts : sequence of Verdict

    Returns
    -------
    dict
        Column -> value of summary.csv.
    """
    summary = {
        "applicator": app.name,
        "reference": ref_kind,
        "source": source.name,
        "n_dwells": int(rel.size),
        "n_plan_dwells_ring": int(in_plan.sum()),
        "n_plan_dwells_tandem": int(n_tandem),
        "s_ref_mm": float(s_ref_mm),
        **_path_numbers("sim", dev.simulated, dev.angle_simulated_deg),
        "max_angle_sim_vs_centreline_deg": float(np.max(dev.angle_sim_vs_centreline_deg)),
    }
    if ref_kind == "measured":
        summary.update(_path_numbers("centreline", dev.centreline, dev.angle_centreline_deg))
    std = doses[doses["kind"] != "tps"]
    for pname in plan_names:
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
    summary["verdict"] = _overall_verdict(verdicts)
    return summary
