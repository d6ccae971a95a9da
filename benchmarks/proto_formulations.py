"""Prototype (issue 29, branch lagrange): other Newton formulations replayed on captured load steps.

    .venv/bin/python benchmarks/proto_formulations.py [SCENE] [--variants base,mixed,...]

A quasi-static run of SCENE (default ring26-flexitron) is captured as in
``benchmarks/bench_kernels.py`` (the start state of every Newton solve). Every captured step is
then solved from that same start by a Python Newton (the compiled assembler and LU; iteration
counts, not times, are the result) in each of these formulations:

- ``base``: a replica of :func:`ringqa.simulation.solvers.newton.newton` (checked against it:
  the same iterations on every step);
- ``mixed``: the contact force of every sample in contact carried as its own unknown ``lam``
  (a mixed, force-displacement formulation, condensed sample by sample): the sample's consistency
  ``d - G(lam) = 0`` (``G`` the inverse wall law) is linearised in ``lam``, so the assembled force
  is ``lam + k_t (d - G(lam))`` with stiffness ``k_t = 1 / G'(lam)``, and after a step
  ``lam <- lam + k_t (d + n.dp - G(lam))``. The converged state is the primal one (there
  ``d = G(lam)``); convergence is judged on the primal residual;
- ``kkt``: the links' lengths as exact constraints ``|e_j| - l_j = 0`` with multipliers (no axial
  penalty), the KKT system ``[H + sum mu_j C_j, A^T; A, 0]`` solved dense, the multipliers
  started by least squares, the same chain update (which keeps the linearised length, so a full
  step lands every link on its length) and trust region; converged at ``max|r + A^T mu| <=
  tol_abs`` (the lengths are exact to round-off by construction);
- ``...-chord``: the same with the factors of the last Jacobian reused while a chord step cuts
  ``max|r|`` by ``--chord-rate`` (default :data:`CHORD_RATE`) at a full step; a chord step that
  fails Armijo at the full step is dropped and a fresh Jacobian is built at the same point;
- ``mixed-...-ext``: a sample with a positive carried force keeps the linearised law (its force
  may then be negative: an active-set guess) while the iterate has it outside the wall, with
  its normal and distance Hessian computed here (circular lumens only);
- ``...-warm``: ``mixed``'s forces started from the previous step's converged contact forces
  (instead of ``F(d)`` at the prediction), ``kkt``'s multipliers from the previous step's
  converged penalty tensions ``k (|e| - l)`` (instead of least squares);
- ``...-oracle``: the same from THIS step's converged forces / tensions: not a method, a bound on
  what any treatment of the force unknowns can give.

Variants combine by name (``kkt-mixed-warm-chord``). Printed per variant: Newton iterations,
Jacobians (factorisations), residual assemblies and line-search halvings over all steps,
failures, the largest coordinate difference of the converged state from the compiled Newton's
(m), the iterations by the residual they started from, the steps whose contact set changed
between the start and the solution, and an estimated solve time: the counts times the per-call
costs :data:`COST_US` (measured with ``benchmarks/bench_kernels.py`` and ``--time-lu``, which
times the banded LU of the penalty Jacobian and of the node-interleaved KKT matrix).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as sla

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_kernels import _copy_nt, best_us, capture  # noqa: E402

from ringqa.simulation._kernels import closest_point  # noqa: E402
from ringqa.simulation.band import band_solve  # noqa: E402
from ringqa.simulation.effects.axial import AxialArgs  # noqa: E402
from ringqa.simulation.effects.contact import ContactArgs  # noqa: E402
from ringqa.simulation.solvers.assemble import assemble  # noqa: E402
from ringqa.simulation.solvers.newton import newton, update_chain  # noqa: E402

#: a chord step is kept while it cuts max|r| at least this much at a full step
CHORD_RATE = 0.5
#: per-call costs (us) for the estimate, measured with ``benchmarks/bench_kernels.py --every 12``
#: and :func:`time_kkt_lu` on ring26-flexitron (branch lagrange, 2026-11-29, load ~3): Jacobian
#: only, banded LU (penalty: 123 unknowns, kl 8; KKT: 164 node-interleaved unknowns, kl 10),
#: residual only + chain update, a substitution with stored factors (estimated: ~1/4 of the LU),
#: the mixed formulation's per-sample bookkeeping per assembly, and a load step's fixed cost
#: (predictor 7.7 + the loop's own work 4.9)
COST_US = {"jac": 8.06, "lu": 9.65, "lu_kkt": 17.4, "res": 6.12 + 0.7, "sub": 2.5,
           "sub_kkt": 4.4, "mixed": 0.3, "step": 12.6}  # fmt: skip


def estimate_us(v, n_steps, n_jac, n_chord, n_res):
    """Estimated solve time (us) of a variant's counts with :data:`COST_US`."""
    c = COST_US
    kkt = "kkt" in v
    t = n_jac * (c["jac"] + (c["lu_kkt"] if kkt else c["lu"]))
    t += n_chord * (c["sub_kkt"] if kkt else c["sub"])
    t += n_res * (c["res"] + (c["mixed"] if "mixed" in v else 0.0))
    return t + n_steps * c["step"]


