"""The uncertainty figure: per-dwell 95 % position ellipses on the ring, dose-difference bars.

:func:`uncertainty_figure` returns a matplotlib Figure (no file written): ``ringqa sweep`` saves
it as ``uncertainty.png``; the report can place it on a page.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse

from ringqa.sweep.store import StoredSamples

__all__ = ["CHI2_2D_95", "plane_axes", "uncertainty_figure"]

#: chi-square quantile with 2 degrees of freedom at 95 %: -2 ln(0.05)
CHI2_2D_95 = float(-2.0 * np.log(0.05))


def plane_axes(points_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre and the two principal axes of ``points_mm`` (the ring's plane), (3,) each."""
    p = np.asarray(points_mm, dtype=float)
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt[0], vt[1]


def uncertainty_figure(
    samples: StoredSamples,
    nominal_mm: np.ndarray,
    reference_mm: np.ndarray,
    summary: pd.DataFrame,
    title: str = "",
) -> Figure:
    """The figure (see the module docstring).

    Parameters
    ----------
    samples : StoredSamples
    nominal_mm : (n_dwell, 3) ndarray
        The nominal run's simulated dwells, mm.
    reference_mm : (n_dwell, 3) ndarray
        The reference (measured or centreline) dwells, mm.
    summary : DataFrame
        The ``summary.csv`` table (for the dose intervals).
    title : str
    """
    fig = Figure(figsize=(11, 5.2))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.2, 1]})
    c, e1, e2 = plane_axes(np.vstack([reference_mm, nominal_mm]))

    def proj(p):
        q = np.asarray(p) - c
        return np.stack([q @ e1, q @ e2], axis=-1)

    ref2, nom2 = proj(reference_mm), proj(nominal_mm)
    xyz = np.stack([samples.arrays["x_mm"], samples.arrays["y_mm"], samples.arrays["z_mm"]], -1)
    ok = samples.ok
    ax.plot(ref2[:, 0], ref2[:, 1], "k.", ms=4, label="reference")
    ax.plot(nom2[:, 0], nom2[:, 1], "C0.", ms=4, label="simulated (nominal)")
    drawn = False
    for j in range(xyz.shape[1]):
        pts = proj(xyz[ok, j, :])
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts) < 3:
            continue
        ax.plot(pts[:, 0], pts[:, 1], ",", color="C1", alpha=0.4)
        cov = np.cov(pts.T)
        w, v = np.linalg.eigh(cov)
        w = np.clip(w, 0.0, None)
        angle = float(np.degrees(np.arctan2(v[1, 1], v[0, 1])))
        ax.add_patch(
            Ellipse(
                tuple(pts.mean(axis=0)),
                2 * np.sqrt(CHI2_2D_95 * w[1]),
                2 * np.sqrt(CHI2_2D_95 * w[0]),
                angle=angle,
                fill=False,
                color="C3",
                lw=0.8,
                label=None if drawn else "95 % ellipse of the samples",
            )
        )
        drawn = True
    ax.set_aspect("equal")
    ax.set_xlabel("in-plane axis 1, mm")
    ax.set_ylabel("in-plane axis 2, mm")
    ax.set_title("Dwell positions across the uncertainty")
    ax.legend(fontsize=7, loc="best")
    dd = summary[summary["quantity"] == "dose_diff_pct"]
    y = np.arange(len(dd))
    mean = dd["mean"].to_numpy(float)
    lo, hi = dd["p2_5"].to_numpy(float), dd["p97_5"].to_numpy(float)
    bx.errorbar(mean, y, xerr=[mean - lo, hi - mean], fmt="o", color="C0", capsize=3)
    bx.axvline(0.0, color="k", lw=0.6)
    bx.set_yticks(y, [str(p) for p in dd["point"]], fontsize=7)
    bx.set_xlabel("dose difference simulated vs reference, % (mean, 95 % interval)")
    bx.set_title("Dose difference intervals")
    bx.grid(axis="x", alpha=0.3)
    n_ok, n = int(ok.sum()), len(ok)
    fig.suptitle(f"{title} ({n_ok} of {n} samples ok)".strip())
    fig.tight_layout()
    return fig
