"""The fitted covariance propagated with its correlations (issue 26, item 3).

``calibration_sweep.toml`` draws the identifiable fitted keys from one multivariate normal: the
means are the fitted values, the sds their standard errors and ``[correlation]`` the fit's
correlation matrix (sampled as ``mean + sd * (L z)``, ``L L^T = R``, z independent standard
normals; ringqa.sweep.sampling). Checked here on a fit result with a known covariance
(strong correlations, as mu_k and the lumen diameter have on a ring: both move the dwells
outwards).

Tolerance. For n independent draws of N(mu, Sigma) the unbiased sample covariance has
``Var(S_ij) = (Sigma_ij^2 + Sigma_ii Sigma_jj) / (n - 1)`` (Wishart moments; Anderson,
*An Introduction to Multivariate Statistical Analysis*, 3rd ed., section 7.2). With n = 4000 the
test allows 4 of these standard deviations per entry (six distinct entries: a chance of about
4e-4 that a correct sampler fails, and the seed is fixed). The same spec without its
``[correlation]`` (keys drawn independently, the old behaviour) gives sample correlations near 0
and misses the -0.8 entry by about 40 standard deviations.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ringqa.calibration.fit import FitResult
from ringqa.calibration.output import sweep_spec_text
from ringqa.calibration.run import Calibration
from ringqa.sweep import load_spec
from ringqa.sweep.sampling import design

KEYS = ("contact.mu_k", "instrument.ei_scale", "lumen.diameter_delta_mm")
VALUES = {"contact.mu_k": 0.18, "instrument.ei_scale": 1.1, "lumen.diameter_delta_mm": 0.12}
SE = np.array([0.012, 0.09, 0.05])
CORR = np.array([[1.0, 0.5, -0.8], [0.5, 1.0, -0.3], [-0.8, -0.3, 1.0]])
COV = CORR * np.outer(SE, SE)
N = 4000


def _calibration() -> Calibration:
    fit = FitResult(
        keys=KEYS, values=dict(VALUES), start=dict.fromkeys(KEYS, 0.0),
        se=dict(zip(KEYS, SE.tolist(), strict=True)), correlation=CORR,
        identifiable=dict.fromkeys(KEYS, True), chi2=10.0, dof=20, scale=1.0,
        singular_values=np.ones(3), positions_before=[], positions_after=[], nfev=3,
        message="", seconds=0.0, covariance=COV,
    )  # fmt: skip
    measured = (SimpleNamespace(input="ring26x60", label="ring26x60"),)
    return Calibration(measured=measured, cable="flexitron", fit=fit, numerical_error_mm=[],
                       sigma_mm=[], left_out=(), overrides={}, stem_mm=60.0, register="none",
                       seconds=0.0)  # fmt: skip


def _spec(tmp_path, text):
    path = tmp_path / "calibration_sweep.toml"
    path.write_text(text, encoding="utf-8")
    return load_spec(path, {"samples": N})


def test_drawn_parameters_have_the_fitted_covariance(tmp_path):
    """Sample covariance of 4000 drawn (mu_k, EI, lumen delta) within 4 standard errors of the
    fitted covariance, entry by entry (module docstring)."""
    spec = _spec(tmp_path, sweep_spec_text(_calibration()))
    assert spec.correlation is not None and spec.correlation.keys == KEYS
    x = np.asarray(design(spec), dtype=float)[:, [spec.names.index(k) for k in KEYS]]
    s = np.cov(x, rowvar=False)
    tol = 4.0 * np.sqrt((COV**2 + np.outer(np.diag(COV), np.diag(COV))) / (N - 1))
    assert np.all(np.abs(s - COV) <= tol), (s, COV, tol)
    mean_tol = 4.0 * SE / np.sqrt(N)
    assert np.all(np.abs(x.mean(axis=0) - [VALUES[k] for k in KEYS]) <= mean_tol)


def test_without_the_correlation_table_the_check_fails(tmp_path):
    """The independent draws (the spec without [correlation]) miss the -0.8 covariance of mu_k
    and the lumen delta by far more than the tolerance: the check above can fail."""
    text = sweep_spec_text(_calibration()).split("\n[correlation]")[0]
    spec = _spec(tmp_path, text)
    assert spec.correlation is None
    x = np.asarray(design(spec), dtype=float)[:, [spec.names.index(k) for k in KEYS]]
    s = np.cov(x, rowvar=False)
    tol = 4.0 * np.sqrt((COV[0, 2] ** 2 + COV[0, 0] * COV[2, 2]) / (N - 1))
    assert abs(s[0, 2] - COV[0, 2]) > 5 * tol  # about 40 sd off; the check allows 4


@pytest.mark.parametrize("identifiable", [(True, False, False), (True, True, False)])
def test_only_identifiable_keys_are_varied(tmp_path, identifiable):
    """A key the data do not determine is held (and left out of [correlation]); one varied key
    needs no correlation table."""
    cal = _calibration()
    ident = dict(zip(KEYS, identifiable, strict=True))
    cal = Calibration(**{**cal.__dict__, "fit": FitResult(**{**cal.fit.__dict__,
                                                              "identifiable": ident})})  # fmt: skip
    spec = _spec(tmp_path, sweep_spec_text(cal))
    varied = tuple(k for k in KEYS if ident[k])
    assert spec.names == varied
    assert (spec.correlation is None) == (len(varied) == 1)
