"""Commission several applicators in one go (e.g. the six shipped rings); one failure does not
stop the others."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from ringqa.errors import RingQAError
from ringqa.pipeline.commission import commission
from ringqa.pipeline.result import CommissioningResult
from ringqa.pipeline.settings import CommissionSettings
from ringqa.pipeline.simulate import Engine


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
        ``applicator``, ``verdict`` = ``"ERROR"`` and ``error`` for a failure.
    """

    results: tuple[CommissioningResult, ...]
    failures: tuple[tuple[str, str], ...]
    summary: pd.DataFrame

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

    Returns
    -------
    BatchResult
        Write it with ``ringqa.report.write_batch(batch, out_dir)``.
    """
    from tqdm import tqdm

    items = list(inputs)
    results: list[CommissioningResult] = []
    failures: list[tuple[str, str]] = []
    rows = []
    bar = tqdm(items, desc="commission", unit="applicator", disable=not progress)
    for item in bar:
        label = _label(item)
        bar.set_postfix_str(label)
        try:
            res = commission(item, settings, engine=engine)
        except Exception as exc:  # one applicator must not stop the batch
            reason = " ".join(str(exc).split()) or type(exc).__name__
            if not _is_user_error(exc):
                reason = f"{type(exc).__name__}: {reason}"
            failures.append((label, reason))
            rows.append({"applicator": label, "verdict": "ERROR", "error": reason})
            continue
        results.append(res)
        rows.append({**res.summary.as_row(), "error": ""})
    return BatchResult(tuple(results), tuple(failures), pd.DataFrame(rows))


def _is_user_error(exc: Exception) -> bool:
    from tg43.errors import TG43Error

    return isinstance(exc, RingQAError | TG43Error)
