"""How far a run is from the reference: position and direction errors per dwell.

Runs that failed have no error: the NaN-aware maximum and median here give NaN for them.
"""

from __future__ import annotations

import math

import numpy as np


def position_errors_mm(pos_mm, ref_mm) -> np.ndarray:
    """|p - p_ref| per dwell (mm); NaN where the shapes disagree."""
    a, b = np.asarray(pos_mm, float), np.asarray(ref_mm, float)
    if a.shape != b.shape:
        return np.full(max(len(b), 1), np.nan)
    return np.linalg.norm(a - b, axis=1)


def angle_errors_deg(dirs, ref_dirs) -> np.ndarray:
    """Angle between source directions per dwell (deg), robust near 0 (atan2 form)."""
    a, b = np.asarray(dirs, float), np.asarray(ref_dirs, float)
    if a.shape != b.shape:
        return np.full(max(len(b), 1), np.nan)
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    cross = np.linalg.norm(np.cross(a, b), axis=1)
    dot = np.sum(a * b, axis=1)
    return np.degrees(np.arctan2(cross, dot))


def max_or_nan(a) -> float:
    """The maximum, or NaN when ``a`` is empty or holds a non-finite value (a failed run)."""
    a = np.asarray(a, float)
    return float(np.max(a)) if a.size and np.all(np.isfinite(a)) else math.nan


def median_or_nan(a) -> float:
    """The median, or NaN when ``a`` is empty or holds a non-finite value (a failed run)."""
    a = np.asarray(a, float)
    return float(np.median(a)) if a.size and np.all(np.isfinite(a)) else math.nan
