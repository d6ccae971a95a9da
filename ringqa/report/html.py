"""``report.html``: the commissioning result as a 3D view a physicist can turn, beside report.pdf.

The PDF shows 2D projections; a ring, its channel and four source paths are 3D. The HTML page
shows, from the same :class:`~ringqa.pipeline.result.CommissioningResult` as the PDF:

- a rotatable 3D view (plotly) of every channel's centre line, the reference path (as supplied
  and registered), the simulated path, the centreline dwells and the dose points; hovering a
  simulated dwell shows its deviation from the reference (3D, along, radial, out of plane), its
  numerical error and the dwell's reference flag; hovering a dose point shows its dose and the
  dose differences of the simulated and centreline plans;
- the verdicts, the conclusion and the dose table, with the PDF's numbers in the PDF's forms
  (:mod:`ringqa.pipeline.numbers`; the dose table is :func:`ringqa.report.pdf.dose_table`).

The page is self-contained: plotly's JavaScript is inlined (no network, opened by
double-click). plotly is imported only here, when the page is written.
"""

from __future__ import annotations

from html import escape
from pathlib import Path

import numpy as np

from ringqa.outdir import atomic_write_bytes
from ringqa.pipeline.numbers import (
    DIST_MM,
    DOSE_GY,
    ERROR_MM,
    OFFSET_MM,
    SIGNED_PCT,
    fmt,
    fmt_verdict_value,
)
from ringqa.report.figures import FLAG_NAMES, reference_name
from ringqa.report.pdf import LONG_NAMES, dose_table

__all__ = ["PATH_STYLES", "html_parts", "html_text", "plotly_js", "view_figure", "write_html"]

#: dwell path -> (legend name, colour, marker size) in the 3D view
PATH_STYLES = {
    "measured": ("reference as supplied", "#6d4c41", 4),
    "registered": ("reference, registered", "#000000", 5),
    "simulated": ("simulated", "#1565c0", 5),
    "centreline": ("centreline dwells", "#2e7d32", 4),
}
STATUS_COLOURS = {"PASS": "#2e7d32", "WARN": "#ef6c00", "FAIL": "#c62828", "ACTION": "#c62828"}


def _dwell_hover(res, path: str, rows) -> list[str]:
    """One hover text per dwell of ``path``."""
    out = []
    for r in rows.itertuples():
        flag = str(getattr(r, "reference_flag", "") or "")
        flag = "" if flag in ("", "nan") else f"<br>reference: {FLAG_NAMES.get(flag, flag)}"
        text = (
            f"<b>{PATH_STYLES[path][0]}</b>, dwell {r.dwell}<br>"
            f"relative position {r.relative_position_mm:g} mm"
        )
        if path in ("simulated", "centreline") and path != res.reference:
            text += (
                f"<br>deviation {fmt(r.dist_to_reference_mm, DIST_MM)} mm "
                f"(along {fmt(r.along_mm, OFFSET_MM)}, radial {fmt(r.radial_mm, OFFSET_MM)}, "
                f"out of plane {fmt(r.out_of_plane_mm, OFFSET_MM)} mm)"
            )
        if path == "simulated" and hasattr(r, "numerical_error_mm"):
            text += f"<br>numerical error {fmt(r.numerical_error_mm, ERROR_MM)} mm"
        out.append(text + flag)
    return out


def _point_hover(res, point: str) -> str:
    d = res.doses[res.doses["point"] == point]
    lines = [f"<b>{escape(LONG_NAMES.get(point, point))}</b>"]
    for r in d.itertuples():
        if r.plan == "rtplan":
            continue
        line = f"{r.plan} plan: {fmt(r.dose_gy, DOSE_GY)} Gy"
        if r.plan not in (res.reference, "registered") and r.kind != "tps":
            line += f" ({fmt(r.diff_pct, SIGNED_PCT)} / {fmt(r.diff_registered_pct, SIGNED_PCT)} %)"
        lines.append(line)
    return "<br>".join(lines)


def _xyz(rows) -> dict:
    a = np.asarray(rows, dtype=float)
    return {"x": a[:, 0].tolist(), "y": a[:, 1].tolist(), "z": a[:, 2].tolist()}


#: mm of margin around the dwells and dose points in the 3D view
VIEW_MARGIN_MM = 10.0