def dense(B, kl, n):
    """The leading n x n block of the band storage as a dense matrix."""
    A = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + kl + 1)):
            A[i, j] = B[i, kl + j - i]
    return A


class Problem:
    """One captured step and the machinery to assemble it in each formulation."""

    def __init__(self, model, state, kkt: bool):
        effects, q0, st, sw0 = state
        self.st = st
        self.sw0 = sw0
        self.q0 = q0
        self.nd = st.nd
        self.n_nodes = st.n_nodes
        self.kl = st.kl
        self.n_free = model.n_free
        self.tol = model.tol_abs
        self.max_iter = model.max_iter
        self.max_step = model.max_step
        self.kkt = kkt
        eff = list(effects)
        self.k_contact = None
        for k, p in enumerate(eff):
            if isinstance(p, AxialArgs):
                self.link_len = p.link_len
                self.ea = p.ea_n
                if kkt:
                    eff[k] = AxialArgs(p.link_len, 0.0)
            if isinstance(p, ContactArgs):
                self.k_contact = p
        self.effects = tuple(eff)
        n_all = q0.shape[0]
        self.r = np.zeros(n_all)
        self.B = np.zeros_like(model.B)
        self.en = np.zeros_like(model.energies)
        # constrained links: those with a free node (the driven nodes' link is prescribed)
        self.n_free_nodes = self.n_free // self.nd
        self.links = list(range(min(self.n_nodes - 1, self.n_free_nodes)))
        self.extend = False
        self.circular = self.k_contact is not None and not bool(
            np.any(self.k_contact.chan.seg_flat < self.k_contact.chan.seg_rb)
        )
        self.chord_rate = CHORD_RATE
        self.chord_tries = 0
        self.chord_kept = 0

    def sw(self):
        return _copy_nt(self.sw0)

    # -- constraints -----------------------------------------------------------------------
    def cons(self, q):
        """A (m x n_free), c (m,), and the links' unit vectors and lengths."""
        nd, nf = self.nd, self.n_free
        m = len(self.links)
        A = np.zeros((m, nf))
        c = np.zeros(m)
        eh = np.zeros((m, 3))
        L = np.zeros(m)
        for k, j in enumerate(self.links):
            e = q[nd * (j + 1) : nd * (j + 1) + 3] - q[nd * j : nd * j + 3]
            L[k] = np.linalg.norm(e)
            eh[k] = e / L[k]
            c[k] = L[k] - self.link_len[j]
            for a in range(3):
                A[k, nd * j + a] = -eh[k, a]
                if nd * (j + 1) + a < nf:
                    A[k, nd * (j + 1) + a] = eh[k, a]
        return A, c, eh, L

    def cons_hess(self, q, mu, eh, L):
        """sum_j mu_j Hess(|e_j|) on the free coordinates."""
        nd, nf = self.nd, self.n_free
        Hc = np.zeros((nf, nf))
        for k, j in enumerate(self.links):
            P = (np.eye(3) - np.outer(eh[k], eh[k])) / L[k] * mu[k]
            for ia, na in ((nd * j, 1.0), (nd * (j + 1), -1.0)):
                for ib, nb in ((nd * j, 1.0), (nd * (j + 1), -1.0)):
                    if ia + 3 <= nf and ib + 3 <= nf:
                        Hc[ia : ia + 3, ib : ib + 3] += na * nb * P
        return Hc

    # -- mixed contact -----------------------------------------------------------------------
    def law_inverse(self, lam, i, sw):
        """(G(lam), k_t = 1 / G'(lam)) of sample i (its wall law at its current a, w)."""
        kw = self.k_contact.k_wall * sw.wt[i]
        w = sw.w[i]
        a = sw.d[i] - sw.z[i] * w
        if lam <= 0.5 * kw * w:
            z = math.sqrt(2.0 * lam / (kw * w))
            return a + w * z, kw * z
        return a + w * (lam / (kw * w) + 0.5), kw


