"""The PDF report a physicist signs (reportlab, A4 portrait; matplotlib for the figures only).

Every page has a running header (the applicator's full name, software version, date) and footer
(the input's SHA-256 prefix, page n/N), see :mod:`ringqa.report.layout`. The pages of one
applicator:

1. Commissioning summary (:func:`page1_items`, flowing onto the next page when it does not fit):
   the title with the applicator's full name, the signing physicist's fields
   (:class:`~ringqa.report.fields.ReportFields`: institution, physicist, applicator serial beside
   the library's part ID, afterloader, source and its calibration; blank lines when not given),
   the run (applicator, source, plan, tolerances, software, date, inputs with SHA-256), the
   verdicts grouped by role with the one-line conclusion, every note of the run (warnings, input
   notes), where the reference path comes from and what its checks found (registration and its
   transform), the numbers "as supplied | registered" side by side with the simulation's
   numerical error, the free notes, the signature block and the references used on the page.
2. Dwell positions like the paper's Figure 6 (the applicator frame's plane, in the family's
   words, and the orthogonal view); after it, only when the cross-check failed, both engines'
   dwells (:mod:`ringqa.report.cross_check`).
3. Deviation per dwell: 3D distance (with the simulation's numerical error),
   along/radial/out-of-plane components, angle of orientation; flagged reference positions shaded.
4. Dose points: map and the dose table of the standard plans (differences to the reference plan
   as supplied and, when registered, as registered; the RT Plan's own doses beside the TPS
   values), with the TG-43 data's reference.
5. Dwell-by-dwell table (reference flags, numerical error), over as many pages as it needs.
6. The settings: every row of the settings table (:data:`ringqa.pipeline.settings.SETTINGS`)
   with the run's value, unit and origin, grouped by configuration table; what the run records
   beyond it (channel, ``--set``, files); the scene.
7. Optional: the accuracy study of ``ringqa accuracy``; then any extra ``sections``.

Batch: ``summary.pdf`` with the same header/footer, Figure-5-like boxplots, the summary table,
the dose table over applicators, failures and the signature block.

The report names the pipeline's ``measured`` path "the reference path (as supplied)": it is what
the user or the applicator library supplies, a measurement only when its source says so.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np
import pandas as pd
from reportlab.platypus import CondPageBreak, KeepTogether, PageBreak, Table, TableStyle

from ringqa.pipeline.numbers import (
    ANGLE_DEG,
    DIST_MM,
    DOSE_GY,
    DOSE_PCT,
    ERROR_MM,
    OFFSET_MM,
    SIGNED_PCT,
)
from ringqa.pipeline.numbers import fmt as _fmt_number
from ringqa.report import layout
from ringqa.report.cross_check import cross_check_figure, cross_check_page, failed_cross_check
from ringqa.report.fields import ReportFields
from ringqa.report.figures import (
    DEVIATIONS_SIZE,
    DOSE_MAP_SIZE,
    FLAG_COLOURS,
    FLAG_NAMES,
    POSITIONS_SIZE,
    accuracy_caption,
    accuracy_figure,
    batch_distances_figure,
    deviation_caption,
    deviations_figure,
    dose_points_caption,
    dose_points_figure,
    frame_words,
    positions_figure,
    reference_flags,
    reference_name,
)
from ringqa.report.layout import badge, grid_table, heading, para
from ringqa.units import m_to_mm

LONG_NAMES = {
    "point_a_left": "Point A left",
    "point_a_right": "Point A right",
    "surface_left": "lateral ring surface left",
    "surface_right": "lateral ring surface right",
    "depth5_left": "5 mm deeper, left",
    "depth5_right": "5 mm deeper, right",
}
STATUS_COLOURS = layout.STATUS_COLOURS
#: The dwell table's column of the flags of the reference path as supplied (when registered).
SUPPLIED_FLAG_COLUMN = "ref. as\nsupplied"
#: the dwell table's column of the flags of the registered reference path
REGISTERED_FLAG_COLUMN = "ref.\nregistered"
#: short names of the compared paths in the dwell table's headers (whole words on each line)
PATH_SHORT = {"simulated": "sim.", "centreline": "cl."}
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
#: The method's paper, cited where its figures, tables and lumen data are used.
PAPER_REFERENCE = "Straathof R, et al. Med Phys 2024;51:3698. doi:10.1002/mp.16934"
#: A section of extra pages: ``section(result) -> list of reportlab flowables``.
Section = Callable[[object], list]


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


def fmt_value(value, form: str = DIST_MM, missing: str = "-") -> str:
    """``value`` in its printed ``form`` (:func:`ringqa.pipeline.numbers.fmt`): ``missing`` for
    None, NaN or infinity (never "nan"), never "-0.00"."""
    return _fmt_number(value, form, missing)


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
    xyz = ", ".join(fmt_value(x, OFFSET_MM) for x in t_mm)
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
            "field", f"{res.applicator}  (input: {res.input_label}, {res.input_kind})", "Applicator"
        ),
        TextItem(
            "field",
            f"{s.source} (TG-43), S_K = {fmt_value(s.sk_U, '{:.0f}')} U; cable model: "
            f"{s.cable} preset (all settings: settings page)",
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
            text = f"{fmt_value(err[0], ERROR_MM)} ({fmt_value(err[1], ERROR_MM)})"
            rows.append(("Simulated: numerical error, max (median) (mm)", text, text))
    reg_diffs = s.max_abs_diff_registered_pct or s.max_abs_diff_pct
    for plan, per_kind in s.max_abs_diff_pct.items():
        for kind, where in DOSE_KINDS:
            rows.append(
                (
                    f"{plan.capitalize()} plan: max |dose difference|, {where} (%)",
                    fmt_value(per_kind.get(kind), DOSE_PCT),
                    fmt_value(reg_diffs.get(plan, {}).get(kind), DOSE_PCT),
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
    """Everything page 1 (and its continuation) says, in order, in the report's wording: the
    run, the verdicts and conclusion, the notes (warnings first on the page), the reference path
    and the numbers as supplied | registered.

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
        *verdict_items(result),
        *note_items(result),
        *reference_items(result),
        *comparison_items(result),
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
    dose = fmt_value(row["dose_gy"], DOSE_GY)
    if plan == reference:
        return dose
    raw = fmt_value(row["diff_pct"], SIGNED_PCT)
    if plan == "registered" or not registered:
        return f"{dose} ({raw} %)"
    return f"{dose} ({raw} / {fmt_value(row.get('diff_registered_pct'), SIGNED_PCT)} %)"


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
        # (point, plan) -> the position of its first row: one pass, not two filters per cell
        first: dict[tuple, int] = {}
        for k, key in enumerate(zip(frame["point"], frame["plan"], strict=True)):
            first.setdefault(key, k)
        for name in dict.fromkeys(frame["point"]):
            row = [LONG_NAMES.get(name, name) + suffix]
            for plan in plans:
                k = first.get((name, plan))
                row.append(
                    "-" if k is None else _dose_cell(frame.iloc[k], plan, res.reference, registered)
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
        "rel.\npos.\n(mm)": base["relative_position_mm"].map("{:g}".format),
        "in\nplan": base["in_plan"].map({True: "yes", False: ""}),
    }
    if ref == "measured":
        names = flags[["flag_supplied", "flag"]].map(lambda f: FLAG_NAMES.get(f, f))
        if res.summary.registration != "none":
            data[SUPPLIED_FLAG_COLUMN] = names["flag_supplied"]
            data[REGISTERED_FLAG_COLUMN] = names["flag"]
        else:
            data["ref.\nposition"] = names["flag"]
    for p in others:
        sub = d[d["path"] == p].reset_index(drop=True)
        q = PATH_SHORT.get(p, p)
        columns = [
            ("dist_to_reference_mm", f"{q}\n3D\n(mm)", DIST_MM),
            ("along_mm", f"{q}\nalong\n(mm)", OFFSET_MM),
            ("radial_mm", f"{q}\nradial\n(mm)", OFFSET_MM),
            ("out_of_plane_mm", f"{q}\nout of\nplane\n(mm)", OFFSET_MM),
            ("angle_deg", f"{q}\nangle\n(deg)", ANGLE_DEG),
        ]
        if p == "simulated" and "numerical_error_mm" in sub:
            columns.append(("numerical_error_mm", f"{q}\nnum.\nerror\n(mm)", ERROR_MM))
        for key, col, form in columns:
            data[col] = sub[key].map(lambda x, form=form: fmt_value(x, form))
    return pd.DataFrame(data)


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
                # the dose difference the verdicts judge (to the registered reference plan)
                col = "diff_registered_pct" if "diff_registered_pct" in d else "diff_pct"
                per_kind[kind].append(float(d.loc[d["kind"] == kind, col].abs().max()))
            per_kind["n"].append(1.0)
    rows = []
    for (ref, plan), per_kind in groups.items():
        cells = [f"{ref} - {plan} ({len(per_kind['n'])})"]
        for kind in ("point_a", "surface", "depth5"):
            v = np.asarray(per_kind[kind])
            cells.append(
                f"{fmt_value(np.median(v), DOSE_PCT)} ({fmt_value(v.min(), DOSE_PCT)} - "
                f"{fmt_value(v.max(), DOSE_PCT)})"
            )
        rows.append(cells)
    return rows


