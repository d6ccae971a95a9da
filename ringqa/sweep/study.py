"""``run_sweep``: spec -> nominal run -> samples on Dask (streamed to samples.h5) -> outputs.

Order (nothing is written before the spec, the output folder, the nominal run and the
scheduler have all been checked):

1. the output folder is checked (:func:`ringqa.outdir.check_writable`; a folder holding only a
   ``samples.h5`` of the same spec is a sweep to resume);
2. the design is drawn (:mod:`ringqa.sweep.sampling`);
3. the nominal run (every parameter at its centre) runs in this process: it must succeed, gives
   the dwell and point labels and the positions the spread is measured from, and warms the numba
   cache the workers then load;
4. the cluster is reached or started (:mod:`ringqa.sweep.execute`);
5. the samples not yet in ``DIR/samples.h5`` run in batches; each finished batch is appended;
6. ``summary.csv``, ``sensitivity.csv``, ``sweep.json`` and ``uncertainty.png`` are written
   through :func:`ringqa.outdir.staged_output` (``samples.h5`` carried over).
"""

from __future__ import annotations

import contextlib
import os
import platform
import signal
import sys
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ringqa.errors import RingQAError
from ringqa.outdir import HANDLED_SIGNALS, check_writable, staged_output
from ringqa.progress import status_line
from ringqa.provenance import display_path
from ringqa.sweep.analysis import failure_report, sensitivity, sensitivity_reason, summary
from ringqa.sweep.execute import auto_batch_size
from ringqa.sweep.fast import NumericalBound, calibrate, cheap_sample, run_cheap_batch
from ringqa.sweep.runner import Job, SampleRecord, commission_settings, run_ticking_batch
from ringqa.sweep.sampling import design, n_runs, salib_problem
from ringqa.sweep.spec import SweepSpec
from ringqa.sweep.store import SAMPLES_NAME, SampleStore, StoredSamples, read_samples

__all__ = ["SweepResult", "job_of", "nominal_values", "run_sweep"]


@dataclass(frozen=True)
class SweepResult:
    """What a sweep produced.

    Attributes
    ----------
    out : Path
        The output folder.
    samples : StoredSamples
    summary : DataFrame
        ``summary.csv``.
    sensitivity : DataFrame
        ``sensitivity.csv``.
    record : dict
        ``sweep.json``.
    """

    out: Path
    samples: StoredSamples
    summary: pd.DataFrame
    sensitivity: pd.DataFrame
    record: dict


def job_of(spec: SweepSpec) -> Job:
    """The :class:`~ringqa.sweep.runner.Job` the workers receive."""
    return Job(spec.input, dict(spec.settings), dict(spec.fixed), spec.names, spec.seed)


def nominal_values(spec: SweepSpec) -> list:
    """Every parameter at its centre (mean, midpoint, median, first grid value)."""
    return [p.nominal for p in spec.parameters]


def _nominal(job: Job, values) -> tuple[SampleRecord, np.ndarray, object]:
    """The nominal run in this process: its record, the reference dwells (mm), the result."""
    from ringqa.errors import RingQAError
    from ringqa.pipeline import commission
    from ringqa.pipeline.uncertainty import Perturbation, perturbed_engine
    from ringqa.sweep.runner import record_of

    t0 = time.perf_counter()
    settings, pert = commission_settings(job, values)
    try:
        res = commission(
            job.input,
            settings,
            engine=perturbed_engine(Perturbation.from_values(pert, (job.seed, -1))),
        )
    except RingQAError as exc:
        raise RingQAError(
            f"the nominal run (every parameter at its centre) failed: {exc}"
        ) from None
    rec = record_of(res, -1, tuple(values), time.perf_counter() - t0, "parent")
    ref = res.dwells[res.dwells["path"] == res.reference]
    return rec, ref[["x_mm", "y_mm", "z_mm"]].to_numpy(float), res


def calibration_indices(n_runs: int, k: int) -> list[int]:
    """``k`` sample indices spread evenly over a design of ``n_runs`` (all when fewer)."""
    if n_runs <= k:
        return list(range(n_runs))
    return sorted({int(np.rint(x)) for x in np.linspace(0, n_runs - 1, k)})