def evaluate(pb, q, sw, lam, jac):
    """Residual (and Jacobian in pb.B) at q in the problem's formulation.

    Returns (r, primal max|r|): with ``lam`` (mixed) the assembled forces of the carried samples
    are the condensed ones; the primal residual is assembled too (for the convergence test)."""
    r = np.zeros_like(pb.r)
    assemble(pb.effects, q, pb.st, sw, r, pb.B, jac, True, pb.en)
    primal = r.copy()
    if lam is not None:
        changed = False
        for i in range(sw.F.shape[0]):
            if sw.F[i] > 0.0 and sw.z[i] > 0.0:
                if not lam[i] > 0.0:
                    lam[i] = sw.F[i]  # newly in contact: start from the primal force
                G, kt = pb.law_inverse(lam[i], i, sw)
                fe = lam[i] + kt * (sw.d[i] - G)
                if (fe <= 0.0 and not pb.extend) or kt <= 0.0:
                    lam[i] = sw.F[i]
                    continue
                sw.F[i] = fe
                sw.dF[i] = kt
                changed = True
            elif pb.extend and lam[i] > 0.0 and pb.circular:
                # carried force, sample outside the wall at this iterate: keep the linearised
                # law (needs its wall normal and distance Hessian, which the kernel leaves zero)
                if extend_sample(pb, q, sw, lam, i):
                    changed = True
                else:
                    lam[i] = 0.0
            else:
                lam[i] = 0.0
        if changed:
            assemble(pb.effects, q, pb.st, sw, r, pb.B, jac, False, pb.en)
    return r, primal


def extend_sample(pb, q, sw, lam, i):
    """Give sample i (outside the wall, carried force ``lam[i]``) its circular-lumen normal,
    distance Hessian (as ``contact_geometry``) and the condensed force (``-ext`` variants)."""
    ch = pb.k_contact.chan
    nd = pb.nd
    j = sw.link[i]
    al = sw.alpha[i]
    p = (1 - al) * q[nd * j : nd * j + 3] + al * q[nd * (j + 1) : nd * (j + 1) + 3]
    work = np.empty(9)
    si = closest_point(ch.h, ch.pos, ch.tan, p, sw.s[i], 0.01, work)
    c, d1, d2 = work[0:3], work[3:6], work[6:9]
    o = p - c
    dc = float(np.linalg.norm(o))
    D = float(d1 @ d1 - o @ d2)
    w = sw.w[i]
    a = sw.d[i] - sw.z[i] * w
    G, kt = pb.law_inverse(lam[i], i, sw)
    fe = lam[i] + kt * (dc - G)
    # an active-set guess: the linearised force may be negative at this iterate (the tangent of
    # the wall law about the carried force crosses zero at half its depth)
    if not (kt > 0.0 and dc > 1e-12):
        return False
    n = o / dc
    sw.s[i] = si
    sw.p[i] = p
    sw.d[i] = dc
    sw.z[i] = (dc - a) / w
    sw.n[i] = n
    sw.H[i] = (np.eye(3) - np.outer(n, n) - np.outer(d1, d1) / D) / dc
    sw.F[i] = fe
    sw.dF[i] = kt
    return True


def lam_update(pb, sw, lam, q_old, dq_applied):
    """lam <- lam + k_t (d + n.dp - G(lam)) with dp the applied step of each sample (old n)."""
    nd = pb.nd
    for i in range(sw.F.shape[0]):
        if lam[i] > 0.0 and sw.dF[i] > 0.0:
            j = sw.link[i]
            al = sw.alpha[i]
            dp = (1 - al) * dq_applied[nd * j : nd * j + 3] + al * dq_applied[
                nd * (j + 1) : nd * (j + 1) + 3
            ]
            # sw.F, sw.dF hold the condensed force and k_t at the old point
            lam[i] = max(sw.F[i] + sw.dF[i] * float(np.dot(sw.n[i], dp)), 0.0)


