"""Each effect's law against hand-derived values: hinge energy, Stribeck and Coulomb friction,
the Khatait contact law's regions, and the units' validation messages."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ringqa.errors import SceneError
from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects.friction import friction_phi
from ringqa.simulation.scene import ContactParams, Effects, SolverSettings
from tests.simulation.builders import assemble_at, model, rod, scene


def _model(effects):
    ch = arc_channel(
        radius_m=0.013, angle_rad=1.9 * np.pi, entry_m=0.04, r_b_m=0.5e-3, r_a_m=0.45e-3
    )
    return model(scene(ch, rod(), effects=effects, solver=SolverSettings(axial_stiffness_n=1.0)),
                 0.06)  # fmt: skip


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
    assemble_at(m, m.effects, q, m.step(q.copy(), q * 0, 1.0))
    k = 5e-4 / l0
    assert m.energies[m.names.index("bending")] == pytest.approx(0.5 * k * th**2, rel=1e-12)


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


def test_coulomb_law_is_mu_k_tanh():
    """Coulomb: mu(v) = mu_k tanh(v / v_reg): at v = v_reg, 0.2 tanh(1) = 0.152318."""
    phi, _ = friction_phi(1e-4, 1, 0.25, 0.2, 1e-3, 1e-4)
    assert phi * 1e-4 == pytest.approx(0.2 * math.tanh(1.0), rel=1e-12)


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
    k w (z - 1/2) beyond, continuous with continuous slope at z = 1 (k w / 2, k).
    r_b = 0.5 mm, r_o = 0.3 mm -> b = 0.2 mm; w = min(0.05 mm, 0.2 b) = 0.04 mm."""
    m = _model(Effects(friction="none"))
    b = 0.5e-3 - 0.3e-3
    w = min(0.05e-3, 0.2 * b)
    q = m.initial_state(0.0)  # straight part of the channel: offset along y is the distance
    k = m.unit("contact").stiffness_n_m
    for d, expect in [
        (b - w - 1e-6, 0.0),
        (b - w / 2, 0.5 * k * w * 0.25),
        (b, 0.5 * k * w),
        (b + 1e-5, k * w * (1 + 1e-5 / w - 0.5)),
    ]:
        qq = q.copy()
        qq[1] = d  # tip node (sample 0 sits on it), offset in +y
        assemble_at(m, m.effects, qq, m.step(qq.copy(), qq * 0, 1.0))
        assert m.samples.F[0] == pytest.approx(expect, rel=1e-9, abs=1e-12)


def test_wall_damping_never_pulls():
    """A sample moving away from the wall inside the transition zone: elastic force
    k w z^2 / 2 minus damping c_w (3 - 2z) z^2 v_n would be negative for a fast enough
    retreat; the total is clamped at zero (the paper's code leaves a sticky wall)."""
    m = _model(Effects(friction="none", wall_damping=True))
    b = 0.2e-3
    w = 0.04e-3
    q = m.initial_state(0.0)
    q[1] = b - w / 2  # z = 1/2
    m.d_prev[:] = b + 1e-3  # it was 1 mm further out: v_n = -1 mm / 1 ms = -1 m/s
    assemble_at(m, m.effects, q, m.step(q.copy(), q * 0, 1e-3))
    assert m.samples.F[0] == 0.0 and m.samples.dF[0] == 0.0


def test_contact_params_validation_names_key():
    """A negative wall stiffness is refused where the scene is built, naming the key."""
    with pytest.raises(SceneError, match=r"contact\.stiffness_n_m: must be > 0, got -1 N/m"):
        ContactParams(stiffness_n_m=-1.0)
