"""What a study returns: :class:`AccuracyStudy`, and its recommendation for each target."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ringqa.accuracy.reference import ReferenceInfo
from ringqa.accuracy.table import recommend


@dataclass(frozen=True)
class AccuracyStudy:
    """The study's results.

    Attributes
    ----------
    scene_name : str
    table : pandas.DataFrame
        One row per grid run: the settings (one column per key), ``label``, ``kind``
        (``numerical`` / ``model``), ``time_s``, ``max_err_mm``, ``median_err_mm``,
        ``max_err_deg``, ``median_err_deg``, ``dose_err_pct``, ``status``, ``pareto``,
        ``newton_iters``, ``n_elements``, ``n_repeats``, ``message``.
    reference : ReferenceInfo
    target_mm : float
    recommended : dict or None
        The cheapest numerical run meeting ``target_mm`` (its table row), or None.
    recommended_overrides : dict or None
    dose_points : str
        How the dose points were defined.
    out_dir : Path or None
    warnings : tuple of str
    run_overrides : tuple of dict
        The overrides of each run (indexed by the table's ``run`` column).
    """

    scene_name: str
    table: Any
    reference: ReferenceInfo
    target_mm: float
    recommended: dict | None
    recommended_overrides: dict | None
    dose_points: str
    out_dir: Path | None = None
    warnings: tuple[str, ...] = field(default_factory=tuple)
    run_overrides: tuple[dict, ...] = field(default_factory=tuple)

    def recommend(self, target_mm: float, include_model_changes: bool = False) -> dict | None:
        """The cheapest successful run with ``max_err_mm <= target_mm`` (table row), or None."""
        return recommend(self.table, target_mm, include_model_changes)


SUMMARY_TARGETS_MM = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)


def recommendation_summary(study: AccuracyStudy, targets=SUMMARY_TARGETS_MM) -> dict:
    """For each target (mm): the cheapest numerical run meeting it (run, label, time, errors)."""
    out = {}
    for target in sorted({*targets, study.target_mm}, reverse=True):
        row = study.recommend(target)
        out[f"{target:g}"] = (
            None
            if row is None
            else {
                k: row[k]
                for k in ("run", "label", "time_s", "max_err_mm", "max_err_deg", "dose_err_pct")
            }
        )
    return out
