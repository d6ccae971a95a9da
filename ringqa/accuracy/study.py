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
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import statistics
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.errors import RingQAError
from ringqa.units import m_to_mm

CSV_NAME = "accuracy.csv"
PNG_NAME = "accuracy.png"
TOML_NAME = "recommended.toml"
CACHE_NAME = "runs.jsonl"
REFERENCE_CSV = "reference.csv"
CONTRACT_COLUMNS = (
    "time_s",
    "max_err_mm",
    "median_err_mm",
    "max_err_deg",
    "status",
    "pareto",
)
REFERENCE_TOL = 1.0e-10
DEFAULT_NOISE_MM = 1.0e-4  # 0.1 um: below this dwell differences are numerical noise
STATUS_WORDS = {0: "success", 1: "jammed", -1: "failed"}


class AccuracyError(RingQAError):
    """The study cannot be run as asked (bad grid key, no successful reference)."""


# ------------------------------------------------------------------------------------------------
# settings helpers
# ------------------------------------------------------------------------------------------------
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
    node: Any = scene.to_dict()
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            return None
        node = node[part]
    return node


def _step_key(scene) -> str:
    return "solver.time_step_s" if scene.solver.kind == "dynamic" else "solver.increment_mm"


def _scaled(scene, factor_el: float, factor_step: float, tol: float | None = None) -> dict:
    """Overrides scaling every flexible section's element length and the step by factors."""
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
            grid.append(_scaled(scene, fe, fs))
    for tol in (1e-4, 1e-6):
        if tol != scene.solver.tol:
            grid.append({**_scaled(scene, 1.0, 1.0), "solver.tol": tol})
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


def run_key(scene_dict: Mapping[str, Any], salt: str = "") -> str:
    """Cache key of a run: hash of the scene in user units (name excluded) and ``salt``."""
    d = {k: v for k, v in scene_dict.items() if k not in ("name", "description")}
    text = json.dumps(d, sort_keys=True, default=str) + salt
    return hashlib.sha256(text.encode()).hexdigest()[:20]


@functools.lru_cache(maxsize=1)
def engine_fingerprint() -> str:
    """Hash of the installed engine's source (ringqa/simulation/**/*.py) and ringqa's version:
    cached runs of an older engine are not reused."""
    from ringqa import __version__

    root = Path(__file__).resolve().parents[1] / "simulation"
    h = hashlib.sha256(__version__.encode())
    for path in sorted(root.rglob("*.py")):
        h.update(path.name.encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:16]


def channel_fingerprint(channel) -> str:
    """Hash of a channel's geometry (centreline points, lumen arrays, s_ref): a changed
    applicator file invalidates cached runs that name it."""
    h = hashlib.sha256()
    pts = getattr(channel.centreline, "points_m", None)
    if pts is not None:
        h.update(np.ascontiguousarray(pts, dtype=float).tobytes())
    else:
        h.update(str(channel.centreline.length_m).encode())
    for arr in channel.lumen.kernel_arrays():
        h.update(np.ascontiguousarray(arr, dtype=float).tobytes())
    h.update(repr(float(channel.s_ref_m)).encode())
    return h.hexdigest()[:16]


def _salt(scene) -> str:
    return engine_fingerprint() + channel_fingerprint(scene.channel)


# ------------------------------------------------------------------------------------------------
# one run
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunRecord:
    """One finished run (what the cache stores).

    Attributes
    ----------
    key : str
        Cache key (hash of the scene settings).
    overrides : dict
        The dotted overrides (user units) relative to the study's scene.
    status : int
        0 success, 1 jammed, -1 failed.
    message : str
    times_s : tuple of float
        ``solve_time_s`` of each repeat (JIT excluded).
    newton_iters : int
        Total Newton iterations.
    n_elements : int
    positions_mm : (n, 3) ndarray
        Source centre per advance.
    directions : (n, 3) ndarray
        Unit source direction per advance.
    """

    key: str
    overrides: dict
    status: int
    message: str
    times_s: tuple[float, ...]
    newton_iters: int
    n_elements: int
    positions_mm: np.ndarray
    directions: np.ndarray

    @property
    def time_s(self) -> float:
        """Median wall time over the repeats (s)."""
        return float(statistics.median(self.times_s)) if self.times_s else math.nan

    def as_json(self) -> str:
        return json.dumps(
            {
                "key": self.key,
                "overrides": self.overrides,
                "status": self.status,
                "message": self.message,
                "times_s": list(self.times_s),
                "newton_iters": self.newton_iters,
                "n_elements": self.n_elements,
                "positions_mm": np.round(self.positions_mm, 9).tolist(),
                "directions": np.round(self.directions, 12).tolist(),
            },
            default=str,
        )

    @classmethod
    def from_json(cls, line: str) -> RunRecord:
        d = json.loads(line)
        return cls(
            key=d["key"],
            overrides=d["overrides"],
            status=int(d["status"]),
            message=d["message"],
            times_s=tuple(d["times_s"]),
            newton_iters=int(d["newton_iters"]),
            n_elements=int(d["n_elements"]),
            positions_mm=np.asarray(d["positions_mm"], dtype=float).reshape(-1, 3),
            directions=np.asarray(d["directions"], dtype=float).reshape(-1, 3),
        )