def _fmt(value, fmt: str) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-"
    try:
        return fmt.format(value)
    except (ValueError, TypeError):
        return str(value)


# ---------------------------------------------------------------------------------------------
# The signing physicist's fields, references, signature
# ---------------------------------------------------------------------------------------------

#: What the report prints for a field nobody filled in: a line to write on.
BLANK = "_" * 38


def library_parts(res) -> str:
    """The applicator library's part IDs per channel (RT Plan input), e.g.
    ``"ring 110350-06 (Interstitial Ring Tube d=26mm, 60°); tandem 110307-06 (...)"``; ``""``
    when the input has no library."""
    channels = (res.geometry.metadata or {}).get("channels") or {}
    parts = []
    for name, info in channels.items():
        if isinstance(info, dict) and info.get("library_part"):
            desc = f" ({info['description']})" if info.get("description") else ""
            parts.append(f"{name} {info['library_part']}{desc}")
    return "; ".join(parts)


def field_rows(res, fields: ReportFields | None) -> list[tuple[str, str]]:
    """(label, value) of the fields the signing physicist fills in; :data:`BLANK` for the empty
    ones. ``res`` is a CommissioningResult (for the library's part ID) or None (a batch)."""
    f = fields or ReportFields()
    serial = f.applicator_serial or BLANK
    parts = library_parts(res) if res is not None else ""
    if parts:
        serial += f"   (library part ID: {parts})"
    rows = [
        ("Institution", f.institution or BLANK),
        ("Physicist", f.physicist or BLANK),
    ]
    if res is not None:
        rows.append(("Applicator serial / part no.", serial))
    rows += [
        ("Afterloader", f.afterloader or BLANK),
        ("Source, calibration", f.source_calibration or BLANK),
    ]
    if f.label:
        rows.append(("Label", f.label))
    return rows


def tg43_reference(source: str) -> str:
    """The citation of the TG-43 consensus data of ``source`` (a shipped name or a folder), from
    its ``meta.json``; ``""`` when the source cannot be read."""
    try:
        from tg43 import load_source

        return load_source(source).reference
    except Exception:  # a citation must never stop the report
        return ""


def _references(*texts: str) -> list:
    refs = [t for t in texts if t]
    if not refs:
        return []
    out = [heading("References", 2)]
    out += [para(f"[{k}] {t}", "small") for k, t in enumerate(refs, start=1)]
    return out


def _fields_table(rows) -> Table:
    width = layout.FRAME_WIDTH
    return grid_table(
        [[label, value] for label, value in rows],
        [0.24 * width, 0.76 * width],
        header_rows=0,
        align="LEFT",
    )


