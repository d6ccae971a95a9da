"""Finished runs and where they are kept: the run record, its key, the ``runs.jsonl`` cache.

A run's key hashes the scene's settings (user units) with the engine's source and the channel's
geometry, so a changed engine or applicator is re-run; finished runs are appended one JSON line
each, so an interrupted study resumes without losing them.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import statistics
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ringqa.jsonio import json_text
from ringqa.simulation.scenefile import scene_to_dict, scene_with_overrides

CACHE_NAME = "runs.jsonl"


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


def scene_salt(scene) -> str:
    """What besides the settings decides a run: the engine's source and the channel's geometry."""
    return engine_fingerprint() + channel_fingerprint(scene.channel)


def key_of(scene, overrides: Mapping[str, Any]) -> str:
    """Cache key of ``scene`` with ``overrides`` (dotted keys, user units) applied.

    Raises
    ------
    RingQAError
        A bad override (the scene file's checker names the key).
    """
    s = scene_with_overrides(scene, overrides) if overrides else scene
    return run_key(scene_to_dict(s), scene_salt(s))


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
        """One line of ``runs.jsonl`` (:func:`ringqa.jsonio.json_text`: NaN is written as null;
        :meth:`from_json` reads it back as NaN)."""
        return json_text(
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
            indent=None,
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


class RunCache:
    """Finished runs, one JSON line each in ``DIR/runs.jsonl`` (or in memory without a DIR).

    Parameters
    ----------
    path : Path or None
        The ``runs.jsonl`` file (None: keep runs in memory only).
    resume : bool
        Read the runs already in ``path``; False deletes the file.
    """

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
        """The finished run of this key, or None."""
        return self.runs.get(key)

    def put(self, rec: RunRecord) -> None:
        """Keep ``rec`` and append it to the file."""
        self.runs[rec.key] = rec
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            with open(self.path, "a") as fh:
                fh.write(rec.as_json() + "\n")
                fh.flush()


def load_cached_runs(out_dir: str | Path) -> list[RunRecord]:
    """The runs cached in ``out_dir/runs.jsonl`` (for inspection)."""
    path = Path(out_dir) / CACHE_NAME
    if not path.is_file():
        return []
    return [RunRecord.from_json(x) for x in path.read_text().splitlines() if x.strip()]
