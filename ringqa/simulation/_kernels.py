"""Numba kernels of the channel: evaluation, closest point, sliding points along it.

Everything here sees arrays and scalars only (SI units). The channel is a uniform arc-length
table (spacing ``h``) of centreline positions ``pos (m,3)``, unit tangents ``tan (m,3)`` and
normals ``nor (m,3)``, interpolated by cubic Hermite pieces (C1, exact to ~h^4 kappa^3 / 384,
i.e. < 1 nm for h = 0.25 mm and a 5 mm bend), extended by straight lines before s = 0 (the
approach: the transfer tube in front of the applicator) and beyond the last sample.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# ------------------------------------------------------------------------------------------
# centreline evaluation


@njit(cache=True, error_model="numpy")
def curve_eval(h, pos, tan, s, out_c, out_d1, out_d2):
    """Position, first and second arc-length derivative of the centreline at ``s``.

    Parameters
    ----------
    h : float
        Table spacing (m).
    pos, tan : (m, 3) float64
        Positions (m) and unit tangents at ``s_k = k h``.
    s : float
        Arc length (m); outside [0, (m-1) h] the centreline continues straight.
    out_c, out_d1, out_d2 : (3,) float64
        Filled with c(s), c'(s), c''(s).
    """
    m = pos.shape[0]
    s_end = (m - 1) * h
    if s <= 0.0:
        for a in range(3):
            out_c[a] = pos[0, a] + s * tan[0, a]
            out_d1[a] = tan[0, a]
            out_d2[a] = 0.0
        return
    if s >= s_end:
        for a in range(3):
            out_c[a] = pos[m - 1, a] + (s - s_end) * tan[m - 1, a]
            out_d1[a] = tan[m - 1, a]
            out_d2[a] = 0.0
        return
    k = int(s / h)
    if k > m - 2:
        k = m - 2
    t = (s - k * h) / h
    t2 = t * t
    t3 = t2 * t
    h00 = 2 * t3 - 3 * t2 + 1
    h10 = t3 - 2 * t2 + t
    h01 = -2 * t3 + 3 * t2
    h11 = t3 - t2
    d00 = 6 * t2 - 6 * t
    d10 = 3 * t2 - 4 * t + 1
    d01 = -6 * t2 + 6 * t
    d11 = 3 * t2 - 2 * t
    e00 = 12 * t - 6
    e10 = 6 * t - 4
    e01 = -12 * t + 6
    e11 = 6 * t - 2
    for a in range(3):
        p0 = pos[k, a]
        p1 = pos[k + 1, a]
        m0 = tan[k, a] * h
        m1 = tan[k + 1, a] * h
        out_c[a] = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
        out_d1[a] = (d00 * p0 + d10 * m0 + d01 * p1 + d11 * m1) / h
        out_d2[a] = (e00 * p0 + e10 * m0 + e01 * p1 + e11 * m1) / (h * h)


@njit(cache=True, error_model="numpy")
def normal_at(h, nor, s, out):
    """Unit principal normal at ``s`` (linear interpolation of the table, renormalised)."""
    m = nor.shape[0]
    if s <= 0.0:
        k = 0
        t = 0.0
    elif s >= (m - 1) * h:
        k = m - 2
        t = 1.0
    else:
        k = int(s / h)
        if k > m - 2:
            k = m - 2
        t = (s - k * h) / h
    nn = 0.0
    for a in range(3):
        out[a] = (1.0 - t) * nor[k, a] + t * nor[k + 1, a]
        nn += out[a] * out[a]
    nn = np.sqrt(nn)
    if nn > 0.0:
        for a in range(3):
            out[a] /= nn


@njit(cache=True, error_model="numpy")
def normal_rate(h, nor, s, out):
    """d(nor)/ds at ``s`` from the table (piecewise-constant difference quotient; 0 outside)."""
    m = nor.shape[0]
    if s <= 0.0 or s >= (m - 1) * h:
        for a in range(3):
            out[a] = 0.0
        return
    k = int(s / h)
    if k > m - 2:
        k = m - 2
    for a in range(3):
        out[a] = (nor[k + 1, a] - nor[k, a]) / h


@njit(cache=True, error_model="numpy")
def closest_point(h, pos, tan, p, s_hint, window, work):
    """Arc length of the centreline point closest to ``p``.

    Newton iteration on ``(c(s) - p) . c'(s) = 0`` from ``s_hint``, kept inside
    ``[s_hint - window, s_hint + window]`` (``window <= 0``: global search over the table first).
    ``work`` is a (9,) scratch array; on return ``work[0:3]`` = c(s), ``work[3:6]`` = c'(s),
    ``work[6:9]`` = c''(s).

    Returns
    -------
    s : float
        Arc length of the closest point (m), exact to ~1e-12 m.
    """
    c = work[0:3]
    d1 = work[3:6]
    d2 = work[6:9]
    m = pos.shape[0]
    if window <= 0.0:
        best = 1e300
        kb = 0
        for k in range(m):
            dd = 0.0
            for a in range(3):
                dd += (pos[k, a] - p[a]) ** 2
            if dd < best:
                best = dd
                kb = k
        s = kb * h
        # the straight extensions compete too (a ring can curl back near its own entry line)
        sp = 0.0
        for a in range(3):
            sp += (p[a] - pos[0, a]) * tan[0, a]
        if sp < 0.0:
            dd = 0.0
            for a in range(3):
                dd += (p[a] - pos[0, a] - sp * tan[0, a]) ** 2
            if dd < best:
                best = dd
                s = sp
        sp = 0.0
        for a in range(3):
            sp += (p[a] - pos[m - 1, a]) * tan[m - 1, a]
        # beyond the tip only a short way (the lumen ends there; a long ray could pass near
        # other parts of a curled channel)
        if 0.0 < sp < 0.02:
            dd = 0.0
            for a in range(3):
                dd += (p[a] - pos[m - 1, a] - sp * tan[m - 1, a]) ** 2
            if dd < best:
                best = dd
                s = (m - 1) * h + sp
        lo = s - 2 * h
        hi = s + 2 * h
    else:
        s = s_hint
        lo = s_hint - window
        hi = s_hint + window
    for _ in range(30):
        curve_eval(h, pos, tan, s, c, d1, d2)
        f = 0.0
        df = 0.0
        for a in range(3):
            f += (c[a] - p[a]) * d1[a]
            df += d1[a] * d1[a] + (c[a] - p[a]) * d2[a]
        if df < 1e-3:
            df = 1e-3
        ds = -f / df
        # bounded steps (1 mm) so Newton cannot jump to a far branch
        if ds > 1e-3:
            ds = 1e-3
        elif ds < -1e-3:
            ds = -1e-3
        s_new = s + ds
        if s_new < lo:
            s_new = lo
        elif s_new > hi:
            s_new = hi
        if s_new == s:
            # the step vanished in round-off: c, c', c'' already hold the values at s (the
            # final evaluation below would recompute them bit for bit)
            return s
        done = abs(s_new - s) < 1e-13
        s = s_new
        if done:
            break
    curve_eval(h, pos, tan, s, c, d1, d2)
    return s


@njit(cache=True, error_model="numpy")
def slide_points(h, pos, tan, pts, s_hint, ds, out, s_out):
    """Move points along the centreline by ``ds`` keeping their offset (load-step predictor).

    Each point's offset from its closest centreline point is carried to the point ``ds`` further
    along, rotated by the minimal rotation that takes the old tangent to the new one.
    """
    work = np.empty(9)
    c1 = np.empty(3)
    t1 = np.empty(3)
    dd = np.empty(3)
    for i in range(pts.shape[0]):
        s = closest_point(h, pos, tan, pts[i], s_hint[i], 0.01, work)
        # scalars, not array copies: no allocation per point (same arithmetic)
        t00 = work[3]
        t01 = work[4]
        t02 = work[5]
        o0 = pts[i, 0] - work[0]
        o1 = pts[i, 1] - work[1]
        o2 = pts[i, 2] - work[2]
        curve_eval(h, pos, tan, s + ds, c1, t1, dd)
        # Rodrigues rotation taking t0 to t1
        k0 = t01 * t1[2] - t02 * t1[1]
        k1 = t02 * t1[0] - t00 * t1[2]
        k2 = t00 * t1[1] - t01 * t1[0]
        cth = t00 * t1[0] + t01 * t1[1] + t02 * t1[2]
        # v' = v cos + (k x v) + k (k.v) / (1 + cos)   with k = t0 x t1 (|k| = sin)
        kx0 = k1 * o2 - k2 * o1
        kx1 = k2 * o0 - k0 * o2
        kx2 = k0 * o1 - k1 * o0
        kv = k0 * o0 + k1 * o1 + k2 * o2
        fac = kv / (1.0 + cth) if cth > -0.99 else 0.0
        out[i, 0] = c1[0] + o0 * cth + kx0 + k0 * fac
        out[i, 1] = c1[1] + o1 * cth + kx1 + k1 * fac
        out[i, 2] = c1[2] + o2 * cth + kx2 + k2 * fac
        s_out[i] = s + ds


@njit(cache=True, error_model="numpy")
def restore_lengths(q, nd, n_nodes, link_len):
    """Free nodes put back at their link length from the proximal neighbour (in place)."""
    for j in range(n_nodes - 3, -1, -1):
        a = nd * j
        b = nd * (j + 1)
        ll = 0.0
        for c in range(3):
            ll += (q[a + c] - q[b + c]) ** 2
        f = link_len[j] / np.sqrt(ll)
        for c in range(3):
            q[a + c] = q[b + c] + (q[a + c] - q[b + c]) * f


@njit(cache=True, error_model="numpy")
def chain_on_centreline(h, pos, tan, s_nodes, nd, q):
    """Every node ``k`` at the centreline point ``s_nodes[k]`` (m), twist 0 (in place on ``q``).

    The loop :meth:`ringqa.simulation.model.Model.initial_state` ran in Python (one
    :func:`curve_eval` per node), in one call: the same evaluations, so the same positions.
    """
    c = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    for k in range(s_nodes.shape[0]):
        curve_eval(h, pos, tan, s_nodes[k], c, d1, d2)
        for a in range(3):
            q[nd * k + a] = c[a]


@njit(cache=True, error_model="numpy")
def sample_hints(h, pos, tan, q, nd, link, alpha, s_out):
    """Closest-point arc length of every contact sample of state ``q`` by a global search
    (:func:`closest_point` with no window) into ``s_out`` (m).

    The sample on link ``j`` at fraction ``a`` sits at ``(1 - a) x_j + a x_{j+1}``, computed as
    :meth:`ringqa.simulation.model.Model.set_hints` did with numpy (a product and a sum per
    coordinate, no fused multiply-add), so the hints are the same, bit for bit.
    """
    work = np.empty(9)
    p = np.empty(3)
    for i in range(link.shape[0]):
        j = link[i]
        a = alpha[i]
        for c in range(3):
            p[c] = (1 - a) * q[nd * j + c] + a * q[nd * (j + 1) + c]
        s_out[i] = closest_point(h, pos, tan, p, 0.0, -1.0, work)


@njit(cache=True, error_model="numpy")
def closest_rows(h, pos, tan, pts, s_out, d_out):
    """:meth:`ringqa.simulation.channel.ChannelTable.closest` (no hint: a global search) of
    every row of ``pts`` (n, 3) in one call: arc length ``s_out`` and distance ``d_out`` (m).

    The same arithmetic: :func:`closest_point`, the centreline point by :func:`curve_eval` and
    the distance as ``sqrt(np.dot(e, e))`` (BLAS ddot, as ``np.linalg.norm``).
    """
    work = np.empty(9)
    p = np.empty(3)
    c = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    e = np.empty(3)
    for k in range(pts.shape[0]):
        for a in range(3):
            p[a] = pts[k, a]
        s = closest_point(h, pos, tan, p, 0.0, -1.0, work)
        curve_eval(h, pos, tan, s, c, d1, d2)
        for a in range(3):
            e[a] = p[a] - c[a]
        s_out[k] = s
        d_out[k] = np.sqrt(np.dot(e, e))