def signature_block(fields: ReportFields | None = None) -> KeepTogether:
    """Name, date and signature lines of the physicist who checked the report (the name
    pre-filled from ``fields.physicist`` when given)."""
    f = fields or ReportFields()
    width = layout.FRAME_WIDTH
    rows = [
        ["Checked and approved by (name)", "Date", "Signature"],
        [(f.physicist if f.physicist else "") + "\n\n" + "_" * 34, "\n\n" + "_" * 16,
         "\n\n" + "_" * 30],
    ]  # fmt: skip
    table = grid_table(rows, [0.42 * width, 0.2 * width, 0.38 * width], align="LEFT")
    return KeepTogether([heading("Signature", 1), table])


def _free_notes(notes: Sequence[str]) -> list:
    out = [heading("Notes of the physicist", 1)]
    given = [n for n in notes if n and n.strip()]
    if given:
        out += [para(n) for n in given]
    else:
        out += [para("_" * 110, "small") for _ in range(2)]
    return out


# ---------------------------------------------------------------------------------------------
# Page 1: text items as flowables
# ---------------------------------------------------------------------------------------------


def _conclusion_box(item: TextItem) -> Table:
    colour = STATUS_COLOURS.get(item.label, "#757575")
    table = Table([[para(item.text, "conclusion")]], colWidths=[layout.FRAME_WIDTH])
    table.setStyle(
        TableStyle(
            [
                ("FONTNAME", (0, 0), (-1, -1), layout.FONT),
                ("BOX", (0, 0), (-1, -1), 2, colour),
                ("BACKGROUND", (0, 0), (-1, -1), "#fafafa"),
                ("TOPPADDING", (0, 0), (-1, -1), 4),
                ("BOTTOMPADDING", (0, 0), (-1, -1), 5),
            ]
        )
    )
    return table


def _run_table(items: list[TextItem]) -> Table:
    """The run's fields and input files as one two-column table."""
    width = layout.FRAME_WIDTH
    rows = []
    for it in items:
        if it.kind == "file":
            cell = para(
                f"{escape(it.text)}<br/><font name='{layout.FONT_MONO}' size='6.5'>"
                f"SHA-256 {escape(it.label)}</font>",
                "cell",
                markup=True,
            )
            rows.append(["", cell])
        else:
            rows.append([it.label, it.text])
    return grid_table(rows, [0.24 * width, 0.76 * width], header_rows=0, align="LEFT")


def items_flowables(items: Sequence[TextItem]) -> list:
    """Page-1 text items as reportlab flowables (a heading kept with what follows it)."""
    out: list = []
    run: list[TextItem] = []
    width = layout.FRAME_WIDTH
    for it in [*items, TextItem("end")]:
        if it.kind in ("field", "file"):
            run.append(it)
            continue
        if run:
            out.append(_run_table(run))
            run = []
        if it.kind == "heading":
            out += [CondPageBreak(60), heading(it.text, 1)]
        elif it.kind == "subheading":
            out += [CondPageBreak(40), heading(it.text, 2)]
        elif it.kind == "text":
            out.append(para(it.text))
        elif it.kind == "verdict":
            out.append(para(f"{badge(it.label)}&nbsp; {escape(it.text)}", markup=True))
        elif it.kind == "conclusion":
            out += [layout.spacer(1.5), _conclusion_box(it), layout.spacer(1.5)]
        elif it.kind == "note":
            out.append(para(f"• {escape(it.text)}", "note", markup=True))
        elif it.kind == "table" and it.rows:
            widths = [0.56 * width, 0.22 * width, 0.22 * width]
            out.append(grid_table([list(r) for r in it.rows], widths))
            out.append(layout.spacer(1.5))
    return out


def summary_flowables(result, fields: ReportFields | None = None, notes=()) -> list:
    """Page 1 and its continuation: title, the physicist's fields, :func:`page1_items`, the
    references used there, free notes and the signature block."""
    f = fields or ReportFields()
    return [
        heading("Commissioning report", 0),
        para(result.applicator, "h1"),
        _fields_table(field_rows(result, f)),
        layout.spacer(2),
        *items_flowables(page1_items(result)),
        *_references(PAPER_REFERENCE),
        *_free_notes([f.notes, *notes]),
        signature_block(f),
    ]


# ---------------------------------------------------------------------------------------------
# Figures drawn ahead, in a forked process (the second core), while this one lays out the rest
# ---------------------------------------------------------------------------------------------

#: the report's figures :func:`draw_ahead` can draw in other processes: maker, size (inches);
#: in the order of their pages (positions on page 3, deviations on page 4, the dose map on 5)
AHEAD_FIGURES: dict[str, tuple[Callable, tuple[float, float]]] = {
    "positions": (positions_figure, POSITIONS_SIZE),
    "deviations": (deviations_figure, DEVIATIONS_SIZE),
    "doses": (dose_points_figure, DOSE_MAP_SIZE),
}


#: the figures :class:`DrawnAhead` draws in one child each group: the positions and the dose
#: map together (0.2 + 0.15 s of CPU) beside the deviations (0.27 s); a child less saves its
#: fork and its first-draw costs (about 0.03 s of CPU), and the PDF needs none of them before
#: the file is written (:func:`_figure`)
AHEAD_GROUPS: tuple[tuple[str, ...], ...] = (("positions", "doses"), ("deviations",))


class DrawnAhead:
    """The report figures of one result (:data:`AHEAD_FIGURES`) being drawn in forked child
    processes (:class:`ringqa.parallel.ForkedCall`, one a group of :data:`AHEAD_GROUPS`: each
    figure compressed as the PDF stores it: :func:`ringqa.report.layout.figure_flate`) while
    this process writes the tables, report.html and the PDF's pages; the PDF waits for a
    figure only when the file is written (every page laid out by then: :func:`_figure`).
    Without a free core (or ``os.fork``) they are drawn here when first needed: the pixels, and
    so the PDF, are the same either way (each child is a copy of this process, matplotlib's
    state included). Give it to :func:`write_pdf` (``drawn=``)."""

    def __init__(self, result, fork: bool | None = None) -> None:
        from ringqa.parallel import ForkedCall, second_core_free
        from ringqa.report import agg_text, ticks  # noqa: F401 - loaded once, before the forks

        self.result = result
        fork = second_core_free() if fork is None else fork
        self._calls = {}
        for group in AHEAD_GROUPS:
            call = ForkedCall(functools.partial(_draw_figures, result, group), fork)
            self._calls.update(dict.fromkeys(group, call))
        self._images: dict = {}

    @property
    def forked(self) -> bool:
        """The figures are being drawn in child processes (until their pixels arrive)."""
        return any(call.forked for call in self._calls.values())

    def image(self, name: str) -> layout.FlateImage:
        """Figure ``name`` as the PDF stores it (waits for its child the first time)."""
        if name not in self._images:
            self._images.update(self._calls[name].result())
        return self._images[name]

    def cancel(self) -> None:
        """Stop the children whose figures are no longer needed."""
        for call in dict.fromkeys(self._calls.values()):
            call.cancel()


