"""Each effect's kernel: exact derivatives (finite differences), energies, friction law shape.

The Newton solver relies on exact Jacobians (quadratic convergence); every effect's analytic
Jacobian is compared with central finite differences of its residual on a randomly perturbed,
partly in-contact chain.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sim_builders import rod, scene

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects._kernels import friction_phi
from ringqa.simulation.scene import ContactParams, Effects, SolverSettings
from ringqa.simulation.solvers import _kernels as SK
from ringqa.simulation.solvers.driver import Model


def _model(effects, axial=1.0, gravity=None):
    ch = arc_channel(
        radius_m=0.013, angle_rad=1.9 * np.pi, entry_m=0.04, r_b_m=0.5e-3, r_a_m=0.45e-3
    )
    sc = scene(ch, rod(), effects=effects, solver=SolverSettings(axial_stiffness_n=axial))
    m = Model(sc, np.array([0.06]))
    return m


def _assemble(m, q, qp, dt=2e-3, jac=True):
    r = np.zeros(m.n_all)
    B = np.zeros_like(m.B)
    v_prev = np.linspace(-1e-3, 1e-3, m.n_all)
    SK.assemble(
        q, qp, v_prev, qp, m.links, m.chan, m.samples, m.swork, m.par, dt, r, B, jac, m.energies
    )
    return r, B


def _jacobian_error(m, seed=1):
    rng = np.random.default_rng(seed)
    q = m.initial_state(0.05)
    m.prescribe(q, 0.05)
    qp = q.copy()
    q = q + rng.normal(scale=1e-4, size=q.shape)
    if m.nd == 4:
        q.reshape(-1, 4)[:, 3] += rng.normal(scale=0.3, size=m.n_nodes)
    m.samp_d_prev[:] = 0.1e-3
    _, B = _assemble(m, q, qp)
    n = 40
    J = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - m.kl), min(n, i + m.kl + 1)):
            J[i, j] = B[i, m.kl + j - i]
    Jfd = np.zeros((n, n))
    for j in range(n):
        eps = 1e-7 if (m.nd == 4 and j % 4 == 3) else 1e-9
        qq = q.copy()
        qq[j] += eps
        rp, _ = _assemble(m, qq, qp, jac=False)
        qq[j] -= 2 * eps
        rm, _ = _assemble(m, qq, qp, jac=False)
        Jfd[:, j] = (rp - rm)[:n] / (2 * eps)
    n_contact = int(np.sum(m.samp_F > 0))
    return float(np.max(np.abs(J - Jfd)) / np.max(np.abs(Jfd))), n_contact


@pytest.mark.parametrize(
    "effects",
    [
        Effects(friction="none", contact=False),
        Effects(friction="none"),
        Effects(friction="coulomb"),
        Effects(friction="stribeck"),
        Effects(friction="stribeck", wall_damping=True),
        Effects(friction="none", gravity_m_s2=(0.0, -9.81, 0.0)),
    ],
    ids=["bending+axial", "contact", "coulomb", "stribeck", "damping", "gravity"],
)
def test_jacobian_is_exact(effects):
    """Analytic Jacobian = central finite differences to 1e-7 of its largest entry.

    Finite-difference truncation and round-off at eps = 1e-9 m are ~1e-9 relative here, so a
    mistake in any derivative term (they are O(1) of the entries) would show as > 1e-3.
    """
    m = _model(effects)
    err, n_contact = _jacobian_error(m)
    if effects.contact:
        assert n_contact >= 3  # the check covers samples in contact
    assert err < 1e-7


def test_torsion_friction_jacobian_is_close():
    """With torsion the friction Jacobian ignores the rotation of the link axis within the step
    (documented): it stays within 5 % of finite differences, enough for Newton."""
    m = _model(Effects(friction="stribeck", torsion=True))
    err, _ = _jacobian_error(m)
    assert err < 0.05


def test_hinge_energy_is_k_theta_squared_over_two():
    """Three nodes with a 30 degree kink: energy k theta^2 / 2 with k = EI / l (equal links).

    EI = 5e-4 N m^2, l = 3 mm -> k = 0.16667 N m; theta = pi/6 -> U = 0.0228453 J.
    """
    m = _model(Effects(friction="none", contact=False))
    q = m.initial_state(0.0)
    qv = q.reshape(m.n_nodes, 3)
    l0 = m.chain.link_len[0]
    th = math.pi / 6
    # node 0 rotated by 30 degrees about node 1 in the xy-plane
    qv[0] = qv[1] + l0 * np.array([math.cos(th), math.sin(th), 0.0])
    _assemble(m, q, q.copy())
    k = 5e-4 / l0
    assert m.energies[1] == pytest.approx(0.5 * k * th**2, rel=1e-12)


def test_stribeck_law_peaks_at_mu_s_at_v_brk():
    """The paper's law: mu(v_brk) = sqrt(2e)(mu_s - mu_k) e^(-1/2) / sqrt(2) + mu_k tanh(10)
    = (mu_s - mu_k) + mu_k (1 - 4e-9) = mu_s; mu -> mu_k for v >> v_brk; mu(0) = 0."""
    mu_s, mu_k, vb = 0.25, 0.20, 1e-3
    vreg = vb / 10

    def mu(v):
        return friction_phi(v, 2, mu_s, mu_k, vb, vreg)[0] * v

    assert mu(vb) == pytest.approx(mu_s, rel=1e-7)
    assert mu(0.5) == pytest.approx(mu_k, rel=1e-9)
    assert mu(1e-12) < 1e-8
    v = np.linspace(1e-5, 5e-3, 400)
    assert np.max([mu(x) for x in v]) < mu_s * 1.01


def test_friction_phi_derivative_matches_finite_difference():
    """psi = phi'(v) / v: compare with central differences across the small-v series switch."""
    for law in (1, 2):
        for v in (1e-8, 5e-8, 2e-6, 1e-4, 3e-3):
            h = 1e-3 * max(v, 1e-4)
            fp = friction_phi(v + h, law, 0.25, 0.2, 1e-3, 1e-4)[0]
            fm = friction_phi(v - h, law, 0.25, 0.2, 1e-3, 1e-4)[0]
            psi = friction_phi(v, law, 0.25, 0.2, 1e-3, 1e-4)[1]
            assert psi == pytest.approx((fp - fm) / (2 * h) / v, rel=1e-4, abs=1e-3)


