"""simulate()/SimResult contract: columns, shapes, statuses, switched-off effects leave no trace."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ringqa.errors import SimulationError
from ringqa.simulation import SimResult, simulate
from ringqa.simulation.result import DWELL_COLUMNS
from ringqa.simulation.scene import ContactParams, Effects, Motion, Outputs, SolverSettings
from tests.simulation.builders import flexitron, model, ring_channel, scene

ADV = np.array([70.0, 60.0, 80.0])


@pytest.fixture(scope="module")
def ring():
    return ring_channel()


def test_result_contract(ring):
    """One row per requested advance, in the requested order; the dwell table's contract
    columns; offsets, s and directions consistent with the positions."""
    res = simulate(scene(ring, flexitron(), effects=Effects(friction="stribeck")), ADV)
    assert isinstance(res, SimResult) and res.success and res.status == 0
    n = ADV.size
    assert res.source_pos_m.shape == (n, 3) and res.source_dir.shape == (n, 3)
    assert res.contact_force_n.shape == (n, res.n_elements + 1)
    np.testing.assert_allclose(np.linalg.norm(res.source_dir, axis=1), 1.0, atol=1e-12)
    df = res.dwell_table()
    assert tuple(df.columns[: len(DWELL_COLUMNS)]) == DWELL_COLUMNS
    np.testing.assert_array_equal(df["advance_mm"], ADV)
    # source 2.4 mm behind the tip along the capsule axis
    np.testing.assert_allclose(
        res.tip_pos_m - res.source_pos_m, 2.4e-3 * res.source_dir, atol=1e-12
    )
    # the s/offset columns describe the source centre: |pos - c(s)| = offset
    from ringqa.simulation.channel import ChannelTable

    tb = ChannelTable.from_channel(ring)
    for p, s, off in zip(res.source_pos_m, res.s_m, res.offset_m, strict=True):
        assert np.linalg.norm(p - tb.point(s)) == pytest.approx(off, abs=1e-9)
    # the source is near (not necessarily behind: a thin cable can bow to the inner wall
    # between contacts) where the centreline model would put it
    assert np.all(np.abs(res.s_m * 1e3 - ADV) < 2.0)
    assert res.solve_time_s > 0 and res.settings["n_nodes"] == res.n_elements + 1
    assert {"input", "elastic", "friction", "balance_error"} <= set(res.work)


def test_no_advances_is_an_error(ring):
    with pytest.raises(SimulationError, match="advances"):
        simulate(scene(ring, flexitron()), [])


def test_trajectory_on_request(ring):
    sc = scene(ring, flexitron(), outputs=Outputs(trajectory=True))
    res = simulate(sc, [30.0])
    tr = res.trajectory
    assert tr["nodes_m"].shape[1:] == (res.n_elements + 1, 3)
    assert tr["advance_m"].shape == tr["push_force_n"].shape == (tr["nodes_m"].shape[0],)
    assert tr["advance_m"][-1] == pytest.approx(0.03)


def _same(a, b):
    for f in ("source_pos_m", "source_dir", "tip_pos_m", "push_force_n", "nodes_m"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    np.testing.assert_array_equal(a.newton_iters, b.newton_iters)


def test_switched_off_effects_leave_no_trace(ring):
    """An effect switched on with a zero coefficient gives bit-identical results to the effect
    switched off (so the off path really skips it and the on path adds nothing else):
    gravity (0, 0, 0) vs None; wall damping c_w = 0 vs off; Coulomb friction mu = 0 vs none
    (both with zero-damping on, so both take the same load steps)."""
    base = scene(ring, flexitron(), effects=Effects(friction="stribeck"))
    on = base.replace(effects=Effects(friction="stribeck", gravity_m_s2=(0.0, 0.0, 0.0)))
    _same(simulate(base, ADV), simulate(on, ADV))
    on = base.replace(effects=Effects(friction="stribeck", wall_damping=True),
                      contact=ContactParams(damping_ns_m=0.0))  # fmt: skip
    _same(simulate(base, ADV), simulate(on, ADV))
    zero_c = ContactParams(damping_ns_m=0.0, mu_s=0.0, mu_k=0.0)
    off = base.replace(effects=Effects(friction="none", wall_damping=True), contact=zero_c)
    on = base.replace(effects=Effects(friction="coulomb", wall_damping=True), contact=zero_c)
    _same(simulate(off, ADV), simulate(on, ADV))


def test_torsion_without_friction_changes_nothing(ring):
    """Without friction the twist decouples: torsion on (4 DOFs per node) gives the same chain
    as torsion off (3 DOFs) to round-off (a different elimination order in the banded solve)."""
    off = scene(ring, flexitron(), effects=Effects(friction="none"))
    on = off.replace(effects=Effects(friction="none", torsion=True))
    a, b = simulate(off, ADV), simulate(on, ADV)
    assert a.settings["dof_per_node"] == 3 and b.settings["dof_per_node"] == 4
    np.testing.assert_allclose(a.source_pos_m, b.source_pos_m, atol=1e-9)


def test_dynamic_solver_reports_step_and_matches_quasistatic_roughly(ring):
    """Backward-Euler dynamics at 0.5 m/s with the paper's scaled mass: dwell positions within
    1 mm of the quasi-static ones (inertia small by design of the paper's scaling), and the time
    step used is reported."""
    qs = scene(ring, flexitron(), effects=Effects(friction="stribeck"))
    dyn = qs.replace(
        effects=Effects(friction="stribeck", inertia=True, wall_damping=True),
        solver=SolverSettings(kind="dynamic", time_step_s=1e-3),
        motion=Motion(speed_m_s=0.5),
    )
    a, b = simulate(qs, ADV), simulate(dyn, ADV)
    assert b.success and b.settings["time_step_s"] == 1e-3
    assert np.max(np.linalg.norm(a.source_pos_m - b.source_pos_m, axis=1)) < 1e-3
    # trapezoidal input velocity: D / V + the 10 ms ramp (accelerate + decelerate), to a step
    assert b.settings["simulated_time_s"] == pytest.approx((0.08 + 2.4e-3) / 0.5 + 0.01, abs=2e-3)


def test_bdf2_integrator_is_recorded_and_closes_the_work_balance(ring):
    """``solver.integrator = "bdf2"``: recorded in the settings (run.json), dwells within 0.5 mm of
    backward Euler's at dt = 1 ms (measured: 5 um at 60 and 70 mm, 0.27 mm at 80 mm, the final
    stop, where the cable arrives still moving in stick-slip and both integrators scatter by
    ~0.1-0.2 mm down to dt = 31 us), and its work balance closes better (0.7 % vs 3.1 %: less
    numerical dissipation; friction and damping work are taken over the actual step
    displacement). Quasi-static runs ignore it with a warning and give bit-identical results."""
    dyn = scene(ring, flexitron(), effects=Effects(friction="stribeck", inertia=True,
                wall_damping=True), solver=SolverSettings(kind="dynamic", time_step_s=1e-3),
                motion=Motion(speed_m_s=0.5))  # fmt: skip
    be = simulate(dyn, ADV)
    bdf = simulate(dyn.replace(solver=dataclasses.replace(dyn.solver, integrator="bdf2")), ADV)
    assert be.success and bdf.success
    assert be.settings["solver"]["integrator"] == "backward_euler"
    assert bdf.settings["solver"]["integrator"] == "bdf2"
    assert np.max(np.linalg.norm(be.source_pos_m - bdf.source_pos_m, axis=1)) < 0.5e-3
    assert bdf.work["balance_error"] < be.work["balance_error"]
    assert bdf.work["balance_error"] < 0.01
    qs = scene(ring, flexitron(), effects=Effects(friction="stribeck"))
    a = simulate(qs, ADV)
    b = simulate(qs.replace(solver=SolverSettings(integrator="bdf2")), ADV)
    np.testing.assert_array_equal(a.source_pos_m, b.source_pos_m)
    assert any("integrator" in w for w in b.warnings)


def test_a_model_assembles_only_the_effects_its_scene_calls_for(ring):
    """ "Simulate only the effects a scene calls for": the assembled tuple holds exactly the
    switched-on effects, in assembly order (plus the solver's tether), and nothing else is
    called or compiled for it."""
    base = ["inextensibility", "bending"]
    cases = [
        (Effects(friction="none", contact=False), SolverSettings(), [*base, "tether"]),
        (Effects(friction="stribeck"), SolverSettings(), [*base, "contact", "friction", "tether"]),
        (
            Effects(friction="coulomb", torsion=True, wall_damping=True,
                    gravity_m_s2=(0.0, -9.81, 0.0)),
            SolverSettings(kind="dynamic"),
            [*base, "torsion", "contact", "wall_damping", "friction", "gravity", "inertia",
             "tether"],
        ),
    ]  # fmt: skip
    for eff, solver, want in cases:
        m = model(scene(ring, flexitron(), effects=eff, solver=solver), 0.08)
        assert list(m.names) == want
        assert [type(a).__name__ for a in m.effects] == [type(u.args()).__name__ for u in m.units]


@pytest.mark.parametrize("torsion", [False, True])
def test_step_work_is_taken_over_the_actual_displacement(ring, torsion):
    """A BDF2 step solves against a modified history: friction's velocity comes from
    ``q - q_hist``, but its work must be taken over the step's actual slip ``q - q_start``
    (and wall damping's over the actual change of distance). Checked against the friction law
    evaluated here from the samples the kernel left: W = sum_i F_i phi(|v_i|) v_i . w_i, v the
    tangential slip from the history over dt, w the tangential slip from the start; and
    W_damp = sum_i c_w sh(z_i) v_n,i (d_i - d_start,i)."""
    from ringqa.simulation.effects.friction import friction_phi
    from ringqa.simulation.solvers.driver import initial_equilibrium

    eff = Effects(friction="stribeck", inertia=True, wall_damping=True, torsion=torsion)
    sc = scene(ring, flexitron(), effects=eff, solver=SolverSettings(kind="dynamic"),
               motion=Motion(speed_m_s=0.5, start_m=0.07))  # fmt: skip
    m = model(sc, 0.08)
    u, dt = m.u_start, 1e-3
    q = m.initial_state(u)
    m.prescribe(q, u)
    v = np.zeros(m.n_all)
    assert initial_equilibrium(m, q, v, dt)[0] == 0
    m.d_prev[:] = m.samples.d
    q_n = q.copy()
    q_hist = q_n - 0.3e-3 * (np.arange(m.n_all) % m.nd == 0)  # a history 0.3 mm behind along x
    d_hist = m.d_prev - 1e-6
    q = q + 0.5e-3 * (np.arange(m.n_all) % m.nd == 0)
    m.predict(q, 0.5e-3, u + 0.5e-3, False)
    st = m.step(q_hist, v, dt, q_ref=q.copy(), q_start=q_n, d_hist=d_hist)
    assert m.solve(m.effects, q, st)[0] == 0
    sw = m.samples
    fr = m.unit("friction")
    nd = m.nd
    w_fr = 0.0
    for i in np.flatnonzero(sw.F > 0):
        j, al = sw.link[i], sw.alpha[i]
        n = sw.n[i]

        def tangential(qq, j=j, al=al, n=n, i=i):
            w = sw.p[i] - (
                (1 - al) * qq[nd * j : nd * j + 3] + al * qq[nd * j + nd : nd * j + nd + 3]
            )
            w = w - (w @ n) * n
            if torsion:
                t = q[nd * j + nd : nd * j + nd + 3] - q[nd * j : nd * j + 3]
                tau = np.cross(t / np.linalg.norm(t), n)
                dphi = (1 - al) * (q[nd * j + 3] - qq[nd * j + 3]) + al * (
                    q[nd * j + nd + 3] - qq[nd * j + nd + 3]
                )
                w = w + sw.ro[i] * dphi * tau
            return w

        vel = tangential(q_hist) / dt
        phi, _ = friction_phi(np.linalg.norm(vel), fr.law, fr.mu_s, fr.mu_k, fr.v_brk,
                              max(fr.v_reg, fr.slip_min / dt))  # fmt: skip
        w_fr += sw.F[i] * phi * vel @ tangential(q_n)
    assert w_fr != 0
    assert m.work_of("friction") == pytest.approx(w_fr, rel=1e-9)
    c_w = m.unit("wall_damping").c_w
    z = sw.z
    sh = np.where(z <= 1.0, (3 - 2 * z) * z * z, 1.0)
    w_d = np.sum(np.where(z > 0, c_w * sw.wt * sh * (sw.d - d_hist) / dt * (sw.d - m.d_prev), 0.0))
    assert w_d != 0
    assert m.work_of("wall_damping") == pytest.approx(w_d, rel=1e-9)


def test_dynamic_start_is_ramped_not_an_impulse(ring):
    """The input starts from rest on a 10 ms ramp: the largest push force over the run does not
    grow as 1/dt (a jump to 0.5 m/s in one step would push the cable's mass with ~ m v / dt).
    dt 1 ms and 0.1 ms: peak push forces within a factor 1.5."""
    peaks = []
    for dt in (1e-3, 1e-4):
        sc = scene(ring, flexitron(), effects=Effects(friction="stribeck", inertia=True),
                   solver=SolverSettings(kind="dynamic", time_step_s=dt),
                   outputs=Outputs(trajectory=True))  # fmt: skip
        res = simulate(sc, [20.0])
        assert res.success
        peaks.append(float(np.max(res.trajectory["push_force_n"])))
    assert max(peaks) / min(peaks) < 1.5


def test_newton_failure_is_a_status_not_an_exception(ring):
    """max_iter = 1 cannot converge: status -1, message says where, rows NaN."""
    sc = scene(ring, flexitron(), solver=SolverSettings(max_iter=1, tol=1e-14))
    res = simulate(sc, ADV)
    assert res.status == -1 and "did not converge" in res.message
    assert np.all(np.isnan(res.push_force_n))


def test_scene_errors_name_the_key(ring):
    """A bad setting is refused where the scene is built (the dataclass checks itself against
    its scene key) and the error names the key as written in a scene file."""
    from ringqa.errors import SceneError

    with pytest.raises(SceneError, match=r"effects\.friction"):
        scene(ring, flexitron(), effects=Effects(friction="sticky"))
    with pytest.raises(SceneError, match=r"solver\.increment_mm"):
        dataclasses.replace(SolverSettings(), increment_m=0.0)
