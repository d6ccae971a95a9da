"""Commission several applicators in one go (e.g. the six shipped rings); one failure does not
stop the others."""

from __future__ import annotations

import os
import pickle
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from ringqa import parallel
from ringqa.errors import RingQAError
from ringqa.parallel import default_workers, worker_signals
from ringqa.pipeline import simulate
from ringqa.pipeline.commission import commission
from ringqa.pipeline.result import CommissioningResult
from ringqa.pipeline.settings import CommissionSettings
from ringqa.pipeline.simulate import (
    Engine,
    SimulationJammedError,
    default_engine,
    kernels_cached,
    own_engine,
)


@dataclass(frozen=True, eq=False)
class BatchResult:
    """Results of :func:`commission_batch`.

    Attributes
    ----------
    results : tuple of CommissioningResult
        The applicators that completed, in input order.
    failures : tuple of (str, str)
        (input, one-line reason) for each applicator that failed.
    summary : pandas.DataFrame
        One row per input: the result's summary row (:meth:`Summary.as_row`), or
        ``applicator``, ``verdict`` = ``"ERROR"`` and ``error`` for a failure; ``folder`` names
        the result's output subfolder (empty for a failure).
    labels : tuple of str
        One per result, unique in the batch: the output subfolder (the applicator's name made
        safe for a file name; ``name-2``, ``name-3`` ... for a repeated name, so two inputs never
        share or overwrite a folder).
    solver_failures : tuple of str
        The inputs of :attr:`failures` whose simulation jammed or failed
        (:class:`~ringqa.pipeline.simulate.SimulationJammedError`; ``ringqa commission`` exits
        3), as opposed to bad input.
    """

    results: tuple[CommissioningResult, ...]
    failures: tuple[tuple[str, str], ...]
    summary: pd.DataFrame
    labels: tuple[str, ...] = ()
    solver_failures: tuple[str, ...] = ()

    def label(self, i: int) -> str:
        """The output subfolder of ``results[i]``."""
        if self.labels:
            return self.labels[i]
        return unique_label(self.results[i].applicator, set())

    @property
    def ok(self) -> bool:
        """True when every applicator completed."""
        return not self.failures


def _label(item) -> str:
    if isinstance(item, str | Path):
        p = Path(item)
        return p.stem if p.suffix else p.name
    return str(getattr(item, "name", item))


def commission_batch(
    inputs: Iterable,
    settings: CommissionSettings | None = None,
    *,
    engine: Engine | None = None,
    progress: bool = True,
    labels: Sequence[str] | None = None,
    workers: int | None = None,
) -> BatchResult:
    """Run :func:`commission` on each input; collect results and failures.

    Parameters
    ----------
    inputs : iterable
        Anything :func:`commission` accepts (names, paths, Applicators).
    settings : CommissionSettings, optional
        The same for every input.
    engine : Engine, optional
        The simulation engine (default: ringqa's).
    progress : bool
        Show a tqdm progress bar over the applicators on stderr.
    labels : sequence of str, optional
        One label per input (e.g. the applicator's serial number): its output folder's name
        and its ``folder`` in summary.csv; default: the applicator's name. Repeated labels
        get ``-2``, ``-3``... (never two inputs in one folder).
    workers : int, optional
        Processes commissioning the inputs at once (default
        :func:`ringqa.parallel.default_workers`); the results are the same, in the same order,
        as with 1 (forked worker processes run the same code; a result that cannot be sent
        back is remade here).

    Returns
    -------
    BatchResult
        Write it with ``ringqa.report.write_batch(batch, out_dir)``.
    """
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    items = list(inputs)
    check_labels(labels, len(items))
    results: list[CommissioningResult] = []
    failures: list[tuple[str, str]] = []
    solver: list[str] = []
    rows = []
    folders: list[str] = []
    taken: set[str] = set()
    bar = tqdm(total=len(items), desc="commission", unit="applicator", disable=not progress)
    n_workers = default_workers() if workers is None else max(1, int(workers))
    outcomes = _outcomes(items, settings, engine, n_workers, bar, labels)
    for k, (res, reason, jammed) in enumerate(outcomes):
        label = _label(items[k]) if labels is None else str(labels[k])
        bar.update()
        if res is None:
            failures.append((label, reason))
            if jammed:
                solver.append(label)
            rows.append({"applicator": label, "verdict": "ERROR", "error": reason,
                         "input": _input_name(items[k])})  # fmt: skip
            continue
        results.append(res)
        folders.append(unique_label(res.applicator if labels is None else label, taken))
        rows.append({**res.summary_row(), "error": "", "folder": folders[-1]})
    bar.close()
    return BatchResult(tuple(results), tuple(failures), pd.DataFrame(rows), tuple(folders),
                       tuple(solver))  # fmt: skip


