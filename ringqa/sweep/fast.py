"""A cheap sample: one engine run at the commissioning settings, everything else prepared once.

A converged commissioning run (:func:`ringqa.pipeline.commission`) loads and parses the input,
builds the reference, the review, the plan selection, the stem-trimmed channel, the dose points
and the reference plan, then runs the engine two to eight times (the numerical check: the run at
the commissioning settings, a refined run, probes and resolving runs where the path branches).
In a sweep only the engine run depends on the sample; the rest is the same in every sample.

- :func:`prepare` does the sample-independent work once per worker process (cached per job:
  :func:`prepared`): the input, the channels, the reference and its review, the plan selection,
  the dose points, the reference plan's doses and the advances.
- :func:`cheap_sample` then runs ONE engine run at the commissioning settings on the sample's
  perturbed channel and cable, and computes the sample's deviations and doses with the same
  pipeline functions :func:`~ringqa.pipeline.commission` uses (so a cheap sample's numbers are
  those of the commissioning run at the commissioning settings).
- The numerical check is a property of the settings: :func:`calibrate` measures it once per sweep
  on a few samples (a full commissioning run and a cheap one each), and every cheap sample
  reports, per dwell, the bound found there (:class:`NumericalBound`): the largest distance of a
  cheap sample from its full run's positions plus that full run's own numerical error. A
  sample's dwells are then within its reported error of what a full commissioning run gives
  (``tests/sweep/test_sweep_fast.py`` checks it on samples that were not calibrated).

A sample's engine run has a wall-clock budget (:data:`DEFAULT_BUDGET_S`, or set from the
calibration); a run that exceeds it stops at the next load step and the sample fails with a
message that says so (never an endless sample).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import socket
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.sweep.runner import Job, SampleRecord, commission_settings, tick

__all__ = [
    "DEFAULT_BUDGET_S",
    "NumericalBound",
    "Prepared",
    "calibrate",
    "cheap_sample",
    "prepare",
    "prepared",
    "run_cheap_batch",
    "tick",
]

#: Wall-clock budget of one sample's engine run when no calibration set one, s.
DEFAULT_BUDGET_S = 60.0
#: The budget set from the calibration: this many times the slowest calibrated cheap sample, and
#: at least :data:`MIN_BUDGET_S`.
BUDGET_FACTOR = 20.0
#: Smallest budget set from the calibration, s (a loaded machine slows every run).
MIN_BUDGET_S = 10.0


@dataclass(frozen=True, eq=False)
class Prepared:
    """What every sample of a sweep shares, built once per worker (:func:`prepare`).

    Attributes
    ----------
    app : Applicator
    channel : Channel
        The channel simulated (stem-trimmed as the commissioning run trims it).
    cable : str
        Instrument preset.
    advances_mm : (m,) ndarray
        Advances the engine reports (sorted as the commissioning run pushes).
    rows : (n,) ndarray of int
        Row of each dwell (reference order) in the engine's output.
    compared : PathDwells
        The reference as compared (registered or as supplied).
    reference, review, selection, points, tandem, source, sk_u, prescription_gy :
        The pipeline's objects of the same names (:func:`~ringqa.pipeline.commission`).
    centreline : PathDwells
        The centreline dwells.
    points_mm : (k, 3) ndarray
        Every dose point, mm.
    reference_dose_gy : (k,) ndarray
        The doses at them of the plan the verdicts judge against (the registered reference plan
        where the run registers, else the reference plan).
    dwell_ids : tuple of int
    point_names : tuple of str
    s_ref_mm : float
    """

    app: Any
    channel: Any
    cable: str
    advances_mm: np.ndarray
    rows: np.ndarray
    compared: Any
    reference: Any
    review: Any
    selection: Any
    centreline: Any
    points: Any
    tandem: Any
    source: Any
    sk_u: float
    prescription_gy: float
    points_mm: np.ndarray
    reference_dose_gy: np.ndarray
    dwell_ids: tuple[int, ...]
    point_names: tuple[str, ...]
    s_ref_mm: float


@dataclass(frozen=True)
class NumericalBound:
    """The numerical error every cheap sample reports, measured once per sweep (:func:`calibrate`).

    Attributes
    ----------
    error_mm : (n,) ndarray
        Per dwell: the largest, over the calibration samples, of the distance between the cheap
        sample's and the full commissioning run's positions plus the full run's own numerical
        error, mm.
    indices : tuple of int
        The calibration samples.
    cheap_vs_full_mm : list of float
        Per calibration sample: the largest distance cheap vs full over the dwells, mm.
    full_error_mm : list of float
        Per calibration sample: the full run's largest numerical error, mm.
    cheap_s, full_s : list of float
        Per calibration sample: CPU seconds of the cheap sample and of the full run.
    failed : list of str
        Calibration samples that failed (either way), with the reason.
    """

    error_mm: np.ndarray
    indices: tuple[int, ...] = ()
    cheap_vs_full_mm: tuple[float, ...] = ()
    full_error_mm: tuple[float, ...] = ()
    cheap_s: tuple[float, ...] = ()
    full_s: tuple[float, ...] = ()
    failed: tuple[str, ...] = ()

    @property
    def budget_s(self) -> float:
        """The per-sample wall-clock budget set from the calibration, s."""
        if not self.cheap_s:
            return DEFAULT_BUDGET_S
        return max(MIN_BUDGET_S, BUDGET_FACTOR * max(self.cheap_s))

    def as_dict(self) -> dict:
        """The ``sweep.json`` ``numerical_check`` section."""
        return {
            "mode": "calibrated",
            "calibration_samples": list(self.indices),
            "error_mm_per_dwell": [float(x) for x in self.error_mm],
            "max_error_mm": float(np.max(self.error_mm)) if self.error_mm.size else None,
            "cheap_vs_full_max_mm": list(self.cheap_vs_full_mm),
            "full_run_max_error_mm": list(self.full_error_mm),
            "cheap_cpu_s": list(self.cheap_s),
            "full_cpu_s": list(self.full_s),
            "budget_s": self.budget_s,
            "failed": list(self.failed),
            "text": (
                "Each sample is ONE engine run at the commissioning settings. Its numerical error "
                "per dwell is the bound measured on the calibration samples: the largest distance "
                "of a cheap sample from the full commissioning run (commissioning + refined runs, "
                "probes) with the same parameters, plus that full run's own numerical error."
            ),
        }


def prepare(job: Job) -> Prepared:
    """The sample-independent part of a commissioning run of ``job`` (the steps of
    :func:`ringqa.pipeline.commission` before and around the simulation).

    Raises
    ------
    RingQAError
        As :func:`~ringqa.pipeline.commission` would for this input and these settings.
    """
    from ringqa.geometry import Channel
    from ringqa.geometry.stem import trim_to_stem
    from ringqa.pipeline.doses import dose_points, standard_plans
    from ringqa.pipeline.dwells import (
        centreline_dwells,
        plan_selection,
        reference_dwells,
        tandem_dwells,
    )
    from ringqa.pipeline.inputs import channel_of, check_measured_path, choose_source, load_input
    from ringqa.pipeline.reference import review_reference
    from ringqa.pipeline.simulate import check_clearance, choose_cable, instrument_radii_m
    from ringqa.plan import points_array_mm
    from ringqa.units import m_to_mm, mm_to_m

    # the settings every sample shares (the varied keys left out)
    cfg, _ = commission_settings(dataclasses.replace(job, names=()), ())
    if cfg.centreline_correction is not None:  # pragma: no cover - not a sweep setting
        raise ValueError("a centreline correction is not supported by the cheap sample")
    loaded = load_input(job.input)
    app = loaded.applicator
    ring = channel_of(app, cfg.channel)
    check_measured_path(job.input, ring, cfg.channel, loaded.kind, cfg.require_measured)
    src = choose_source(cfg.source, cfg.sk_U, loaded.rtplan)
    cable = choose_cable(cfg.cable, src.source.name).preset
    capsule_r_m, cable_r_m = instrument_radii_m(None, ring, cable)
    check_clearance(app, ring, cable_r_m)
    reference = reference_dwells(app, ring, cfg.plan_step_mm)
    review = review_reference(app, ring, reference, cfg.register, capsule_r_m)
    compared = review.registered
    registered = compared.dwells if cfg.register != "none" and reference.kind == "measured" \
        else None  # fmt: skip
    selection = plan_selection(app, ring, reference, cfg.plan_step_mm, review.compared)
    rel = reference.relative_position_mm
    centreline = centreline_dwells(ring, rel)
    channel = ring
    if cfg.stem_mm is not None and isinstance(ring, Channel):
        stem = trim_to_stem(ring, mm_to_m(cfg.stem_mm))
        if stem.dropped_m > 0:
            channel = stem.channel
    s_ref_mm = m_to_mm(channel.s_ref_m)
    rel_sorted = np.sort(np.unique(np.round(np.asarray(rel, dtype=float), 9)))[::-1]
    advances = s_ref_mm - rel_sorted
    wanted = s_ref_mm - np.asarray(rel, dtype=float)
    rows = np.array([int(np.argmin(np.abs(advances - a))) for a in wanted], dtype=int)
    points = dose_points(app, loaded.rtplan, cfg.point_spec)
    tandem = tandem_dwells(app, cfg.tandem_dwells, cfg.plan_step_mm)
    plans = standard_plans(
        reference, registered, selection, centreline, centreline, tandem, points, src.source,
        prescription_gy=cfg.prescription_gy, sk_U=src.sk_U,
    )  # fmt: skip
    pts = points_array_mm(points.all)
    return Prepared(
        app=app,
        channel=channel,
        cable=cable,
        advances_mm=advances,
        rows=rows,
        compared=compared.dwells,
        reference=reference,
        review=review,
        selection=selection,
        centreline=centreline,
        points=points,
        tandem=tandem,
        source=src.source,
        sk_u=float(src.sk_U),
        prescription_gy=float(cfg.prescription_gy),
        points_mm=pts,
        # the plan the verdicts judge against: the registered reference where registered
        # (doses.csv diff_registered_pct), as record_of's full samples
        reference_dose_gy=np.asarray(plans.compared_reference.dose_gy(pts), dtype=float),
        dwell_ids=tuple(range(1, len(rel) + 1)),
        point_names=tuple(str(p.name) for p in points.all),
        s_ref_mm=float(s_ref_mm),
    )


def job_key(job: Job) -> str:
    """A digest of ``job`` (what :func:`prepared` caches on)."""
    text = json.dumps(
        [job.input, dict(job.settings), dict(job.fixed), list(job.names), job.seed],
        sort_keys=True,
        default=str,
    )
    return hashlib.sha256(text.encode()).hexdigest()


_PREPARED: dict[str, Prepared] = {}


def prepared(job: Job) -> Prepared:
    """:func:`prepare` of ``job``, once per process (later calls return the same object)."""
    key = job_key(job)
    if key not in _PREPARED:
        _PREPARED.clear()  # one sweep per worker at a time: keep memory flat
        _PREPARED[key] = prepare(job)
    return _PREPARED[key]


class BudgetExceededError(RuntimeError):
    """A sample's engine run ran past its wall-clock budget."""


