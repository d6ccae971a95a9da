"""One sample = one converged commissioning run with perturbed inputs (runs on a Dask worker).

:func:`run_batch` is the Dask task: it receives a :class:`Job` (the input, settings and
parameter names; small and picklable) and a list of ``(index, values)`` and returns one
:class:`SampleRecord` per sample. A failed sample (a jam, an impossible value) is a record with
``ok = False`` and its message, never an exception: one bad sample does not stop the sweep.
"""

from __future__ import annotations

import dataclasses
import os
import socket
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ringqa.pipeline.uncertainty import PERTURBATION_KEYS, Perturbation, perturbed_engine

__all__ = [
    "DWELL_QUANTITIES",
    "POINT_QUANTITIES",
    "Job",
    "SampleRecord",
    "run_batch",
    "run_sample",
    "run_ticking_batch",
    "tick",
]

#: per-dwell outputs kept for each sample (mm); ``shift_mm`` is computed later from x, y, z
DWELL_QUANTITIES = (
    "deviation_mm",
    "along_mm",
    "radial_mm",
    "out_of_plane_mm",
    "numerical_error_mm",
)
#: per-point outputs kept for each sample
POINT_QUANTITIES = ("dose_gy", "dose_diff_pct")


@dataclass(frozen=True)
class Job:
    """What every sample of a sweep shares (sent to the workers).

    Attributes
    ----------
    input : str
        Commissioning input.
    settings : dict
        :class:`~ringqa.pipeline.settings.CommissionSettings` keyword arguments (without the
        scene overrides).
    fixed : dict
        Scene keys held fixed (user units).
    names : tuple of str
        The varied keys, in the order of a sample's values.
    seed : int
        The study's seed (the centreline displacement's shape is drawn from (seed, i)).
    """

    input: str
    settings: Mapping[str, Any]
    fixed: Mapping[str, Any]
    names: tuple[str, ...]
    seed: int


@dataclass(frozen=True)
class SampleRecord:
    """One sample's outcome.

    Attributes
    ----------
    index : int
    values : tuple
        The parameter values (spec order).
    ok : bool
    message : str
        Why it failed ("" when ok).
    positions_mm : (n_dwell, 3) ndarray
        Simulated source centres, mm (NaN when failed).
    dwell : dict of str to (n_dwell,) ndarray
        :data:`DWELL_QUANTITIES`.
    point : dict of str to (n_point,) ndarray
        :data:`POINT_QUANTITIES`.
    seconds : float
        Wall time of the sample (measured on the worker).
    worker : str
        host:pid of the process that ran it.
    dwell_ids, point_names : tuple
        The dwell numbers and dose-point names of the outputs' rows.
    cpu_seconds : float
        CPU time of the sample in its process (less sensitive to a loaded machine than
        ``seconds``).
    """

    index: int
    values: tuple
    ok: bool
    message: str
    positions_mm: np.ndarray
    dwell: Mapping[str, np.ndarray] = field(default_factory=dict)
    point: Mapping[str, np.ndarray] = field(default_factory=dict)
    seconds: float = 0.0
    worker: str = ""
    dwell_ids: tuple[int, ...] = ()
    point_names: tuple[str, ...] = ()
    cpu_seconds: float = 0.0


def commission_settings(job: Job, values: Sequence) -> tuple[Any, Perturbation]:
    """The CommissionSettings and Perturbation of one sample."""
    from ringqa.pipeline import CommissionSettings

    overrides = dict(job.fixed)
    pert: dict[str, float] = {}
    for key, v in zip(job.names, values, strict=True):
        if key in PERTURBATION_KEYS:
            pert[key] = float(v)
        else:
            overrides[key] = bool(v) if isinstance(v, bool | np.bool_) else float(v)
    kw = dict(job.settings)
    if "sk_u" in kw:
        kw["sk_U"] = kw.pop("sk_u")
    if "centreline_reference" in kw:
        kw["require_measured"] = False if kw.pop("centreline_reference") else None
    return CommissionSettings(scene_overrides=overrides, **kw), pert


def run_sample(job: Job, index: int, values: Sequence) -> SampleRecord:
    """Run sample ``index`` (a converged commissioning run); a failure becomes a record."""
    from ringqa.errors import RingQAError
    from ringqa.pipeline import commission

    t0, c0 = time.perf_counter(), time.process_time()
    who = f"{socket.gethostname()}:{os.getpid()}"
    vals = tuple(v.item() if isinstance(v, np.generic) else v for v in values)
    try:
        settings, pert = commission_settings(job, vals)
        engine = perturbed_engine(Perturbation.from_values(pert, (job.seed, int(index))))
        res = commission(job.input, settings, engine=engine)
    except (RingQAError, ValueError, ArithmeticError) as exc:
        return SampleRecord(
            int(index),
            vals,
            False,
            f"{type(exc).__name__}: {exc}",
            np.full((0, 3), np.nan),
            seconds=time.perf_counter() - t0,
            worker=who,
            cpu_seconds=time.process_time() - c0,
        )
    rec = record_of(res, int(index), vals, time.perf_counter() - t0, who)
    return dataclasses.replace(rec, cpu_seconds=time.process_time() - c0)


def record_of(res, index: int, values: tuple, seconds: float, worker: str) -> SampleRecord:
    """The :class:`SampleRecord` of a finished commissioning result ``res``."""
    d = res.dwells[res.dwells["path"] == "simulated"]
    doses = res.doses[res.doses["plan"] == "simulated"]
    dwell = {
        "deviation_mm": d["dist_to_reference_mm"].to_numpy(float),
        "along_mm": d["along_mm"].to_numpy(float),
        "radial_mm": d["radial_mm"].to_numpy(float),
        "out_of_plane_mm": d["out_of_plane_mm"].to_numpy(float),
        "numerical_error_mm": d["numerical_error_mm"].to_numpy(float),
    }
    point = {
        "dose_gy": doses["dose_gy"].to_numpy(float),
        # the difference the verdicts judge: to the registered reference plan (= diff_pct
        # without registration)
        "dose_diff_pct": doses["diff_registered_pct"].to_numpy(float),
    }
    return SampleRecord(
        int(index),
        tuple(values),
        True,
        "",
        d[["x_mm", "y_mm", "z_mm"]].to_numpy(float),
        dwell,
        point,
        seconds,
        worker,
        tuple(int(x) for x in d["dwell"]),
        tuple(str(x) for x in doses["point"]),
    )


def run_batch(job: Job, batch: Sequence[tuple[int, Sequence]]) -> list[SampleRecord]:
    """The Dask task: run every ``(index, values)`` of ``batch`` in turn (one at a time: the
    commissioning runs fork no children here)."""
    import ringqa.pipeline.simulate as simulate

    simulate.CONCURRENT_RUNS = False
    return [run_sample(job, i, v) for i, v in batch]


def run_ticking_batch(
    job: Job, batch: Sequence[tuple[int, Sequence]], progress: str | None = None
) -> list[SampleRecord]:
    """:func:`run_batch` that tells the ``distributed.Queue`` named ``progress`` of every
    finished sample (:func:`tick`): the command's bar moves per sample, not per task."""
    out = []
    for item in batch:
        out += run_batch(job, [item])
        tick(progress)
    return out


def tick(queue: str | None) -> None:
    """Put one item on the ``distributed.Queue`` named ``queue`` (nothing without a name, or
    outside a worker; a failure is ignored: it only moves a progress bar)."""
    if queue is None:
        return
    try:
        from distributed import Queue, get_worker

        get_worker()
        Queue(queue).put(1, timeout=1)
    except Exception:
        return
