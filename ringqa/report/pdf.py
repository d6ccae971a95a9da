"""The PDF report a physicist signs (matplotlib PdfPages, A4 portrait).

Pages per applicator:
1. Commissioning summary (:func:`page1_items`, flowed onto a second text page when it does not
   fit): title block (applicator, source, plan, tolerances, software, date, inputs with SHA-256),
   where the reference path comes from and what its checks found (planar, constant height,
   infeasible positions, positions outside the channel, the registration and its transform), the
   verdicts grouped by role (TPS model, simulation check, numerics) with the one-line conclusion,
   the numbers "as supplied | registered" side by side with the simulation's numerical error, the
   notes and the signature lines.
2. Dwell positions like the paper's Figure 6: projected onto the ring plane and orthogonal to it,
   reference (as supplied and registered) / simulated / centreline, with the channel centreline
   and the flagged reference positions.
3. Deviation per dwell: 3D distance (with the simulation's numerical error),
   along/radial/out-of-plane components, angle of orientation; flagged reference positions shaded.
4. Dose points: map (ring plane and side view) and the dose table of the standard plans
   (differences to the reference plan as supplied and, when registered, as registered; the RT
   Plan's own doses beside the TPS values).
5. Dwell-by-dwell table (reference flags, numerical error).
6. Settings of the run.
Batch: a cross-applicator page with Figure-5-like boxplots and the summary table.

The report names the pipeline's ``measured`` path "the reference path (as supplied)": it is what
the user or the applicator library supplies, a measurement only when its source says so.
"""

from __future__ import annotations

import functools
import re
import textwrap
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ringqa.pipeline import RingGeometry
from ringqa.report.fields import ReportFields
from ringqa.units import m_to_mm

A4 = (8.27, 11.69)
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
#: Reference flags (``reference_flag``): short name in the tables and the shading colour.
FLAG_NAMES = {"infeasible": "infeasible", "outside_channel": "outside"}
FLAG_COLOURS = {"infeasible": "#ffcdd2", "outside_channel": "#cfd8dc"}
FLAG_EDGES = {"infeasible": "#c62828", "outside_channel": "#546e7a"}
#: The dwell table's column of the flags of the reference path as supplied (when registered).
SUPPLIED_FLAG_COLUMN = "reference\nas\nsupplied"
#: Verdict roles in page-1 order (:mod:`ringqa.pipeline.verdicts`).
ROLE_ORDER = ("input check", "TPS model", "simulation check", "numerics")
#: Point kinds of the comparison table, in the order the issue names them.
DOSE_KINDS = (("surface", "surface"), ("depth5", "5 mm deeper"), ("point_a", "Point A"))
#: Page-1 wording: what the pipeline's notes call the reference, and the report's words for it.
PLAIN_WORDS = (
    (r"measured source path", "reference source path"),
    (r"measured path", "reference path"),
    (r"measured plan", "standard plan on the reference path"),
)


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


# ---------------------------------------------------------------------------------------------
# Page 1 as text: pure functions of the result (tested without rendering)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TextItem:
    """One piece of a text page.

    Attributes
    ----------
    kind : str
        ``heading``, ``subheading``, ``field`` (``label``: its name), ``file`` (``text``: the
        path, ``label``: its SHA-256), ``text``, ``verdict`` (``label``: its status),
        ``conclusion`` (``label``: the overall verdict, its frame's colour), ``table``
        (``rows``) or ``note``.
    text : str
        What it says.
    label : str
        The field's name, the file's digest, the verdict's status or the overall verdict.
    rows : tuple of tuple of str
        The table's rows, the header first (``table`` only).
    """

    kind: str
    text: str = ""
    label: str = ""
    rows: tuple[tuple[str, ...], ...] = ()

    def lines(self) -> list[str]:
        """The item as plain lines (a table: one line per row, cells joined by ``" | "``)."""
        if self.kind == "table":
            return [" | ".join(row) for row in self.rows]
        if self.kind == "file":
            return [f"{self.text} (SHA-256 {self.label})"]
        if self.label and self.kind != "conclusion":
            return [f"{self.label}: {self.text}"]
        return [self.text]


