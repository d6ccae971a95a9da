"""A whole calibration: measured paths -> fitted cable with uncertainties, residuals, left-out
predictions (``ringqa calibrate``; docs/calibration.md).

1. Read, check and register the measured paths (:mod:`.measured`).
2. The numerical error of the simulation at each measured point, from the commissioning's own
   check at the start values (:func:`ringqa.pipeline.simulate.simulate_dwells`): it joins each
   point's uncertainty, so the fit does not chase the discretisation.
3. The weighted least squares of the fitted keys (:mod:`.fit`).
4. With two or more applicators, leave-one-out: the fit on all but one, the left-out one
   predicted with it (the prediction error tells a clinic whether measuring one ring is enough;
   its own lumen diameter change, which the others cannot tell, at its start value).

With two or more applicators the cable keys are shared and ``lumen.diameter_delta_mm`` is fitted
per applicator (``lumen.diameter_delta_mm@LABEL``, :func:`~ringqa.calibration.model
.expand_keys`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ringqa.calibration.fit import FitResult, fit_parameters
from ringqa.calibration.measured import CalibrationError, MeasuredApplicator
from ringqa.calibration.model import (
    APPLICATOR_SEP,
    DEFAULT_KEYS,
    FITTABLE_KEYS,
    PER_APPLICATOR_KEYS,
    ForwardModel,
    applicator_of,
    expand_keys,
)
from ringqa.pipeline.simulate import Engine, simulate_dwells

__all__ = ["Calibration", "LeftOut", "calibrate", "check_keys"]


@dataclass(frozen=True, eq=False)
class LeftOut:
    """One applicator predicted by the fit on the others.

    Attributes
    ----------
    label : str
    values : dict
        The keys fitted without it.
    distance_mm : (m,) ndarray
        Per used point: measured vs predicted, mm.
    median_mm, max_mm : float
    """

    label: str
    values: dict
    distance_mm: np.ndarray
    median_mm: float
    max_mm: float


@dataclass(frozen=True, eq=False)
class Calibration:
    """Everything ``ringqa calibrate`` reports.

    Attributes
    ----------
    measured : tuple of MeasuredApplicator
    cable : str
    fit : FitResult
    numerical_error_mm : list of (m,) ndarray
        Per applicator and point, the simulation's numerical error at the start values, mm.
    sigma_mm : list of (m,) ndarray
        Per point, the total uncertainty used as weight: sqrt(sd^2 + numerical error^2), mm.
    left_out : tuple of LeftOut
    overrides : dict
        The user's scene overrides the fit started from (``--config``).
    stem_mm : float or None
    register : str
    seconds : float
        Wall time of the whole calibration, s.
    """

    measured: tuple[MeasuredApplicator, ...]
    cable: str
    fit: FitResult
    numerical_error_mm: list
    sigma_mm: list
    left_out: tuple[LeftOut, ...]
    overrides: dict
    stem_mm: float | None
    register: str
    seconds: float

    def distances(self, which: str) -> list[np.ndarray]:
        """Per applicator, measured vs simulated distance at every point (``"before"`` or
        ``"after"`` the fit), mm."""
        pos = self.fit.positions_before if which == "before" else self.fit.positions_after
        return [np.linalg.norm(m.measured_mm - p, axis=1)
                for m, p in zip(self.measured, pos, strict=True)]  # fmt: skip

    def used_distances(self, which: str) -> np.ndarray:
        """Distances at the points in the fit, all applicators, mm."""
        return np.concatenate([d[m.used] for m, d in
                               zip(self.measured, self.distances(which), strict=True)])  # fmt: skip


def check_keys(keys: Sequence[str] | None) -> tuple[str, ...]:
    """The fitted keys (default :data:`~ringqa.calibration.model.DEFAULT_KEYS`), checked.

    Raises
    ------
    CalibrationError
        An unknown or repeated key.
    """
    if not keys:
        return DEFAULT_KEYS
    out = []
    for k in keys:
        k = str(k).strip()
        if k not in FITTABLE_KEYS:
            raise CalibrationError(
                f"--fit {k}: cannot be fitted; choose from {', '.join(FITTABLE_KEYS)}"
            )
        if k in out:
            raise CalibrationError(f"--fit {k}: given twice")
        out.append(k)
    return tuple(out)


def numerical_errors(
    model: ForwardModel, values: Mapping[str, float], engine: Engine | None
) -> list[np.ndarray]:
    """Per applicator and measured point, the numerical error of the simulated position at
    ``values`` (the commissioning's check: commissioning vs refined run, refined further where
    needed), mm."""
    out = []
    over = {**dict(model.overrides), **dict(values)}
    for m in model.measured:
        sim = simulate_dwells(
            m.applicator, m.channel, m.relative_position_mm, cable=model.cable,
            scene_overrides=over, engine=engine, stem_mm=model.stem_mm,
            stem_check=False,  # the discretisation's error only (the fit's model keeps the stem)
        )  # fmt: skip
        out.append(np.asarray(sim.numerics.error_mm, dtype=float))
    return out


def calibrate(
    measured: Sequence[MeasuredApplicator],
    *,
    keys: Sequence[str] | None = None,
    overrides: Mapping[str, Any] | None = None,
    stem_mm: float | None = None,
    register: str = "none",
    engine: Engine | None = None,
    leave_one_out: bool = True,
    workers: int | None = None,
) -> Calibration:
    """Fit the cable to the measured paths (module docstring).

    Parameters
    ----------
    measured : sequence of MeasuredApplicator
        From :func:`~ringqa.calibration.measured.measured_applicators` (one cable).
    keys : sequence of str, optional
        Fitted scene keys (default mu_k, mu_s, EI scale).
    overrides : mapping, optional
        Scene overrides under the fitted values (``--config``'s ``[scene]``, ``--set``); a
        fitted key given here is the fit's start value.
    stem_mm : float or None
        The commissioning's modelled stem, mm.
    register : str
        How the paths were registered (for the record).
    engine : Engine, optional
    leave_one_out : bool
        With two or more applicators, also fit without each one and predict it.
    workers : int, optional
        Processes for the Jacobian (default: the cores).

    Returns
    -------
    Calibration

    Raises
    ------
    CalibrationError
    """
    t0 = time.perf_counter()
    keys = check_keys(keys)
    measured = tuple(measured)
    if not measured:
        raise CalibrationError("nothing to fit: give at least one measured path")
    over = dict(overrides or {})
    start = {k: float(over.pop(k)) for k in list(over) if k in keys}
    cable = measured[0].cable
    model = ForwardModel(measured, cable, over, stem_mm, engine)
    base = {**model.base_values(), **start}
    for k in PER_APPLICATOR_KEYS:  # a start value given for all applicators: each one's
        if k in start:
            base.update({f"{k}{APPLICATOR_SEP}{m.label}": start[k] for m in measured})
    numerics = numerical_errors(model, {k: base[k] for k in keys}, engine)
    sigma = [np.sqrt(m.sd_mm**2 + e**2) for m, e in zip(measured, numerics, strict=True)]
    labels = [m.label for m in measured]
    result = fit_parameters(model, expand_keys(keys, labels), sigma, base, workers=workers)
    left: list[LeftOut] = []
    if leave_one_out and len(measured) >= 2:
        for i, m in enumerate(measured):
            others = tuple(x for j, x in enumerate(measured) if j != i)
            sub = ForwardModel(others, cable, over, stem_mm, engine)
            sig = [s for j, s in enumerate(sigma) if j != i]
            sub_keys = tuple(  # the others' own lumen keys, as in the whole fit
                k for k in result.keys if applicator_of(k) in ("", *(x.label for x in others))
            )
            part = fit_parameters(sub, sub_keys, sig, {**base, **result.values},
                                  workers=workers, check_bounds=False)  # fmt: skip
            alone = ForwardModel((m,), cable, over, stem_mm, engine)
            pred = alone.positions(part.values)[0]
            dist = np.linalg.norm(m.measured_mm - pred, axis=1)[m.used]
            left.append(LeftOut(m.label, dict(part.values), dist, float(np.median(dist)),
                                float(np.max(dist))))  # fmt: skip
    return Calibration(
        measured=measured,
        cable=cable,
        fit=result,
        numerical_error_mm=numerics,
        sigma_mm=sigma,
        left_out=tuple(left),
        overrides=over,
        stem_mm=stem_mm,
        register=register,
        seconds=time.perf_counter() - t0,
    )
