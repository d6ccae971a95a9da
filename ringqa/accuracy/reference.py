"""The converged reference: refine beyond the finest grid run until two levels agree.

Level k halves the finest grid's element lengths and increment (or time step) k times and
tightens the tolerance to ``min(tol, 1e-10)``; the reference is converged when the two finest
levels differ by at most a tenth of the smallest error any grid run reports against the finest
(or by less than ``noise_mm``). See :mod:`ringqa.accuracy.study` for the whole rule.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.accuracy.cache import RunCache, RunRecord, key_of
from ringqa.accuracy.grid import AccuracyError, finest_factors, scaled_overrides
from ringqa.accuracy.metrics import position_errors_mm

REFERENCE_TOL = 1.0e-10
DEFAULT_NOISE_MM = 1.0e-4  # 0.1 um: below this dwell differences are numerical noise


@dataclass(frozen=True)
class ReferenceLevel:
    """One refinement level of the reference (a row of ``reference.csv``).

    Attributes
    ----------
    level : int
        k = 1, 2, ...: the finest grid run's element lengths and step halved k times.
    overrides : dict
        Its dotted overrides (user units).
    time_s : float
        Its solve time, s (one run).
    n_elements : int
    status : int
        0 success, 1 jammed, -1 failed.
    diff_to_previous_mm : float
        Max dwell difference to the previous level, mm (NaN for the first).
    """

    level: int
    overrides: dict[str, Any]
    time_s: float
    n_elements: int
    status: int
    diff_to_previous_mm: float

    def csv_row(self) -> dict[str, Any]:
        """The ``reference.csv`` row: the fields, then one column per override key."""
        return {
            "level": self.level,
            "time_s": self.time_s,
            "n_elements": self.n_elements,
            "status": self.status,
            "diff_to_previous_mm": self.diff_to_previous_mm,
            **self.overrides,
        }


@dataclass(frozen=True)
class ReferenceInfo:
    """How the reference was obtained.

    Attributes
    ----------
    levels : tuple of ReferenceLevel
        Every refinement level run.
    agreement_mm : float
        Max dwell difference between the two finest levels (mm).
    smallest_error_mm : float
        Smallest max error of a grid run against the finest level (mm).
    converged : bool
        ``agreement_mm <= max(0.1 * smallest_error_mm, noise_mm)``.
    criterion : str
        The rule in words.
    tail_estimate_mm : float
        Estimated error of the reference itself: the geometric tail ``d r / (1 - r)`` of the
        level differences ``d`` shrinking by ``ratio`` r per level (NaN with fewer than three
        levels or when the differences do not shrink). A check on the rule: for a slowly
        converging engine two levels can agree while both are still off.
    ratio : float
        Ratio of the last two level differences.
    """

    levels: tuple[ReferenceLevel, ...]
    agreement_mm: float
    smallest_error_mm: float
    converged: bool
    criterion: str
    tail_estimate_mm: float = math.nan
    ratio: float = math.nan


def tail_estimate(diffs) -> tuple[float, float]:
    """Geometric-tail estimate of the error left after the last level (mm) and the ratio.

    With level differences ``d_k`` shrinking as ``d_k = r d_(k-1)``, the finest level is still
    ``d_k r / (1 - r)`` away from the limit. NaN when fewer than two differences are known or
    ``r >= 1`` (not converging).
    """
    d = [x for x in diffs if x is not None and np.isfinite(x)]
    if len(d) < 2 or d[-2] <= 0:
        return math.nan, math.nan
    r = d[-1] / d[-2]
    if not r < 1.0:
        return math.nan, float(r)
    return float(d[-1] * r / (1.0 - r)), float(r)


@dataclass(frozen=True, eq=False)
class Refinement:
    """What the reference refinement ran and found.

    Attributes
    ----------
    levels : tuple of ReferenceLevel
    runs : tuple of RunRecord
        The levels' runs, in the same order.
    agreement_mm : float
        Max dwell difference between the two finest levels, mm (inf with fewer than two).
    smallest_error_mm : float
        Smallest max error of a grid run against the finest level, mm.
    converged : bool
    warnings : tuple of str
        A level that failed, a time budget that stopped the refinement.
    """

    levels: tuple[ReferenceLevel, ...]
    runs: tuple[RunRecord, ...]
    agreement_mm: float
    smallest_error_mm: float
    converged: bool
    warnings: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class Reference:
    """The converged (or finest) reference run and how it was obtained.

    Attributes
    ----------
    info : ReferenceInfo
    run : RunRecord
        The finest successful level: every grid run is compared with it.
    warnings : tuple of str
        Not converged, or converging slowly.
    """

    info: ReferenceInfo
    run: RunRecord
    warnings: tuple[str, ...]


def refine_reference(
    scene,
    grid_list: list[dict],
    runs: list[RunRecord],
    get: Callable[..., RunRecord],
    cache: RunCache,
    bar,
    *,
    max_levels: int,
    noise_mm: float,
    max_ref_time_s: float,
) -> Refinement:
    """Run the reference levels until the two finest agree, one fails, or time runs out.

    Parameters
    ----------
    scene : Scene
    grid_list : list of dict
        The grid runs' overrides (the finest of them is refined).
    runs : list of RunRecord
        The finished grid runs (their smallest error sets the agreement needed).
    get : callable
        ``get(overrides, n_repeats) -> RunRecord``: a run, from the cache or executed.
    cache : RunCache
        Levels found there are not subject to ``max_ref_time_s``.
    bar : progress bar
        Advanced by one per level.
    max_levels : int
        Most levels.
    noise_mm : float
        Agreement below which the reference counts as converged regardless, mm.
    max_ref_time_s : float
        Do not start a level (beyond the second) predicted to take longer, s.

    Returns
    -------
    Refinement
    """
    finest = finest_factors(scene, grid_list)
    finest_el, finest_step = finest.element_length, finest.step
    warnings: list[str] = []
    levels: list[ReferenceLevel] = []
    level_recs: list[RunRecord] = []
    agreement = math.inf
    smallest = math.nan
    converged = False
    for k in range(1, max_levels + 1):
        f = 0.5**k
        ov = scaled_overrides(
            scene, finest_el * f, finest_step * f, min(scene.solver.tol, REFERENCE_TOL)
        )
        if level_recs and len(level_recs) >= 2 and cache.get(key_of(scene, ov)) is None:
            # each level doubles elements and steps: ~4x the time of the previous one
            predicted = 4.0 * level_recs[-1].time_s
            if predicted > max_ref_time_s:
                warnings.append(
                    f"reference refinement stopped before level {k}: it would take ~"
                    f"{predicted:.0f} s (> max_ref_time_s = {max_ref_time_s:g} s)"
                )
                break
        rec = get(ov, 1)  # the reference's time is not reported: one run
        bar.update(1)
        diff = math.nan
        if level_recs and rec.status == 0 and level_recs[-1].status == 0:
            diff = float(
                np.nanmax(position_errors_mm(rec.positions_mm, level_recs[-1].positions_mm))
            )
        levels.append(ReferenceLevel(k, ov, rec.time_s, rec.n_elements, rec.status, diff))
        level_recs.append(rec)
        if rec.status != 0:
            warnings.append(f"reference level {k} did not succeed: {rec.message}")
            break
        if len(level_recs) < 2:
            continue
        agreement = diff
        errs = [
            float(np.nanmax(position_errors_mm(r.positions_mm, rec.positions_mm)))
            for r in runs
            if r.status == 0
        ]
        errs = [e for e in errs if np.isfinite(e) and e > 0]
        smallest = min(errs) if errs else math.nan
        bound = max(0.1 * smallest if np.isfinite(smallest) else 0.0, noise_mm)
        if np.isfinite(agreement) and agreement <= bound:
            converged = True
            break
    return Refinement(
        tuple(levels), tuple(level_recs), agreement, smallest, converged, tuple(warnings)
    )


def reference_from(scene, refinement: Refinement, noise_mm: float) -> Reference:
    """The reference (the finest successful level) and how it was obtained.

    Parameters
    ----------
    scene : Scene
        For messages (its name).
    refinement : Refinement
    noise_mm : float
        For the convergence rule's text.

    Returns
    -------
    Reference
        With warnings when it did not converge or converges slowly.

    Raises
    ------
    AccuracyError
        No level succeeded.
    """
    levels, level_recs = refinement.levels, refinement.runs
    agreement, smallest = refinement.agreement_mm, refinement.smallest_error_mm
    converged = refinement.converged
    warnings: list[str] = []
    ref = next((r for r in reversed(level_recs) if r.status == 0), None)
    if ref is None:
        raise AccuracyError(
            f"scene {scene.name}: no reference run succeeded ({levels[-1].status}: "
            f"{level_recs[-1].message}); fix the scene before studying its accuracy"
        )
    if not converged:
        warnings.append(
            f"reference not converged after {len(levels)} levels: the two finest levels differ by "
            f"{agreement:.3g} mm, more than a tenth of the smallest reported error "
            f"({smallest:.3g} mm); errors below ~{agreement:.2g} mm are not resolved"
        )
    tail, ratio = tail_estimate([lv.diff_to_previous_mm for lv in levels])
    if np.isfinite(tail) and np.isfinite(smallest) and tail > 0.1 * smallest:
        warnings.append(
            f"the reference levels converge slowly (each halving shrinks the change by only "
            f"{ratio:.2f}): its own error is estimated at {tail:.2g} mm (geometric tail), more "
            f"than a tenth of the smallest reported error ({smallest:.2g} mm)"
        )
    reference = ReferenceInfo(
        levels=levels,
        agreement_mm=float(agreement),
        smallest_error_mm=float(smallest),
        converged=converged,
        tail_estimate_mm=float(tail),
        ratio=float(ratio),
        criterion=(
            "levels halve the finest grid element lengths and step; converged when the two finest "
            f"levels agree to max(0.1 x smallest grid error, {noise_mm:g} mm)"
        ),
    )
    return Reference(reference, ref, tuple(warnings))
