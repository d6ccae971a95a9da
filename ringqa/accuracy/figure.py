"""The study's figure: log-log error vs time, each run labelled, the Pareto front marked."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ringqa.accuracy.result import AccuracyStudy


def plot_study(study: AccuracyStudy, path: Path) -> None:
    """Log-log error vs time, each run labelled, the Pareto front marked, failures shown."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = study.table
    fig = plt.figure(figsize=(14, 7))
    ax = fig.add_axes((0.07, 0.09, 0.6, 0.83))
    ok = (t["status"] == 0) & np.isfinite(t["max_err_mm"]) & (t["max_err_mm"] > 0)
    floor = study.reference.agreement_mm if np.isfinite(study.reference.agreement_mm) else 1e-6
    zero = (t["status"] == 0) & (t["max_err_mm"] <= 0)
    num, mod = ok & (t["kind"] == "numerical"), ok & (t["kind"] == "model")
    if num.any():
        ax.scatter(
            t.loc[num, "time_s"], t.loc[num, "max_err_mm"], c="C0", label="numerical settings"
        )
    if mod.any():
        ax.scatter(
            t.loc[mod, "time_s"],
            t.loc[mod, "max_err_mm"],
            c="C2",
            marker="s",
            label="model change (effect on/off, solver kind)",
        )
    front = t[t["pareto"]].sort_values("time_s")
    if len(front):
        ax.step(
            front["time_s"], front["max_err_mm"], where="post", c="C3", lw=1.5, label="Pareto front"
        )
        ax.scatter(
            front["time_s"], front["max_err_mm"], facecolors="none", edgecolors="C3", s=120, lw=1.5
        )
    ymax = float(np.nanmax(t.loc[ok, "max_err_mm"])) if ok.any() else 1.0
    ymin = float(np.nanmin(t.loc[ok, "max_err_mm"])) if ok.any() else floor
    if zero.any():
        ax.scatter(
            t.loc[zero, "time_s"],
            np.full(int(zero.sum()), max(ymin / 3, 1e-9)),
            marker="v",
            c="k",
            label="error below the reference's resolution",
        )
    bad = t["status"] != 0
    if bad.any():
        tb = t.loc[bad, "time_s"].fillna(t["time_s"].median())
        ax.scatter(
            tb,
            np.full(int(bad.sum()), ymax * 3),
            marker="x",
            c="k",
            s=60,
            label="jammed / failed (error not measured)",
        )
    key_lines = []
    placed: list[tuple[float, float]] = []
    for _, r in t.iterrows():
        rid = int(r["run"])
        status = "" if r["status"] == 0 else f" [{r['status_text']}]"
        err = f"{r['max_err_mm']:.3g} mm" if r["status"] == 0 else "no error"
        key_lines.append(f"#{rid:<2d} {r['label']}{status}: {r['time_s']:.3g} s, {err}")
        y = r["max_err_mm"] if r["status"] == 0 and r["max_err_mm"] > 0 else None
        if r["status"] != 0:
            y = ymax * 3
        if y is None or not np.isfinite(r["time_s"]):
            continue
        # stagger ids of (nearly) coincident points so that each stays readable
        lx, ly = math.log10(r["time_s"]), math.log10(y)
        n_near = sum(1 for px, py in placed if abs(px - lx) < 0.04 and abs(py - ly) < 0.04)
        placed.append((lx, ly))
        ax.annotate(
            f"#{rid}",
            (r["time_s"], y),
            fontsize=7,
            xytext=(4, 3 + 8 * n_near),
            textcoords="offset points",
        )
    fig.text(
        0.70,
        0.95,
        "runs (#: settings: time, max error)\n" + "\n".join(key_lines),
        fontsize=6,
        va="top",
        family="monospace",
    )
    ax.axhline(study.target_mm, c="C1", ls="--", lw=1, label=f"target {study.target_mm:g} mm")
    if study.recommended:
        ax.scatter(
            [study.recommended["time_s"]],
            [study.recommended["max_err_mm"]],
            marker="*",
            s=300,
            c="gold",
            edgecolors="k",
            zorder=5,
            label=f"recommended ({study.recommended['time_s']:.3g} s)",
        )
    if np.isfinite(study.reference.agreement_mm) and study.reference.agreement_mm > 0:
        ax.axhline(
            study.reference.agreement_mm,
            c="0.6",
            ls=":",
            lw=1,
            label="reference resolution (two finest levels)",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("solve time per run (s, JIT excluded, median of repeats)")
    ax.set_ylabel("max dwell position error vs converged reference (mm)")
    ax.set_title(f"Accuracy vs time: {study.scene_name}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.savefig(path, dpi=120)
    plt.close(fig)
