"""The paper's channel study (Figures 8 and 9): three families, each at D and D + 0.2 mm.

Families (Straathof et al. 2024, section 2.4; every channel at the nominal diameter and at the
printing tolerance's +0.2 mm):

- ``radius``: r = 20, 25, ... 60 mm, tau = 0, 2.6 mm (9 channels, 18 runs);
- ``torsion``: tau = 0, pi/4, pi/2, 3 pi/4, pi, r = 35 mm, 2.6 mm (5, 10);
- ``diameter``: D = 2.6, 2.8, 3.0 mm, r = 35 mm, tau = 0 (3, 6).

34 rows; the r = 35 mm / tau = 0 channel at 2.6 and 2.8 mm appears in every family and the
2.8 mm one again as the diameter family's +0.2 mm of 2.6 mm, so 28 distinct channels are
simulated (each once) and the rows reuse them.

The runs are independent: they go to a :class:`concurrent.futures.ProcessPoolExecutor` (forked
workers on Linux, spawned elsewhere: :func:`start_method`). The kernels are warm in every worker
before its first run: a forked worker inherits them from the parent, which warms them first; a
spawned one loads them from numba's on-disk cache; either way the initializer runs a tiny
warm-up scene, so no run's solve time includes compilation. ``workers=1`` runs in this process.
A run the engine refuses to set up (a :class:`~ringqa.errors.RingQAError`) becomes a row with
status -1 and the reason; the channels are checked before any run (:func:`check_spec`).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry.s_channel import DIAMETER_TOLERANCE_MM, NOMINAL_DIAMETER_MM
from ringqa.needle.peaks import FILTER_WINDOW_MM
from ringqa.needle.run import NeedleRun, failed_run, run_channel
from ringqa.needle.scene import ChannelSpec, NeedleError, check_spec, paper_channel
from ringqa.simulation import Scene

FAMILIES = ("radius", "torsion", "diameter")
#: ``--sweep paper`` = all three families.
PAPER = "paper"
PAPER_RADII_MM = tuple(float(r) for r in range(20, 61, 5))
PAPER_TORSIONS_RAD = tuple(float(t) for t in np.linspace(0.0, math.pi, 5))
PAPER_DIAMETERS_MM = (2.6, 2.8, 3.0)
#: Fixed values of the families that do not vary them (section 2.4).
FAMILY_RADIUS_MM = 35.0
FAMILY_TORSION_RAD = 0.0

#: Columns of the sweep's peaks table, in order.
PEAK_COLUMNS = (
    "family",
    "radius_mm",
    "torsion_rad",
    "diameter_mm",
    "nominal_diameter_mm",
    "peak1_n",
    "peak1_depth_mm",
    "plateau_n",
    "plateau_depth_mm",
    "plateau_from_mm",
    "plateau_to_mm",
    "peak2_n",
    "peak2_depth_mm",
    "status",
    "message",
    "solve_time_s",
    "wall_time_s",
    "n_elements",
)


@dataclass(frozen=True)
class SweepPoint:
    """One row of the study: a family entry at its nominal or +0.2 mm diameter.

    Attributes
    ----------
    family : str
        ``radius``, ``torsion`` or ``diameter``.
    radius_mm, torsion_rad : float
        The channel's bend radius (mm) and torsion (rad).
    nominal_diameter_mm : float
        The family entry's (designed) diameter (mm).
    diameter_mm : float
        The diameter simulated (mm): nominal, or nominal + 0.2 mm.
    """

    family: str
    radius_mm: float
    torsion_rad: float
    nominal_diameter_mm: float
    diameter_mm: float

    @property
    def spec(self) -> ChannelSpec:
        """The channel simulated."""
        return ChannelSpec(self.radius_mm, self.torsion_rad, self.diameter_mm)

    @property
    def key(self) -> tuple[float, float, float]:
        """Identifies the simulated channel (rounded: equal channels share one run)."""
        return (round(self.radius_mm, 9), round(self.torsion_rad, 9), round(self.diameter_mm, 9))


def parse_families(text: str | Iterable[str]) -> tuple[str, ...]:
    """``"paper"`` -> all three families; otherwise a comma-separated subset of them.

    Raises
    ------
    NeedleError
        For an unknown family name (the message lists the choices).
    """
    names = [t.strip() for t in (text.split(",") if isinstance(text, str) else text)]
    names = [n for n in names if n]
    if not names:
        raise NeedleError(f"--sweep: no family given (choose {PAPER}, or {', '.join(FAMILIES)})")
    out: list[str] = []
    for n in names:
        if n == PAPER:
            out.extend(FAMILIES)
        elif n in FAMILIES:
            out.append(n)
        else:
            raise NeedleError(
                f"--sweep {n}: unknown family {n!r} (choose {PAPER}, or one or more of "
                f"{', '.join(FAMILIES)} separated by commas)"
            )
    return tuple(f for f in FAMILIES if f in out)


def paper_points(families: Sequence[str] = FAMILIES) -> list[SweepPoint]:
    """The study's rows for ``families`` (module docstring), nominal then +0.2 mm each."""
    tol = DIAMETER_TOLERANCE_MM
    entries: list[tuple[str, float, float, float]] = []
    for fam in parse_families(list(families)):
        if fam == "radius":
            entries += [(fam, r, 0.0, NOMINAL_DIAMETER_MM) for r in PAPER_RADII_MM]
        elif fam == "torsion":
            entries += [(fam, FAMILY_RADIUS_MM, t, NOMINAL_DIAMETER_MM) for t in PAPER_TORSIONS_RAD]
        else:
            entries += [(fam, FAMILY_RADIUS_MM, FAMILY_TORSION_RAD, d) for d in PAPER_DIAMETERS_MM]
    return [
        SweepPoint(fam, r, t, d, round(d + extra, 9))
        for fam, r, t, d in entries
        for extra in (0.0, tol)
    ]


