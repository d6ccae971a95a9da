"""The contact's skip of far samples (``ContactArgs.skip_far``): a sample that was out of contact
by the gap g at its last exact evaluation and has moved less than g / FAR_SAFETY since is not
searched again; it must contribute exactly what the full evaluation gives (nothing)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ringqa.simulation.analytic import arc_channel
from ringqa.simulation.effects.contact import FAR_SAFETY, ContactArgs
from ringqa.simulation.scene import Effects, SolverSettings
from tests.simulation.builders import assemble_at, model, rod, scene


def _model(effects):
    ch = arc_channel(
        radius_m=0.013, angle_rad=1.9 * np.pi, entry_m=0.04, r_b_m=0.5e-3, r_a_m=0.45e-3
    )
    return model(scene(ch, rod(), effects=effects, solver=SolverSettings(axial_stiffness_n=1.0)),
                 0.06)  # fmt: skip


def _no_skip(effects):
    return tuple(e._replace(skip_far=False) if isinstance(e, ContactArgs) else e for e in effects)


def _positions(m, q):
    sw = m.samples
    x = q.reshape(m.n_nodes, m.nd)[:, :3]
    a = sw.alpha[:, None]
    return (1 - a) * x[sw.link] + a * x[sw.link + 1]


def test_skipped_samples_give_the_full_residual_and_jacobian():
    """From an exact evaluation at q0 (partly in contact: the chain laid on the centreline and
    perturbed by 0.1 mm), move the free nodes by ~5 um (q1): samples out of contact by more
    than FAR_SAFETY x their move are skipped (they keep their q0 position in ``samp_p``); the
    residual and Jacobian at q1 equal those of the full evaluation at q1 (every sample searched
    from the same hints) to 1e-12 of their largest entries (the skipped samples' hints are
    stale, which moves the others' nothing and their own results not at all: they carry no
    force)."""
    m = _model(Effects(friction="stribeck"))
    rng = np.random.default_rng(3)
    q0 = m.initial_state(0.05)
    m.prescribe(q0, 0.05)
    qp = q0.copy()
    q0 = q0 + rng.normal(scale=1e-4, size=q0.shape)
    st = m.step(qp, np.zeros(m.n_all), 1e-3)
    assemble_at(m, m.effects, q0, st)  # the exact evaluation (reference of the skip test)
    sw = m.samples
    hints = sw.s.copy()
    p0 = sw.p.copy()
    gap = -sw.z * sw.w
    q1 = q0.copy()
    q1[: m.n_free] += rng.normal(scale=3e-6, size=m.n_free)
    moved = np.linalg.norm(_positions(m, q1) - p0, axis=1)
    expect_skip = (sw.z < 0) & (moved < gap / FAR_SAFETY)
    expect_skip[0] = False  # the tip sample is always searched (the jam monitor reads its s)
    r_skip, B_skip = assemble_at(m, m.effects, q1, st)
    skipped = np.all(sw.p == p0, axis=1) & (moved > 0)  # (samples on the driven nodes stay)
    np.testing.assert_array_equal(skipped, expect_skip & (moved > 0))
    assert expect_skip.sum() >= 10  # the case exercises the skip ...
    n_contact = int(np.sum(sw.F > 0))
    assert n_contact >= 3  # ... next to samples in contact
    sw.s[:] = hints
    r_full, B_full = assemble_at(m, _no_skip(m.effects), q1, st)
    assert np.all(sw.F[expect_skip] == 0.0)  # what the skip assumed, checked exactly
    assert np.max(np.abs(r_skip - r_full)) <= 1e-12 * np.max(np.abs(r_full))
    assert np.max(np.abs(B_skip - B_full)) <= 1e-12 * np.max(np.abs(B_full))


@pytest.mark.parametrize(("damping", "c_w", "refresh"), [(False, 10.0, False), (True, 10.0, True),
                                                      (True, 0.0, False)])  # fmt: skip
def test_skip_with_wall_damping_refreshes_the_distance_history(damping, c_w, refresh):
    """The contact always skips far samples; with wall damping (c_w != 0: it reads every sample's
    distance history, which a skipped sample does not update) the model refreshes the skipped
    samples' distances after every solved step (with c_w = 0 damping adds exact zeros)."""
    from ringqa.simulation.scene import ContactParams

    ch = arc_channel(radius_m=0.013, angle_rad=np.pi, entry_m=0.04)
    sc = scene(ch, rod(), effects=Effects(friction="none", wall_damping=damping),
               contact=ContactParams(damping_ns_m=c_w))  # fmt: skip
    m = model(sc, 0.06)
    (contact,) = [e for e in m.effects if isinstance(e, ContactArgs)]
    assert contact.skip_far is True
    assert m._refresh_far is refresh


def test_damped_dynamic_run_with_skipping_equals_the_full_evaluation(monkeypatch):
    """Stress scene 42 (dynamic BDF2, Coulomb friction, wall damping, stepwise pauses; the
    shipped 26 mm ring in a 1.05 mm lumen), its first 10 mm: with far samples skipped and their
    distances refreshed after every step, the run is the run that evaluates every sample, to
    round-off (1e-12 m) with the same Newton iterations. Without the refresh the stale distance
    history changes wall damping at the next contact and the dwells move by ~3e-5 m here (measured:
    0.029 mm on the whole scene), so the test fails for a skip without the refresh."""
    from ringqa.simulation import simulate
    from ringqa.simulation.effects.contact import Contact
    from ringqa.simulation.scenefile import load_scene
    from tests.simulation.solvers.test_stress_regressions import STRESS_42

    data = {**STRESS_42, "motion": {**STRESS_42["motion"], "span_mm": 10.0}}
    skipping = simulate(load_scene(data))
    build = Contact.build.__func__

    def no_skip(cls, ctx):
        unit = build(cls, ctx)
        return None if unit is None else dataclasses.replace(unit, skip_far=False)

    monkeypatch.setattr(Contact, "build", classmethod(no_skip))
    full = simulate(load_scene(data))
    assert skipping.status == full.status == 0
    assert np.max(np.abs(skipping.source_pos_m - full.source_pos_m)) <= 1e-12
    assert skipping.stats.n_newton_iters == full.stats.n_newton_iters
