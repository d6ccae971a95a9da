"""The design: seeded, sample i depends on (seed, i) only, distributions as specified."""

from __future__ import annotations

import numpy as np

from ringqa.sweep.sampling import design, n_runs, sample_values
from ringqa.sweep.spec import spec_from_dict


def _spec(samples=8, method="random", **params):
    params = params or {
        "contact.mu_k": {"distribution": "uniform", "low": 0.1, "high": 0.3},
        "instrument.ei_scale": {"distribution": "lognormal", "median": 1.0, "sigma": 0.1},
        "lumen.diameter_delta_mm": {"distribution": "normal", "mean": 0.1, "sd": 0.05},
    }
    return spec_from_dict(
        {
            "input": "ring26x60",
            "samples": samples,
            "seed": 7,
            "method": method,
            "parameters": params,
        }
    )


def test_sample_depends_on_seed_and_index_only():
    """Rows of a 5-sample design equal the first 5 rows of a 20-sample design and each row
    equals sample_values(spec, i) computed alone: no dependence on the other samples (hence
    on which worker ran which batch)."""
    a, b = design(_spec(5)), design(_spec(20))
    np.testing.assert_array_equal(a, b[:5])
    np.testing.assert_array_equal(b[13], sample_values(_spec(20), 13))
    assert not np.array_equal(b[0], b[1])


def test_distributions_match_their_parameters():
    """4000 draws: uniform(0.1, 0.3) mean 0.2, sd 0.2/sqrt(12) = 0.0577; lognormal median 1 ->
    median of the draws 1 within 1 %; normal(0.1, 0.05). Standard error of a mean of 4000 draws
    is sd/63, so 4 standard errors are the tolerances."""
    x = design(_spec(4000)).astype(float)
    assert abs(x[:, 0].mean() - 0.2) < 4 * 0.0577 / 63
    assert abs(x[:, 0].std() - 0.0577) < 0.003
    assert x[:, 0].min() >= 0.1 and x[:, 0].max() <= 0.3
    assert abs(np.median(x[:, 1]) - 1.0) < 0.01
    assert abs(x[:, 2].mean() - 0.1) < 4 * 0.05 / 63


def test_grid_cycles_through_the_factorial():
    """Two grid parameters (2 x 3 = 6 combinations): sample i takes combination i mod 6, the
    first parameter varying slowest."""
    spec = _spec(
        12,
        **{
            "motion.backward": {"distribution": "grid", "values": [False, True]},
            "contact.mu_k": {"distribution": "grid", "values": [0.1, 0.2, 0.3]},
        },
    )
    rows = design(spec)
    assert [tuple(r) for r in rows[:6]] == [
        (False, 0.1),
        (False, 0.2),
        (False, 0.3),
        (True, 0.1),
        (True, 0.2),
        (True, 0.3),
    ]
    assert [tuple(r) for r in rows[6:]] == [tuple(r) for r in rows[:6]]


def test_sobol_design_size_and_seed():
    """SALib's Saltelli design without second order: N (D + 2) rows; same seed, same rows."""
    spec = _spec(8, method="sobol")
    x = design(spec)
    assert x.shape == (8 * (3 + 2), 3) == (n_runs(spec), 3)
    np.testing.assert_array_equal(x, design(spec))
    assert x[:, 0].min() >= 0.1 and x[:, 0].max() <= 0.3
