"""Numba kernels of the geometry layer: centreline evaluation, closest point, lumen wall distance.

The kernels see arrays and scalars only (the public classes validate and unpack). All are
``@njit(cache=True)`` without fastmath (bit-stable contact geometry). Units: SI (m).

Centreline arrays (the fields of :class:`ringqa.geometry.centreline.CentrelineTable`)
--------------------------------------------------------------------------------------
``knots (nb+1,)``
    Breakpoints of the polynomial pieces, increasing, ``knots[0] = 0``, ``knots[-1] = L``.
``coef (nb, deg+1, 3)``
    Power-basis coefficients: on piece ``i`` the position is
    ``r(s) = sum_j coef[i, j] * (s - knots[i])**j``. The parameter ``s`` is the arc length (the
    spline was refitted until its parameter equals arc length at the data points to 1e-9).
``s (m,)``, ``pos (m,3)``, ``nor (m,3)``
    Dense uniform sampling (spacing ``s[1] - s[0] <= 0.25 mm``) used to start searches and to
    carry the parallel-transported normal where the curvature is ~0.

Beyond the ends (``s < 0`` or ``s > L``) the centreline is extended by straight lines along the
end tangents, with the end normal: ``frame_at`` and ``closest_point`` both use this extension, so
a cable node outside the applicator gets a finite, continuous answer.

Signatures
----------
``eval_deriv(knots, coef, s, nu) -> (3,)``: ``nu``-th derivative of r at s (extended).
``frame_at(knots, coef, s_tab, nor_tab, s) -> (pos (3,), tan (3,), nor (3,))``.
``closest_point(knots, coef, s_tab, pos_tab, p (3,), s_hint, window) -> (s, dist)``.
``closest_points(knots, coef, s_tab, pos_tab, pts (k,3), hints (k,), window) -> (s (k,), d (k,))``.
``wall_distance(seg_s, seg_rb, seg_flat, s, offset (3,), nor (3,)) -> (d_wall, n0, n1, n2)``.

Speed (benchmarks/bench_geometry.py, one core): hinted ``closest_point`` with a 2 mm window about
0.5 us, global about 1.2 us on a 90 mm curve; ``frame_at`` 0.2 us; ``wall_distance`` 0.07 us.

Caveat: numba's on-disk cache of a caller in another module does not notice edits to these
kernels; after changing this file, delete the callers' ``__pycache__/*.nbi|*.nbc`` files.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Curvature (1/m) below which the Frenet normal is replaced by the transported normal. A bend
#: radius above 1 m is "straight" for an applicator (real bends: 5-50 mm), and below it the bend
#: DIRECTION is interpolation ripple: a quintic spline through a C2 stem/transition join ripples
#: with curvature up to ~0.05 1/m whose direction flips from sample to sample.
KAPPA_MIN = 1.0

#: Newton tolerance on the arc length of a closest point (m).
_S_TOL = 1.0e-11


@njit(cache=True)
def _piece(knots, s):
    """Index ``i`` of the piece with ``knots[i] <= s < knots[i+1]`` (clamped to the pieces)."""
    nb = knots.shape[0] - 1
    if s <= knots[0]:
        return 0
    if s >= knots[nb]:
        return nb - 1
    lo = 0
    hi = nb
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if knots[mid] <= s:
            lo = mid
        else:
            hi = mid
    return lo


@njit(cache=True)
def _eval_in(coef, i, x, nu):
    """``nu``-th derivative of piece ``i`` at local coordinate ``x`` (Horner)."""
    deg = coef.shape[1] - 1
    out = np.zeros(3)
    if nu > deg:
        return out
    for j in range(deg, nu - 1, -1):
        f = 1.0
        for q in range(nu):
            f *= j - q
        for c in range(3):
            out[c] = out[c] * x + f * coef[i, j, c]
    return out


@njit(cache=True)
def eval_deriv(knots, coef, s, nu):
    """``nu``-th derivative (0..3) of the extended centreline at arc length ``s`` (m)."""
    nb = knots.shape[0] - 1
    length = knots[nb]
    if s < 0.0 or s > length:
        s_end = 0.0 if s < 0.0 else length
        i = _piece(knots, s_end)
        r = _eval_in(coef, i, s_end - knots[i], 0)
        d = _eval_in(coef, i, s_end - knots[i], 1)
        nrm = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        for c in range(3):
            d[c] /= nrm
        if nu == 0:
            for c in range(3):
                r[c] += (s - s_end) * d[c]
            return r
        if nu == 1:
            return d
        return np.zeros(3)
    i = _piece(knots, s)
    return _eval_in(coef, i, s - knots[i], nu)


@njit(cache=True)
def _unit(v):
    n = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return v / n, n


@njit(cache=True)
def frame_at(knots, coef, s_tab, nor_tab, s):
    """Position, unit tangent (distal) and unit normal at arc length ``s`` (m).

    The normal is the Frenet normal where the curvature exceeds ``KAPPA_MIN``; elsewhere (and
    beyond the ends) it is the table's parallel-transported normal, interpolated linearly and
    re-orthogonalised against the exact tangent, so it is never NaN.

    Returns
    -------
    pos, tan, nor : (3,) float64 each
    """
    length = knots[knots.shape[0] - 1]
    sc = min(max(s, 0.0), length)
    r0, r1, r2, d0, d1, d2, c0, c1, c2 = _eval012(knots, coef, sc)
    sp = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    t0 = d0 / sp
    t1 = d1 / sp
    t2 = d2 / sp
    pos = np.empty(3)
    tan = np.empty(3)
    nor = np.empty(3)
    pos[0] = r0 + (s - sc) * t0
    pos[1] = r1 + (s - sc) * t1
    pos[2] = r2 + (s - sc) * t2
    tan[0] = t0
    tan[1] = t1
    tan[2] = t2
    if s == sc:
        x0 = d1 * c2 - d2 * c1
        x1 = d2 * c0 - d0 * c2
        x2 = d0 * c1 - d1 * c0
        kappa = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2) / (sp * sp * sp)
        if kappa > KAPPA_MIN:
            a = c0 * t0 + c1 * t1 + c2 * t2
            n0 = c0 - a * t0
            n1 = c1 - a * t1
            n2 = c2 - a * t2
            nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            nor[0] = n0 / nn
            nor[1] = n1 / nn
            nor[2] = n2 / nn
            return pos, tan, nor
    m = s_tab.shape[0]
    h = s_tab[1] - s_tab[0]
    x = sc / h
    j = int(x)
    if j > m - 2:
        j = m - 2
    w = x - j
    n0 = (1.0 - w) * nor_tab[j, 0] + w * nor_tab[j + 1, 0]
    n1 = (1.0 - w) * nor_tab[j, 1] + w * nor_tab[j + 1, 1]
    n2 = (1.0 - w) * nor_tab[j, 2] + w * nor_tab[j + 1, 2]
    a = n0 * t0 + n1 * t1 + n2 * t2
    n0 -= a * t0
    n1 -= a * t1
    n2 -= a * t2
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    nor[0] = n0 / nn
    nor[1] = n1 / nn
    nor[2] = n2 / nn
    return pos, tan, nor


@njit(cache=True)
def _eval012(knots, coef, s):
    """r, r', r'' at ``s`` on the polynomial pieces (no extension), as 9 scalars, no allocation."""
    i = _piece(knots, s)
    x = s - knots[i]
    deg = coef.shape[1] - 1
    p0 = coef[i, deg, 0]
    p1 = coef[i, deg, 1]
    p2 = coef[i, deg, 2]
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    for j in range(deg - 1, -1, -1):
        b0 = b0 * x + a0
        b1 = b1 * x + a1
        b2 = b2 * x + a2
        a0 = a0 * x + p0
        a1 = a1 * x + p1
        a2 = a2 * x + p2
        p0 = p0 * x + coef[i, j, 0]
        p1 = p1 * x + coef[i, j, 1]
        p2 = p2 * x + coef[i, j, 2]
    return p0, p1, p2, a0, a1, a2, 2.0 * b0, 2.0 * b1, 2.0 * b2


