"""Figures of a commissioning result, as :class:`matplotlib.figure.Figure` objects.

Used by the PDF report (embedded as images) and by the notebook methods of
:class:`~ringqa.pipeline.result.CommissioningResult` (``plot_positions``, ``plot_deviations``,
``plot_doses``, through the pipeline's named seam ``REPORT_WRITERS``, which
:mod:`ringqa.report` fills when imported). No pyplot: the figures are made with
``matplotlib.figure.Figure`` directly, so making one never switches the user's backend nor adds
to pyplot's list of open figures (a notebook shows a returned Figure as it is;
``fig.savefig(...)`` works without a GUI).
matplotlib is imported only when a figure is made.

All lengths in mm, angles in degrees, as in the result's tables.
"""

from __future__ import annotations

import itertools
import textwrap

import numpy as np
import pandas as pd

COLOURS = {
    "measured": "black",
    "registered": "tab:green",
    "simulated": "tab:red",
    "centreline": "tab:blue",
}
MARKERS = {"measured": "s", "registered": "D", "simulated": "o", "centreline": "^"}
#: How the report names the pipeline's paths and plans.
PATH_LABELS = {
    "measured": "reference as supplied",
    "registered": "reference registered",
    "simulated": "simulated",
    "centreline": "centreline",
}
#: Reference flags (``reference_flag``): short name in the tables and the shading colour.
FLAG_NAMES = {"infeasible": "infeasible", "outside_channel": "outside"}
FLAG_COLOURS = {"infeasible": "#ffcdd2", "outside_channel": "#cfd8dc"}
FLAG_EDGES = {"infeasible": "#c62828", "outside_channel": "#546e7a"}
#: Figure sizes (inches), made to fill the width of an A4 page inside the report's margins.
POSITIONS_SIZE = (7.1, 8.3)
DEVIATIONS_SIZE = (7.1, 8.6)
DOSE_MAP_SIZE = (7.1, 3.5)
ACCURACY_SIZE = (7.1, 4.6)
BATCH_SIZE = (7.1, 4.4)


