"""The cheaper effect kernels (branch kernels, docs/engine.md "A cheaper iteration") give the
kernels they replaced (tests/simulation/effects/reference_kernels.py, main 9f17845) bit for bit.

The rewrites change where values live (scalars and per-hinge tables instead of small scratch
arrays), which loops the compiler vectorises and the order in which DIFFERENT entries are
written, never an expression or the order of the terms one entry of ``r`` or ``B`` receives.
With IEEE arithmetic and no fused multiply-add (numba does not contract without fastmath),
the same operations on the same operands round the same way, so any difference at all, even
in the last bit, is a wrong term, index or order; the comparison is on the bit patterns
(``view(int64)``), with ``r`` and ``B`` pre-filled with random values so that the order of
the additions into them matters. States: the Jacobian tests' arc-channel chain perturbed
(1e-6 and 1e-4 m), with 3 and 4 (torsion) coordinates a node and hinges of zero stiffness.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects.axial import axial_kernel
from ringqa.simulation.effects.bending import bending_kernel
from ringqa.simulation.scene import Effects, SolverSettings
from tests.simulation.builders import model, rod, scene
from tests.simulation.effects import reference_kernels as ref


def _model(torsion: bool):
    ch = arc_channel(
        radius_m=0.013, angle_rad=1.9 * np.pi, entry_m=0.04, r_b_m=0.5e-3, r_a_m=0.45e-3
    )
    eff = Effects(friction="stribeck", torsion=torsion)
    return model(scene(ch, rod(), effects=eff, solver=SolverSettings(axial_stiffness_n=1e6)), 0.06)


def _states(m, n=6, seed=3):
    """``n`` perturbed states of ``m`` (m), alternately 1e-6 and 1e-4 m off its chain."""
    rng = np.random.default_rng(seed)
    q0 = m.initial_state(0.05)
    m.prescribe(q0, 0.05)
    for k in range(n):
        q = q0 + rng.normal(scale=1e-4 if k % 2 else 1e-6, size=q0.shape)
        if m.nd == 4:
            q.reshape(-1, 4)[:, 3] += rng.normal(scale=0.3, size=m.n_nodes)
        yield k, q, rng


def _same(a, b) -> bool:
    a = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
    b = np.ascontiguousarray(np.asarray(b, dtype=np.float64))
    return a.shape == b.shape and bool(np.array_equal(a.view(np.int64), b.view(np.int64)))


def _compare(old, new, args, m, rng, jac):
    B0 = rng.normal(size=m.B.shape)
    r0 = rng.normal(size=m.n_all)
    B1, r1, B2, r2 = B0.copy(), r0.copy(), B0.copy(), r0.copy()
    e1 = old(*args, r1, B1, jac)
    e2 = new(*args, r2, B2, jac)
    assert _same(e1, e2)
    assert _same(r1, r2)
    assert _same(B1, B2)


@pytest.mark.parametrize("torsion", [False, True])
@pytest.mark.parametrize("jac", [False, True])
def test_bending_and_axial_kernels_bit_for_bit(torsion, jac):
    m = _model(torsion)
    hinge_k = m.unit("bending").hinge_k
    ax = m.unit("inextensibility")
    for k, q, rng in _states(m):
        hk = hinge_k.copy()
        if k >= 4:
            hk[rng.integers(0, hk.size, 3)] = 0.0  # hinges without stiffness are skipped
        _compare(ref.bending_kernel, bending_kernel, (q, m.nd, m.n_nodes, m.kl, hk), m, rng, jac)
        _compare(ref.axial_kernel, axial_kernel,
                 (q, m.nd, m.n_nodes, m.kl, ax.link_len, ax.ea_n), m, rng, jac)  # fmt: skip


def _u_lumen_model():
    """The U-shaped lumen of test_effect_jacobians (a flat side 0.32 mm out on the outside of a
    13 mm arc): samples near the flat take the blended branch."""
    from ringqa.simulation.analytic import ArcCentreline, SimpleChannel, SimpleLumen

    cl = ArcCentreline(0.04, 0.013, 1.9 * np.pi)
    lumen = SimpleLumen((0.0, np.inf), (0.5e-3,), (0.45e-3,), (0.32e-3,))
    sc = scene(SimpleChannel("u", cl, lumen, 0.1), rod(), effects=Effects(friction="stribeck"),
               solver=SolverSettings(axial_stiffness_n=1e6))  # fmt: skip
    return model(sc, 0.06)


def _geometry(fn, m, q, sw, mode):
    p = m.unit("contact").args()
    ch = p.chan
    return fn(
        q, m.nd, sw.link, sw.alpha, sw.ro, sw.wt, ch.h, ch.pos, ch.tan, ch.flat_normal,
        ch.kappa_min_flat, ch.seg_s, ch.seg_rb, ch.seg_ra, ch.seg_flat, p.transition, p.max_frac,
        p.k_wall, sw.s, sw.p, sw.d, sw.n, sw.H, sw.z, sw.w, sw.F, sw.dF, mode,
    )  # fmt: skip


@pytest.mark.parametrize("lumen", ["circle", "u"])
def test_contact_geometry_bit_for_bit(lumen):
    """Every sample result (s, p, d, n, H, z, w, F, dF) and the energy of the new
    ``contact_geometry`` equal the old one's, bit for bit, in its three modes: every sample,
    far samples skipped (after a first evaluation, then a small move) and far samples only;
    some samples in contact (and, in the U lumen, on the flat side's blend), some not."""
    from ringqa.simulation.effects.contact import ONLY_FAR, SKIP_FAR, contact_geometry

    m = _model(False) if lumen == "circle" else _u_lumen_model()
    blended_seen = in_contact = out = 0
    for k, q, rng in _states(m):
        sw_old = m.samples._replace(**{f: getattr(m.samples, f).copy() for f in m.samples._fields})
        sw_new = sw_old._replace(**{f: getattr(sw_old, f).copy() for f in sw_old._fields})
        q2 = q + rng.normal(scale=2e-6, size=q.shape)
        for mode, qq in ((0, q), (SKIP_FAR, q2), (ONLY_FAR, q2 + 1e-6)):
            e1 = _geometry(ref.contact_geometry, m, qq, sw_old, mode)
            e2 = _geometry(contact_geometry, m, qq, sw_new, mode)
            assert _same(e1, e2)
            for f in sw_old._fields:
                assert _same(getattr(sw_old, f), getattr(sw_new, f)), (k, mode, f)
        in_contact += int(np.sum(sw_new.F > 0))
        out += int(np.sum(sw_new.z < 0))
        # a blended sample's normal is not radial (its offset has a component along it)
        on = sw_new.F > 0
        radial = np.abs(np.sum(sw_new.n[on] * sw_new.H[on, :, 0], axis=1))
        blended_seen += int(np.sum(radial > 1e-9))
    assert in_contact >= 10 and out >= 10
    if lumen == "u":
        assert blended_seen > 0