@njit(cache=True)
def _g(knots, coef, p, s):
    """Half the derivative of |r(s) - p|^2, its derivative, and the squared distance."""
    r0, r1, r2, d0, d1, d2, c0, c1, c2 = _eval012(knots, coef, s)
    e0 = r0 - p[0]
    e1 = r1 - p[1]
    e2 = r2 - p[2]
    g = e0 * d0 + e1 * d1 + e2 * d2
    dg = d0 * d0 + d1 * d1 + d2 * d2 + e0 * c0 + e1 * c1 + e2 * c2
    return g, dg, e0 * e0 + e1 * e1 + e2 * e2


@njit(cache=True)
def _refine(knots, coef, p, lo, hi):
    """Minimise |r(s) - p|^2 over [lo, hi]: safeguarded Newton on g = (r - p).r'.

    Returns (s, squared distance). The iterate never leaves [lo, hi]; where g keeps one sign the
    minimiser is the corresponding end; a local maximum inside means one of the ends wins.
    """
    glo, _, flo = _g(knots, coef, p, lo)
    ghi, _, fhi = _g(knots, coef, p, hi)
    if glo >= 0.0 and ghi >= 0.0:
        return lo, flo
    if glo <= 0.0 and ghi <= 0.0:
        return hi, fhi
    if glo > 0.0 and ghi < 0.0:  # a maximum inside: the smaller end
        if flo <= fhi:
            return lo, flo
        return hi, fhi
    # glo < 0 < ghi: a bracketed minimum
    s = 0.5 * (lo + hi)
    for _ in range(60):
        g, dg, _f = _g(knots, coef, p, s)
        if g < 0.0:
            lo = s
        else:
            hi = s
        if dg > 0.0:
            s_new = s - g / dg
        else:
            s_new = 0.5 * (lo + hi)
        if s_new <= lo or s_new >= hi:
            s_new = 0.5 * (lo + hi)
        if abs(s_new - s) < _S_TOL or hi - lo < _S_TOL:
            s = s_new
            break
        s = s_new
    _g0, _dg0, f = _g(knots, coef, p, s)
    return s, f