def new_figure(size: tuple[float, float]):
    """A :class:`matplotlib.figure.Figure` of ``size`` (inches), not registered with pyplot,
    drawn by the Agg canvas (``fig.canvas.draw()``, ``fig.savefig`` work without a GUI):
    :class:`ringqa.report.agg_text.FigureCanvas`, matplotlib's Agg canvas whose text is laid
    out and rendered once per distinct string and glyph (the same pixels), where the installed
    matplotlib is the release it was checked on, else ``FigureCanvasAgg``."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ringqa.report import agg_text

    fig = Figure(figsize=size)
    (agg_text.FigureCanvas if agg_text.checked() else FigureCanvasAgg)(fig)
    return fig


def _finish(fig, title: str | None):
    from ringqa.report import agg_text, ticks

    if title:
        fig.suptitle(title, fontsize=11, weight="bold", x=0.02, ha="left")
    if agg_text.checked():  # the matplotlib release the tick places were checked on
        ticks.ticks_in_view(fig)  # no ticks made outside the view (the same drawing)
    for ax in fig.axes:
        _pin_title(ax)
    return fig


def _pin_title(ax) -> bool:
    """Fix an axes title at its default height when nothing can push it up.

    matplotlib places a title automatically at every draw: it measures the y axis' offset text
    ("1e-5", "+1000") and any tick labels on top, which builds and measures all tick labels once
    more (13 % of the six shipped rings' PDF time, issue 16). Without tick labels on top (the
    test matplotlib's ``_update_title_position`` makes: the first major and minor x ticks'
    ``label2``; the axes of a stack sharing x, whose x tick labels are hidden, included), an x
    label at the bottom, no child axes and no offset text (checked here with the axis' own
    locator and formatter, as the draw would) the automatic place is the default one (y = 1 in
    axes coordinates): pinning it there draws the same pixels. Otherwise the title stays
    automatic. (A figure changed afterwards, e.g. by a notebook's ``ax.set_ylim`` that brings
    an offset text, keeps the pinned height.)

    Returns
    -------
    bool
        True when the title was pinned.
    """
    text = ax.get_title()
    if not text or ax.child_axes or ax.xaxis.get_label_position() == "top":
        return False
    if any(tick.label2.get_visible() for tick in (ax.xaxis.majorTicks[0], ax.xaxis.minorTicks[0])):
        return False  # tick labels on top: the draw lifts the title above them
    fmt = ax.yaxis.get_major_formatter()
    fmt.set_locs(ax.yaxis.get_majorticklocs())  # as the draw does (Axis._update_ticks)
    if fmt.get_offset():
        return False
    t = ax.title  # set_title again with y: matplotlib's public way to switch auto placing off
    ax.set_title(text, fontsize=t.get_fontsize(), fontweight=t.get_fontweight(),
                 color=t.get_color(), y=1.0)  # fmt: skip
    return True


def frame_axes(geometry):
    """The applicator frame's axes of a :class:`~ringqa.pipeline.result.RingGeometry` (its
    family's frame; the ``ring_*`` names are results.json's): centre (3,), e_left (3,), e_ant
    (3,) across the cranial axis, e_cranial (3,)."""
    c = np.asarray(geometry.ring_centre_mm, dtype=float)
    n = np.asarray(geometry.ring_normal, dtype=float)
    n = n / np.linalg.norm(n)
    lat = np.asarray(geometry.ring_lateral, dtype=float)
    lat = lat - np.dot(lat, n) * n
    lat /= np.linalg.norm(lat)
    return c, lat, np.cross(n, lat), n


def project(xyz, geometry):
    """Points (n, 3) in mm -> (left, perpendicular across the cranial axis, cranial)
    coordinates in the applicator frame, mm (three arrays of n)."""
    c, e1, e2, n = frame_axes(geometry)
    d = np.asarray(xyz, dtype=float).reshape(-1, 3) - c
    return d @ e1, d @ e2, d @ n


def frame_words(res):
    """The report words of the frame ``res`` is drawn in (its applicator's family:
    :class:`ringqa.geometry.families.FamilyWords`; a ring's for an unknown family)."""
    from ringqa.geometry.families import FAMILIES

    family = FAMILIES.get(getattr(res, "frame_family", "ring")) or FAMILIES["ring"]
    return family.words


def path_label(path: str, reference: str) -> str:
    """How a path (or its plan) is named in legends and tables."""
    if path == reference == "centreline":
        return "centreline (the reference)"
    return PATH_LABELS.get(path, path)


def reference_name(res) -> str:
    """The path the others are compared with, for page titles."""
    if res.reference != "measured":
        return "centreline (the reference)"
    mode = res.summary.registration
    return "reference path" if mode == "none" else f"registered reference path ({mode})"


def reference_flags(res) -> pd.DataFrame:
    """Per reference dwell: ``relative_position_mm``, ``flag`` (of the path as compared) and
    ``flag_supplied`` (of the path as supplied); ``""`` when the position is fine."""
    d = res.dwells
    base = d[d["path"] == res.reference].reset_index(drop=True)
    n = len(base)
    flags = base["reference_flag"] if "reference_flag" in base else pd.Series([""] * n)
    flags = flags.fillna("").astype(str).to_numpy()
    review = res.reference_check
    raw = flags
    if review is not None and len(review.raw_flags) == n:
        raw = np.asarray(review.raw_flags, dtype=str)
    return pd.DataFrame(
        {
            "relative_position_mm": base["relative_position_mm"].to_numpy(),
            "flag": flags,
            "flag_supplied": raw,
        }
    )


def _flagged_rows(res) -> pd.DataFrame:
    """The reference rows (as compared: registered when registered) that carry a flag."""
    d = res.dwells
    path = "registered" if "registered" in set(d["path"]) else res.reference
    sub = d[d["path"] == path].reset_index(drop=True)
    flags = reference_flags(res)["flag"]
    return sub.assign(flag=flags.to_numpy())[flags.to_numpy() != ""]


def _shade_flags(ax, table: pd.DataFrame, legend: bool) -> None:
    """Shade the relative positions whose reference position is flagged (``table``:
    :func:`reference_flags` of the result)."""
    rel = table["relative_position_mm"].to_numpy(dtype=float)
    half = 0.5 * float(np.median(np.diff(np.sort(rel)))) if rel.size > 1 else 0.5
    seen = set()
    for x, flag in zip(rel, table["flag"], strict=True):
        if flag not in FLAG_COLOURS:
            continue
        label = None
        if legend and flag not in seen:
            label = f"reference position {FLAG_NAMES[flag]}"
            seen.add(flag)
        ax.axvspan(
            x - half, x + half, color=FLAG_COLOURS[flag], alpha=0.8, lw=0, zorder=0, label=label
        )


def positions_figure(res, title: str | None = None):
    """Dwell positions like Figure 6 of Straathof et al. (2024): projected onto the ring plane
    and orthogonal to it, every path of ``res.dwells``, the channel centrelines and the flagged
    reference positions.

    Parameters
    ----------
    res : CommissioningResult
    title : str, optional
        A title above the plots (the report gives none: its page has a heading).

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(POSITIONS_SIZE)
    axes = fig.subplots(2, 1, gridspec_kw={"height_ratios": [1.35, 1]})
    geo = res.geometry
    ax1, ax2 = axes
    for name, line in geo.centrelines_mm.items():
        u, v, h = project(np.asarray(line), geo)
        ax1.plot(u, v, "-", color="0.75", lw=1, label=f"{name} centreline")
        ax2.plot(u, h, "-", color="0.75", lw=1)
    d = res.dwells
    for path in ("measured", "registered", "centreline", "simulated"):
        sub = d[d["path"] == path]
        if sub.empty:
            continue
        u, v, h = project(sub[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
        kw = {
            "color": COLOURS[path],
            "marker": MARKERS[path],
            "ms": 4,
            "lw": 0.8,
            "mfc": "none" if path != "simulated" else COLOURS[path],
        }
        ax1.plot(u, v, label=f"{path_label(path, res.reference)} dwells", **kw)
        ax2.plot(u, h, **kw)
        if path == res.reference:
            rel = sub["relative_position_mm"].to_numpy()
            for k in range(0, len(u), 4):
                ax1.annotate(
                    f"{rel[k]:g}",
                    (u[k], v[k]),
                    textcoords="offset points",
                    xytext=(6, 4),
                    fontsize=6,
                    color="0.3",
                )
    flagged = _flagged_rows(res)
    for flag, rows in flagged.groupby("flag", sort=False):
        u, v, h = project(rows[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
        kw = {
            "ls": "none",
            "marker": "o",
            "ms": 10,
            "mfc": "none",
            "mew": 1.2,
            "color": FLAG_EDGES.get(flag, "0.3"),
        }
        ax1.plot(u, v, label=f"reference position {FLAG_NAMES.get(flag, flag)}", **kw)
        ax2.plot(u, h, **kw)
    r = geo.ring_radius_mm
    lim = r + 8
    plane = frame_words(res).plane
    ax1.set_xlim(-lim, lim)
    ax1.set_ylim(-lim, lim)
    ax1.set_aspect("equal")
    ax1.set_xlabel(f"patient left (mm), in the {plane}")
    ax1.set_ylabel(f"in the {plane}, perpendicular (mm)")
    ax1.set_title(
        f"projected onto the {plane} (seen from cranial); numbers: relative position (mm)",
        fontsize=9,
    )
    ax1.plot(0, 0, "k+")
    # beside the ring (the square axes, drawn at the left, leave room): never over a dwell
    ax1.set_anchor("W")
    ax1.legend(fontsize=6.5, loc="lower left", bbox_to_anchor=(1.02, 0.0), borderaxespad=0.0)
    ax1.grid(alpha=0.3)
    ax2.set_xlim(-lim, lim)
    ax2.set_xlabel(f"patient left (mm), in the {plane}")
    ax2.set_ylabel(f"cranial (mm), orthogonal to the {plane}")
    ax2.set_title(f"orthogonal to the {plane} (seen from anterior/posterior)", fontsize=9)
    ax2.grid(alpha=0.3)
    _, _, hh = project(d[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    span = max(3.0, float(np.max(np.abs(hh))) * 1.3) if hh.size else 3.0
    ax2.set_ylim(-span, span)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.06, top=0.95 if title else 0.97,
                        hspace=0.22)  # fmt: skip
    return _finish(fig, title)


def _compared_paths(dwells, ref: str):
    """(path, its rows) for the simulated and centreline paths other than the reference."""
    for path in ("simulated", "centreline"):
        if path != ref:
            yield path, dwells[dwells["path"] == path]


def deviation_caption(res) -> str:
    """What the deviation figure compares, in one or two sentences."""
    text = f"Simulated and centreline dwells compared with the {reference_name(res)}."
    if (reference_flags(res)["flag"] != "").any():
        text += (
            " Shaded: reference positions that are infeasible (red) or outside the channel (grey)."
        )
    return text


def deviations_figure(res, title: str | None = None):
    """Deviation per dwell: 3D distance (with the simulation's numerical error), its along /
    radial / out-of-plane components (mm) and the angle between source orientations (deg),
    flagged reference positions shaded.

    Parameters
    ----------
    res : CommissioningResult
    title : str, optional
        A title above the plots.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(DEVIATIONS_SIZE)
    axes = fig.subplots(3, 1, sharex=True)
    ref = res.reference
    versus = "reference" if ref == "measured" else "centreline"
    d = res.dwells
    lim_rec, lim_req = res.settings.position_limits_mm
    compared = list(_compared_paths(d, ref))  # (path, its rows): the three axes' lines
    flags = reference_flags(res)
    ax = axes[0]
    for path, sub in compared:
        rel = sub["relative_position_mm"].to_numpy(dtype=float)
        dist = sub["dist_to_reference_mm"].to_numpy(dtype=float)
        ax.plot(
            rel, dist, marker=MARKERS[path], color=COLOURS[path], ms=4, label=f"{path} vs {versus}"
        )
        if path == "simulated" and "numerical_error_mm" in sub:
            err = sub["numerical_error_mm"].fillna(0.0).to_numpy(dtype=float)
            ax.fill_between(
                rel,
                np.clip(dist - err, 0, None),
                dist + err,
                color=COLOURS[path],
                alpha=0.25,
                lw=0,
                label="simulated ± its numerical error",
            )
            ax.plot(
                rel,
                err,
                ls=":",
                color=COLOURS[path],
                lw=1.2,
                label="numerical error of the simulation",
            )
    moved = d[d["path"] == "measured"] if "registered" in set(d["path"]) else d.iloc[:0]
    if not moved.empty:
        ax.plot(
            moved["relative_position_mm"],
            moved["dist_to_reference_mm"],
            ls="--",
            lw=1,
            color=COLOURS["measured"],
            label="reference as supplied vs registered",
        )
    ax.axhline(lim_rec, color="#ef6c00", ls="--", lw=1, label=f"{lim_rec:g} mm recommended")
    ax.axhline(lim_req, color="#c62828", ls="--", lw=1, label=f"{lim_req:g} mm required")
    _shade_flags(ax, flags, legend=True)
    ax.set_ylabel("3D distance (mm)")
    ax.set_ylim(0, 1.6 * max(ax.get_ylim()[1], lim_req))  # room for the legend
    ax.legend(fontsize=6.5, ncol=2, loc="upper center")
    ax.grid(alpha=0.3)
    ax = axes[1]
    styles = {"along_mm": "-", "radial_mm": "--", "out_of_plane_mm": ":"}
    for path, sub in compared:
        for comp, ls in styles.items():
            ax.plot(
                sub["relative_position_mm"],
                sub[comp],
                ls=ls,
                color=COLOURS[path],
                lw=1.2,
                label=f"{path}: {comp[:-3].replace('_', '-')}",
            )
    _shade_flags(ax, flags, legend=False)
    ax.axhline(0, color="0.5", lw=0.6)
    ax.set_ylabel("component (mm)")
    ax.set_title(
        f"along = distal positive; radial = outward in the {frame_words(res).plane}; "
        "out-of-plane = cranial positive",
        fontsize=8,
    )
    ax.legend(fontsize=6.5, ncol=2)
    ax.grid(alpha=0.3)
    ax = axes[2]
    for path, sub in compared:
        ax.plot(
            sub["relative_position_mm"],
            sub["angle_deg"],
            marker=MARKERS[path],
            ms=4,
            color=COLOURS[path],
            label=f"{path} vs {versus}",
        )
    _shade_flags(ax, flags, legend=False)
    ax.set_ylabel("orientation difference (deg)")
    ax.set_xlabel("relative position (mm), 0 = most distal dwell")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.06, top=0.95 if title else 0.98,
                        hspace=0.18)  # fmt: skip
    return _finish(fig, title)


#: dose points closer than this in a view (mm) share one label
LABEL_MERGE_MM = 3.0
#: vertical label offsets (points) tried in turn for neighbouring dose points
LABEL_LEVELS_PT = (5, -11, 14, -20, 23, -29)


def label_groups(x, y, labels, tol_mm: float) -> list[tuple[float, float, list[str]]]:
    """Labels of points within ``tol_mm`` of a group's first point joined into one group
    ``(x, y, [labels])`` (first point's place), in the order of the points."""
    groups: list[tuple[float, float, list[str]]] = []
    for xi, yi, label in zip(x, y, labels, strict=True):
        for gx, gy, names in groups:
            if float(np.hypot(gx - xi, gy - yi)) < tol_mm:
                names.append(label)
                break
        else:
            groups.append((float(xi), float(yi), [label]))
    return groups


def dose_points_figure(res, title: str | None = None):
    """The dose points beside the standard plan's dwells: the ring plane (seen from cranial) and
    the orthogonal view, zoomed on the dwells and points (mm).

    Parameters
    ----------
    res : CommissioningResult
    title : str, optional
        A title above the plots.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(DOSE_MAP_SIZE)
    ax1, ax2 = fig.subplots(1, 2)
    geo = res.geometry
    for line in geo.centrelines_mm.values():
        u, v, h = project(np.asarray(line), geo)
        ax1.plot(u, v, "-", color="0.75", lw=1)
        ax2.plot(u, h, "-", color="0.75", lw=1)
    pdw = res.plan_dwells
    ref_plan = pdw[pdw["plan"] == res.reference]
    u, v, h = project(ref_plan[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    ax1.plot(u, v, "k.", ms=5, label="standard-plan dwells")
    ax2.plot(u, h, "k.", ms=5)
    pts = res.doses[res.doses["plan"] == res.reference]
    pu, pv, ph = project(pts[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
    short = {
        "point_a_left": "A L",
        "point_a_right": "A R",
        "surface_left": "S L",
        "surface_right": "S R",
        "depth5_left": "5 L",
        "depth5_right": "5 R",
    }
    labels = [short.get(name, name) for name in pts["point"]]
    colours = ["tab:green" if kind != "tps" else "tab:purple" for kind in pts["kind"]]
    # one line of star markers per run of points of one colour: the markers drawn in the
    # points' order, as one line per point would draw them (the same pixels)
    start = 0
    for colour, run in itertools.groupby(colours):
        stop = start + len(list(run))
        ax1.plot(pu[start:stop], pv[start:stop], "*", color=colour, ms=9)
        ax2.plot(pu[start:stop], ph[start:stop], "*", color=colour, ms=9)
        start = stop
    # points that fall (nearly) on one another in a view share one label ("A L / S L / A2"):
    # one label per place, none printed over another
    # ... written outward (left of a point on the patient's right, right of one on the left),
    # neighbours on one side alternately above and below
    for ax, yy in ((ax1, pv), (ax2, ph)):
        groups = label_groups(pu, yy, labels, LABEL_MERGE_MM)
        placed: list[tuple[float, float, float, int]] = []  # x, y, side, level
        for x0, y0, names in sorted(groups, key=lambda g: abs(g[0])):
            side = -1.0 if x0 < 0 else 1.0
            near = {lv for px, py, ps, lv in placed
                    if ps == side and abs(px - x0) < 8.0 and abs(py - y0) < 6.0}  # fmt: skip
            level = next(lv for lv in LABEL_LEVELS_PT if lv not in near)
            placed.append((x0, y0, side, level))
            ax.annotate(" / ".join(names), (x0, y0), xytext=(4 * side, level),
                        textcoords="offset points", fontsize=7,
                        ha="left" if side > 0 else "right")  # fmt: skip
    # zoom on the dwells and points (the channels' long stems would dwarf them)
    for ax, xs, ys in ((ax1, (u, pu), (v, pv)), (ax2, (u, pu), (h, ph))):
        xx, yy = np.concatenate(xs), np.concatenate(ys)
        half = 0.5 * max(np.ptp(xx), np.ptp(yy)) + 8.0
        cx, cy = 0.5 * (xx.max() + xx.min()), 0.5 * (yy.max() + yy.min())
        ax.set_xlim(cx - half, cx + half)
        ax.set_ylim(cy - half, cy + half)
    for ax, ylabel, view in (
        (
            ax1,
            f"in the {frame_words(res).plane} (mm)",
            f"{frame_words(res).plane} (seen from cranial)",
        ),
        (ax2, "cranial (mm)", "orthogonal view"),
    ):
        ax.set_xlabel("patient left (mm)")
        ax.set_ylabel(ylabel)
        ax.set_title(view, fontsize=9)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    ax1.legend(fontsize=7, loc="lower right")
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.13, top=0.86 if title else 0.92,
                        wspace=0.3)  # fmt: skip
    return _finish(fig, title)


def dose_points_caption(res) -> str:
    """Where the dose points are, in words (mm)."""
    spec = res.settings.dose_points
    words = frame_words(res)
    text = (
        f"A L/R = Point A left/right: {spec.point_a_lateral_mm:g} mm lateral of the "
        f"{words.axis}, {spec.point_a_height_mm:g} mm cranial of the {words.origin}. "
    )
    kinds = set(res.doses["kind"].astype(str)) if "kind" in res.doses else set()
    if "surface" in kinds:  # the ring's own points (issue 30: only for rings)
        text += (
            f"S L/R = lateral ring surface, {spec.surface_offset_mm:g} mm outside the channel "
            f"centreline in the {words.plane} (outer surface of the Ring CT/MR mesh). 5 L/R = "
            f"{spec.depth_mm:g} mm deeper. "
        )
    return text + "Purple: the RT Plan's own points."


def accuracy_figure(res, table: pd.DataFrame, title: str | None = None):
    """The accuracy/time study of the scene (``ringqa accuracy``'s accuracy.csv): max dwell
    error (mm) against solve time (s), the Pareto front and a tenth of the tolerance.

    Parameters
    ----------
    res : CommissioningResult
    table : pandas.DataFrame
        ``time_s, max_err_mm, status[, pareto]``.
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(ACCURACY_SIZE)
    ax = fig.add_subplot()
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
    fig.subplots_adjust(left=0.11, right=0.97, bottom=0.11, top=0.92 if title else 0.97)
    return _finish(fig, title)


def accuracy_caption(table: pd.DataFrame) -> str:
    """How many runs the accuracy table holds and how to read it."""
    ok = (table["status"] == 0) & np.isfinite(table["max_err_mm"]) & (table["max_err_mm"] > 0)
    return (
        f"{len(table)} runs of the scene's numerical settings, {int((~ok).sum())} failed, jammed "
        "or exact. The simulated dwell positions in this report are only as accurate as the "
        "settings used: compare the scene settings (settings page) with the Pareto front."
    )


def batch_distances(batch) -> tuple[list[np.ndarray], list[str], list[str]]:
    """What :func:`batch_distances_figure` plots: per applicator and compared path, the 3D
    distances the verdicts judge (to the registered reference, reference positions outside the
    channel left out: :meth:`~ringqa.pipeline.result.CommissioningResult.compared_dwells`),
    with the box's label and colour. Their medians and maxima are summary.csv's
    ``median_dist_*`` / ``max_dist_*`` (``_registered`` for a registered run).

    Returns
    -------
    (list of ndarray, list of str, list of str)
        Distances (mm), labels, colours; one per box.
    """
    data, labels, colours = [], [], []
    for r in batch.results:
        for path in ("centreline", "simulated"):
            if path == r.reference:
                continue
            data.append(r.compared_dwells(path)["dist_to_reference_mm"].to_numpy(dtype=float))
            name = textwrap.shorten(r.applicator, 22, placeholder="...")
            labels.append(f"{name}\n{path[:3]}. vs {r.reference[:4]}.")
            colours.append(COLOURS[path])
    return data, labels, colours


def batch_distances_figure(batch, title: str | None = None):
    """Distances to the reference per applicator, like Figure 5 of Straathof et al. (2024):
    one box per applicator and compared path (mm), with the position tolerances.

    Parameters
    ----------
    batch : BatchResult
    title : str, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = new_figure(BATCH_SIZE)
    ax = fig.add_subplot()
    data, labels, colours = batch_distances(batch)
    if data:
        bp = ax.boxplot(data, patch_artist=True, sym="x")
        ax.set_xticks(range(1, len(labels) + 1), labels, fontsize=6.5, rotation=45, ha="right")
        for patch, c in zip(bp["boxes"], colours, strict=True):
            patch.set_facecolor(c)
            patch.set_alpha(0.35)
        for med in bp["medians"]:
            med.set_color("black")
    lim_rec, lim_req = batch.results[0].settings.position_limits_mm if batch.results else (1.0, 2.0)
    ax.axhline(lim_rec, color="#ef6c00", ls="--", lw=1, label=f"{lim_rec:g} mm recommended")
    ax.axhline(lim_req, color="#c62828", ls="--", lw=1, label=f"{lim_req:g} mm required")
    ax.legend(fontsize=7, loc="upper right")
    ax.set_ylabel("3D distance to the reference path (mm)")
    ax.grid(alpha=0.3, axis="y")
    fig.subplots_adjust(left=0.1, right=0.98, bottom=0.3, top=0.88 if title else 0.9)
    return _finish(fig, title)
