"""Every effect's Jacobian against finite differences of its own residual, and the one assembler.

Newton converges quadratically only with exact Jacobians; each effect's analytic Jacobian is
compared with central finite differences of its residual on a randomly perturbed, partly
in-contact chain. Each effect is assembled alone (with contact in front of the effects that act
through the contact samples: wall damping and friction), so a wrong term cannot hide behind
another effect's.
"""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects import EFFECTS
from ringqa.simulation.scene import Effects, SolverSettings
from tests.simulation.builders import assemble_at, dense, model, rod, scene

#: every assembled effect's FD case: (effects on in the model, effects in the tuple, tolerance)
CASES = {
    "inextensibility": (Effects(friction="none", contact=False), ("inextensibility",), 1e-7),
    "bending": (Effects(friction="none", contact=False), ("bending",), 1e-7),
    "torsion": (Effects(friction="none", torsion=True), ("torsion",), 1e-7),
    "contact": (Effects(friction="none"), ("contact",), 1e-7),
    "wall_damping": (
        Effects(friction="none", wall_damping=True),
        ("contact", "wall_damping"),
        1e-7,
    ),
    "friction": (Effects(friction="stribeck"), ("contact", "friction"), 1e-7),
    "friction_coulomb": (Effects(friction="coulomb"), ("contact", "friction"), 1e-7),
    # with torsion the friction Jacobian ignores the rotation of the link axis within the
    # step (documented): within 5 % of finite differences, enough for Newton
    "friction_torsion": (Effects(friction="stribeck", torsion=True), ("contact", "friction"), 0.05),
    "gravity": (Effects(friction="none", gravity_m_s2=(0.0, -9.81, 0.0)), ("gravity",), 0.0),
    "inertia": (Effects(friction="none", inertia=True), ("inertia",), 1e-7),
    "tether": (Effects(friction="none"), ("tether",), 1e-7),
}


def _model(effects, dynamic=False):
    ch = arc_channel(
        radius_m=0.013, angle_rad=1.9 * np.pi, entry_m=0.04, r_b_m=0.5e-3, r_a_m=0.45e-3
    )
    solver = SolverSettings(axial_stiffness_n=1.0, kind="dynamic" if dynamic else "quasistatic")
    return model(scene(ch, rod(), effects=effects, solver=solver), 0.06)


def _perturbed(m, seed=1):
    rng = np.random.default_rng(seed)
    q = m.initial_state(0.05)
    m.prescribe(q, 0.05)
    qp = q.copy()
    q = q + rng.normal(scale=1e-4, size=q.shape)
    if m.nd == 4:
        q.reshape(-1, 4)[:, 3] += rng.normal(scale=0.3, size=m.n_nodes)
    m.d_prev[:] = 0.1e-3
    return q, qp


def jacobian_error(m, effects, n=40):
    """max |J - J_fd| / max |J_fd| over the leading n x n block, samples in contact, max |J|."""
    q, qp = _perturbed(m)
    st = m.step(qp, np.linspace(-1e-3, 1e-3, m.n_all), 2e-3)
    _, B = assemble_at(m, effects, q, st)
    J = dense(m, B, n)
    n_contact = int(np.sum(m.samples.F > 0))
    Jfd = np.zeros((n, n))
    for j in range(n):
        eps = 1e-7 if (m.nd == 4 and j % 4 == 3) else 1e-9
        qq = q.copy()
        qq[j] += eps
        rp, _ = assemble_at(m, effects, qq, st, jac=False)
        qq[j] -= 2 * eps
        rm, _ = assemble_at(m, effects, qq, st, jac=False)
        Jfd[:, j] = (rp - rm)[:n] / (2 * eps)
    scale = np.max(np.abs(Jfd))
    err = float(np.max(np.abs(J - Jfd)) / scale) if scale > 0 else float(np.max(np.abs(J)))
    return err, n_contact


def test_every_registered_effect_has_a_jacobian_case():
    """A new effect in the registry must come with its finite-difference case here."""
    names = {case[1][-1] for case in CASES.values()}
    assert {cls.name for cls in EFFECTS} <= names


@pytest.mark.parametrize("case", sorted(CASES))
def test_effect_jacobian_matches_finite_differences(case):
    """Analytic Jacobian = central finite differences to 1e-7 of its largest entry.

    Finite-difference truncation and round-off at eps = 1e-9 m are ~1e-9 relative here, so a
    mistake in any derivative term (they are O(1) of the entries) would show as > 1e-3. Gravity
    has no stiffness: both are exactly zero. The tether is tested at 1 N s/m.
    """
    eff, names, tol = CASES[case]
    m = _model(eff, dynamic=eff.inertia)
    args = {u.name: u.args() for u in m.units}
    if case == "tether":
        args["tether"] = m.unit("tether").with_coef(1.0)
    effects = tuple(args[n] for n in names)
    err, n_contact = jacobian_error(m, effects)
    if "contact" in names:
        assert n_contact >= 3  # the check covers samples in contact
    if case == "gravity":
        assert err == 0.0
    else:
        assert err < tol


