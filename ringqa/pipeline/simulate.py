"""The simulated source positions at the dwells, with their numerical error.

The cable is pushed to the advances ``s_ref - p`` of the reference dwells; a lumen narrower than
the cable is refused first, a run that fails to converge is repeated with a finer input
increment, and a jam is reported as :class:`SimulationJammedError` with where it stopped.

Every commissioning simulation is run twice (the accuracy study's rule, :mod:`ringqa.accuracy`):
at the commissioning settings (:data:`COMMISSION_ELEMENT_MM`, :data:`COMMISSION_INCREMENT_MM`),
and once more with every element length and the increment halved. The refined run's positions
are reported; the distance between the two runs is each dwell's ``numerical_error_mm`` (for a
first-order convergence it equals the refined run's error; the measured convergence is faster,
so it over-estimates it: ``benchmarks/bench_commission_numerics.py``). When that distance exceeds
:data:`NUMERICAL_ERROR_WARN_MM` the run is refined again (at most :data:`MAX_EXTRA_LEVELS` more
times) and the last two runs give the positions and the error; the report says so.

The channel simulated keeps :data:`~ringqa.geometry.stem.DEFAULT_STEM_M` of straight channel
before its first bend (:func:`~ringqa.geometry.stem.trim_to_stem`; the dwells keep their place in
space). That cut is a modelling choice the numerical error must cover (issue 28): when it dropped
straight shaft, the whole channel is run too, at the commissioning and the refined settings
(:class:`StemCheck`), and each dwell's error gains the distance of the whole channel's refined
run from the reported positions plus the whole channel's own error (its two runs' distance).

The engine is reached through an :class:`Engine` (its four functions), so tests and other engines
can stand in for :mod:`ringqa.simulation`: :func:`default_engine` is the real one.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ringqa import parallel as forked
from ringqa.errors import RingQAError, SimulationError
from ringqa.geometry import Channel
from ringqa.geometry.stem import trim_to_stem
from ringqa.parallel import ForkedCall
from ringqa.pipeline.dwells import PathDwells
from ringqa.pipeline.result import SimulationInfo
from ringqa.units import m_to_mm, mm_to_m

#: Cable preset simulated for each TG-43 source (its afterloader's cable); other sources get the
#: Flexitron cable, and the report says so.
SOURCE_CABLE = {"flexisource": "flexitron", "mhdr-v2": "microselectron"}
#: The cable used when the source has none of its own.
FALLBACK_CABLE = "flexitron"

#: Element lengths of the commissioning runs per cable preset and section, mm (the refined run
#: halves them): chosen from the measurements in docs/commissioning.md (numerical error <= 0.05 mm
#: on the example and the six shipped rings; the paper's 3/10 mm gave up to 0.12 mm).
COMMISSION_ELEMENT_MM: dict[str, dict[str, float]] = {
    "flexitron": {"thin": 2.0, "thick": 5.0},
    "microselectron": {"cable": 2.0},
}
#: Input increment of the commissioning runs (quasi-static), mm (the refined run halves it).
COMMISSION_INCREMENT_MM = 1.0
#: Refinement factor of the second run (element lengths and increment).
REFINE_FACTOR = 0.5
#: When the two runs differ by more than :data:`NUMERICAL_ERROR_WARN_MM`, refine (and run) again,
#: at most this many more times.
MAX_EXTRA_LEVELS = 2
#: When a run needed the fallback stabilisation (the cable stuck and snapped), the quasi-static
#: path can branch, and where it branches depends on the settings: two more runs at these
#: factors of the commissioning settings (the refined run's x 0.8 and x 0.7) probe it; each
#: dwell's error is the largest distance of any of them from the refined run.
PROBE_FACTORS = (0.4, 0.35)
#: When the probes put dwells more than :data:`NUMERICAL_ERROR_WARN_MM` apart (the path branches
#: at these settings), two much finer runs at these factors of the commissioning settings settle
#: it: below about 1/5 the branch the cable takes stops depending on the settings (measured on
#: the Oncentra example with the microSelectron cable: links 0.4 -> 0.3 -> 0.2 -> 0.15 mm at
#: half-link increments move the dwells 0.03, 0.03, 0.01 mm, coarser runs hop between branches
#: 0.3 mm apart; docs/commissioning.md). Their distance is the reported error.
RESOLVE_FACTORS = (0.2, 0.1)
#: Numerical error (max over the dwells) above which the report warns, mm.
NUMERICAL_ERROR_WARN_MM = 0.1
#: Run the independent engine runs of the numerical check two at a time (the commissioning run
#: here, the refined one in a forked child process; the probes likewise) where ``os.fork`` exists,
#: the machine has two cores, one of them free (:func:`ringqa.parallel.second_core_free`)
#: and the kernel cache is warm (:func:`kernels_cached`). The results are those of running them
#: one after the other (the child runs the same code on the same scene); a batch's worker
#: processes switch it off (they already use the cores). Only ringqa's own engine is run so: a
#: stand-in engine's side effects (a test's record of its calls) stay in this process.
CONCURRENT_RUNS = True


#: Measure what the modelled stem's cut moves (:class:`StemCheck`) whenever the cut dropped
#: straight shaft: the whole channel at the commissioning and the refined settings. Measured on the
#: example (microSelectron cable, 133 mm of shaft dropped; benchmarks/bench_commission_numerics.py
#: "Modelled stem"): the whole channel's runs at 1, 1/2, 1/4 and 1/8 of the commissioning settings
#: lie 0.28-0.44 mm from the reported (60 mm stem) positions and 0.42-0.57 mm from each other (the
#: cable buckles in the 193 mm shaft and where it settles depends on the settings); a single
#: probe at the commissioning settings falls short of the 1/4 run by up to 0.19 mm, the sum
#: :class:`StemCheck` adds covers it.
STEM_CHECK = True


@dataclass(frozen=True, eq=False)
class StemCheck:
    """What simulating the whole channel instead of the modelled stem does to the dwells.

    Attributes
    ----------
    stem_mm, dropped_mm : float
        Straight channel kept before the first bend, and the straight shaft left out, mm.
    distance_mm : (n,) ndarray
        Per dwell (the reference's order): distance of the whole channel's refined run from the
        reported positions, mm (zeros when ``ok`` is False).
    whole_error_mm : (n,) ndarray
        Per dwell: distance between the whole channel's runs at the commissioning and the refined
        settings (its own numerical error), mm.
    added_mm : (n,) ndarray
        ``distance_mm + whole_error_mm``: what each dwell's numerical error gains, mm.
    ok : bool
        Both whole-channel runs reached every dwell (else nothing is added and ``text`` says so).
    solve_time_s : float
        The two runs' solve time, s.
    text : str
        For the report.
    """

    stem_mm: float
    dropped_mm: float
    distance_mm: np.ndarray
    whole_error_mm: np.ndarray
    added_mm: np.ndarray
    ok: bool
    solve_time_s: float
    text: str

    @property
    def max_mm(self) -> float:
        """Largest ``added_mm`` (0 when not measured)."""
        return float(np.max(self.added_mm)) if self.added_mm.size else 0.0

    def as_dict(self) -> dict:
        """The ``results.json`` ``numerical_check.stem_check`` section."""
        d, w = self.distance_mm, self.whole_error_mm
        return {
            "stem_mm": self.stem_mm,
            "dropped_mm": self.dropped_mm,
            "ok": self.ok,
            "max_distance_mm": float(np.max(d)) if d.size else 0.0,
            "median_distance_mm": float(np.median(d)) if d.size else 0.0,
            "max_whole_channel_error_mm": float(np.max(w)) if w.size else 0.0,
            "max_added_mm": self.max_mm,
            "added_mm_per_dwell": [float(x) for x in self.added_mm],
            "solve_time_s": self.solve_time_s,
            "text": self.text,
        }


#: The cross-check (issue 28): the flexible-element engine (``model.formulation = "flexible"``)
#: runs once beside the rigid runs (at :data:`CROSS_CHECK_ELEMENT_FACTOR`); the dwells' largest
#: disagreement above max(:data:`CROSS_CHECK_MIN_MM`, 2 x the combined numerical error) fails
#: the numerics. On by default in ``ringqa commission`` (``--no-cross-check`` turns it off).
CROSS_CHECK_MIN_MM = 0.2
#: The cross-check's flexible run: every element length of the commissioning scene times this,
#: the increment unchanged. Its cubic elements' discretisation error is small next to the
#: increment's (docs/engine.md, "Convergence and cost per accuracy"); measured on the four
#: agreement scenes with ``benchmarks/flexible_agreement.py --cross-check`` (see
#: CROSS_CHECK_FLEXIBLE_ERROR_MM) at 40-60 % of the CPU time of the commissioning element lengths.
CROSS_CHECK_ELEMENT_FACTOR = 2.0
#: The flexible engine's own numerical error at the cross-check settings, mm (taken, with margin,
#: from the measurements named at :data:`CROSS_CHECK_ELEMENT_FACTOR`: up to 0.049 mm from its own
#: x0.25 run on ring26-flexitron, 0.031 on ring13-push100, 0.008 on needle-paper; on the
#: example's commissioning run 0.048 mm from the rigid x0.25 run, its own x0.25 run taking
#: another branch there).
CROSS_CHECK_FLEXIBLE_ERROR_MM = 0.06
#: The report's line when the cross-check was switched off.
CROSS_CHECK_OFF_TEXT = (
    "Cross-check with an independent engine (flexible beam elements): switched off "
    "(--no-cross-check or simulation.cross_check = false), so the simulated positions rest on "
    "the rigid-link engine alone."
)


@dataclass(frozen=True)
class CrossCheck:
    """The flexible engine's dwells against the reported (rigid, refined) ones.

    Attributes
    ----------
    disagreement_mm : (n,) ndarray
        Per dwell (the reference's order): distance between the two engines' source centres, mm
        (NaN where the flexible run did not get).
    max_mm : float
        Largest disagreement (NaN when the flexible run failed).
    limit_mm : float
        max(CROSS_CHECK_MIN_MM, 2 x (the rigid runs' numerical error + the flexible engine's)).
    fails : bool
        ``max_mm > limit_mm``.
    ok : bool
        The flexible run reached every dwell.
    solve_time_s, wall_time_s : float
        What the flexible run cost (s): its solve time, and the wall time from its start to its
        result (when it ran on the second core beside the rigid runs, most of that overlapped
        them).
    flexible_pos_mm : (n, 3) ndarray
        Its source centres (the reference's order), for plotting beside the rigid ones.
    text : str
        One line for the report.
    settings : dict
        The flexible run's numerical settings (dotted keys, user units).
    concurrent : bool
        It ran in a forked process beside the rigid runs.
    added_wall_s : float
        Wall time the command waited for it after the rigid runs (s; its whole wall time when it
        ran after them).
    relative_position_mm : (n,) ndarray or None
        The dwells' relative positions (mm, the order of the arrays above; None: not recorded).
    """

    disagreement_mm: np.ndarray
    max_mm: float
    limit_mm: float
    fails: bool
    ok: bool
    solve_time_s: float
    wall_time_s: float
    flexible_pos_mm: np.ndarray
    text: str
    settings: dict = field(default_factory=dict)
    concurrent: bool = False
    added_wall_s: float = 0.0
    relative_position_mm: np.ndarray | None = None

    def as_dict(self) -> dict:
        """The ``results.json`` ``numerical_check.cross_check`` section."""
        return {
            "max_disagreement_mm": self.max_mm,
            "limit_mm": self.limit_mm,
            "fails": self.fails,
            "ok": self.ok,
            "solve_time_s": self.solve_time_s,
            "wall_time_s": self.wall_time_s,
            "text": self.text,
            "settings": dict(self.settings),
            "concurrent": self.concurrent,
            "added_wall_s": self.added_wall_s,
        }


class SimulationJammedError(RingQAError):
    """The simulated cable jammed (or the engine failed) before reaching every dwell."""


@dataclass(frozen=True)
class Engine:
    """The four engine functions the pipeline calls (:func:`default_engine`: ringqa's own).

    Attributes
    ----------
    simulate : callable
        ``simulate(scene, advances_mm=(n,) mm, progress=bool)`` -> a result with ``status``
        (0 ok, 1 jammed, -1 failed), ``message``, ``advances_mm`` (n,), ``source_pos_m`` (n, 3)
        and ``source_dir`` (n, 3); optionally ``warnings``, ``solve_time_s``, ``n_elements``,
        ``settings``.
    scene_for_channel : callable
        ``scene_for_channel(channel, cable)`` -> a scene (with ``instrument.sections[].r_o_m``,
        ``motion``, ``solver.increment_m``, ``instrument.afterloader`` where it has them).
    scene_with_overrides : callable
        ``scene_with_overrides(scene, {dotted key: value})`` -> a new scene.
    scene_to_dict : callable
        ``scene_to_dict(scene)`` -> the scene in user units (for provenance).
    refine : callable or None
        ``refine(scene, factor)`` -> the scene with every element length and the increment (or
        time step) times ``factor``; None: :func:`refine_scene` (ringqa's scenes).
    """

    simulate: Callable[..., Any]
    scene_for_channel: Callable[..., Any]
    scene_with_overrides: Callable[[Any, Mapping[str, Any]], Any]
    scene_to_dict: Callable[[Any], dict]
    refine: Callable[[Any, float], Any] | None = None


def refine_scene(scene, factor: float):
    """``scene`` with every flexible section's element length and the increment (or time step)
    times ``factor`` (:func:`ringqa.accuracy.scaled_overrides`)."""
    from ringqa.accuracy import scaled_overrides
    from ringqa.simulation.scenefile import scene_with_overrides

    return scene_with_overrides(scene, scaled_overrides(scene, factor, factor))


def default_engine() -> Engine:
    """ringqa's engine: :func:`ringqa.simulation.simulate` and the scene functions of
    :mod:`ringqa.simulation.scenefile` (imported on first use: importing the pipeline stays
    light)."""
    from ringqa.simulation import simulate
    from ringqa.simulation.scenefile import scene_for_channel, scene_to_dict, scene_with_overrides

    return Engine(simulate, scene_for_channel, scene_with_overrides, scene_to_dict)


@dataclass(frozen=True, eq=False)
class CableChoice:
    """The cable simulated and why.

    Attributes
    ----------
    preset : str
        Instrument preset name.
    note : str
        For the report: which cable model, where its numbers come from, and whether they are
        borrowed from another cable.
    """

    preset: str
    note: str


def choose_cable(cable: str | None, source_name: str) -> CableChoice:
    """The cable preset: as given, else the one of the source's afterloader (Flexitron for a
    source without its own cable model).

    Parameters
    ----------
    cable : str or None
        The user's choice (``--cable``); None: from the source.
    source_name : str
        The plan's TG-43 source name.
    """
    from ringqa.simulation.instruments import BORROWED_MECHANICS, CABLE_PRESETS, PRESET_SOURCES

    cables = [name for name in CABLE_PRESETS if name != "catheter"]
    if cable is not None and cable not in cables:
        raise RingQAError(
            f"--cable {cable!r}: unknown cable model; choose one of {', '.join(cables)} (or "
            "leave it out: the cable of the plan's source)"
        )
    if cable is not None:
        preset, why = cable, "chosen in the settings"
    elif source_name in SOURCE_CABLE:
        preset, why = SOURCE_CABLE[source_name], f"the cable of the {source_name} source"
    else:
        preset = FALLBACK_CABLE
        why = (
            f"the {source_name} source has no cable model in ringqa: the Flexitron cable is "
            "BORROWED"
        )
    text = f"Cable model: {preset} ({why}). {PRESET_SOURCES.get(preset, 'custom instrument')}."
    if preset in BORROWED_MECHANICS:
        text += (
            " Its mechanics are borrowed from another cable: the simulated positions assume them."
        )
    return CableChoice(preset, text)


@dataclass(frozen=True, eq=False)
class NumericalCheck:
    """How far the simulated dwells are from converged: the commissioning run vs a refined run.

    Attributes
    ----------
    error_mm : (n,) ndarray
        Per dwell (the reference's order): distance between the two runs' source centres, mm,
        plus what the modelled stem's cut moves it (``stem.added_mm``, when measured).
    max_mm, median_mm : float
        Largest and median of ``error_mm``.
    settings : dict
        The numerical settings (dotted keys, user units) of the last-but-one run.
    refined_settings : dict
        The last (reported) run's.
    solve_time_s, refined_solve_time_s : float
        The two runs' solve times, s.
    n_runs : int
        Runs made: 2, or more when the error exceeded the warning level and the run was
        refined again (at most ``2 + MAX_EXTRA_LEVELS``), plus the probes.
    n_probes : int
        Runs that probed where a stalling path branches (:data:`PROBE_FACTORS`; 0 when no run
        needed the fallback stabilisation).
    branch_mm : float
        Largest distance the probes found between runs at the commissioning settings' scale, mm
        (0 without probes). When it exceeded the warning level the run was resolved with two
        much finer runs (:data:`RESOLVE_FACTORS`; ``resolved``) and ``error_mm`` is theirs.
    resolved : bool
        The reported positions come from the resolving runs.
    cross_check : CrossCheck or None
        The flexible engine's run beside the rigid ones (None: not run, ``cross_check=False``).
    stem : StemCheck or None
        The whole channel's runs (None: nothing was cut, or ``stem_check=False``).
    total_solve_time_s : float
        Solve time of all runs, s.
    stabilised_steps : int
        Load steps of the reported (refined) run that needed the fallback stabilisation.
    text : tuple of str
        Plain-language statements for the report.
    """

    error_mm: np.ndarray
    max_mm: float
    median_mm: float
    settings: dict
    refined_settings: dict
    solve_time_s: float
    refined_solve_time_s: float
    stabilised_steps: int
    text: tuple[str, ...]
    n_runs: int = 2
    total_solve_time_s: float = 0.0
    n_probes: int = 0
    branch_mm: float = 0.0
    resolved: bool = False
    cross_check: CrossCheck | None = None
    stem: StemCheck | None = None

    @property
    def discretisation_mm(self) -> np.ndarray:
        """Per dwell: the error without the modelled stem's share (``error_mm - stem.added_mm``)."""
        return self.error_mm if self.stem is None else self.error_mm - self.stem.added_mm

    @property
    def warns(self) -> bool:
        """The largest error exceeds :data:`NUMERICAL_ERROR_WARN_MM`."""
        return self.max_mm > NUMERICAL_ERROR_WARN_MM

    def as_dict(self) -> dict:
        """The ``results.json`` ``numerical_check`` section."""
        return {
            "max_numerical_error_mm": self.max_mm,
            "median_numerical_error_mm": self.median_mm,
            "warn_above_mm": NUMERICAL_ERROR_WARN_MM,
            "settings": dict(self.settings),
            "refined_settings": dict(self.refined_settings),
            "solve_time_s": self.solve_time_s,
            "refined_solve_time_s": self.refined_solve_time_s,
            "stabilised_steps": self.stabilised_steps,
            "n_runs": self.n_runs,
            "n_probes": self.n_probes,
            "total_solve_time_s": self.total_solve_time_s,
            "text": list(self.text),
            "branch_mm": self.branch_mm,
            "resolved": self.resolved,
            "cross_check": None if self.cross_check is None else self.cross_check.as_dict(),
            "stem_check": None if self.stem is None else self.stem.as_dict(),
        }


@dataclass(frozen=True, eq=False)
class SimulatedDwells:
    """The engine's source positions at the reference dwells, and how the run went.

    Attributes
    ----------
    dwells : PathDwells
        Source centres (n, 3) in mm and unit directions (n, 3), in the reference's order (the
        refined run).
    info : SimulationInfo
        The refined run.
    numerics : NumericalCheck
        Commissioning run vs refined run.
    scene : dict
        The scene simulated (refined run), in user units (empty if it could not be written).
    afterloader : str
        The afterloader whose cable was simulated.
    stem : TrimmedChannel or None
        How the channel was shortened before simulating (None: not shortened).
    notes : tuple of str
        For the report (a retry with a finer increment, the modelled stem).
    """

    dwells: PathDwells
    info: SimulationInfo
    numerics: NumericalCheck
    scene: dict
    afterloader: str
    stem: Any
    notes: tuple[str, ...]


def instrument_radii_m(engine: Engine | None, channel, preset: str) -> tuple[float, float]:
    """``(capsule radius, largest radius)`` of the instrument ``preset``, m (the capsule is its
    most distal section); ``engine`` (default :func:`default_engine`) builds the scene of a
    preset ringqa does not ship."""
    from ringqa.simulation.instruments import CABLE_PRESETS

    if preset in CABLE_PRESETS:
        sections = CABLE_PRESETS[preset].sections
    else:
        engine = engine or default_engine()
        sections = engine.scene_for_channel(channel, preset).instrument.sections
    return float(sections[0].r_o_m), max(float(s.r_o_m) for s in sections)


def _cable_radius_m(scene) -> float | None:
    inst = getattr(scene, "instrument", None)
    sections = getattr(inst, "sections", None)
    if not sections:
        return None
    return max(float(s.r_o_m) for s in sections)


def check_clearance(app, channel, r_cable: float | None) -> None:
    """Refuse a lumen narrower than the cable (or source capsule) of radius ``r_cable`` (m)."""
    lumen = getattr(channel, "lumen", None)
    if r_cable is None or lumen is None or not hasattr(lumen, "kernel_arrays"):
        return
    seg_rb = np.asarray(lumen.kernel_arrays()[1], dtype=float)
    if seg_rb.size and float(seg_rb.min()) <= r_cable:
        raise RingQAError(
            f"applicator {app.name}, channel {channel.name}: lumen radius "
            f"{m_to_mm(float(seg_rb.min())):.2f} mm is not larger than the cable/source radius "
            f"{m_to_mm(r_cable):.2f} mm: the cable cannot pass (check the lumen diameter in the "
            "applicator file or the instrument preset)"
        )


#: Refinements of the input increment tried when the engine FAILS to converge (status -1; a
#: jam, status 1, is a result and is not retried): the scene's increment times these factors.
RETRY_INCREMENT_FACTORS = (0.5, 0.25)


@dataclass(frozen=True, eq=False)
class _Run:
    """One engine run at the advances (retried with finer increments when it failed)."""

    res: Any
    status: int
    pos_m: np.ndarray
    ok: bool
    scene: Any
    wall_s: float
    note: str


def _run_engine(simulate, scene, advances, progress: bool = False):
    res = simulate(scene, advances_mm=advances, progress=progress)
    status = int(res.status)
    pos_m = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
    ok = status == 0 and pos_m.shape[0] >= advances.size and bool(np.all(np.isfinite(pos_m)))
    return res, status, pos_m, ok


def _run_with_retries(engine: Engine, scene, advances, progress: bool) -> _Run:
    """Run the engine; a run that FAILED to converge (status -1) is repeated with the increment
    times :data:`RETRY_INCREMENT_FACTORS` (a jam, status 1, is a result and is not retried)."""
    t0 = time.perf_counter()
    res, status, pos_m, ok = _run_engine(engine.simulate, scene, advances, progress)
    inc_m = getattr(getattr(scene, "solver", None), "increment_m", None)
    note = ""
    if not ok and status == -1 and inc_m:
        first_message = str(res.message)
        for factor in RETRY_INCREMENT_FACTORS:
            inc_mm = m_to_mm(float(inc_m)) * factor
            retry = engine.scene_with_overrides(scene, {"solver.increment_mm": inc_mm})
            res, status, pos_m, ok = _run_engine(engine.simulate, retry, advances, progress)
            if ok:
                note = (
                    f"The simulation did not converge with an input increment of "
                    f"{m_to_mm(float(inc_m)):g} mm ({first_message}); it was repeated with "
                    f"{inc_mm:g} mm, which converged (solver.increment_mm = {inc_mm:g})."
                )
                scene = retry
                break
    return _Run(res, status, pos_m, ok, scene, time.perf_counter() - t0, note)


def own_engine(engine: Engine) -> bool:
    """``engine`` runs ringqa's own simulation (not a stand-in, whose side effects, such as a
    test's record of its calls, must stay in this process)."""
    import ringqa.simulation

    return engine.simulate is getattr(ringqa.simulation, "simulate", None)


def kernels_cached() -> bool:
    """The engine's Newton kernel has a numba disk-cache index older than this process (False
    when that cannot be told): its runs may go to forked processes. On a first run, with numba
    compiling, each process would compile the same kernels again (measured: the example's
    first run 22 -> 34 s of compile wall)."""
    try:
        from ringqa.simulation.solvers.newton import newton

        index = Path(newton._cache._cache_file._index_path)
        proc = Path(f"/proc/{os.getpid()}")
        started = proc.stat().st_ctime if proc.exists() else _IMPORTED_AT
        return index.stat().st_mtime < started
    except Exception:
        return False


def second_core_worthwhile(engine: Engine | None = None) -> bool:
    """Independent work may go to a forked process: ``engine`` is ringqa's own (None: the
    default), its kernels are cached (:func:`kernels_cached`: a first run compiles once) and a
    core is free (:func:`ringqa.parallel.second_core_free`)."""
    return (engine is None or own_engine(engine)) and kernels_cached() and forked.second_core_free()


#: when this module was imported (s since the epoch): the process's start where /proc is missing
_IMPORTED_AT = time.time()


def _run_two(
    first: Callable[[], _Run], second: Callable[[], _Run], fork: bool = True
) -> tuple[_Run, _Run]:
    """``(first(), second())``: ``second`` in a forked child while ``first`` runs here (with
    ``fork``)."""
    other = ForkedCall(second, fork and CONCURRENT_RUNS)
    try:
        a = first()
    except BaseException:
        other.cancel()
        raise
    return a, other.result()


def _jammed(app, run: _Run, advances, s_ref_mm: float) -> SimulationJammedError:
    got_adv = np.asarray(run.res.advances_mm, dtype=float).reshape(-1)
    n = min(run.pos_m.shape[0], got_adv.size)
    finite = np.all(np.isfinite(run.pos_m[:n]), axis=1)
    reached = got_adv[:n][finite]
    where = (
        f"after advance {reached[-1]:.1f} mm (relative position "
        f"{s_ref_mm - reached[-1]:.1f} mm; {reached.size} of {advances.size} dwells reached)"
        if reached.size
        else "before the first dwell"
    )
    kind = "jammed" if run.status == 1 else "failed"
    return SimulationJammedError(
        f"applicator {app.name}: the simulated source cable {kind} {where}: "
        f"{run.res.message or 'no message'} (check the lumen and the scene "
        "settings, e.g. --set solver.increment_mm=0.25 or --set effects.friction=coulomb)"
    )


def _dwell_rows(run: _Run, advances, wanted_mm) -> np.ndarray:
    """Row of each wanted advance (mm) in the run's output."""
    got_adv = np.asarray(run.res.advances_mm, dtype=float).reshape(-1)
    lookup = {round(float(a), 6): i for i, a in enumerate(got_adv)}
    idx = []
    for a in wanted_mm:
        i = lookup.get(round(float(a), 6))
        if i is None:  # tolerate rounding in the engine's echo of the advances
            i = int(np.argmin(np.abs(got_adv - a)))
            if abs(got_adv[i] - a) > 1e-3:
                raise SimulationError(f"the simulation did not report advance {a:.3f} mm")
        idx.append(i)
    return np.asarray(idx, dtype=int)


def _numeric_settings(scene_dict: dict) -> dict:
    """The numerical settings of a scene (element lengths, increment or time step), user units."""
    out: dict = {}
    disc = scene_dict.get("discretisation", {})
    if isinstance(disc, Mapping) and "element_length_mm" in disc:
        out["discretisation.element_length_mm"] = disc["element_length_mm"]
    solver = scene_dict.get("solver", {})
    if isinstance(solver, Mapping):
        for key in ("increment_mm", "time_step_s"):
            if solver.get(key) is not None:
                out[f"solver.{key}"] = solver[key]
    for key, value in scene_dict.items():  # stand-in engines: flat dotted keys
        if key.startswith(("discretisation.", "solver.increment_mm", "solver.time_step_s")):
            out[key] = value
    return out


def _scene_dict(engine: Engine, scene) -> dict:
    try:
        return engine.scene_to_dict(scene)
    except Exception:  # provenance must not break a run
        return {}


def commission_scene(engine: Engine, channel, cable: str, scene_overrides: Mapping[str, Any]):
    """The scene of a commissioning run: the preset's scene for ``channel`` at the commissioning
    element lengths and increment (:data:`COMMISSION_ELEMENT_MM`), then the user's overrides."""
    scene = engine.scene_for_channel(channel, cable)
    defaults: dict[str, Any] = {"solver.increment_mm": COMMISSION_INCREMENT_MM}
    if cable in COMMISSION_ELEMENT_MM:
        defaults["discretisation.element_length_mm"] = dict(COMMISSION_ELEMENT_MM[cable])
    scene = engine.scene_with_overrides(scene, defaults)
    if scene_overrides:
        scene = engine.scene_with_overrides(scene, dict(scene_overrides))
    return scene


def _stabilised(run: _Run) -> int:
    """Load steps of a run that needed the fallback stabilisation."""
    settings = run.res.settings or {}
    return int(settings.get("n_stabilised_steps", 0) or 0)


def numerical_text(
    error_mm: np.ndarray,
    stabilised: int,
    n_steps: int | None,
    pair_mm: np.ndarray | None = None,
    n_probes: int = 0,
    branch_mm: float = 0.0,
    resolved: bool = False,
    stem: StemCheck | None = None,
) -> tuple[str, ...]:
    """The numerical check in plain words (report page 1).

    Parameters
    ----------
    error_mm : (n,) ndarray
        Per-dwell numerical error, mm.
    stabilised : int
        Load steps of the reported run that needed the fallback stabilisation.
    n_steps : int or None
        Load steps of that run, when known.
    pair_mm : (n,) ndarray, optional
        Per-dwell distance between the commissioning and the refined run (default ``error_mm``).
    n_probes : int
        Extra runs that probed where the path branches.
    branch_mm : float
        Largest distance the probes found, mm.
    resolved : bool
        The branching was settled by two much finer runs (:data:`RESOLVE_FACTORS`), whose
        distance is ``error_mm``.
    stem : StemCheck, optional
        The modelled stem's check: its share (``stem.added_mm``) is added to ``error_mm`` in the
        reported error, and said first.
    """
    worst, median = float(np.max(error_mm)), float(np.median(error_mm))
    pair = error_mm if pair_mm is None else pair_mm
    if resolved:
        f_coarse, f_fine = RESOLVE_FACTORS
        out = [
            f"Numerical error of the simulated positions: up to {worst:.3f} mm (median "
            f"{median:.3f} mm): how far each dwell moves between two fine runs (every cable link "
            f"and the push increment at 1/{1 / f_coarse:.0f} and 1/{1 / f_fine:.0f} of the "
            "commissioning settings); the finer run's positions are reported.",
            f"They were needed because at the commissioning settings the cable sticks and snaps "
            f"over to another wall contact, and runs with slightly different settings put some "
            f"dwells up to {branch_mm:.2f} mm apart (several cable positions are nearly in "
            "balance there); at the fine settings the runs agree on one of them.",
        ]
    else:
        out = [
            f"Numerical error of the simulated positions: up to {worst:.3f} mm (median "
            f"{median:.3f} mm): how far each dwell moves when every cable link and the push "
            "increment are halved"
            + (" or changed slightly" if n_probes else "")
            + "; the refined positions are reported."
        ]
    if n_probes and not resolved and worst > float(np.max(pair)) + 1e-9:
        out.append(
            f"Halving the settings alone moves the dwells by up to {float(np.max(pair)):.3f} mm, "
            f"but {n_probes} runs with slightly different settings put some dwells up to "
            f"{worst:.3f} mm apart: the cable sticks and snaps over to another wall contact, and "
            "where it does so depends on small changes."
        )
    if worst > NUMERICAL_ERROR_WARN_MM:
        branching = n_probes and not resolved and float(np.max(pair)) <= NUMERICAL_ERROR_WARN_MM
        out.append(
            f"WARNING: the simulated positions are uncertain by up to {worst:.2f} mm, more than "
            f"{NUMERICAL_ERROR_WARN_MM:g} mm"
            + (
                ", because the cable can settle in more than one position there; treat "
                "simulated-vs-reference differences of that size at those dwells as undecided "
                "at these settings, or run much finer ones (--set "
                "discretisation.element_length_mm.<section>=..., --set solver.increment_mm=...)."
                if branching
                else ", because of the numerical settings; treat simulated-vs-reference "
                "differences of that size as numerics, or refine the run (--set "
                "discretisation.element_length_mm.<section>=..., --set solver.increment_mm=...)."
            )
        )
    if stabilised:
        of = f" of {n_steps}" if n_steps else ""
        out.append(
            f"In {stabilised}{of} push steps the cable jumped from one wall contact to another "
            "(or stuck and slipped) and the solver damped the jump to follow it; the numerical "
            "error above includes the effect of this on the dwells."
        )
    if stem is not None:
        _with_stem(out, np.asarray(error_mm, dtype=float), stem)
    return tuple(out)


def _with_stem(out: list[str], error_mm: np.ndarray, stem: StemCheck) -> None:
    """In place: :func:`numerical_text`'s lines with the modelled stem's share said (first the
    total that the report prints, then the discretisation's share, then the stem's)."""
    if not stem.ok:
        out.insert(1, stem.text)
        return
    total = error_mm + stem.added_mm
    worst = float(np.max(total))
    out[0] = out[0].replace(
        "Numerical error of the simulated positions:", "Of that, the discretisation:", 1
    )
    out[:0] = [
        f"Numerical error of the simulated positions, the modelled stem included: up to "
        f"{worst:.3f} mm (median {float(np.median(total)):.3f} mm)."
    ]
    out.insert(2, stem.text)
    if worst > NUMERICAL_ERROR_WARN_MM >= float(np.max(error_mm)):
        out.append(
            f"WARNING: the simulated positions are uncertain by up to {worst:.2f} mm, more than "
            f"{NUMERICAL_ERROR_WARN_MM:g} mm, because of the straight shaft the simulation "
            "leaves out (above): the model does not fix where the cable settles there; treat "
            "simulated-vs-reference differences of that size as undecided by the simulation."
        )


def simulate_dwells(
    app,
    channel,
    relative_position_mm,
    *,
    cable: str,
    scene_overrides: Mapping[str, Any],
    engine: Engine | None = None,
    progress: bool = False,
    stem_mm: float | None = None,
    cross_check: bool | None = None,
    stem_check: bool | None = None,
) -> SimulatedDwells:
    """Simulate the cable to the dwells at ``relative_position_mm``, twice (commissioning and
    refined settings); results in their order.

    Parameters
    ----------
    app : Applicator
    channel : Channel
        The channel simulated.
    relative_position_mm : (n,) array_like
        Relative positions p of the dwells, mm: the cable is pushed to the advances s_ref - p.
    cable : str
        Instrument preset.
    scene_overrides : mapping
        Dotted scene keys -> values (user units), applied over the commissioning settings.
    engine : Engine, optional
        Default :func:`default_engine`.
    progress : bool
        Show the engine's progress bar.
    stem_mm : float or None
        Straight channel kept before the first bend, mm (None: the whole channel).
    cross_check : bool or None
        True: also run the flexible-element engine once and compare (:func:`start_cross_check`;
        ringqa's own engine only; on the second core beside the rigid runs where one is free).
        False: switched off, and the numerical-check text says so. None: not asked (no line).
    stem_check : bool, optional
        When ``stem_mm`` cut straight shaft off the channel, also run the whole channel at the
        commissioning and the refined settings and add what the cut moves to each dwell's error
        (:class:`StemCheck`); default :data:`STEM_CHECK`.

    Returns
    -------
    SimulatedDwells

    Raises
    ------
    RingQAError
        The lumen is not wider than the cable.
    SimulationJammedError
        The cable jammed, or the engine failed even with a finer increment.
    """
    engine = engine or default_engine()
    rel_mm = np.asarray(relative_position_mm, dtype=float)
    notes: list[str] = []
    stem = None
    whole_channel = channel
    if stem_mm is not None and isinstance(channel, Channel):
        stem = trim_to_stem(channel, mm_to_m(stem_mm))
        if stem.dropped_m > 0:
            channel = stem.channel
            notes.append(
                f"Modelled channel: the simulation keeps {stem_mm:g} mm of straight channel "
                f"before the first bend and leaves out the {m_to_mm(stem.dropped_m):.1f} mm of "
                "straight shaft before it (the cable there only passes the push force on; see "
                "docs/commissioning.md for what this moves)."
            )
        else:
            stem = None
    scene = commission_scene(engine, channel, cable, scene_overrides)
    check_clearance(app, channel, _cable_radius_m(scene))
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel_sorted = np.sort(np.unique(np.round(rel_mm, 9)))[::-1]
    advances = s_ref_mm - rel_sorted  # increasing: the cable is pushed in, proximal -> distal
    motion = getattr(scene, "motion", None)
    if getattr(motion, "backward", False) or getattr(motion, "kind", "") == "retract":
        advances = advances[::-1]  # backward stepping / retraction: most distal dwell first
    wanted = s_ref_mm - rel_mm
    refine = engine.refine or refine_scene

    def distance(a: _Run, b: _Run) -> np.ndarray:
        """Per-dwell distance between two runs' source centres, mm (``wanted``'s order)."""
        return m_to_mm(np.linalg.norm(
            a.pos_m[_dwell_rows(a, advances, wanted)] - b.pos_m[_dwell_rows(b, advances, wanted)],
            axis=1))  # fmt: skip

    fork = second_core_worthwhile(engine)
    # the flexible engine's cross-check (its own kernels) starts at once beside the rest
    xpending = start_cross_check(engine, scene, advances, None, rel_mm) if cross_check else None
    whole_check = stem is not None and (STEM_CHECK if stem_check is None else stem_check)
    whole = None
    # without the modelled stem's check, the refined run's scene does not depend on the
    # commissioning run's result (unless that run had to be retried with a finer increment):
    # both run at once. With it, the whole channel's refined run (the longest of all, about
    # three times the refined run's cost) takes the second core instead, forked right after the
    # commissioning run (which loads the engine's kernels, so the child does not load them
    # again), and the refined run, the probes and the whole channel's commissioning-settings
    # run follow here (the same runs with the same results in either order; on one core, or
    # without a free one, they all run here one after the other)
    ahead = ForkedCall(lambda: _run_with_retries(engine, refine(scene, REFINE_FACTOR), advances,
                                                 False),
                       fork and CONCURRENT_RUNS and not whole_check)  # fmt: skip
    try:
        runs = [_run_with_retries(engine, scene, advances, progress)]
        if whole_check and runs[0].ok:
            whole = _WholeChannel(engine, whole_channel, cable, scene_overrides, refine,
                                  advances + m_to_mm(stem.dropped_m), fork)  # fmt: skip
            fork = fork and not whole.forked  # the second core is taken
        if ahead.forked and runs[0].ok and runs[0].scene is scene:
            runs.append(ahead.result())
        else:
            ahead.cancel()  # not started, or not needed: the loop below runs what is needed
        while True:
            if not runs[-1].ok:
                raise _jammed(app, runs[-1], advances, s_ref_mm)
            if len(runs) >= 2:
                coarse, fine = runs[-2], runs[-1]
                error_mm = distance(coarse, fine)
                if (
                    float(np.max(error_mm)) <= NUMERICAL_ERROR_WARN_MM
                    or len(runs) > MAX_EXTRA_LEVELS + 1
                ):
                    break
            runs.append(_run_with_retries(engine, refine(runs[-1].scene, REFINE_FACTOR),
                                          advances, progress))  # fmt: skip
    except BaseException:
        ahead.cancel()
        if whole is not None:
            whole.cancel()
        if xpending is not None:
            xpending.cancel()
        raise
    pair_mm = error_mm
    n_levels = len(runs)
    try:
        probes: list[_Run] = []
        if any(_stabilised(r) for r in (coarse, fine)):
            # stalls and snaps make the path branch; probe where with two more refined runs
            def probe_run(factor: float) -> Callable[[], _Run]:
                return lambda: _run_with_retries(engine, refine(coarse.scene, factor),
                                                 advances, progress
                                                 and factor == PROBE_FACTORS[0])  # fmt: skip

            done = _run_two(*(probe_run(f) for f in PROBE_FACTORS), fork)  # independent: at once
            for probe in done:
                if probe.ok:
                    probes.append(probe)
                    error_mm = np.maximum(error_mm, distance(probe, fine))
        runs += probes
        branch_mm = float(np.max(error_mm)) if probes else 0.0
        resolved = False
        if probes and branch_mm > NUMERICAL_ERROR_WARN_MM:
            # the path branches at these settings: settle it with two much finer runs
            base = runs[0].scene
            f_coarse, f_fine = RESOLVE_FACTORS
            pair = _run_two(  # independent: both at once (in this order when not forked)
                lambda: _run_with_retries(engine, refine(base, f_coarse), advances, progress),
                lambda: _run_with_retries(engine, refine(base, f_fine), advances, False),
                fork,
            )
            runs += pair
            if all(r.ok for r in pair):
                coarse, fine = pair
                error_mm = distance(coarse, fine)
                resolved = True
    except BaseException:
        if whole is not None:
            whole.cancel()
        raise
    notes += [r.note for r in runs if r.note]
    discretisation_mm = error_mm
    stem_result = None
    if whole is not None:
        stem_result = whole.finish(stem, float(stem_mm), wanted,
                                   fine.pos_m[_dwell_rows(fine, advances, wanted)])  # fmt: skip
        runs += whole.runs
        error_mm = error_mm + stem_result.added_mm
    if n_levels > 2:
        notes.append(
            f"The commissioning settings left a numerical error above {NUMERICAL_ERROR_WARN_MM:g} "
            f"mm, so the run was refined {n_levels - 2} more time(s) (every link and the push "
            "increment halved each time); the numbers below come from the last two runs."
        )
    res = fine.res
    run_settings = dict(res.settings or {})
    stabilised = _stabilised(fine)
    n_steps = res.stats.n_steps
    coarse_dict, fine_dict = _scene_dict(engine, coarse.scene), _scene_dict(engine, fine.scene)
    xcheck = None
    if xpending is not None:  # both engines share the stem: its share left out
        xcheck = xpending.finish(float(np.max(discretisation_mm)),
                                 lambda run: distance(run, fine),
                                 lambda run: m_to_mm(run.pos_m[_dwell_rows(run, advances,
                                                                           wanted)]))  # fmt: skip
    text = numerical_text(discretisation_mm, stabilised, n_steps, pair_mm, len(probes), branch_mm,
                          resolved, stem_result)  # fmt: skip
    if cross_check is False:
        text = (*text, CROSS_CHECK_OFF_TEXT)
    numerics = NumericalCheck(
        error_mm=error_mm,
        max_mm=float(np.max(error_mm)),
        median_mm=float(np.median(error_mm)),
        settings=_numeric_settings(coarse_dict),
        refined_settings=_numeric_settings(fine_dict),
        solve_time_s=float(coarse.res.solve_time_s),
        refined_solve_time_s=float(res.solve_time_s),
        stabilised_steps=stabilised,
        text=text if xcheck is None else (*text, xcheck.text),
        n_runs=len(runs),
        n_probes=len(probes),
        branch_mm=branch_mm,
        resolved=resolved,
        total_solve_time_s=sum(float(r.res.solve_time_s) for r in runs),
        cross_check=xcheck,
        stem=stem_result,
    )
    idx_f = _dwell_rows(fine, advances, wanted)
    dirs = np.asarray(res.source_dir, dtype=float).reshape(-1, 3)[idx_f]
    info = SimulationInfo(
        status=fine.status,
        message=str(res.message),
        warnings=tuple(str(w) for w in res.warnings),
        solve_time_s=numerics.total_solve_time_s,
        wall_time_s=sum(r.wall_s for r in runs),
        n_elements=int(res.n_elements or 0),
        settings=run_settings,
    )
    afterloader = getattr(getattr(fine.scene, "instrument", None), "afterloader", "") or cable
    return SimulatedDwells(
        dwells=PathDwells(m_to_mm(fine.pos_m[idx_f]), dirs / np.linalg.norm(dirs, axis=1)[:, None]),
        info=info,
        numerics=numerics,
        scene=fine_dict,
        afterloader=afterloader,
        stem=stem,
        notes=tuple(notes),
    )


class _WholeChannel:
    """The modelled stem's check (:class:`StemCheck`): the whole channel, uncut, at the
    commissioning settings and refined (the refined run, about three times the cost, starts at
    once in a forked child when ``fork``; :meth:`finish` runs the other here and compares).

    Parameters
    ----------
    engine : Engine
    channel : Channel
        The whole channel.
    cable : str
    scene_overrides : mapping
        As for the reported runs.
    refine : callable
        ``refine(scene, factor)``.
    advances : (n,) ndarray
        The reported runs' advances plus the dropped length, mm (the same cable length past
        the same points in space).
    fork : bool
        The refined run may go to a forked child.
    """

    def __init__(self, engine: Engine, channel, cable: str, scene_overrides, refine, advances,
                 fork: bool):  # fmt: skip
        self.engine = engine
        self.advances = np.asarray(advances, dtype=float)
        self.runs: list[_Run] = []
        self.error = ""
        self.scene = None
        self._ahead = None
        try:
            self.scene = commission_scene(engine, channel, cable, scene_overrides)
            fine_scene = refine(self.scene, REFINE_FACTOR)
        except RingQAError as exc:  # said in the report, not a failed commissioning
            self.error = str(exc)
            return
        self._ahead = ForkedCall(
            lambda: _run_with_retries(engine, fine_scene, self.advances, False),
            fork and CONCURRENT_RUNS,
        )

    @property
    def forked(self) -> bool:
        """The refined run runs in a forked child."""
        return self._ahead is not None and self._ahead.forked

    def cancel(self) -> None:
        """Stop the forked run (its result is not needed)."""
        if self._ahead is not None:
            self._ahead.cancel()

    def finish(self, stem, stem_mm: float, wanted, reported_m) -> StemCheck:
        """Run the commissioning-settings run here, collect the refined one and compare.

        Parameters
        ----------
        stem : TrimmedChannel
            The cut made.
        stem_mm : float
            The stem kept, mm.
        wanted : (n,) ndarray
            The reported runs' advances in the reference's order, mm.
        reported_m : (n, 3) ndarray
            The reported source centres (the reference's order), m.
        """
        n = len(reported_m)
        dropped_mm = float(m_to_mm(stem.dropped_m))
        zeros = np.zeros(n)

        def not_measured(why: str, solve: float = 0.0) -> StemCheck:
            text = (
                f"Modelled stem: the simulation keeps {stem_mm:g} mm of straight channel before "
                f"the first bend and leaves out {dropped_mm:.1f} mm of straight shaft; what that "
                f"moves could not be measured ({why}), so the numerical error does NOT include it "
                "(run with --whole-channel to simulate the whole shaft)."
            )
            return StemCheck(stem_mm, dropped_mm, zeros, zeros, zeros, False, solve, text)

        if self._ahead is None:
            return not_measured(self.error)
        try:
            coarse = _run_with_retries(self.engine, self.scene, self.advances, False)
            fine = self._ahead.result()
        except BaseException as exc:
            self.cancel()
            if not isinstance(exc, RingQAError):
                raise
            return not_measured(str(exc))
        finally:
            self._ahead = None
        self.runs = [coarse, fine]
        solve = sum(float(r.res.solve_time_s) for r in self.runs)
        if not (coarse.ok and fine.ok):
            bad = fine if coarse.ok else coarse
            msg = bad.res.message or "no message"
            return not_measured(f"the whole channel's run did not reach every dwell: {msg}", solve)
        want = np.asarray(wanted, dtype=float) + dropped_mm
        pos = {id(r): r.pos_m[_dwell_rows(r, self.advances, want)] for r in self.runs}
        distance = m_to_mm(np.linalg.norm(pos[id(fine)] - np.asarray(reported_m), axis=1))
        own = m_to_mm(np.linalg.norm(pos[id(fine)] - pos[id(coarse)], axis=1))
        added = distance + own
        text = (
            f"Modelled stem: the simulation keeps {stem_mm:g} mm of straight channel before the "
            f"first bend and leaves out {dropped_mm:.1f} mm of straight shaft. Simulated with the "
            f"whole channel the dwells lie up to {float(np.max(distance)):.3f} mm (median "
            f"{float(np.median(distance)):.3f} mm) from the reported ones, and the whole "
            f"channel's own runs (commissioning and refined settings) differ by up to "
            f"{float(np.max(own)):.3f} mm; each dwell's numerical error includes the sum of the "
            f"two (up to {float(np.max(added)):.3f} mm). In a long straight shaft the cable "
            "buckles against the wall under friction, and where it settles depends on small "
            "changes: refining the links does not remove this part."
        )
        return StemCheck(stem_mm, dropped_mm, distance, own, added, True, solve, text)


def cross_check_overrides(engine: Engine, scene) -> dict[str, Any]:
    """The overrides that make the commissioning ``scene`` the cross-check's (dotted keys, user
    units): ``model.formulation = "flexible"``, every element length times
    :data:`CROSS_CHECK_ELEMENT_FACTOR`, the increment unchanged (a stand-in engine's scene only
    gets the formulation)."""
    from ringqa.accuracy import scaled_overrides

    over = scaled_overrides(scene, CROSS_CHECK_ELEMENT_FACTOR, 1.0) if own_engine(engine) else {}
    return {"model.formulation": "flexible", **over}


def cross_check_scene(engine: Engine, scene):
    """The cross-check's scene (:func:`cross_check_overrides` applied to ``scene``)."""
    return engine.scene_with_overrides(scene, cross_check_overrides(engine, scene))


def _flexible_run(engine: Engine, scene, advances) -> _Run | str:
    """The cross-check's run, or why it could not be made (a scene the flexible engine does not
    model: its SceneError's text)."""
    try:
        return _run_with_retries(engine, cross_check_scene(engine, scene), advances, False)
    except RingQAError as exc:
        return str(exc)


class PendingCrossCheck:
    """The cross-check's flexible run, started (in a forked process beside the rigid runs when
    ``fork``; else it runs in :meth:`finish`).

    Parameters
    ----------
    engine : Engine
        ringqa's own (a stand-in engine is not cross-checked: :meth:`finish` returns None).
    scene
        The commissioning run's scene.
    advances : (n,) ndarray
        The advances run, mm.
    fork : bool or None
        Run it in a forked child now (:class:`ringqa.parallel.ForkedCall`). None: when a
        core is free (:func:`ringqa.parallel.second_core_free`), whether or not its
        kernels are cached: unlike the rigid runs' forks, the child compiles kernels the command
        itself never needs, so on a first run the flexible engine compiles beside the rigid
        engine's compile instead of after it.
    relative_position_mm : (n,) array_like or None
        The dwells' relative positions (mm) in the order ``finish``'s callables use, for the
        report's plot.
    """

    def __init__(self, engine: Engine, scene, advances, fork: bool | None,
                 relative_position_mm=None) -> None:  # fmt: skip
        self.engine = engine
        self.rel = None if relative_position_mm is None else np.asarray(relative_position_mm,
                                                                         dtype=float)  # fmt: skip
        self.scene = scene
        self.advances = np.asarray(advances, dtype=float)
        self.active = own_engine(engine)
        self.t0 = time.perf_counter()
        if fork is None:
            fork = forked.second_core_free()
        self.call = ForkedCall(lambda: _flexible_run(engine, scene, self.advances),
                               fork and self.active and CONCURRENT_RUNS)  # fmt: skip

    def cancel(self) -> None:
        """Stop the forked run (its result is not needed)."""
        self.call.cancel()

    def __del__(self) -> None:
        # the rigid runs raised (a jam) before finish(): the child is stopped and reaped when
        # this is dropped, not left blocked on its pipe
        call = getattr(self, "call", None)
        if call is not None:
            call.cancel()

    def finish(self, rigid_error_mm: float, distance, positions) -> CrossCheck | None:
        """Wait for (or make) the flexible run and compare its dwells with the reported ones.

        Parameters
        ----------
        rigid_error_mm : float
            The rigid runs' numerical error (max over the dwells), mm.
        distance, positions : callable
            ``distance(run) -> (n,)`` mm to the reported run and ``positions(run) -> (n, 3)``
            mm, in the reference's order.
        """
        if not self.active:
            self.call.cancel()
            return None
        t_wait = time.perf_counter()
        concurrent = self.call.forked
        run = self.call.result()
        now = time.perf_counter()
        wall = now - self.t0 if concurrent else now - t_wait
        added = now - t_wait
        n = self.advances.size
        limit = max(CROSS_CHECK_MIN_MM, 2.0 * (rigid_error_mm + CROSS_CHECK_FLEXIBLE_ERROR_MM))
        settings = cross_check_overrides(self.engine, self.scene)
        base = {"settings": settings, "concurrent": concurrent, "added_wall_s": added,
                "relative_position_mm": self.rel}  # fmt: skip

        def not_compared(why: str, solve: float) -> CrossCheck:
            text = f"Cross-check with the flexible-element engine not made: {why}"
            return CrossCheck(np.full(n, np.nan), float("nan"), limit, False, False, solve, wall,
                              np.full((n, 3), np.nan), text, **base)  # fmt: skip

        if isinstance(run, str):  # a scene the flexible engine does not model: said, not failed
            return not_compared(run, 0.0)
        solve = float(run.res.solve_time_s)
        if not run.ok:
            msg = run.res.message
            return not_compared(f"its run did not reach every dwell ({msg}).", solve)
        d = np.asarray(distance(run), dtype=float)
        worst = float(np.max(d))
        fails = worst > limit
        where = (
            f"it ran beside the rigid runs on the second core ({solve:.2f} s; the command waited "
            f"{added:.2f} s for it)"
            if concurrent
            else f"it took {solve:.2f} s"
        )
        text = (
            f"Cross-check with an independent engine (flexible beam elements instead of rigid "
            f"links): the dwells agree to {worst:.3f} mm (median {float(np.median(d)):.3f} mm), "
            + ("MORE than" if fails else "within")
            + f" the {limit:.2f} mm the numerical errors allow; {where}."
        )
        return CrossCheck(d, worst, limit, fails, True, solve, wall, positions(run), text, **base)


def start_cross_check(
    engine: Engine, scene, advances, fork: bool | None = None, relative_position_mm=None
) -> PendingCrossCheck:
    """Start the cross-check's flexible run on the commissioning ``scene`` (see
    :class:`PendingCrossCheck`)."""
    return PendingCrossCheck(engine, scene, advances, fork, relative_position_mm)


def cross_check_run(
    engine: Engine, scene, advances, rigid_error_mm: float, distance, positions
) -> CrossCheck:
    """Run the flexible-element engine on the commissioning ``scene`` here and now and compare
    its dwells with the reported (refined rigid) run's (:meth:`PendingCrossCheck.finish`; the
    scene gets ``model.formulation = "flexible"`` and :data:`CROSS_CHECK_ELEMENT_FACTOR`)."""
    pending = PendingCrossCheck(engine, scene, advances, fork=False)
    pending.active = True
    out = pending.finish(rigid_error_mm, distance, positions)
    assert out is not None
    return out


#: Engine warnings about the fallback stabilisation start with a count and contain this; the
#: report states them in plain words (:func:`numerical_text`) instead.
_STABILISATION_WARNING = "needed the fallback stabilisation"
#: The engine's work balance warning starts with this
#: (``ringqa.simulation.plausibility.WORK_BALANCE_TEXT``); the commissioning run makes it the
#: named warning ``simulation.work_balance`` (terminal, results.json, the report's page 1).
WORK_BALANCE_WARNING = "the work balance does not close"


def simulation_notes(info: SimulationInfo, cable: CableChoice) -> list[str]:
    """The report's notes on a run: the cable model, and the engine's warnings (those on the
    fallback stabilisation are said in plain words by :func:`numerical_text` instead).

    Parameters
    ----------
    info : SimulationInfo
        The run (from :func:`simulate_dwells`).
    cable : CableChoice
        The cable simulated and why.
    """
    notes = [cable.note]
    other = [
        w
        for w in info.warnings
        if _STABILISATION_WARNING not in w and not w.startswith(WORK_BALANCE_WARNING)
    ]  # the work balance warning is a named warning of the run (pipeline.commission)
    if other:
        notes.append("Simulation warnings: " + "; ".join(other))
    return notes
