"""The measured curves' moving-average filter, and the 1st peak, plateau and 2nd peak.

Filter
------
The paper's force data (5 kHz at 5 mm/s) were smoothed with a central moving average of 241
samples: 241 / 5000 s x 5 mm/s = 0.241 mm of depth. :func:`moving_average` applies the same
window to the simulated force, as the exact average of its piecewise-linear interpolant over
``depth +- 0.1205 mm`` (the limit of the 5 kHz moving mean; it does not depend on how densely the
simulation reports). At the ends the window shrinks to the data (MATLAB ``movmean``'s default).

Peaks (the paper's Figure 8, numbers (1)-(3))
---------------------------------------------
The channel's two bends are found from its curvature (:func:`bend_windows_mm`: the runs of arc
length where the curvature exceeds half its maximum). With ``split`` = midway between the end of
bend 1 and the start of bend 2 (the tip's depth is its arc length):

1. 1st peak: the largest filtered force at depths below ``split``;
2. plateau: the median filtered force over the PLATEAU REGION: the depths between the two peaks
   where the filtered force is within 10 % of the 1st peak above its lowest value there (the
   flat stretch while the catheter slides through bend 1 and its tip runs along the middle
   straight; the periodic ripple of the links passing the bend stays inside that band);
3. 2nd peak: the largest filtered force at depths from ``split`` on.

Each comes with its depth (the plateau with the middle of its region and the region's ends).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ringqa.units import m_to_mm

#: The paper's filter: 241 samples at 5 kHz and 5 mm/s (mm of depth).
MEASUREMENT_RATE_HZ = 5000.0
MEASUREMENT_SPEED_MM_S = 5.0
FILTER_SAMPLES = 241
FILTER_WINDOW_MM = FILTER_SAMPLES / MEASUREMENT_RATE_HZ * MEASUREMENT_SPEED_MM_S
#: Plateau region: within this fraction of the 1st peak above the lowest force between the peaks.
PLATEAU_BAND = 0.10
#: A bend is where the curvature exceeds this fraction of the channel's largest curvature.
BEND_THRESHOLD = 0.5
#: Spacing of the curvature samples used to find the bends (mm).
BEND_SAMPLE_MM = 0.25


@dataclass(frozen=True)
class Peaks:
    """The paper's force landmarks (N) and their depths (mm); NaN when not reached.

    Attributes
    ----------
    peak1_n, peak1_depth_mm : float
        1st peak (bend 1) and its depth.
    plateau_n, plateau_depth_mm : float
        Plateau (median over its region) and the middle of the region.
    plateau_from_mm, plateau_to_mm : float
        Ends of the plateau region.
    peak2_n, peak2_depth_mm : float
        2nd peak (bend 2) and its depth.
    split_mm : float
        Depth that separates the 1st peak's search from the 2nd's.
    """

    peak1_n: float = math.nan
    peak1_depth_mm: float = math.nan
    plateau_n: float = math.nan
    plateau_depth_mm: float = math.nan
    plateau_from_mm: float = math.nan
    plateau_to_mm: float = math.nan
    peak2_n: float = math.nan
    peak2_depth_mm: float = math.nan
    split_mm: float = math.nan

    def as_dict(self) -> dict[str, float]:
        """Plain dict (column name -> value)."""
        return {k: float(getattr(self, k)) for k in self.__dataclass_fields__}


def moving_average(depth_mm, force_n, window_mm: float = FILTER_WINDOW_MM) -> np.ndarray:
    """Central moving average of ``force_n`` over ``window_mm`` of depth (module docstring).

    Parameters
    ----------
    depth_mm : (n,) array_like
        Increasing depths (mm).
    force_n : (n,) array_like
        Force (N) at those depths; NaN rows (depths not reached) stay NaN and are not averaged.
    window_mm : float
        Window width (mm), default 0.241 mm (the paper's 241 samples at 5 kHz and 5 mm/s).

    Returns
    -------
    (n,) ndarray
        The average of the piecewise-linear force over ``[d - w/2, d + w/2]`` clipped to the
        reached depths.
    """
    x = np.asarray(depth_mm, dtype=float)
    f = np.asarray(force_n, dtype=float)
    if x.shape != f.shape or x.ndim != 1:
        raise ValueError("depth_mm and force_n must be 1-D arrays of the same length")
    if not window_mm > 0:
        raise ValueError(f"window_mm = {window_mm}: must be > 0")
    out = np.full_like(f, np.nan)
    ok = np.isfinite(f) & np.isfinite(x)
    xs, fs = x[ok], f[ok]
    if xs.size < 2:
        out[ok] = fs
        return out
    if np.any(np.diff(xs) <= 0):
        raise ValueError("depth_mm must increase")
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (fs[1:] + fs[:-1]) * np.diff(xs))])
    slope = np.diff(fs) / np.diff(xs)

    def integral(q):
        q = np.clip(q, xs[0], xs[-1])
        i = np.clip(np.searchsorted(xs, q, side="right") - 1, 0, xs.size - 2)
        dq = q - xs[i]
        return cum[i] + fs[i] * dq + 0.5 * slope[i] * dq**2

    lo = np.clip(xs - 0.5 * window_mm, xs[0], xs[-1])
    hi = np.clip(xs + 0.5 * window_mm, xs[0], xs[-1])
    out[ok] = (integral(hi) - integral(lo)) / (hi - lo)
    return out


def bend_windows_mm(channel) -> list[tuple[float, float]]:
    """Arc-length intervals (mm) of the channel's bends: curvature above half its maximum.

    Parameters
    ----------
    channel : ringqa.geometry.Channel

    Returns
    -------
    list of (start_mm, end_mm)
        In order along the channel; empty for a straight channel.
    """
    length = channel.centreline.length_m
    s = np.linspace(0.0, length, max(3, math.ceil(m_to_mm(length) / BEND_SAMPLE_MM) + 1))
    kappa = np.asarray(channel.centreline.curvature(s), dtype=float)
    k_max = float(np.max(kappa))
    if not k_max > 1e-9:
        return []
    on = kappa > BEND_THRESHOLD * k_max
    edges = np.flatnonzero(np.diff(on.astype(np.int8)))
    starts = [0] if on[0] else []
    starts += [int(i) + 1 for i in edges if not on[i]]
    ends = [int(i) for i in edges if on[i]]
    if on[-1]:
        ends.append(on.size - 1)
    return [(m_to_mm(s[a]), m_to_mm(s[b])) for a, b in zip(starts, ends, strict=True)]


def force_peaks(depth_mm, force_filtered_n, bends_mm, complete: bool = True) -> Peaks:
    """The 1st peak, plateau and 2nd peak of a filtered force-depth curve (module docstring).

    Parameters
    ----------
    depth_mm, force_filtered_n : (n,) array_like
        Depth (mm) and the FILTERED force (N) (:func:`moving_average`); NaN rows are ignored.
    bends_mm : sequence of (start_mm, end_mm)
        The channel's bends (:func:`bend_windows_mm`); the first two are used.
    complete : bool
        False when the run stopped early (jam, failure): the 2nd peak and the plateau are then
        not reported (their search window was not covered), nor the 1st peak if the run stopped
        before ``split``.

    Returns
    -------
    Peaks
        All NaN when the channel has fewer than two bends; a landmark not reached is NaN.
    """
    x = np.asarray(depth_mm, dtype=float)
    g = np.asarray(force_filtered_n, dtype=float)
    ok = np.isfinite(g)
    x, g = x[ok], g[ok]
    if len(bends_mm) < 2 or x.size == 0:
        return Peaks()
    split = 0.5 * (bends_mm[0][1] + bends_mm[1][0])
    first = x < split
    if not first.any() or (not complete and x[-1] < split):
        return Peaks(split_mm=split)
    i1 = int(np.argmax(np.where(first, g, -np.inf)))
    out = {"peak1_n": g[i1], "peak1_depth_mm": x[i1], "split_mm": split}
    second = x >= split
    if second.any() and complete:
        i2 = int(np.argmax(np.where(second, g, -np.inf)))
        out.update(peak2_n=g[i2], peak2_depth_mm=x[i2])
        between = np.arange(i1, i2 + 1)
        low = float(np.min(g[between]))
        region = between[g[between] <= low + PLATEAU_BAND * g[i1]]
        out.update(
            plateau_n=float(np.median(g[region])),
            plateau_from_mm=x[region[0]],
            plateau_to_mm=x[region[-1]],
            plateau_depth_mm=0.5 * (x[region[0]] + x[region[-1]]),
        )
    return Peaks(**{k: float(v) for k, v in out.items()})