def fmt_value(value, fmt: str = "{:.2f}", missing: str = "-") -> str:
    """``value`` formatted with ``fmt``; ``missing`` for None, NaN or infinity (never "nan")."""
    if value is None:
        return missing
    try:
        if not np.isfinite(float(value)):
            return missing
    except (TypeError, ValueError):
        return str(value)
    try:
        text, zero = fmt.format(value), fmt.format(0.0)
    except (TypeError, ValueError):
        return str(value)
    return zero if text.lstrip("+-") == zero.lstrip("+-") else text  # no "-0.00"


def plain_wording(text: str, keep: Iterable[str] = ()) -> str:
    """``text`` with the pipeline's "measured path/plan" called the reference path/plan.

    The strings in ``keep`` (where the path comes from, in its own words) are left unchanged.
    """
    kept = [k for k in keep if k]
    if kept:
        pattern = "(" + "|".join(re.escape(k) for k in kept) + ")"
        parts = re.split(pattern, text)
        return "".join(p if p in kept else plain_wording(p) for p in parts)
    for old, new in PLAIN_WORDS:
        text = re.sub(
            old,
            lambda m, new=new: new[0].upper() + new[1:] if m.group(0)[0].isupper() else new,
            text,
            flags=re.IGNORECASE,
        )
    return text


def transform_text(matrix_m) -> str:
    """The registration's 4x4 transform in words: rotation (deg, about the coordinate origin)
    and translation (mm) applied to the supplied path."""
    m = np.asarray(matrix_m, dtype=float)
    if np.allclose(m, np.eye(4), rtol=0.0, atol=1e-12):
        return "Transform: none (the supplied positions are compared unchanged)."
    rot = m[:3, :3]
    t_mm = m_to_mm(m[:3, 3])
    angle = float(np.degrees(np.arccos(np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0))))
    xyz = ", ".join(fmt_value(x, "{:+.2f}") for x in t_mm)
    text = (
        f"Transform applied to the supplied path (patient coordinates): translation "
        f"(x, y, z) = ({xyz}) mm, {fmt_value(float(np.linalg.norm(t_mm)))} mm in all; "
        f"rotation {fmt_value(angle)} deg"
    )
    if angle >= 0.005:
        axis = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
        norm = float(np.linalg.norm(axis))
        if norm > 0:
            text += " about the axis (" + ", ".join(f"{x:+.3f}" for x in axis / norm) + ")"
        text += ", applied before the translation"
    return text + "."


def _reference_kind_text(res) -> str:
    """The plan and path the others are compared with, in words."""
    if res.reference == "measured":
        return "the reference path"
    return "the channel centreline (no reference path supplied)"


def header_items(res) -> list[TextItem]:
    """The title block: applicator, source, plan, tolerances, software, date, input files."""
    s = res.settings
    prov = res.provenance
    items = [
        TextItem(
            "field", f"{res.applicator}  (input: {res.input}, {res.input_kind})", "Applicator"
        ),
        TextItem(
            "field",
            f"{s.source} (TG-43), S_K = {fmt_value(s.sk_U, '{:.0f}')} U; cable model: "
            f"{s.cable} preset (all simulation settings: last page)",
            "Source, cable",
        ),
        TextItem(
            "field",
            f"dwells every {s.plan_step_mm:g} mm on {_reference_kind_text(res)}, equal times, "
            f"mean Point A dose = {s.prescription_gy:g} Gy; the same times on the simulated and "
            "centreline dwells",
            "Standard plan",
        ),
        TextItem(
            "field",
            f"{fmt_value(res.summary.s_ref_mm)} mm of centreline arc length from the channel "
            "entry to relative position 0 (most distal dwell)",
            "s_ref",
        ),
        TextItem(
            "field",
            f"position {s.position_limits_mm[0]:g} mm recommended / "
            f"{s.position_limits_mm[1]:g} mm required (AAPM MPPG 13.a); "
            f"dose action level {s.dose_action_pct:g} %",
            "Tolerances",
        ),
        TextItem(
            "field",
            f"{prov.software} (Python {prov.python}); {prov.created_utc} UTC",
            "Software, date",
        ),
    ]
    if prov.inputs:
        items.append(TextItem("field", f"{len(prov.inputs)} file(s)", "Inputs (SHA-256)"))
        items += [TextItem("file", str(path), digest) for path, digest in prov.inputs.items()]
    else:
        items.append(
            TextItem("field", "(applicator object given in Python, no file)", "Inputs (SHA-256)")
        )
    return items


