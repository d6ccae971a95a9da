"""The settings a study varies: the grid of overrides, the scene's values, labels and kinds.

A grid is a list of dotted overrides in user units (``{"solver.increment_mm": 0.5}``); the
default grid refines the element lengths and the step, tightens the tolerance, switches the
solver kind and toggles each optional effect. Runs that change the physics are "model" runs,
the others "numerical". :class:`AccuracyError`, the study's error, lives here: a bad grid key is
the first thing it reports.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ringqa.accuracy.cache import key_of
from ringqa.errors import RingQAError
from ringqa.simulation.scenefile import scene_to_dict
from ringqa.units import m_to_mm


class AccuracyError(RingQAError):
    """The study cannot be run as asked (bad grid key, no successful reference)."""


def flexible_sections(scene) -> list[str]:
    """Names of the instrument's flexible (discretised) sections."""
    return [s.name for s in scene.instrument.sections if not s.rigid]


def setting_value(scene, key: str):
    """The scene's current value (user units) of a dotted setting key."""
    if key.startswith("discretisation.element_length_mm."):
        name = key.rsplit(".", 1)[1]
        for s in scene.instrument.sections:
            if s.name == name:
                return round(m_to_mm(s.element_length_m), 9)
        raise AccuracyError(f"grid key {key}: the instrument has no section {name!r}")
    node: Any = scene_to_dict(scene)
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return None
        node = node[part]
    return node


def _step_key(scene) -> str:
    return "solver.time_step_s" if scene.solver.kind == "dynamic" else "solver.increment_mm"


def scaled_overrides(
    scene, factor_el: float, factor_step: float, tol: float | None = None
) -> dict[str, Any]:
    """Overrides scaling every flexible section's element length and the step by factors.

    Parameters
    ----------
    scene : ringqa.simulation.scene.Scene
        The scene whose settings are scaled.
    factor_el, factor_step : float
        Factors on every flexible section's element length and on the load increment (quasi-
        static) or time step (dynamic); 0.25 and 0.25 is "4x refined".
    tol : float or None
        Newton tolerance to set as well (None: unchanged).

    Returns
    -------
    dict
        Dotted overrides in user units (mm, s), values rounded to 6 significant digits, for
        :func:`ringqa.simulation.scenefile.scene_with_overrides`.
    """
    out: dict[str, Any] = {}
    for name in flexible_sections(scene):
        out[f"discretisation.element_length_mm.{name}"] = _r(
            setting_value(scene, f"discretisation.element_length_mm.{name}") * factor_el
        )
    key = _step_key(scene)
    out[key] = _r(setting_value(scene, key) * factor_step)
    if tol is not None:
        out["solver.tol"] = tol
    return out


def _r(x: float) -> float:
    return float(f"{x:.6g}")


DEFAULT_FACTORS = (2.0, 1.0, 0.5, 0.25)


def default_grid(scene, factors: tuple[float, ...] = DEFAULT_FACTORS) -> list[dict[str, Any]]:
    """The default grid of settings (each a dict of dotted overrides in user units).

    - element length (all flexible sections together) x ``factors`` (2, 1, 1/2, 1/4) crossed with
      the increment (quasi-static) or time step (dynamic) x ``factors``: 16 runs;
    - Newton tolerance 1e-4 and 1e-6 at the scene's discretisation;
    - (quasi-static) the solver's stabilisation 1e-4 and 1e-3 (a numerical aid for snap-through
      and stalls: its influence is measured like any other setting);
    - the other solver kind (quasi-static <-> dynamic with inertia) at the scene's discretisation;
    - each optional effect toggled (torsion, wall damping, friction none <-> the scene's law,
      gravity): these change the MODEL; their rows show what the effect changes and costs.
    """
    grid: list[dict[str, Any]] = []
    for fe in factors:
        for fs in factors:
            grid.append(scaled_overrides(scene, fe, fs))
    for tol in (1e-4, 1e-6):
        if tol != scene.solver.tol:
            grid.append({**scaled_overrides(scene, 1.0, 1.0), "solver.tol": tol})
    if scene.solver.kind == "quasistatic":
        for stab in (1e-4, 1e-3):
            if stab != scene.solver.stabilisation:
                grid.append({"solver.stabilisation": stab})
    if scene.solver.kind == "quasistatic":
        grid.append({"solver.kind": "dynamic", "effects.inertia": True})
    else:
        grid.append({"solver.kind": "quasistatic", "effects.inertia": False})
    e = scene.effects
    grid.append({"effects.torsion": not e.torsion})
    grid.append({"effects.wall_damping": not e.wall_damping})
    grid.append({"effects.friction": "none" if e.friction != "none" else "stribeck"})
    grid.append({"effects.gravity": e.gravity_m_s2 is None})
    return grid