def draw_ahead(result, fork: bool | None = None) -> DrawnAhead:
    """Start drawing ``result``'s costliest report figures in a forked process (see
    :class:`DrawnAhead`; ``fork``: None = when a core is free)."""
    return DrawnAhead(result, fork)


def _draw_figures(result, names) -> dict:
    # drawn and compressed here (in the child when forked): only the PDF's bytes travel
    return {name: _draw_one(AHEAD_FIGURES[name][0], result) for name in names}


#: the figures being drawn ahead for the report being written (set by :func:`write_pdf`)
_AHEAD: list[DrawnAhead] = []


def _figure(name: str, res, width: float):
    """Report figure ``name`` of ``res``, ``width`` points wide, laid out at once and its
    pixels written into the PDF when the PDF is written (:class:`ringqa.report.layout
    .LaterFigure`): from the process drawing it ahead when :func:`write_pdf` was given one for
    ``res`` (the pages after it are laid out meanwhile, not waiting for it), else drawn then."""
    make, (w_in, h_in) = AHEAD_FIGURES[name]
    for drawn in _AHEAD:
        if drawn.result is res:
            fetch = functools.partial(drawn.image, name)
            break
    else:
        fetch = functools.partial(_draw_one, make, res)
    return layout.LaterFigure(name, fetch, width, width * float(h_in) / float(w_in))


#: zlib's level for the report's three figures (:data:`AHEAD_FIGURES`): 3 compresses their
#: 9.8 MB of pixels in 26 ms of CPU instead of the default level's 64 ms (in the figure
#: children, on the main job's two busy cores); the same pixels, the PDF about 12-15 % larger
#: (README's main job 455 -> 510 kB, the example without registration 458 -> 522 kB,
#: ring26x60 355 -> 408 kB)
FIGURE_FLATE_LEVEL = 3


def _draw_one(make, res) -> layout.FlateImage:
    # unnamed: LaterFigure names the image by its key (no MD5 of the pixels needed)
    return layout.figure_flate(make(res), named=False, level=FIGURE_FLATE_LEVEL)


# ---------------------------------------------------------------------------------------------
# The other pages
# ---------------------------------------------------------------------------------------------


def positions_flowables(res) -> list:
    """Dwell positions (the paper's Figure 6)."""
    return [
        heading("Dwell positions (paper Figure 6 [1])", 1),
        para(
            f"Projected onto the {frame_words(res).plane} (seen from cranial; numbers: relative "
            "position, mm) and orthogonal to it. Reference as supplied and registered, "
            "simulated, centreline; circled: flagged reference positions."
        ),
        _figure("positions", res, 0.95 * layout.FRAME_WIDTH),
        *_references(PAPER_REFERENCE),
    ]


def deviations_flowables(res) -> list:
    """Deviation per dwell: distance, components, angle."""
    return [
        heading(f"Deviations from the {reference_name(res)}", 1),
        para(deviation_caption(res)),
        _figure("deviations", res, 0.86 * layout.FRAME_WIDTH),
    ]


def _dose_col_widths(n: int) -> list[float]:
    first = 0.2 if n > 4 else 0.25
    return [layout.FRAME_WIDTH * w for w in [first, *([(1.0 - first) / (n - 1)] * (n - 1))]]


def doses_flowables(res) -> list:
    """Dose points (map) and the standard plans' dose table; the RT Plan's own doses."""
    header, cells = dose_table(res)
    out = [
        heading("Dose points and standard-plan doses", 1),
        _figure("doses", res, layout.FRAME_WIDTH),
        para(dose_points_caption(res), "small"),
        layout.spacer(2),
        para(_dose_table_title(res) + " [2]."),
        grid_table([header, *cells], _dose_col_widths(len(header))),
    ]
    own = res.doses[res.doses["plan"] == "rtplan"]
    if not own.empty:
        rows = [["RT Plan point", "TPS dose (Gy)", "ringqa dose (Gy)", "difference"]]
        rows += [
            [
                str(r.point),
                fmt_value(r.tps_dose_gy, "{:.4f}"),
                fmt_value(r.dose_gy, "{:.4f}"),
                f"{fmt_value(r.diff_pct, SIGNED_PCT)} %",
            ]
            for r in own.itertuples()
        ]
        out += [
            heading(
                "The RT Plan's own dwells and times at its points: ringqa TG-43 beside the TPS", 2
            ),
            grid_table(rows),
        ]
    tg43 = tg43_reference(res.settings.source)
    tg43 = f"TG-43 data of the source {res.settings.source}: {tg43}" if tg43 else ""
    return [*out, *_references(PAPER_REFERENCE + " (dose points, Table 2)", tg43)]


#: width of the dwell table's flag columns, points (whole words: "infeasible", "registered")
FLAG_COLUMN_PT = 50.0


def dwell_column_widths(columns: Sequence[str]) -> list[float]:
    """The dwell table's column widths (points): the flag columns wide enough for their words,
    the number columns sharing the rest."""
    flag = [c.startswith("ref.") for c in columns]
    rest = (layout.FRAME_WIDTH - FLAG_COLUMN_PT * sum(flag)) / max(1, len(columns) - sum(flag))
    return [FLAG_COLUMN_PT if f else rest for f in flag]


