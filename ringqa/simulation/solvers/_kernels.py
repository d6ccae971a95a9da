"""Numba kernels of the solvers: assemble the switched-on effects, Newton with line search.

The kernels take the model's arrays in five groups (plain tuples, built once by
:class:`ringqa.simulation.solvers.driver.Model` and holding its live arrays: numba passes a tuple
of arrays as cheaply as the arrays themselves) and unpack each with one line at the top:

``links`` (the discretised chain)
    ``(nd, n_nodes, kl, link_len, hinge_k, twist_k, node_mass, node_rot)``: DOFs per node (3, or
    4 with torsion: x, y, z (m), twist (rad)), node count N + 1, half-bandwidth of the banded
    Jacobian (``3 nd - 1``), link lengths (N,) (m, tip first), hinge stiffnesses at the interior
    nodes (N-1,) (N m/rad), twist stiffness per link (N,) (N m/rad), lumped node masses (N+1,)
    (kg) and polar inertias (N+1,) (kg m^2).
``chan`` (the channel table, :class:`~ringqa.simulation.channel.ChannelTable`)
    ``(h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb, seg_ra, seg_flat)``: the arc-length
    spacing (m); centreline positions (m, 3) (m), unit tangents and unit normals (m, 3) at
    ``s = k h``; the curvature (1/m) below which a flat side fades out
    (:data:`~ringqa.simulation.channel.KAPPA_MIN_FLAT`); the lumen segments' breaks (k+1,) (m),
    wall radii r_b (k,) (m), transition radii r_a (k,) (m) and flat-side distances (k,) (m, +inf:
    circular).
``samples`` (the contact sample points along the links; P of them)
    ``(samp_link, samp_alpha, samp_ro, samp_wt, samp_s, samp_d_prev)``: the link of each sample
    (P,) int64, its fraction along the link (P,) (0 at node ``link``), the outer radius there (P,)
    (m), its wall-stiffness weight (P,) (1: the scene's k and c_w), its closest centreline arc
    length (P,) (m; the closest-point hint, updated in place) and its wall distance at the start
    of the step (P,) (m; wall damping).
``swork`` (per-sample results of the last assemble, written in place)
    ``(samp_p, samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF)``: sample positions
    (P, 3) (m), effective centre distances d (P,) (m), wall normals grad d (P, 3) (unit), Hessians
    of d (P, 3, 3) (1/m), contact depths z = (d - a) / w (P,) (-), transition widths w (P,) (m),
    normal forces (P,) (N) and their derivatives dF/dd (P,) (N/m).
``par`` (switches and parameters)
    ``(cpar, flags, g)``: ``cpar`` (float64 (11,)): [k_wall (N/m), transition (m; <= 0: from
    the lumen), transition_max_fraction, c_w (N s/m), mu_s, mu_k, v_brk (m/s), v_reg (m/s),
    stabilisation (N s/m), k_axial (N), slip_min (m)]; ``flags`` (int64 (7,)): [contact,
    friction_law (0 none, 1 coulomb, 2 stribeck), wall_damping, inertia, gravity, torsion,
    stabilisation] (an effect whose flag is 0 is not called at all); ``g`` (3,) gravity (m/s^2).

``q_ref``: the predicted state the stabilisation's viscosity acts against.
``energies`` (float64 (8,)): axial, bending, torsion, contact, gravity potential, friction work of
the step, damping work of the step, kinetic (not filled here).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ringqa.simulation._kernels import band_solve, curve_eval, restore_lengths, slide_points
from ringqa.simulation.effects._kernels import (
    add_axial,
    add_bending,
    add_friction,
    add_gravity,
    add_inertia,
    add_torsion,
    add_viscous,
    add_wall_damping,
    apply_normal,
    clamp_normal,
    contact_geometry,
    friction_phi,
    twist_slip_direction,
)


@njit(cache=True)
def assemble(q, q_prev, v_prev, q_ref, links, chan, samples, swork, par, dt, r, B, jac, energies):
    """Residual ``r`` (and banded Jacobian ``B`` when ``jac``) of the switched-on effects.

    Parameters
    ----------
    q, q_prev, v_prev, q_ref : (n_all,) float
        State, state at the start of the step, velocity there (m/s; twist rad/s), stabilisation
        reference (m; twist in rad).
    links, chan, samples, swork, par : tuple
        The model's groups (module docstring); ``samples``' closest-point hints and ``swork`` are
        updated in place.
    dt : float
        Time step (s).
    r : (n_all,) float
        Output: residual (N; twist N m).
    B : (n_all, 3 kl + 1) float
        Output: banded Jacobian (when ``jac``).
    jac : bool
        Build ``B`` too.
    energies : (8,) float
        Output: the energies and the step's work (J; module docstring).
    """
    nd, n_nodes, kl, link_len, hinge_k, twist_k, node_mass, node_rot = links
    h, pos, tan, nor, kappa_min_flat, seg_s, seg_rb, seg_ra, seg_flat = chan
    samp_link, samp_alpha, samp_ro, samp_wt, samp_s, samp_d_prev = samples
    samp_p, samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF = swork
    cpar, flags, g = par
    r[:] = 0.0
    if jac:
        B[:, :] = 0.0
    energies[:] = 0.0
    energies[0] = add_axial(q, nd, n_nodes, link_len, cpar[9], r, B, kl, jac)
    energies[1] = add_bending(q, nd, n_nodes, hinge_k, r, B, kl, jac)
    if flags[5]:
        energies[2] = add_torsion(q, nd, n_nodes, twist_k, r, B, kl, jac)
    if flags[0]:
        energies[3] = contact_geometry(
            q, nd, samp_link, samp_alpha, samp_ro, samp_wt, h, pos, tan, nor, kappa_min_flat,
            seg_s, seg_rb, seg_ra, seg_flat, cpar[1], cpar[2], cpar[0],
            samp_s, samp_p, samp_d, samp_n, samp_H, samp_z, samp_w, samp_F, samp_dF,
        )  # fmt: skip
        if flags[2]:
            energies[6] = add_wall_damping(
                samp_d, samp_d_prev, samp_z, samp_w, samp_wt, cpar[3], dt, samp_F, samp_dF
            )
            clamp_normal(samp_F, samp_dF)
        apply_normal(nd, samp_link, samp_alpha, samp_n, samp_H, samp_F, samp_dF, r, B, kl, jac)
        if flags[1]:
            v_reg = max(cpar[7], cpar[10] / dt)
            energies[5] = add_friction(
                q, q_prev, nd, samp_link, samp_alpha, samp_ro, samp_p, samp_n, samp_H, samp_F,
                samp_dF,
                flags[1], cpar[4], cpar[5], cpar[6], v_reg, dt, flags[5] != 0, r, B, kl, jac,
            )  # fmt: skip
    if flags[4]:
        energies[4] = add_gravity(q, nd, n_nodes, node_mass, g, r)
    if flags[3]:
        add_inertia(q, q_prev, v_prev, nd, n_nodes, node_mass, node_rot, dt, r, B, kl, jac)
    if flags[6]:
        add_viscous(q, q_ref, nd, n_nodes, cpar[8], dt, r, B, kl, jac)


@njit(cache=True)
def assemble_jacobian(q, q_prev, v_prev, q_ref, links, samples, swork, par, dt, r_scratch, B):
    """The banded Jacobian ``B`` at ``q`` after :func:`assemble` ran there without it.

    Uses the contact samples that assemble left (closest points, normals, forces including
    wall damping); adds the same terms in the same order as ``assemble(..., jac=True)``, so
    ``B`` is bit-identical to it. The effects' residual contributions go to ``r_scratch``
    (discarded). Lets the line search evaluate trial points without the Jacobian and build it
    only where Newton continues. Arguments as for :func:`assemble` (no channel needed).
    """
    nd, n_nodes, kl, link_len, hinge_k, twist_k, node_mass, node_rot = links
    samp_link, samp_alpha, samp_ro, _samp_wt, _samp_s, _samp_d_prev = samples
    samp_p, _samp_d, samp_n, samp_H, _samp_z, _samp_w, samp_F, samp_dF = swork
    cpar, flags, _g = par
    B[:, :] = 0.0
    add_axial(q, nd, n_nodes, link_len, cpar[9], r_scratch, B, kl, True)
    add_bending(q, nd, n_nodes, hinge_k, r_scratch, B, kl, True)
    if flags[5]:
        add_torsion(q, nd, n_nodes, twist_k, r_scratch, B, kl, True)
    if flags[0]:
        apply_normal(
            nd, samp_link, samp_alpha, samp_n, samp_H, samp_F, samp_dF, r_scratch, B, kl, True
        )
        if flags[1]:
            v_reg = max(cpar[7], cpar[10] / dt)
            add_friction(
                q, q_prev, nd, samp_link, samp_alpha, samp_ro, samp_p, samp_n, samp_H, samp_F,
                samp_dF,
                flags[1], cpar[4], cpar[5], cpar[6], v_reg, dt, flags[5] != 0, r_scratch, B, kl,
                True,
            )  # fmt: skip
    if flags[3]:
        add_inertia(q, q_prev, v_prev, nd, n_nodes, node_mass, node_rot, dt, r_scratch, B, kl, True)
    if flags[6]:
        add_viscous(q, q_ref, nd, n_nodes, cpar[8], dt, r_scratch, B, kl, True)


@njit(cache=True)
def update_chain(q0, dq, lam, nd, n_nodes, n_free, q):
    """``q = q0 + lam dq`` with every link's length following its LINEARISED change.

    A straight-line update rotates a link through an angle beta and so stretches it by
    ~ l beta^2 / 2; with the stiff inextensibility penalty that second-order stretch carries
    forces far larger than the cable's bending forces, and the line search then crawls. Walking
    from the driven end to the tip, each free node is put at distance ``|e| + lam e^.de`` from its
    proximal neighbour in the direction of the straight-line update: first order it is the
    Newton step, so Newton's convergence is kept (a "second-order correction" step).
    """
    for i in range(n_free):
        q[i] = q0[i] + lam * dq[i]
    for j in range(n_nodes - 3, -1, -1):
        a = nd * j
        b = nd * (j + 1)
        L0 = 0.0
        lin = 0.0
        for c in range(3):
            e = q0[a + c] - q0[b + c]
            L0 += e * e
        L0 = math.sqrt(L0)
        for c in range(3):
            e = q0[a + c] - q0[b + c]
            db = lam * dq[b + c] if b + c < n_free else q[b + c] - q0[b + c]
            lin += e / L0 * (lam * dq[a + c] - db)
        Lt = L0 + lin
        Ln = 0.0
        for c in range(3):
            e = q[a + c] - q[b + c]
            Ln += e * e
        Ln = math.sqrt(Ln)
        for c in range(3):
            q[a + c] = q[b + c] + (q[a + c] - q[b + c]) * (Lt / Ln)


@njit(cache=True)
def newton(
    q,
    n_free,
    q_prev,
    v_prev,
    q_ref,
    links,
    chan,
    samples,
    swork,
    par,
    dt,
    tol_abs,
    max_iter,
    max_step,
    r,
    B,
    energies,
):
    """Solve ``r(q) = 0`` for the first ``n_free`` entries of ``q`` (the rest are prescribed).

    Newton with the exact banded Jacobian, every step limited to ``max_step`` (m) per coordinate
    (a trust region that stops a step from crossing the lumen) and a backtracking line search on
    ``|r|^2`` (Armijo, halving up to 8 times). Converged when ``max |r_free| <= tol_abs``.

    Parameters
    ----------
    q : (n_all,) float
        Start state, solved in place (m; twist in rad).
    n_free : int
        Number of unknowns (``nd`` x the free nodes; the driven nodes come last).
    q_prev, v_prev, q_ref, dt : see :func:`assemble`.
    links, chan, samples, swork, par : tuple
        The model's groups (module docstring).
    tol_abs : float
        Convergence threshold on ``max |r_free|`` (N).
    max_iter : int
        Iteration limit.
    max_step : float
        Largest change of a coordinate per Newton step (m).
    r, B, energies : arrays
        Work and output arrays as for :func:`assemble`.

    Returns
    -------
    status : int
        0 converged, 1 iteration limit, 2 singular Jacobian, 3 non-finite residual, 4 stalled
        (the line search cut two consecutive steps below 1/32), 5 no progress (the residual has
        not halved in 20 iterations).
    iters : int
        Newton iterations used.
    res : float
        Final ``max |r_free|`` (N).

    On return ``r``, ``energies`` and ``swork`` hold the values at the returned ``q``.
    """
    nd, n_nodes, kl, _link_len, _hinge_k, _twist_k, _node_mass, _node_rot = links
    n_all = q.shape[0]
    rhs = np.zeros(n_all)
    q0 = np.empty(n_all)
    r_try = np.empty(n_all)
    status = 1
    it = 0
    n_small = 0
    best = np.inf
    it_best = 0
    r_scratch = np.empty(n_all)
    fresh = False  # r already holds the residual at q (from the accepted line-search trial)
    need_jac = False  # ... but B not yet the Jacobian there (built only if Newton goes on)
    for it in range(max_iter + 1):
        if not fresh:
            assemble(
                q, q_prev, v_prev, q_ref, links, chan, samples, swork, par, dt, r, B, True, energies
            )
        fresh = False
        res = 0.0
        merit0 = 0.0
        for i in range(n_free):
            a = abs(r[i])
            merit0 += r[i] * r[i]
            if a > res:
                res = a
        if not math.isfinite(merit0):
            return 3, it, res
        if res <= tol_abs:
            return 0, it, res
        if it == max_iter:
            break
        if res < 0.5 * best:
            best = res
            it_best = it
        elif it - it_best >= 20:
            status = 5  # no progress: the residual has not halved in 20 iterations
            break
        if need_jac:
            assemble_jacobian(
                q, q_prev, v_prev, q_ref, links, samples, swork, par, dt, r_scratch, B
            )
            need_jac = False
        for i in range(n_free):
            rhs[i] = -r[i]
        if not band_solve(B, kl, rhs, n_free):
            return 2, it, res
        mx = 0.0
        for i in range(n_free):
            a = abs(rhs[i])
            if a > mx:
                mx = a
        if not math.isfinite(mx):
            return 2, it, res
        scale = 1.0
        if mx > max_step:
            scale = max_step / mx
        q0[:] = q
        lam = scale
        for _ls in range(9):
            update_chain(q0, rhs, lam, nd, n_nodes, n_free, q)
            assemble(
                q,
                q_prev,
                v_prev,
                q_ref,
                links,
                chan,
                samples,
                swork,
                par,
                dt,
                r_try,
                B,
                False,
                energies,
            )
            merit = 0.0
            for i in range(n_free):
                merit += r_try[i] * r_try[i]
            if math.isfinite(merit) and merit <= (1.0 - 1e-4 * lam) * merit0:
                break
            lam *= 0.5
        # the last trial's residual is that of the new q: reuse it (its Jacobian is built at
        # the top of the next iteration if Newton goes on: not after the converging step)
        r[:] = r_try
        fresh = True
        need_jac = True
        if mx * lam < 1e-15:
            # stagnation at round-off
            status = 1
            break
        # stalled: the line search keeps cutting the step hard (limit point, snap-through):
        # give up early so the driver can cut the step or stabilise
        if lam < scale / 32.0:
            n_small += 1
            if n_small >= 2:
                status = 4
                break
        else:
            n_small = 0
    assemble(q, q_prev, v_prev, q_ref, links, chan, samples, swork, par, dt, r, B, False, energies)
    res = 0.0
    for i in range(n_free):
        if abs(r[i]) > res:
            res = abs(r[i])
    return status, it, res


@njit(cache=True)
def predict(q, slide, du, u_new, links, chan, samples, cum, cft, node_sample):
    """Load-step predictor in place on ``q`` (one call instead of four from Python).

    With ``slide`` every free node is slid ``du`` along the channel keeping its offset
    (``slide_points``; node hints from the samples at the nodes, ``samp_s`` advanced by ``du``);
    then the two driven proximal nodes are put on the approach axis for input advance ``u_new``
    (twist 0) and the free nodes' link lengths are restored. The same arithmetic as the driver's
    ``Model.slide``, ``Model.prescribe`` and ``Model.restore_lengths``.

    Parameters
    ----------
    q : (n_all,) float
        State, changed in place (m; twist in rad).
    slide : bool
        Slide the free nodes along the channel first.
    du, u_new : float
        Advance of this step and the input advance at its end (m).
    links, chan, samples : tuple
        The model's groups (module docstring); ``samp_s`` is advanced by ``du`` in place.
    cum : (N+1,) float
        Arc length of each node from the tip along the undeformed cable (m).
    cft : float
        Source centre's distance behind the tip (m).
    node_sample : (N,) int64
        The sample that sits on each node 0..N-1 (alpha = 0).
    """
    nd, n_nodes, _kl, link_len, _hinge_k, _twist_k, _node_mass, _node_rot = links
    h, pos, tan, _nor, _kappa_min_flat, _seg_s, _seg_rb, _seg_ra, _seg_flat = chan
    _samp_link, _samp_alpha, _samp_ro, _samp_wt, samp_s, _samp_d_prev = samples
    if slide:
        x = np.empty((n_nodes, 3))
        for k in range(n_nodes):
            for a in range(3):
                x[k, a] = q[nd * k + a]
        hints = np.empty(n_nodes)
        for k in range(n_nodes - 1):
            hints[k] = samp_s[node_sample[k]]
        hints[n_nodes - 1] = hints[n_nodes - 2] - link_len[n_nodes - 2]
        out = np.empty((n_nodes, 3))
        s_out = np.empty(n_nodes)
        slide_points(h, pos, tan, x, hints, du, out, s_out)
        for k in range(n_nodes - 2):
            for a in range(3):
                q[nd * k + a] = out[k, a]
        for i in range(samp_s.shape[0]):
            samp_s[i] += du
    c = np.empty(3)
    d1 = np.empty(3)
    d2 = np.empty(3)
    for k in range(n_nodes - 2, n_nodes):
        curve_eval(h, pos, tan, u_new + cft - cum[k], c, d1, d2)
        for a in range(3):
            q[nd * k + a] = c[a]
        if nd == 4:
            q[nd * k + 3] = 0.0
    restore_lengths(q, nd, n_nodes, link_len)


@njit(cache=True)
def lump_to_nodes(samp_link, samp_alpha, samp_F, out):
    """Add each sample's force to its link's nodes by fraction (in place on ``out``).

    The same order and arithmetic as ``np.add.at(out, link, (1 - alpha) F)`` followed by
    ``np.add.at(out, link + 1, alpha F)``.
    """
    for i in range(samp_link.shape[0]):
        out[samp_link[i]] += (1 - samp_alpha[i]) * samp_F[i]
    for i in range(samp_link.shape[0]):
        out[samp_link[i] + 1] += samp_alpha[i] * samp_F[i]


@njit(cache=True)
def max_penetration(samp_z, samp_w):
    """``max((z - 1) w, initial=0)`` over the samples (m): the deepest sink into the wall.

    A NaN propagates as in ``np.max``.
    """
    m = 0.0
    for i in range(samp_z.shape[0]):
        v = (samp_z[i] - 1.0) * samp_w[i]
        if v > m or v != v:
            m = v
            if v != v:
                break
    return m


@njit(cache=True)
def combine(a, x, b, y, out):
    """``out = a x - b y`` elementwise (BDF2's history combinations; one call, no temporaries)."""
    for i in range(x.shape[0]):
        out[i] = a * x[i] - b * y[i]


@njit(cache=True)
def step_work(q, q_n, q_h, links, samples, swork, d_n, d_h, par, dt_eff, out):
    """Friction and wall-damping work (J) of a step solved against a modified history.

    A BDF2 step runs the Newton kernel with ``q_prev = q_h`` (the history combination) and
    ``dt = dt_eff``: its forces are right, but the work the kernel's ``energies`` report is
    force times ``q - q_h`` (the velocity times ``dt_eff``), not times the step's displacement.
    This recomputes the same forces at the converged state (friction velocity
    ``(p - p_h) / dt_eff``, wall-damping velocity ``(d - d_h) / dt_eff``, the normal force
    ``samp_F`` the kernel left, after damping and the clamp) and takes their work over the actual
    displacement ``q - q_n`` (sample points, twist) and distance change ``d - d_n``, as backward
    Euler does. With ``q_h = q_n``, ``d_h = d_n`` the result equals the kernel's ``energies[5]``
    and ``energies[6]``.

    Parameters
    ----------
    q, q_n, q_h : (n_all,) float
        Converged state, state at the start of the step, history state (m; twist in rad).
    links, samples : tuple
        The model's groups (module docstring).
    swork : tuple
        The sample results as the Newton kernel left them at ``q`` (normals, forces (N),
        distances (m), z, widths (m)).
    d_n, d_h : (P,) float
        Sample distances at the start of the step and their history combination (m).
    par : tuple
        ``(cpar, flags, g)`` (``cpar[10]`` as used in the solve).
    dt_eff : float
        The time step the kernel was called with (s).
    out : (2,) float
        Output: friction work, damping work (J).
    """
    nd = links[0]
    samp_link, samp_alpha, samp_ro, samp_wt, _samp_s, _samp_d_prev = samples
    _samp_p, samp_d, samp_n, _samp_H, samp_z, _samp_w, samp_F, _samp_dF = swork
    cpar, flags, _g = par
    out[0] = 0.0
    out[1] = 0.0
    law = flags[1]
    torsion = flags[5] != 0
    if flags[0] == 0:
        return
    if flags[2]:
        c_w = cpar[3]
        for i in range(samp_d.shape[0]):
            z = samp_z[i]
            if z <= 0.0:
                continue
            vn = (samp_d[i] - d_h[i]) / dt_eff
            sh = (3.0 - 2.0 * z) * z * z if z <= 1.0 else 1.0
            out[1] += c_w * samp_wt[i] * sh * vn * (samp_d[i] - d_n[i])
    if law == 0:
        return
    v_reg = max(cpar[7], cpar[10] / dt_eff)
    wv = np.empty(3)
    dp = np.empty(3)
    tau = np.zeros(3)
    for i in range(samp_link.shape[0]):
        F = samp_F[i]
        if F == 0.0:
            continue
        j = samp_link[i]
        w0 = 1.0 - samp_alpha[i]
        w1 = samp_alpha[i]
        n = samp_n[i]
        wn = 0.0
        for a in range(3):
            p = w0 * q[nd * j + a] + w1 * q[nd * (j + 1) + a]
            wv[a] = p - (w0 * q_h[nd * j + a] + w1 * q_h[nd * (j + 1) + a])
            dp[a] = p - (w0 * q_n[nd * j + a] + w1 * q_n[nd * (j + 1) + a])
            wn += wv[a] * n[a]
        for a in range(3):
            wv[a] -= wn * n[a]
        if torsion:
            ro = samp_ro[i]
            twist_slip_direction(q, nd, j, n, tau)
            dphi_h = w0 * (q[nd * j + 3] - q_h[nd * j + 3]) + w1 * (
                q[nd * (j + 1) + 3] - q_h[nd * (j + 1) + 3]
            )
            dphi_n = w0 * (q[nd * j + 3] - q_n[nd * j + 3]) + w1 * (
                q[nd * (j + 1) + 3] - q_n[nd * (j + 1) + 3]
            )
            for a in range(3):
                wv[a] += ro * dphi_h * tau[a]
                dp[a] += ro * dphi_n * tau[a]
        vm = 0.0
        for a in range(3):
            vm += (wv[a] / dt_eff) ** 2
        vm = math.sqrt(vm)
        phi, _psi = friction_phi(vm, law, cpar[4], cpar[5], cpar[6], v_reg)
        for a in range(3):
            # F_t = -F phi v ; its work on the actual displacement, counted positive
            out[0] += F * phi * (wv[a] / dt_eff) * dp[a]