def _scene(res) -> dict:
    """The 3D scene: axes around the dwells and dose points (the long channel shafts cut off,
    the ring fills the view), equal scales, the camera looking at the ring from cranial and
    slightly lateral."""
    d = res.dwells
    pts = [d[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)]
    std = res.doses[res.doses["kind"] != "tps"] if "kind" in res.doses else res.doses
    if not std.empty:
        pts.append(std[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float))
    xyz = np.vstack(pts)
    xyz = xyz[np.all(np.isfinite(xyz), axis=1)]
    lo, hi = xyz.min(axis=0) - VIEW_MARGIN_MM, xyz.max(axis=0) + VIEW_MARGIN_MM
    span = hi - lo
    ratio = span / span.max()
    normal = np.asarray(res.geometry.ring_normal, dtype=float)
    lateral = np.asarray(res.geometry.ring_lateral, dtype=float)
    eye = 1.6 * normal + 0.9 * lateral + 0.6 * np.cross(normal, lateral)
    axes = {
        f"{a}axis": {"title": {"text": f"{a} (mm)"}, "range": [float(lo[k]), float(hi[k])]}
        for k, a in enumerate("xyz")
    }
    return {
        **axes,
        "aspectmode": "manual",
        "aspectratio": {a: float(ratio[k]) for k, a in enumerate("xyz")},
        "camera": {"eye": {a: float(eye[k]) for k, a in enumerate("xyz")},
                   "up": {a: float(normal[k]) for k, a in enumerate("xyz")}},
    }  # fmt: skip


def view_figure(res) -> dict:
    """The 3D view of one result, as a plotly figure dict (``data``: traces, ``layout``; written
    with :func:`plotly.io.to_html` without building graph objects, which costs more than the
    rest of the page).

    Parameters
    ----------
    res : CommissioningResult

    Returns
    -------
    dict
        ``data``: one ``scatter3d`` line per channel centre line (``channel <name>``), one line
        with markers per dwell path (:data:`PATH_STYLES` names; ``text``: the hover texts, one
        per dwell), the dose points (``hovertext``: one per point); ``layout``.
    """
    data = []
    for name, pts in (res.geometry.centrelines_mm or {}).items():
        data.append({
            "type": "scatter3d", "mode": "lines", "name": f"channel {name}", **_xyz(pts),
            "line": {"color": "#9e9e9e", "width": 3}, "hoverinfo": "name",
        })  # fmt: skip
    d = res.dwells
    for path, (label, colour, size) in PATH_STYLES.items():
        rows = d[d["path"] == path]
        if rows.empty:
            continue
        data.append({
            "type": "scatter3d", "mode": "lines+markers", "name": label,
            **_xyz(rows[["x_mm", "y_mm", "z_mm"]]),
            "marker": {"size": size, "color": colour}, "line": {"color": colour, "width": 2},
            "text": _dwell_hover(res, path, rows), "hovertemplate": "%{text}<extra></extra>",
        })  # fmt: skip
    ref = res.doses[res.doses["plan"] == res.reference]
    ref = ref[ref["kind"] != "tps"]
    if not ref.empty:
        data.append({
            "type": "scatter3d", "mode": "markers+text", "name": "dose points",
            **_xyz(ref[["x_mm", "y_mm", "z_mm"]]),
            "text": [str(p) for p in ref["point"]], "textposition": "top center",
            "marker": {"size": 4, "color": "#c62828", "symbol": "diamond"},
            "hovertext": [_point_hover(res, str(p)) for p in ref["point"]],
            "hovertemplate": "%{hovertext}<extra></extra>",
        })  # fmt: skip
    layout = {
        "scene": _scene(res),
        "margin": {"l": 0, "r": 0, "t": 30, "b": 0}, "height": 640,
        "legend": {"itemsizing": "constant"},
        "title": {"text": f"{escape(res.applicator)}: dwell positions, compared with the "
                          f"{reference_name(res)}"},
    }  # fmt: skip
    return {"data": data, "layout": layout}


def _table(header, rows) -> str:
    head = "".join(f"<th>{escape(str(h)).replace(chr(10), '<br>')}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{escape(str(c)).replace(chr(10), '<br>')}</td>" for c in row)
        + "</tr>"
        for row in rows
    )  # fmt: skip
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _verdicts_html(res) -> str:
    rows = []
    for v in res.verdicts:
        colour = STATUS_COLOURS.get(v.status, "#000")
        rows.append(
            f"<tr><td style='color:{colour};font-weight:bold'>{escape(v.status)}</td>"
            f"<td>{escape(v.role)}</td><td>{escape(v.check)}</td>"
            f"<td>{escape(fmt_verdict_value(v.value, v.unit, v.check))}</td>"
            f"<td>{escape(v.text)}</td></tr>"
        )
    head = "<tr><th>status</th><th>kind</th><th>check</th><th>value</th><th>what it says</th></tr>"
    return f"<table><thead>{head}</thead><tbody>{''.join(rows)}</tbody></table>"