@njit(cache=True)
def _refine_from(knots, coef, p, s0, lo, hi):
    """Newton from the sample ``s0``; falls back to the bracketed :func:`_refine` on [lo, hi]
    when an iterate leaves the bracket or the curvature of |r - p|^2 is not positive."""
    s = s0
    for _ in range(12):
        g, dg, f = _g(knots, coef, p, s)
        if not dg > 0.0:
            break
        step = g / dg
        s_new = s - step
        if s_new < lo or s_new > hi:
            break
        if abs(step) < _S_TOL:
            _g0, _dg0, f = _g(knots, coef, p, s_new)
            return s_new, f
        s = s_new
    return _refine(knots, coef, p, lo, hi)


@njit(cache=True)
def closest_point(knots, coef, s_tab, pos_tab, p, s_hint, window):
    """Closest point of the (extended) centreline to ``p`` within ``s_hint +- window``.

    Parameters
    ----------
    knots, coef, s_tab, pos_tab : arrays
        Table arrays (see the module docstring).
    p : (3,) float64
        Query point (m).
    s_hint, window : float
        Search interval ``[s_hint - window, s_hint + window]`` (m); ``window <= 0`` searches the
        whole centreline (and its straight extensions beyond the ends).

    Returns
    -------
    s : float
        Arc length of the closest point (m), within the search interval; it may be < 0 or > L
        on the straight extensions.
    dist : float
        Distance from ``p`` to the centreline point at ``s`` (m).

    Notes
    -----
    The dense samples inside the interval are scanned; every sampled local minimum whose squared
    distance is within the sampling error of the best one is refined by bracketed Newton on the
    polynomial pieces (to 1e-11 m in s), and the best refined answer wins. A hint with a small
    window therefore never jumps to another branch of the curve passing nearby.
    """
    nb = knots.shape[0] - 1
    length = knots[nb]
    if window > 0.0:
        a = s_hint - window
        b = s_hint + window
    else:
        a = -math.inf
        b = math.inf
    # search on the curve part first
    ca = max(a, 0.0)
    cb = min(b, length)
    best_s = 0.0
    best_f = math.inf
    if ca <= cb:
        m = s_tab.shape[0]
        h = s_tab[1] - s_tab[0]
        j0 = math.ceil(ca / h - 1e-12)
        j1 = math.floor(cb / h + 1e-12)
        if j0 < 0:
            j0 = 0
        if j1 > m - 1:
            j1 = m - 1
        n_in = j1 - j0 + 1
        if n_in < 1:
            s, f = _refine(knots, coef, p, ca, cb)
            best_s = s
            best_f = f
        else:
            fmin = math.inf
            for j in range(j0, j1 + 1):
                e0 = pos_tab[j, 0] - p[0]
                e1 = pos_tab[j, 1] - p[1]
                e2 = pos_tab[j, 2] - p[2]
                f = e0 * e0 + e1 * e1 + e2 * e2
                if f < fmin:
                    fmin = f
            # A branch whose true minimum beats the best sample has a sample within h/2 of its
            # minimiser, so at most h^2/4 * max f''/2 above it, with f'' = 2(|r'|^2 + (r-p).r'')
            # <= 2(1 + d kappa). Twice that bound, for kappa up to 2000 1/m (0.5 mm radius):
            margin = 0.5 * h * h * (1.0 + math.sqrt(fmin) * 2.0e3)
            f_prev = math.inf
            e0 = pos_tab[j0, 0] - p[0]
            e1 = pos_tab[j0, 1] - p[1]
            e2 = pos_tab[j0, 2] - p[2]
            f_cur = e0 * e0 + e1 * e1 + e2 * e2
            for j in range(j0, j1 + 1):
                if j < j1:
                    e0 = pos_tab[j + 1, 0] - p[0]
                    e1 = pos_tab[j + 1, 1] - p[1]
                    e2 = pos_tab[j + 1, 2] - p[2]
                    f_next = e0 * e0 + e1 * e1 + e2 * e2
                else:
                    f_next = math.inf
                if f_cur <= fmin + margin and f_prev >= f_cur and f_next >= f_cur:
                    lo = max(s_tab[j] - h, ca)
                    hi = min(s_tab[j] + h, cb)
                    s, f = _refine_from(knots, coef, p, s_tab[j], lo, hi)
                    if f < best_f:
                        best_f = f
                        best_s = s
                f_prev = f_cur
                f_cur = f_next
    # straight extensions beyond the ends
    if a < 0.0:
        r0, r1, r2, t0, t1, t2, _c0, _c1, _c2 = _eval012(knots, coef, 0.0)
        sp = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0 /= sp
        t1 /= sp
        t2 /= sp
        u = (p[0] - r0) * t0 + (p[1] - r1) * t1 + (p[2] - r2) * t2
        u = min(max(min(u, 0.0), a), b)
        e0 = r0 + u * t0 - p[0]
        e1 = r1 + u * t1 - p[1]
        e2 = r2 + u * t2 - p[2]
        f = e0 * e0 + e1 * e1 + e2 * e2
        if f < best_f:
            best_f = f
            best_s = u
    if b > length:
        r0, r1, r2, t0, t1, t2, _c0, _c1, _c2 = _eval012(knots, coef, length)
        sp = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        t0 /= sp
        t1 /= sp
        t2 /= sp
        u = (p[0] - r0) * t0 + (p[1] - r1) * t1 + (p[2] - r2) * t2
        u = max(min(max(u, 0.0), b - length), a - length)
        e0 = r0 + u * t0 - p[0]
        e1 = r1 + u * t1 - p[1]
        e2 = r2 + u * t2 - p[2]
        f = e0 * e0 + e1 * e1 + e2 * e2
        if f < best_f:
            best_f = f
            best_s = length + u
    return best_s, math.sqrt(best_f)


