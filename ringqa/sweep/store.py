"""``samples.h5``: one record per finished sample, appended as results arrive (resumable).

Layout (h5py): attributes ``spec_digest`` (a resumed sweep must match it), ``parameters``,
``dwells``, ``points``; resizable datasets along the first axis, one row per finished sample
in the order they finished:

- ``index`` (n,) int, ``values`` (n, D) float (flags as 0/1), ``ok`` (n,) bool,
  ``message`` (n,) str, ``seconds`` and ``cpu_seconds`` (n,) float, ``worker`` (n,) str;
- ``x_mm``, ``y_mm``, ``z_mm`` and each of :data:`~ringqa.sweep.runner.DWELL_QUANTITIES`:
  (n, n_dwell) float (NaN for a failed sample);
- each of :data:`~ringqa.sweep.runner.POINT_QUANTITIES`: (n, n_point) float.

The file is flushed after every batch, so a killed sweep keeps every sample written before.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from ringqa.errors import RingQAError
from ringqa.sweep.runner import DWELL_QUANTITIES, POINT_QUANTITIES, SampleRecord

__all__ = ["SAMPLES_NAME", "SampleStore", "StoredSamples", "read_samples"]

SAMPLES_NAME = "samples.h5"
_STR = h5py.string_dtype()


@dataclass(frozen=True)
class StoredSamples:
    """The finished samples, sorted by index (each index once).

    Attributes
    ----------
    index : (n,) ndarray of int
    values : (n, D) ndarray
    ok : (n,) ndarray of bool
    message : list of str
    seconds : (n,) ndarray
        Wall time of each sample on its worker, s.
    cpu_seconds : (n,) ndarray
        CPU time of each sample, s (NaN in files written before it was recorded).
    worker : list of str
    arrays : dict of str to ndarray
        ``x_mm``, ``y_mm``, ``z_mm``, the dwell quantities (n, n_dwell) and the point
        quantities (n, n_point).
    parameters : tuple of str
    dwells : tuple of int
    points : tuple of str
    """

    index: np.ndarray
    values: np.ndarray
    ok: np.ndarray
    message: list[str]
    seconds: np.ndarray
    cpu_seconds: np.ndarray
    worker: list[str]
    arrays: dict[str, np.ndarray]
    parameters: tuple[str, ...]
    dwells: tuple[int, ...]
    points: tuple[str, ...]


def _row(rec: SampleRecord, n: int, quantity: str, kind: str) -> np.ndarray:
    src = rec.dwell if kind == "dwell" else rec.point
    out = np.full(n, np.nan)
    if rec.ok:
        v = np.asarray(src[quantity], dtype=float)
        out[: min(n, v.size)] = v[:n]
    return out


class SampleStore:
    """Append-only writer of ``samples.h5`` (open it with ``with``).

    Parameters
    ----------
    path : Path
        The file (created if missing).
    digest : str
        The spec's digest; an existing file with another is refused.
    parameters : sequence of str
    dwells : sequence of int
    points : sequence of str
    """

    def __init__(self, path: Path, digest: str, parameters, dwells, points) -> None:
        self.path = Path(path)
        self.digest = digest
        self.parameters = tuple(parameters)
        self.dwells = tuple(int(d) for d in dwells)
        self.points = tuple(str(p) for p in points)
        self._f: h5py.File | None = None

    def __enter__(self) -> SampleStore:
        new = not self.path.exists()
        self._f = h5py.File(self.path, "a")
        f = self._f
        if new or "index" not in f:
            f.attrs["spec_digest"] = self.digest
            f.attrs["parameters"] = list(self.parameters)
            f.attrs["dwells"] = list(self.dwells)
            f.attrs["points"] = list(self.points)
            d, nd, npt = len(self.parameters), len(self.dwells), len(self.points)
            f.create_dataset("index", (0,), maxshape=(None,), dtype="i8")
            f.create_dataset("values", (0, d), maxshape=(None, d), dtype="f8")
            f.create_dataset("ok", (0,), maxshape=(None,), dtype="bool")
            f.create_dataset("message", (0,), maxshape=(None,), dtype=_STR)
            f.create_dataset("seconds", (0,), maxshape=(None,), dtype="f8")
            f.create_dataset("cpu_seconds", (0,), maxshape=(None,), dtype="f8")
            f.create_dataset("worker", (0,), maxshape=(None,), dtype=_STR)
            for name in ("x_mm", "y_mm", "z_mm", *DWELL_QUANTITIES):
                f.create_dataset(name, (0, nd), maxshape=(None, nd), dtype="f8")
            for name in POINT_QUANTITIES:
                f.create_dataset(name, (0, npt), maxshape=(None, npt), dtype="f8")
            f.flush()
        elif f.attrs.get("spec_digest") != self.digest:
            f.close()
            raise RingQAError(
                f"{self.path}: holds samples of a different spec (other parameters, seed or "
                "input); choose a new --out folder, or delete samples.h5 to start again"
            )
        return self

    def __exit__(self, *exc) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None

    def numerical_bound(self):
        """The calibrated sweep's :class:`~ringqa.sweep.fast.NumericalBound` stored in the file
        (None: not calibrated yet)."""
        from ringqa.sweep.fast import NumericalBound

        assert self._f is not None
        text = self._f.attrs.get("numerical_bound")
        if text is None:
            return None
        d = json.loads(text)
        return NumericalBound(
            error_mm=np.asarray(d["error_mm"], dtype=float),
            **{k: tuple(v) for k, v in d.items() if k != "error_mm"},
        )

    def set_numerical_bound(self, bound) -> None:
        """Keep ``bound`` in the file (a resumed sweep reports the same numerical error)."""
        assert self._f is not None
        d = dataclasses.asdict(bound)
        d["error_mm"] = [float(x) for x in bound.error_mm]
        self._f.attrs["numerical_bound"] = json.dumps(d)
        self._f.flush()

    def done(self) -> set[int]:
        """Indices already stored."""
        assert self._f is not None
        return {int(i) for i in self._f["index"][()]}

    def append(self, records: list[SampleRecord]) -> None:
        """Append ``records`` and flush the file."""
        f = self._f
        assert f is not None
        if not records:
            return
        n0, k = f["index"].shape[0], len(records)
        nd, npt = len(self.dwells), len(self.points)
        for name in f:
            ds = f[name]
            ds.resize(n0 + k, axis=0)
        f["index"][n0:] = [r.index for r in records]
        f["values"][n0:] = np.array([[float(v) for v in r.values] for r in records]).reshape(
            k, len(self.parameters)
        )
        f["ok"][n0:] = [r.ok for r in records]
        f["message"][n0:] = [r.message for r in records]
        f["seconds"][n0:] = [r.seconds for r in records]
        if "cpu_seconds" in f:
            f["cpu_seconds"][n0:] = [r.cpu_seconds for r in records]
        f["worker"][n0:] = [r.worker for r in records]
        for j, axis in enumerate(("x_mm", "y_mm", "z_mm")):
            rows = []
            for r in records:
                row = np.full(nd, np.nan)
                if r.ok:
                    row[: min(nd, len(r.positions_mm))] = r.positions_mm[:nd, j]
                rows.append(row)
            f[axis][n0:] = np.array(rows)
        for q in DWELL_QUANTITIES:
            f[q][n0:] = np.array([_row(r, nd, q, "dwell") for r in records])
        for q in POINT_QUANTITIES:
            f[q][n0:] = np.array([_row(r, npt, q, "point") for r in records])
        f.flush()


def read_samples(path: Path, limit: int | None = None) -> StoredSamples:
    """Read ``samples.h5`` (rows sorted by sample index; ``limit``: only indices below it, the
    runs of the current design)."""
    with h5py.File(path, "r") as f:
        index, order = np.unique(f["index"][()], return_index=True)  # sorted; repeats once
        if limit is not None:
            order = order[index < limit]
        arrays = {
            name: f[name][()][order]
            for name in ("x_mm", "y_mm", "z_mm", *DWELL_QUANTITIES, *POINT_QUANTITIES)
        }
        return StoredSamples(
            index=f["index"][()][order],
            values=f["values"][()][order],
            ok=f["ok"][()][order].astype(bool),
            message=[
                m.decode() if isinstance(m, bytes) else str(m) for m in f["message"][()][order]
            ],
            seconds=f["seconds"][()][order],
            cpu_seconds=f["cpu_seconds"][()][order]
            if "cpu_seconds" in f
            else np.full(len(order), np.nan),
            worker=[w.decode() if isinstance(w, bytes) else str(w) for w in f["worker"][()][order]],
            arrays=arrays,
            parameters=tuple(str(p) for p in f.attrs["parameters"]),
            dwells=tuple(int(d) for d in f.attrs["dwells"]),
            points=tuple(str(p) for p in f.attrs["points"]),
        )
