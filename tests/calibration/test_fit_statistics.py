"""The least squares and its statistics on a stand-in model with a known answer."""

from __future__ import annotations

import numpy as np
import pytest

from ringqa.calibration.fit import fit_parameters
from ringqa.calibration.measured import CalibrationError


class _Linear:
    """Positions linear in mu_k, independent of mu_s and EI: x_i = a_i (mu_k - 0.2)."""

    def __init__(self, a, measured_x, sd):
        from types import SimpleNamespace

        n = len(a)
        self.a = np.asarray(a, dtype=float)
        meas = np.zeros((n, 3))
        meas[:, 0] = measured_x
        self.measured = (SimpleNamespace(measured_mm=meas, used=np.ones(n, bool)),)
        self.sigma = [np.full(n, sd)]

    def base_values(self):
        return {"contact.mu_k": 0.2, "contact.mu_s": 0.25, "instrument.ei_scale": 1.0,
                "lumen.diameter_delta_mm": 0.0}  # fmt: skip

    def min_delta_mm(self):
        return -1.0

    def positions(self, values):
        pos = np.zeros((self.a.size, 3))
        pos[:, 0] = self.a * (values["contact.mu_k"] - 0.2)
        return [pos]


def test_linear_model_recovered_with_the_textbook_error():
    """x_i = a_i (mu_k - 0.2) with a = 2..20 mm per unit mu_k, data made at mu_k = 0.15 without
    noise: the fit returns 0.15, and SE(mu_k) = sd / sqrt(sum a_i^2) (weighted linear least
    squares; chi2 = 0 so no rescaling): 0.2 / sqrt(4+16+...+400 = 1540) = 5.10e-3 (less the
    forward difference's 2.5 %).
    mu_s and EI move nothing: identifiable false, errors infinite."""
    a = np.arange(2.0, 21.0, 2.0)
    model = _Linear(a, a * (0.15 - 0.2), 0.2)
    res = fit_parameters(model, ("contact.mu_k", "contact.mu_s", "instrument.ei_scale"),
                         model.sigma, workers=1)  # fmt: skip
    assert abs(res.values["contact.mu_k"] - 0.15) < 2e-5  # xtol 1e-4 on log(mu_k)
    # the Jacobian is a forward difference of 5 % in log(mu_k): its slope is
    # a mu_k (e^0.05 - 1) / 0.05 = 1.0254 a mu_k, so the SE is 2.5 % small (docs/calibration.md)
    expected = 0.2 / np.sqrt(np.sum(a**2)) / 1.0254
    assert res.se["contact.mu_k"] == pytest.approx(expected, rel=2e-3)
    assert res.identifiable == {"contact.mu_k": True, "contact.mu_s": False,
                                "instrument.ei_scale": False}  # fmt: skip
    assert np.isinf(res.se["contact.mu_s"]) and np.isinf(res.se["instrument.ei_scale"])


def test_too_few_points_refused_with_the_number_needed():
    model = _Linear([1.0, 2.0, 3.0, 4.0], np.zeros(4), 0.2)
    with pytest.raises(CalibrationError, match=r"4 measured point\(s\).*needs at least 5"):
        fit_parameters(model, ("contact.mu_k", "contact.mu_s", "instrument.ei_scale"),
                       model.sigma, workers=1)  # fmt: skip


def test_identifiable_key_on_a_bound_is_refused():
    """Data that want mu_k = 0.005 (below the searched 0.01) and determine it well (SE ~5e-5):
    the fit stops on the bound and says so instead of returning a precise-looking number. (A key
    the data barely determine may end on a bound: identifiable false, said in the notes.)"""
    a = np.arange(200.0, 2001.0, 200.0)
    model = _Linear(a, a * (0.005 - 0.2), 0.2)
    with pytest.raises(CalibrationError, match=r"bound of contact\.mu_k"):
        fit_parameters(model, ("contact.mu_k",), model.sigma, workers=1)


class _Jumping(_Linear):
    """The linear mu_k model plus an EI term: smooth (``x += b ln EI``, slopes equal on both
    sides) or with the solution jumping by ``jump`` mm in y at the fitted EI (EI > 1 + 1e-9),
    as a model with two equilibria does (measured with gravity on a soft ring: 0.6 mm)."""

    def __init__(self, a, measured_x, sd, b=0.0, jump=0.0):
        super().__init__(a, measured_x, sd)
        self.b, self.jump = b, jump

    def positions(self, values):
        (pos,) = super().positions(values)
        ei = values.get("instrument.ei_scale", 1.0)
        pos[:, 1] = self.b * np.log(ei) + (self.jump if ei > 1.0 + 1e-9 else 0.0)
        return [pos]


@pytest.mark.parametrize(("b", "jump", "smooth"), [(0.5, 0.0, True), (0.5, 0.6, False)])
def test_a_parameter_the_positions_jump_with_is_not_identifiable(b, jump, smooth):
    """EI fitted beside mu_k; data made at EI = 1 (the start). Smooth (y = 0.5 ln EI, SE of
    ln EI = 0.2 / (0.5 sqrt(10)) = 0.13: identifiable): its forward and backward slopes agree,
    ratio 1. With a 0.6 mm jump just above EI = 1, the forward difference sees a slope of
    0.6 / 0.05 + 0.5 = 12.5 mm per unit ln EI (a precise-looking SE of 0.2 / (12.5 sqrt(10)) =
    0.005), the backward one 0.5: ratio 25 > 3 -> identifiable false, and the notes say why;
    mu_k (smooth) stays identifiable either way."""
    from ringqa.calibration.fit import MAX_SLOPE_RATIO

    a = np.arange(2.0, 21.0, 2.0)
    model = _Jumping(a, a * (0.15 - 0.2), 0.2, b=b, jump=jump)
    res = fit_parameters(model, ("contact.mu_k", "instrument.ei_scale"), model.sigma, workers=1)
    ratio = res.slope_ratio["instrument.ei_scale"]
    assert res.identifiable["contact.mu_k"]
    assert res.slope_ratio["contact.mu_k"] < 1.1 and res.slope_cosine["contact.mu_k"] > 0.99
    if smooth:
        assert ratio < 1.01 and res.identifiable["instrument.ei_scale"]
    else:
        assert ratio == pytest.approx(25.0, rel=0.01) and ratio > MAX_SLOPE_RATIO
        assert not res.identifiable["instrument.ei_scale"]
        assert any("do not change smoothly" in n for n in res.notes)