def expand_grid(grid) -> list[dict[str, Any]]:
    """A grid given as a list of override dicts, or as {key: [values]} (cartesian product)."""
    if grid is None:
        return []
    if isinstance(grid, Mapping):
        keys = list(grid)
        combos: list[dict[str, Any]] = [{}]
        for k in keys:
            vals = grid[k] if isinstance(grid[k], list | tuple) else [grid[k]]
            combos = [{**c, k: v} for c in combos for v in vals]
        return combos
    return [dict(g) for g in grid]


MODEL_KEYS = ("effects.", "solver.kind", "contact.", "instrument.")


def is_model_change(overrides: Mapping[str, Any]) -> bool:
    """True when a run changes the physics (an effect, the solver kind), not only numerics."""
    return any(k.startswith(MODEL_KEYS) for k in overrides)


def label_of(overrides: Mapping[str, Any]) -> str:
    """A short label for plots: ``el thin 1.5 thick 5 | inc 0.5 | tol 1e-06``."""
    if not overrides:
        return "scene's own settings"
    parts = []
    els = {k.rsplit(".", 1)[1]: v for k, v in overrides.items() if ".element_length_mm." in k}
    if els:
        parts.append("el " + " ".join(f"{k} {v:g}" for k, v in els.items()))
    short = {
        "solver.increment_mm": "inc",
        "solver.time_step_s": "dt",
        "solver.tol": "tol",
        "solver.kind": "",
    }
    for k, v in overrides.items():
        if ".element_length_mm." in k or (k == "effects.inertia" and "solver.kind" in overrides):
            continue
        name = short.get(k, k.split(".")[-1])
        val = f"{v:g}" if isinstance(v, float) else str(v).lower()
        parts.append(f"{name} {val}".strip())
    return " | ".join(parts)


def dedupe_grid(scene, grid_list: list[dict]) -> list[dict]:
    """Drop runs whose scene equals an earlier one (e.g. the scene's own settings spelled out).

    Raises
    ------
    AccuracyError
        A grid entry the scene cannot take (names the entry and the key).
    """
    seen: set[str] = set()
    out = []
    for ov in grid_list:
        try:
            key = key_of(scene, ov)
        except RingQAError as exc:
            raise AccuracyError(f"grid entry {ov}: {exc}") from None
        if key not in seen:
            seen.add(key)
            out.append(ov)
    return out


@dataclass(frozen=True)
class FinestFactors:
    """The finest refinement a grid uses, relative to the scene's own settings.

    Attributes
    ----------
    element_length : float
        Smallest factor on the flexible sections' element lengths (1: none finer).
    step : float
        Smallest factor on the increment (quasi-static) or time step (dynamic).
    """

    element_length: float
    step: float


def finest_factors(scene, grid_list) -> FinestFactors:
    """Smallest element-length and step factors (relative to the scene) used in the grid."""
    el_f, st_f = 1.0, 1.0
    key = _step_key(scene)
    base_step = setting_value(scene, key)
    for ov in grid_list:
        for name in flexible_sections(scene):
            k = f"discretisation.element_length_mm.{name}"
            if k in ov:
                el_f = min(el_f, float(ov[k]) / setting_value(scene, k))
        if key in ov:
            st_f = min(st_f, float(ov[key]) / base_step)
    return FinestFactors(el_f, st_f)