def _calibrate(
    cl, job: Job, table, spec: SweepSpec, nom_rec, nom_cheap, nominal, progress: bool = False
) -> NumericalBound:
    """The numerical bound of a calibrated sweep: the nominal run (already run both ways here)
    and ``spec.calibration_samples - 1`` design samples run both ways on the cluster."""
    from ringqa.sweep.execute import one_core
    from ringqa.sweep.fast import calibrate_one

    nominal_point = {
        "index": -1,
        "ok": True,
        "cheap_s": nom_cheap.cpu_seconds,
        "full_s": nom_rec.cpu_seconds,
        "dist_mm": np.linalg.norm(nom_cheap.positions_mm - nom_rec.positions_mm, axis=1).tolist(),
        "full_error_mm": np.asarray(nom_rec.dwell["numerical_error_mm"], float).tolist(),
    }
    idx = calibration_indices(len(table), max(0, spec.calibration_samples - 1))
    vals = [[v.item() if hasattr(v, "item") else v for v in table[i]] for i in idx]
    cl.run(one_core)
    futures = [
        cl.submit(calibrate_one, job, i, v, pure=False) for i, v in zip(idx, vals, strict=True)
    ]
    if progress:  # each calibration sample runs the engine twice: its own bar, per sample
        from distributed import wait

        from ringqa.progress import progress_bar

        with progress_bar(total=len(futures), desc="ringqa sweep: calibrating the numerical "
                          "check", unit="sample", file=sys.stderr) as bar:  # fmt: skip
            for fut in futures:
                wait([fut])
                bar.update(1)
    results = [nominal_point, *cl.gather(futures)]
    return calibrate(results, len(nom_rec.dwell_ids))


def _versions() -> dict:
    import importlib.metadata as md

    from ringqa import __version__

    out = {"ringqa": __version__, "python": platform.python_version()}
    for name in ("numpy", "numba", "dask", "distributed", "SALib", "h5py", "scipy"):
        try:
            out[name] = md.version(name)
        except md.PackageNotFoundError:  # pragma: no cover
            out[name] = None
    return out


