"""``simulate(scene)``: the engine's entry point."""

from __future__ import annotations

import numpy as np

from ringqa.errors import SimulationError
from ringqa.simulation.result import SimResult
from ringqa.units import mm_to_m

_WARM = False


def warm_up() -> None:
    """Compile (or load from the numba cache) the kernels of every effect combination on tiny
    problems (quasi-static and dynamic, every effect on).

    :func:`simulate` does not need it: each run compiles (or loads) exactly the kernels its
    scene uses before starting its clock, so ``solve_time_s`` excludes JIT.
    """
    global _WARM
    if _WARM:
        return
    from ringqa.simulation._cache import ensure_fresh_kernel_cache

    ensure_fresh_kernel_cache()
    from ringqa.simulation.solvers.driver import run
    from ringqa.simulation.warmup import tiny_scenes

    for scene, adv in tiny_scenes():
        run(scene, adv)
    _WARM = True


def simulate(scene, advances_mm=None, progress: bool = False) -> SimResult:
    """Push the scene's instrument through its channel and report at the requested advances.

    ``scene.model.formulation`` chooses the engine: ``"rigid"`` (rigid links and hinge springs,
    :mod:`ringqa.simulation.solvers`) or ``"flexible"`` (beam elements,
    :mod:`ringqa.simulation.flexible`); both return the same :class:`SimResult`.

    Parameters
    ----------
    scene : ringqa.simulation.scene.Scene
        Channel, instrument, effects, motion and solver settings (SI).
    advances_mm : array_like of float, optional
        Cable advances (mm) to report: the centreline arc length at which the source centre would
        sit if the cable followed the centreline (relative position p of a channel is advance
        ``s_ref_mm - p``). Default: ``scene.motion.advances_m``.
    progress : bool
        Show a tqdm progress bar (input length in mm).

    Returns
    -------
    SimResult
        status 0 (success), 1 (jammed) or -1 (failed); never raises for a run that jams or does
        not converge.

    Raises
    ------
    SimulationError, SceneError
        For a scene that cannot be set up (names the setting and the fix).
    """
    if advances_mm is None:
        adv = np.asarray(scene.motion.advances_m, dtype=float)
    else:
        adv = mm_to_m(np.atleast_1d(np.asarray(advances_mm, dtype=float)))
    adv = np.atleast_1d(adv).astype(float)
    if adv.size == 0:
        raise SimulationError(
            "no advances to report: pass advances_mm or set motion.advances_mm in the scene"
        )
    if not np.all(np.isfinite(adv)):
        raise SimulationError("advances_mm: all advances must be finite numbers (mm)")
    if getattr(getattr(scene, "model", None), "formulation", "rigid") == "flexible":
        from ringqa.simulation.flexible import run_flexible

        return run_flexible(scene, adv, progress=progress)
    from ringqa.simulation.solvers.driver import run

    return run(scene, adv, progress=progress)
