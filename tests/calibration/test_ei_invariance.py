"""Why the dwell positions cannot determine the cable's bending stiffness EI (issue 26).

The physics (docs/calibration.md, "Why EI is not identifiable"). In the quasi-static model
without gravity every force is either proportional to EI or set by the wall:

- bending: hinge springs ``EI / l`` times the hinge angle (proportional to EI);
- wall contact: the three-region law ``F = k w z^2 / 2`` (``0 < z <= 1``), ``k w (z - 1/2)``
  beyond, ``z = p / w`` with ``p`` the penetration beyond ``r_a - r_o`` and ``w`` the
  transition width (proportional to the wall stiffness ``k``, not EI);
- friction: ``mu(v) N`` with the slip velocity from the geometry (proportional to N);
- the axial penalty EA = 1e6 N (strain ~1e-6 at 1 N: 0.1 um per 100 mm, negligible);
- the push is a prescribed displacement, not a force.

So multiplying EI AND k by the same alpha multiplies every force by alpha and leaves the same
configuration in equilibrium: the positions are exactly invariant (test 1). With k fixed, EI x
alpha equals EI x 1 with the wall k / alpha: the only change is the penetration needed to carry
the alpha-times larger contact forces. The law is convex with F(0) = 0, so F(alpha p) >=
alpha F(p) and the new penetration is at most alpha p: each contact point sinks at most
``(alpha - 1) p_max`` deeper. A source point moves by that sideways, plus the extra cable the
deeper path takes up along the way: sitting ``dp`` further out on a bend of turning angle
``Theta`` lengthens the path by ``dp Theta``, which the fixed advance takes from the source's
progress. Hence (test 2)

    |x(alpha EI) - x(EI)| <= (alpha - 1) p_max (1 + Theta)

with ``Theta`` the channel's total turning angle from the driven end to the most proximal
measured point's advance and ``p_max`` the penetration that carries the largest sample force:
a contact sample's force ``F_s`` is shared between the two nodes of its link (fractions alpha,
1 - alpha), so ``F_s <= 2 max F_node``, and ``p(F) = sqrt(2 w F / k)`` for ``F <= k w / 2``,
``F / k + w / 2`` beyond (the largest ``w = r_b - r_a`` of the lumen: the kernel only narrows
it). On ring26x60 (Flexitron, 9 film points): F_node max 0.42 N, w = 0.1 mm, k = 1e5 N/m ->
p_max = sqrt(2 * 1e-4 * 0.84 / 1e5) = 41 um; Theta = 6.0 rad (the 264 deg ring plus the
stem's bend and the spline's wiggle); bound 0.25 * 41 um * 7.0 = 0.072 mm; measured
0.002-0.005 mm (the quadratic zone gives sqrt(1.25) - 1 = 0.118 of p rather than 0.25, and
not every contact is at p_max).

Gravity adds the weight ``m g`` (not proportional to EI): with the cable's real mass
(1.5-4.5 g/m, 0.015-0.044 N/m) against contact forces of 0.1-0.4 N per node it moves the
EI x 1.25 difference by at most 0.001 mm on this ring, in the ring plane or normal to it
(test 3; docs/calibration.md has the table).
"""

from __future__ import annotations

import numpy as np

from ringqa.calibration.model import ForwardModel
from ringqa.pipeline.simulate import default_engine
from tests.calibration.conftest import STEM_MM, TRUTH, synthetic

BASE = {"contact.mu_k": TRUTH["contact.mu_k"], "contact.mu_s": TRUTH["contact.mu_s"]}
K_WALL = 1.0e5  # the Flexitron preset's wall stiffness, N/m (paper Table 1)


def _run(overrides, values):
    """The 9 film points of ring26x60 (mm) and the engine's result."""
    m = synthetic(noise_mm=0.0)
    fm = ForwardModel((m,), "flexitron", overrides, STEM_MM)
    target = fm._targets()[0]
    scene = fm.scene(0, values)
    res = default_engine().simulate(scene, advances_mm=target.advances_mm, progress=False)
    assert res.status == 0, res.message
    pos = np.asarray(res.source_pos_m, dtype=float)[target.rows] * 1e3
    return pos, res, target, scene