CSS = """
body { font-family: DejaVu Sans, Helvetica, Arial, sans-serif; margin: 1.5em; color: #212121; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em 0; font-size: 0.85em; }
th, td { border: 1px solid #bdbdbd; padding: 3px 6px; vertical-align: top; }
th { background: #eeeeee; }
.conclusion { border: 2px solid #424242; padding: 0.5em; margin: 1em 0; font-weight: bold; }
.small { font-size: 0.8em; color: #616161; }
"""


def prepare_html() -> None:
    """Load what :func:`html_text` needs ahead of it (plotly and its default template, about
    0.13 s CPU of the first page: e.g. while a forked process commissions). Nothing is
    written; the page is the same with or without it."""
    import plotly.io

    tiny = {"data": [{"type": "scatter3d", "x": [0.0], "y": [0.0], "z": [0.0]}], "layout": {}}
    plotly.io.to_html(tiny, full_html=False, include_plotlyjs=False, validate=False)


#: plotly's own configuration line, which it writes before its inlined script
#: (``plotly.io.to_html(..., include_plotlyjs=True)``): MathJax is not fetched
PLOTLY_CONFIG = "<script>window.PlotlyConfig = {MathJaxConfig: 'local'};</script>"


def plotly_js() -> bytes:
    """plotly.js, minified, as the installed plotly ships it (the file
    :func:`plotly.offline.get_plotlyjs` reads, as bytes: no 4.6 MB decode and encode)."""
    import pkgutil

    data = pkgutil.get_data("plotly", "package_data/plotly.min.js")
    if data is None:  # pragma: no cover - a plotly laid out otherwise
        from plotly.offline import get_plotlyjs

        data = get_plotlyjs().encode("utf-8")
    return data


def html_parts(res) -> tuple[str, str]:
    """The page (:func:`html_text`) before and after plotly.js, which goes between them in a
    ``<script>`` element of the page's head, after :data:`PLOTLY_CONFIG` (as
    ``plotly.io.to_html`` with ``include_plotlyjs=True`` writes both, once for the page)."""
    import plotly.io

    view = plotly.io.to_html(view_figure(res), full_html=False, include_plotlyjs=False,
                             validate=False, config={"displaylogo": False})  # fmt: skip
    header, rows = dose_table(res)
    prov = res.provenance
    inputs = "".join(
        f"<li>{escape(name)} (SHA-256 {digest})</li>" for name, digest in prov.inputs.items()
    )
    before = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>ringqa commissioning: {escape(res.applicator)}</title>
<style>{CSS}</style>
{PLOTLY_CONFIG}
<script>"""
    after = f"""</script></head>
<body>
<h1>Commissioning: {escape(res.applicator)}</h1>
<p class="small">{escape(prov.software)}, {escape(prov.created_utc)} UTC; input
{escape(res.input_label)} ({escape(res.input_kind)}); reference: {escape(reference_name(res))}.
The signed report is report.pdf beside this page; its numbers are these.</p>
<ul class="small">{inputs}</ul>
<div class="conclusion">{escape(res.conclusion)}</div>
<h2>Verdicts</h2>
{_verdicts_html(res)}
<h2>Dwell positions in 3D</h2>
<p class="small">Drag to turn, scroll to zoom; hover a dwell for its deviation and numerical
error, a dose point for its doses and differences (to the reference plan as supplied /
registered, %). Click a legend entry to hide a path.</p>
{view}
<h2>Dose (Gy) of the standard plan on each dwell set</h2>
<p class="small">In brackets the difference to the standard plan on the reference path as
supplied / registered, % (as report.pdf).</p>
{_table(header, rows)}
</body></html>
"""
    return before, after


def html_text(res) -> str:
    """The whole page (one string, plotly's JavaScript inlined in its head)."""
    before, after = html_parts(res)
    return before + plotly_js().decode("utf-8") + after


def write_html(res, path) -> Path:
    """Write ``report.html`` of ``res`` to ``path`` (atomically).

    Parameters
    ----------
    res : CommissioningResult
    path : str or pathlib.Path

    Returns
    -------
    pathlib.Path
    """
    path = Path(path)
    before, after = html_parts(res)
    # plotly.js (4.6 MB) goes in as the bytes it was read as: one copy of the page in all
    # (building it as text, then encoding it, made five; docs/speed.md, 2026-11-29)
    atomic_write_bytes(path, b"".join((before.encode("utf-8"), plotly_js(), after.encode("utf-8"))))
    return path