@njit(cache=True)
def closest_points(knots, coef, s_tab, pos_tab, pts, hints, window):
    """Vectorised :func:`closest_point`: ``pts (k,3)``, ``hints (k,)`` -> ``(s (k,), d (k,))``."""
    k = pts.shape[0]
    s_out = np.empty(k)
    d_out = np.empty(k)
    for i in range(k):
        s_out[i], d_out[i] = closest_point(knots, coef, s_tab, pos_tab, pts[i], hints[i], window)
    return s_out, d_out


@njit(cache=True)
def frames_at(knots, coef, s_tab, nor_tab, s_arr):
    """Vectorised :func:`frame_at`: ``s_arr (k,)`` -> ``pos, tan, nor`` each ``(k,3)``."""
    k = s_arr.shape[0]
    pos = np.empty((k, 3))
    tan = np.empty((k, 3))
    nor = np.empty((k, 3))
    for i in range(k):
        p, t, n = frame_at(knots, coef, s_tab, nor_tab, s_arr[i])
        # element copies, not ``pos[i] = p``: an array slice assignment compiles numba's
        # shape-mismatch error formatting (strings), ~3 s of a cold start (docs/speed.md)
        for c in range(3):
            pos[i, c] = p[c]
            tan[i, c] = t[c]
            nor[i, c] = n[c]
    return pos, tan, nor