def reference_items(res) -> list[TextItem]:
    """Where the reference path comes from, what its checks found, how it was registered."""
    items = [TextItem("heading", "Reference path")]
    review = res.reference_check
    if review is None:
        return [*items, TextItem("text", f"The reference is {_reference_kind_text(res)}.")]
    items += [TextItem("text", line) for line in review.lines()]
    if review.registration is not None:
        items.append(TextItem("text", transform_text(review.registration.matrix())))
    return items


def role_heading(role: str, reference: str) -> str:
    """The sub-heading of one verdict role on page 1."""
    against = "reference path" if reference == "measured" else "centreline (the reference)"
    return {
        "TPS model": "TPS model (centreline vs reference path): a finding about planning on the "
        "channel centreline",
        "simulation check": f"Simulation check (simulated vs {against}): does the simulation "
        "reproduce it?",
        "numerics": "Numerics: the simulation's numerical error",
    }.get(role, role.capitalize() if role else "Other checks")


def verdict_items(res) -> list[TextItem]:
    """The verdicts grouped by role, then the one-line conclusion."""
    groups: dict[str, list] = {role: [] for role in ROLE_ORDER}
    for v in res.verdicts:
        groups.setdefault(v.role, []).append(v)
    items = [TextItem("heading", "Verdicts")]
    for role, verdicts in groups.items():
        if not verdicts and not (role == "TPS model" and res.reference != "measured"):
            continue
        items.append(TextItem("subheading", role_heading(role, res.reference)))
        if not verdicts:
            items.append(
                TextItem(
                    "text",
                    "No finding: without a reference path the centreline itself is the "
                    "reference, so planning on it cannot be checked here.",
                )
            )
        items += [TextItem("verdict", v.text, v.status) for v in verdicts]
    text = res.conclusion or "Conclusion: not stated by the run."
    items.append(TextItem("conclusion", text, res.summary.verdict))
    return items


def comparison_rows(res) -> list[tuple[str, str, str]]:
    """The page-1 table: each number against the reference as supplied and as registered.

    Returns
    -------
    list of (str, str, str)
        The header (``"", "as supplied", "registered (<mode>)"``), then one row per number.
    """
    s = res.summary
    num = res.numerics
    measured = res.reference == "measured"
    rows = [("", "as supplied", f"registered ({s.registration})")]
    against = "reference" if measured else "centreline (reference)"
    pairs = [("Simulated", s.simulated, s.simulated_registered)]
    if measured:
        pairs.append(("Centreline", s.centreline, s.centreline_registered))
    for name, raw, reg in pairs:
        reg = raw if reg is None else reg
        for what, attr in (("median", "median_dist_mm"), ("max", "max_dist_mm")):
            rows.append(
                (
                    f"{name} vs {against}: {what} distance (mm)",
                    fmt_value(getattr(raw, attr, None)),
                    fmt_value(getattr(reg, attr, None)),
                )
            )
        if name == "Simulated":
            err = (s.max_numerical_error_mm, s.median_numerical_error_mm)
            if num is not None:
                err = (num.max_mm, num.median_mm)
            text = f"{fmt_value(err[0], '{:.3f}')} ({fmt_value(err[1], '{:.3f}')})"
            rows.append(("Simulated: numerical error, max (median) (mm)", text, text))
    reg_diffs = s.max_abs_diff_registered_pct or s.max_abs_diff_pct
    for plan, per_kind in s.max_abs_diff_pct.items():
        for kind, where in DOSE_KINDS:
            rows.append(
                (
                    f"{plan.capitalize()} plan: max |dose difference|, {where} (%)",
                    fmt_value(per_kind.get(kind)),
                    fmt_value(reg_diffs.get(plan, {}).get(kind)),
                )
            )
    if measured:
        rows.append(
            (
                "Reference positions that cannot lie in the lumen",
                str(s.n_reference_infeasible_raw),
                str(s.n_reference_infeasible),
            )
        )
        review = res.reference_check
        n_out_raw = (
            s.n_reference_outside if review is None else review.count("outside_channel", raw=True)
        )
        rows.append(
            (
                "Reference positions outside the channel (left out)",
                str(n_out_raw),
                str(s.n_reference_outside),
            )
        )
    return rows