def _scene(prep: Prepared, job: Job, index: int, values: Sequence):
    """The sample's scene at the commissioning settings (perturbed channel and cable)."""
    from ringqa.pipeline.simulate import commission_scene
    from ringqa.pipeline.uncertainty import Perturbation, perturbed_engine

    settings, pert = commission_settings(job, values)
    engine = perturbed_engine(Perturbation.from_values(pert, (job.seed, int(index))))
    return commission_scene(engine, prep.channel, prep.cable, settings.scene_overrides)


def _engine_run(scene, advances_mm: np.ndarray, budget_s: float | None):
    """One engine run (retried with a finer increment when it FAILED to converge, as the
    commissioning run does)."""
    from ringqa.pipeline.simulate import RETRY_INCREMENT_FACTORS
    from ringqa.simulation.scenefile import scene_with_overrides
    from ringqa.simulation.solvers.driver import run
    from ringqa.units import m_to_mm, mm_to_m

    if getattr(getattr(scene, "model", None), "formulation", "rigid") != "rigid":
        from ringqa.simulation import simulate  # another engine: no budget inside its run

        run = lambda sc, adv, deadline=None: simulate(sc, advances_mm=m_to_mm(adv))  # noqa: E731
    deadline = None if budget_s is None else time.perf_counter() + budget_s
    res = run(scene, mm_to_m(advances_mm), deadline=deadline)
    if res.settings.get("budget_exceeded"):
        raise BudgetExceededError(res.message)
    inc_mm = m_to_mm(float(scene.solver.increment_m))
    for factor in RETRY_INCREMENT_FACTORS if res.status == -1 else ():
        retry = scene_with_overrides(scene, {"solver.increment_mm": inc_mm * factor})
        res = run(retry, mm_to_m(advances_mm), deadline=deadline)
        if res.settings.get("budget_exceeded"):
            raise BudgetExceededError(res.message)
        if res.status == 0:
            break
    return res