# ---------------------------------------------------------------------------------------------
# Lumen
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
def _segment(seg_s, s):
    """Index ``k`` with ``seg_s[k] <= s < seg_s[k+1]`` (clamped to the segments)."""
    return _piece(seg_s, s)


@njit(cache=True)
def wall_distance(seg_s, seg_rb, seg_flat, s, offset, nor):
    """Signed distance to the lumen wall and the outward wall normal.

    Parameters
    ----------
    seg_s : (k+1,) float64
        Segment bounds in arc length (m), increasing (may start at -inf and end at +inf).
    seg_rb : (k,) float64
        Lumen radius r_b per segment (m).
    seg_flat : (k,) float64
        Distance from the centreline to the flat side (m) on the outside of the bend (along
        ``-nor``); ``+inf`` (or >= r_b) means a circular lumen.
    s : float
        Arc length of the cross-section (m).
    offset : (3,) float64
        Point minus centreline point at ``s`` (m), in the normal plane.
    nor : (3,) float64
        Unit centreline normal at ``s`` (towards the centre of the bend).

    Returns
    -------
    d_wall : float
        Distance to the nearest wall (m): positive inside the lumen, negative beyond the wall.
    n0, n1, n2 : float
        Outward unit wall normal at the nearest wall point.

    Notes
    -----
    The lumen is the disk ``|o| <= r_b`` intersected with the half-plane ``-o.nor <= flat``.
    Inside a convex intersection the distance to the boundary is the minimum of the distances to
    each boundary, so ``d_wall`` is continuous across the circle/flat junction; outside, the
    nearest boundary point is the radial projection, the projection on the flat, or a corner.
    """
    k = _segment(seg_s, s)
    rb = seg_rb[k]
    flat = seg_flat[k]
    rho = math.sqrt(offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2])
    if rho > 0.0:
        er0 = offset[0] / rho
        er1 = offset[1] / rho
        er2 = offset[2] / rho
    else:
        er0 = -nor[0]
        er1 = -nor[1]
        er2 = -nor[2]
    d_circ = rb - rho
    if not (flat < rb):
        return d_circ, er0, er1, er2
    # coordinates in the normal plane: u towards the outside of the bend (-nor), v lateral
    u = -(offset[0] * nor[0] + offset[1] * nor[1] + offset[2] * nor[2])
    l0 = offset[0] + u * nor[0]
    l1 = offset[1] + u * nor[1]
    l2 = offset[2] + u * nor[2]
    v = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
    if v > 0.0:
        el0 = l0 / v
        el1 = l1 / v
        el2 = l2 / v
    else:
        el0 = 0.0
        el1 = 0.0
        el2 = 0.0
    d_flat = flat - u
    if d_circ >= 0.0 and d_flat >= 0.0:
        if d_flat < d_circ:
            return d_flat, -nor[0], -nor[1], -nor[2]
        return d_circ, er0, er1, er2
    # outside: nearest point of the convex lumen boundary
    half = math.sqrt(rb * rb - flat * flat)
    best = math.inf
    b0 = 0.0
    b1 = 0.0
    b2 = 0.0
    # radial projection onto the circle (valid if it lies on the arc, u <= flat)
    if rho > 0.0 and u * rb / rho <= flat:
        dd = abs(rho - rb)
        if dd < best:
            best = dd
            b0 = er0
            b1 = er1
            b2 = er2
    # projection onto the flat (valid if |v| <= half chord and beyond the flat)
    if d_flat < 0.0 and v <= half:
        dd = -d_flat
        if dd < best:
            best = dd
            b0 = -nor[0]
            b1 = -nor[1]
            b2 = -nor[2]
    # the corner on the point's side
    c0 = -flat * nor[0] + half * el0
    c1 = -flat * nor[1] + half * el1
    c2 = -flat * nor[2] + half * el2
    w0 = offset[0] - c0
    w1 = offset[1] - c1
    w2 = offset[2] - c2
    dd = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    if dd < best and dd > 0.0:
        best = dd
        b0 = w0 / dd
        b1 = w1 / dd
        b2 = w2 / dd
    return -best, b0, b1, b2


