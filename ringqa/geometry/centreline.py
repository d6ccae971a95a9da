"""Channel centrelines: smooth arc-length parametrised curves through measured or designed points.

A :class:`Centreline` interpolates points ordered PROXIMAL (channel entry) -> DISTAL (tip) with a
quintic spline (C4; cubic when only 4-5 points are given) whose parameter is refitted until it
equals the arc length at every data point to 1e-9 (relative). Arc length ``s`` runs from 0 at the
first point to ``length_m`` at the last; the tangent points distally. Beyond the ends the curve is
extended by straight lines along the end tangents (a cable outside the applicator still gets a
position and a closest point).

Everything is in metres. The dense :class:`CentrelineTable` carries contiguous arrays for the numba
kernels in :mod:`ringqa.geometry._kernels`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ringqa.errors import RingQAError
from ringqa.geometry import _kernels as K
from ringqa.geometry._bspline import make_interp_spline

#: Maximum spacing of the dense table (m).
TABLE_SPACING_M = 0.25e-3

_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)

#: Most points a centreline (or a measured path) may have (issue 25). A channel needs one point
#: every 0.1-1 mm (150-1500 for a 150 mm ring); the spline's memory and time grow linearly
#: (benchmarks/bench_memory.py: 40 000 points ~0.9 s and < 100 MB above the imports), and
#: 100 000 points are 1 um apart on a 100 mm channel, below any measurement's resolution.
MAX_POINTS = 100_000


def point_count_problem(n: int, what: str = "centreline") -> tuple[str, str] | None:
    """(problem, fix) when ``n`` points are more than :data:`MAX_POINTS`, else None.

    Parameters
    ----------
    n : int
        Number of points given.
    what : str
        What the points are ("centreline", "measured path"), for the message.
    """
    if n <= MAX_POINTS:
        return None
    return (
        f"{n:,} points, more than the {MAX_POINTS:,} a {what} may have (a channel needs one "
        "point every 0.1-1 mm: 150-1500 for a 150 mm ring)",
        "resample the points along the channel, e.g. every 0.25 mm by interpolating each "
        "coordinate over the cumulative distance between points (numpy.interp)",
    )


class GeometryError(RingQAError):
    """Invalid geometry input (names the argument and the fix)."""


@dataclass(frozen=True, eq=False)
class CentrelineTable:
    """Arrays describing a centreline for the numba kernels (all contiguous float64, SI).

    Attributes
    ----------
    knots : (nb+1,) ndarray
        Breakpoints of the polynomial pieces (m), ``knots[0] = 0``, ``knots[-1] = length``.
    coef : (nb, deg+1, 3) ndarray
        Power-basis coefficients, ``r(s) = sum_j coef[i, j] (s - knots[i])**j`` on piece i.
    s : (m,) ndarray
        Dense uniform arc-length samples (m), spacing ``<= 0.25 mm``.
    pos : (m, 3) ndarray
        Positions at ``s`` (m).
    tan : (m, 3) ndarray
        Unit tangents at ``s`` (distal).
    nor : (m, 3) ndarray
        Unit normals at ``s``: Frenet where the curvature exceeds ``KAPPA_MIN``, elsewhere
        parallel-transported from the nearest curved sample (or from a fixed perpendicular on an
        entirely straight line).
    kappa : (m,) ndarray
        Curvature at ``s`` (1/m).
    """

    knots: np.ndarray
    coef: np.ndarray
    s: np.ndarray
    pos: np.ndarray
    tan: np.ndarray
    nor: np.ndarray
    kappa: np.ndarray

    @property
    def length_m(self) -> float:
        """Arc length of the centreline (m)."""
        return float(self.knots[-1])

    @property
    def spacing_m(self) -> float:
        """Spacing of the dense samples (m)."""
        return float(self.s[1] - self.s[0])


def _validate_points(points_m) -> np.ndarray:
    try:
        pts = np.array(points_m, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GeometryError(
            f"points_m: cannot be read as numbers ({exc}); give an (n, 3) array in metres"
        ) from None
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise GeometryError(
            f"points_m: expected an (n, 3) array of x, y, z in metres, got shape {pts.shape}"
        )
    too_many = point_count_problem(pts.shape[0])
    if too_many is not None:
        raise GeometryError(f"points_m: {too_many[0]}; {too_many[1]}")
    if pts.shape[0] < 4:
        raise GeometryError(
            f"points_m: a centreline needs at least 4 points, got {pts.shape[0]}; "
            "give more points along the channel"
        )
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        raise GeometryError(
            f"points_m: point {int(np.argmax(bad))} is not finite (NaN or inf); "
            "remove or correct it"
        )
    chord = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    scale = max(float(np.ptp(pts, axis=0).max()), 1e-300)
    dup = chord <= 1e-9 * scale
    if dup.any():
        i = int(np.argmax(dup))
        raise GeometryError(
            f"points_m: points {i} and {i + 1} coincide; remove duplicated consecutive points"
        )
    if scale > 10.0:
        raise GeometryError(
            f"points_m: the points span {scale:.3g} m; centreline points must be in metres "
            "(convert millimetres with ringqa.units.mm_to_m)"
        )
    return pts


def _arc_lengths(spl, breaks: np.ndarray) -> np.ndarray:
    """Arc length of ``spl`` over each interval of ``breaks`` (10-point Gauss-Legendre)."""
    a = breaks[:-1, None]
    b = breaks[1:, None]
    x = 0.5 * (b - a) * _GL_X[None, :] + 0.5 * (b + a)
    speed = np.linalg.norm(spl(x.ravel(), 1), axis=-1).reshape(x.shape)
    return 0.5 * (b[:, 0] - a[:, 0]) * (speed * _GL_W[None, :]).sum(axis=1)


def _fit_arclength(pts: np.ndarray, degree: int, rtol: float = 1e-9, max_iter: int = 60):
    """Interpolating spline whose parameter equals arc length at the data points."""
    t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    with np.errstate(over="ignore", invalid="ignore"):
        return _fit_arclength_loop(pts, degree, t, rtol, max_iter)


def _fit_arclength_loop(pts, degree, t, rtol, max_iter):
    """The fixed-point iteration of :func:`_fit_arclength` (GeometryError when it fails)."""
    err = float("nan")
    for _ in range(max_iter):
        if not (np.isfinite(t).all() and np.all(np.diff(t) > 0)):
            break  # the spline between the points has a cusp (zero speed): no arc length
        try:
            spl = make_interp_spline(t, pts, k=degree)
        except (ValueError, np.linalg.LinAlgError):
            break
        knots = np.unique(spl.t[(spl.t >= t[0]) & (spl.t <= t[-1])])
        breaks = np.unique(np.concatenate([knots, t]))
        seg = _arc_lengths(spl, breaks)
        cum = np.concatenate([[0.0], np.cumsum(seg)])
        arc_at_t = np.interp(t, breaks, cum)  # exact: every t is a break
        dt = np.diff(t)
        darc = np.diff(arc_at_t)
        err = float(np.max(np.abs(darc - dt) / dt))
        if err < rtol:
            return spl, t, err
        t = arc_at_t
    raise GeometryError(
        f"points_m: the arc-length parametrisation did not converge (residual {err:.2e}); "
        "the points are probably very unevenly spaced or zig-zag: resample them along the channel"
    )


def _power_coefficients(spl, t_end: float):
    """Breakpoints and power-basis coefficients (nb, deg+1, 3) of a B-spline on [0, t_end]."""
    deg = spl.k
    brk = np.unique(spl.t[(spl.t >= 0.0) & (spl.t <= t_end)])
    brk[0] = 0.0
    brk[-1] = t_end
    left = brk[:-1]
    coef = np.empty((left.size, deg + 1, 3))
    fact = 1.0
    for j in range(deg + 1):
        if j > 0:
            fact *= j
        coef[:, j, :] = spl(left, j) / fact
    return np.ascontiguousarray(brk), np.ascontiguousarray(coef)


def _transport_fill(tan: np.ndarray, nor: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Fill normals at invalid samples by parallel transport (double reflection) from the nearest
    valid sample; with no valid sample, transport a fixed perpendicular from the first sample."""
    m = tan.shape[0]
    out = nor.copy()

    def transport(n, t0, t1):
        # rotation-minimising transport between unit tangents t0 -> t1 (projection + renorm.)
        v = n - np.dot(n, t1) * t1
        return v / np.linalg.norm(v)

    if not valid.any():
        t0 = tan[0]
        axis = np.zeros(3)
        axis[int(np.argmin(np.abs(t0)))] = 1.0
        n = axis - np.dot(axis, t0) * t0
        out[0] = n / np.linalg.norm(n)
        for i in range(1, m):
            out[i] = transport(out[i - 1], tan[i - 1], tan[i])
        return out
    # forward and backward passes; keep the one from the nearer valid sample
    fwd = np.full(m, -1)
    bwd = np.full(m, -1)
    nf = out.copy()
    nbk = out.copy()
    last = -1
    for i in range(m):
        if valid[i]:
            last = i
        elif last >= 0:
            nf[i] = transport(nf[i - 1], tan[i - 1], tan[i])
        fwd[i] = last
    last = -1
    for i in range(m - 1, -1, -1):
        if valid[i]:
            last = i
        elif last >= 0:
            nbk[i] = transport(nbk[i + 1], tan[i + 1], tan[i])
        bwd[i] = last
    for i in np.flatnonzero(~valid):
        df = i - fwd[i] if fwd[i] >= 0 else np.inf
        db = bwd[i] - i if bwd[i] >= 0 else np.inf
        out[i] = nf[i] if df <= db else nbk[i]
    return out


