"""Running the samples on Dask (``dask.distributed``): a local cluster or an existing one.

- :func:`connect`: a ``LocalCluster`` of worker PROCESSES (one thread each: the engine holds the
  GIL in numba kernels; processes share nothing) or a ``Client`` of the scheduler at
  ``--scheduler ADDRESS``; an unreachable address is a one-line error before anything is written.
- :func:`stream`: the samples in batches of ``batch_size`` (one Dask task each, so scheduling
  overhead, ~ms per task, stays small next to the runs), handed to ``on_batch`` in the order they
  finish. A worker that dies mid-task: Dask reruns its task on another worker; every batch
  already handed over is kept.

Each worker warms the numba on-disk cache once (:func:`warm_worker`, a worker plugin), so
samples do not pay the compilation; with the parent warmed first the workers only load it.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Sequence

from ringqa.errors import RingQAError
from ringqa.sweep.runner import Job, SampleRecord, run_batch

__all__ = ["batches", "connect", "stream", "warm_worker"]

#: seconds to wait for an existing scheduler before giving up
CONNECT_TIMEOUT_S = 10


def warm_worker(job: Job, nominal: Sequence) -> str:
    """Run the nominal sample once in this process (compiles or loads the numba kernels)."""
    from ringqa.sweep.runner import run_sample

    rec = run_sample(job, -1, nominal)
    return f"{rec.worker} warmed in {rec.seconds:.2f} s"


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
) -> None:
    """Run ``todo`` on the cluster; call ``on_batch`` with each finished batch's records
    (``nominal``: the values each worker runs once first, to warm its numba kernels)."""
    from distributed import as_completed

    # warm each worker once (numba cache); workers that join later warm on their first task
    if nominal is not None:
        with contextlib.suppress(Exception):
            client.run(warm_worker, job, list(nominal))
    futures = [
        client.submit(run_batch, job, b, pure=False, retries=2) for b in batches(todo, batch_size)
    ]
    try:
        for fut in as_completed(futures):
            on_batch(fut.result())
            fut.release()
    finally:
        for fut in futures:
            fut.cancel()