@njit(cache=True)
def banded_eliminate(band, kl, ku, b):
    """Forward elimination of ``A x = b`` for a banded ``A`` without pivoting (in place).

    Parameters
    ----------
    band : (n, kl + ku + 1) ndarray
        The band of ``A`` row by row: ``band[i, kl + j - i] = A[i, j]`` for
        ``i - kl <= j <= i + ku``; on return the upper triangle ``U`` of the elimination
        (``band[i, kl:]``; the columns left of ``kl`` are left as they were).
    kl, ku : int
        Number of sub- and super-diagonals.
    b : (n, d) ndarray
        Right-hand sides; on return ``L^-1 b``.

    Returns
    -------
    bool
        False when a pivot is zero (``band`` and ``b`` then undefined).

    Notes
    -----
    Row ``i`` minus ``A[i, j] / A[j, j]`` times row ``j`` for the ``kl`` rows below each pivot,
    element by element the dense elimination's operations (the same IEEE results): without
    pivoting nothing fills in outside the band, so memory is O(n (kl + ku)) and time
    O(n kl ku). Stable for totally positive matrices such as B-spline collocation matrices
    (de Boor and Pinkus, 1977). The back substitution is left to the caller.
    """
    n = band.shape[0]
    d = b.shape[1]
    for j in range(n - 1):
        piv = band[j, kl]
        if piv == 0.0:
            return False
        r1 = min(j + kl + 1, n)
        c1 = min(j + ku + 1, n)
        for i in range(j + 1, r1):
            f = band[i, kl + j - i] / piv
            for c in range(j + 1, c1):
                band[i, kl + c - i] -= f * band[j, kl + c - j]
            for m in range(d):
                b[i, m] -= f * b[j, m]
    return band[n - 1, kl] != 0.0
