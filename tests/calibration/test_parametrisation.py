"""The fit's coordinates keep every parameter in its physical range (issue 26: mu_s < mu_k and
EI <= 0 are never tried)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from ringqa.calibration.model import DEFAULT_KEYS, Parametrisation

START = {"contact.mu_k": 0.2, "contact.mu_s": 0.25, "instrument.ei_scale": 1.0,
         "lumen.diameter_delta_mm": 0.0}  # fmt: skip


def _par(keys=DEFAULT_KEYS):
    return Parametrisation.build(keys, START, -1.0)


@given(st.lists(st.floats(-30, 30), min_size=3, max_size=3))
def test_any_theta_gives_physical_values(theta):
    v = _par().values(np.array(theta))
    assert v["contact.mu_s"] >= v["contact.mu_k"] > 0
    assert v["instrument.ei_scale"] > 0


def test_round_trip_and_gradient():
    """theta(values(theta)) = theta; the transform's gradient equals central differences
    (step 1e-6: truncation error ~1e-12 relative)."""
    par = _par()
    theta = np.array([np.log(0.15), np.log(0.19 / 0.15 - 1), np.log(1.25)])
    values = par.values(theta)
    assert abs(values["contact.mu_s"] - 0.19) < 1e-12
    np.testing.assert_allclose(par.theta(values), theta, atol=1e-12)
    g = par.gradient(theta)
    num = np.zeros((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-6
        hi, lo = par.values(theta + e), par.values(theta - e)
        num[:, j] = [(hi[k] - lo[k]) / 2e-6 for k in DEFAULT_KEYS]
    np.testing.assert_allclose(g, num, rtol=1e-6, atol=1e-9)


def test_mu_k_alone_stays_below_the_cable_mu_s():
    par = _par(("contact.mu_k",))
    assert np.exp(par.upper[0]) <= START["contact.mu_s"] + 1e-15
