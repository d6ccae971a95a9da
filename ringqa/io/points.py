"""Centreline and source-path points: CSV and JSON files in millimetres, metres inside.

Formats (both documented in ``docs/importers.md``):

CSV
    A header row with the columns ``x_mm, y_mm, z_mm`` (any order, extra columns ignored) and
    optionally ``relative_position_mm`` and (source paths) ``sd_mm``, each point's standard
    uncertainty. Blank lines and lines starting with ``#`` are skipped, except the two settings
    of a measured source path written as comments: ``# method = film`` (film, ct, panel,
    vendor) and ``# measured_sd_mm = 0.5`` (one uncertainty for every point).
    Separator: comma (else ``;`` or tab, as found in the header); decimal point ``.``.
    Encoding: UTF-8 (with or without BOM), UTF-16 with its BOM, else Latin-1 (a German Excel's
    comment); :attr:`PointSet.encoding` records it, :attr:`PointSet.notes` says when not UTF-8.
JSON
    ``{"units": "mm", "points": [[x, y, z], ...], "relative_position_mm": [...]}`` (the last key
    optional), or the column form ``{"x_mm": [...], "y_mm": [...], "z_mm": [...]}``; a source
    path may add ``"sd_mm": [...]`` (or one ``"measured_sd_mm"``) and ``"method"``.

Measured source paths may be any subset of positions along the path (a film, a CT marker wire):
give their ``relative_position_mm``. A single point off the path of its neighbours (an outlier)
is kept and named in :attr:`PointSet.notes` and :attr:`PointSet.outliers` (the pipeline's
reference check then flags it), rather than refused as rows out of order.

Ordering conventions
    A centreline (``kind="centreline"``) runs PROXIMAL (channel entry) -> DISTAL (tip), and so
    does a centreline correction segment (``kind="correction"``, read by
    :mod:`ringqa.io.correction`). A measured source path (``kind="path"``) lists source-centre
    positions MOST DISTAL FIRST (relative positions 0, step, 2 step, ...), as afterloaders and
    TPSs number them.

Every problem (missing file or column, metres, centimetres or micrometres instead of
millimetres, a huge offset, NaN, duplicated or unordered points, too few points) raises
:class:`PointsFileError` naming the file, the row or column and the fix.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringqa.errors import InputFileError
from ringqa.geometry.centreline import MAX_POINTS, point_count_problem
from ringqa.jsonio import json_text
from ringqa.outdir import atomic_write_text
from ringqa.textio import check_columns, read_json, read_text
from ringqa.units import m_to_mm, mm_to_m

KINDS = ("centreline", "path", "correction")
MIN_POINTS = {"centreline": 4, "path": 2, "correction": 4}
#: What each kind is called in messages.
KIND_NAMES = {"centreline": "centreline", "path": "path", "correction": "correction segment"}
COLUMNS = ("x_mm", "y_mm", "z_mm")
REL_COLUMN = "relative_position_mm"
#: Points closer than this (mm) are duplicates.
DUPLICATE_TOL_MM = 1.0e-3
#: A whole file spanning less than this (mm) is almost certainly written in metres.
METRE_SPAN_MM = 1.0
#: Consecutive segments turning by more than this (deg) mean the points are out of order.
TURN_BACK_DEG = 100.0
#: No applicator point lies farther than this (mm) from the origin of any patient or applicator
#: frame (DICOM patient coordinates stay within about 1 m): larger values are another unit.
MAX_COORDINATE_MM = 1.0e4
#: A centreline shorter or longer than this (mm) is in another unit (cm, m, um) or not a channel.
CENTRELINE_LENGTH_MM = (20.0, 5000.0)
#: Encodings tried, in order, for CSV files (name used in notes, codec). UTF-16 only with its BOM.
CSV_ENCODINGS = (("UTF-8", "utf-8"), ("Latin-1", "latin-1"))
#: Column of each point's standard uncertainty (source paths).
SD_COLUMN = "sd_mm"
#: How a measured source path was measured (``method`` in the file; recorded in provenance).
METHODS = ("film", "ct", "panel", "vendor")
#: Consecutive positions of a source path with relative positions more than this apart (mm) are
#: not checked for turning back (sparse film positions on a ring turn by their arc between).
TURN_CHECK_GAP_MM = 10.0


class PointsFileError(InputFileError):
    """A centreline or source-path file cannot be read correctly."""


@dataclass(frozen=True)
class PointSet:
    """Points read from a file.

    Attributes
    ----------
    points_m : numpy.ndarray
        (n, 3) positions in metres, in the file's order (see the module docstring).
    relative_position_mm : numpy.ndarray or None
        (n,) relative positions in mm when the file has them.
    kind : str
        ``"centreline"``, ``"path"`` or ``"correction"``.
    path : str
        The file read.
    labels : tuple of str
        Where each point is in the file (``"line 7"`` in a CSV, ``"point 3"`` in JSON), for
        messages about single points found later (e.g. by the centreline correction).
    encoding : str
        The text encoding the file was read with: ``"UTF-8"``, ``"UTF-8 with BOM"``,
        ``"UTF-16"`` or ``"Latin-1"`` (the fallback when the file is not UTF-8, e.g. a comment
        written by a German Excel).
    notes : tuple of str
        Things the caller should show the user (e.g. the Latin-1 fallback, an outlier kept);
        empty when there is nothing to say.
    sd_mm : (n,) ndarray or None
        Each point's standard uncertainty, mm (a source path's ``sd_mm`` column or its one
        ``measured_sd_mm``); None when the file gives none.
    method : str
        How the path was measured (one of :data:`METHODS`), ``""`` when not stated.
    outliers : tuple of int
        Rows (0-based, file order) of single points off the path of their neighbours: kept,
        named in ``notes``.
    """

    points_m: np.ndarray
    relative_position_mm: np.ndarray | None
    kind: str
    path: str
    labels: tuple[str, ...] = ()
    encoding: str = "UTF-8"
    notes: tuple[str, ...] = ()
    sd_mm: np.ndarray | None = None
    method: str = ""
    outliers: tuple[int, ...] = ()


def read_points(path: str | Path, kind: str = "centreline") -> np.ndarray:
    """Read centreline or source-path points from CSV or JSON.

    Parameters
    ----------
    path : str or Path
        A ``.csv`` or ``.json`` file in millimetres (see the module docstring).
    kind : {"centreline", "path", "correction"}
        Centreline (proximal -> distal, at least 4 points), measured source path (most distal
        first, at least 2 points) or centreline correction segment (proximal -> distal, at least
        4 points; see :mod:`ringqa.io.correction`).

    Returns
    -------
    numpy.ndarray
        (n, 3) points in METRES.

    Raises
    ------
    PointsFileError
        On any problem, naming the file, the row/column and the fix.
    """
    return read_point_set(path, kind).points_m


def read_point_set(path: str | Path, kind: str = "centreline") -> PointSet:
    """Like :func:`read_points` but also return the optional relative positions."""
    if kind not in KINDS:
        raise ValueError(f"kind={kind!r}: use one of {KINDS}")
    p = Path(path)
    if not p.is_file():
        raise PointsFileError(p, "file not found", "check the path")
    suffix = p.suffix.lower()
    encoding = "UTF-8"
    extra: dict = {}
    if suffix == ".csv":
        text, encoding = read_text_any(p)
        _check_line_count(p, text, kind)
        pts, rel, labels = _read_csv(p, text, extra)
    elif suffix == ".json":
        pts, rel, labels = _read_json(p, extra)
    else:
        raise PointsFileError(
            p, f"unknown file type {p.suffix!r}", "use a .csv (x_mm,y_mm,z_mm) or .json file"
        )
    sd, method = path_uncertainty(p, extra, len(pts), labels, kind)
    outliers = check_points(p, pts, rel, labels, kind)
    notes: tuple[str, ...] = ()
    if encoding in ("Latin-1", "UTF-16"):
        notes = (
            f"{p.name}: not UTF-8, read as {encoding}; the numbers are unaffected, but check any "
            "non-ASCII text (comments, labels) and save the file as UTF-8 to silence this note",
        )
    for k in outliers:
        notes += (
            f"{p.name}: {labels[k]} lies off the path of its neighbours ({labels[k - 1]}, "
            f"{labels[k + 1]}): a single outlier, kept and checked against the channel with the "
            "other points (correct or remove it if it is a typing error)",
        )
    return PointSet(
        points_m=np.ascontiguousarray(mm_to_m(pts)),
        relative_position_mm=None if rel is None else np.ascontiguousarray(rel),
        kind=kind,
        path=str(p),
        labels=tuple(labels),
        encoding=encoding,
        notes=notes,
        sd_mm=sd,
        method=method,
        outliers=tuple(outliers),
    )


def path_uncertainty(p, extra: dict, n: int, labels, kind: str) -> tuple[np.ndarray | None, str]:
    """The per-point uncertainty (mm) and the method a file gave (``extra``: ``sd_mm`` list,
    ``measured_sd_mm`` number, ``method`` text, as read), checked."""
    sd = extra.get("sd_mm")
    one = extra.get("measured_sd_mm")
    method = extra.get("method", "")
    if (sd is not None or one is not None or method) and kind != "path":
        raise PointsFileError(
            p, "sd_mm / measured_sd_mm / method belong to a measured source path",
            "leave them out of a centreline file",
        )  # fmt: skip
    if sd is not None and one is not None:
        raise PointsFileError(
            p, "both sd_mm (per point) and measured_sd_mm (all points) are given", "keep one"
        )
    if one is not None:
        if not (math.isfinite(one) and one > 0):
            raise PointsFileError(p, f"measured_sd_mm is {one!r}", "give a number of mm > 0")
        sd = np.full(n, float(one))
    if sd is not None:
        sd = np.asarray(sd, dtype=float)
        bad = np.flatnonzero(~(np.isfinite(sd) & (sd > 0)))
        if bad.size:
            k = int(bad[0])
            raise PointsFileError(
                p, f"{labels[k]}, {SD_COLUMN}: {float(sd[k]):g} is not an uncertainty",
                "give each point's standard uncertainty in mm (> 0)",
            )  # fmt: skip
    if method and method not in METHODS:
        raise PointsFileError(
            p, f"method {method!r} is not known", f"choose one of {', '.join(METHODS)}"
        )
    return sd, str(method)


def _check_line_count(p: Path, text: str, kind: str) -> None:
    """Refuse a CSV with more data rows than a centreline or path may have before parsing it
    (issue 25: a 10^6-row file took 10 s and 800 MB to parse before any check)."""
    if max(text.count("\n"), text.count("\r")) <= MAX_POINTS:  # also old Mac line ends
        return
    rows = sum(1 for line in text.splitlines() if line.strip() and not line.lstrip()[:1] == "#")
    too_many = point_count_problem(rows - 1, KIND_NAMES[kind])
    if too_many is not None:
        raise PointsFileError(p, *too_many)


def read_text_any(p: Path) -> tuple[str, str]:
    """The text of ``p`` and the encoding used: UTF-8 (with or without BOM), UTF-16 (with its
    BOM, as Excel's "Unicode text" writes it), else Latin-1 (which decodes any bytes: the
    fallback for files from a non-UTF-8 Excel or editor)."""
    tf = read_text(p, what="CSV", latin1=True, error=PointsFileError)  # ringqa.textio
    return tf.text, tf.encoding


def write_points(
    path: str | Path,
    points_m: np.ndarray,
    relative_position_mm: np.ndarray | None = None,
) -> Path:
    """Write points (metres) as a CSV ``x_mm,y_mm,z_mm`` (or JSON if ``path`` ends in .json).

    Parameters
    ----------
    path : str or Path
        Target file; ``.json`` writes ``{"units": "mm", "points": ...}``, anything else CSV.
    points_m : array_like
        (n, 3) positions in metres.
    relative_position_mm : array_like, optional
        (n,) relative positions (mm), written as the ``relative_position_mm`` column/key.

    Returns
    -------
    Path
        The file written (atomically: :func:`ringqa.outdir.atomic_write_text`). Coordinates are
        written to 1e-6 mm, so reading the file back gives the same points to 1 nm.
    """
    pts = np.asarray(points_m, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points_m: expected shape (n, 3), got {pts.shape}")
    mm = m_to_mm(pts)
    rel = None if relative_position_mm is None else np.asarray(relative_position_mm, dtype=float)
    if rel is not None and rel.shape != (len(pts),):
        raise ValueError(f"relative_position_mm: expected shape ({len(pts)},), got {rel.shape}")
    p = Path(path)
    if p.suffix.lower() == ".json":
        doc: dict = {"units": "mm", "points": [[round(float(v), 6) for v in row] for row in mm]}
        if rel is not None:
            doc[REL_COLUMN] = [round(float(v), 6) for v in rel]
        return atomic_write_text(p, json_text(doc, indent=1) + "\n")
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow([*COLUMNS, *([REL_COLUMN] if rel is not None else [])])
    for i, row in enumerate(mm):
        cells = [f"{v:.6f}" for v in row]
        if rel is not None:
            cells.append(f"{rel[i]:.6f}")
        w.writerow(cells)
    return atomic_write_text(p, buf.getvalue())


# --------------------------------------------------------------------------------------------
# parsing


def _metre_columns_error(p: Path, header: list[str]) -> PointsFileError | None:
    lower = [h.strip().lower() for h in header]
    if any(h in ("x_m", "y_m", "z_m") for h in lower):
        return PointsFileError(
            p,
            "columns are in metres (x_m, y_m, z_m)",
            "write millimetres in columns x_mm, y_mm, z_mm (multiply by 1000)",
        )
    if any(h in ("x_cm", "y_cm", "z_cm") for h in lower):
        return PointsFileError(
            p,
            "columns are in centimetres (x_cm, ...)",
            "write millimetres in columns x_mm, y_mm, z_mm (multiply by 10)",
        )
    return None


def _comment_settings(p: Path, text: str, extra: dict) -> None:
    """``# method = film`` and ``# measured_sd_mm = 0.5`` comment lines into ``extra``."""
    for n, line in enumerate(text.splitlines(), start=1):
        body = line.strip()
        if not body.startswith("#") or "=" not in body:
            continue
        name, _, value = (part.strip() for part in body[1:].partition("="))
        if name == "method":
            extra["method"] = value.strip("\"'").lower()
        elif name == "measured_sd_mm":
            try:
                extra["measured_sd_mm"] = float(value)
            except ValueError:
                raise PointsFileError(
                    p, f"line {n}: measured_sd_mm = {value!r} is not a number",
                    "write e.g. # measured_sd_mm = 0.5",
                ) from None  # fmt: skip