def test_contact_law_regions_and_continuity():
    """Khatait law on a sample moved across the wall: F = 0 below a, k w z^2 / 2 in the zone,
    k w (z - 1/2) beyond, continuous with continuous slope at z = 1 (k w / 2, k)."""
    m = _model(Effects(friction="none"))
    b = 0.5e-3 - 0.3e-3
    w = min(0.05e-3, 0.2 * b)
    q = m.initial_state(0.0)  # straight part of the channel: offset along y is the distance
    k = m.cpar[0]
    for d, expect in [
        (b - w - 1e-6, 0.0),
        (b - w / 2, 0.5 * k * w * 0.25),
        (b, 0.5 * k * w),
        (b + 1e-5, k * w * (1 + 1e-5 / w - 0.5)),
    ]:
        qq = q.copy()
        qq[1] = d  # tip node (sample 0 sits on it), offset in +y
        _assemble(m, qq, qq.copy())
        assert m.samp_F[0] == pytest.approx(expect, rel=1e-9, abs=1e-12)


def test_contact_params_validation_names_key():
    """A negative wall stiffness is refused with the dotted key in the message."""
    from ringqa.errors import SceneError

    ch = arc_channel()
    sc = scene(ch, rod(), contact=ContactParams(stiffness_n_m=-1.0))
    with pytest.raises(SceneError, match=r"contact\.stiffness_n_m"):
        Model(sc, np.array([0.01]))


def test_u_lumen_jacobian_is_close():
    """U-shaped lumen (flat 0.32 mm from the centreline on the outside of a 13 mm arc, corners
    rounded): the contact Jacobian matches finite differences to 1 % of its largest entry (the
    flat's normal is interpolated from the table, its rate taken piecewise constant)."""
    from ringqa.simulation.analytic import ArcCentreline, SimpleChannel, SimpleLumen

    cl = ArcCentreline(0.04, 0.013, 1.9 * np.pi)
    lumen = SimpleLumen((0.0, np.inf), (0.5e-3,), (0.45e-3,), (0.32e-3,))
    sc = scene(SimpleChannel("u", cl, lumen, 0.1), rod(), effects=Effects(friction="none"),
               solver=SolverSettings(axial_stiffness_n=1.0))  # fmt: skip
    m = Model(sc, np.array([0.06]))
    err, n_contact = _jacobian_error(m)
    assert n_contact >= 3
    assert err < 1e-2
