"""From the stored samples to ``summary.csv`` and ``sensitivity.csv``.

``summary.csv`` (the contract): one row per dwell and quantity, then per dose point and
quantity, columns ``dwell, point, quantity, mean, sd, p2_5, p97_5, n_ok, n_failed`` (``dwell``
empty on point rows and ``point`` empty on dwell rows). Dwell quantities: ``deviation_mm``
(3D distance simulated - reference), ``along_mm``, ``radial_mm``, ``out_of_plane_mm``,
``shift_mm`` (3D distance from the NOMINAL run's simulated position: the parameter spread alone)
and ``numerical_error_mm`` (each sample's own numerical error, kept apart so a reader sees
whether the parameters or the numerics dominate). Point quantities: ``dose_gy`` and
``dose_diff_pct`` (simulated plan vs the reference plan, %).

``sensitivity.csv``: for each of three scalar outputs (``max_deviation_mm``,
``mean_deviation_mm``, ``max_abs_dose_diff_pct``) and each parameter, the standardised
regression coefficient ``src`` (with the regression's ``r2``; meaningful when r2 is near 1) and,
for a Sobol design, SALib's first-order and total indices ``s1, s1_conf, st, st_conf``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import pandas as pd

from ringqa.sweep.store import StoredSamples

__all__ = [
    "OUTPUTS",
    "SUMMARY_COLUMNS",
    "failure_report",
    "scalar_outputs",
    "sensitivity",
    "sensitivity_reason",
    "shift_mm",
    "summary",
]

SUMMARY_COLUMNS = ("dwell", "point", "quantity", "mean", "sd", "p2_5", "p97_5", "n_ok", "n_failed")
SENSITIVITY_COLUMNS = (
    "output",
    "parameter",
    "method",
    "src",
    "r2",
    "s1",
    "s1_conf",
    "st",
    "st_conf",
)
OUTPUTS = ("max_deviation_mm", "mean_deviation_mm", "max_abs_dose_diff_pct")


def shift_mm(s: StoredSamples, nominal_positions_mm: np.ndarray) -> np.ndarray:
    """(n, n_dwell) 3D distance of each sample's dwell from the nominal run's, mm."""
    xyz = np.stack([s.arrays["x_mm"], s.arrays["y_mm"], s.arrays["z_mm"]], axis=-1)
    return np.linalg.norm(xyz - np.asarray(nominal_positions_mm)[None, :, :], axis=-1)


def _stats(col: np.ndarray, ok: np.ndarray) -> dict:
    v = col[ok & np.isfinite(col)]
    n_ok = int(v.size)
    if n_ok == 0:
        return {"mean": np.nan, "sd": np.nan, "p2_5": np.nan, "p97_5": np.nan, "n_ok": 0}
    return {
        "mean": float(np.mean(v)),
        "sd": float(np.std(v, ddof=1)) if n_ok > 1 else np.nan,
        "p2_5": float(np.percentile(v, 2.5)),
        "p97_5": float(np.percentile(v, 97.5)),
        "n_ok": n_ok,
    }


def summary(s: StoredSamples, nominal_positions_mm: np.ndarray) -> pd.DataFrame:
    """The ``summary.csv`` table (see the module docstring)."""
    n_total = len(s.index)
    rows = []
    dwell_q = {q: s.arrays[q] for q in ("deviation_mm", "along_mm", "radial_mm", "out_of_plane_mm")}
    dwell_q["shift_mm"] = shift_mm(s, nominal_positions_mm)
    dwell_q["numerical_error_mm"] = s.arrays["numerical_error_mm"]
    for j, dwell in enumerate(s.dwells):
        for q, arr in dwell_q.items():
            st = _stats(arr[:, j], s.ok)
            rows.append(
                {"dwell": dwell, "point": "", "quantity": q, **st, "n_failed": n_total - st["n_ok"]}
            )
    for j, point in enumerate(s.points):
        for q in ("dose_gy", "dose_diff_pct"):
            st = _stats(s.arrays[q][:, j], s.ok)
            rows.append(
                {"dwell": "", "point": point, "quantity": q, **st, "n_failed": n_total - st["n_ok"]}
            )
    df = pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))
    df["dwell"] = df["dwell"].astype(object)
    return df


def scalar_outputs(s: StoredSamples) -> dict[str, np.ndarray]:
    """Per sample: largest and mean deviation (mm), largest |dose difference| (%)."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # a failed sample's all-NaN row
        dev = s.arrays["deviation_mm"]
        dd = np.abs(s.arrays["dose_diff_pct"])
        return {
            "max_deviation_mm": np.where(
                s.ok, np.nanmax(np.where(np.isnan(dev), -np.inf, dev), axis=1), np.nan
            ),
            "mean_deviation_mm": np.where(s.ok, np.nanmean(dev, axis=1), np.nan),
            "max_abs_dose_diff_pct": np.where(
                s.ok, np.nanmax(np.where(np.isnan(dd), -np.inf, dd), axis=1), np.nan
            ),
        }


