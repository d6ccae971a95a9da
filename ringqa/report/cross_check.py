"""The report's page when the cross-check fails: both engines' dwells over the channel.

When the flexible-element engine's dwells disagree with the reported (rigid-link) ones by more
than the numerical errors allow (:class:`ringqa.pipeline.simulate.CrossCheck`, ``fails``; the
Numerics verdict is then FAIL), the report shows both paths: projected onto the ring plane with
the channel's centreline, the dwells beyond the limit circled and labelled with their
disagreement, and the disagreement per dwell against the limit. :func:`cross_check_page` is the
page, :func:`cross_check_figure` its figure; a report whose cross-check passed (or was not made)
has no such page.
"""

from __future__ import annotations

import numpy as np

from ringqa.report.figures import COLOURS, frame_words, new_figure, project
from ringqa.report.layout import FRAME_WIDTH, figure_image, heading, para

#: the figure's size (inches): an A4 page's frame width
CROSS_CHECK_SIZE = (7.1, 8.0)
#: the flexible engine's colour and marker in the figure
FLEXIBLE_COLOUR = "tab:purple"
BEYOND_COLOUR = "#c62828"
#: at most this many dwells beyond the limit are labelled with their disagreement (the worst)
MAX_LABELS = 8


def failed_cross_check(res):
    """The CrossCheck of ``res`` (a CommissioningResult) when it failed, else None."""
    xc = getattr(res.numerics, "cross_check", None) if res.numerics is not None else None
    return xc if xc is not None and xc.ok and xc.fails else None


def _paired(res, xc) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(relative position (n,), rigid (n, 3), flexible (n, 3), disagreement (n,)) in mm, the
    rigid (reported, simulated) dwells of ``res.dwells`` paired with the cross-check's by
    relative position (in the order of the cross-check's arrays when it has none)."""
    sim = res.dwells[res.dwells["path"] == "simulated"]
    rel_sim = sim["relative_position_mm"].to_numpy(dtype=float)
    pos_sim = sim[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)
    flex = np.asarray(xc.flexible_pos_mm, dtype=float).reshape(-1, 3)
    dis = np.asarray(xc.disagreement_mm, dtype=float).reshape(-1)
    rel = xc.relative_position_mm
    if rel is None:
        n = min(len(rel_sim), len(flex))
        return rel_sim[:n], pos_sim[:n], flex[:n], dis[:n]
    rel = np.asarray(rel, dtype=float)
    rows = [int(np.argmin(np.abs(rel_sim - r))) for r in rel]
    return rel, pos_sim[rows], flex, dis


def cross_check_figure(res, title: str | None = None):
    """Both engines' dwells when the cross-check failed (``res.numerics.cross_check``).

    Top: the reported (rigid-link) and the flexible-element engine's source positions projected
    onto the ring plane with the channel centrelines; the dwells whose disagreement exceeds the
    limit circled and labelled (mm). Bottom: the disagreement per dwell against its relative
    position, with the limit.

    Parameters
    ----------
    res : CommissioningResult
        With a failed cross-check (:func:`failed_cross_check`).
    title : str, optional
        A title above the plots.

    Returns
    -------
    matplotlib.figure.Figure
    """
    xc = res.numerics.cross_check
    rel, rigid, flex, dis = _paired(res, xc)
    beyond = dis > xc.limit_mm
    geo = res.geometry
    fig = new_figure(CROSS_CHECK_SIZE)
    ax1, ax2 = fig.subplots(2, 1, gridspec_kw={"height_ratios": [1.5, 1]})
    for name, line in geo.centrelines_mm.items():
        u, v, _ = project(np.asarray(line), geo)
        ax1.plot(u, v, "-", color="0.75", lw=1, label=f"{name} centreline")
    ur, vr, _ = project(rigid, geo)
    uf, vf, _ = project(flex, geo)
    ax1.plot(ur, vr, "o-", color=COLOURS["simulated"], ms=3.5, lw=0.8,
             label="simulated dwells (rigid links, reported)")  # fmt: skip
    ax1.plot(uf, vf, "s--", color=FLEXIBLE_COLOUR, ms=3.5, lw=0.8, mfc="none",
             label="flexible-element engine (cross-check)")  # fmt: skip
    ax1.plot(ur[beyond], vr[beyond], "o", ms=11, mfc="none", mew=1.3, color=BEYOND_COLOUR,
             label=f"disagreement above {xc.limit_mm:.2f} mm")  # fmt: skip
    worst_first = np.flatnonzero(beyond)[np.argsort(-dis[beyond], kind="stable")]
    for k in worst_first[:MAX_LABELS]:
        ax1.annotate(f"{dis[k]:.2f} mm (p = {rel[k]:g})", (ur[k], vr[k]),
                     textcoords="offset points", xytext=(7, 5), fontsize=6.5,
                     color=BEYOND_COLOUR)  # fmt: skip
    r = geo.ring_radius_mm
    lim = r + 8
    ax1.set_xlim(-lim, lim)
    ax1.set_ylim(-lim, lim)
    ax1.set_aspect("equal")
    ax1.set_anchor("W")
    plane = frame_words(res).plane  # the family's words ("ring plane" for a ring)
    ax1.set_xlabel(f"patient left (mm), in the {plane}")
    ax1.set_ylabel(f"in the {plane}, perpendicular (mm)")
    ax1.set_title(f"both engines' source positions, projected onto the {plane}", fontsize=9)
    ax1.legend(fontsize=6.5, loc="lower left", bbox_to_anchor=(1.02, 0.0), borderaxespad=0.0)
    ax1.grid(alpha=0.3)
    ax2.plot(rel, dis, "o-", color="0.25", ms=3.5, lw=0.8, label="disagreement")
    ax2.plot(rel[beyond], dis[beyond], "o", color=BEYOND_COLOUR, ms=6)
    ax2.axhline(xc.limit_mm, color=BEYOND_COLOUR, ls="--", lw=1,
                label=f"allowed: {xc.limit_mm:.2f} mm")  # fmt: skip
    ax2.set_xlabel("relative position of the dwell (mm)")
    ax2.set_ylabel("rigid vs flexible engine (mm)")
    ax2.set_title("distance between the two engines' source centres per dwell", fontsize=9)
    ax2.set_ylim(0.0, max(1.25 * float(np.nanmax(dis, initial=0.0)), 1.5 * xc.limit_mm))
    ax2.legend(fontsize=7, loc="upper right")
    ax2.grid(alpha=0.3)
    fig.subplots_adjust(left=0.1, right=0.97, bottom=0.07, top=0.93 if title else 0.96,
                        hspace=0.3)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def cross_check_page(res) -> list:
    """The report page of a failed cross-check (empty when it passed or was not made)."""
    xc = failed_cross_check(res)
    if xc is None:
        return []
    return [
        heading("Numerics FAIL: the two engines disagree", 1),
        para(
            f"{xc.text} The reported positions come from the rigid-link engine; an independent "
            "engine (flexible beam elements, a different discretisation of the same cable) puts "
            f"{int(np.sum(np.asarray(xc.disagreement_mm) > xc.limit_mm))} dwell(s) further from "
            "them than the numerical errors allow, so the simulated positions are not trusted "
            "at these settings: refine the run (--set "
            "discretisation.element_length_mm.<section>=..., --set solver.increment_mm=...) or "
            "check the scene."
        ),
        figure_image(cross_check_figure(res), 0.95 * FRAME_WIDTH),
    ]
