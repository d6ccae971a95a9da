"""TG-43U1 dose rate and plan dose: input checks, unit conversion and kernel calls.

Formalism (AAPM TG-43U1, 2D line source)::

    D_rate(r, theta) = S_K * Lambda * [G_L(r, theta) / G_L(r0, theta0)] * g_L(r) * F(r, theta)

with G_L(r, theta) = beta / (L r sin theta) off the axis and 1 / (r^2 - L^2/4) on it, beta the
angle the active length L subtends at the point, r from the source centre and theta from the
source axis pointing to the TIP (distal end). Positions are in mm at this interface; the kernels
work in metres.
"""

from __future__ import annotations

import datetime as _dt
import math
from collections.abc import Sequence

import numpy as np

from tg43.errors import TG43Error
from tg43.source import Source

#: Ir-192 half-life used for decay correction, days.
IR192_HALF_LIFE_DAYS = 73.83
#: Tolerance on |direction| - 1 (directions must be unit vectors to this accuracy).
DIRECTION_NORM_TOL = 1e-6

_M_PER_MM = 1e-3
_M_PER_CM = 1e-2
_S_PER_H = 3600.0
_GY_PER_CGY = 1e-2
#: With ``parallel=True``, grids of at least this many point-dwell pairs are split over numba's
#: threads; smaller ones run on one thread (no faster on two: thread start-up and imbalance).
PARALLEL_MIN_PAIRS = 20_000
#: Point-dwell pairs per block handed to a thread (~25 us of work: fine enough to balance the
#: threads at the threshold, coarse enough that the per-block set-up is ~1 %).
_CHUNK_PAIRS = 2048


# --------------------------------------------------------------------------------------------
# input checks


def _as_xyz(value, name: str, *, allow_single: bool = False) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise TG43Error(f"{name}: must be numbers with shape (n, 3) (x, y, z in mm)") from None
    if allow_single and arr.shape == (3,):
        arr = arr.reshape(1, 3)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise TG43Error(f"{name}: shape must be (n, 3), got {arr.shape} (one x, y, z row each)")
    bad = ~np.isfinite(arr)
    if bad.any():
        row = int(np.argwhere(bad)[0][0])
        raise TG43Error(
            f"{name}: row {row} holds a NaN or infinite coordinate ({arr[row].tolist()}); "
            "give finite numbers"
        )
    return np.ascontiguousarray(arr)


def _check_dwells(positions_mm, directions) -> tuple[np.ndarray, np.ndarray]:
    pos = _as_xyz(positions_mm, "positions_mm")
    dirs = _as_xyz(directions, "directions")
    if pos.shape[0] != dirs.shape[0]:
        raise TG43Error(
            f"positions_mm has {pos.shape[0]} rows but directions has {dirs.shape[0]} "
            "(one unit direction per dwell)"
        )
    norms = np.linalg.norm(dirs, axis=1)
    bad = np.abs(norms - 1.0) > DIRECTION_NORM_TOL
    if bad.any():
        row = int(np.argmax(bad))
        what = "zero" if norms[row] == 0 else f"not a unit vector (|d| = {norms[row]:.9g})"
        raise TG43Error(
            f"directions: row {row} is {what}; give the unit vector from the cable towards the "
            f"source tip (|d| must be 1 within {DIRECTION_NORM_TOL:g}; normalise it)"
        )
    return pos, dirs / norms[:, None]


def _tables(source: Source) -> tuple:
    """Kernel arguments after (points, dwells, weights) (SI, built once per source)."""
    cached = source._cache.get("kernel_tables")
    if cached is not None:
        return cached
    from tg43._kernels import build_tables

    length_m = source.active_length_cm * _M_PER_CM
    half = 0.5 * length_m
    r0 = source.r0_cm * _M_PER_CM
    g_l0 = 2.0 * math.atan(half / r0) / (length_m * r0)  # G_L(r0, 90 deg) in m^-2
    tables = build_tables(
        half,
        source.r_min_cm * _M_PER_CM,
        source.dose_rate_constant / g_l0,
        source.gl_r_cm * _M_PER_CM,
        source.gl,
        source.f_r_cm * _M_PER_CM,
        np.deg2rad(source.f_theta_deg),
        source.f,
    )
    source._cache["kernel_tables"] = tables
    return tables


