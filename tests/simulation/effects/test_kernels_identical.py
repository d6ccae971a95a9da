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