def _default_simulator():
    import ringqa.simulation as sim

    simulate = getattr(sim, "simulate", None)
    if simulate is None:
        raise AccuracyError("the simulation engine (ringqa.simulation.simulate) is not available")
    return simulate


def execute(scene, overrides, simulator, repeats: int = 3, max_repeat_s: float = 5.0) -> RunRecord:
    """Run ``scene`` with ``overrides`` ``repeats`` times; keep the median timing.

    The first call of a process compiles the kernels; the engine's ``solve_time_s`` excludes
    that. Repeats stop early once a single run takes more than ``max_repeat_s``.
    """
    s = scene.with_overrides(overrides) if overrides else scene
    key = run_key(s.to_dict(), _salt(s))
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


class _Cache:
    """Finished runs, one JSON line each in ``DIR/runs.jsonl`` (or in memory without a DIR)."""

    def __init__(self, path: Path | None, resume: bool) -> None:
        self.path = path
        self.runs: dict[str, RunRecord] = {}
        if path is not None and path.is_file():
            if resume:
                for line in path.read_text().splitlines():
                    if line.strip():
                        try:
                            rec = RunRecord.from_json(line)
                        except (ValueError, KeyError):
                            continue  # a line cut by an interruption
                        self.runs[rec.key] = rec
            else:
                path.unlink()

    def get(self, key: str) -> RunRecord | None:
        return self.runs.get(key)

    def put(self, rec: RunRecord) -> None:
        self.runs[rec.key] = rec
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with open(self.path, "a") as fh:
                fh.write(rec.as_json() + "\n")
                fh.flush()


# ------------------------------------------------------------------------------------------------
# errors, dose, Pareto
# ------------------------------------------------------------------------------------------------
def position_errors_mm(pos_mm, ref_mm) -> np.ndarray:
    """|p - p_ref| per dwell (mm); NaN where the shapes disagree."""
    a, b = np.asarray(pos_mm, float), np.asarray(ref_mm, float)
    if a.shape != b.shape:
        return np.full(max(len(b), 1), np.nan)
    return np.linalg.norm(a - b, axis=1)


def angle_errors_deg(dirs, ref_dirs) -> np.ndarray:
    """Angle between source directions per dwell (deg), robust near 0 (atan2 form)."""
    a, b = np.asarray(dirs, float), np.asarray(ref_dirs, float)
    if a.shape != b.shape:
        return np.full(max(len(b), 1), np.nan)
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    cross = np.linalg.norm(np.cross(a, b), axis=1)
    dot = np.sum(a * b, axis=1)
    return np.degrees(np.arctan2(cross, dot))


def pareto_mask(time_s, err) -> np.ndarray:
    """True for runs no other run beats in both time and error (NaN never on the front)."""
    t, e = np.asarray(time_s, float), np.asarray(err, float)
    ok = np.isfinite(t) & np.isfinite(e)
    mask = np.zeros(t.size, bool)
    for i in np.flatnonzero(ok):
        dominated = ok & (t <= t[i]) & (e <= e[i]) & ((t < t[i]) | (e < e[i]))
        mask[i] = not dominated.any()
    return mask


