"""The formulation axis of the accuracy study: the rigid-link and the flexible-element engines
(``model.formulation``) refined side by side.

For each formulation the scene is run at a ladder of refinement factors (every flexible
section's element length and the increment times the factor: :func:`.grid.scaled_overrides`).
Each level's error is its largest dwell distance from the same formulation's finest level; the
observed order of convergence comes from successive differences,
``p = log(d_k / d_{k+1}) / log(f_k / f_{k+1})`` with ``d_k`` the largest dwell change from
level k to k+1; the cost per accuracy is the time of the cheapest level whose error is within the
target, and the two formulations' finest levels are compared with each other (an independent
check that both converge to the same answer).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ringqa.accuracy.grid import AccuracyError, scaled_overrides
from ringqa.simulation.scenefile import scene_with_overrides

#: the engines compared (``model.formulation``)
FORMULATIONS = ("rigid", "flexible")
#: default refinement ladder (element length and increment factors)
LADDER = (2.0, 1.0, 0.5, 0.25)


@dataclass(frozen=True)
class FormulationLevel:
    """One run of the ladder.

    Attributes
    ----------
    formulation : str
    factor : float
        Element-length and increment factor.
    status : int
        The run's status (0 ok).
    time_s : float
        Solve time (s, JIT excluded).
    n_elements : int
    change_mm : float
        Largest dwell distance from the next finer level of the same formulation (mm; NaN for
        the finest).
    err_mm : float
        Largest dwell distance from the same formulation's finest level (mm; 0 for the finest).
    cross_mm : float
        Largest dwell distance from the other formulation at the same factor (mm).
    """

    formulation: str
    factor: float
    status: int
    time_s: float
    n_elements: int
    change_mm: float
    err_mm: float
    cross_mm: float


@dataclass(frozen=True)
class FormulationStudy:
    """Both formulations' ladders and what they show.

    Attributes
    ----------
    levels : tuple of FormulationLevel
    orders : dict
        Formulation -> observed orders of convergence between successive changes.
    finest_agreement_mm : float
        Largest dwell distance between the two formulations' finest levels (mm).
    cheapest : dict
        Formulation -> (factor, time_s) of the cheapest level within ``target_mm`` of its own
        finest level (None: none is).
    target_mm : float
    """

    levels: tuple[FormulationLevel, ...]
    orders: dict[str, list[float]]
    finest_agreement_mm: float
    cheapest: dict[str, tuple[float, float] | None]
    target_mm: float

    def text(self) -> str:
        """The study as lines for the terminal."""
        out = ["formulation  factor  elements  time_s  change_mm  err_mm  vs_other_mm"]
        for lv in self.levels:
            out.append(
                f"{lv.formulation:11s}  {lv.factor:6g}  {lv.n_elements:8d}  {lv.time_s:6.3f}  "
                f"{lv.change_mm:9.4f}  {lv.err_mm:6.4f}  {lv.cross_mm:11.4f}"
            )
        for f, p in self.orders.items():
            ps = ", ".join(f"{x:.2f}" for x in p) or "n/a"
            c = self.cheapest.get(f)
            cost = (
                f"cheapest within {self.target_mm:g} mm: x{c[0]:g}, {c[1]:.3f} s"
                if c
                else f"no level within {self.target_mm:g} mm"
            )
            out.append(f"{f}: observed order of convergence {ps}; {cost}")
        out.append(
            f"finest levels of the two formulations agree to {self.finest_agreement_mm:.4f} mm"
        )
        return "\n".join(out)


def _dist_mm(a, b) -> float:
    d = np.linalg.norm(np.asarray(a.source_pos_m) - np.asarray(b.source_pos_m), axis=1)
    return float(np.nanmax(d)) * 1e3 if np.any(np.isfinite(d)) else math.nan


def compare_formulations(
    scene,
    factors: tuple[float, ...] = LADDER,
    target_mm: float = 0.1,
    simulator: Callable | None = None,
) -> FormulationStudy:
    """Run both formulations over the refinement ``factors`` (see module docstring).

    Raises
    ------
    AccuracyError
        Fewer than two factors, or a finest run that did not succeed.
    """
    facs = tuple(sorted({float(f) for f in factors}, reverse=True))
    if len(facs) < 2:
        raise AccuracyError("the formulation study needs at least two refinement factors")
    if simulator is None:
        from ringqa.simulation import simulate as simulator
    runs: dict[str, list] = {}
    for form in FORMULATIONS:
        base = scene_with_overrides(scene, {"model.formulation": form})
        runs[form] = [simulator(scene_with_overrides(base, scaled_overrides(base, f, f)))
                      for f in facs]  # fmt: skip
        if runs[form][-1].status != 0:
            raise AccuracyError(f"the finest {form} run (x{facs[-1]:g}) did not succeed: "
                                f"{runs[form][-1].message}")  # fmt: skip
    levels = []
    orders: dict[str, list[float]] = {}
    cheapest: dict[str, tuple[float, float] | None] = {}
    other = {"rigid": "flexible", "flexible": "rigid"}
    for form in FORMULATIONS:
        rs = runs[form]
        changes = [_dist_mm(rs[k], rs[k + 1]) for k in range(len(rs) - 1)] + [math.nan]
        errs = [_dist_mm(r, rs[-1]) for r in rs]
        ps = []
        for k in range(len(rs) - 2):
            a, b = changes[k], changes[k + 1]
            if a > 0 and b > 0:
                ps.append(math.log(a / b) / math.log(facs[k] / facs[k + 1]))
        orders[form] = ps
        best = None
        for k, r in enumerate(rs[:-1]):
            if (
                r.status == 0
                and errs[k] <= target_mm
                and (best is None or r.solve_time_s < best[1])
            ):
                best = (facs[k], float(r.solve_time_s))
        cheapest[form] = best
        for k, r in enumerate(rs):
            levels.append(FormulationLevel(
                form, facs[k], int(r.status), float(r.solve_time_s), int(r.n_elements),
                changes[k], errs[k], _dist_mm(r, runs[other[form]][k]),
            ))  # fmt: skip
    return FormulationStudy(
        tuple(levels), orders, _dist_mm(runs["rigid"][-1], runs["flexible"][-1]), cheapest,
        float(target_mm),
    )  # fmt: skip