@dataclass(frozen=True)
class SweepResult:
    """The study's runs.

    Attributes
    ----------
    points : tuple of SweepPoint
        The rows, in study order.
    runs : dict
        ``SweepPoint.key`` -> :class:`NeedleRun` (one per distinct channel).
    wall_time_s : float
        Wall time of the whole sweep (s), pool start-up included.
    workers : int
        Processes used.
    settings : Scene
        The settings every run used.
    """

    points: tuple[SweepPoint, ...]
    runs: dict[tuple[float, float, float], NeedleRun]
    wall_time_s: float
    workers: int
    settings: Scene

    def run(self, point: SweepPoint) -> NeedleRun:
        """The run of a row."""
        return self.runs[point.key]

    def peaks_table(self):
        """One row per study point (:data:`PEAK_COLUMNS`), as a pandas DataFrame."""
        import pandas as pd

        rows = []
        for p in self.points:
            r = self.run(p)
            rows.append(
                {
                    "family": p.family,
                    "radius_mm": p.radius_mm,
                    "torsion_rad": p.torsion_rad,
                    "diameter_mm": p.diameter_mm,
                    "nominal_diameter_mm": p.nominal_diameter_mm,
                    **{k: v for k, v in r.peaks.as_dict().items() if k != "split_mm"},
                    "status": r.status,
                    "message": r.message,
                    "solve_time_s": r.solve_time_s,
                    "wall_time_s": r.wall_time_s,
                    "n_elements": r.n_elements,
                }
            )
        return pd.DataFrame(rows, columns=list(PEAK_COLUMNS))

    def force_table(self):
        """Long table: ``family, radius_mm, torsion_rad, diameter_mm, depth_mm, force_n,
        force_raw_n, nominal_diameter_mm`` (force_n filtered), one row per depth per study row."""
        import pandas as pd

        parts = []
        for p in self.points:
            r = self.run(p)
            n = r.depth_mm.size
            parts.append(
                pd.DataFrame(
                    {
                        "family": [p.family] * n,
                        "radius_mm": p.radius_mm,
                        "torsion_rad": p.torsion_rad,
                        "diameter_mm": p.diameter_mm,
                        "depth_mm": r.depth_mm,
                        "force_n": r.force_n,
                        "force_raw_n": r.force_raw_n,
                        "nominal_diameter_mm": p.nominal_diameter_mm,
                    }
                )
            )
        return pd.concat(parts, ignore_index=True)


# ---- worker side ---------------------------------------------------------------------------
_WORKER: dict = {}


def _init_worker(settings: Scene, depth_mm: float | None, window_mm: float) -> None:
    """Pool initializer: keep the settings, load the kernels and warm them on a tiny run."""
    _WORKER.update(settings=settings, depth_mm=depth_mm, window_mm=window_mm)
    warm_up(settings)


