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
from ringqa.plan import applicator_dose_points, dose_points_from_frame, points_array_mm
from ringqa.simulation.scenefile import scene_to_dict
from ringqa.units import m_to_mm, mm_to_m


@dataclass(frozen=True, eq=False)
class DoseModel:
    """Dose at fixed points for equal dwell times at given positions (for dose errors).

    Attributes
    ----------
    points_mm : (k, 3) ndarray
        The dose points, mm.
    point_names : tuple of str
    source_name : str
        TG-43 source.
    how : str
        How the points were defined (for ``study.json``).
    """

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
    """The report's dose points for the scene's applicator, else a fitted-circle stand-in.

    Parameters
    ----------
    scene : Scene
        Its channel spec (:func:`~ringqa.simulation.scenefile.scene_to_dict`) names the
        applicator, if any.
    ref_positions_mm : (n, 3) array_like
        The reference run's dwells, mm (the stand-in circle is fitted to them).

    Returns
    -------
    DoseModel or None
        None when neither works (fewer than 3 dwells, no plausible circle).
    """
    src = "flexisource"  # the Flexitron's source (the only cable preset with a source)
    spec = scene_to_dict(scene).get("channel", {})
    spec = spec if isinstance(spec, Mapping) else {}
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


@dataclass(frozen=True, eq=False)
class DoseReference:
    """The dose points of a study and the reference run's dose there.

    Attributes
    ----------
    model : DoseModel or None
        None: no dose errors are computed.
    dose : (k,) ndarray or None
        The reference run's dose at the model's points (arbitrary units).
    warnings : tuple of str
        Why there are no dose errors, when the model failed.
    """

    model: DoseModel | None
    dose: np.ndarray | None
    warnings: tuple[str, ...] = ()

    @property
    def how(self) -> str:
        """How the dose points were defined (``study.json: dose_points``)."""
        return self.model.how if self.model is not None else "not computed"


def reference_dose(scene, ref_positions_mm, ref_directions) -> DoseReference:
    """The dose model of the scene and the reference run's dose.

    Parameters
    ----------
    scene : Scene
    ref_positions_mm : (n, 3) array_like
        The reference run's dwells, mm.
    ref_directions : (n, 3) array_like
        Its unit source directions.

    Returns
    -------
    DoseReference
        Without a model (and with a warning) when the dose cannot be computed.
    """
    dose_model = dose_model_for(scene, ref_positions_mm)
    if dose_model is None:
        return DoseReference(None, None)
    try:
        return DoseReference(dose_model, dose_model.dose(ref_positions_mm, ref_directions))
    except Exception as exc:
        return DoseReference(None, None, (f"dose errors not computed: {exc}",))
