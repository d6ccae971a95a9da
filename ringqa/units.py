"""Unit conversions at the user's edge, in one place.

Inside the engines everything is SI (m, N, s, rad, kg). Files, the command line and reports use
millimetres, degrees and seconds. Convert with these functions only, never with literal factors.
"""

from __future__ import annotations

import numpy as np

M_PER_MM = 1.0e-3
MM_PER_M = 1.0e3


def mm_to_m(value_mm):
    """Millimetres to metres (scalars or arrays)."""
    return (
        np.asarray(value_mm, dtype=float) * M_PER_MM
        if np.ndim(value_mm)
        else float(value_mm) * M_PER_MM
    )


def m_to_mm(value_m):
    """Metres to millimetres (scalars or arrays)."""
    return (
        np.asarray(value_m, dtype=float) * MM_PER_M
        if np.ndim(value_m)
        else float(value_m) * MM_PER_M
    )


def deg_to_rad(value_deg):
    """Degrees to radians (scalars or arrays)."""
    return np.deg2rad(value_deg)


def rad_to_deg(value_rad):
    """Radians to degrees (scalars or arrays)."""
    return np.rad2deg(value_rad)