def comparison_items(res) -> list[TextItem]:
    """The "as supplied | registered" table, what its columns mean, the numerical error."""
    mode = res.summary.registration
    if res.reference != "measured":
        meaning = (
            "Registration: none (the centreline is the reference, nothing to register): both "
            "columns are equal."
        )
    elif mode == "none":
        meaning = (
            "Registration: none: the reference path is compared as supplied, so both columns are "
            "equal."
        )
    else:
        meaning = (
            f"Registration: {mode}: 'registered' compares with the reference path moved onto the "
            "channel (transform above); the verdicts judge the registered column."
        )
    dist = "distances" if res.reference == "measured" else "distances to the centreline"
    items = [
        TextItem("heading", "The numbers side by side: as supplied | registered"),
        TextItem("table", rows=tuple(comparison_rows(res))),
        TextItem("text", meaning),
        TextItem("subheading", f"Numerical error of the simulation (beside the simulated {dist})"),
    ]
    numerics = res.numerics
    if numerics is None or not numerics.text:
        return [*items, TextItem("text", "Not estimated in this run.")]
    return [*items, *(TextItem("text", line) for line in numerics.text)]


def note_items(res) -> list[TextItem]:
    """The run's notes (in the report's wording)."""
    return [TextItem("heading", "Notes"), *(TextItem("note", note) for note in res.notes)]


def page1_items(result) -> list[TextItem]:
    """Everything page 1 (and its continuation) says, in order, in the report's wording.

    The pipeline's sentences (reference checks, verdicts, notes) call the supplied path the
    "reference path" (:func:`plain_wording`); where the path comes from is quoted as given.

    Parameters
    ----------
    result : CommissioningResult

    Returns
    -------
    list of TextItem
    """
    items = [
        *header_items(result),
        *reference_items(result),
        *verdict_items(result),
        *comparison_items(result),
        *note_items(result),
    ]
    review = result.reference_check
    keep = () if review is None else (review.source,)
    return [
        it
        if it.kind in ("field", "file")  # names and paths as given
        else TextItem(
            it.kind,
            plain_wording(it.text, keep),
            it.label,
            tuple(tuple(plain_wording(c, keep) for c in row) for row in it.rows),
        )
        for it in items
    ]


def page1_lines(result) -> list[str]:
    """Page 1's text as plain lines (what the physicist reads, without the layout)."""
    return [line for item in page1_items(result) for line in item.lines()]


# ---------------------------------------------------------------------------------------------
# Page 1 rendered: text items flowed onto A4 pages
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Style:
    x: float
    size: float
    width: int
    weight: str = "normal"
    family: str = "sans-serif"
    before: float = 0.0
    after: float = 0.003


#: kind -> layout (x in figure fraction, font size, wrap width in characters, spacing)
_STYLES = {
    "heading": _Style(0.06, 11.5, 80, "bold", before=0.012, after=0.006),
    "subheading": _Style(0.07, 8.5, 105, "bold", before=0.004, after=0.003),
    "field": _Style(0.25, 8.5, 88),
    "file": _Style(0.25, 7.0, 100),
    "text": _Style(0.075, 8.5, 112, after=0.004),
    "verdict": _Style(0.165, 8.5, 100, after=0.006),
    "conclusion": _Style(0.07, 10.5, 86, "bold", before=0.01, after=0.016),
    "table": _Style(0.075, 8.0, 110, family="monospace", before=0.002, after=0.012),
    "note": _Style(0.06, 8.0, 122, after=0.003),
}
_PT = A4[1] * 72.0  # page height in points
_TOP = 0.925
_BOTTOM_FIRST = 0.1  # page 1 keeps the signature line free
_BOTTOM = 0.04
_CONCLUSION_PAD = 5.0  # points


@functools.cache
def _line_height(size: float, family: str) -> float:
    """Height of one line of text (fraction of the A4 page height), measured once per font."""
    plt = _plt()
    fig = plt.figure(figsize=A4)
    try:
        renderer = fig.canvas.get_renderer()
        heights = [
            fig.text(0, 0, "\n".join(["Ag|"] * n), fontsize=size, family=family)
            .get_window_extent(renderer)
            .height
            for n in (1, 11)
        ]
        return (heights[1] - heights[0]) / 10 / fig.bbox.height
    finally:
        plt.close(fig)


def _table_text(rows) -> tuple[str, str]:
    """Header and body of a monospaced table (columns padded to their widths)."""
    widths = [max(len(r[k]) for r in rows) for k in range(len(rows[0]))]

    def line(row):
        first = row[0].ljust(widths[0])
        return "  ".join(
            [first, *(c.rjust(max(w, 11)) for c, w in zip(row[1:], widths[1:], strict=True))]
        )

    header = line(rows[0])
    return header, "\n".join([("-" * len(header)), *(line(r) for r in rows[1:])])