def warm_up(settings: Scene) -> None:
    """Run the catheter 2 mm into a short channel once (compiles or loads the numba kernels)."""
    run_channel(paper_channel(ChannelSpec(), settings), settings, depth_mm=2.0)


def _run_spec(spec: ChannelSpec) -> NeedleRun:
    s = _WORKER
    channel = paper_channel(spec, s["settings"])
    try:
        return run_channel(channel, s["settings"], s["depth_mm"], s["window_mm"])
    except RingQAError as exc:  # the engine refused this channel: a result, not a crash
        return failed_run(channel, s["settings"], str(exc), s["depth_mm"])


def start_method() -> str:
    """How the pool starts its workers: ``fork`` on Linux (a worker is ready in milliseconds and
    inherits the parent's compiled kernels and imports), ``spawn`` elsewhere (macOS and Windows,
    where forking is unsafe or absent; each worker then imports ringqa and loads the kernels from
    numba's on-disk cache, ~2-4 s, and a script calling :func:`run_sweep` needs the
    ``if __name__ == "__main__":`` guard)."""
    return "fork" if sys.platform.startswith("linux") else "spawn"


def default_workers() -> int:
    """Two processes (the development machine's cores), fewer when the machine has fewer."""
    return max(1, min(2, os.cpu_count() or 1))


def run_sweep(
    settings: Scene,
    families: Sequence[str] | str = FAMILIES,
    workers: int | None = None,
    progress: bool = True,
    depth_mm: float | None = None,
    window_mm: float = FILTER_WINDOW_MM,
) -> SweepResult:
    """Simulate the study's channels (each distinct channel once) over a process pool.

    Parameters
    ----------
    settings : Scene
        The needle settings (:func:`ringqa.needle.scene.load_settings`).
    families : sequence of str or str
        Family names, or ``"paper"`` for all three (:func:`parse_families`).
    workers : int, optional
        Processes (default :func:`default_workers`); 1 runs in this process.
    progress : bool
        Show a tqdm progress bar (channels finished).
    depth_mm : float, optional
        Insertion depth (default 120 mm).
    window_mm : float
        Moving-average window (mm).

    Returns
    -------
    SweepResult

    Raises
    ------
    NeedleError
        Unknown family, or a channel the catheter cannot be simulated in (checked for every
        channel before any run starts).
    """
    fams = parse_families(families)
    points = tuple(paper_points(fams))
    specs: dict[tuple[float, float, float], ChannelSpec] = {}
    for p in points:
        specs.setdefault(p.key, p.spec)
    for spec in specs.values():
        check_spec(spec, settings)
    n_workers = default_workers() if workers is None else int(workers)
    if n_workers < 1:
        raise NeedleError(f"--workers {workers}: at least 1")
    n_workers = min(n_workers, len(specs))
    # tightest channels first: they take longest, so the pool's two queues end together
    order = sorted(specs, key=lambda k: (k[0], k[2]))
    from ringqa.progress import progress_bar as tqdm  # plain lines when not a terminal

    t0 = time.perf_counter()
    runs: dict[tuple[float, float, float], NeedleRun] = {}
    if n_workers == 1:
        _init_worker(settings, depth_mm, window_mm)
        with tqdm(
            total=len(order), unit="channel", desc="needle sweep", disable=not progress
        ) as bar:
            for key in order:
                runs[key] = _run_spec(specs[key])
                bar.update(1)
    else:
        method = start_method()
        if method == "fork":
            warm_up(settings)  # the forked workers inherit the compiled kernels
        with ProcessPoolExecutor(
            max_workers=n_workers,
            mp_context=multiprocessing.get_context(method),
            initializer=_init_worker,
            initargs=(settings, depth_mm, window_mm),
        ) as pool:
            # submit before the progress bar exists: the workers start here, before tqdm's
            # monitor thread (a forked process should not inherit running threads)
            futures = {pool.submit(_run_spec, specs[k]): k for k in order}
            with tqdm(
                total=len(order), unit="channel", desc="needle sweep", disable=not progress
            ) as bar:
                try:
                    for fut in as_completed(futures):
                        runs[futures[fut]] = fut.result()
                        bar.update(1)
                except BaseException:
                    pool.shutdown(wait=False, cancel_futures=True)
                    raise
    return SweepResult(
        points=points,
        runs=runs,
        wall_time_s=time.perf_counter() - t0,
        workers=n_workers,
        settings=settings,
    )
