"""The accuracy/time study: what each numerical setting costs and what it buys.

A scene is run over a grid of settings (element length per cable section, input increment or
time step, Newton tolerance, solver kind, each optional effect on/off). Every run is timed
(the engine's ``solve_time_s``, JIT excluded, median of ``repeats`` runs) and compared with a
reference run refined until it no longer changes:

Reference (how "converged" is decided)
--------------------------------------
Level k of the reference halves the finest grid's element lengths and increment (or time step)
k times (k = 1, 2, ...) and tightens the tolerance to ``min(tol, 1e-10)``. After each new level the
difference between the two finest levels (max over dwells, mm) is compared with the smallest
error any grid run reports against the finest level; the reference is CONVERGED when that
difference is at most a tenth of it (or below ``noise_mm``, the level at which dwell positions are
no longer meaningful). Refinement stops there, or after ``max_levels`` levels with
``converged = False`` recorded (and a warning). Every level is a row of ``reference.csv``.

Errors per run: position error |p - p_ref| over the dwells (max and median, mm), direction error
(angle between source directions, deg), and the dose error at the report's dose points (Point A,
ring surface, 5 mm deeper; left and right) for equal dwell times at the simulated positions,
max over points in %, through :mod:`tg43` with the Flexisource data. Without an applicator ring
frame (analytic channels) the points are built from a circle fitted to the reference dwells
(documented stand-in).

Runs that fail or jam have no error (NaN); they appear with their status and are never on the
Pareto front nor recommended. Finished runs are cached in ``DIR/runs.jsonl`` (one JSON line per
run, keyed by the scene's settings, the channel geometry and the engine's source), so an
interrupted study resumes without losing them and a changed engine or applicator is re-run.

The parts live in one module each: :mod:`~ringqa.accuracy.grid` (the settings varied),
:mod:`~ringqa.accuracy.runs` (one timed run), :mod:`~ringqa.accuracy.cache` (run records and
``runs.jsonl``), :mod:`~ringqa.accuracy.reference` (the converged reference),
:mod:`~ringqa.accuracy.metrics` and :mod:`~ringqa.accuracy.dose` (the errors),
:mod:`~ringqa.accuracy.table` (table, Pareto front, recommendation),
:mod:`~ringqa.accuracy.result` (:class:`AccuracyStudy`), :mod:`~ringqa.accuracy.output` and
:mod:`~ringqa.accuracy.figure` (the files). This module runs them in order.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from ringqa.accuracy.cache import (
    CACHE_NAME,
    RunCache,
    RunRecord,
    channel_fingerprint,
    engine_fingerprint,
    key_of,
    load_cached_runs,
    run_key,
)
from ringqa.accuracy.dose import (
    DoseModel,
    DoseReference,
    dose_error_pct,
    dose_model_for,
    reference_dose,
)
from ringqa.accuracy.figure import plot_study
from ringqa.accuracy.grid import (
    DEFAULT_FACTORS,
    MODEL_KEYS,
    AccuracyError,
    dedupe_grid,
    default_grid,
    expand_grid,
    flexible_sections,
    is_model_change,
    label_of,
    setting_value,
)
from ringqa.accuracy.metrics import angle_errors_deg, position_errors_mm
from ringqa.accuracy.output import (
    CSV_NAME,
    PNG_NAME,
    REFERENCE_CSV,
    TOML_NAME,
    write_recommended,
    write_study,
)
from ringqa.accuracy.reference import (
    DEFAULT_NOISE_MM,
    REFERENCE_TOL,
    Reference,
    ReferenceInfo,
    ReferenceLevel,
    Refinement,
    reference_from,
    refine_reference,
    tail_estimate,
)
from ringqa.accuracy.result import SUMMARY_TARGETS_MM, AccuracyStudy, recommendation_summary
from ringqa.accuracy.runs import cost_progress_bar, execute
from ringqa.accuracy.table import (
    CONTRACT_COLUMNS,
    STATUS_WORDS,
    pareto_mask,
    recommend,
    results_table,
)

__all__ = [
    "CACHE_NAME",
    "CONTRACT_COLUMNS",
    "CSV_NAME",
    "DEFAULT_FACTORS",
    "DEFAULT_NOISE_MM",
    "MODEL_KEYS",
    "PNG_NAME",
    "REFERENCE_CSV",
    "REFERENCE_TOL",
    "STATUS_WORDS",
    "SUMMARY_TARGETS_MM",
    "TOML_NAME",
    "AccuracyError",
    "AccuracyStudy",
    "DoseModel",
    "DoseReference",
    "Reference",
    "ReferenceInfo",
    "ReferenceLevel",
    "Refinement",
    "RunCache",
    "RunRecord",
    "angle_errors_deg",
    "channel_fingerprint",
    "dedupe_grid",
    "default_grid",
    "dose_error_pct",
    "dose_model_for",
    "engine_fingerprint",
    "execute",
    "expand_grid",
    "flexible_sections",
    "is_model_change",
    "key_of",
    "label_of",
    "load_cached_runs",
    "pareto_mask",
    "plot_study",
    "position_errors_mm",
    "recommend",
    "recommendation_summary",
    "reference_dose",
    "reference_from",
    "refine_reference",
    "results_table",
    "run_key",
    "run_study",
    "setting_value",
    "tail_estimate",
    "write_recommended",
    "write_study",
]


def run_study(
    scene,
    grid=None,
    target_mm: float = 0.1,
    out_dir: str | Path | None = None,
    progress: bool = False,
    resume: bool = True,
    simulator: Callable | None = None,
    repeats: int = 3,
    max_levels: int = 4,
    noise_mm: float = DEFAULT_NOISE_MM,
    factors: tuple[float, ...] = DEFAULT_FACTORS,
    max_ref_time_s: float = 120.0,
) -> AccuracyStudy:
    """Run the accuracy/time study of a scene.

    Parameters
    ----------
    scene : Scene
        The scene whose settings are studied (its own settings are one of the runs).
    grid : list of dict or dict of lists, optional
        Dotted overrides in user units per run (``{"solver.increment_mm": 0.5}``), or
        ``{key: [values]}`` for a cartesian grid; default :func:`default_grid`.
    target_mm : float
        Accuracy (max dwell position error, mm) the recommendation must meet.
    out_dir : str or Path, optional
        Where to write ``accuracy.csv``, ``accuracy.png``, ``recommended.toml``,
        ``reference.csv`` and the run cache ``runs.jsonl`` (see :func:`write_study`).
    progress : bool
        Show a progress bar (tqdm) over the runs.
    resume : bool
        Reuse finished runs cached in ``out_dir``; False starts afresh.
    simulator : callable, optional
        ``simulator(scene) -> SimResult``; default :func:`ringqa.simulation.simulate` (tests pass
        a fake).
    repeats : int
        Timed repeats per run (median reported).
    max_levels : int
        Most reference refinement levels.
    noise_mm : float
        Agreement below which the reference counts as converged regardless (mm).
    factors : tuple of float
        Refinement factors of the default grid (ignored when ``grid`` is given).
    max_ref_time_s : float
        Do not start a reference level (beyond the second) predicted to take longer than this
        (4x the previous level's time); the study then reports the reference as not converged.

    Returns
    -------
    AccuracyStudy
    """

    if not (isinstance(target_mm, int | float) and target_mm > 0 and math.isfinite(target_mm)):
        raise AccuracyError(f"--target-mm {target_mm!r}: must be a positive number of mm")
    if simulator is None:
        from ringqa.simulation import simulate as simulator
    grid_list = expand_grid(grid) if grid is not None else default_grid(scene, factors)
    grid_list = dedupe_grid(scene, [{}, *grid_list])
    out = Path(out_dir) if out_dir is not None else None
    cache = RunCache(out / CACHE_NAME if out is not None else None, resume)

    def get(overrides, n_repeats: int = repeats) -> RunRecord:
        rec = cache.get(key_of(scene, overrides))
        if rec is None:
            rec = execute(scene, overrides, simulator, repeats=n_repeats)
            cache.put(rec)
        return rec

    # weighted by each run's predicted cost (a reference level costs 4x the one before)
    bar = cost_progress_bar(scene, grid_list, max_levels, repeats, progress, max_ref_time_s)
    runs = []
    for ov in grid_list:
        runs.append(get(ov))
        bar.update(1)
    refinement = refine_reference(
        scene, grid_list, runs, get, cache, bar, max_levels=max_levels, noise_mm=noise_mm,
        max_ref_time_s=max_ref_time_s,
    )  # fmt: skip
    bar.close()
    reference = reference_from(scene, refinement, noise_mm)
    dose = reference_dose(scene, reference.run.positions_mm, reference.run.directions)
    table = results_table(scene, grid_list, runs, reference.run, dose)
    rec_row = recommend(table, target_mm)
    rec_ov = None if rec_row is None else dict(grid_list[int(rec_row["run"])])
    no_recommendation = () if rec_row is not None else (
        f"no numerical setting in the grid meets {target_mm:g} mm",
    )  # fmt: skip
    study = AccuracyStudy(
        scene_name=scene.name,
        table=table,
        reference=reference.info,
        target_mm=float(target_mm),
        recommended=rec_row,
        recommended_overrides=rec_ov,
        dose_points=dose.how,
        out_dir=out,
        warnings=(*refinement.warnings, *reference.warnings, *dose.warnings, *no_recommendation),
        run_overrides=tuple(dict(g) for g in grid_list),
    )
    if out is not None:
        write_study(study, scene, out)
    return study