def _read_csv(
    p: Path, text: str, extra: dict | None = None
) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    extra = {} if extra is None else extra
    if "\x00" in text:
        raise PointsFileError(p, "contains NUL bytes: not a text (CSV) file", "save it as a CSV")
    _comment_settings(p, text, extra)
    lines = [
        (n, line)
        for n, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not lines:
        raise PointsFileError(
            p, "empty file", "write a header x_mm,y_mm,z_mm and one row per point"
        )
    head = lines[0][1]
    delimiter = next((d for d in (",", ";", "\t") if d in head), ",")
    rows = list(csv.reader([line for _, line in lines], delimiter=delimiter))
    header = [h.strip() for h in rows[0]]
    check_columns(header, p, error=PointsFileError)  # a repeated column: refused, named
    err = _metre_columns_error(p, header)
    if err:
        raise err
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise PointsFileError(
            p,
            f"header line {lines[0][0]} has no column(s) {', '.join(missing)} "
            f"(found: {', '.join(header) or 'nothing'})",
            "the first line must name the columns x_mm,y_mm,z_mm with units in millimetres",
        )
    wanted = list(COLUMNS) + ([REL_COLUMN] if REL_COLUMN in header else [])
    wanted += [SD_COLUMN] if SD_COLUMN in header else []
    idx = [header.index(c) for c in wanted]
    values = np.empty((len(rows) - 1, len(wanted)))
    labels = []
    for k, (row, (lineno, _)) in enumerate(zip(rows[1:], lines[1:], strict=True)):
        labels.append(f"line {lineno}")
        for j, (col, i) in enumerate(zip(wanted, idx, strict=True)):
            cell = row[i].strip() if i < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                raise PointsFileError(
                    p,
                    f"line {lineno}, column {col}: {cell!r} is not a number",
                    "write decimals with a point, not a comma"
                    if "," in cell
                    else "every row needs numeric x_mm, y_mm, z_mm",
                ) from None
            if not math.isfinite(v):
                raise PointsFileError(
                    p,
                    f"line {lineno}, column {col}: value is {cell}",
                    "remove the row or give a finite number",
                )
            values[k, j] = v
    rel = values[:, wanted.index(REL_COLUMN)].copy() if REL_COLUMN in wanted else None
    if SD_COLUMN in wanted:
        extra["sd_mm"] = values[:, wanted.index(SD_COLUMN)].copy()
    return values[:, :3].copy(), rel, labels


def _read_json(
    p: Path, extra: dict | None = None
) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    extra = {} if extra is None else extra
    doc = read_json(p, error=PointsFileError)  # strict: duplicate keys, depth, encoding
    if not isinstance(doc, dict):
        raise PointsFileError(
            p, "top level is not an object", 'write {"units": "mm", "points": [[x, y, z], ...]}'
        )
    if any(k in doc for k in ("x_m", "y_m", "z_m")):
        raise PointsFileError(
            p, "keys are in metres (x_m, ...)", "write millimetres under x_mm, y_mm, z_mm"
        )
    rel = doc.get(REL_COLUMN)
    if "points" in doc:
        units = doc.get("units")
        if units is None:
            raise PointsFileError(
                p, 'no "units" key', 'add "units": "mm" (coordinates must be in millimetres)'
            )
        if str(units).strip().lower() != "mm":
            hint = " (multiply by 1000)" if str(units).strip().lower() in ("m", "metre") else ""
            raise PointsFileError(
                p,
                f'"units" is {units!r}; ringqa reads millimetres',
                f'convert the points to mm{hint} and set "units": "mm"',
            )
        raw = doc["points"]
        if not isinstance(raw, list):
            raise PointsFileError(p, '"points" is not a list', "give a list of [x, y, z] triples")
        values = np.empty((len(raw), 3))
        for k, item in enumerate(raw):
            if not (isinstance(item, list | tuple) and len(item) == 3):
                raise PointsFileError(
                    p, f"points[{k}] is {item!r}, not [x, y, z]", "give three numbers per point"
                )
            for j in range(3):
                values[k, j] = _json_number(p, f"points[{k}][{j}]", item[j])
    elif all(c in doc for c in COLUMNS):
        cols = [doc[c] for c in COLUMNS]
        if not all(isinstance(c, list) for c in cols) or len({len(c) for c in cols}) != 1:
            raise PointsFileError(
                p, "x_mm, y_mm, z_mm are not lists of equal length", "give one value per point"
            )
        values = np.empty((len(cols[0]), 3))
        for j, (name, col) in enumerate(zip(COLUMNS, cols, strict=True)):
            for k, v in enumerate(col):
                values[k, j] = _json_number(p, f"{name}[{k}]", v)
    else:
        raise PointsFileError(
            p,
            f"no points found (keys: {', '.join(doc) or 'none'})",
            'write {"units": "mm", "points": [[x, y, z], ...]} or x_mm/y_mm/z_mm lists',
        )
    if rel is not None:
        if not isinstance(rel, list) or len(rel) != len(values):
            raise PointsFileError(
                p,
                f'"{REL_COLUMN}" does not have one value per point ({len(values)})',
                "give one relative position per point or leave the key out",
            )
        rel = np.array([_json_number(p, f"{REL_COLUMN}[{k}]", v) for k, v in enumerate(rel)])
    labels = [f"point {k}" for k in range(len(values))]
    sd = doc.get(SD_COLUMN)
    if sd is not None:
        if not isinstance(sd, list) or len(sd) != len(values):
            raise PointsFileError(
                p, f'"{SD_COLUMN}" does not have one value per point ({len(values)})',
                'give one uncertainty per point, or one "measured_sd_mm" for all',
            )  # fmt: skip
        extra["sd_mm"] = [_json_number(p, f"{SD_COLUMN}[{k}]", v) for k, v in enumerate(sd)]
    if "measured_sd_mm" in doc:
        extra["measured_sd_mm"] = _json_number(p, "measured_sd_mm", doc["measured_sd_mm"])
    if "method" in doc:
        if not isinstance(doc["method"], str):
            raise PointsFileError(p, "method is not text", f"write one of {', '.join(METHODS)}")
        extra["method"] = doc["method"].strip().lower()
    return values, rel, labels


def _json_number(p: Path, where: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise PointsFileError(p, f"{where} is {v!r}, not a number", "give numbers in mm")
    if not math.isfinite(v):
        raise PointsFileError(p, f"{where} is {v}", "give a finite number")
    return float(v)


# --------------------------------------------------------------------------------------------
# checks


def check_points(p, pts: np.ndarray, rel: np.ndarray | None, labels, kind: str) -> tuple[int, ...]:
    """Refuse points (mm, file order) that cannot be what ``kind`` says: too few, in another unit
    (metres, centimetres, micrometres, a huge offset), duplicated or out of order.

    ``p`` names the file in messages, ``labels`` each point (``"line 7"``); used for CSV and
    JSON point files and for points given inline in an applicator file.

    Returns
    -------
    tuple of int
        A source path's single outliers (rows off the path of their neighbours, see
        :func:`single_outliers`): kept, for the caller to name. Empty for other kinds.
    """
    n = len(pts)
    name = KIND_NAMES[kind]
    too_many = point_count_problem(n, name)
    if too_many is not None:
        raise PointsFileError(p, *too_many)
    if n < MIN_POINTS[kind]:
        raise PointsFileError(
            p,
            f"{n} point(s); a {name} needs at least {MIN_POINTS[kind]}",
            "give more points (centrelines: one every 1-2 mm)",
        )
    span = float(np.max(np.ptp(pts, axis=0)))
    if span < METRE_SPAN_MM:
        raise PointsFileError(
            p,
            f"all points lie within {span:.3g} mm of each other: this looks like metres",
            "write coordinates in millimetres (multiply by 1000)",
        )
    far = np.abs(pts).max(axis=1)
    if float(far.max()) > MAX_COORDINATE_MM:
        k = int(np.argmax(far))
        raise PointsFileError(
            p,
            f"{labels[k]} has a coordinate of {pts[k][np.argmax(np.abs(pts[k]))]:.6g} mm: no "
            f"applicator lies {MAX_COORDINATE_MM / 1000:g} m from the origin",
            "write coordinates in millimetres (micrometres: divide by 1000) in the patient or "
            "applicator frame, without a large offset",
        )
    steps = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    dup = np.flatnonzero(steps < DUPLICATE_TOL_MM)
    if dup.size:
        k = int(dup[0])
        raise PointsFileError(
            p,
            f"{labels[k + 1]} repeats the point of {labels[k]} ({len(dup)} duplicate(s))",
            "remove duplicated points",
        )
    if rel is not None:
        d = np.diff(rel)
        bad = np.flatnonzero(d <= 0)
        if bad.size:
            k = int(bad[0])
            order = "increase (most distal first)" if kind == "path" else "increase"
            raise PointsFileError(
                p,
                f"{REL_COLUMN} does not {order}: {labels[k]} has {rel[k]:g}, "
                f"{labels[k + 1]} has {rel[k + 1]:g}",
                "sort the rows by relative position, most distal (0) first",
            )
    # Turning back (angle between consecutive segments) means the rows are out of order.
    outliers: tuple[int, ...] = ()
    if n >= 3:
        turn = turn_angles_deg(pts)
        bad = np.flatnonzero(turn > TURN_BACK_DEG)
        if rel is not None and kind == "path":  # sparse positions turn by the arc between them
            gap = np.diff(rel)
            bad = bad[(gap[bad] <= TURN_CHECK_GAP_MM) & (gap[bad + 1] <= TURN_CHECK_GAP_MM)]
        if bad.size and kind == "path":
            outliers = single_outliers(pts, bad)
            if outliers:
                bad = np.array([], dtype=int)
        if bad.size:
            k = int(bad[0]) + 1
            raise PointsFileError(
                p,
                f"the {name} turns back by {turn[k - 1]:.0f} degrees at {labels[k]}: the points "
                "are not in order along the channel",
                "sort the rows along the channel ("
                + ("most distal first" if kind == "path" else "proximal entry -> distal tip")
                + ")",
            )
    # Any two non-consecutive points coinciding (a loop through itself) is also a duplicate.
    from scipy.spatial import cKDTree

    pairs = cKDTree(pts).query_pairs(DUPLICATE_TOL_MM)
    if pairs:
        i, j = sorted(min(pairs))
        raise PointsFileError(
            p, f"{labels[j]} repeats the point of {labels[i]}", "remove duplicated points"
        )
    if kind == "centreline":
        length = float(steps.sum())
        lo, hi = CENTRELINE_LENGTH_MM
        if length < lo:
            raise PointsFileError(
                p,
                f"the centreline is only {length:.4g} mm long (an applicator channel is "
                f"{lo:g}-{hi:g} mm): this looks like centimetres",
                "write coordinates in millimetres (centimetres: multiply by 10)",
            )
        if length > hi:
            raise PointsFileError(
                p,
                f"the centreline is {length:.6g} mm long (an applicator channel is "
                f"{lo:g}-{hi:g} mm): this looks like micrometres or another unit",
                "write coordinates in millimetres (micrometres: divide by 1000)",
            )
    return outliers


def turn_angles_deg(pts: np.ndarray) -> np.ndarray:
    """(n-2,) angle (deg) between consecutive segments of (n, 3) points, at points 1..n-2."""
    d = np.diff(pts, axis=0)
    length = np.linalg.norm(d, axis=1)
    cosang = np.einsum("ij,ij->i", d[:-1], d[1:]) / (length[:-1] * length[1:])
    return np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))