def cheap_sample(
    job: Job,
    index: int,
    values: Sequence,
    error_mm: np.ndarray | None = None,
    budget_s: float | None = DEFAULT_BUDGET_S,
) -> SampleRecord:
    """Sample ``index``: one engine run at the commissioning settings (see the module docstring).

    Parameters
    ----------
    job : Job
    index : int
    values : sequence
        The parameter values (spec order).
    error_mm : (n_dwell,) ndarray, optional
        The numerical error each dwell reports (the calibration's bound; default NaN: not yet
        measured).
    budget_s : float or None
        Wall-clock budget of the engine run, s (None: none).

    Returns
    -------
    SampleRecord
        A failure (a jam, an impossible value, the budget exceeded) is a record with ``ok =
        False`` and its reason.
    """
    from ringqa.errors import RingQAError

    t0, c0 = time.perf_counter(), time.process_time()
    who = f"{socket.gethostname()}:{os.getpid()}"
    vals = tuple(v.item() if isinstance(v, np.generic) else v for v in values)

    def failed(msg: str) -> SampleRecord:
        return SampleRecord(
            int(index), vals, False, msg, np.full((0, 3), np.nan),
            seconds=time.perf_counter() - t0, worker=who, cpu_seconds=time.process_time() - c0,
        )  # fmt: skip

    try:
        prep = prepared(job)
        scene = _scene(prep, job, index, vals)
        res = _engine_run(scene, prep.advances_mm, budget_s)
    except BudgetExceededError as exc:
        return failed(f"BudgetExceeded: {exc}")
    except (RingQAError, ValueError, ArithmeticError) as exc:
        return failed(f"{type(exc).__name__}: {exc}")
    pos_m = np.asarray(res.source_pos_m, dtype=float).reshape(-1, 3)
    if res.status != 0 or pos_m.shape[0] < prep.advances_mm.size or not np.all(np.isfinite(pos_m)):
        kind = "jammed" if res.status == 1 else "failed"
        return failed(f"SimulationJammedError: the simulated source cable {kind}: {res.message}")
    n = len(prep.dwell_ids)
    err = np.full(n, np.nan) if error_mm is None else np.asarray(error_mm, dtype=float)
    rec = record_from_positions(prep, pos_m, np.asarray(res.source_dir, float).reshape(-1, 3))
    return SampleRecord(
        int(index), vals, True, "", rec["positions_mm"],
        {**rec["dwell"], "numerical_error_mm": err}, rec["point"],
        time.perf_counter() - t0, who, prep.dwell_ids, prep.point_names,
        time.process_time() - c0,
    )  # fmt: skip