def _wrapped(item: TextItem) -> str:
    style = _STYLES[item.kind]
    if item.kind == "table":
        header, body = _table_text(item.rows)
        return header + "\n" + body
    if item.kind == "note":
        return "- " + textwrap.fill(item.text, style.width).replace("\n", "\n  ")
    if item.kind == "file":
        return textwrap.fill(item.text, style.width) + "\n" + item.label
    return textwrap.fill(item.text, style.width)


def _item_height(item: TextItem) -> float:
    """Height of an item on the page (figure fraction), spacing included."""
    style = _STYLES[item.kind]
    n = _wrapped(item).count("\n") + 1
    pad = 2 * _CONCLUSION_PAD / _PT if item.kind == "conclusion" else 0.0
    return style.before + n * _line_height(style.size, style.family) + pad + style.after


def _draw_item(fig, item: TextItem, y: float) -> None:
    """Draw ``item`` with its top at ``y`` (after its spacing before)."""
    style = _STYLES[item.kind]
    y -= style.before
    kw = {"fontsize": style.size, "va": "top", "weight": style.weight, "family": style.family}
    text = _wrapped(item)
    if item.kind == "field":
        fig.text(0.06, y, item.label, fontsize=style.size, weight="bold", va="top")
    if item.kind == "verdict":
        fig.text(
            0.075,
            y,
            f" {item.label} ",
            fontsize=style.size,
            weight="bold",
            va="top",
            color="white",
            bbox={
                "facecolor": STATUS_COLOURS.get(item.label, "grey"),
                "edgecolor": "none",
                "pad": 1.5,
            },
        )
    if item.kind == "conclusion":
        edge = STATUS_COLOURS.get(item.label, "0.4")
        kw["bbox"] = {"facecolor": "#fafafa", "edgecolor": edge, "lw": 2, "pad": _CONCLUSION_PAD}
    if item.kind == "file":
        path, digest = text.rsplit("\n", 1)
        fig.text(style.x, y, path, **kw)
        y -= (path.count("\n") + 1) * _line_height(style.size, style.family)
        fig.text(style.x, y, digest, **{**kw, "family": "monospace"})
        return
    if item.kind == "table":
        header, body = text.split("\n", 1)
        fig.text(style.x, y, header, **{**kw, "weight": "bold"})
        fig.text(style.x, y - _line_height(style.size, style.family), body, **kw)
        return
    fig.text(style.x, y, text, **kw)


def _flow(plt, items: list[TextItem], title: str, more_title: str) -> list:
    """Lay ``items`` out top to bottom, starting a new page when the next one does not fit (a
    heading stays with the item after it; the space after an item may reach the margin)."""
    figs = [_text_page(plt, title)]
    y = _TOP
    for k, item in enumerate(items):
        height = _item_height(item)
        need = height - _STYLES[item.kind].after
        if item.kind in ("heading", "subheading") and k + 1 < len(items):
            need = height + _item_height(items[k + 1]) - _STYLES[items[k + 1].kind].after
        bottom = _BOTTOM_FIRST if len(figs) == 1 else _BOTTOM
        if y - need < bottom and y < _TOP:
            figs.append(_text_page(plt, more_title))
            y = _TOP
        _draw_item(figs[-1], item, y)
        y -= height
    return figs


