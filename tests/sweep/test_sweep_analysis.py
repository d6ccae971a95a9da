"""summary.csv and sensitivity.csv from stored samples (synthetic samples: numbers by hand)."""

from __future__ import annotations

import numpy as np

from ringqa.sweep.analysis import SUMMARY_COLUMNS, sensitivity, src, summary
from ringqa.sweep.store import StoredSamples


def _samples(n=200, seed=0):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 2))
    dev = np.column_stack([1.0 + 0.2 * x[:, 0], 2.0 + 0.1 * x[:, 1]])
    ok = np.ones(n, bool)
    ok[-1] = False
    dev[-1] = np.nan
    arrays = {
        "x_mm": dev.copy(),
        "y_mm": np.zeros((n, 2)),
        "z_mm": np.zeros((n, 2)),
        "deviation_mm": dev,
        "along_mm": dev,
        "radial_mm": dev,
        "out_of_plane_mm": dev,
        "numerical_error_mm": np.full((n, 2), 0.01),
        "dose_gy": np.full((n, 1), 7.0),
        "dose_diff_pct": (3 * x[:, :1] + 20),
    }
    return StoredSamples(
        np.arange(n),
        x,
        ok,
        [""] * n,
        np.ones(n),
        np.ones(n),
        ["w"] * n,
        arrays,
        ("a", "b"),
        (1, 2),
        ("point_a_left",),
    )


def test_summary_contract_columns_and_numbers():
    """Dwell 1's deviation is 1 + 0.2 x0 with x0 ~ N(0, 1): its mean and sd are those of the
    199 ok samples, the failed one counted in n_failed; the 95 % interval is the 2.5 and 97.5
    percentiles of the same numbers."""
    s = _samples()
    nominal = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    df = summary(s, nominal)
    assert tuple(df.columns) == SUMMARY_COLUMNS
    row = df[(df["dwell"] == 1) & (df["quantity"] == "deviation_mm")].iloc[0]
    v = 1.0 + 0.2 * s.values[:-1, 0]
    assert row["n_ok"] == 199 and row["n_failed"] == 1
    np.testing.assert_allclose(
        [row["mean"], row["sd"], row["p2_5"], row["p97_5"]],
        [v.mean(), v.std(ddof=1), *np.percentile(v, [2.5, 97.5])],
    )
    shift = df[(df["dwell"] == 1) & (df["quantity"] == "shift_mm")].iloc[0]
    np.testing.assert_allclose(shift["mean"], np.abs(v - 1.0).mean())
    assert set(df["quantity"]) == {
        "deviation_mm",
        "along_mm",
        "radial_mm",
        "out_of_plane_mm",
        "shift_mm",
        "numerical_error_mm",
        "dose_gy",
        "dose_diff_pct",
    }


def test_src_of_a_linear_model():
    """y = 2 x0 + 0.5 x1 (no noise): SRC_j = b_j sd(x_j) / sd(y) and R^2 = 1."""
    rng = np.random.default_rng(1)
    x = rng.normal(size=(500, 2)) * [1.0, 3.0]
    y = 2 * x[:, 0] + 0.5 * x[:, 1]
    coef, r2 = src(x, y)
    expected = np.array([2 * x[:, 0].std(ddof=1), 0.5 * x[:, 1].std(ddof=1)]) / y.std(ddof=1)
    np.testing.assert_allclose(coef, expected, rtol=1e-9)
    assert abs(r2 - 1.0) < 1e-9


def test_sensitivity_ranks_the_parameter_that_drives_the_output():
    """max |dose diff| = 3 x0 + 20 (positive for |x0| < 6.7: every draw) is linear in
    parameter a alone: src_a = 1, src_b = 0 up to the sampling noise of 199 samples
    (~1/sqrt(199) = 0.07 for b), and R^2 = 1."""
    df = sensitivity(_samples(), ("a", "b"), None)
    d = df[df["output"] == "max_abs_dose_diff_pct"].set_index("parameter")["src"]
    assert abs(d["a"] - 1.0) < 0.01 and abs(d["b"]) < 0.01