def dwell_table_flowables(res) -> list:
    """The dwell-by-dwell table (its header repeats on every page it runs over)."""
    table = dwell_table(res)
    flags = reference_flags(res)
    columns = list(table.columns)
    supplied_col = columns.index(SUPPLIED_FLAG_COLUMN) if SUPPLIED_FLAG_COLUMN in columns else -1
    rows = [columns, *table.to_numpy().tolist()]
    row_colours, cell_colours = {}, {}
    for k, (flag, raw) in enumerate(zip(flags["flag"], flags["flag_supplied"], strict=True)):
        if flag in FLAG_COLOURS:
            row_colours[k + 1] = FLAG_COLOURS[flag]
        elif supplied_col >= 0 and raw in FLAG_COLOURS:
            cell_colours[(k + 1, supplied_col)] = FLAG_COLOURS[raw]
    return [
        heading(f"Dwell by dwell: deviations from the {reference_name(res)}", 1),
        para(
            "sim. = simulated, cl. = centreline, ref. = reference position (as supplied / "
            "registered), num. error = the simulation's numerical error. "
            f"along = distal positive, radial = outward in the {frame_words(res).plane}, out of "
            "plane = cranial positive; angle between source orientations. Shaded rows: "
            "reference position infeasible (cannot lie in the lumen, red) or outside the "
            "channel (left out of the verdicts, grey).",
            "small",
        ),
        grid_table(
            rows,
            dwell_column_widths(columns),
            row_colours=row_colours,
            cell_colours=cell_colours,
            first_left=False,
        ),
    ]


def flatten(d: dict, prefix: str = "") -> dict:
    """Nested dict -> ``{"a.b.c": value}``."""
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _setting_text(value) -> str:
    if isinstance(value, list | tuple):
        if len(value) > 6 or any(isinstance(v, list | tuple | dict) for v in value):
            return f"({len(value)} values: results.json)"
        return ", ".join(_fmt(v, "{}") for v in value)
    if isinstance(value, dict):
        return "{}"
    return _fmt(value, "{}")


def settings_record(res, fields: ReportFields | None = None) -> dict:
    """What the run recorded of its settings, by :attr:`Setting.record
    <ringqa.pipeline.settings.Setting.record>` name: results.json ``settings`` (without the
    scene), the :class:`~ringqa.pipeline.result.RunSettings` fields results.json does not keep
    (the cross-check) and the report's fields (``fields``, blank when not given)."""
    run = res.settings
    record = {f.name: getattr(run, f.name) for f in dataclasses.fields(run)}
    record.update(run.as_dict())  # results.json's forms (dose points as a table, lists)
    record.pop("scene", None)
    f = fields or ReportFields()
    record.update({k: getattr(f, k) for k in f.__dataclass_fields__})
    return record


def table_rows(res, fields: ReportFields | None = None) -> list[tuple[str, str, str, str, str]]:
    """One row per row of the settings table (:data:`ringqa.pipeline.settings.SETTINGS`, read
    when called, in its order): ``(table, name, value, unit, origin)``. The value is the
    run's (:meth:`~ringqa.pipeline.settings.Setting.value_in` of :func:`settings_record`;
    ``-`` when not recorded or empty), the origin ``result.settings_origin``'s (``-`` when the
    settings were made in Python)."""
    from ringqa.pipeline import settings as setting_table

    record = settings_record(res, fields)
    origins = dict(getattr(res, "settings_origin", {}) or {})
    files = origin_files(res)
    rows = []
    for s in setting_table.SETTINGS:
        value = s.value_in(record)
        text = "-" if value is setting_table.NOT_RECORDED or value == "" else _setting_text(value)
        origin = origins.get(s.key, setting_table.DEFAULT_ORIGIN if origins else "-")
        rows.append((s.table, s.name, text, s.unit, files.get(origin, origin)))
    return rows


def origin_files(res) -> dict[str, str]:
    """The settings' origins that name a file (``--config <path>``, ``user config <path>``)
    -> a short label for the settings table's narrow column (``--config [1]``), numbered in
    order of first use; the page names each file under the table."""
    from ringqa.pipeline import settings as setting_table

    origins = dict(getattr(res, "settings_origin", {}) or {})
    out: dict[str, str] = {}
    for s in setting_table.SETTINGS:
        origin = origins.get(s.key, "")
        for kind in ("--config ", "user config "):
            if origin.startswith(kind) and origin not in out:
                out[origin] = f"{kind}[{len(out) + 1}]"
    return out


def grouped_two_up(rows: Sequence[tuple[str, str, str, str, str]]) -> tuple[list, list]:
    """:func:`table_rows` as two columns of (name, value, unit, origin) cells, read down the
    left then down the right, each configuration table under a ``[table]`` row (repeated,
    ``continued``, where the right column starts inside a table). Returns the rows of 8
    cells and the (row, column) cells of the group rows (to shade)."""
    lines: list[tuple[str, ...]] = []
    shown = None
    for table, *cells in rows:
        if table != shown:
            lines.append((f"[{table}]",))
            shown = table
        lines.append((table, *cells))
    half = (len(lines) + 1) // 2
    left, right = lines[:half], lines[half:]
    if right and len(right[0]) > 1:  # the right column starts inside a table
        right.insert(0, (f"[{right[0][0]}] continued",))
        if len(right) > len(left):
            left.append(("",))

    def cells(line):
        if len(line) == 1:
            return [para(line[0], "cellhead") if line[0] else "", "", "", ""], bool(line[0])
        return list(line[1:]), False

    out, group = [], []
    for k in range(max(len(left), len(right))):
        a, ga = cells(left[k] if k < len(left) else ("",))
        b, gb = cells(right[k] if k < len(right) else ("",))
        out.append(a + b)
        group += [(k + 1, c) for c in range(4) if ga] + [(k + 1, 4 + c) for c in range(4) if gb]
    return out, group