def _title_page(plt, res) -> list:
    """Page 1 (and its continuation): :func:`page1_items` laid out, with the signature lines."""
    figs = _flow(
        plt,
        page1_items(res),
        textwrap.shorten(f"ringqa commissioning report: {res.applicator}", 60),
        textwrap.shorten(f"Commissioning summary (continued): {res.applicator}", 60),
    )
    figs[0].text(
        0.06,
        0.05,
        "Checked by: ______________________   Signature: ____________________   "
        "Date: ______________",
        fontsize=10,
    )
    if len(figs) > 1:
        figs[0].text(0.06, 0.075, "Continued on the next page.", fontsize=8.5, style="italic")
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
        "tandem dwells (no reference path)": s.tandem_dwells,
        "registration of the reference path": s.register,
    }
    if res.numerics is not None:
        run["numerical check runs"] = res.numerics.n_runs
    for w in sim.warnings:
        run.setdefault("engine warnings", "")
        run["engine warnings"] += f"{w}; "
    y = 0.92
    fig.text(0.06, y, "Run", fontsize=12, weight="bold", va="top")
    y -= 0.025
    lines = [textwrap.shorten(f"{k} = {_fmt(v, '{}')}", 110) for k, v in run.items()]
    fig.text(0.06, y, "\n".join(lines), fontsize=7.5, va="top", family="monospace")
    y -= 0.0135 * len(lines) + 0.02
    fig.text(
        0.06, y, "Scene (simulation settings, user units)", fontsize=12, weight="bold", va="top"
    )
    y -= 0.025
    items = [textwrap.shorten(f"{k} = {_fmt(v, '{}')}", 58) for k, v in flat.items()]
    per_col = max(1, int((y - 0.04) / 0.0125))
    if len(items) > 2 * per_col:
        items = [
            *items[: 2 * per_col - 1],
            f"... {len(items) - 2 * per_col + 1} more in results.json",
        ]
    fig.text(0.06, y, "\n".join(items[:per_col]), fontsize=7, va="top", family="monospace")
    fig.text(0.52, y, "\n".join(items[per_col:]), fontsize=7, va="top", family="monospace")
    return fig


def _flatten(d: dict, prefix: str = "") -> dict:
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(_flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _path_label(path: str, reference: str) -> str:
    """How a path (or its plan) is named in legends and tables."""
    if path == reference == "centreline":
        return "centreline (the reference)"
    return PATH_LABELS.get(path, path)


def _reference_name(res) -> str:
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


def _shade_flags(ax, res, legend: bool) -> None:
    """Shade the relative positions whose reference position is flagged."""
    table = reference_flags(res)
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
    for path in ("measured", "registered", "centreline", "simulated"):
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
        ax1.plot(u, v, label=f"{_path_label(path, res.reference)} dwells", **kw)
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
    flagged = _flagged_rows(res)
    for flag, rows in flagged.groupby("flag", sort=False):
        u, v, h = _project(rows[["x_mm", "y_mm", "z_mm"]].to_numpy(), geo)
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
    ax1.legend(fontsize=6.5, loc="lower left")
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
    ref_name = _reference_name(res)
    fig.suptitle(_title(res, "Deviations"), fontsize=13, weight="bold", x=0.06, ha="left")
    subtitle = f"Simulated and centreline dwells compared with the {ref_name}."
    if (reference_flags(res)["flag"] != "").any():
        subtitle += (
            " Shaded: reference positions that are infeasible (red) or outside the channel (grey)."
        )
    fig.text(0.06, 0.945, textwrap.fill(subtitle, 120), fontsize=8, va="top")
    versus = "reference" if ref == "measured" else "centreline"
    d = res.dwells
    lim_rec, lim_req = res.settings.position_limits_mm
    ax = axes[0]
    for path, sub in _compared_paths(d, ref):
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
    _shade_flags(ax, res, legend=True)
    ax.set_ylabel("3D distance (mm)")
    ax.set_ylim(0, 1.6 * max(ax.get_ylim()[1], lim_req))  # room for the legend
    ax.legend(fontsize=6.5, ncol=2, loc="upper center")
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
    _shade_flags(ax, res, legend=False)
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
            label=f"{path} vs {versus}",
        )
    _shade_flags(ax, res, legend=False)
    ax.set_ylabel("orientation difference (deg)")
    ax.set_xlabel("relative position (mm), 0 = most distal dwell")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.subplots_adjust(left=0.12, right=0.95, bottom=0.06, top=0.92, hspace=0.25)
    return fig


def _plan_label(plan: str, reference: str) -> str:
    """Column name of one standard plan in the dose table."""
    if plan == reference == "centreline":
        return "centreline plan\n(the reference)"
    return {
        "measured": "reference plan\n(as supplied)",
        "registered": "reference plan\n(registered)",
    }.get(plan, f"{plan} plan")


def _dose_cell(row, plan: str, reference: str, registered: bool) -> str:
    """One dose-table cell: the dose, and the difference(s) to the reference plan(s)."""
    dose = fmt_value(row["dose_gy"], "{:.3f}")
    if plan == reference:
        return dose
    raw = fmt_value(row["diff_pct"], "{:+.2f}")
    if plan == "registered" or not registered:
        return f"{dose} ({raw} %)"
    return f"{dose} ({raw} / {fmt_value(row.get('diff_registered_pct'), '{:+.2f}')} %)"


