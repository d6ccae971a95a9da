"""Weighted least squares of the cable parameters on measured source paths (docs/calibration.md).

The residuals are the three coordinates of measured minus simulated source position at every
measured point not flagged, each divided by the point's total uncertainty
``sigma_i = sqrt(sd_i^2 + e_i^2)`` (``sd_i`` the measurement's, ``e_i`` the simulation's
numerical error at that point from the commissioning's own check, so that the fit does not
chase the discretisation). :func:`scipy.optimize.least_squares` (trust-region reflective, with
bounds) minimises their sum of squares in the coordinates ``theta`` of
:class:`~ringqa.calibration.model.Parametrisation`, which keep every parameter in its physical
range (mu_s > mu_k, EI > 0) whatever the optimiser tries.

The Jacobian is by forward differences with a step of :data:`FD_STEP` in theta (5 % of mu_k, of
mu_s - mu_k and of EI; 0.05 mm of lumen diameter). At fixed settings the simulated positions
are smooth in the parameters (measured on ring26x60: the slope of the dwells in log mu_k is
the same within 0.6 % for steps from 0.1 % to 5 %, in log EI within 1.3 %; docs/calibration.md),
so a step this size measures the parameter, not the discretisation, and stays clear of any
step-size-dependent switch of the solver's load steps. Its columns are independent runs: they
go to forked worker processes (:func:`ringqa.parallel.worker_pool`) on the machine's
cores.

Standard errors: ``Cov(theta) = s^2 (J^T J)^-1`` from the weighted Jacobian at the optimum (its
SVD; a singular value below :data:`RCOND` times the largest makes the directions it spans
undetermined: infinite variance), with ``s^2 = max(1, chi^2 / (N - n))`` (a misfit larger than
the stated uncertainties widens the errors; never narrows them), mapped to the parameters with
the transform's gradient. A parameter is **identifiable** when its standard error is finite and
at most :data:`MAX_RELATIVE_SE` of its value (lumen diameter change: at most
:data:`MAX_DELTA_SE_MM`).
"""

from __future__ import annotations

import logging
import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ringqa.calibration.measured import CalibrationError
from ringqa.calibration.model import ForwardModel, Parametrisation, base_key

__all__ = [
    "FD_STEP",
    "MAX_DELTA_SE_MM",
    "MAX_RELATIVE_SE",
    "MAX_SLOPE_RATIO",
    "RCOND",
    "FitResult",
    "fit_parameters",
    "points_needed",
]

log = logging.getLogger(__name__)

#: Forward-difference step in theta (log-parameters: 5 %; lumen diameter: 0.05 mm).
FD_STEP = 0.05
#: Singular values of the weighted Jacobian below this fraction of the largest: undetermined.
RCOND = 1.0e-6
#: Identifiable: standard error at most this fraction of the value ...
MAX_RELATIVE_SE = 0.3
#: ... or, for the lumen diameter change (value may be 0), at most this many mm.
MAX_DELTA_SE_MM = 0.1
#: Evaluations of the objective the optimiser may make (each one simulation per applicator).
MAX_NFEV = 40
#: A fitted theta this close to a bound is on it (trust-region reflective stays strictly inside).
BOUND_TOL = 1.0e-3
#: A fitted key is not identifiable when the positions' slope one step above and one below its
#: fitted value (:func:`_slopes`) differ by more than this factor, or point in opposite
#: directions (cosine < 0): the positions jump there (two equilibria) and a Jacobian standard
#: error means nothing.
MAX_SLOPE_RATIO = 3.0
#: Extra points (beyond one per fitted parameter) a fit needs.
EXTRA_POINTS = 2


def points_needed(n_params: int) -> int:
    """Measured points (not flagged) a fit of ``n_params`` parameters needs."""
    return n_params + EXTRA_POINTS