def _input_name(item) -> str:
    """A failed input as summary.csv's ``input`` names it (as given; ``ringqa:data/...`` for a
    shipped file)."""
    from ringqa.provenance import display_path

    if isinstance(item, str | Path) and Path(item).exists():
        return display_path(item)
    return str(getattr(item, "name", item))


def _commission_one(item, settings, engine) -> tuple[CommissioningResult | None, str, bool]:
    """``(result, "", False)``, or ``(None, one-line reason, jammed)`` when ``item`` failed
    (``jammed``: the simulation jammed or failed, not the input)."""
    try:
        return commission(item, settings, engine=engine), "", False
    except Exception as exc:  # one applicator must not stop the batch
        reason = " ".join(str(exc).split()) or type(exc).__name__
        if not _is_user_error(exc):
            reason = f"{type(exc).__name__}: {reason}"
        return None, reason, isinstance(exc, SimulationJammedError)


def _worker_init() -> None:
    """A batch's worker: the signals of :func:`~ringqa.parallel.worker_signals`, and its
    simulations run one at a time (the workers use the cores already)."""
    worker_signals()
    simulate.CONCURRENT_RUNS = False


def _worker_task(k: int) -> tuple[str, bytes | str]:
    """Commission input ``k`` of the pool's job ``(items, settings, engine)`` in a worker:
    ``("ok", pickled (result, reason))``, or ``("here", "")`` when the result cannot be pickled
    (the parent remakes it)."""
    items, settings, engine = parallel.job()
    out = _commission_one(items[k], settings, engine)
    try:
        return "ok", pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:
        return "here", ""


def _outcomes(items, settings, engine, workers: int, bar, labels) -> Iterator[tuple]:
    """``(result or None, reason)`` per input, in input order; ``workers`` > 1: computed by a
    pool of forked processes."""

    def show(k: int) -> None:
        bar.set_postfix_str(_label(items[k]) if labels is None else str(labels[k]))

    if workers > 1 and (engine is None or own_engine(engine)) and not kernels_cached():
        workers = 1  # numba compiles on this first run: every worker would compile it all
    if workers <= 1 or len(items) <= 1 or not hasattr(os, "fork"):
        for k, item in enumerate(items):
            show(k)
            yield _commission_one(item, settings, engine)
        return
    if engine is None:
        default_engine()  # import the engine once, before forking (the workers inherit it)
    job = (items, settings, engine)
    with parallel.worker_pool(min(workers, len(items)), _worker_init, job) as pool:
        for k, (tag, data) in enumerate(pool.imap(_worker_task, range(len(items)))):
            show(k)
            if tag == "ok":
                yield pickle.loads(data)
            else:
                yield _commission_one(items[k], settings, engine)


def check_labels(labels: Sequence[str] | None, n_inputs: int) -> None:
    """Refuse labels (``--label``) that are not one per input (RingQAError)."""
    if labels is not None and len(labels) != n_inputs:
        raise RingQAError(
            f"--label: {len(labels)} label(s) for {n_inputs} input(s); give one --label per "
            "input, in the order of the inputs"
        )


def unique_label(name: str, taken: set[str]) -> str:
    """``name`` made safe for a folder name (letters, digits, ``-_.``; others ``_``), with
    ``-2``, ``-3`` ... appended while it is in ``taken`` (compared case-insensitively, as some
    file systems do); the result is added to ``taken``."""
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in str(name)).strip("._")
    safe = safe or "applicator"
    label, k = safe, 1
    while label.lower() in taken:
        k += 1
        label = f"{safe}-{k}"
    taken.add(label.lower())
    return label


def _is_user_error(exc: Exception) -> bool:
    from tg43.errors import TG43Error

    return isinstance(exc, RingQAError | TG43Error)