def run_only_rows(res) -> list[tuple[str, str]]:
    """What results.json ``settings`` records beyond the settings table's rows (the channel,
    the ``--set`` overrides, a centreline correction, the calibration file and its SHA-256), as
    (dotted key, value text) rows; then the simulation's status, solve time, elements,
    numerical check runs and engine warnings."""
    from ringqa.pipeline import settings as setting_table

    data = res.settings.as_dict()
    data.pop("scene", None)
    held = {s.record for s in setting_table.SETTINGS}
    parts = {f"{s.record}.{s.name}" for s in setting_table.SETTINGS}
    rows = []
    for key, value in flatten(data).items():
        if key in parts or key in held:
            continue
        rows.append((key, _short(_setting_text(value), 90)))
    sim = res.simulation
    rows += [
        ("simulation status", f"{sim.status} {sim.message}".strip()),
        ("simulation solve time", f"{sim.solve_time_s:.2f} s"),
        ("elements", str(sim.n_elements)),
    ]
    if res.numerics is not None:
        rows.append(("numerical check runs", str(res.numerics.n_runs)))
    rows += [("engine warning", w) for w in sim.warnings]
    return rows


def scene_rows(res) -> list[tuple[str, str]]:
    """The simulated scene's settings (user units), as (dotted key, value text) rows."""
    scene = res.settings.as_dict().get("scene", {}) or {}
    rows = [(k, _short(_setting_text(v))) for k, v in flatten(scene).items()]
    return rows or [("(engine defaults)", "")]


def _short(text: str, width: int = 60) -> str:
    """``text``, or its start and a pointer to results.json when longer than ``width``."""
    return text if len(text) <= width else text[: width - 24].rstrip() + "... (results.json)"


def _two_up(rows: list[tuple[str, str]]) -> list[list[str]]:
    half = (len(rows) + 1) // 2
    left, right = rows[:half], rows[half:]
    right = right + [("", "")] * (len(left) - len(right))
    return [[a, b, c, d] for (a, b), (c, d) in zip(left, right, strict=True)]


#: the settings page's shade of a configuration table's row
GROUP_SHADE = "#f5f5f5"


def settings_flowables(res, fields: ReportFields | None = None) -> list:
    """The settings page: every row of the settings table with the run's value, its unit and
    where it came from (grouped by configuration table, as ``ringqa config show``), what the
    run records beyond the table, and the scene."""
    w = layout.FRAME_WIDTH
    rows, groups = grouped_two_up(table_rows(res, fields))
    side = [0.225 * w, 0.125 * w, 0.045 * w, 0.105 * w]
    return [
        heading("Settings of this run (effective values, where each came from)", 1),
        grid_table(
            [["setting", "value", "unit", "from"] * 2, *rows],
            side * 2,
            style="cell",
            align="LEFT",
            cell_colours={cell: GROUP_SHADE for cell in groups},
        ),
        *[
            para(f"{label.split()[-1]} {origin}", "small")
            for origin, label in origin_files(res).items()
        ],
        grid_table(
            [["also recorded", "value"], *[[k, v] for k, v in run_only_rows(res)]],
            [0.3 * w, 0.7 * w],
            style="cell",
            align="LEFT",
        ),
        heading("Scene (simulation settings, user units)", 1),
        grid_table(
            [["setting", "value", "setting", "value"], *_two_up(scene_rows(res))],
            [0.3 * w, 0.2 * w, 0.3 * w, 0.2 * w],
            align="LEFT",
        ),
    ]


def accuracy_flowables(res, table: pd.DataFrame) -> list:
    """The accuracy/time study of the scene."""
    return [
        heading("Accuracy of the simulation settings", 1),
        layout.figure_image(accuracy_figure(res, table)),
        para(accuracy_caption(table)),
    ]


def _date(created_utc: str) -> str:
    return created_utc.replace("T", " ")[:16] + " UTC" if created_utc else ""


def page_stamp(result) -> layout.PageStamp:
    """The running header/footer of one applicator's report."""
    prov = result.provenance
    inputs = layout.inputs_digest_text(
        list(prov.inputs.values()), "input: applicator object given in Python (no file)"
    )
    return layout.PageStamp(
        title=f"ringqa commissioning report: {result.applicator}",
        software=prov.software,
        date=_date(prov.created_utc),
        inputs=inputs,
    )


def report_story(
    result,
    *,
    fields: ReportFields | None = None,
    notes: Sequence[str] = (),
    accuracy: pd.DataFrame | None = None,
    sections: Sequence[Section] = (),
) -> list:
    """All flowables of one applicator's report, page breaks included (see the module
    docstring for the pages). ``sections`` add pages after the standard ones."""
    pages = [summary_flowables(result, fields, notes), *detail_pages(result, fields)]
    if accuracy is not None:
        pages.append(accuracy_flowables(result, accuracy))
    pages += [list(section(result)) for section in sections]
    return _joined(pages)


def detail_pages(result, fields: ReportFields | None = None) -> list[list]:
    """The pages after page 1 of one channel's report: positions, deviations, dose points,
    the dwell table and the settings (one list of flowables per page; ``fields``: the report
    fields the settings page lists)."""
    return [
        positions_flowables(result),
        *([page] if (page := cross_check_page(result)) else []),  # a failed cross-check
        deviations_flowables(result),
        doses_flowables(result),
        dwell_table_flowables(result),
        settings_flowables(result, fields),
    ]


def _joined(pages: Sequence[list]) -> list:
    """The pages' flowables with a page break between pages."""
    story: list = []
    for k, page in enumerate(pages):
        if k:
            story.append(PageBreak())
        story += page
    return story


def report_figures(result, accuracy: pd.DataFrame | None = None) -> list:
    """The report's figures of one CommissioningResult (positions, deviations, dose points,
    accuracy when given), as :class:`matplotlib.figure.Figure` (no pyplot state to close)."""
    figs = [positions_figure(result), deviations_figure(result), dose_points_figure(result)]
    if failed_cross_check(result) is not None:
        figs.append(cross_check_figure(result))
    if accuracy is not None:
        figs.append(accuracy_figure(result, accuracy))
    return figs