def fit_ring_frame(points_mm) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Centre, unit normal, unit lateral and radius of the circle best fitting 3D points (mm).

    Plane by SVD, then an algebraic (Kasa) circle fit in the plane. The lateral axis points
    from the centre towards the points' mean (sign conventions of a real ring frame are unknown
    here: this is the stand-in frame for analytic channels).
    """
    p = np.asarray(points_mm, float)
    c0 = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c0)
    e1, e2, n = vt[0], vt[1], vt[2]
    u, v = (p - c0) @ e1, (p - c0) @ e2
    a = np.column_stack([u, v, np.ones_like(u)])
    sol, *_ = np.linalg.lstsq(a, u**2 + v**2, rcond=None)
    uc, vc = sol[0] / 2, sol[1] / 2
    r = math.sqrt(max(sol[2] + uc**2 + vc**2, 1e-12))
    centre = c0 + uc * e1 + vc * e2
    lat = c0 - centre
    lat = lat - np.dot(lat, n) * n
    lat = lat / np.linalg.norm(lat) if np.linalg.norm(lat) > 1e-9 else e1
    return centre, n, lat, r


@dataclass(frozen=True)
class DoseModel:
    """Dose at fixed points for equal dwell times at given positions (for dose errors)."""

    points_mm: np.ndarray
    point_names: tuple[str, ...]
    source_name: str
    how: str

    def dose(self, positions_mm, directions) -> np.ndarray:
        """Dose per unit time weight at each point (arbitrary units, relative use only)."""
        import tg43

        src = tg43.load_source(self.source_name)
        n = len(positions_mm)
        return tg43.plan_dose_gy(
            src, positions_mm, directions, np.full(n, 1.0), 1.0e4, self.points_mm
        )


def dose_model_for(scene, ref_positions_mm) -> DoseModel | None:
    """The report's dose points for the scene's applicator, else a fitted-circle stand-in."""
    try:
        from ringqa.plan import applicator_dose_points, dose_points_from_frame, points_array_mm
    except ImportError:  # pragma: no cover - plan layer missing
        return None
    src = "flexisource"  # the Flexitron's source (the only cable preset with a source)
    spec = scene.source.get("channel", {}) if isinstance(scene.source, Mapping) else {}
    if spec.get("applicator"):
        try:
            from ringqa.io.applicator_file import load_applicator

            app = load_applicator(spec["applicator"])
            pts = applicator_dose_points(app)
            return DoseModel(
                points_array_mm(pts),
                tuple(p.name for p in pts),
                src,
                f"report dose points of applicator {spec['applicator']}",
            )
        except Exception:  # fall back to the stand-in below
            pass
    ref = np.asarray(ref_positions_mm, float)
    if len(ref) < 3:
        return None
    centre, normal, lat, r = fit_ring_frame(ref)
    if not (np.isfinite(r) and 1.0 < r < 1.0e3):
        return None
    pts = dose_points_from_frame(centre, normal, lat, r)
    return DoseModel(
        points_array_mm(pts),
        tuple(p.name for p in pts),
        src,
        "stand-in: report dose points around a circle fitted to the reference dwells",
    )


def dose_error_pct(model: DoseModel | None, pos_mm, dirs, ref_dose) -> float:
    """Max over points of |D/D_ref - 1| in %, NaN when not computable."""
    if model is None or ref_dose is None:
        return math.nan
    try:
        d = model.dose(pos_mm, dirs)
    except Exception:  # e.g. a point inside the source
        return math.nan
    return float(np.max(np.abs(d / ref_dose - 1.0)) * 100.0)


# ------------------------------------------------------------------------------------------------
# the study
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceInfo:
    """How the reference was obtained.

    Attributes
    ----------
    levels : tuple of dict
        Per refinement level: ``overrides``, ``time_s``, ``n_elements``, ``status``,
        ``diff_to_previous_mm`` (max dwell difference to the previous level).
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

    levels: tuple[dict, ...]
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


