"""A parameter the positions do not determine is flagged (issue 26, must show)."""

from __future__ import annotations

import numpy as np

from ringqa.calibration.run import calibrate
from tests.calibration.conftest import STEM_MM, synthetic


def test_mu_s_alone_without_stick_is_not_identifiable():
    """The synthetic ring's cable slides at every dwell (no stick): the Stribeck peak mu_s
    never acts, so the weighted Jacobian's one column is zero and mu_s's error is infinite:
    identifiable false, and the value stays at its start (no precise-looking number)."""
    m = synthetic(noise_mm=0.0)
    cal = calibrate([m], keys=("contact.mu_s",), stem_mm=STEM_MM)
    f = cal.fit
    assert f.identifiable == {"contact.mu_s": False}
    assert np.isinf(f.se["contact.mu_s"])
    assert abs(f.values["contact.mu_s"] - f.start["contact.mu_s"]) < 1e-9
