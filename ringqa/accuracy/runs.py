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


def progress_bar(total: int, on: bool):
    """A tqdm bar over ``total`` runs on stderr, or a silent stand-in (``update``, ``close``)."""
    if not on:
        return _NoBar()
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    return tqdm(total=total, desc="accuracy runs", unit="run")