def run_sweep(
    spec: SweepSpec,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: bool = False,
    client=None,
    partial: bool = False,
) -> SweepResult:
    """Run a sweep (see the module docstring); ``client``: an existing
    ``distributed.Client`` (tests), else :func:`~ringqa.sweep.execute.connect`; ``partial``:
    run nothing, write the outputs from the samples already in ``samples.h5`` (a long study
    looked at while it is unfinished; ``--partial``)."""
    from ringqa.sweep.execute import connect, stream

    t_start = time.perf_counter()
    out = check_writable(out, ours=(SAMPLES_NAME,))
    h5 = out / SAMPLES_NAME
    if h5.exists():  # a sweep to resume: refuse another spec's samples before any work
        with SampleStore(h5, spec.digest(), spec.names, (), ()) as st:
            n_done_before = len(st.done())
    elif partial:
        raise RingQAError(f"--partial: {h5} does not exist: no finished samples to summarise")
    else:
        n_done_before = 0
    table = design(spec)
    job = job_of(spec)
    nominal = nominal_values(spec)
    with contextlib.ExitStack() as stack:
        t_cluster = time.perf_counter()
        cl = client
        if (
            cl is None and scheduler and not partial
        ):  # an unreachable scheduler fails before the nominal run
            cl = stack.enter_context(connect(scheduler, workers))
        cluster_s = time.perf_counter() - t_cluster
        t0 = time.perf_counter()
        status_line("ringqa sweep: the nominal run (every parameter at its centre)", progress)
        nom_rec, reference_mm, nom_res = _nominal(job, nominal)
        nominal_s = time.perf_counter() - t0
        cheap = spec.numerics == "calibrated"
        nom_cheap = None
        if cheap:  # the nominal cheap sample: prepares this process, then times a sample
            cheap_sample(job, -1, nominal, None, None)
            nom_cheap = cheap_sample(job, -1, nominal, None, None)
            if not nom_cheap.ok:
                raise RingQAError(
                    "the nominal run (every parameter at its centre) failed as a single engine "
                    f"run at the commissioning settings: {nom_cheap.message} (numerics = "
                    '"full" runs every sample as a full commissioning run)'
                )
        # a local cluster starts after the nominal run warmed the numba cache
        if cl is None and not partial:
            t_cluster = time.perf_counter()
            n_start = workers or os.cpu_count() or 1
            status_line(f"ringqa sweep: starting {n_start} worker process(es); each loads the "
                        "numerical kernels once", progress)  # fmt: skip
            cl = stack.enter_context(connect(None, workers))
            cluster_s = time.perf_counter() - t_cluster
        n_workers = 0 if cl is None else len(cl.scheduler_info().get("workers", {}))
        out.mkdir(parents=True, exist_ok=True)
        with SampleStore(
            h5, spec.digest(), spec.names, nom_rec.dwell_ids, nom_rec.point_names
        ) as st:
            done = st.done()
            todo = [] if partial else [(i, table[i]) for i in range(len(table)) if i not in done]
            t_cal = time.perf_counter()
            bound = None
            if cheap:
                bound = st.numerical_bound()
                if bound is None and cl is not None:
                    bound = _calibrate(cl, job, table, spec, nom_rec, nom_cheap, nominal,
                                       progress)  # fmt: skip
                    st.set_numerical_bound(bound)
            calibration_s = time.perf_counter() - t_cal
            sample_s = nom_cheap.seconds if cheap else nom_rec.seconds
            batch_size = spec.batch_size or auto_batch_size(sample_s, len(todo), n_workers)
            budget_s = spec.sample_budget_s or (bound.budget_s if bound is not None else None)
            bar = _bar(len(table), len(done), progress)
            t_run = time.perf_counter()

            guard = _AppendGuard()
            shown = _Shown(bar, len(done), len(table))

            def on_batch(records: list[SampleRecord]) -> None:
                with guard:
                    st.append(records)
                shown.stored(len(records))

            try:
                with guard.installed():
                    if todo and cheap:
                        err = None if bound is None else [float(x) for x in bound.error_mm]
                        ticks = f"ringqa-sweep-{uuid.uuid4().hex}" if progress else None
                        stream(cl, job, todo, batch_size, on_batch, nominal, run_cheap_batch,
                               (err, budget_s, ticks),
                               None if ticks is None else (ticks, shown.ticked))  # fmt: skip
                    elif todo:
                        ticks = f"ringqa-sweep-{uuid.uuid4().hex}" if progress else None
                        stream(cl, job, todo, batch_size, on_batch, nominal, run_ticking_batch,
                               (ticks,),
                               None if ticks is None else (ticks, shown.ticked))  # fmt: skip
            finally:
                bar.close()
            run_s = time.perf_counter() - t_run
    samples = read_samples(h5, limit=len(table))
    summ = summary(samples, nom_rec.positions_mm)
    sens = sensitivity(samples, spec.names, salib_problem(spec) if spec.method == "sobol" else None)
    failures = [
        {"index": int(i), "values": [float(v) for v in vals], "message": m}
        for i, vals, ok, m in zip(
            samples.index, samples.values, samples.ok, samples.message, strict=True
        )
        if not ok
    ]
    failed_report = failure_report(samples, spec.names, [float(v) for v in nominal])
    sens_reason = sensitivity_reason(samples, spec.names)
    n_new = len(todo)
    sample_s = float(np.sum(samples.seconds))
    record = {
        "spec": dict(spec.raw),
        "spec_file": spec.path,
        "spec_digest": spec.digest(),
        "seed": spec.seed,
        "method": spec.method,
        "n_runs": n_runs(spec),
        "partial": bool(partial and len(samples.index) < len(table)),
        "n_ok": int(samples.ok.sum()),
        "n_failed": int((~samples.ok).sum()),
        "resumed_from": n_done_before,
        "computed_now": n_new,
        "versions": _versions(),
        "execution": {
            "scheduler": scheduler or "LocalCluster (processes)",
            "workers": n_workers,
            "batch_size": batch_size,
            "batch_size_auto": spec.batch_size == 0,
            "sample_budget_s": budget_s,
            "workers_used": sorted(set(samples.worker)),
        },
        "timings_s": {
            "nominal_run": nominal_s,
            "cluster_start": cluster_s,
            "calibration": calibration_s,
            "samples_wall": run_s,
            "samples_wall_sum": sample_s,
            "samples_cpu_sum": float(np.nansum(samples.cpu_seconds)),
            "mean_per_sample": sample_s / max(1, len(samples.index)),
            "mean_cpu_per_sample": float(np.nanmean(samples.cpu_seconds))
            if np.isfinite(samples.cpu_seconds).any()
            else None,
            "total": time.perf_counter() - t_start,
        },
        "nominal": {
            "values": dict(zip(spec.names, nominal, strict=True)),
            "max_deviation_mm": float(np.max(nom_rec.dwell["deviation_mm"])),
            "max_numerical_error_mm": float(np.max(nom_rec.dwell["numerical_error_mm"])),
            # the nominal run's dose differences as the report's verdicts judge them (to the
            # registered reference plan): the uncertainty page's intervals are of these
            "dose_diff_pct": dict(
                zip(nom_rec.point_names, map(float, nom_rec.point["dose_diff_pct"]), strict=True)
            ),
        },
        "spread_vs_numerics": _spread_vs_numerics(summ),
        "numerical_check": bound.as_dict()
        if bound is not None
        else {
            "mode": spec.numerics,
            "text": "every sample is a full commissioning run with its own numerical check"
            if spec.numerics == "full"
            else "not calibrated (no finished calibration)",
        },
        "numerics": spec.numerics,
        "parameters": [
            {"key": p.key, "distribution": p.distribution, **p.args, "source": p.source}
            for p in spec.parameters
        ],
        "failures": failures,
        "failure_report": failed_report,
        "intervals": (
            "every sample succeeded"
            if failed_report["n_failed"] == 0
            else f"conditional on success: {failed_report['n_failed']} of "
            f"{failed_report['n']} samples ({failed_report['failed_fraction']:.1%}) failed and "
            "are not in the means, sds and percentiles"
        ),
        "sensitivity_note": sens_reason,
    }
    _write(
        out,
        summ,
        sens,
        record,
        samples,
        nom_rec.positions_mm,
        reference_mm,
        f"{nom_res.applicator}: {display_path(spec.path)}"  # never an install path
        + (
            f" ({failed_report['n_failed']} of {failed_report['n']} samples failed: intervals "
            "conditional on success)"
            if failed_report["n_failed"]
            else ""
        ),
    )
    return SweepResult(out, samples, summ, sens, record)