def _evaluate(
    source: Source,
    pts_mm: np.ndarray,
    pos_mm: np.ndarray,
    dirs: np.ndarray,
    weights: np.ndarray | None,
    parallel: bool,
) -> tuple[int, np.ndarray]:
    """Run the kernel on checked inputs.

    Returns the number of (point, dwell) pairs inside the source and either the (n_points,
    n_dwells) dose-rate matrix per S_K (``weights`` None) or the (n_points,) weighted sums.
    Threads are used only when asked (``parallel``) and the grid has at least
    :data:`PARALLEL_MIN_PAIRS` pairs; the numbers are the same bit for bit either way.
    """
    from tg43 import _kernels

    points = pts_mm * _M_PER_MM
    dwells = _kernels.dwell_rows(pos_mm * _M_PER_MM, dirs)
    n_p, n_d = points.shape[0], dwells.shape[1]
    matrix = weights is None
    rates = np.empty((n_p, n_d) if matrix else (0, 0))
    sums = np.empty(0 if matrix else n_p)
    w = np.empty(0) if matrix else weights
    args = (points, dwells, w, *_tables(source), rates, sums, matrix)
    if parallel and n_p > 1 and n_p * n_d >= PARALLEL_MIN_PAIRS:
        import numba

        if numba.get_num_threads() > 1:
            n_bad = _rows_parallel(max(1, _CHUNK_PAIRS // max(n_d, 1)), *args)
            return n_bad, rates if matrix else sums
    n_bad = _kernels.rows(0, n_p, *args)
    return n_bad, rates if matrix else sums


def _rows_parallel(chunk: int, *args) -> int:
    """``_kernels.rows_parallel`` with blocks of ``chunk`` points handed to the threads one at
    a time as they free up (numba's default splits the blocks evenly up front, which leaves a
    thread idle when another process slows its partner)."""
    import numba

    from tg43 import _kernels

    before = numba.set_parallel_chunksize(1)
    try:
        return _kernels.rows_parallel(chunk, *args)
    finally:
        numba.set_parallel_chunksize(before)


def _inside_error(source: Source, pts_mm: np.ndarray, pos_mm: np.ndarray, dirs: np.ndarray):
    """Build the error for the first (point, dwell) pair inside the source."""
    for j in range(pos_mm.shape[0]):
        d = pts_mm - pos_mm[j]
        r = np.linalg.norm(d, axis=1)
        z = d @ dirs[j]
        y = np.sqrt(np.maximum(r * r - z * z, 0.0))
        half_mm = 0.5 * source.active_length_cm * 10.0
        bad = (r < source.r_min_cm * 10.0) | ((y == 0) & (r <= half_mm))
        if bad.any():
            i = int(np.argmax(bad))
            n_bad = int(bad.sum())
            return TG43Error(
                f"points_mm: row {i} ({pts_mm[i].tolist()}) is {r[i]:.4g} mm from the centre of "
                f"dwell {j}, inside the {source.name} source (valid from r = "
                f"{source.r_min_cm * 10:.4g} mm; {n_bad} point(s) for this dwell); move the "
                "point or drop it"
            )
    return TG43Error("points_mm: a point lies inside the source (move it)")  # pragma: no cover


# --------------------------------------------------------------------------------------------
# public API


def dose_rate_per_sk(
    source: Source, positions_mm, directions, points_mm, *, parallel: bool = False
) -> np.ndarray:
    """Dose rate per unit air-kerma strength from each dwell at each point (2D line source).

    Parameters
    ----------
    source : Source
        From :func:`tg43.load_source`.
    positions_mm : array_like, shape (n_dwells, 3)
        Centres of the active source at each dwell, mm.
    directions : array_like, shape (n_dwells, 3)
        Unit vectors along the source axis pointing from the cable towards the source TIP
        (theta = 0). Norms must be 1 within 1e-6.
    points_mm : array_like, shape (n_points, 3)
        Calculation points, mm.
    parallel : bool
        Split the points over all numba threads when the grid has at least
        :data:`PARALLEL_MIN_PAIRS` point-dwell pairs (the same numbers bit for bit; default one
        thread).

    Returns
    -------
    ndarray, shape (n_points, n_dwells)
        Dose rate per unit S_K, cGy h^-1 U^-1.

    Raises
    ------
    TG43Error
        Wrong shapes, NaN/inf coordinates, zero or non-unit directions, or a point inside the
        source (nearer the source centre than ``source.r_min_cm``, or on the active segment).
    """
    _check_source(source)
    pos, dirs = _check_dwells(positions_mm, directions)
    pts = _as_xyz(points_mm, "points_mm", allow_single=True)
    n_bad, out = _evaluate(source, pts, pos, dirs, None, parallel)
    if n_bad:
        raise _inside_error(source, pts, pos, dirs)
    return out


def plan_dose_gy(
    source: Source,
    positions_mm,
    directions,
    times_s,
    sk_U: float,
    points_mm,
    *,
    treatment_date: _dt.date | _dt.datetime | str | None = None,
    reference_date: _dt.date | _dt.datetime | str | None = None,
    parallel: bool = False,
) -> np.ndarray:
    """Total dose of a plan at each point, Gy.

    ``D_i = sum_j S_K * rate_ij * t_j`` with ``rate_ij`` from :func:`dose_rate_per_sk`.

    Parameters
    ----------
    source : Source
        From :func:`tg43.load_source`.
    positions_mm, directions : array_like, shape (n_dwells, 3)
        Dwell centres (mm) and unit source directions (towards the tip).
    times_s : array_like, shape (n_dwells,)
        Dwell times, s (>= 0).
    sk_U : float
        Air-kerma strength, U (= cGy cm^2 h^-1), at the reference date (or at treatment when no
        dates are given).
    points_mm : array_like, shape (n_points, 3)
        Calculation points, mm.
    treatment_date, reference_date : date, datetime or ISO string, optional
        Give both to decay-correct S_K from the reference date to the treatment date with the
        Ir-192 half-life (73.83 d). Neither: no decay correction.
    parallel : bool
        Split the points over all numba threads when the grid has at least
        :data:`PARALLEL_MIN_PAIRS` point-dwell pairs (the same numbers bit for bit; default one
        thread).

    Returns
    -------
    ndarray, shape (n_points,)
        Dose, Gy.

    Raises
    ------
    TG43Error
        Bad shapes or values (see :func:`dose_rate_per_sk`), negative or non-finite times,
        S_K <= 0, only one date given, or a treatment date before the reference date.
    """
    _check_source(source)
    pos, dirs = _check_dwells(positions_mm, directions)
    pts = _as_xyz(points_mm, "points_mm", allow_single=True)
    times = _check_times(times_s, pos.shape[0])
    sk = _check_sk(sk_U) * decay_factor(treatment_date, reference_date)
    weights = times * (sk / _S_PER_H * _GY_PER_CGY)  # Gy per (cGy h^-1 U^-1)
    n_bad, out = _evaluate(source, pts, pos, dirs, weights, parallel)
    if n_bad:
        raise _inside_error(source, pts, pos, dirs)
    return out


def decay_factor(treatment_date=None, reference_date=None) -> float:
    """Ir-192 decay factor exp(-ln 2 * dt / 73.83 d) between two dates (1 if neither given).

    Raises
    ------
    TG43Error
        Only one date given, an unreadable date, or treatment before reference.
    """
    if treatment_date is None and reference_date is None:
        return 1.0
    if treatment_date is None or reference_date is None:
        missing = "treatment_date" if treatment_date is None else "reference_date"
        raise TG43Error(
            f"{missing}: missing; give both treatment_date and reference_date to decay-correct "
            "S_K, or neither"
        )
    t = _as_datetime(treatment_date, "treatment_date")
    ref = _as_datetime(reference_date, "reference_date")
    days = (t - ref).total_seconds() / 86400.0
    if days < 0:
        raise TG43Error(
            f"treatment_date {t.isoformat()} is before reference_date {ref.isoformat()}; "
            "check the dates (S_K is given at the reference date of the source certificate)"
        )
    return math.exp(-math.log(2.0) * days / IR192_HALF_LIFE_DAYS)


def _as_datetime(value, name: str) -> _dt.datetime:
    if isinstance(value, _dt.datetime):
        out = value
    elif isinstance(value, _dt.date):
        out = _dt.datetime(value.year, value.month, value.day)
    elif isinstance(value, str):
        try:
            out = _dt.datetime.fromisoformat(value.strip())
        except ValueError:
            raise TG43Error(f"{name}: {value!r} is not an ISO date (use YYYY-MM-DD)") from None
    else:
        raise TG43Error(f"{name}: must be a date, datetime or ISO string, got {value!r}")
    if out.tzinfo is not None:
        out = out.astimezone(_dt.UTC).replace(tzinfo=None)
    return out


def _check_times(times_s, n_dwells: int) -> np.ndarray:
    try:
        times = np.array(times_s, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise TG43Error("times_s: must be numbers, one dwell time (s) per dwell") from None
    if times.shape[0] != n_dwells:
        raise TG43Error(
            f"times_s has {times.shape[0]} values but there are {n_dwells} dwells (one each)"
        )
    if not np.all(np.isfinite(times)):
        raise TG43Error(f"times_s: dwell {int(np.argmax(~np.isfinite(times)))} is not finite")
    if np.any(times < 0):
        j = int(np.argmax(times < 0))
        raise TG43Error(f"times_s: dwell {j} has negative time {times[j]} s (must be >= 0)")
    return times


def _check_sk(sk_U) -> float:
    try:
        sk = float(sk_U)
    except (TypeError, ValueError):
        raise TG43Error(f"sk_U: {sk_U!r} is not a number (air-kerma strength in U)") from None
    if not math.isfinite(sk) or sk <= 0:
        raise TG43Error(f"sk_U: {sk_U!r} must be a finite air-kerma strength > 0 U")
    return sk


def _check_source(source) -> None:
    if not isinstance(source, Source):
        raise TG43Error(
            f"source: expected a tg43 Source (use tg43.load_source(name)), got "
            f"{type(source).__name__}"
        )


# --------------------------------------------------------------------------------------------
# along-away tables


def along_away_points_mm(z_cm: Sequence[float], y_cm: Sequence[float]) -> np.ndarray:
    """Points of an along-away grid for a source at the origin pointing along +z, mm.

    Returns shape (len(z_cm) * len(y_cm), 3) with rows ordered z-major (``[z0 y0, z0 y1, ...]``),
    points at (y, 0, z).
    """
    z = np.asarray(z_cm, dtype=float) * 10.0
    y = np.asarray(y_cm, dtype=float) * 10.0
    zz, yy = np.meshgrid(z, y, indexing="ij")
    return np.column_stack([yy.ravel(), np.zeros(zz.size), zz.ravel()])


def along_away_table(source: Source, z_cm, y_cm) -> np.ndarray:
    """Dose rate per S_K on an along-away grid, cGy h^-1 U^-1, shape (len(z_cm), len(y_cm)).

    The source sits at the origin pointing along +z (tip side = +z). Points inside the source
    (r < ``source.r_min_cm`` or on the active segment) are NaN instead of an error.
    """
    _check_source(source)
    z = np.asarray(z_cm, dtype=float)
    y = np.asarray(y_cm, dtype=float)
    pts = along_away_points_mm(z, y)
    _, out = _evaluate(source, pts, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), None, False)
    return out[:, 0].reshape(z.size, y.size)