def test_u_lumen_jacobian_is_close():
    """U-shaped lumen (flat 0.32 mm from the centreline on the outside of a 13 mm arc, corners
    rounded): the contact Jacobian matches finite differences to 1 % of its largest entry (the
    flat's normal is interpolated from the table, its rate taken piecewise constant)."""
    from ringqa.simulation.analytic import ArcCentreline, SimpleChannel, SimpleLumen

    cl = ArcCentreline(0.04, 0.013, 1.9 * np.pi)
    lumen = SimpleLumen((0.0, np.inf), (0.5e-3,), (0.45e-3,), (0.32e-3,))
    sc = scene(SimpleChannel("u", cl, lumen, 0.1), rod(), effects=Effects(friction="none"),
               solver=SolverSettings(axial_stiffness_n=1.0))  # fmt: skip
    m = model(sc, 0.06)
    err, n_contact = jacobian_error(m, m.effects)
    assert n_contact >= 3
    assert err < 1e-2


def test_one_assembler_three_uses_agree_bit_for_bit():
    """The residual without the Jacobian is the residual with it; the Jacobian rebuilt from the
    samples a residual-only call left (``fresh=False``, as Newton does after its line search) is
    the full call's Jacobian: the same code adds the same terms in the same order. (Each call
    starts its closest-point searches from the same hints: the hints move the converged arc
    lengths by round-off.)"""
    m = _model(Effects(friction="stribeck", wall_damping=True, torsion=True,
                       gravity_m_s2=(0.0, -9.81, 0.0)))  # fmt: skip
    q, qp = _perturbed(m)
    st = m.step(qp, np.zeros(m.n_all), 2e-3)
    hints = m.samples.s.copy()
    r_full, B_full = assemble_at(m, m.effects, q, st, jac=True)
    e_full = m.energies.copy()
    m.samples.s[:] = hints
    r_only, _ = assemble_at(m, m.effects, q, st, jac=False)
    np.testing.assert_array_equal(r_only, r_full)
    np.testing.assert_array_equal(m.energies, e_full)
    _, B_again = assemble_at(m, m.effects, q, st, jac=True, fresh=False)
    np.testing.assert_array_equal(B_again, B_full)
    np.testing.assert_array_equal(m.energies, e_full)  # a Jacobian-only call leaves them


def test_monotone_friction_changes_the_jacobian_only_on_the_falling_branch():
    """``FrictionArgs.monotone`` (the retry and pause-step Jacobian, solvers/stepper.py) floors
    the Stribeck law's slope along the slip at zero where ``d mu / dv < 0``: the residual must be
    the same bit for bit (the converged answer is the same law's), and the Jacobian must change
    only at contact samples sliding on the falling branch. Slips of ~2 um over a 1 ms step
    (v ~ 2 mm/s = 2 v_brk, where mu falls from mu_s towards mu_k) put samples there; with
    Coulomb's monotone tanh the flag may change nothing beyond round-off."""
    for law, changes in (("stribeck", True), ("coulomb", False)):
        m = _model(Effects(friction=law), dynamic=True)
        q, _ = _perturbed(m)  # partly in contact
        qp = q - np.random.default_rng(3).normal(scale=2e-6, size=q.shape)
        st = m.step(qp, np.zeros(m.n_all), 1e-3)
        exact = tuple(u.args() for u in m.units if u.name in ("contact", "friction"))
        mono = tuple(
            u.monotone_args() if u.name == "friction" else u.args()
            for u in m.units
            if u.name in ("contact", "friction")
        )
        s_hint = m.samples.s.copy()  # the closest-point search starts from these hints
        r0, B0 = assemble_at(m, exact, q, st)
        assert int(np.sum(m.samples.F > 0)) >= 3
        m.samples.s[:] = s_hint
        r1, B1 = assemble_at(m, mono, q, st)
        assert np.array_equal(r0, r1)
        change = float(np.max(np.abs(B1 - B0)) / np.max(np.abs(B0)))
        if changes:
            assert change > 1e-6
        else:  # tanh's slope is >= 0: only round-off in saturated samples (~1e-17) is floored
            assert change < 1e-12
