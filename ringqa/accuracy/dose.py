"""The dose error of a run: the report's dose points and their dose for equal dwell times.

The points are the report's (Point A, ring surface, 5 mm deeper; left and right) for the
scene's applicator, or, without an applicator ring frame (analytic channels), the same points
around a circle fitted to the reference dwells (documented stand-in). Doses come from
:mod:`tg43` with the Flexisource data.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ringqa.geometry import fit_ring_frame
from ringqa.units import m_to_mm, mm_to_m


@dataclass(frozen=True)
class DoseModel:
    """Dose at fixed points for equal dwell times at given positions (for dose errors)."""

    points_mm: np.ndarray
    point_names: tuple[str, ...]
    source_name: str
    how: str

    def dose(self, positions_mm, directions) -> np.ndarray:
        """Dose per unit time weight at each point (arbitrary units, relative use only)."""
        import tg43

        src = tg43.load_source(self.source_name)
        n = len(positions_mm)
        return tg43.plan_dose_gy(
            src, positions_mm, directions, np.full(n, 1.0), 1.0e4, self.points_mm
        )


def dose_model_for(scene, ref_positions_mm) -> DoseModel | None:
    """The report's dose points for the scene's applicator, else a fitted-circle stand-in."""
    try:
        from ringqa.plan import applicator_dose_points, dose_points_from_frame, points_array_mm
    except ImportError:  # pragma: no cover - plan layer missing
        return None
    src = "flexisource"  # the Flexitron's source (the only cable preset with a source)
    spec = scene.source.get("channel", {}) if isinstance(scene.source, Mapping) else {}
    if spec.get("applicator"):
        try:
            from ringqa.io.applicator_file import load_applicator

            app = load_applicator(spec["applicator"])
            pts = applicator_dose_points(app)
            return DoseModel(
                points_array_mm(pts),
                tuple(p.name for p in pts),
                src,
                f"report dose points of applicator {spec['applicator']}",
            )
        except Exception:  # fall back to the stand-in below
            pass
    ref = np.asarray(ref_positions_mm, float)
    if len(ref) < 3:
        return None
    frame = fit_ring_frame(mm_to_m(ref), lateral="points_mean")
    r = m_to_mm(frame.radius_m)
    if not (np.isfinite(r) and 1.0 < r < 1.0e3):
        return None
    pts = dose_points_from_frame(m_to_mm(frame.centre_m), frame.normal, frame.lateral, r)
    return DoseModel(
        points_array_mm(pts),
        tuple(p.name for p in pts),
        src,
        "stand-in: report dose points around a circle fitted to the reference dwells",
    )


def dose_error_pct(model: DoseModel | None, pos_mm, dirs, ref_dose) -> float:
    """Max over points of |D/D_ref - 1| in %, NaN when not computable."""
    if model is None or ref_dose is None:
        return math.nan
    try:
        d = model.dose(pos_mm, dirs)
    except Exception:  # e.g. a point inside the source
        return math.nan
    return float(np.max(np.abs(d / ref_dose - 1.0)) * 100.0)


def _reference_dose(scene, ref_positions_mm, ref_directions, warnings: list[str]):
    """The dose model of the scene and the reference run's dose, or (None, None).

    A failure of the dose model is recorded in ``warnings``; the study then has no dose errors.
    """
    dose_model = dose_model_for(scene, ref_positions_mm)
    ref_dose = None
    if dose_model is not None:
        try:
            ref_dose = dose_model.dose(ref_positions_mm, ref_directions)
        except Exception as exc:
            warnings.append(f"dose errors not computed: {exc}")
            dose_model = None
    return dose_model, ref_dose