def record_from_positions(prep: Prepared, pos_m: np.ndarray, dir_: np.ndarray) -> dict:
    """The sample's outputs from the engine's source centres ``pos_m`` (m) and directions at
    :attr:`Prepared.advances_mm`, computed as :func:`~ringqa.pipeline.commission` computes them."""
    from ringqa.pipeline.deviations import compare_with_reference
    from ringqa.pipeline.dwells import PathDwells
    from ringqa.plan import relative_difference_pct
    from ringqa.units import m_to_mm

    pos = m_to_mm(pos_m[prep.rows])
    dirs = dir_[prep.rows]
    sim = PathDwells(pos, dirs / np.linalg.norm(dirs, axis=1)[:, None])
    dev = compare_with_reference(prep.app, prep.compared, sim, prep.centreline).simulated
    in_plan = prep.selection.in_plan
    p, d = sim.positions_mm[in_plan], sim.directions[in_plan]
    if prep.tandem is not None:
        p = np.vstack([p, prep.tandem.positions_mm])
        d = np.vstack([d, prep.tandem.directions])
    plan = _reference_plan(prep).transfer(p, d, "simulated")
    dose = np.asarray(plan.dose_gy(prep.points_mm), dtype=float)
    return {
        "positions_mm": pos,
        "dwell": {
            "deviation_mm": dev.dist_mm,
            "along_mm": dev.along_mm,
            "radial_mm": dev.radial_mm,
            "out_of_plane_mm": dev.out_of_plane_mm,
        },
        "point": {
            "dose_gy": dose,
            "dose_diff_pct": np.asarray(relative_difference_pct(dose, prep.reference_dose_gy)),
        },
    }