def single_outliers(pts: np.ndarray, bad_turns: np.ndarray) -> tuple[int, ...]:
    """The rows that explain every turn-back of ``bad_turns`` (indices into
    :func:`turn_angles_deg`) as single points off the path: a row k such that its neighbours'
    path without it does not turn back, and k projects between its neighbours (a jump sideways,
    not a row swapped along the path). Empty when the turn-backs are not all explained so (the
    rows are then out of order).
    """
    n = len(pts)
    found: set[int] = set()
    for b in bad_turns:
        vertex = int(b) + 1
        cands = [k for k in (vertex, vertex - 1, vertex + 1) if 0 < k < n - 1]
        hit = None
        for k in cands:
            a, c = pts[k - 1], pts[k + 1]
            seg = c - a
            t = float(np.dot(pts[k] - a, seg) / max(float(np.dot(seg, seg)), 1e-30))
            if not 0.0 <= t <= 1.0:
                continue
            lo, hi = max(0, k - 2), min(n, k + 3)
            rest = np.delete(pts[lo:hi], k - lo, axis=0)
            if len(rest) < 3 or not np.any(turn_angles_deg(rest) > TURN_BACK_DEG):
                hit = k
                break
        if hit is None:
            return ()
        found.add(hit)
    rows = sorted(found)
    if np.any(np.diff(rows) < 2):
        return ()  # two outliers side by side are not "single": the rows may be out of order
    return tuple(rows)
