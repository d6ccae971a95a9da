"""Newton's method on the assembled residual: a banded exact Jacobian, a trust region and a
backtracking line search, with a chain update that keeps the links' lengths to first order."""

from __future__ import annotations

import math
import types

import numpy as np
from numba import njit

from ringqa.simulation.band import band_solve
from ringqa.simulation.solvers.assemble import assemble

#: Newton's return codes
CONVERGED, ITERATION_LIMIT, SINGULAR, NOT_FINITE, STALLED, NO_PROGRESS = 0, 1, 2, 3, 4, 5
#: what each return code means (for messages)
STATUS_TEXT = {
    CONVERGED: "converged",
    ITERATION_LIMIT: "iteration limit",
    SINGULAR: "singular Jacobian",
    NOT_FINITE: "non-finite residual",
    STALLED: "stalled (line search cut twice below 1/32)",
    NO_PROGRESS: "no progress (residual not halved in 20 iterations)",
}
#: indices of the work counters :func:`newton` adds to
N_RESIDUALS, N_JACOBIANS, N_SOLVES, N_HALVINGS = 0, 1, 2, 3


@njit(cache=True, error_model="numpy")
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


@njit(cache=True, error_model="numpy")
def newton(effects, q, st, sw, n_free, tol_abs, max_iter, max_step, r, B, energies, counters):
    """Solve ``r(q) = 0`` for the first ``n_free`` entries of ``q`` (the rest are prescribed).

    Newton with the exact banded Jacobian, every step limited to ``max_step`` (m) per coordinate
    (a trust region that stops a step from crossing the lumen) and a backtracking line search on
    ``|r|^2`` (Armijo, halving up to 8 times). Converged when ``max |r_free| <= tol_abs``.

    Parameters
    ----------
    effects : tuple
        The effects' kernel args (:func:`~ringqa.simulation.solvers.assemble.assemble`).
    q : (n_all,) float64
        Start state, solved in place (m; twist in rad).
    st : Step
        Layout and history of the step.
    sw : Samples
        Contact samples (hints and results updated in place).
    n_free : int
        Number of unknowns (``nd`` x the free nodes; the driven nodes come last).
    tol_abs : float
        Convergence threshold on ``max |r_free|`` (N).
    max_iter : int
        Iteration limit.
    max_step : float
        Largest change of a coordinate per Newton step (m).
    r, B : arrays
        Work arrays: residual (n_all,) and banded Jacobian.
    energies : (len(effects),) float64
        Output: each effect's energy or step work at the returned ``q`` (J).
    counters : (4,) int64
        Added to: residual assemblies, Jacobian builds, linear solves, line-search halvings.

    Returns
    -------
    status : int
        :data:`CONVERGED` (0), :data:`ITERATION_LIMIT` (1), :data:`SINGULAR` (2),
        :data:`NOT_FINITE` (3), :data:`STALLED` (4: the line search cut two consecutive steps
        below 1/32), :data:`NO_PROGRESS` (5: the residual has not halved in 20 iterations).
    iters : int
        Newton iterations used.
    res : float
        Final ``max |r_free|`` (N).

    On return ``r``, ``energies`` and ``sw`` hold the values at the returned ``q``.
    """
    nd = st.nd
    n_nodes = st.n_nodes
    kl = st.kl
    n_all = q.shape[0]
    # runtime booleans: literal True/False would compile the assembler twice
    yes = max_iter >= 0
    no = not yes
    rhs = np.zeros(n_all)
    q0 = np.empty(n_all)
    r_try = np.empty(n_all)
    r_scratch = np.empty(n_all)
    e_scratch = np.empty(energies.shape[0])
    status = 1
    it = 0
    n_small = 0
    best = np.inf
    it_best = 0
    fresh = False  # r already holds the residual at q (from the accepted line-search trial)
    need_jac = False  # ... but B not yet the Jacobian there (built only if Newton goes on)
    res_prev = np.inf
    for it in range(max_iter + 1):
        if not fresh:
            assemble(effects, q, st, sw, r, B, yes, yes, energies)
            counters[0] += 1
            counters[1] += 1
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
            assemble(effects, q, st, sw, r_scratch, B, yes, no, e_scratch)
            counters[1] += 1
            need_jac = False
        for i in range(n_free):
            rhs[i] = -r[i]
        counters[2] += 1
        if not band_solve(B, kl, rhs, n_free):
            return 2, it, res
        mx = 0.0
        for i in range(n_free):
            a = abs(rhs[i])
            if a > mx:
                mx = a
        if not math.isfinite(mx):
            return 2, it, res
        # negative curvature: r = grad E, so the Newton step d = -J^-1 r goes uphill in energy
        # (r.d > 0) only where J is indefinite along r, i.e. past a buckling load (the straight
        # free cable pushed past Euler's load sits on a saddle that Newton on |r| is drawn to
        # and stalls at). Step the other way, downhill along the unstable mode (trust-region
        # sized, accepted without the |r|^2 line search, which a step off a saddle must raise),
        # so the cable buckles onto the wall and Newton converges to the stable equilibrium.
        # Only for a step the trust region clips (a near-singular mode dominates it: the
        # saddle's signature; flipping every uphill step sent converging steps astray: the 34 mm
        # rings got 8-13 fallback steps). Not with torsion: its friction Jacobian is approximate
        # (5 %), so the sign test is not.
        uphill = 0.0
        for i in range(n_free):
            uphill += rhs[i] * r[i]
        scale = 1.0
        if mx > max_step:
            scale = max_step / mx
        flip = uphill > 0.0 and nd == 3 and scale < 1.0
        if flip:
            for i in range(n_free):
                rhs[i] = -rhs[i]
        for i in range(q.shape[0]):  # element copies: an array slice assignment compiles
            q0[i] = q[i]  # numba's shape-mismatch error formatting (~3 s of cold start)
        lam = scale
        # the first trial builds the Jacobian with its residual (one pass over the effects
        # instead of two) unless Newton is expected to converge there: superlinear
        # convergence predicts the next residual res^2 / res_prev; the same values either way
        fuse = not (res * res <= tol_abs * res_prev)
        res_prev = res
        trial_jac = False
        for _ls in range(9):
            update_chain(q0, rhs, lam, nd, n_nodes, n_free, q)
            trial_jac = fuse and _ls == 0
            assemble(effects, q, st, sw, r_try, B, trial_jac, yes, energies)
            counters[0] += 1
            if trial_jac:
                counters[1] += 1
            merit = 0.0
            for i in range(n_free):
                merit += r_try[i] * r_try[i]
            if math.isfinite(merit) and (flip or merit <= (1.0 - 1e-4 * lam) * merit0):
                break
            lam *= 0.5
            counters[3] += 1
        # the last trial's residual is that of the new q: reuse it (its Jacobian is built at
        # the top of the next iteration if Newton goes on: not after the converging step)
        for i in range(r.shape[0]):
            r[i] = r_try[i]
        fresh = True
        need_jac = not trial_jac  # B is the Jacobian at q if the accepted trial built it
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
    assemble(effects, q, st, sw, r, B, no, yes, energies)
    counters[0] += 1
    res = 0.0
    for i in range(n_free):
        if abs(r[i]) > res:
            res = abs(r[i])
    return status, it, res


def _uncached_twin(dispatcher, **rebind):
    """The same function compiled without the disk cache, its globals ``rebind`` replaced."""
    f = dispatcher.py_func
    g = dict(f.__globals__)
    g.update(rebind)
    twin = types.FunctionType(f.__code__, g, f.__name__, f.__defaults__, f.__closure__)
    twin.__doc__ = f.__doc__
    return njit(twin)


#: the assembler and Newton for models with effects defined outside ringqa (not disk-cached:
#: :func:`ringqa.simulation.effects.base.is_cacheable`)
assemble_uncached = _uncached_twin(assemble)
newton_uncached = _uncached_twin(newton, assemble=assemble_uncached)