_PLANS: dict[int, Any] = {}


def _reference_plan(prep: Prepared):
    """The reference plan (times at Point A) of ``prep`` (once per process)."""
    key = id(prep)
    if key not in _PLANS:
        from ringqa.pipeline.doses import standard_plans

        _PLANS.clear()
        _PLANS[key] = standard_plans(
            prep.reference, None, prep.selection, prep.centreline, prep.centreline, prep.tandem,
            prep.points, prep.source, prescription_gy=prep.prescription_gy, sk_U=prep.sk_u,
        ).reference  # fmt: skip
    return _PLANS[key]


def run_cheap_batch(
    job: Job,
    batch: Sequence[tuple[int, Sequence]],
    error_mm: Sequence[float] | None,
    budget_s: float | None,
    progress: str | None = None,
) -> list[SampleRecord]:
    """The Dask task of a calibrated sweep: :func:`cheap_sample` of every ``(index, values)``;
    ``progress``: the name of a ``distributed.Queue`` told of every finished sample (the
    command's progress bar moves per sample)."""
    err = None if error_mm is None else np.asarray(error_mm, dtype=float)
    out = []
    for i, v in batch:
        out.append(cheap_sample(job, i, v, err, budget_s))
        tick(progress)
    return out


def calibrate_one(job: Job, index: int, values: Sequence) -> dict:
    """One calibration sample: the cheap sample and the full commissioning run (the Dask task of
    :func:`calibrate`)."""
    from ringqa.sweep.runner import run_sample

    c0 = time.process_time()
    cheap = cheap_sample(job, index, values, None, None)
    c1 = time.process_time()
    full = run_sample(job, index, values)
    c2 = time.process_time()
    out = {"index": int(index), "cheap_s": c1 - c0, "full_s": c2 - c1, "ok": False}
    if not (cheap.ok and full.ok):
        out["message"] = cheap.message or full.message
        return out
    dist = np.linalg.norm(cheap.positions_mm - full.positions_mm, axis=1)
    out.update(
        ok=True,
        dist_mm=dist.tolist(),
        full_error_mm=np.asarray(full.dwell["numerical_error_mm"], float).tolist(),
    )
    return out


def calibrate(results: Sequence[dict], n_dwell: int) -> NumericalBound:
    """The :class:`NumericalBound` of the calibration samples' :func:`calibrate_one` results."""
    good = [r for r in results if r["ok"]]
    if good:
        err = np.max(
            [np.asarray(r["dist_mm"]) + np.asarray(r["full_error_mm"]) for r in good], axis=0
        )
    else:
        err = np.full(n_dwell, np.nan)
    return NumericalBound(
        error_mm=err,
        indices=tuple(int(r["index"]) for r in results),
        cheap_vs_full_mm=tuple(float(np.max(r["dist_mm"])) for r in good),
        full_error_mm=tuple(float(np.max(r["full_error_mm"])) for r in good),
        cheap_s=tuple(float(r["cheap_s"]) for r in results),
        full_s=tuple(float(r["full_s"]) for r in results),
        failed=tuple(f"{r['index']}: {r['message']}" for r in results if not r["ok"]),
    )
