"""Running the samples on Dask (``dask.distributed``): a local cluster or an existing one.

- :func:`connect`: a ``LocalCluster`` of worker PROCESSES (one thread each: the engine holds the
  GIL in numba kernels; processes share nothing) or a ``Client`` of the scheduler at
  ``--scheduler ADDRESS``; an unreachable address is a one-line error before anything is written.
- :func:`stream`: the samples in batches of ``batch_size`` (one Dask task each, so scheduling
  overhead, ~ms per task, stays small next to the runs), handed to ``on_batch`` in the order they
  finish. A worker that dies mid-task: Dask reruns its task on another worker; every batch
  already handed over is kept.

Each worker warms the numba on-disk cache once (:func:`warm_worker`), so samples do not pay the
compilation; with the parent warmed first the workers only load it. Every worker runs one thing
at a time on one core: numba, OpenMP and BLAS get one thread (:data:`ONE_THREAD`, set before the
worker process starts) and a worker's commissioning runs never fork children of their own
(``ringqa.pipeline.simulate.CONCURRENT_RUNS`` off in the workers). Tasks are sized from the
measured time of a sample (:func:`auto_batch_size`) and Dask's work stealing moves queued tasks
from busy to idle workers, so the tail of a sweep stays short.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence

from ringqa.errors import RingQAError
from ringqa.sweep.runner import Job, SampleRecord, run_batch, run_ticking_batch

__all__ = ["auto_batch_size", "batches", "connect", "one_core", "stream", "warm_worker"]

#: seconds to wait for an existing scheduler before giving up
CONNECT_TIMEOUT_S = 10
#: environment of a local cluster's worker processes: one thread for numba, OpenMP and BLAS
#: (the workers already use every core)
ONE_THREAD = {
    "NUMBA_NUM_THREADS": "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
#: wall time aimed at per task with ``batch_size = "auto"``, s (the scheduler's round trip of a
#: few ms stays ~1 % of it)
TASK_TARGET_S = 0.5
#: with ``batch_size = "auto"``, at least this many tasks per worker (a short tail)
TASKS_PER_WORKER = 4


def one_core() -> None:
    """This process runs one sample at a time on one core: its commissioning runs fork no
    children (the sweep's workers use the cores already)."""
    import numba

    import ringqa.pipeline.simulate as simulate

    simulate.CONCURRENT_RUNS = False
    numba.set_num_threads(1)  # a remote cluster's workers too (a local one starts with 1)


def warm_worker(job: Job, nominal: Sequence, cheap: bool = False) -> str:
    """Run the nominal sample once in this process (compiles or loads the numba kernels; a
    ``cheap`` sweep's prepared input is built too)."""
    from ringqa.sweep.runner import run_sample

    one_core()
    if cheap:
        from ringqa.sweep.fast import cheap_sample

        rec = cheap_sample(job, -1, nominal, None, None)
    else:
        rec = run_sample(job, -1, nominal)
    return f"{rec.worker} warmed in {rec.seconds:.2f} s"


def auto_batch_size(sample_s: float, n_todo: int, n_workers: int) -> int:
    """Samples per task for samples of ``sample_s`` seconds: about :data:`TASK_TARGET_S` of
    work per task, but at least :data:`TASKS_PER_WORKER` tasks per worker."""
    per_task = max(1, round(TASK_TARGET_S / max(sample_s, 1e-3)))
    spread = max(1, -(-n_todo // (TASKS_PER_WORKER * max(1, n_workers))))
    return int(max(1, min(per_task, spread)))


@contextlib.contextmanager
def connect(scheduler: str | None, workers: int | None) -> Iterator[object]:
    """A ``distributed.Client``: to ``scheduler`` (an address) or to a new local cluster of
    ``workers`` processes (default: all cores)."""
    import logging

    from distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise RingQAError(
                f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc}); start "
                "one (dask scheduler) or leave --scheduler out to use this machine's cores"
            ) from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(
        n_workers=n,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
        env=dict(ONE_THREAD),
    )
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def batches(todo: Sequence[tuple[int, Sequence]], size: int) -> list[list[tuple[int, list]]]:
    """``todo`` cut into lists of ``size`` (values as plain Python numbers)."""
    plain = [(int(i), [v.item() if hasattr(v, "item") else v for v in vals]) for i, vals in todo]
    return [plain[k : k + size] for k in range(0, len(plain), size)]


def stream(
    client,
    job: Job,
    todo: Sequence[tuple[int, Sequence]],
    batch_size: int,
    on_batch: Callable[[list[SampleRecord]], None],
    nominal: Sequence | None = None,
    task: Callable[..., list[SampleRecord]] = run_batch,
    task_args: Sequence = (),
    ticks: tuple[str, Callable[[int], None]] | None = None,
) -> None:
    """Run ``todo`` on the cluster; call ``on_batch`` with each finished batch's records
    (``nominal``: the values each worker runs once first, to warm its numba kernels; ``task``:
    the Dask task, ``task(job, batch, *task_args)``, default :func:`run_batch`; ``ticks``: the
    name of the ``distributed.Queue`` the task puts an item on per finished sample and the
    function called, from a thread here, with 1 for each new item, so that the bar steps
    through every count even when several samples finish between two polls)."""

    with _pumping(client, ticks):
        _stream(client, job, todo, batch_size, on_batch, nominal, task, task_args)


@contextlib.contextmanager
def _pumping(client, ticks):
    """A thread that empties the ``ticks`` queue every 0.2 s into its function (none: nothing)."""
    if ticks is None:
        yield
        return
    import threading

    from distributed import Queue

    name, fn = ticks
    stop = threading.Event()
    queue = Queue(name, client=client)

    def pump() -> None:
        while True:
            done = stop.wait(0.2)
            try:
                n = len(queue.get(batch=True))
            except Exception:
                return
            for _ in range(n):  # one step per sample, also when several came in one poll
                fn(1)
            if done:
                return

    thread = threading.Thread(target=pump, name="ringqa-sweep-progress", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(timeout=5)


def _stream(client, job, todo, batch_size, on_batch, nominal, task, task_args) -> None:
    from distributed import as_completed

    # warm each worker once (numba cache); workers that join later warm on their first task
    if nominal is not None:
        with contextlib.suppress(Exception):
            client.run(warm_worker, job, list(nominal),
                       task not in (run_batch, run_ticking_batch))  # fmt: skip
    futures = [
        client.submit(task, job, b, *task_args, pure=False, retries=2)
        for b in batches(todo, batch_size)
    ]
    try:
        for fut in as_completed(futures):
            on_batch(fut.result())
            fut.release()
    finally:
        for fut in futures:
            fut.cancel()