@dataclass(frozen=True, eq=False)
class FitResult:
    """A converged fit.

    Attributes
    ----------
    keys : tuple of str
    values : dict
        Fitted values of the fitted keys (and mu_s when it moved with mu_k), user units.
    start : dict
        The start values.
    se : dict
        Standard error of each fitted key (inf: undetermined).
    correlation : (n, n) ndarray
        Correlation matrix of the fitted keys (NaN where undetermined).
    identifiable : dict
        Per fitted key: True when determined by the data (module docstring's rule).
    chi2 : float
        Weighted sum of squares at the optimum.
    dof : int
        Residuals minus parameters.
    scale : float
        ``s^2`` applied to the covariance.
    singular_values : (n,) ndarray
        Of the weighted Jacobian in theta.
    positions_before, positions_after : list of (m, 3) ndarray
        Simulated points per applicator at the start and fitted values, mm.
    nfev : int
        Objective evaluations.
    message : str
        The optimiser's.
    seconds : float
        Wall time of the fit, s.
    notes : tuple of str
    covariance : (n, n) ndarray or None
        Of the fitted keys' values.
    slope_ratio, slope_cosine : dict
        Per fitted key, the ratio (larger / smaller) and the cosine of the positions' slopes one
        step above and one below the fitted value (:func:`_slopes`; NaN where a step leaves the
        searched range).
    """

    keys: tuple[str, ...]
    values: dict
    start: dict
    se: dict
    correlation: np.ndarray
    identifiable: dict
    chi2: float
    dof: int
    scale: float
    singular_values: np.ndarray
    positions_before: list
    positions_after: list
    nfev: int
    message: str
    seconds: float
    notes: tuple[str, ...] = field(default=())
    covariance: np.ndarray | None = None
    slope_ratio: dict = field(default_factory=dict)
    slope_cosine: dict = field(default_factory=dict)


def _residuals(model: ForwardModel, positions: list, sigma: list) -> np.ndarray:
    """Weighted residual vector (measured - simulated) / sigma over the used points."""
    parts = []
    for m, pos, sig in zip(model.measured, positions, sigma, strict=True):
        used = m.used
        parts.append(((m.measured_mm[used] - pos[used]) / sig[used][:, None]).ravel())
    return np.concatenate(parts)


# a forked worker's evaluation (the model and parametrisation are the pool's job)
def _evaluate(theta: Sequence[float]):
    from ringqa import parallel as forked

    model, par = forked.job()
    try:
        return model.positions(par.values(np.asarray(theta, dtype=float)))
    except CalibrationError as exc:
        return exc


def _workers(n_tasks: int) -> int:
    """Worker processes for ``n_tasks`` independent evaluations (1: evaluate here)."""
    from ringqa import parallel as forked
    from ringqa.pipeline.simulate import kernels_cached

    if n_tasks < 2 or not forked.can_fork() or not kernels_cached():
        return 1
    return max(1, min(n_tasks, os.cpu_count() or 1))