def src(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """Standardised regression coefficients of ``y`` on the columns of ``x`` and the R^2.

    ``y/sd(y) = sum_j b_j x_j/sd(x_j) + c`` by least squares; a column without spread gets NaN.

    Parameters
    ----------
    x : (n, D) ndarray
    y : (n,) ndarray

    Returns
    -------
    (D,) ndarray, float
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    d = x.shape[1]
    out = np.full(d, np.nan)
    sx = x.std(axis=0, ddof=1) if len(y) > 1 else np.zeros(d)
    sy = float(y.std(ddof=1)) if len(y) > 1 else 0.0
    live = sx > 0
    if sy == 0 or not live.any() or len(y) <= int(live.sum()) + 1:
        return out, np.nan
    z = (x[:, live] - x[:, live].mean(axis=0)) / sx[live]
    a = np.column_stack([z, np.ones(len(y))])
    coef, *_ = np.linalg.lstsq(a, (y - y.mean()) / sy, rcond=None)
    out[live] = coef[:-1]
    fit = a @ coef
    resid = (y - y.mean()) / sy - fit
    r2 = 1.0 - float(resid @ resid) / float(len(y) - 1)
    return out, r2


def sensitivity(s: StoredSamples, names: Sequence[str], problem: dict | None) -> pd.DataFrame:
    """The ``sensitivity.csv`` table; ``problem``: the SALib problem of a Sobol design (None:
    regression coefficients only)."""
    outs = scalar_outputs(s)
    reason = sensitivity_reason(s, names)
    rows = []
    for name, y in outs.items():
        good = s.ok & np.isfinite(y)
        coef, r2 = src(s.values[good], y[good])
        method = "src" if np.isfinite(coef).any() else (reason or "none: the output has no spread")
        sob = None
        if problem is not None and good.all() and len(y) > 0 and np.std(y) > 0:
            from SALib.analyze import sobol

            sob = sobol.analyze(problem, y, calc_second_order=False, seed=0)
        elif problem is not None and method == "src":
            n_bad = int((~good).sum())
            method = (
                f"src (no Sobol indices: {n_bad} of {len(y)} runs failed, and SALib needs "
                "every run of the design)"
                if n_bad
                else "src (no Sobol indices: the output has no spread)"
            )
        for j, p in enumerate(names):
            row = {
                "output": name,
                "parameter": p,
                "method": "sobol+src" if sob is not None else method,
                "src": coef[j],
                "r2": r2,
                "s1": np.nan,
                "s1_conf": np.nan,
                "st": np.nan,
                "st_conf": np.nan,
            }
            if sob is not None:
                row.update(
                    s1=float(sob["S1"][j]),
                    s1_conf=float(sob["S1_conf"][j]),
                    st=float(sob["ST"][j]),
                    st_conf=float(sob["ST_conf"][j]),
                )
            rows.append(row)
    return pd.DataFrame(rows, columns=list(SENSITIVITY_COLUMNS))


#: a failure/parameter link is called out when at most this share of the successful samples lies
#: on the failures' side of the threshold
FAILURE_LINK_SHARE = 0.25


def failure_report(s: StoredSamples, names: Sequence[str], centres: Sequence[float]) -> dict:
    """Which samples failed, why, and whether the failures go with one parameter.

    For each parameter ``x`` (and its distance from the centre, ``|x - centre|``) the threshold
    that all failures pass is ``t = min`` (or ``max``) of the failures' values; the link is
    called out ("all 3 failures have |centreline.displacement_mm| >= 0.357") when at least two
    samples failed and at most :data:`FAILURE_LINK_SHARE` of the successful samples pass the same
    threshold; the strongest such link comes first.

    Parameters
    ----------
    s : StoredSamples
    names : sequence of str
        The parameters (the columns of ``s.values``).
    centres : sequence of float
        Each parameter's nominal value.

    Returns
    -------
    dict
        ``n``, ``n_failed``, ``failed_fraction``, ``reasons`` (reason -> count: the message up to
        its first colon), ``links`` (list of dicts: ``parameter``, ``form``, ``threshold``,
        ``side``, ``ok_share``, ``text``) and ``text`` (one line for the terminal and the
        report).
    """
    n = len(s.index)
    failed = ~np.asarray(s.ok, dtype=bool)
    k = int(failed.sum())
    reasons: dict[str, int] = {}
    for m, bad in zip(s.message, failed, strict=True):
        if bad:
            key = str(m).split(":", 1)[0] or "unknown"
            reasons[key] = reasons.get(key, 0) + 1
    links = []
    n_ok = n - k
    if k >= 2 and n_ok >= 1:
        vals = np.asarray(s.values, dtype=float).reshape(n, -1)
        for j, (name, c) in enumerate(zip(names, centres, strict=True)):
            x = vals[:, j]
            forms = [(name, x)]
            if np.any(x < c) and np.any(x > c):
                label = f"|{name}|" if c == 0 else f"|{name} - {c:g}|"
                forms.append((label, np.abs(x - c)))
            for label, v in forms:
                vf, vo = v[failed], v[~failed]
                for side, t, share in (
                    (">=", float(vf.min()), float(np.mean(vo >= vf.min()))),
                    ("<=", float(vf.max()), float(np.mean(vo <= vf.max()))),
                ):
                    if share <= FAILURE_LINK_SHARE:
                        links.append(
                            {
                                "parameter": name,
                                "form": label,
                                "side": side,
                                "threshold": t,
                                "ok_share": share,
                                "text": f"all {k} failures have {label} {side} {t:.4g} "
                                f"({share:.0%} of the {n_ok} successful samples do too)",
                            }
                        )
        links.sort(key=lambda d: d["ok_share"])
    frac = k / n if n else 0.0
    if k == 0:
        text = f"all {n} samples succeeded"
    else:
        why = ", ".join(f"{r} x{c}" for r, c in sorted(reasons.items(), key=lambda x: -x[1]))
        text = (
            f"{k} of {n} samples failed ({frac:.1%}: {why}); the intervals are conditional on "
            "success"
        )
        if links:
            text += f"; {links[0]['text']}"
    return {
        "n": n,
        "n_failed": k,
        "failed_fraction": frac,
        "reasons": reasons,
        "links": links,
        "text": text,
    }


def sensitivity_reason(s: StoredSamples, names: Sequence[str]) -> str:
    """Why ``sensitivity.csv`` has no regression coefficients ("" when it has them)."""
    outs = scalar_outputs(s)
    good = np.asarray(s.ok, dtype=bool)
    n_good = int(good.sum())
    vals = np.asarray(s.values, dtype=float).reshape(len(s.index), -1)[good]
    live = int(np.sum(vals.std(axis=0) > 0)) if n_good > 1 else 0
    if n_good <= live + 1:
        return (
            f"no regression coefficients: {n_good} successful samples for {live} varied "
            f"parameters (at least {live + 2} needed; run more samples)"
        )
    if live == 0:
        return "no regression coefficients: no parameter varies across the successful samples"
    if all(np.nanstd(y[good]) == 0 for y in outs.values()):
        return "no regression coefficients: the outputs do not vary across the samples"
    return ""