def _penetration_m(force_n: float, w_m: float, k: float) -> float:
    """Inverse of the three-region law (module docstring)."""
    if force_n <= k * w_m / 2:
        return float(np.sqrt(2.0 * w_m * force_n / k))
    return force_n / k + w_m / 2


def test_ei_and_wall_stiffness_scaled_together_leave_the_dwells_unchanged():
    """EI x 1.25 with k x 1.25: every force scales by 1.25, the same configuration is in
    equilibrium; the dwells agree to the solver's tolerance (Newton tol 1e-8 on the residual:
    nanometres; measured 1.4e-5 mm), against 0.005 mm when EI alone changes. Tolerance
    1e-4 mm: 50x below the EI-alone change, so a force not scaled with EI (a bug in
    instrument.ei_scale) would fail it."""
    a, *_ = _run({}, {**BASE, "instrument.ei_scale": 1.0})
    b, *_ = _run({"contact.stiffness_n_m": 1.25 * K_WALL}, {**BASE, "instrument.ei_scale": 1.25})
    c, *_ = _run({}, {**BASE, "instrument.ei_scale": 1.25})
    assert np.max(np.linalg.norm(b - a, axis=1)) < 1e-4
    assert np.max(np.linalg.norm(c - a, axis=1)) > 1e-3  # EI alone does move them (a little)


def test_ei_alone_moves_the_dwells_no_more_than_the_wall_penetration_allows():
    """Gravity off, EI x 1.25 vs x 1: every dwell within (alpha - 1) p_max (1 + Theta)
    (module docstring's derivation, p_max from the run's own largest node force)."""
    alpha = 1.25
    a, res, target, _scene = _run({}, {**BASE, "instrument.ei_scale": 1.0})
    b, *_ = _run({}, {**BASE, "instrument.ei_scale": alpha})
    lumen = target.channel.lumen
    w_m = float(np.max(np.asarray(lumen.seg_rb) - np.asarray(lumen.seg_ra)))
    f_max = float(np.max(np.abs(res.contact_force_n)))
    p_max = _penetration_m(2.0 * f_max, w_m, K_WALL)
    cl = target.channel.centreline
    s = np.linspace(0.0, target.channel.s_ref_m, 4000)
    tan = cl.tangent(s)
    theta = float(np.sum(np.arccos(np.clip(np.sum(tan[1:] * tan[:-1], axis=1), -1.0, 1.0))))
    bound_mm = (alpha - 1.0) * p_max * (1.0 + theta) * 1e3
    moved = np.linalg.norm(b - a, axis=1)
    assert 0.01 < bound_mm < 0.2, (bound_mm, p_max, theta)  # the docstring's 0.072 mm
    assert np.all(moved <= bound_mm), (moved, bound_mm)


def test_gravity_with_the_real_cable_mass_does_not_make_ei_visible():
    """Gravity on (real masses, 9.81 m/s^2 normal to the ring plane and in it): EI x 1.25
    still moves the film points by less than 0.01 mm, 20x below the 0.2 mm film/CT noise
    (so a fit's standard error of ln EI stays > 1: identifiable false). Measured: 0.0015-0.0061
    mm (normal), 0.0023-0.0051 mm (in plane), 0.0019-0.0053 mm without gravity."""
    for g in ([0.0, 0.0, 9.80665], [9.80665, 0.0, 0.0]):
        over = {"effects.gravity": True, "effects.gravity_m_s2": g, "instrument.real_mass": True}
        a, *_ = _run(over, {**BASE, "instrument.ei_scale": 1.0})
        b, *_ = _run(over, {**BASE, "instrument.ei_scale": 1.25})
        assert np.max(np.linalg.norm(b - a, axis=1)) < 0.01, g