def fit_parameters(
    model: ForwardModel,
    keys: Sequence[str],
    sigma: list,
    start: Mapping[str, float] | None = None,
    *,
    workers: int | None = None,
    check_bounds: bool = True,
) -> FitResult:
    """Fit ``keys`` so that ``model``'s simulated points match the measured ones.

    Parameters
    ----------
    model : ForwardModel
    keys : sequence of str
        Scene keys to fit (:data:`~ringqa.calibration.model.FITTABLE_KEYS`).
    sigma : list of (m,) ndarray
        Per applicator, each point's total uncertainty, mm.
    start : mapping, optional
        Start values (default: the scene's own, :meth:`ForwardModel.base_values`).
    workers : int, optional
        Processes for the Jacobian's columns (default: one per column up to the cores, when
        the kernels are compiled and the machine can fork).
    check_bounds : bool
        Refuse a fit that ends on a bound of an identifiable parameter.

    Returns
    -------
    FitResult

    Raises
    ------
    CalibrationError
        Too few points, no convergence, a bound reached, a failed simulation.
    """
    t0 = time.perf_counter()
    keys = tuple(keys)
    n_used = int(sum(int(np.count_nonzero(m.used)) for m in model.measured))
    need = points_needed(len(keys))
    if n_used < need:
        raise CalibrationError(
            f"{n_used} measured point(s) can be used; fitting {len(keys)} parameter(s) "
            f"({', '.join(keys)}) needs at least {need}: measure more positions or fit fewer "
            "keys (--fit)"
        )
    base = model.base_values()
    start_values = {**base, **dict(start or {})}
    par = Parametrisation.build(keys, start_values, model.min_delta_mm())
    theta0 = par.theta(start_values)
    cache: dict[bytes, list] = {}

    def positions(theta: np.ndarray) -> list:
        key = np.asarray(theta, dtype=float).tobytes()
        if key not in cache:
            cache[key] = model.positions(par.values(theta))
        return cache[key]

    def fun(theta):
        return _residuals(model, positions(theta), sigma)

    n_workers = _workers(len(keys)) if workers is None else max(1, int(workers))
    from ringqa import parallel as forked

    pool_cm = forked.worker_pool(n_workers, job=(model, par)) if n_workers > 1 else None
    pool = pool_cm.__enter__() if pool_cm is not None else None
    try:

        def jac(theta):
            theta = np.asarray(theta, dtype=float)
            f0 = fun(theta)
            steps = []
            for j in range(len(keys)):
                h = FD_STEP
                if theta[j] + h > par.upper[j]:
                    h = -h  # step inwards at the upper bound
                steps.append(h)
            trial = [theta + h * np.eye(len(keys))[j] for j, h in enumerate(steps)]
            if pool is not None:
                done = pool.map(_evaluate, [list(t) for t in trial])
            else:
                done = [_try(model, par, t) for t in trial]
            cols = []
            for t, h, pos in zip(trial, steps, done, strict=True):
                if isinstance(pos, CalibrationError):
                    raise pos
                cache[np.asarray(t, dtype=float).tobytes()] = pos
                cols.append((_residuals(model, pos, sigma) - f0) / h)
            return np.column_stack(cols)

        from scipy.optimize import least_squares

        before = positions(theta0)
        sol = least_squares(
            fun, theta0, jac=jac, bounds=(par.lower, par.upper), method="trf",
            x_scale=1.0, xtol=1e-4, ftol=1e-8, gtol=1e-8, max_nfev=MAX_NFEV,
        )  # fmt: skip
        jac_opt = sol.jac if sol.jac is not None else jac(sol.x)
        ratio, cosine = _slopes(np.asarray(sol.x, dtype=float), par, fun, cache, pool, model)
    finally:
        if pool_cm is not None:
            pool_cm.__exit__(None, None, None)
    if sol.status <= 0:
        raise CalibrationError(
            f"the fit did not converge after {sol.nfev} evaluations ({sol.message}); nothing "
            "written (fit fewer keys with --fit, or check the measured points)"
        )
    theta = np.asarray(sol.x, dtype=float)
    after = positions(theta)
    resid = fun(theta)
    chi2 = float(resid @ resid)
    dof = int(resid.size - len(keys))
    scale = max(1.0, chi2 / dof) if dof > 0 else math.inf
    _u, s, vt = np.linalg.svd(np.asarray(jac_opt, dtype=float), full_matrices=False)
    good = s > RCOND * (s.max() if s.size and s.max() > 0 else 1.0)
    inv = np.zeros_like(s)
    inv[good] = 1.0 / s[good] ** 2
    cov_theta = (vt.T * inv) @ vt * scale
    g = par.gradient(theta)
    cov = g @ cov_theta @ g.T
    values = par.values(theta)
    se_arr = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    # a direction the data do not determine: infinite variance for every key it involves
    null = vt[~good]
    if null.size:
        loads = np.abs(g @ null.T)  # (keys, null directions)
        se_arr = np.where(np.any(loads > 1e-6, axis=1), np.inf, se_arr)
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(np.sqrt(np.diag(cov)), np.sqrt(np.diag(cov)))
    corr[~np.isfinite(se_arr), :] = np.nan
    corr[:, ~np.isfinite(se_arr)] = np.nan
    se = {k: float(v) for k, v in zip(keys, se_arr, strict=True)}
    ident = {}
    for k in keys:
        if base_key(k) == "lumen.diameter_delta_mm":
            ident[k] = bool(np.isfinite(se[k]) and se[k] <= MAX_DELTA_SE_MM)
        else:
            ident[k] = bool(np.isfinite(se[k]) and se[k] <= MAX_RELATIVE_SE * abs(values[k]))
    notes: list[str] = []
    near = (theta - par.lower < BOUND_TOL) | (par.upper - theta < BOUND_TOL)
    on_bound = [k for j, k in enumerate(keys) if sol.active_mask[j] != 0 or near[j]]
    for j, k in enumerate(keys):
        if ratio[j] > MAX_SLOPE_RATIO or cosine[j] < 0.0:
            notes.append(
                f"{k}: the simulated positions do not change smoothly with it at the fitted "
                f"values (their slopes one {FD_STEP:g} step above and one below differ by a "
                f"factor {ratio[j]:.3g}, cosine {cosine[j]:.2f}: the solution jumps between "
                "equilibria); its standard error means nothing (identifiable: false)"
            )
            ident[k] = False
    for k in on_bound:
        if ident[k] and check_bounds:
            raise CalibrationError(
                f"the fit ran into the bound of {k} (value {values[k]:.4g}): the measurement "
                "pulls it outside the range ringqa searches; nothing written (check the "
                "measured points and their registration, or fit fewer keys with --fit)"
            )
        notes.append(
            f"{k} ended at the edge of its searched range ({values[k]:.4g}); the data do not "
            "determine it (identifiable: false)."
        )
        ident[k] = False
    return FitResult(
        keys=keys,
        values=values,
        start={k: start_values[k] for k in keys},
        se=se,
        correlation=corr,
        identifiable=ident,
        chi2=chi2,
        dof=dof,
        scale=float(scale),
        singular_values=s,
        positions_before=before,
        positions_after=after,
        nfev=int(sol.nfev),
        message=str(sol.message),
        seconds=time.perf_counter() - t0,
        notes=tuple(notes),
        covariance=cov,
        slope_ratio={k: float(ratio[j]) for j, k in enumerate(keys)},
        slope_cosine={k: float(cosine[j]) for j, k in enumerate(keys)},
    )