class Centreline:
    """A channel centreline: C2 (quintic: C4) curve parametrised by arc length, in metres.

    Build with :meth:`from_points`. Arc length ``s`` (m) runs from 0 at the proximal (entry) end
    to :attr:`length_m` at the distal tip; all evaluators accept a scalar or a ``(k,)`` array and
    return ``(3,)`` / ``(k, 3)`` vectors or scalars / ``(k,)`` values. Outside ``[0, length]``
    the straight extensions along the end tangents are used (curvature and torsion 0 there).
    """

    __slots__ = ("_degree", "_length", "_points", "_spl", "_table")

    def __init__(self, spl, points_m: np.ndarray, length_m: float, table: CentrelineTable):
        self._spl = spl
        self._points = points_m
        self._length = float(length_m)
        self._table = table
        self._degree = int(spl.k)

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def from_points(cls, points_m, degree: int | None = None) -> Centreline:
        """Interpolate points ordered proximal -> distal.

        Parameters
        ----------
        points_m : (n, 3) array_like
            Centreline points (m), n >= 4, finite, no duplicated consecutive points.
        degree : {3, 5}, optional
            Spline degree; default 5 (C4, curvature and torsion smooth) when n >= 6, else 3.

        Returns
        -------
        Centreline

        Raises
        ------
        GeometryError
            Fewer than 4 or more than :data:`MAX_POINTS` points, non-finite or duplicated
            points, points not in metres, or a parametrisation that does not converge.
        """
        pts = _validate_points(points_m)
        if degree is None:
            degree = 5 if pts.shape[0] >= 6 else 3
        if degree not in (3, 5):
            raise GeometryError(f"degree: must be 3 or 5, got {degree!r}")
        if pts.shape[0] < degree + 1:
            raise GeometryError(
                f"points_m: degree {degree} needs at least {degree + 1} points, got {pts.shape[0]}"
            )
        spl, t, _err = _fit_arclength(pts, degree)
        length = float(t[-1])
        knots, coef = _power_coefficients(spl, length)
        m = max(int(np.ceil(length / TABLE_SPACING_M)) + 1, 2)
        s = np.linspace(0.0, length, m)
        d0 = spl(s)
        d1 = spl(s, 1)
        d2 = spl(s, 2)
        speed = np.linalg.norm(d1, axis=1)
        tan = d1 / speed[:, None]
        cross = np.cross(d1, d2)
        kappa = np.linalg.norm(cross, axis=1) / speed**3
        nvec = d2 - np.sum(d2 * tan, axis=1)[:, None] * tan
        valid = kappa > K.KAPPA_MIN
        nn = np.linalg.norm(nvec, axis=1)
        nor = np.zeros_like(nvec)
        nor[valid] = nvec[valid] / nn[valid, None]
        nor = _transport_fill(tan, nor, valid)
        table = CentrelineTable(
            knots=knots,
            coef=coef,
            s=np.ascontiguousarray(s),
            pos=np.ascontiguousarray(d0),
            tan=np.ascontiguousarray(tan),
            nor=np.ascontiguousarray(nor),
            kappa=np.ascontiguousarray(kappa),
        )
        return cls(spl, pts, length, table)

    # -- properties -----------------------------------------------------------------------
    @property
    def length_m(self) -> float:
        """Arc length from the proximal end to the distal tip (m)."""
        return self._length

    @property
    def table(self) -> CentrelineTable:
        """Dense arrays for the numba kernels."""
        return self._table

    @property
    def points_m(self) -> np.ndarray:
        """The input points (n, 3) in metres (a copy)."""
        return self._points.copy()

    @property
    def degree(self) -> int:
        """Spline degree (3 or 5)."""
        return self._degree

    # -- evaluation -----------------------------------------------------------------------
    @staticmethod
    def _as_s(s_m):
        s = np.asarray(s_m, dtype=float)
        if not np.all(np.isfinite(s)):
            raise GeometryError("s_m: arc lengths must be finite numbers (m)")
        return s, s.ndim == 0

    def _deriv(self, s: np.ndarray, nu: int) -> np.ndarray:
        """nu-th derivative (k,3) of the extended curve."""
        s = np.atleast_1d(s)
        inside = np.clip(s, 0.0, self._length)
        out = np.asarray(self._spl(inside, nu), dtype=float).reshape(s.size, 3)
        out_side = (s < 0.0) | (s > self._length)
        if out_side.any():
            ends = np.where(s[out_side] < 0.0, 0.0, self._length)
            r = self._spl(ends)
            d = self._spl(ends, 1)
            d = d / np.linalg.norm(d, axis=1)[:, None]
            if nu == 0:
                out[out_side] = r + (s[out_side] - ends)[:, None] * d
            elif nu == 1:
                out[out_side] = d
            else:
                out[out_side] = 0.0
        return out

    def position(self, s_m):
        """Position (m) at arc length ``s_m``: ``(3,)`` for a scalar, ``(k, 3)`` for ``(k,)``."""
        s, scalar = self._as_s(s_m)
        out = self._deriv(s, 0)
        return out[0] if scalar else out

    def tangent(self, s_m):
        """Unit tangent (pointing distally) at ``s_m``: ``(3,)`` or ``(k, 3)``."""
        s, scalar = self._as_s(s_m)
        d = self._deriv(s, 1)
        out = d / np.linalg.norm(d, axis=1)[:, None]
        return out[0] if scalar else out

    def frame(self, s_m):
        """Position, unit tangent and unit normal at ``s_m`` (via the kernel ``frames_at``)."""
        s, scalar = self._as_s(s_m)
        t = self._table
        pos, tan, nor = K.frames_at(t.knots, t.coef, t.s, t.nor, np.atleast_1d(s).astype(float))
        if scalar:
            return pos[0], tan[0], nor[0]
        return pos, tan, nor

    def normal(self, s_m):
        """Unit normal at ``s_m`` (towards the centre of curvature; parallel-transported where
        the curvature is below ``KAPPA_MIN`` = 1 1/m): ``(3,)`` or ``(k, 3)``."""
        return self.frame(s_m)[2]

    def binormal(self, s_m):
        """Unit binormal ``tangent x normal`` at ``s_m``: ``(3,)`` or ``(k, 3)``."""
        _, tan, nor = self.frame(s_m)
        return np.cross(tan, nor)

    def curvature(self, s_m):
        """Curvature (1/m) at ``s_m``: scalar or ``(k,)``."""
        s, scalar = self._as_s(s_m)
        d1 = self._deriv(s, 1)
        d2 = self._deriv(s, 2)
        k = np.linalg.norm(np.cross(d1, d2), axis=1) / np.linalg.norm(d1, axis=1) ** 3
        return float(k[0]) if scalar else k

    def torsion(self, s_m):
        """Torsion (1/m) at ``s_m``: scalar or ``(k,)``; 0 where the curvature is ~0."""
        s, scalar = self._as_s(s_m)
        d1 = self._deriv(s, 1)
        d2 = self._deriv(s, 2)
        d3 = self._deriv(s, 3)
        c = np.cross(d1, d2)
        c2 = np.sum(c * c, axis=1)
        speed = np.linalg.norm(d1, axis=1)
        kappa = np.sqrt(c2) / speed**3
        tau = np.zeros_like(c2)
        ok = kappa > K.KAPPA_MIN
        tau[ok] = np.sum(c[ok] * d3[ok], axis=1) / c2[ok]
        return float(tau[0]) if scalar else tau

    def closest(self, points_m, s_hint_m=None, window_m=None):
        """Closest centreline points (numba kernel ``closest_points``).

        Parameters
        ----------
        points_m : (3,) or (k, 3) array_like
            Query points (m).
        s_hint_m : float or (k,) array_like, optional
            Arc lengths to search around (m), e.g. each point's previous answer.
        window_m : float, optional
            Half-width of the search interval around the hint (m). Without a hint or a window
            (or with ``window_m <= 0``) the whole centreline is searched.

        Returns
        -------
        s_m : (k,) ndarray
            Arc length of the closest point (may be < 0 or > length on the straight extensions).
        dist_m : (k,) ndarray
            Distance to the centreline (m).
        """
        p = np.asarray(points_m, dtype=float)
        p2 = np.ascontiguousarray(np.atleast_2d(p))
        if p2.ndim != 2 or p2.shape[1] != 3 or not np.isfinite(p2).all():
            raise GeometryError("points_m: expected finite (k, 3) points in metres")
        if s_hint_m is None or window_m is None or window_m <= 0:
            hints = np.zeros(p2.shape[0])
            window = -1.0
        else:
            hints = np.ascontiguousarray(np.broadcast_to(np.asarray(s_hint_m, float), p2.shape[:1]))
            if not np.isfinite(hints).all():
                raise GeometryError("s_hint_m: hints must be finite arc lengths (m)")
            window = float(window_m)
        t = self._table
        return K.closest_points(t.knots, t.coef, t.s, t.pos, p2, hints, window)

    def __repr__(self) -> str:
        return (
            f"Centreline(length={self._length * 1e3:.3f} mm, points={self._points.shape[0]}, "
            f"degree={self._degree})"
        )
