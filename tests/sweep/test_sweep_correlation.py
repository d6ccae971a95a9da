"""Correlated normal parameters in a sweep spec (``[correlation]``): refusals, and the identity
matrix drawing the same numbers as independent draws."""

from __future__ import annotations

import pytest

from ringqa.sweep import SweepSpecError
from ringqa.sweep.sampling import sample_values
from ringqa.sweep.spec import spec_from_dict


def _data(matrix, keys=("contact.mu_k", "instrument.ei_scale"), method="random", dist="normal"):
    params = {
        "contact.mu_k": {"distribution": "normal", "mean": 0.2, "sd": 0.02},
        "instrument.ei_scale": (
            {"distribution": "normal", "mean": 1.0, "sd": 0.1}
            if dist == "normal" else {"distribution": "uniform", "low": 0.8, "high": 1.2}
        ),
        "contact.mu_s": {"distribution": "normal", "mean": 0.3, "sd": 0.01},
    }  # fmt: skip
    out = {"input": "ring26x60", "samples": 8, "seed": 3, "method": method,
           "parameters": params}  # fmt: skip
    if matrix is not None:
        out["correlation"] = {"keys": list(keys), "matrix": matrix}
    return out


def test_identity_matrix_draws_the_independent_numbers():
    """With R = I (L = I) every sample equals the spec without [correlation]: numpy's
    ``normal(mean, sd)`` is ``mean + sd * standard_normal()`` on the same stream."""
    a = spec_from_dict(_data([[1.0, 0.0], [0.0, 1.0]]))
    b = spec_from_dict(_data(None))
    for i in range(8):
        assert sample_values(a, i) == sample_values(b, i)


def test_full_correlation_gives_proportional_draws():
    """r = -1: the EI draw's standard score is minus mu_k's in every sample (semi-definite
    matrix: factored through its eigen-decomposition)."""
    spec = spec_from_dict(_data([[1.0, -1.0], [-1.0, 1.0]]))
    for i in range(8):
        mu_k, ei, _ = sample_values(spec, i)
        assert (ei - 1.0) / 0.1 == pytest.approx(-(mu_k - 0.2) / 0.02, abs=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"matrix": [[1.0, 0.5], [0.4, 1.0]]}, "not symmetric"),
        ({"matrix": [[1.0, 1.5], [1.5, 1.0]]}, "not a correlation matrix"),
        ({"matrix": [[2.0, 0.0], [0.0, 1.0]]}, "diagonal must be 1"),
        ({"matrix": [[1.0, 0.0]]}, "2 x 2 table"),
        ({"matrix": [[1.0, 0.0], [0.0, 1.0]], "dist": "uniform"}, "not a varied parameter with"),
        ({"matrix": [[1.0, 0.0], [0.0, 1.0]], "keys": ("contact.mu_k",)}, "two or more"),
        ({"matrix": [[1.0, 0.0], [0.0, 1.0]], "method": "sobol"}, 'method = "random"'),
    ],
)
def test_bad_correlation_refused_naming_the_field(kwargs, match):
    with pytest.raises(SweepSpecError, match=match):
        spec_from_dict(_data(**kwargs), "spec.toml")


def test_unknown_field_of_the_table_refused():
    data = _data([[1.0, 0.0], [0.0, 1.0]])
    data["correlation"]["rho"] = 0.5
    with pytest.raises(SweepSpecError, match=r"correlation\.rho"):
        spec_from_dict(data, "spec.toml")