def _slopes(theta, par, fun, cache, pool, model) -> tuple[np.ndarray, np.ndarray]:
    """Per parameter, the ratio ``max(|J+|, |J-|) / min(|J+|, |J-|)`` and the cosine of the
    weighted residuals' forward and backward difference columns (step :data:`FD_STEP` in theta)
    at the fitted ``theta``. Where the positions are smooth in it the ratio is about
    ``1 + FD_STEP`` times the relative curvature and the cosine about 1 (measured on ring26x60:
    1.02-1.05); a jump between equilibria within a step makes one side many times the other or
    turns it round (ring26x60 with gravity and the real cable mass, fitted from mu_k 0.2 / EI 1:
    the dwells jump by 0.6 mm). A parameter that moves nothing: 1 and 1; one side still, the
    other not: inf. NaN where the backward step leaves the searched range."""
    n = theta.size
    r0 = fun(theta)
    trial, where = [], []
    for j in range(n):
        h = FD_STEP if theta[j] + FD_STEP <= par.upper[j] else -FD_STEP
        for sign in (1.0, -1.0):
            t = theta.copy()
            t[j] += sign * h
            if not (par.lower[j] <= t[j] <= par.upper[j]):
                continue
            trial.append(t)
            where.append((j, sign, h))
    todo = [t for t in trial if np.asarray(t, dtype=float).tobytes() not in cache]
    if todo:
        done = (pool.map(_evaluate, [list(t) for t in todo]) if pool is not None
                else [_try(model, par, t) for t in todo])  # fmt: skip
        for t, pos in zip(todo, done, strict=True):
            if not isinstance(pos, CalibrationError):
                cache[np.asarray(t, dtype=float).tobytes()] = pos
    cols: dict[tuple[int, float], np.ndarray] = {}
    for t, (j, sign, h) in zip(trial, where, strict=True):
        key = np.asarray(t, dtype=float).tobytes()
        if key in cache:
            cols[(j, sign)] = sign * (fun(t) - r0) / h
    ratio, cosine = np.full(n, np.nan), np.full(n, np.nan)
    for j in range(n):
        if (j, 1.0) in cols and (j, -1.0) in cols:
            a, b = cols[(j, 1.0)], cols[(j, -1.0)]
            na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
            tiny = 1e-12 * max(1.0, na, nb)
            if na <= tiny and nb <= tiny:
                ratio[j], cosine[j] = 1.0, 1.0
            elif min(na, nb) <= tiny:
                ratio[j], cosine[j] = np.inf, 0.0
            else:
                ratio[j] = max(na, nb) / min(na, nb)
                cosine[j] = float(a @ b) / (na * nb)
    return ratio, cosine


def _try(model: ForwardModel, par: Parametrisation, theta):
    try:
        return model.positions(par.values(np.asarray(theta, dtype=float)))
    except CalibrationError as exc:
        return exc
