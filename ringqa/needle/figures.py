"""Figures of the needle study: one channel's force-depth curve, the paper's Figures 8 and 9.

Matplotlib with the Agg backend (no display needed); each function writes one PNG.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ringqa.needle.run import NeedleRun
from ringqa.needle.sweep import FAMILIES, SweepResult

#: landmark -> (label, colour) in the paper's numbering
LANDMARKS = {
    "peak1_n": ("(1) 1st peak", "C3"),
    "plateau_n": ("(2) plateau", "C0"),
    "peak2_n": ("(3) 2nd peak", "C2"),
}
_X = {
    "radius": ("radius_mm", "radius of curvature r (mm)"),
    "torsion": ("torsion_rad", "torsion tau (rad)"),
    "diameter": ("nominal_diameter_mm", "nominal channel diameter (mm)"),
}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _mark_peaks(ax, run: NeedleRun) -> None:
    p = run.peaks
    for num, (x, y) in enumerate(
        (
            (p.peak1_depth_mm, p.peak1_n),
            (p.plateau_depth_mm, p.plateau_n),
            (p.peak2_depth_mm, p.peak2_n),
        ),
        start=1,
    ):
        if math.isfinite(x) and math.isfinite(y):
            ax.plot([x], [y], "ko", ms=4)
            ax.annotate(f"({num})", (x, y), textcoords="offset points", xytext=(0, 6), ha="center")
    if math.isfinite(p.plateau_from_mm):
        ax.plot([p.plateau_from_mm, p.plateau_to_mm], [p.plateau_n] * 2, "k:", lw=1)


def plot_force_depth(run: NeedleRun, path: str | Path, title: str = "") -> None:
    """Insertion force against depth: raw and filtered, bends shaded, landmarks (1)-(3)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for a, b in run.bends_mm:
        ax.axvspan(a, b, color="0.92", lw=0)
    ax.plot(run.depth_mm, run.force_raw_n, color="0.6", lw=0.8, label="simulated")
    ax.plot(
        run.depth_mm,
        run.force_n,
        color="C0",
        lw=1.5,
        label=f"filtered ({run.filter_window_mm:.3g} mm moving average)",
    )
    _mark_peaks(ax, run)
    ax.set_xlabel("insertion depth (mm)")
    ax.set_ylabel("axial insertion force (N)")
    ax.set_title(title or run.name, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    if run.status != 0:
        ax.text(0.99, 0.02, run.message, transform=ax.transAxes, ha="right", fontsize=7, color="C3")
    fig.text(0.99, 0.005, "grey bands: the channel's bends", ha="right", fontsize=7, color="0.4")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_figure8(sweep: SweepResult, path: str | Path) -> None:
    """The paper's Figure 8: force-depth per radius, the nominal..+0.2 mm band shaded.

    One panel per radius of the ``radius`` family (tau = 0, 2.6 mm): the band between the runs
    at the nominal and the +0.2 mm diameter, both curves drawn, the nominal run's landmarks
    (1)-(3) marked.
    """
    plt = _pyplot()
    pts = [p for p in sweep.points if p.family == "radius"]
    radii = sorted({p.radius_mm for p in pts})
    if not radii:
        raise ValueError("Figure 8 needs the 'radius' family")
    ncol = 3
    nrow = math.ceil(len(radii) / ncol)
    fig, axs = plt.subplots(nrow, ncol, figsize=(12, 3.0 * nrow), sharex=True, sharey=True)
    axs = np.atleast_1d(axs).ravel()
    for ax, r in zip(axs, radii, strict=False):
        nom = next(p for p in pts if p.radius_mm == r and p.diameter_mm == p.nominal_diameter_mm)
        wide = next(p for p in pts if p.radius_mm == r and p.diameter_mm != p.nominal_diameter_mm)
        a, b = sweep.run(nom), sweep.run(wide)
        ax.fill_between(a.depth_mm, a.force_n, b.force_n, color="C0", alpha=0.25, lw=0)
        ax.plot(a.depth_mm, a.force_n, color="C0", lw=1.2, label=f"{nom.diameter_mm:g} mm")
        ax.plot(
            b.depth_mm, b.force_n, color="C0", lw=0.8, ls="--", label=f"{wide.diameter_mm:g} mm"
        )
        _mark_peaks(ax, a)
        ax.set_title(f"r = {r:g} mm", fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axs[len(radii) :]:
        ax.set_visible(False)
    forces = np.concatenate([sweep.run(p).force_n for p in pts])
    forces = forces[np.isfinite(forces)]
    if forces.size:  # room above the highest peak for its label (runs that failed are empty)
        axs[0].set_ylim(bottom=min(0.0, float(forces.min())), top=1.15 * float(forces.max()))
    axs[0].legend(fontsize=8, loc="upper right")
    for ax in axs[(nrow - 1) * ncol :]:
        ax.set_xlabel("insertion depth (mm)")
    for ax in axs[::ncol]:
        ax.set_ylabel("force (N)")
    fig.suptitle(
        "Simulated axial insertion force vs depth, planar S channels (tau = 0); band: nominal "
        "to +0.2 mm diameter",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_figure9(sweep: SweepResult, path: str | Path) -> None:
    """The paper's Figure 9: peaks and plateau against r, tau and diameter, with the band.

    One panel per family present; for each landmark the band between the nominal and the +0.2 mm
    diameter's value (shaded, dotted outline), the nominal value as a line with markers.
    """
    plt = _pyplot()
    table = sweep.peaks_table()
    fams = [f for f in FAMILIES if (table["family"] == f).any()]
    fig, axs = plt.subplots(1, len(fams), figsize=(4.6 * len(fams), 4.2), squeeze=False)
    for ax, fam in zip(axs[0], fams, strict=True):
        xcol, xlabel = _X[fam]
        t = table[table["family"] == fam]
        nom = t[t["diameter_mm"] == t["nominal_diameter_mm"]].sort_values(xcol)
        wide = t[t["diameter_mm"] != t["nominal_diameter_mm"]].sort_values(xcol)
        for col, (label, colour) in LANDMARKS.items():
            x = nom[xcol].to_numpy()
            lo, hi = nom[col].to_numpy(), wide[col].to_numpy()
            ax.fill_between(x, lo, hi, color=colour, alpha=0.2, lw=0)
            ax.plot(x, hi, color=colour, ls=":", lw=1)
            ax.plot(x, lo, color=colour, marker="o", ms=3, lw=1.2, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("axial insertion force (N)")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    axs[0][0].legend(fontsize=8)
    fig.suptitle(
        "Simulated peak and plateau forces; shaded: nominal (solid) to +0.2 mm diameter (dotted)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