def recommend(table, target_mm: float, include_model_changes: bool = False) -> dict | None:
    """The cheapest successful run (by ``time_s``) whose ``max_err_mm`` meets the target."""
    ok = (table["status"] == 0) & (table["max_err_mm"] <= target_mm)
    if not include_model_changes:
        ok &= table["kind"] == "numerical"
    if not ok.any():
        return None
    row = table[ok].sort_values(["time_s", "max_err_mm"]).iloc[0]
    return row.to_dict()


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
    import pandas as pd

    if not (isinstance(target_mm, int | float) and target_mm > 0 and math.isfinite(target_mm)):
        raise AccuracyError(f"--target-mm {target_mm!r}: must be a positive number of mm")
    simulator = simulator or _default_simulator()
    grid_list = expand_grid(grid) if grid is not None else default_grid(scene, factors)
    grid_list = _dedupe(scene, [{}, *grid_list])
    out = Path(out_dir) if out_dir is not None else None
    cache = _Cache(out / CACHE_NAME if out is not None else None, resume)
    warnings: list[str] = []

    def get(overrides, n_repeats: int = repeats) -> RunRecord:
        rec = cache.get(_key_of(scene, overrides))
        if rec is None:
            rec = execute(scene, overrides, simulator, repeats=n_repeats)
            cache.put(rec)
        return rec

    bar = _progress(len(grid_list) + max_levels, progress)
    runs = []
    for ov in grid_list:
        runs.append(get(ov))
        bar.update(1)

    # reference: refine beyond the finest grid run until the two finest levels agree
    finest_el, finest_step = _finest_factors(scene, grid_list)
    levels: list[dict] = []
    level_recs: list[RunRecord] = []
    agreement = math.inf
    smallest = math.nan
    converged = False
    for k in range(1, max_levels + 1):
        f = 0.5**k
        ov = _scaled(scene, finest_el * f, finest_step * f, min(scene.solver.tol, REFERENCE_TOL))
        if level_recs and len(level_recs) >= 2 and cache.get(_key_of(scene, ov)) is None:
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
        levels.append(
            {
                "level": k,
                "overrides": ov,
                "time_s": rec.time_s,
                "n_elements": rec.n_elements,
                "status": rec.status,
                "diff_to_previous_mm": diff,
            }
        )
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
    bar.close()
    ref = next((r for r in reversed(level_recs) if r.status == 0), None)
    if ref is None:
        raise AccuracyError(
            f"scene {scene.name}: no reference run succeeded ({levels[-1]['status']}: "
            f"{level_recs[-1].message}); fix the scene before studying its accuracy"
        )
    if not converged:
        warnings.append(
            f"reference not converged after {len(levels)} levels: the two finest levels differ by "
            f"{agreement:.3g} mm, more than a tenth of the smallest reported error "
            f"({smallest:.3g} mm); errors below ~{agreement:.2g} mm are not resolved"
        )
    tail, ratio = tail_estimate([lv["diff_to_previous_mm"] for lv in levels])
    if np.isfinite(tail) and np.isfinite(smallest) and tail > 0.1 * smallest:
        warnings.append(
            f"the reference levels converge slowly (each halving shrinks the change by only "
            f"{ratio:.2f}): its own error is estimated at {tail:.2g} mm (geometric tail), more "
            f"than a tenth of the smallest reported error ({smallest:.2g} mm)"
        )
    reference = ReferenceInfo(
        levels=tuple(levels),
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

    dose_model = dose_model_for(scene, ref.positions_mm)
    ref_dose = None
    if dose_model is not None:
        try:
            ref_dose = dose_model.dose(ref.positions_mm, ref.directions)
        except Exception as exc:
            warnings.append(f"dose errors not computed: {exc}")
            dose_model = None

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
            max_err_mm=_nanmax(pe),
            median_err_mm=_nanmedian(pe),
            max_err_deg=_nanmax(ae),
            median_err_deg=_nanmedian(ae),
            dose_err_pct=dose_error_pct(dose_model, rec.positions_mm, rec.directions, ref_dose)
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
    rec_row = recommend(table, target_mm)
    rec_ov = None
    if rec_row is not None:
        rec_ov = dict(grid_list[int(rec_row["run"])])
    else:
        warnings.append(f"no numerical setting in the grid meets {target_mm:g} mm")
    study = AccuracyStudy(
        scene_name=scene.name,
        table=table,
        reference=reference,
        target_mm=float(target_mm),
        recommended=rec_row,
        recommended_overrides=rec_ov,
        dose_points=dose_model.how if dose_model is not None else "not computed",
        out_dir=out,
        warnings=tuple(warnings),
        run_overrides=tuple(dict(g) for g in grid_list),
    )
    if out is not None:
        write_study(study, scene, out)
    return study


def _key_of(scene, overrides) -> str:
    s = scene.with_overrides(overrides) if overrides else scene
    return run_key(s.to_dict(), _salt(s))


def _dedupe(scene, grid_list: list[dict]) -> list[dict]:
    """Drop runs whose scene equals an earlier one (e.g. the scene's own settings spelled out)."""
    seen: set[str] = set()
    out = []
    for ov in grid_list:
        try:
            key = _key_of(scene, ov)
        except RingQAError as exc:
            raise AccuracyError(f"grid entry {ov}: {exc}") from None
        if key not in seen:
            seen.add(key)
            out.append(ov)
    return out


def _nanmax(a) -> float:
    a = np.asarray(a, float)
    return float(np.max(a)) if a.size and np.all(np.isfinite(a)) else math.nan


def _nanmedian(a) -> float:
    a = np.asarray(a, float)
    return float(np.median(a)) if a.size and np.all(np.isfinite(a)) else math.nan


def _finest_factors(scene, grid_list) -> tuple[float, float]:
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
    return el_f, st_f


class _NoBar:
    def update(self, n=1) -> None:
        pass

    def close(self) -> None:
        pass


def _progress(total: int, on: bool):
    if not on:
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, desc="accuracy runs", unit="run")