def _spread_vs_numerics(summ: pd.DataFrame) -> dict:
    """Largest per-dwell sd of the parameter spread (shift) and largest mean numerical error."""
    shift = summ[summ["quantity"] == "shift_mm"]["sd"].to_numpy(float)
    num = summ[summ["quantity"] == "numerical_error_mm"]["mean"].to_numpy(float)
    a = float(np.nanmax(shift)) if np.isfinite(shift).any() else float("nan")
    b = float(np.nanmax(num)) if np.isfinite(num).any() else float("nan")
    return {
        "max_sd_shift_mm": a,
        "max_mean_numerical_error_mm": b,
        "dominant": "parameters" if a > b else "numerics",
    }


def _write(out, summ, sens, record, samples, nominal_mm, reference_mm, title) -> None:
    from ringqa.jsonio import write_json
    from ringqa.sweep.figures import uncertainty_figure

    with staged_output(out, ours=(SAMPLES_NAME,)) as stage:
        summ.to_csv(stage / "summary.csv", index=False, float_format="%.6g")
        sens.to_csv(stage / "sensitivity.csv", index=False, float_format="%.6g")
        write_json(stage / "sweep.json", record)
        fig = uncertainty_figure(samples, nominal_mm, reference_mm, summ, title)
        fig.savefig(stage / "uncertainty.png", dpi=110)


class _Shown:
    """The progress bar's count: samples finished on the workers (per sample, from the tasks'
    ticks) or stored (per task), whichever is ahead, never past the total (a retried task ticks
    twice)."""

    def __init__(self, bar, done: int, total: int) -> None:
        import threading

        self.bar, self.total = bar, total
        self.n_stored = self.n_ticked = done
        self.lock = threading.Lock()

    def _show(self) -> None:
        n = min(self.total, max(self.n_stored, self.n_ticked))
        if n > self.bar.n:
            self.bar.update(n - self.bar.n)

    def stored(self, k: int) -> None:
        with self.lock:
            self.n_stored += k
            self._show()

    def ticked(self, k: int) -> None:
        with self.lock:
            self.n_ticked += k
            self._show()


class _AppendGuard:
    """SIGINT/SIGTERM/SIGHUP while samples stream: stop the sweep (KeyboardInterrupt), but never
    in the middle of appending a batch to samples.h5 (a signal then waits for the append to
    finish), so an interrupted sweep keeps a readable file with every finished sample."""

    def __init__(self) -> None:
        self.busy = False
        self.pending: int | None = None

    def _handler(self, signum, frame) -> None:
        if self.busy:
            self.pending = signum
            return
        raise KeyboardInterrupt(signal.Signals(signum).name)

    def __enter__(self) -> None:
        self.busy = True

    def __exit__(self, *exc) -> None:
        self.busy = False
        if self.pending is not None:
            signum, self.pending = self.pending, None
            raise KeyboardInterrupt(signal.Signals(signum).name)

    @contextlib.contextmanager
    def installed(self):
        """The handler for SIGINT, SIGTERM and SIGHUP (main thread only; restored after)."""
        import threading

        if threading.current_thread() is not threading.main_thread():
            yield
            return
        previous = {}
        for sig in HANDLED_SIGNALS:
            old = signal.getsignal(sig)
            if old is None or old is signal.SIG_IGN:
                continue
            previous[sig] = old
            signal.signal(sig, self._handler)
        try:
            yield
        finally:
            for sig, old in previous.items():
                signal.signal(sig, old)


def _bar(total: int, done: int, show: bool):
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    return tqdm(
        total=total,
        initial=done,
        disable=not show,
        unit="sample",
        file=sys.stderr,
        desc="ringqa sweep",
    )
