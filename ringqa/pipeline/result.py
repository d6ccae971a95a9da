"""What one commissioning run returns: the tolerance verdicts and the whole result.

:class:`Verdict` is one tolerance check as the report shows it; :class:`CommissioningResult`
holds every table, verdict, note and setting of one run (see :mod:`ringqa.pipeline.commission`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pandas as pd

from ringqa.provenance import Provenance


@dataclass(frozen=True)
class Verdict:
    """One tolerance check, shown in the report.

    Attributes
    ----------
    check : str
        What is compared (``"position: simulated vs measured"``).
    value : float
        The checked value (max distance in mm, or max |dose difference| in %).
    unit : str
        ``"mm"`` or ``"%"``.
    limits : tuple of float
        (recommended, required) for positions; (action level,) for doses.
    status : str
        ``"PASS"``, ``"WARN"`` (within the required 2 mm but above the recommended 1 mm),
        ``"FAIL"`` (position beyond 2 mm) or ``"ACTION"`` (dose beyond the action level).
    text : str
        One sentence for the report.
    """

    check: str
    value: float
    unit: str
    limits: tuple[float, ...]
    status: str
    text: str

    def as_dict(self) -> dict:
        return {
            "check": self.check,
            "value": float(self.value),
            "unit": self.unit,
            "limits": [float(x) for x in self.limits],
            "status": self.status,
            "text": self.text,
        }


@dataclass(frozen=True, eq=False)
class CommissioningResult:
    """Everything one commissioning run produced (tables in mm, deg, Gy, %).

    Attributes
    ----------
    applicator : str
        Applicator name.
    input : str
        What the user gave (name or path); ``input_kind`` one of ``shipped``, ``file``,
        ``folder``, ``rtplan``, ``object``.
    reference : str
        ``"measured"`` (a measured source path) or ``"centreline"`` (none shipped: the comparison
        is simulated vs centreline).
    dwells : pandas.DataFrame
        One row per dwell and path (``measured``/``simulated``/``centreline``): columns
        ``applicator, dwell, relative_position_mm, path, x_mm, y_mm, z_mm, dir_x, dir_y, dir_z,
        dist_to_measured_mm, dist_to_reference_mm, along_mm, radial_mm, out_of_plane_mm,
        angle_deg, in_plan``.
    doses : pandas.DataFrame
        One row per dose point and plan: ``applicator, point, kind, plan, dose_gy, diff_pct,
        x_mm, y_mm, z_mm, tps_dose_gy``.
    plan_dwells : pandas.DataFrame
        The three standard plans' dwells with their (equal) times.
    summary : dict
        Per-applicator numbers (one row of summary.csv).
    verdicts : tuple of Verdict
    geometry : dict
        For plots: ``ring_centre_mm``, ``ring_normal``, ``ring_lateral``, ``ring_radius_mm``,
        ``centrelines_mm`` (channel name -> (k, 3)), ``s_ref_mm``.
    simulation : dict
        ``status, message, warnings, solve_time_s, n_elements, settings``.
    settings : dict
        Source, S_K, prescription, cable, tolerances, dose point definitions, scene settings.
    notes : tuple of str
        Statements the report must show (reference used, cable vs afterloader, ...).
    provenance : Provenance
    timings_s : dict
    """

    applicator: str
    input: str
    input_kind: str
    reference: str
    dwells: pd.DataFrame
    doses: pd.DataFrame
    plan_dwells: pd.DataFrame
    summary: dict
    verdicts: tuple[Verdict, ...]
    geometry: dict
    simulation: dict
    settings: dict
    notes: tuple[str, ...]
    provenance: Provenance
    timings_s: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """True when no verdict is FAIL or ACTION."""
        return all(v.status in ("PASS", "WARN") for v in self.verdicts)
