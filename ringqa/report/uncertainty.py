"""The report's uncertainty page: what a sweep (``commission --sweep`` / ``--uncertainty N``)
says about each verdict.

The page is a report *section* (:data:`ringqa.report.pdf.Section`): :func:`uncertainty_section`
takes the sweep's ``summary.csv`` table (columns ``dwell, point, quantity, mean, sd, p2_5,
p97_5, n_ok, n_failed``; :mod:`ringqa.sweep.analysis`), its figure and its record, and returns
the callable the report writer calls with the result. It does not import the sweep: the report
only lays out what it is handed.

What "holds across the uncertainty" means here (the 95 % interval of the sampled parameters):

- position: a dwell holds when the upper end (p97.5) of its 3D deviation from the reference is
  within the required position tolerance;
- dose: a point holds when the whole interval [p2.5, p97.5] of its dose difference is within
  plus or minus the dose action level.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

import pandas as pd

from ringqa.pipeline.numbers import SIGNED_PCT, fmt
from ringqa.report import layout
from ringqa.report.layout import grid_table, heading, para

__all__ = ["interval_verdicts", "judged_points", "left_out_dwells", "uncertainty_section"]


def _rows(summary: pd.DataFrame, key: str, quantity: str) -> pd.DataFrame:
    sub = summary[(summary["quantity"] == quantity) & (summary[key].astype(str) != "")]
    return sub.reset_index(drop=True)


def _dwell_key(value) -> str:
    try:
        return str(int(float(value)))
    except (TypeError, ValueError):
        return str(value)


def left_out_dwells(result) -> set[str]:
    """The dwells the result's verdicts leave out (reference position outside the channel), as
    the sweep's ``dwell`` column names them."""
    d = result.dwells
    if "reference_flag" not in d:
        return set()
    out = d[(d["path"] == "simulated") & (d["reference_flag"].astype(str) == "outside_channel")]
    return {_dwell_key(x) for x in out["dwell"]}


def judged_points(result) -> set[str] | None:
    """The dose points the result's dose verdicts judge (the standard points; the RT Plan's own
    points, kind ``tps``, are an input check against the TPS, not judged here)."""
    d = result.doses
    if "kind" not in d:
        return None
    return {str(p) for p in d[d["kind"] != "tps"]["point"]}


def interval_verdicts(
    summary: pd.DataFrame, required_mm: float, action_pct: float, left_out=(), points=None
) -> dict[str, list[tuple[str, float, float, bool]]]:
    """Per dwell and per dose point: the 95 % interval and whether the verdict holds across it.

    Parameters
    ----------
    summary : pandas.DataFrame
        The sweep's ``summary.csv`` table.
    required_mm : float
        Required position tolerance, mm.
    action_pct : float
        Dose-difference action level, %.
    left_out : collection of str
        Dwells the verdicts leave out (:func:`left_out_dwells`): left out here too.
    points : collection of str, optional
        The dose points the verdicts judge (:func:`judged_points`; default: every point).

    Returns
    -------
    dict
        ``"dwells"``: ``(dwell, mean_mm, p97_5_mm, holds)`` of ``deviation_mm``;
        ``"points"``: ``(point, p2_5_pct, p97_5_pct, holds)`` of ``dose_diff_pct``. A row
        without successful samples (NaN bounds) never holds.
    """
    dwells = []
    skip = {_dwell_key(x) for x in left_out}
    for row in _rows(summary, "dwell", "deviation_mm").itertuples():
        if _dwell_key(row.dwell) in skip:
            continue
        hi = float(row.p97_5)
        dwells.append((_dwell_key(row.dwell), float(row.mean), hi, bool(hi <= required_mm)))
    judged = None if points is None else {str(p) for p in points}
    rows = []
    for row in _rows(summary, "point", "dose_diff_pct").itertuples():
        if judged is not None and str(row.point) not in judged:
            continue
        lo, hi = float(row.p2_5), float(row.p97_5)
        ok = math.isfinite(lo) and math.isfinite(hi) and max(abs(lo), abs(hi)) <= action_pct
        rows.append((str(row.point), lo, hi, bool(ok)))
    return {"dwells": dwells, "points": rows}


def _png(data: bytes, width: float):
    """PNG bytes as an image flowable ``width`` points wide (aspect kept)."""
    from io import BytesIO

    from reportlab.lib.utils import ImageReader

    from ringqa.report.layout import PixelImage

    reader = ImageReader(BytesIO(data))
    w, h = reader.getSize()
    return PixelImage(reader, width, width * h / w)


def uncertainty_section(
    summary: pd.DataFrame, figure_png: bytes | None = None, record: Mapping | None = None
) -> Callable[[object], list]:
    """The uncertainty page as a report section.

    Parameters
    ----------
    summary : pandas.DataFrame
        The sweep's ``summary.csv`` table.
    figure_png : bytes, optional
        The sweep's ``uncertainty.png`` (95 % position ellipses, dose intervals).
    record : mapping, optional
        The sweep's ``sweep.json`` record (``n_ok``, ``n_runs`` and the spec are printed).

    Returns
    -------
    callable
        ``section(result) -> list of flowables`` (tolerances from ``result.settings``).
    """
    record = dict(record or {})

    def section(result) -> list:
        s = result.settings
        required = float(s.position_limits_mm[1])
        action = float(s.dose_action_pct)
        skip = left_out_dwells(result)
        v = interval_verdicts(summary, required, action, skip, judged_points(result))
        n_ok, n_runs = record.get("n_ok", "?"), record.get("n_runs", "?")
        bad_dwells = [d for d, _, _, ok in v["dwells"] if not ok]
        bad_points = [p for p, _, _, ok in v["points"] if not ok]
        out = [
            heading("Uncertainty of the simulated positions and doses", 0),
            para(
                f"{n_ok} of {n_runs} sampled commissioning runs succeeded (parameters and their "
                "distributions: the sweep specification in results of ringqa sweep, "
                "docs/sweeps.md). Intervals are the 2.5th-97.5th percentiles of the samples. "
                f"Position holds when the 97.5th percentile of a dwell's deviation is within "
                f"{required:g} mm (required); dose holds when the whole interval is within "
                f"+/-{action:g} %. The same comparison as the verdicts: registration "
                f"{result.summary.registration}, dose differences to the registered reference "
                "plan at the standard dose points (the RT Plan's own points are in "
                "uncertainty.csv)"
                + (
                    f", dwell(s) {', '.join(sorted(skip, key=float))} left out (reference "
                    "position outside the channel)."
                    if skip
                    else "."
                )
            ),
            para(
                "Position: "
                + (
                    f"holds at all {len(v['dwells'])} dwells."
                    if not bad_dwells
                    else f"does NOT hold at {len(bad_dwells)} of {len(v['dwells'])} dwells "
                    f"({', '.join(bad_dwells[:12])}{' ...' if len(bad_dwells) > 12 else ''})."
                )
                + " Dose: "
                + (
                    f"holds at all {len(v['points'])} points."
                    if not bad_points
                    else f"does NOT hold at {', '.join(bad_points)}."
                )
            ),
        ]
        if figure_png is not None:
            out.append(_png(figure_png, layout.FRAME_WIDTH * 0.9))
        rows = [["point", "dose difference p2.5 (%)", "p97.5 (%)", f"within +/-{action:g} %"]]
        rows += [
            [p, fmt(lo, SIGNED_PCT), fmt(hi, SIGNED_PCT), "yes" if ok else "NO"]
            for p, lo, hi, ok in v["points"]
        ]
        out.append(grid_table(rows))
        return out

    return section
