"""tg43: AAPM TG-43U1 dose engine for HDR brachytherapy sources (stands alone, no ringqa imports).

Public API::

    source = tg43.load_source("mhdr-v2")                    # or a folder path
    rate = tg43.dose_rate_per_sk(source, positions_mm, directions, points_mm)  # cGy h^-1 U^-1
    dose = tg43.plan_dose_gy(source, positions_mm, directions, times_s, sk_U, points_mm)  # Gy

Importing the package compiles nothing: the numba kernels compile (or load from cache) on the
first call.
"""

from tg43.dose import (
    DIRECTION_NORM_TOL,
    IR192_HALF_LIFE_DAYS,
    along_away_points_mm,
    along_away_table,
    decay_factor,
    dose_rate_per_sk,
    plan_dose_gy,
)
from tg43.errors import TG43Error
from tg43.point import dose_rate_per_sk_point_1d, point_source_tables
from tg43.source import Source, known_sources, load_source

__all__ = [
    "DIRECTION_NORM_TOL",
    "IR192_HALF_LIFE_DAYS",
    "Source",
    "TG43Error",
    "along_away_points_mm",
    "along_away_table",
    "decay_factor",
    "dose_rate_per_sk",
    "dose_rate_per_sk_point_1d",
    "known_sources",
    "load_source",
    "plan_dose_gy",
    "point_source_tables",
]