# ------------------------------------------------------------------------------------------------
# output
# ------------------------------------------------------------------------------------------------
def write_study(study: AccuracyStudy, scene, out_dir: str | Path) -> None:
    """Write ``accuracy.csv``, ``reference.csv``, ``accuracy.png``, ``recommended.toml`` and
    ``study.json`` into ``out_dir`` (atomically; the run cache stays beside them)."""
    from ringqa.outdir import staged_output
    from ringqa.provenance import Provenance

    with staged_output(out_dir) as stage:
        study.table.to_csv(stage / CSV_NAME, index=False, float_format="%.6g")
        import pandas as pd

        pd.DataFrame(
            [
                {**{k: v for k, v in lv.items() if k != "overrides"}, **lv["overrides"]}
                for lv in study.reference.levels
            ]
        ).to_csv(stage / REFERENCE_CSV, index=False, float_format="%.6g")
        plot_study(study, stage / PNG_NAME)
        if study.recommended_overrides is not None:
            write_recommended(study, scene, stage / TOML_NAME)
        info = {
            "scene": study.scene_name,
            "target_mm": study.target_mm,
            "recommended": study.recommended,
            "recommended_overrides": study.recommended_overrides,
            "reference": {
                "converged": study.reference.converged,
                "agreement_mm": study.reference.agreement_mm,
                "smallest_error_mm": study.reference.smallest_error_mm,
                "criterion": study.reference.criterion,
                "tail_estimate_mm": study.reference.tail_estimate_mm,
                "ratio": study.reference.ratio,
                "levels": list(study.reference.levels),
            },
            "recommendations": recommendation_summary(study),
            "dose_points": study.dose_points,
            "engine_fingerprint": engine_fingerprint(),
            "warnings": list(study.warnings),
            "provenance": Provenance.now(settings={"scene": study.scene_name}).as_dict(),
        }
        (stage / "study.json").write_text(json.dumps(_jsonable(info), indent=2))


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


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


def write_recommended(study: AccuracyStudy, scene, path: Path) -> None:
    """``recommended.toml``: the scene with the recommended settings, commented header."""
    import tomli_w

    rec_scene = scene.with_overrides(study.recommended_overrides or {})
    row = study.recommended or {}
    header = [
        f"# ringqa accuracy: cheapest settings meeting {study.target_mm:g} mm for {scene.name}",
        f"# claimed: max dwell error {row.get('max_err_mm', math.nan):.4g} mm, "
        f"{row.get('max_err_deg', math.nan):.3g} deg; "
        f"solve time {row.get('time_s', math.nan):.4g} s",
        f"# settings: {row.get('label', '')}",
        f"# reference converged: {study.reference.converged} "
        f"(two finest levels agree to {study.reference.agreement_mm:.3g} mm)",
    ]
    data = rec_scene.to_dict()
    data["description"] = (
        f"recommended by ringqa accuracy for {study.target_mm:g} mm: {row.get('label', '')}"
    )
    path.write_text("\n".join(header) + "\n" + tomli_w.dumps(_jsonable(data)))


