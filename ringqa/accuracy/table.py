"""The table of runs: errors per run, the Pareto front of time vs error, the recommendation.

One row per grid run with its settings, time and errors against the reference; runs that fail
or jam have no error (NaN), are never on the Pareto front and never recommended. Only numerical
settings compete: a model change (an effect, the solver kind) is shown but not a candidate.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ringqa.accuracy.cache import RunRecord
from ringqa.accuracy.dose import DoseReference, dose_error_pct
from ringqa.accuracy.grid import is_model_change, label_of, setting_value
from ringqa.accuracy.metrics import (
    angle_errors_deg,
    max_or_nan,
    median_or_nan,
    position_errors_mm,
)

CONTRACT_COLUMNS = (
    "time_s",
    "max_err_mm",
    "median_err_mm",
    "max_err_deg",
    "status",
    "pareto",
)
STATUS_WORDS = {0: "success", 1: "jammed", -1: "failed"}


def pareto_mask(time_s, err) -> np.ndarray:
    """True for runs no other run beats in both time and error (NaN never on the front)."""
    t, e = np.asarray(time_s, float), np.asarray(err, float)
    ok = np.isfinite(t) & np.isfinite(e)
    mask = np.zeros(t.size, bool)
    for i in np.flatnonzero(ok):
        dominated = ok & (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        mask[i] = not dominated.any()
    return mask


def recommend(table, target_mm: float, include_model_changes: bool = False) -> dict | None:
    """The cheapest successful run (by ``time_s``) whose ``max_err_mm`` meets the target."""
    ok = (table["status"] == 0) & (table["max_err_mm"] <= target_mm)
    if not include_model_changes:
        ok &= table["kind"] == "numerical"
    if not ok.any():
        return None
    row = table[ok].sort_values(["time_s", "max_err_mm"]).iloc[0]
    return row.to_dict()


def results_table(
    scene, grid_list: list[dict], runs: list[RunRecord], ref: RunRecord, dose: DoseReference
):
    """One row per grid run: its settings, label, kind, time, errors and Pareto flag.

    Parameters
    ----------
    scene : Scene
        The studied scene (gives the values of settings a run leaves unchanged).
    grid_list : list of dict
        The runs' overrides.
    runs : list of RunRecord
        The finished runs, in the order of ``grid_list``.
    ref : RunRecord
        The reference run.
    dose : DoseReference
        The dose points and the reference run's dose there.

    Returns
    -------
    pandas.DataFrame
        The columns of :attr:`AccuracyStudy.table`.
    """
    import pandas as pd

    keys: list[str] = []
    for ov in grid_list:
        keys += [k for k in ov if k not in keys]
    base_vals = {k: setting_value(scene, k) for k in keys}
    base_numeric = {
        k: v
        for k, v in base_vals.items()
        if (".element_length_mm." in k or k in ("solver.increment_mm", "solver.time_step_s"))
        and v is not None
    }
    rows = []
    for ov, rec in zip(grid_list, runs, strict=True):
        ok = rec.status == 0
        pe = position_errors_mm(rec.positions_mm, ref.positions_mm) if ok else np.array([np.nan])
        ae = angle_errors_deg(rec.directions, ref.directions) if ok else np.array([np.nan])
        row: dict[str, Any] = {"run": len(rows)}
        row.update({k: ov.get(k, base_vals[k]) for k in keys})
        row.update(
            label=label_of(ov) if ov else f"scene ({label_of(base_numeric)})",
            kind="model" if is_model_change(ov) else "numerical",
            time_s=rec.time_s,
            max_err_mm=max_or_nan(pe),
            median_err_mm=median_or_nan(pe),
            max_err_deg=max_or_nan(ae),
            median_err_deg=median_or_nan(ae),
            dose_err_pct=dose_error_pct(dose.model, rec.positions_mm, rec.directions, dose.dose)
            if ok
            else math.nan,
            status=rec.status,
            status_text=STATUS_WORDS.get(rec.status, str(rec.status)),
            newton_iters=rec.newton_iters,
            n_elements=rec.n_elements,
            n_repeats=len(rec.times_s),
            message=rec.message,
        )
        rows.append(row)
    table = pd.DataFrame(rows)
    # the front compares numerical settings of the same model; model changes are not candidates
    numerical = (table["kind"] == "numerical").to_numpy()
    err_num = np.where(numerical, table["max_err_mm"].to_numpy(float), np.nan)
    table["pareto"] = pareto_mask(table["time_s"], err_num)
    return table
