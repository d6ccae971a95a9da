"""The PDF report a physicist signs (matplotlib PdfPages, A4 portrait).

Pages per applicator:
1. Title block (applicator, input with SHA-256, source, software, date, scene settings), verdicts,
   notes, signature lines.
2. Dwell positions like the paper's Figure 6: projected onto the ring plane and orthogonal to it,
   measured / simulated / centreline, with the channel centreline.
3. Deviation per dwell: 3D distance, along/radial/out-of-plane components, angle of orientation.
4. Dose points: map (ring plane and side view) and the dose table for the three plans
   (+ the RT Plan's own doses beside the TPS values).
5. Dwell-by-dwell table.
Batch: a cross-applicator page with Figure-5-like boxplots and the summary table.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pandas as pd

from ringqa.pipeline import RingGeometry

A4 = (8.27, 11.69)
COLOURS = {"measured": "black", "simulated": "tab:red", "centreline": "tab:blue"}
MARKERS = {"measured": "s", "simulated": "o", "centreline": "^"}
LONG_NAMES = {
    "point_a_left": "Point A left",
    "point_a_right": "Point A right",
    "surface_left": "lateral ring surface left",
    "surface_right": "lateral ring surface right",
    "depth5_left": "5 mm deeper, left",
    "depth5_right": "5 mm deeper, right",
}
STATUS_COLOURS = {
    "PASS": "#2e7d32",
    "WARN": "#ef6c00",
    "FAIL": "#c62828",
    "ACTION": "#c62828",
    "ERROR": "#c62828",
}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _title(res, what: str) -> str:
    """Page title: what, then the applicator (shortened to fit the page)."""
    return textwrap.shorten(f"{what}: {res.applicator}", 62, placeholder="...")


def _frame(geometry: RingGeometry):
    """Ring frame: centre (3,), e_left (3,), e_ant (3,) in-plane, e_cranial (3,)."""
    c = np.asarray(geometry.ring_centre_mm, dtype=float)
    n = np.asarray(geometry.ring_normal, dtype=float)
    n = n / np.linalg.norm(n)
    lat = np.asarray(geometry.ring_lateral, dtype=float)
    lat = lat - np.dot(lat, n) * n
    lat /= np.linalg.norm(lat)
    return c, lat, np.cross(n, lat), n


def _project(xyz, geometry: RingGeometry):
    c, e1, e2, n = _frame(geometry)
    d = np.asarray(xyz, dtype=float).reshape(-1, 3) - c
    return d @ e1, d @ e2, d @ n


def _text_page(plt, title: str):
    fig = plt.figure(figsize=A4)
    fig.text(0.06, 0.965, title, fontsize=14, weight="bold", va="top")
    return fig


def _title_page(plt, res) -> list:
    fig = _text_page(plt, textwrap.shorten(f"ringqa commissioning report: {res.applicator}", 60))
    prov = res.provenance
    s = res.settings
    lines = [
        ("Applicator", f"{res.applicator}  (input: {res.input}, {res.input_kind})"),
        ("Reference path", _reference_text(res)),
        ("Source (TG-43)", f"{s.source}, S_K = {s.sk_U:.0f} U"),
        ("Cable model", f"{s.cable} preset (all simulation settings: last page)"),
        (
            "Standard plan",
            f"dwells every {s.plan_step_mm:g} mm, equal times, "
            f"mean Point A dose = {s.prescription_gy:g} Gy",
        ),
        (
            "s_ref",
            f"{res.summary.s_ref_mm:.2f} mm of centreline arc length from the channel "
            "entry to relative position 0 (most distal dwell)",
        ),
        (
            "Tolerances",
            f"position {s.position_limits_mm[0]:g} mm recommended / "
            f"{s.position_limits_mm[1]:g} mm required (AAPM MPPG 13.a); "
            f"dose action level {s.dose_action_pct:g} %",
        ),
        ("Software", f"{prov.software} (Python {prov.python})"),
        ("Date (UTC)", prov.created_utc),
    ]
    y = 0.925
    for key, val in lines:
        fig.text(0.06, y, key, fontsize=9, weight="bold", va="top")
        wrapped = textwrap.fill(val, 80)
        fig.text(0.26, y, wrapped, fontsize=9, va="top")
        y -= 0.022 * (wrapped.count("\n") + 1)
    fig.text(0.06, y, "Inputs (SHA-256)", fontsize=9, weight="bold", va="top")
    if prov.inputs:
        for path, digest in prov.inputs.items():
            fig.text(0.26, y, textwrap.fill(str(path), 90), fontsize=7, va="top")
            y -= 0.015 * (len(str(path)) // 90 + 1)
            fig.text(0.26, y, digest, fontsize=7, va="top", family="monospace")
            y -= 0.02
    else:
        fig.text(0.26, y, "(applicator object given in Python, no file)", fontsize=8, va="top")
        y -= 0.02
    y -= 0.01
    fig.text(0.06, y, "Verdicts", fontsize=12, weight="bold", va="top")
    y -= 0.03
    for v in res.verdicts:
        fig.text(
            0.06,
            y,
            f" {v.status} ",
            fontsize=10,
            weight="bold",
            va="top",
            color="white",
            bbox={"facecolor": STATUS_COLOURS.get(v.status, "grey"), "edgecolor": "none"},
        )
        fig.text(0.17, y, textwrap.fill(v.text, 85), fontsize=9, va="top")
        y -= 0.032
    y -= 0.01
    fig.text(0.06, y, "Notes", fontsize=12, weight="bold", va="top")
    y -= 0.028
    figs = [fig]
    for note in res.notes:
        wrapped = textwrap.fill(note, 100)
        height = 0.017 * (wrapped.count("\n") + 1) + 0.006
        if y - height < 0.09:  # continue on a new page, keep the signature line free
            fig = _text_page(plt, "Notes (continued)")
            figs.append(fig)
            y = 0.92
        fig.text(0.06, y, "- " + wrapped.replace("\n", "\n  "), fontsize=8.5, va="top")
        y -= height
    figs[0].text(
        0.06,
        0.05,
        "Checked by: ______________________   Signature: ____________________   "
        "Date: ______________",
        fontsize=10,
    )
    if len(figs) > 1:
        figs[0].text(0.06, 0.075, "Notes continue on the next page.", fontsize=8.5, style="italic")
    return figs


def _settings_page(plt, res):
    """The simulation's scene settings and the run's other settings (for the record)."""
    fig = _text_page(plt, textwrap.shorten(f"Settings of this run: {res.applicator}", 60))
    s = res.settings
    sim = res.simulation
    flat = {
        k: v for k, v in _flatten(s.scene).items() if not isinstance(v, list | tuple | dict)
    } or {"(engine defaults)": ""}
    for k, v in s.scene_overrides.items():
        flat[f"--set {k}"] = v
    run = {
        "simulation status": f"{sim.status} {sim.message}".strip(),
        "simulation solve time": f"{sim.solve_time_s:.2f} s",
        "elements": sim.n_elements,
        **{f"dose point {k}": v for k, v in s.dose_points.as_dict().items()},
        "plan step": f"{s.plan_step_mm:g} mm",
        "tandem dwells (no measured path)": s.tandem_dwells,
    }
    for w in sim.warnings:
        run.setdefault("engine warnings", "")
        run["engine warnings"] += f"{w}; "
    y = 0.92
    fig.text(0.06, y, "Run", fontsize=12, weight="bold", va="top")
    y -= 0.025
    lines = [textwrap.shorten(f"{k} = {v}", 110) for k, v in run.items()]
    fig.text(0.06, y, "\n".join(lines), fontsize=7.5, va="top", family="monospace")
    y -= 0.0135 * len(lines) + 0.02
    fig.text(
        0.06, y, "Scene (simulation settings, user units)", fontsize=12, weight="bold", va="top"
    )
    y -= 0.025
    items = [textwrap.shorten(f"{k} = {v}", 58) for k, v in flat.items()]
    per_col = max(1, int((y - 0.04) / 0.0125))
    if len(items) > 2 * per_col:
        items = [
            *items[: 2 * per_col - 1],
            f"... {len(items) - 2 * per_col + 1} more in results.json",
        ]
    fig.text(0.06, y, "\n".join(items[:per_col]), fontsize=7, va="top", family="monospace")
    fig.text(0.52, y, "\n".join(items[per_col:]), fontsize=7, va="top", family="monospace")
    return fig


def _reference_text(res) -> str:
    if res.reference == "measured":
        return (
            f"MEASURED source path ({res.summary.n_dwells} positions); simulated and "
            "centreline dwells are compared with it"
        )
    return (
        "no measured path: the CENTRELINE is the reference; the comparison is simulated vs "
        "centreline"
    )


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _positions_page(plt, res):
    """Figure 6 of the paper: ring-plane view and the orthogonal view."""
    fig, axes = plt.subplots(2, 1, figsize=A4, gridspec_kw={"height_ratios": [1.35, 1]})
    fig.suptitle(
        _title(res, "Dwell positions (paper Figure 6)"),
        fontsize=13,
        weight="bold",
        x=0.06,
        ha="left",
    )
    geo = res.geometry
    ax1, ax2 = axes
    for name, line in geo.centrelines_mm.items():
        u, v, h = _project(np.asarray(line), geo)
        ax1.plot(u, v, "-", color="0.75", lw=1, label=f"{name} centreline")
        ax2.plot(u, h, "-", color="0.75", lw=1)
    d = res.dwells
    for path in ("measured", "centreline", "simulated"):
        sub = d[d["path"] == path]
        if sub.empty:
            continue
        u, v, h = _project(sub[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
        kw = {
            "color": COLOURS[path],
            "marker": MARKERS[path],
            "ms": 4,
            "lw": 0.8,
            "mfc": "none" if path != "simulated" else COLOURS[path],
        }
        ax1.plot(u, v, label=f"{path} dwells", **kw)
        ax2.plot(u, h, **kw)
        if path == res.reference:
            for k in range(0, len(u), 4):
                ax1.annotate(
                    f"{sub['relative_position_mm'].iloc[k]:g}",
                    (u[k], v[k]),
                    textcoords="offset points",
                    xytext=(6, 4),
                    fontsize=6,
                    color="0.3",
                )
    r = geo.ring_radius_mm
    lim = r + 8
    ax1.set_xlim(-lim, lim)
    ax1.set_ylim(-lim, lim)
    ax1.set_aspect("equal")
    ax1.set_xlabel("patient left (mm), in the ring plane")
    ax1.set_ylabel("in the ring plane, perpendicular (mm)")
    ax1.set_title(
        "projected onto the ring plane (seen from cranial); numbers: relative position (mm)",
        fontsize=9,
    )
    ax1.plot(0, 0, "k+")
    ax1.legend(fontsize=7, loc="lower right")
    ax1.grid(alpha=0.3)
    ax2.set_xlim(-lim, lim)
    ax2.set_xlabel("patient left (mm), in the ring plane")
    ax2.set_ylabel("cranial (mm), orthogonal to the ring plane")
    ax2.set_title("orthogonal to the ring plane (seen from anterior/posterior)", fontsize=9)
    ax2.grid(alpha=0.3)
    _, _, hh = _project(d[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    span = max(3.0, float(np.max(np.abs(hh))) * 1.3) if hh.size else 3.0
    ax2.set_ylim(-span, span)
    fig.subplots_adjust(left=0.12, right=0.95, bottom=0.06, top=0.92, hspace=0.25)
    return fig


def _compared_paths(dwells, ref: str):
    """(path, its rows) for the simulated and centreline paths other than the reference."""
    for path in ("simulated", "centreline"):
        if path != ref:
            yield path, dwells[dwells["path"] == path]


def _deviation_page(plt, res):
    fig, axes = plt.subplots(3, 1, figsize=A4, sharex=True)
    ref = res.reference
    fig.suptitle(
        _title(res, f"Deviation from the {ref} path"),
        fontsize=13,
        weight="bold",
        x=0.06,
        ha="left",
    )
    d = res.dwells
    lim_rec, lim_req = res.settings.position_limits_mm
    ax = axes[0]
    for path, sub in _compared_paths(d, ref):
        ax.plot(
            sub["relative_position_mm"],
            sub["dist_to_reference_mm"],
            marker=MARKERS[path],
            color=COLOURS[path],
            ms=4,
            label=f"{path} vs {ref}",
        )
    ax.axhline(lim_rec, color="#ef6c00", ls="--", lw=1, label=f"{lim_rec:g} mm recommended")
    ax.axhline(lim_req, color="#c62828", ls="--", lw=1, label=f"{lim_req:g} mm required")
    ax.set_ylabel("3D distance (mm)")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    ax = axes[1]
    styles = {"along_mm": "-", "radial_mm": "--", "out_of_plane_mm": ":"}
    for path, sub in _compared_paths(d, ref):
        for comp, ls in styles.items():
            ax.plot(
                sub["relative_position_mm"],
                sub[comp],
                ls=ls,
                color=COLOURS[path],
                lw=1.2,
                label=f"{path}: {comp[:-3].replace('_', '-')}",
            )
    ax.axhline(0, color="0.5", lw=0.6)
    ax.set_ylabel("component (mm)")
    ax.set_title(
        "along = distal positive; radial = outward in the ring plane; out-of-plane = "
        "cranial positive",
        fontsize=8,
    )
    ax.legend(fontsize=6.5, ncol=2)
    ax.grid(alpha=0.3)
    ax = axes[2]
    for path, sub in _compared_paths(d, ref):
        ax.plot(
            sub["relative_position_mm"],
            sub["angle_deg"],
            marker=MARKERS[path],
            ms=4,
            color=COLOURS[path],
            label=f"{path} vs {ref}",
        )
    ax.set_ylabel("orientation difference (deg)")
    ax.set_xlabel("relative position (mm), 0 = most distal dwell")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.subplots_adjust(left=0.12, right=0.95, bottom=0.06, top=0.92, hspace=0.25)
    return fig


def _dose_page(plt, res):
    fig = plt.figure(figsize=A4)
    fig.suptitle(
        _title(res, "Dose points and standard-plan doses"),
        fontsize=13,
        weight="bold",
        x=0.06,
        ha="left",
    )
    geo = res.geometry
    ax1 = fig.add_axes((0.08, 0.60, 0.40, 0.32))
    ax2 = fig.add_axes((0.56, 0.60, 0.40, 0.32))
    for line in geo.centrelines_mm.values():
        u, v, h = _project(np.asarray(line), geo)
        ax1.plot(u, v, "-", color="0.75", lw=1)
        ax2.plot(u, h, "-", color="0.75", lw=1)
    pdw = res.plan_dwells
    ref_plan = pdw[pdw["plan"] == res.reference]
    u, v, h = _project(ref_plan[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    ax1.plot(u, v, "k.", ms=5, label="standard-plan dwells")
    ax2.plot(u, h, "k.", ms=5)
    pts = res.doses[res.doses["plan"] == res.reference]
    pu, pv, ph = _project(pts[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    short = {
        "point_a_left": "A L",
        "point_a_right": "A R",
        "surface_left": "S L",
        "surface_right": "S R",
        "depth5_left": "5 L",
        "depth5_right": "5 R",
    }
    for k, name in enumerate(pts["point"]):
        colour = "tab:green" if pts["kind"].iloc[k] != "tps" else "tab:purple"
        ax1.plot(pu[k], pv[k], "*", color=colour, ms=9)
        ax2.plot(pu[k], ph[k], "*", color=colour, ms=9)
        label = short.get(name, name)
        off = {  # labels point away from each other on both sides (offsets in points)
            "point_a_left": (-6, 9), "point_a_right": (-6, 9),
            "surface_left": (-14, -13), "surface_right": (3, -13),
            "depth5_left": (3, -13), "depth5_right": (-14, -13),
        }.get(name, (4, 4))  # fmt: skip
        for ax, yy in ((ax1, pv[k]), (ax2, ph[k])):
            ax.annotate(label, (pu[k], yy), xytext=off, textcoords="offset points", fontsize=7)
    # zoom on the dwells and points (the channels' long stems would dwarf them)
    for ax, xs, ys in ((ax1, (u, pu), (v, pv)), (ax2, (u, pu), (h, ph))):
        xx, yy = np.concatenate(xs), np.concatenate(ys)
        half = 0.5 * max(np.ptp(xx), np.ptp(yy)) + 8.0
        cx, cy = 0.5 * (xx.max() + xx.min()), 0.5 * (yy.max() + yy.min())
        ax.set_xlim(cx - half, cx + half)
        ax.set_ylim(cy - half, cy + half)
    for ax, ylabel, title in (
        (ax1, "in the ring plane (mm)", "ring plane (seen from cranial)"),
        (ax2, "cranial (mm)", "orthogonal view"),
    ):
        ax.set_xlabel("patient left (mm)")
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize=9)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    ax1.legend(fontsize=7, loc="lower right")
    spec = res.settings.dose_points
    fig.text(
        0.06,
        0.555,
        textwrap.fill(
            f"A L/R = Point A left/right: {spec.point_a_lateral_mm:g} mm lateral of the ring "
            f"axis, {spec.point_a_height_mm:g} mm cranial of the ring channel plane. S L/R = "
            f"lateral ring surface, {spec.surface_offset_mm:g} mm outside the channel "
            "centreline in the ring plane (outer surface of the Ring CT/MR mesh). 5 L/R = "
            f"{spec.depth_mm:g} mm deeper. Purple: the RT Plan's own points.",
            115,
        ),
        fontsize=8,
        va="top",
    )
    # dose table
    d = res.doses[res.doses["kind"] != "tps"]
    plans = [p for p in ("measured", "centreline", "simulated") if p in set(d["plan"])]
    cells = []
    for name in dict.fromkeys(d["point"]):
        row = [LONG_NAMES.get(name, name)]
        for p in plans:
            r = d[(d["point"] == name) & (d["plan"] == p)].iloc[0]
            row.append(
                f"{r['dose_gy']:.3f}"
                if p == res.reference
                else f"{r['dose_gy']:.3f} ({r['diff_pct']:+.2f} %)"
            )
        cells.append(row)
    tps = res.doses[res.doses["kind"] == "tps"]
    for name in dict.fromkeys(tps[tps["plan"] != "rtplan"]["point"]):
        row = [f"{name} (RT Plan point)"]
        for p in plans:
            r = tps[(tps["point"] == name) & (tps["plan"] == p)].iloc[0]
            row.append(
                f"{r['dose_gy']:.3f}"
                if p == res.reference
                else f"{r['dose_gy']:.3f} ({r['diff_pct']:+.2f} %)"
            )
        cells.append(row)
    ax = fig.add_axes((0.06, 0.22, 0.88, 0.27))
    ax.axis("off")
    ax.set_title(
        "Dose (Gy) of the standard plan on each dwell set; in brackets the difference "
        f"to the {res.reference} plan",
        fontsize=9,
        loc="left",
    )
    table = ax.table(
        cellText=cells,
        colLabels=["dose point", *[f"{p} plan" for p in plans]],
        loc="upper center",
        cellLoc="center",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    table.scale(1, 1.25)
    own = res.doses[res.doses["plan"] == "rtplan"]
    if not own.empty:
        ax = fig.add_axes((0.06, 0.03, 0.88, 0.16))
        ax.axis("off")
        ax.set_title(
            "The RT Plan's own dwells and times at its points: ringqa TG-43 beside the TPS",
            fontsize=9,
            loc="left",
        )
        cells = [
            [r.point, f"{r.tps_dose_gy:.4f}", f"{r.dose_gy:.4f}", f"{r.diff_pct:+.2f} %"]
            for r in own.itertuples()
        ]
        t = ax.table(
            cellText=cells,
            colLabels=["RT Plan point", "TPS dose (Gy)", "ringqa dose (Gy)", "difference"],
            loc="upper center",
            cellLoc="center",
        )
        t.auto_set_font_size(False)
        t.set_fontsize(8)
    return fig


def _dwell_table_pages(plt, res):
    d = res.dwells
    ref = res.reference
    others = [p for p in ("simulated", "centreline") if p != ref and p in set(d["path"])]
    base = d[d["path"] == ref].reset_index(drop=True)
    cols = ["relative\nposition (mm)", "in the\nstandard plan"]
    data = {
        cols[0]: base["relative_position_mm"].map("{:g}".format),
        cols[1]: base["in_plan"].map({True: "yes", False: ""}),
    }
    for p in others:
        sub = d[d["path"] == p].reset_index(drop=True)
        for key, col, fmt in (
            ("dist_to_reference_mm", f"{p}\n3D (mm)", "{:.2f}"),
            ("along_mm", f"{p}\nalong (mm)", "{:+.2f}"),
            ("radial_mm", f"{p}\nradial (mm)", "{:+.2f}"),
            ("out_of_plane_mm", f"{p}\nout of plane", "{:+.2f}"),
            ("angle_deg", f"{p}\nangle (deg)", "{:.1f}"),
        ):
            data[col] = sub[key].map(fmt.format)
    table = pd.DataFrame(data)
    figs = []
    per_page = 40
    for start in range(0, len(table), per_page):
        chunk = table.iloc[start : start + per_page]
        fig = _text_page(plt, f"Deviations from the {ref} path, dwell by dwell")
        ax = fig.add_axes((0.04, 0.04, 0.92, 0.88))
        ax.axis("off")
        t = ax.table(
            cellText=chunk.to_numpy(),
            colLabels=list(chunk.columns),
            loc="upper center",
            cellLoc="center",
        )
        t.auto_set_font_size(False)
        t.set_fontsize(6.5)
        t.scale(1, 1.15)
        for (row, _), cell in t.get_celld().items():
            if row == 0:
                cell.set_height(cell.get_height() * 2.2)
        fig.text(
            0.04,
            0.935,
            textwrap.fill(
                f"{res.applicator}. along = distal positive, radial = outward in the ring plane, "
                "out of plane = cranial positive; angle between source orientations.",
                120,
            ),
            fontsize=8,
            va="top",
        )
        figs.append(fig)
    return figs


def _accuracy_page(plt, res, table: pd.DataFrame):
    """The accuracy/time study of the scene (ringqa accuracy's accuracy.csv): error vs time."""
    fig = plt.figure(figsize=A4)
    fig.suptitle(
        _title(res, "Accuracy of the simulation settings"),
        fontsize=13,
        weight="bold",
        x=0.06,
        ha="left",
    )
    ax = fig.add_axes((0.12, 0.45, 0.8, 0.45))
    ok = (table["status"] == 0) & np.isfinite(table["max_err_mm"]) & (table["max_err_mm"] > 0)
    t = table[ok]
    ax.scatter(t["time_s"], t["max_err_mm"], c="C0", s=18, label="runs (max dwell error)")
    if "pareto" in t:
        front = t[t["pareto"].astype(bool)].sort_values("time_s")
        ax.step(front["time_s"], front["max_err_mm"], where="post", c="C3", label="Pareto front")
    lim_rec = res.settings.position_limits_mm[0]
    ax.axhline(
        0.1 * lim_rec,
        color="0.4",
        ls=":",
        lw=1,
        label=f"{0.1 * lim_rec:g} mm (a tenth of the {lim_rec:g} mm tolerance)",
    )
    if len(t):
        ax.set_xscale("log")
        ax.set_yscale("log")
    ax.set_xlabel("solve time per run (s)")
    ax.set_ylabel("max dwell-position error vs converged reference (mm)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    n_bad = int((~ok).sum())
    fig.text(
        0.06,
        0.38,
        textwrap.fill(
            f"{len(table)} runs of the scene's numerical settings, {n_bad} failed, jammed or "
            "exact. The simulated dwell positions in this report are only as accurate as the "
            "settings used: compare the scene settings on page 1 with the Pareto front.",
            110,
        ),
        fontsize=9,
        va="top",
    )
    return fig


def write_pdf(
    result, path: Path, *, png_dir: Path | None = None, accuracy: pd.DataFrame | None = None
) -> Path:
    """Write the report PDF of one CommissioningResult.

    ``png_dir``: also save each page as PNG; ``accuracy``: the table of ``ringqa accuracy``
    (accuracy.csv: ``time_s, max_err_mm, status, pareto``) for an extra page.
    """
    plt = _plt()
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    with PdfPages(path) as pdf:
        figs = [
            *_title_page(plt, result),
            _positions_page(plt, result),
            _deviation_page(plt, result),
            _dose_page(plt, result),
            *_dwell_table_pages(plt, result),
            _settings_page(plt, result),
        ]
        if accuracy is not None:
            figs.append(_accuracy_page(plt, result, accuracy))
        for k, fig in enumerate(figs):
            pdf.savefig(fig)
            if png_dir is not None:
                fig.savefig(Path(png_dir) / f"page{k + 1}.png", dpi=80)
            plt.close(fig)
        info = pdf.infodict()
        info["Title"] = f"ringqa commissioning report: {result.applicator}"
        info["Creator"] = result.provenance.software
    return path


def write_batch_pdf(batch, path: Path, *, png_dir: Path | None = None) -> Path:
    """Cross-applicator report: Figure-5-like boxplots, summary table, failures."""
    plt = _plt()
    from matplotlib.backends.backend_pdf import PdfPages

    with PdfPages(path) as pdf:
        fig = plt.figure(figsize=A4)
        fig.suptitle(
            "ringqa commissioning: all applicators", fontsize=14, weight="bold", x=0.06, ha="left"
        )
        ax = fig.add_axes((0.1, 0.58, 0.85, 0.33))
        data, labels, colours = [], [], []
        for r in batch.results:
            for path in ("centreline", "simulated"):
                if path == r.reference:
                    continue
                sub = r.dwells[r.dwells["path"] == path]["dist_to_reference_mm"].to_numpy()
                data.append(sub)
                name = textwrap.shorten(r.applicator, 22, placeholder="...")
                labels.append(f"{name}\n{path[:3]}. vs {r.reference[:4]}.")
                colours.append(COLOURS[path])
        if data:
            bp = ax.boxplot(data, patch_artist=True, sym="x")
            ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=6.5, rotation=45, ha="right")
            for patch, c in zip(bp["boxes"], colours, strict=True):
                patch.set_facecolor(c)
                patch.set_alpha(0.35)
            for med in bp["medians"]:
                med.set_color("black")
        lim_rec, lim_req = (
            batch.results[0].settings.position_limits_mm if batch.results else (1.0, 2.0)
        )
        ax.axhline(lim_rec, color="#ef6c00", ls="--", lw=1, label=f"{lim_rec:g} mm recommended")
        ax.axhline(lim_req, color="#c62828", ls="--", lw=1, label=f"{lim_req:g} mm required")
        ax.legend(fontsize=7, loc="upper right")
        ax.set_ylabel("3D distance to the reference path (mm)")
        ax.set_title(
            "Distances per applicator (paper Figure 5)\nbox: interquartile range, line: "
            "median, whiskers: extremes without outliers, x: outliers",
            fontsize=8,
        )
        ax.grid(alpha=0.3, axis="y")
        refs = {r.applicator: r.reference for r in batch.results}
        if any(v == "centreline" for v in refs.values()):
            fig.text(
                0.06,
                0.475,
                textwrap.fill(
                    "Applicators without a measured source path (the shipped synthetic rings) are "
                    "compared simulated vs CENTRELINE: there is no measurement in those boxes.",
                    110,
                ),
                fontsize=8.5,
                va="top",
                color="#c62828",
            )
        cols = [
            ("applicator", "applicator", "{}"),
            ("reference", "ref.", "{}"),
            ("median_dist_sim_mm", "sim. median (mm)", "{:.2f}"),
            ("max_dist_sim_mm", "sim. max (mm)", "{:.2f}"),
            ("max_dist_centreline_mm", "cl. max (mm)", "{:.2f}"),
            ("max_abs_diff_surface_simulated_pct", "sim. surface\nmax |dD| (%)", "{:.1f}"),
            ("verdict", "verdict", "{}"),
        ]
        cells = []
        for row in batch.summary.to_dict("records"):
            row["applicator"] = textwrap.shorten(str(row.get("applicator")), 22, placeholder="...")
            cells.append([_fmt(row.get(k), f) for k, _, f in cols])
        ax = fig.add_axes((0.04, 0.25, 0.92, 0.18))
        ax.axis("off")
        if cells:
            t = ax.table(
                cellText=cells, colLabels=[c[1] for c in cols], loc="upper center", cellLoc="center"
            )
            t.auto_set_font_size(False)
            t.set_fontsize(7)
            t.scale(1, 1.3)
            for (r, _), cell in t.get_celld().items():
                if r == 0:
                    cell.set_height(cell.get_height() * 1.8)
        rows = table2_rows(batch.results)
        if rows:
            ax = fig.add_axes((0.04, 0.02, 0.92, 0.15))
            ax.axis("off")
            ax.set_title(
                "|Dose difference| between the plans over the applicators, median (range), % "
                "(paper Table 2)",
                fontsize=9,
                loc="left",
            )
            t = ax.table(
                cellText=rows,
                colLabels=["plans (applicators)", "Point A", "lateral surface", "lateral 5 mm"],
                loc="upper center",
                cellLoc="center",
            )
            t.auto_set_font_size(False)
            t.set_fontsize(8)
            t.scale(1, 1.3)
        y = 0.245
        for item, err in batch.failures:
            fig.text(
                0.06,
                y,
                textwrap.shorten(f"FAILED {item}: {err}", 150),
                fontsize=7,
                color="#c62828",
                va="top",
            )
            y -= 0.015
        pdf.savefig(fig)
        if png_dir is not None:
            fig.savefig(Path(png_dir) / "summary.png", dpi=80)
        plt.close(fig)
    return Path(path)


def table2_rows(results) -> list[list[str]]:
    """Paper Table 2 over applicators: median (range) of |dose difference| per point kind.

    One row per comparison (reference plan - other plan, e.g. "measured - centreline");
    each applicator contributes the max |difference| of its left/right points of that kind.
    """
    groups: dict[tuple[str, str], dict[str, list[float]]] = {}
    for r in results:
        for plan in ("centreline", "simulated"):
            d = r.doses[r.doses["plan"] == plan]
            if plan == r.reference or d.empty:
                continue
            per_kind = groups.setdefault(
                (r.reference, plan), {"point_a": [], "surface": [], "depth5": [], "n": []}
            )
            for kind in ("point_a", "surface", "depth5"):
                per_kind[kind].append(float(d.loc[d["kind"] == kind, "diff_pct"].abs().max()))
            per_kind["n"].append(1.0)
    rows = []
    for (ref, plan), per_kind in groups.items():
        cells = [f"{ref} - {plan} ({len(per_kind['n'])})"]
        for kind in ("point_a", "surface", "depth5"):
            v = np.asarray(per_kind[kind])
            cells.append(f"{np.median(v):.1f} ({v.min():.1f} - {v.max():.1f})")
        rows.append(cells)
    return rows


def _fmt(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-"
    try:
        return fmt.format(value)
    except (ValueError, TypeError):
        return str(value)
