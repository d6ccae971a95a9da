"""Running the grid: one timed run of the scene at one setting, the engine, the progress bar.

Every run is timed by the engine's ``solve_time_s`` (JIT excluded), the median of ``repeats``
runs; a "success" with non-finite positions counts as failed.
"""

from __future__ import annotations

import numpy as np

from ringqa.accuracy.cache import RunRecord, run_key, scene_salt
from ringqa.simulation.scenefile import scene_to_dict, scene_with_overrides
from ringqa.units import m_to_mm


def execute(scene, overrides, simulator, repeats: int = 3, max_repeat_s: float = 5.0) -> RunRecord:
    """Run ``scene`` with ``overrides`` ``repeats`` times; keep the median timing.

    The first call of a process compiles the kernels; the engine's ``solve_time_s`` excludes
    that. Repeats stop early once a single run takes more than ``max_repeat_s``.
    """
    s = scene_with_overrides(scene, overrides) if overrides else scene
    key = run_key(scene_to_dict(s), scene_salt(s))
    times: list[float] = []
    res = None
    for _ in range(max(1, repeats)):
        res = simulator(s)
        times.append(float(res.solve_time_s))
        if res.status != 0 or res.solve_time_s > max_repeat_s:
            break
    assert res is not None
    pos = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
    dirs = np.asarray(res.source_dir, dtype=float).reshape(-1, 3)
    bad = not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dirs)))
    # a "success" with non-finite positions is a failure; a jam keeps its status
    status = -1 if (bad and res.status == 0) else int(res.status)
    message = f"{res.message} (non-finite positions)" if (bad and res.status == 0) else res.message
    message = str(message)
    return RunRecord(
        key=key,
        overrides=dict(overrides),
        status=status,
        message=message,
        times_s=tuple(times),
        newton_iters=int(np.sum(np.asarray(res.newton_iters))),
        n_elements=int(res.n_elements),
        positions_mm=m_to_mm(pos),
        directions=dirs,
    )


class _NoBar:
    def update(self, n=1) -> None:
        pass

    def close(self) -> None:
        pass


def _factor(scene, overrides, key: str) -> float:
    """A run's setting ``key`` relative to the scene's own (1 where it is not overridden)."""
    from ringqa.accuracy.grid import setting_value

    base = setting_value(scene, key)
    if key not in overrides or not isinstance(base, int | float) or base <= 0:
        return 1.0
    return max(float(overrides[key]) / float(base), 1e-6)


def run_costs(scene, grid_list, max_levels: int, repeats: int) -> list[float]:
    """Predicted relative cost of each grid run and then each reference level, in the order the
    study runs them: elements x load steps (the Newton work of a step grows with the elements)
    relative to the scene's own settings, times the timed repeats of a grid run; reference level
    k halves the finest grid run's element length and step k times: 4^k times that run's cost
    (the study's own prediction, ``refine_reference``)."""
    from ringqa.accuracy.grid import finest_factors, flexible_sections

    keys = [f"discretisation.element_length_mm.{n}" for n in flexible_sections(scene)]
    step = "solver.time_step_s" if scene.solver.kind == "dynamic" else "solver.increment_mm"

    def units(ov) -> float:
        el = min((_factor(scene, ov, k) for k in keys), default=1.0)
        return 1.0 / (el * _factor(scene, ov, step))

    costs = [max(1, repeats) * units(ov) for ov in grid_list]
    finest = finest_factors(scene, grid_list)
    base = 1.0 / (finest.element_length * finest.step)
    return costs + [base * 4.0**k for k in range(1, max_levels + 1)]


def cost_progress_bar(scene, grid_list, max_levels: int, repeats: int, on: bool,
                      max_ref_time_s: float):  # fmt: skip
    """The study's bar (:class:`ringqa.progress.CostProgress`): one ``update()`` per grid run and
    per reference level, each weighted by :func:`run_costs` and scaled by the measured seconds
    of the runs so far (levels from the third on that would take longer than
    ``max_ref_time_s`` are not counted: the study does not start them)."""
    from ringqa.progress import CostProgress

    costs = run_costs(scene, grid_list, max_levels, repeats)
    n = len(grid_list)
    limits = [None] * n + [None if k < 3 else max_ref_time_s for k in range(1, max_levels + 1)]
    return CostProgress(costs, on=on, desc="accuracy runs", limits_s=limits)


def progress_bar(total: int, on: bool):
    """A tqdm bar over ``total`` runs on stderr, or a silent stand-in (``update``, ``close``)."""
    if not on:
        return _NoBar()
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    return tqdm(total=total, desc="accuracy runs", unit="run")