def solve(pb, mixed=False, chord=False, trace=None, lam0=None, mu0=None):
    """Newton from the captured start; returns (status, iters, jacs, residuals, halvings, q)."""
    q = pb.q0.copy()
    sw = pb.sw()
    nf, nd, kl = pb.n_free, pb.nd, pb.kl
    lam = np.zeros(sw.F.shape[0]) if mixed else None
    if mixed and lam0 is not None:
        lam[:] = lam0
    mu = None
    n_res = n_jac = n_half = 0
    best = np.inf
    it_best = 0
    n_small = 0
    lu = None
    chord_ok = False
    r, primal = evaluate(pb, q, sw, lam, True)
    pb.in_contact_start = sw.z > 0.0
    n_res += 1
    if pb.kkt:
        A, c, eh, L = pb.cons(q)
        mu = -np.linalg.lstsq(A.T, r[:nf], rcond=None)[0] if mu0 is None else mu0.copy()
    it = 0
    status = 1
    for it in range(pb.max_iter + 1):
        if pb.kkt:
            A, c, eh, L = pb.cons(q)
            rx = r[:nf] + A.T @ mu
            res = np.max(np.abs(rx))
            merit0 = float(rx @ rx)
            pres = np.max(np.abs(primal[:nf] + A.T @ mu))
        else:
            rx = r[:nf]
            res = np.max(np.abs(rx))
            merit0 = float(rx @ rx)
            pres = np.max(np.abs(primal[:nf]))
        if trace is not None:
            trace.append(pres)
        if not math.isfinite(merit0):
            return 3, it, n_jac, n_res, n_half, q
        if pres <= pb.tol and (not mixed or res <= 10 * pb.tol):
            pb.in_contact_end = sw.z > 0.0
            return 0, it, n_jac, n_res, n_half, q
        if it == pb.max_iter:
            break
        if res < 0.5 * best:
            best = res
            it_best = it
        elif it - it_best >= 20:
            status = 5
            break
        use_chord = chord and lu is not None and chord_ok
        if not use_chord:
            n_jac += 1
            if pb.kkt:
                H = dense(pb.B, kl, nf) + pb.cons_hess(q, mu, eh, L)
                m = A.shape[0]
                K = np.zeros((nf + m, nf + m))
                K[:nf, :nf] = H
                K[:nf, nf:] = A.T
                K[nf:, :nf] = A
                lu = sla.lu_factor(K)
            elif chord:
                lu = sla.lu_factor(dense(pb.B, kl, nf))
            else:
                lu = None
        if pb.kkt:
            rhs = np.concatenate([-rx, -c])
            sol = sla.lu_solve(lu, rhs)
            dq = np.zeros_like(q)
            dq[:nf] = sol[:nf]
            dmu = sol[nf:]
        elif lu is not None:
            dq = np.zeros_like(q)
            dq[:nf] = sla.lu_solve(lu, -rx)
        else:
            Bw = pb.B.copy()
            rhs = np.zeros_like(q)
            rhs[:nf] = -rx
            if not band_solve(Bw, kl, rhs, nf):
                return 2, it, n_jac, n_res, n_half, q
            dq = rhs
        mx = np.max(np.abs(dq[:nf]))
        scale = 1.0 if mx <= pb.max_step else pb.max_step / mx
        uphill = float(dq[:nf] @ rx)
        flip = uphill > 0.0 and nd == 3 and scale < 1.0 and not use_chord
        if flip:
            dq = -dq
        q_old = q.copy()
        sw_old = _copy_nt(sw)
        lam_old = None if lam is None else lam.copy()
        step = scale
        accepted = False
        for _ls in range(9):
            qt = q_old.copy()
            update_chain(q_old, dq, step, nd, pb.n_nodes, nf, qt)
            swt = sw  # the trials run on the same samples, as the compiled Newton's do
            lamt = None
            if lam is not None:
                lamt = lam_old.copy()
                lam_update(pb, sw_old, lamt, q_old, qt - q_old)
            mut = None if mu is None else mu + step * dmu
            rt, pt = evaluate(pb, qt, swt, lamt, True)
            n_res += 1
            if pb.kkt:
                At, _ct, _e, _l = pb.cons(qt)
                rxt = rt[:nf] + At.T @ mut
            else:
                rxt = rt[:nf]
            merit = float(rxt @ rxt)
            if math.isfinite(merit) and (flip or merit <= (1.0 - 1e-4 * step) * merit0):
                accepted = True
                break
            if use_chord:
                break  # a chord step that does not descend: refresh the Jacobian instead
            step *= 0.5
            n_half += 1
        if use_chord:
            pb.chord_tries += 1
            pb.chord_kept += int(accepted)
        if use_chord and not accepted:
            chord_ok = False
            lam, q = lam_old, q_old
            r, primal = evaluate(pb, q, sw, lam, True)
            n_res += 1
            continue
        q, sw, lam, r, primal = qt, swt, lamt, rt, pt
        if mu is not None:
            mu = mut
        if chord:
            res_new = np.max(np.abs(rxt))
            chord_ok = res_new <= pb.chord_rate * res
        if mx * step < 1e-15:
            status = 1
            break
        if step < scale / 32.0:
            n_small += 1
            if n_small >= 2:
                status = 4
                break
        else:
            n_small = 0
    return status, it, n_jac, n_res, n_half, q


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="ring26-flexitron")
    ap.add_argument(
        "--variants", default="base,mixed,mixed-warm,mixed-oracle,chord,kkt,kkt-warm,kkt-warm-chord"
    )
    ap.add_argument("--chord-rate", type=float, default=CHORD_RATE)
    ap.add_argument("--trace", type=int, default=-1, help="print the residuals of this step")
    ap.add_argument("--time-lu", action="store_true", help="time the penalty and KKT banded LUs")
    a = ap.parse_args()
    model, states = capture(a.scene)
    print(f"{a.scene}: {len(states)} captured Newton solves")
    if a.time_lu:
        for k in range(0, len(states), max(len(states) // 4, 1)):
            t = time_kkt_lu(model, states[k])
            print(
                f"state {k}: banded LU us a call: penalty ({t['penalty'][0]} unknowns, kl "
                f"{t['penalty'][1]}) {t['penalty'][2]:.2f}; KKT ({t['kkt'][0]}, kl {t['kkt'][1]}) "
                f"{t['kkt'][2]:.2f}"
            )
        return 0
    # the compiled Newton on the same starts (the reference of the replica)
    comp_its = []
    q_ref = []
    F_end = []
    cnt_all = np.zeros_like(model.counters)
    for effects, q0, st, sw0 in states:
        q = q0.copy()
        sw = _copy_nt(sw0)
        cnt = np.zeros_like(model.counters)
        out = newton(effects, q, st, sw, model.n_free, model.tol_abs, model.max_iter,
                     model.max_step, np.zeros_like(model.r), np.zeros_like(model.B),
                     np.zeros_like(model.energies), cnt)  # fmt: skip
        cnt_all += cnt
        comp_its.append(out[1])
        q_ref.append(q)
        F_end.append(sw.F.copy())
    print(f"compiled newton: {sum(comp_its)} iterations, counters {list(cnt_all)}")
    print(
        "| variant | iterations | Jacobians | residuals | halvings | failed "
        "| max dq vs compiled (m) | iterations from max|r| > 1e-2 / 1e-4..1e-2 / < 1e-4 N "
        "| estimate (ms; x base) |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    base_est = estimate_us("base", len(states), int(cnt_all[2]), 0, int(cnt_all[0]))
    for v in a.variants.split(","):
        mixed = "mixed" in v
        chord = "chord" in v
        kkt = "kkt" in v
        tot = np.zeros(4, dtype=int)
        failed = 0
        dmax = 0.0
        per = []
        bands = np.zeros(3, dtype=int)
        nc_changed = 0
        its_by_change = ([], [])
        chords = np.zeros(2, dtype=int)
        for k, s in enumerate(states):
            pb = Problem(model, s, kkt)
            pb.chord_rate = a.chord_rate
            pb.extend = "ext" in v
            tr = []
            warm = "warm" in v and k > 0
            lam0 = F_end[k - 1] if warm else None
            if "oracle" in v:  # this step's converged contact forces (a bound, not a method)
                lam0 = F_end[k]
            mu0 = None
            if kkt and (warm or "oracle" in v):
                # the previous (oracle: this) converged step's penalty tensions k (|e| - l)
                qp = q_ref[k] if "oracle" in v else q_ref[k - 1]
                mu0 = np.array([
                    pb.ea / pb.link_len[j] * (np.linalg.norm(
                        qp[pb.nd * (j + 1) : pb.nd * (j + 1) + 3] - qp[pb.nd * j : pb.nd * j + 3]
                    ) - pb.link_len[j]) for j in pb.links
                ])  # fmt: skip
            status, its, nj, nr, nh, q = solve(
                pb, mixed=mixed, chord=chord, trace=tr, lam0=lam0, mu0=mu0
            )
            chords += (pb.chord_tries, pb.chord_kept)
            if status == 0:
                ch = bool(np.any(pb.in_contact_start != pb.in_contact_end))
                nc_changed += int(ch)
                its_by_change[int(ch)].append(its)
            for x in tr[:-1]:
                bands[0 if x > 1e-2 else (1 if x > 1e-4 else 2)] += 1
            if k == a.trace:
                print(v, "step", k, " ".join(f"{x:.2e}" for x in tr))
            per.append(its)
            tot += (its, nj, nr, nh)
            if status != 0:
                failed += 1
            else:
                dmax = max(dmax, float(np.max(np.abs(q - q_ref[k]))))
        est = estimate_us(v, len(states), tot[1], chords[0], tot[2])
        print(
            f"| {v} | {tot[0]} | {tot[1]} | {tot[2]} | {tot[3]} | {failed} | {dmax:.2e} "
            f"| {bands[0]} / {bands[1]} / {bands[2]} | {est / 1e3:.1f}; x{est / base_est:.2f} |"
        )
        if chord:
            print(f"  chord steps tried {chords[0]}, kept (Armijo at the full step) {chords[1]}")
        print(
            f"  steps whose contact set (z > 0) changed from start to solution: {nc_changed}; "
            f"mean iterations of the steps with / without a change: "
            f"{np.mean(its_by_change[1] or [0]):.2f} / {np.mean(its_by_change[0] or [0]):.2f}"
        )
        if v == "base":
            diff = [i for i in range(len(per)) if per[i] != comp_its[i]]
            print(f"  replica vs compiled: {len(diff)} steps differ {diff[:10]}")
    return 0


def time_kkt_lu(model, state, calls=2000, rounds=5):
    """us a call of the banded LU (``band_solve``) on the captured state's Jacobian and on its
    KKT counterpart (node-interleaved unknowns x, y, z, mu_j: half-bandwidth 6), fastest round."""
    from bench_kernels import loop_copy, loop_solve

    pb = Problem(model, state, True)
    q = pb.q0.copy()
    sw = pb.sw()
    nf, nd = pb.n_free, pb.nd
    r, _ = evaluate(pb, q, sw, None, True)
    A, _c, eh, L = pb.cons(q)
    mu = -np.linalg.lstsq(A.T, r[:nf], rcond=None)[0]
    H = dense(pb.B, pb.kl, nf) + pb.cons_hess(q, mu, eh, L)
    m = A.shape[0]
    K = np.zeros((nf + m, nf + m))
    K[:nf, :nf] = H
    K[:nf, nf:] = A.T
    K[nf:, :nf] = A
    perm = []
    for j in range(nf // nd):
        perm += [nd * j + a for a in range(nd)]
        if j < m:
            perm.append(nf + j)
    Kp = K[np.ix_(perm, perm)]
    n = Kp.shape[0]
    kl = max(abs(i - j) for i in range(n) for j in range(n) if Kp[i, j] != 0.0)
    Bk = np.zeros((n, 3 * kl + 1))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + kl + 1)):
            Bk[i, kl + j - i] = Kp[i, j]
    rhs = np.random.default_rng(1).standard_normal(n)
    x = rhs.copy()
    Bw = Bk.copy()
    assert band_solve(Bw, kl, x, n)
    assert np.allclose(Kp @ x, rhs, rtol=0, atol=1e-8 * np.max(np.abs(rhs)) * np.max(np.abs(Kp)))
    out = {}
    for label, B0, k, nn in (("penalty", pb.B.copy(), pb.kl, nf), ("kkt", Bk, kl, n)):
        rhs0 = np.zeros(B0.shape[0])
        rhs0[:nn] = 1.0
        Bw = B0.copy()
        rw = rhs0.copy()
        copy_us = best_us(loop_copy, (B0, Bw, rhs0, rw), calls, rounds)
        solve_us = best_us(loop_solve, (B0, Bw, rhs0, rw, k, nn), calls, rounds)
        out[label] = (nn, k, solve_us - copy_us)
    return out


if __name__ == "__main__":
    raise SystemExit(main())