def write_pdf(
    result,
    path: Path,
    *,
    fields: ReportFields | None = None,
    notes: Sequence[str] | str = (),
    accuracy: pd.DataFrame | None = None,
    sections: Sequence[Section] = (),
    drawn: DrawnAhead | None = None,
) -> Path:
    """Write the report PDF of one CommissioningResult.

    Parameters
    ----------
    result : CommissioningResult
    path : pathlib.Path
        The PDF to write.
    fields : ReportFields, optional
        Institution, physicist, serial, afterloader, source calibration, notes (blank lines to
        fill by hand when not given).
    notes : str or sequence of str
        Free notes printed above the signature block (after ``fields.notes``).
    accuracy : pandas.DataFrame, optional
        The table of ``ringqa accuracy`` (accuracy.csv: ``time_s, max_err_mm, status,
        pareto``) for an extra page.
    sections : sequence of callables, optional
        Extra pages: each ``section(result)`` returns reportlab flowables (build them with
        :mod:`ringqa.report.layout`); each starts on a new page after the standard pages.
    drawn : DrawnAhead, optional
        ``result``'s figures already being drawn in another process (:func:`draw_ahead`).

    Returns
    -------
    pathlib.Path
    """
    if isinstance(notes, str):
        notes = (notes,)
    if drawn is not None and drawn.result is not result:
        drawn = None
    if drawn is not None:
        _AHEAD.append(drawn)
    try:
        story = report_story(
            result, fields=fields, notes=notes, accuracy=accuracy, sections=sections
        )
    finally:
        if drawn is not None:
            _AHEAD.remove(drawn)
    return layout.build_pdf(
        path,
        story,
        page_stamp(result),
        title=f"ringqa commissioning report: {result.applicator}",
        subject="HDR ring applicator commissioning",
    )


#: summary.pdf's table: (summary.csv column as judged, header, form); ``{reg}`` is
#: ``_registered`` for a registered run
BATCH_COLUMNS = (
    ("median_dist_sim{reg}_mm", "sim. median (mm)", DIST_MM),
    ("max_dist_sim{reg}_mm", "sim. max (mm)", DIST_MM),
    ("max_dist_centreline{reg}_mm", "cl. max (mm)", DIST_MM),
    ("max_abs_diff_surface_simulated{reg}_pct", "sim. surface max |dD| (%)", DOSE_PCT),
)


#: summary.pdf's table column widths (fractions of the frame)
BATCH_WIDTHS = (0.17, 0.25, 0.09, 0.11, 0.075, 0.075, 0.075, 0.075, 0.08)


def batch_summary_rows(batch) -> tuple[list[str], list[list[str]]]:
    """summary.pdf's table (header, rows), one row per input as in summary.csv: applicator,
    input, reference, registration, then the numbers the verdicts judge (the ``_registered``
    columns of a registered run, as the verdicts judge them) and the verdict."""
    header = ["applicator", "input", "ref.", "reg.", *(c[1] for c in BATCH_COLUMNS), "verdict"]
    rows = []
    for row in batch.summary.to_dict("records"):
        mode = str(row.get("registration") or "none")
        reg = "" if mode in ("none", "nan") else "_registered"
        cells = [
            _fmt(row.get("applicator"), "{}"),
            _fmt(row.get("input"), "{}"),
            _fmt(row.get("reference"), "{}"),
            "" if row.get("verdict") == "ERROR" else mode,
        ]
        cells += [fmt_value(row.get(key.format(reg=reg)), form) for key, _, form in BATCH_COLUMNS]
        cells.append(_fmt(row.get("verdict"), "{}"))
        rows.append(cells)
    return header, rows


def write_batch_pdf(batch, path: Path, *, fields: ReportFields | None = None) -> Path:
    """Cross-applicator report ``summary.pdf``: the same header/footer, Figure-5-like boxplots,
    the summary table, the dose table over applicators, failures, signature block."""
    from ringqa import __version__

    results = batch.results
    prov = results[0].provenance if results else None
    digests = sorted(d for r in results for d in r.provenance.inputs.values())
    joined = hashlib.sha256("".join(digests).encode()).hexdigest()[: layout.SHA_PREFIX]
    n = len(results) + len(batch.failures)
    stamp = layout.PageStamp(
        title=f"ringqa commissioning: batch of {n} applicator(s)",
        software=prov.software if prov else f"ringqa {__version__}",
        date=_date(prov.created_utc) if prov else "",
        inputs=f"{len(digests)} input file(s), combined SHA-256 {joined}"
        if digests
        else "inputs: shipped or Python applicators (no files)",
    )
    story = [
        heading("Commissioning summary: all applicators", 0),
        _fields_table(field_rows(None, fields)),
        heading("Distances per applicator (paper Figure 5 [1])", 1),
    ]
    if results:
        story.append(layout.figure_image(batch_distances_figure(batch), 0.9 * layout.FRAME_WIDTH))
        story.append(
            para(
                "box: interquartile range, line: median, whiskers: extremes without outliers, "
                "x: outliers.",
                "small",
            )
        )
    if any(r.reference == "centreline" for r in results):
        story.append(
            para(
                "<font color='#c62828'>Applicators without a measured source path (the shipped "
                "synthetic rings) are compared simulated vs CENTRELINE: there is no measurement "
                "in those boxes.</font>",
                markup=True,
            )
        )
    header, rows = batch_summary_rows(batch)
    w = layout.FRAME_WIDTH
    story += [
        heading("Summary", 1),
        para(
            "Distances and dose differences as the verdicts judge them: against the registered "
            "reference path where the run registered it (column reg.), reference positions "
            "outside the channel left out; the same numbers as the boxes above and each "
            "applicator's report. Input: the file commissioned (summary.csv input).",
            "small",
        ),
        grid_table([header, *rows], [f * w for f in BATCH_WIDTHS]),
    ]
    t2 = table2_rows(results)
    if t2:
        story += [
            heading(
                "|Dose difference| between the plans over the applicators, median (range), % "
                "(paper Table 2 [1])",
                2,
            ),
            grid_table(
                [["plans (applicators)", "Point A", "lateral surface", "lateral 5 mm"], *t2]
            ),
        ]
    if batch.failures:
        story.append(heading("Failed", 2))
        story += [
            para(f"<font color='#c62828'>FAILED</font> {_esc(item)}: {_esc(err)}", markup=True)
            for item, err in batch.failures
        ]
    f = fields or ReportFields()
    story += [*_references(PAPER_REFERENCE), *_free_notes([f.notes]), signature_block(f)]
    return layout.build_pdf(
        path, story, stamp, title=stamp.title, subject="HDR ring applicator commissioning"
    )


