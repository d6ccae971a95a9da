"""The flexible engine against independent results (shared/reference/mechanics.md), on its own.

Every expected value is closed form, a published table or an independent numerical solution
(scipy's boundary-value solver for the elastica); the engine was not written from them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_bvp

from ringqa.simulation import simulate
from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.flexible import FlexModel
from ringqa.simulation.scene import ContactParams, Effects, ModelSettings, Motion, SolverSettings
from tests.simulation.builders import rod, scene

EI = 5e-4
GJ = 4e-4
FLEX = ModelSettings(formulation="flexible")


def _cantilever(n_el, length=0.1, ea=1e8, torsion=False):
    """A rod of free length ``length`` clamped at its driven end (the last node), along +x in a
    huge straight lumen with contact off: a cantilever whose tip is node 0 (GJ = 4e-4 N m^2)."""
    ch = arc_channel(radius_m=1.0, angle_rad=0.01, entry_m=0.5, r_b_m=0.2, r_a_m=0.19)
    inst = rod(ei=EI, element=length / n_el, length=1.0, r_o=1e-3, gj=GJ)
    eff = Effects(friction="none", contact=False, torsion=torsion)
    solver = SolverSettings(approach_m=1e-3, axial_stiffness_n=ea)
    u = length - 1e-3
    m = FlexModel(scene(ch, inst, effects=eff, solver=solver, model=FLEX), np.array([u]))
    q = m.initial_state(u)
    m.prescribe(q, u)
    return m, q


def _tip_loaded(m, q, force, steps=10):
    """Solve with a tip force (N, (3,)) applied in ``steps`` equal increments; in place."""
    for f in np.linspace(1.0 / steps, 1.0, steps):
        m.f_ext[0:3] = f * np.asarray(force, dtype=float)
        st, _, _ = m.solve(q, 0.0, 0.0, q)
        assert st == 0
    return q


def test_cantilever_small_deflection():
    """Tip load P << EI / L^2: tip deflection P L^3 / (3 EI) and tip rotation P L^2 / (2 EI)
    (linear beam theory; exact for cubic Hermite elements, whose shape functions contain the
    linear solution, a cubic). L = 0.1 m, EI = 5e-4 N m^2, P = 1e-3 EI / L^2 = 5e-5 N:
    deflection 3.333e-5 m. 4 elements, EA = 1e6 N; within 1e-3 relative (the geometric
    nonlinearity at this load is ~1e-7 relative, Newton's tolerance ~1e-5)."""
    m, q = _cantilever(4, ea=1e6)
    L = m.rod.sigma[-1]
    P = 1e-3 * EI / L**2
    q = _tip_loaded(m, q, (0.0, -P, 0.0), steps=1)
    x = m.nodes(q)
    defl = x[-1, 1] - x[0, 1]
    assert defl == pytest.approx(P * L**3 / (3 * EI), rel=1e-3)
    t0 = q[3:6]
    rot = math.atan2(t0[1], -t0[0])  # tangent points proximally (+sigma): from the tip to +x
    assert rot == pytest.approx(P * L**2 / (2 * EI), rel=1e-3)


# (P L^2 / EI, tip angle deg, deflection / L, shortening / L): mechanics.md item 6 (exact elastica)
ELASTICA = [
    (0.5, 14.01, 0.1621, 0.0159),
    (1.0, 26.43, 0.3017, 0.0564),
    (2.0, 44.79, 0.4935, 0.1606),
    (5.0, 69.64, 0.7138, 0.3876),
    (10.0, 81.95, 0.8106, 0.5550),
]


def _elastica_bvp(load):
    """The elastica by scipy's collocation BVP solver (independent of the table and the engine):
    theta'' = -(P L^2 / EI) cos(theta) in s/L, theta(0) = 0 (clamp), theta'(1) = 0 (free tip);
    x' = cos theta, y' = sin theta. Returns (tip angle deg, deflection / L, shortening / L)."""

    def f(s, y):
        return np.vstack([y[1], -load * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    s = np.linspace(0.0, 1.0, 201)
    y0 = np.vstack([0.5 * s, 0.5 * np.ones_like(s), s, 0.1 * s])
    sol = solve_bvp(f, bc, s, y0, tol=1e-10, max_nodes=100000)
    assert sol.success
    th, _, x, y = sol.sol(1.0)
    return math.degrees(th), y, 1.0 - x


@pytest.mark.parametrize(("load", "angle", "defl", "short"), ELASTICA)
def test_cantilever_elastica(load, angle, defl, short):
    """Large-deflection cantilever, tip load P normal to the undeformed axis (the exact elastica:
    mechanics.md's table, and scipy's BVP solution of theta'' = -(P L^2/EI) cos theta, which
    agree to 1e-4). 20 elements, the load in max(10, 2 P L^2 / EI) steps. Tolerance 0.3 % of the
    tip angle, deflection and shortening (20 cubic elements resolve the elastica's curvature to
    ~1e-4; the 2-point axial penalty with EA = 1e8 N stretches by P / EA ~ 1e-9)."""
    bvp = _elastica_bvp(load)
    assert bvp == pytest.approx((angle, defl, short), rel=2e-3, abs=2e-4)
    m, q = _cantilever(20)
    L = m.rod.sigma[-1]
    P = load * EI / L**2
    q = _tip_loaded(m, q, (0.0, -P, 0.0), steps=max(10, int(2 * load)))
    x = m.nodes(q)
    d = x[0] - x[-1]
    t0 = q[3:6] / np.linalg.norm(q[3:6])
    tip_angle = math.degrees(math.atan2(t0[1], -t0[0]))
    assert tip_angle == pytest.approx(bvp[0], rel=3e-3)
    assert -d[1] / L == pytest.approx(bvp[1], rel=3e-3)
    assert 1.0 - d[0] / L == pytest.approx(bvp[2], rel=3e-3, abs=1e-4)


def test_cantilever_elastica_converges():
    """The elastica's error (P L^2 / EI = 5, tip deflection vs the BVP solution) falls with the
    element length at least at second order: 2, 4, 8 elements."""
    _, defl, _ = _elastica_bvp(5.0)
    errs = []
    for n in (2, 4, 8):
        m, q = _cantilever(n)
        L = m.rod.sigma[-1]
        q = _tip_loaded(m, q, (0.0, -5.0 * EI / L**2, 0.0))
        x = m.nodes(q)
        errs.append(abs((x[-1, 1] - x[0, 1]) / L - defl))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.8), (errs, orders)


def _arc_push(friction="none", mu=0.0, k_wall=1e7, frac=0.2, element=3e-3, angle=1.9 * np.pi,
              entry=0.04, approach=0.02, advances_mm=None, inc=1e-3):  # fmt: skip
    """A uniform rod (EI 5e-4, r_o 0.3 mm) pushed round a 13 mm arc in a 0.5 mm lumen."""
    ch = arc_channel(radius_m=0.013, angle_rad=angle, entry_m=entry, r_b_m=0.5e-3, r_a_m=0.45e-3)
    sc = scene(
        ch,
        rod(ei=EI, element=element),
        effects=Effects(friction=friction),
        contact=ContactParams(stiffness_n_m=k_wall, mu_k=mu, mu_s=mu, transition_max_fraction=frac),
        solver=SolverSettings(increment_m=inc, approach_m=approach),
        motion=Motion(),
        model=FLEX,
    )
    return simulate(sc, advances_mm)


def test_frictionless_insertion_force_long_arc():
    """Pushing a rod round an arc against the outer wall costs EI / (2 rho^2) per unit advance
    once the tip's shape no longer changes (energy balance, mechanics.md item 1): rho = R + c =
    13 + 0.2 mm, EI = 5e-4 N m^2 -> F = 1.4348 N. The push force with the tip 40-70 mm into the
    1.9 pi arc (77.6 mm long; the long-arc limit: it is constant there), 3 mm elements; within
    1 % (the rod sits in the contact transition zone, 0.2 c = 0.04 mm wide: rho uncertain by
    0.3 %, F by 0.6 %); with the tip 30 mm in it is still 1.3 % low. Its spread over those
    30 mm is below 1 % too (no element-passage ripple)."""
    adv = np.arange(80.0, 111.0, 5.0)
    res = _arc_push(advances_mm=adv)
    assert res.success, res.message
    expected = EI / (2 * 0.0132**2)
    assert res.push_force_n == pytest.approx(np.full(adv.size, expected), rel=0.01)


def test_capstan_with_bending_slope_is_mu():
    """Rod pushed round an arc with Coulomb friction mu = 0.2 (mechanics.md item 3): the first
    integral of the Kirchhoff rod in continuous contact makes F + EI / (2 rho^2) grow as
    exp(mu theta) with the wrapped angle; so the slope of ln(F + EI/(2 rho^2)) against the tip's
    wrap is mu, the slope of ln F alone is not. Fit over tip angles 90-300 degrees, 3 mm
    elements; slope within 5 % of mu (the rigid engine's test: 0.191). A short straight entry
    keeps the pushed rod from buckling before the arc."""
    mu = 0.2
    rho = 0.0132
    R = 0.013
    entry = 0.006
    angles = np.deg2rad(np.arange(90.0, 301.0, 15.0))
    adv = (entry + R * angles) * 1e3
    res = _arc_push("coulomb", mu, angle=1.95 * np.pi, entry=entry, approach=0.004,
                    advances_mm=adv)  # fmt: skip
    assert res.success, res.message
    tip = res.tip_pos_m
    theta = np.mod(np.arctan2(tip[:, 0] - entry, -(tip[:, 1] - R)), 2 * np.pi)
    F = res.push_force_n
    slope = np.polyfit(theta, np.log(F + EI / (2 * rho**2)), 1)[0]
    slope_plain = np.polyfit(theta, np.log(F), 1)[0]
    assert slope == pytest.approx(mu, rel=0.05)
    assert abs(slope_plain - mu) > 0.1 * mu


def test_contact_along_elements_keeps_the_rod_in_the_lumen():
    """Contact is sampled along each element, not only at the nodes (the paper's flexible model
    cut through the wall between nodes): 10 mm elements round a 13 mm arc in a 0.5 mm lumen
    (an element's chord would bow 10^2 / (8 x 13) = 0.96 mm, 5x the 0.2 mm clearance); the
    deepest sink of any sample into the wall stays below 10 % of the clearance."""
    res = _arc_push(element=10e-3, advances_mm=np.array([60.0, 90.0]))
    assert res.success, res.message
    assert res.max_penetration_m < 0.1 * 0.2e-3
    # and every node is inside the lumen too (not just the samples)
    centre = np.array([0.04, 0.013])
    x = res.nodes_m[-1]
    inside_arc = x[:, 0] > 0.04
    r = np.hypot(x[inside_arc, 0] - centre[0], x[inside_arc, 1] - centre[1])
    assert np.all(np.abs(r - 0.013) < 0.2e-3 * 1.1)


@pytest.mark.parametrize("n_el", [2, 5])
def test_twist_of_a_straight_rod_under_an_end_torque(n_el):
    """Torsion (``effects.torsion``): a straight rod clamped at its driven end (twist held 0),
    a twisting moment T about its axis at the free tip: the twist grows linearly along the rod,
    tip twist T L / GJ (Saint-Venant torsion of a uniform shaft; the twist DOF's energy is
    GJ/2 int phi'^2). L = 0.1 m, GJ = 4e-4 N m^2, T = 1e-3 N m -> 0.25 rad at the tip, 0.125
    rad at mid-length. Linear elements contain the exact (linear) twist, so 2 elements are exact;
    tolerance 1e-6 relative (Newton's moment tolerance is ~1e-10 N m). An isotropic rod's twist
    does not move its centreline: the nodes stay on the axis to 1e-12 m. With torsion off the
    state carries no twist unknown at all (6 per node)."""
    m, q = _cantilever(n_el, torsion=True)
    assert m.nd == 7 and q.size == 7 * m.n_nodes
    L = m.rod.sigma[-1]
    T = 1e-3
    m.f_ext[6] = T  # node 0 (the tip): x(3), t(3), phi
    st, _, _ = m.solve(q, 0.0, 0.0, q)
    assert st == 0
    phi = m.twist(q)
    assert phi[0] == pytest.approx(T * L / GJ, rel=1e-6)
    sig = m.rod.sigma
    free = sig <= L + 1e-12
    assert phi[free] == pytest.approx(T * (L - sig[free]) / GJ, rel=1e-6, abs=1e-9)
    x = m.nodes(q)
    assert np.max(np.abs(x[:, 1:])) < 1e-12
    off, _ = _cantilever(n_el)
    assert off.nd == 6 and off.n_all == 6 * off.n_nodes


def test_twist_under_an_end_torque_is_unchanged_by_large_bending():
    """The same end torque (a moment about the tip's tangent) with a large tip load P L^2 / EI =
    5 bending the rod 70 degrees: for an isotropic Kirchhoff rod the twisting moment GJ phi' is
    constant along the rod whatever its bending (the Bishop-frame twist decouples), so the tip
    twist is still T L / GJ = 0.25 rad, and the bent shape is the elastica's (the tip angle
    within 0.3 % of the BVP's 69.64 deg, as without torsion). 20 elements; twist within 1e-4."""
    m, q = _cantilever(20, torsion=True)
    L = m.rod.sigma[-1]
    T = 1e-3
    m.f_ext[6] = T
    q = _tip_loaded(m, q, (0.0, -5.0 * EI / L**2, 0.0))
    assert m.twist(q)[0] == pytest.approx(T * L / GJ, rel=1e-4)
    t0 = q[3:6] / np.linalg.norm(q[3:6])
    assert math.degrees(math.atan2(t0[1], -t0[0])) == pytest.approx(_elastica_bvp(5.0)[0],
                                                                    rel=3e-3)  # fmt: skip


@pytest.mark.slow
def test_torsion_agrees_with_the_rigid_engine_in_a_helix():
    """The shipped helix-torsion scene (Flexitron cable through a one-turn helix, Stribeck
    friction, torsion on) in both engines: the dwells agree within 0.1 mm and the push forces
    within 2 % of the peak (as without torsion: docs/engine.md), and torsion's effect on the
    dwells (torsion on minus off, through the friction moment and the twist slip) is the same
    in both engines within 25 % (it is small, ~2e-4 mm, but the same physics in two
    discretisations: the rigid engine's link twists and the flexible engine's element twists)."""
    from ringqa.simulation import load_scene, scene_with_overrides

    base = load_scene("data/scenes/helix-torsion.toml")
    got = {}
    for form in ("rigid", "flexible"):
        for tor in (True, False):
            sc = scene_with_overrides(base, {"model.formulation": form, "effects.torsion": tor})
            res = simulate(sc)
            assert res.success, res.message
            got[form, tor] = res
    assert got["flexible", True].settings["dof_per_node"] == 7
    assert "torsion" in got["flexible", True].settings["effects_assembled"]

    def dist(a, b):
        return np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1)

    assert np.max(dist(got["rigid", True], got["flexible", True])) < 0.1e-3
    peak = np.max(got["rigid", True].push_force_n)
    assert np.max(np.abs(got["rigid", True].push_force_n - got["flexible", True].push_force_n)) \
        < 0.02 * peak  # fmt: skip
    eff_r = np.max(dist(got["rigid", True], got["rigid", False]))
    eff_f = np.max(dist(got["flexible", True], got["flexible", False]))
    assert eff_r > 1e-8
    assert eff_f == pytest.approx(eff_r, rel=0.25)