def plot_study(study: AccuracyStudy, path: Path) -> None:
    """Log-log error vs time, each run labelled, the Pareto front marked, failures shown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = study.table
    fig = plt.figure(figsize=(14, 7))
    ax = fig.add_axes((0.07, 0.09, 0.6, 0.83))
    ok = (t["status"] == 0) & np.isfinite(t["max_err_mm"]) & (t["max_err_mm"] > 0)
    floor = study.reference.agreement_mm if np.isfinite(study.reference.agreement_mm) else 1e-6
    zero = (t["status"] == 0) & (t["max_err_mm"] <= 0)
    num, mod = ok & (t["kind"] == "numerical"), ok & (t["kind"] == "model")
    if num.any():
        ax.scatter(
            t.loc[num, "time_s"], t.loc[num, "max_err_mm"], c="C0", label="numerical settings"
        )
    if mod.any():
        ax.scatter(
            t.loc[mod, "time_s"],
            t.loc[mod, "max_err_mm"],
            c="C2",
            marker="s",
            label="model change (effect on/off, solver kind)",
        )
    front = t[t["pareto"]].sort_values("time_s")
    if len(front):
        ax.step(
            front["time_s"], front["max_err_mm"], where="post", c="C3", lw=1.5, label="Pareto front"
        )
        ax.scatter(
            front["time_s"], front["max_err_mm"], facecolors="none", edgecolors="C3", s=120, lw=1.5
        )
    ymax = float(np.nanmax(t.loc[ok, "max_err_mm"])) if ok.any() else 1.0
    ymin = float(np.nanmin(t.loc[ok, "max_err_mm"])) if ok.any() else floor
    if zero.any():
        ax.scatter(
            t.loc[zero, "time_s"],
            np.full(int(zero.sum()), max(ymin / 3, 1e-9)),
            marker="v",
            c="k",
            label="error below the reference's resolution",
        )
    bad = t["status"] != 0
    if bad.any():
        tb = t.loc[bad, "time_s"].fillna(t["time_s"].median())
        ax.scatter(
            tb,
            np.full(int(bad.sum()), ymax * 3),
            marker="x",
            c="k",
            s=60,
            label="jammed / failed (error not measured)",
        )
    key_lines = []
    placed: list[tuple[float, float]] = []
    for _, r in t.iterrows():
        rid = int(r["run"])
        status = "" if r["status"] == 0 else f" [{r['status_text']}]"
        err = f"{r['max_err_mm']:.3g} mm" if r["status"] == 0 else "no error"
        key_lines.append(f"#{rid:<2d} {r['label']}{status}: {r['time_s']:.3g} s, {err}")
        y = r["max_err_mm"] if r["status"] == 0 and r["max_err_mm"] > 0 else None
        if r["status"] != 0:
            y = ymax * 3
        if y is None or not np.isfinite(r["time_s"]):
            continue
        # stagger ids of (nearly) coincident points so that each stays readable
        lx, ly = math.log10(r["time_s"]), math.log10(y)
        n_near = sum(1 for px, py in placed if abs(px - lx) < 0.04 and abs(py - ly) < 0.04)
        placed.append((lx, ly))
        ax.annotate(
            f"#{rid}",
            (r["time_s"], y),
            fontsize=7,
            xytext=(4, 3 + 8 * n_near),
            textcoords="offset points",
        )
    fig.text(
        0.70,
        0.95,
        "runs (#: settings: time, max error)\n" + "\n".join(key_lines),
        fontsize=6,
        va="top",
        family="monospace",
    )
    ax.axhline(study.target_mm, c="C1", ls="--", lw=1, label=f"target {study.target_mm:g} mm")
    if study.recommended:
        ax.scatter(
            [study.recommended["time_s"]],
            [study.recommended["max_err_mm"]],
            marker="*",
            s=300,
            c="gold",
            edgecolors="k",
            zorder=5,
            label=f"recommended ({study.recommended['time_s']:.3g} s)",
        )
    if np.isfinite(study.reference.agreement_mm) and study.reference.agreement_mm > 0:
        ax.axhline(
            study.reference.agreement_mm,
            c="0.6",
            ls=":",
            lw=1,
            label="reference resolution (two finest levels)",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("solve time per run (s, JIT excluded, median of repeats)")
    ax.set_ylabel("max dwell position error vs converged reference (mm)")
    ax.set_title(f"Accuracy vs time: {study.scene_name}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def load_cached_runs(out_dir: str | Path) -> list[RunRecord]:
    """The runs cached in ``out_dir/runs.jsonl`` (for inspection)."""
    path = Path(out_dir) / CACHE_NAME
    if not path.is_file():
        return []
    return [RunRecord.from_json(x) for x in path.read_text().splitlines() if x.strip()]