def _esc(text) -> str:
    return escape(str(text))


# ---------------------------------------------------------------------------------------------
# Several channels of one input: one report, a section per channel, one conclusion (issue 30)
# ---------------------------------------------------------------------------------------------

#: The order of the overall verdicts, best first (the front page's box takes the worst).
VERDICT_ORDER = ("PASS", "WARN", "FAIL", "ACTION", "ERROR")


def family_words(result):
    """The report words of ``result``'s channel family
    (:class:`ringqa.geometry.families.FamilyWords`; the ring's for an unknown family)."""
    from ringqa.geometry.families import FAMILIES

    family = FAMILIES.get(getattr(result, "family", "ring")) or FAMILIES["ring"]
    return family.words


def channel_title(result) -> str:
    """A channel section's title: ``Channel 1 (ring): ring channel of the ring applicator``."""
    words = family_words(result)
    name = result.settings.channel
    label = result.channel or name
    named = f" ({name})" if name and name != label else ""
    return f"Channel {label}{named}: {words.channel} ({words.title})"


def channel_verdict_rows(results) -> list[list[str]]:
    """The front page's verdict table: one row per channel and verdict (channel, family,
    check, value, status); the channel named on its first row only."""
    from ringqa.pipeline.numbers import fmt_verdict_value

    rows = []
    for res in results:
        words = family_words(res)
        first = True
        for v in res.verdicts:
            rows.append([
                channel_title(res).split(":")[0] if first else "",
                words.title if first else "",
                v.check,
                fmt_verdict_value(v.value, v.unit, v.check),
                v.status,
            ])  # fmt: skip
            first = False
    return rows


def worst_verdict(results, not_simulated=()) -> str:
    """The worst overall verdict of the channels (FAIL when a channel with dwells was left
    out: a channel never passes unseen)."""
    verdicts = [r.summary.verdict for r in results]
    if not_simulated:
        verdicts.append("FAIL")
    known = [v for v in verdicts if v in VERDICT_ORDER]
    return max(known, key=VERDICT_ORDER.index) if known else "FAIL"


def channels_front_flowables(
    results, conclusion: str, not_simulated: Sequence[str] = (), fields=None, notes=()
) -> list:
    """The front page of a several-channel report: the physicist's fields, the one conclusion
    over every channel, the verdict table per channel, the channels not commissioned (by name,
    with why), free notes and the signature block."""
    f = fields or ReportFields()
    first = results[0]
    w = layout.FRAME_WIDTH
    status = worst_verdict(results, not_simulated)
    rows = channel_verdict_rows(results)
    for row in rows:  # the status on its colour, as on page 1 of a one-channel report
        row[-1] = para(badge(row[-1]), "cell", markup=True)
    story = [
        heading("Commissioning report", 0),
        para(first.applicator, "h1"),
        _fields_table(field_rows(first, f)),
        layout.spacer(2),
        heading(f"Conclusion over all {len(results)} channels commissioned", 1),
        _conclusion_box(TextItem("conclusion", conclusion, status)),
        *(
            para(
                f"{badge(r.summary.verdict)}&nbsp; {escape(channel_title(r).split(':')[0])}: "
                f"{escape(r.conclusion)}",
                markup=True,
            )
            for r in results
        ),
        layout.spacer(1.5),
        heading("Verdicts per channel", 1),
        grid_table(
            [["channel", "family", "check", "value", "status"], *rows],
            [0.2 * w, 0.16 * w, 0.38 * w, 0.13 * w, 0.13 * w],
            align="LEFT",
        ),
        para(
            "Each channel's section (in this order) gives its run, verdicts, notes, reference "
            "path, numerical error, positions, deviations, dose points and settings.",
            "small",
        ),
    ]
    if not_simulated:
        story.append(heading("Channels with dwells NOT commissioned", 1))
        story += [para(f"• {_esc(text)}", "note", markup=True) for text in not_simulated]
    return [*story, *_free_notes([f.notes, *notes]), signature_block(f)]


def channel_section_flowables(result) -> list:
    """A channel's first page in a several-channel report: its title (number, name, family),
    then page 1 of a one-channel report (the run, verdicts and conclusion, notes, reference
    path, numbers as supplied | registered, numerical error) without the physicist's fields
    and signature, which the front page carries once."""
    return [
        heading(channel_title(result), 0),
        *items_flowables(page1_items(result)),
        *_references(PAPER_REFERENCE),
    ]


def write_channels_pdf(
    results,
    path: Path,
    *,
    conclusion: str,
    not_simulated: Sequence[str] = (),
    fields: ReportFields | None = None,
    notes: Sequence[str] = (),
) -> Path:
    """One report.pdf for several channels of one input: a front page with the one conclusion
    and the verdict table per channel (:func:`channels_front_flowables`), then a section per
    channel with the pages of a one-channel report (:func:`channel_section_flowables`,
    :func:`detail_pages`), under the same running header and footer.

    Parameters
    ----------
    results : sequence of CommissioningResult
        The channels, in the order of their sections (at least one).
    path : pathlib.Path
    conclusion : str
        The one conclusion over every channel.
    not_simulated : sequence of str
        One sentence per channel with dwells that was not commissioned.
    fields, notes
        As :func:`write_pdf`.

    Returns
    -------
    pathlib.Path
    """
    pages = [channels_front_flowables(results, conclusion, not_simulated, fields, notes)]
    for res in results:
        pages += [channel_section_flowables(res), *detail_pages(res, fields)]
    first = results[0]
    return layout.build_pdf(
        path,
        _joined(pages),
        page_stamp(first),
        title=f"ringqa commissioning report: {first.applicator}",
        subject="HDR gynaecological applicator commissioning, every channel",
    )