def dose_table(res) -> tuple[list[str], list[list[str]]]:
    """The dose page's table of the standard plans: header and rows.

    Each cell is the dose (Gy); beside it, in brackets, the difference to the standard plan on
    the reference path as supplied (``diff_pct``) and, when the reference was registered, to
    the same times on the registered path (``diff_registered_pct``), %.
    """
    doses = res.doses
    registered = res.summary.registration != "none" and "diff_registered_pct" in doses
    present = set(doses["plan"])
    plans = [p for p in ("measured", "registered", "centreline", "simulated") if p in present]
    standard = doses[doses["kind"] != "tps"]
    tps = doses[(doses["kind"] == "tps") & (doses["plan"] != "rtplan")]
    rows = []
    for frame, suffix in ((standard, ""), (tps, " (RT Plan point)")):
        for name in dict.fromkeys(frame["point"]):
            row = [LONG_NAMES.get(name, name) + suffix]
            for plan in plans:
                hit = frame[(frame["point"] == name) & (frame["plan"] == plan)]
                row.append(
                    "-" if hit.empty else _dose_cell(hit.iloc[0], plan, res.reference, registered)
                )
            rows.append(row)
    return ["dose point", *(_plan_label(p, res.reference) for p in plans)], rows


def _dose_column_widths(n: int) -> list[float]:
    """Dose-table column widths (axes fraction): the point names narrower than the doses."""
    first = 0.2 if n > 4 else 0.25
    return [first, *([(1.0 - first) / (n - 1)] * (n - 1))]


def _dose_table_title(res) -> str:
    mode = res.summary.registration
    if res.reference != "measured":
        against = "standard plan on the centreline (the reference)"
    elif mode == "none":
        against = "standard plan on the reference path (registration: none)"
    else:
        against = (
            f"standard plan on the reference path as supplied / on the registered path ({mode}),"
            " same dwell times"
        )
    return (
        "Dose (Gy) of the standard plan on each dwell set; in brackets the difference to the "
        f"{against}"
    )


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
    header, cells = dose_table(res)
    fig.text(0.06, 0.505, textwrap.fill(_dose_table_title(res), 120), fontsize=8.5, va="top")
    ax = fig.add_axes((0.03, 0.21, 0.94, 0.26))
    ax.axis("off")
    table = ax.table(
        cellText=cells,
        colLabels=header,
        loc="upper center",
        cellLoc="center",
        colWidths=_dose_column_widths(len(header)),
    )
    table.auto_set_font_size(False)
    table.set_fontsize(7 if len(header) > 4 else 8)
    table.scale(1, 1.25)
    for (row, _), cell in table.get_celld().items():
        if row == 0:
            cell.set_height(cell.get_height() * 1.7)
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
            [
                str(r.point),
                fmt_value(r.tps_dose_gy, "{:.4f}"),
                fmt_value(r.dose_gy, "{:.4f}"),
                f"{fmt_value(r.diff_pct, '{:+.2f}')} %",
            ]
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


def dwell_table(res) -> pd.DataFrame:
    """The dwell-by-dwell table: relative position, in the plan, the reference flags, the
    simulated deviations with the simulation's numerical error, the centreline's deviations
    (text cells, "-" for missing numbers)."""
    d = res.dwells
    ref = res.reference
    others = [p for p in ("simulated", "centreline") if p != ref and p in set(d["path"])]
    base = d[d["path"] == ref].reset_index(drop=True)
    flags = reference_flags(res)
    data = {
        "relative\nposition\n(mm)": base["relative_position_mm"].map("{:g}".format),
        "in the\nstandard\nplan": base["in_plan"].map({True: "yes", False: ""}),
    }
    if ref == "measured":
        names = flags[["flag_supplied", "flag"]].map(lambda f: FLAG_NAMES.get(f, f))
        if res.summary.registration != "none":
            data[SUPPLIED_FLAG_COLUMN] = names["flag_supplied"]
            data["reference\nregistered"] = names["flag"]
        else:
            data["reference\nposition"] = names["flag"]
    for p in others:
        sub = d[d["path"] == p].reset_index(drop=True)
        columns = [
            ("dist_to_reference_mm", f"{p}\n3D (mm)", "{:.2f}"),
            ("along_mm", f"{p}\nalong\n(mm)", "{:+.2f}"),
            ("radial_mm", f"{p}\nradial\n(mm)", "{:+.2f}"),
            ("out_of_plane_mm", f"{p}\nout of\nplane (mm)", "{:+.2f}"),
            ("angle_deg", f"{p}\nangle\n(deg)", "{:.1f}"),
        ]
        if p == "simulated" and "numerical_error_mm" in sub:
            columns.append(("numerical_error_mm", "simulated\nnumerical\nerror (mm)", "{:.3f}"))
        for key, col, fmt in columns:
            data[col] = sub[key].map(lambda x, fmt=fmt: fmt_value(x, fmt))
    return pd.DataFrame(data)


