"""One needle insertion: simulate, filter the force and extract the peaks."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ringqa.geometry import Channel
from ringqa.needle.peaks import (
    FILTER_WINDOW_MM,
    Peaks,
    bend_windows_mm,
    force_peaks,
    moving_average,
)
from ringqa.needle.scene import depth_grid_mm, n_links, needle_scene
from ringqa.simulation import Scene, simulate
from ringqa.units import m_to_mm


@dataclass(frozen=True)
class NeedleRun:
    """The insertion force against depth in one channel, and its landmarks.

    Attributes
    ----------
    name : str
        Scene name.
    depth_mm : (n,) float64
        Depth of the driven end from its start (mm; :mod:`ringqa.needle.scene`).
    force_raw_n : (n,) float64
        Axial insertion force (N) at each depth, unfiltered; NaN where not reached.
    force_n : (n,) float64
        The same filtered like the measurements (:func:`~ringqa.needle.peaks.moving_average`).
    peaks : Peaks
        1st peak, plateau, 2nd peak (from ``force_n``).
    bends_mm : tuple of (float, float)
        The channel's bends (arc length, mm).
    status : int
        The engine's status: 0 success, 1 jammed, -1 failed.
    message : str
    warnings : tuple of str
    solve_time_s : float
        Engine solve time (s; JIT excluded).
    wall_time_s : float
        Wall time of the whole run including scene set-up (s).
    n_elements : int
        Links in the modelled catheter (including the clamped one).
    settings : dict
        What the engine reports it used (``SimResult.settings``), and ``work``.
    filter_window_mm : float
        Moving-average window (mm).
    """

    name: str
    depth_mm: np.ndarray
    force_raw_n: np.ndarray
    force_n: np.ndarray
    peaks: Peaks
    bends_mm: tuple[tuple[float, float], ...]
    status: int
    message: str
    warnings: tuple[str, ...] = ()
    solve_time_s: float = math.nan
    wall_time_s: float = math.nan
    n_elements: int = 0
    settings: dict[str, Any] = field(default_factory=dict)
    filter_window_mm: float = FILTER_WINDOW_MM

    @property
    def finite(self) -> bool:
        """True when every reported force is finite (no NaN / inf rows)."""
        return bool(np.all(np.isfinite(self.force_raw_n)))


def run_channel(
    channel: Channel,
    settings: Scene,
    depth_mm: float | None = None,
    window_mm: float = FILTER_WINDOW_MM,
) -> NeedleRun:
    """Push the settings' catheter into ``channel`` and extract the force landmarks.

    Parameters
    ----------
    channel : Channel
    settings : Scene
        The needle settings (:func:`ringqa.needle.scene.load_settings`).
    depth_mm : float, optional
        Insertion depth (default 120 mm).
    window_mm : float
        Moving-average window (mm); default the paper's 0.241 mm.

    Returns
    -------
    NeedleRun
        Never raises for a run that jams or fails (see ``status``).
    """
    t0 = time.perf_counter()
    scene = needle_scene(channel, settings, depth_mm)
    res = simulate(scene)
    depth = m_to_mm(np.asarray(scene.motion.advances_m, dtype=float))
    raw = np.asarray(res.push_force_n, dtype=float)
    filt = moving_average(depth, raw, window_mm)
    bends = tuple(bend_windows_mm(channel))
    peaks = force_peaks(depth, filt, bends, complete=bool(np.all(np.isfinite(raw))))
    return NeedleRun(
        name=scene.name,
        depth_mm=depth,
        force_raw_n=raw,
        force_n=filt,
        peaks=peaks,
        bends_mm=bends,
        status=int(res.status),
        message=str(res.message),
        warnings=tuple(res.warnings),
        solve_time_s=float(res.solve_time_s),
        wall_time_s=time.perf_counter() - t0,
        n_elements=n_links(scene),
        settings={**dict(res.settings), "work": dict(res.work)},
        filter_window_mm=float(window_mm),
    )


def failed_run(channel: Channel, settings: Scene, message: str, depth_mm: float | None = None):
    """A :class:`NeedleRun` for a channel whose simulation could not even be set up (status -1,
    NaN forces, ``message`` saying why): a sweep reports it instead of stopping."""
    depth = depth_grid_mm(settings, channel, depth_mm)
    nan = np.full(depth.shape, np.nan)
    return NeedleRun(
        name=f"{settings.name}:{channel.name}",
        depth_mm=depth,
        force_raw_n=nan,
        force_n=nan.copy(),
        peaks=Peaks(),
        bends_mm=tuple(bend_windows_mm(channel)),
        status=-1,
        message=message,
    )