def _dwell_table_pages(plt, res):
    table = dwell_table(res)
    flags = reference_flags(res)["flag"].to_numpy()
    supplied = reference_flags(res)["flag_supplied"].to_numpy()
    columns = list(table.columns)
    supplied_col = columns.index(SUPPLIED_FLAG_COLUMN) if SUPPLIED_FLAG_COLUMN in columns else -1
    figs = []
    per_page = 40
    for start in range(0, len(table), per_page):
        chunk = table.iloc[start : start + per_page]
        fig = _text_page(plt, textwrap.shorten(f"Deviations from the {_reference_name(res)}", 62))
        ax = fig.add_axes((0.03, 0.04, 0.94, 0.86))
        ax.axis("off")
        t = ax.table(
            cellText=chunk.to_numpy(),
            colLabels=list(chunk.columns),
            loc="upper center",
            cellLoc="center",
        )
        t.auto_set_font_size(False)
        t.set_fontsize(6.3)
        t.scale(1, 1.15)
        for (row, col), cell in t.get_celld().items():
            if row == 0:
                cell.set_height(cell.get_height() * 3.0)
            elif flags[start + row - 1] in FLAG_COLOURS:
                cell.set_facecolor(FLAG_COLOURS[flags[start + row - 1]])
            elif col == supplied_col and supplied[start + row - 1] in FLAG_COLOURS:
                cell.set_facecolor(FLAG_COLOURS[supplied[start + row - 1]])
        fig.text(
            0.04,
            0.935,
            textwrap.fill(
                f"{res.applicator}. along = distal positive, radial = outward in the ring plane, "
                "out of plane = cranial positive; angle between source orientations. Shaded rows: "
                "reference position infeasible (cannot lie in the lumen, red) or outside the "
                "channel (left out of the verdicts, grey).",
                125,
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


def report_figures(result, accuracy: pd.DataFrame | None = None) -> list:
    """The report's pages of one CommissioningResult, as matplotlib figures (close them after
    use).

    Parameters
    ----------
    result : CommissioningResult
    accuracy : pandas.DataFrame, optional
        The table of ``ringqa accuracy`` (accuracy.csv) for an extra page.

    Returns
    -------
    list of matplotlib.figure.Figure
    """
    plt = _plt()
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
    return figs


def write_pdf(
    result,
    path: Path,
    *,
    png_dir: Path | None = None,
    accuracy: pd.DataFrame | None = None,
    fields: ReportFields | None = None,
) -> Path:
    """Write the report PDF of one CommissioningResult.

    Parameters
    ----------
    result : CommissioningResult
    path : pathlib.Path
        The PDF to write.
    png_dir : pathlib.Path, optional
        Also save each page there as ``page<k>.png``.
    accuracy : pandas.DataFrame, optional
        The table of ``ringqa accuracy`` (accuracy.csv: ``time_s, max_err_mm, status,
        pareto``) for an extra page.
    fields : ReportFields, optional
        What the signing physicist fills in (from the clinic configuration); not printed yet
        (the report layout being rewritten prints it).

    Returns
    -------
    pathlib.Path
    """
    plt = _plt()
    from matplotlib.backends.backend_pdf import PdfPages

    path = Path(path)
    figs = report_figures(result, accuracy)
    try:
        with PdfPages(path) as pdf:
            for k, fig in enumerate(figs):
                pdf.savefig(fig)
                if png_dir is not None:
                    fig.savefig(Path(png_dir) / f"page{k + 1}.png", dpi=80)
            info = pdf.infodict()
            info["Title"] = f"ringqa commissioning report: {result.applicator}"
            info["Creator"] = result.provenance.software
    finally:
        for fig in figs:
            plt.close(fig)
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
