"""Centreline and source-path points: CSV and JSON files in millimetres, metres inside.

Formats (both documented in ``docs/importers.md``):

CSV
    A header row with the columns ``x_mm, y_mm, z_mm`` (any order, extra columns ignored) and
    optionally ``relative_position_mm``. Blank lines and lines starting with ``#`` are skipped.
    Separator: comma (else ``;`` or tab, as found in the header); decimal point ``.``.
    Encoding: UTF-8 (with or without BOM), UTF-16 with its BOM, else Latin-1 (a German Excel's
    comment); :attr:`PointSet.encoding` records it, :attr:`PointSet.notes` says when not UTF-8.
JSON
    ``{"units": "mm", "points": [[x, y, z], ...], "relative_position_mm": [...]}`` (the last key
    optional), or the column form ``{"x_mm": [...], "y_mm": [...], "z_mm": [...]}``.

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
        Things the caller should show the user (e.g. the Latin-1 fallback); empty when the file
        was plain UTF-8.
    """

    points_m: np.ndarray
    relative_position_mm: np.ndarray | None
    kind: str
    path: str
    labels: tuple[str, ...] = ()
    encoding: str = "UTF-8"
    notes: tuple[str, ...] = ()


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
    if suffix == ".csv":
        text, encoding = read_text_any(p)
        _check_line_count(p, text, kind)
        pts, rel, labels = _read_csv(p, text)
    elif suffix == ".json":
        pts, rel, labels = _read_json(p)
    else:
        raise PointsFileError(
            p, f"unknown file type {p.suffix!r}", "use a .csv (x_mm,y_mm,z_mm) or .json file"
        )
    check_points(p, pts, rel, labels, kind)
    notes = ()
    if encoding in ("Latin-1", "UTF-16"):
        notes = (
            f"{p.name}: not UTF-8, read as {encoding}; the numbers are unaffected, but check any "
            "non-ASCII text (comments, labels) and save the file as UTF-8 to silence this note",
        )
    return PointSet(
        points_m=np.ascontiguousarray(mm_to_m(pts)),
        relative_position_mm=None if rel is None else np.ascontiguousarray(rel),
        kind=kind,
        path=str(p),
        labels=tuple(labels),
        encoding=encoding,
        notes=notes,
    )


def _check_line_count(p: Path, text: str, kind: str) -> None:
    """Refuse a CSV with more data rows than a centreline or path may have before parsing it
    (issue 25: a 10^6-row file took 10 s and 800 MB to parse before any check)."""
    if text.count("\n") <= MAX_POINTS:
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


def _read_csv(p: Path, text: str) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
    if "\x00" in text:
        raise PointsFileError(p, "contains NUL bytes: not a text (CSV) file", "save it as a CSV")
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
    rel = values[:, 3].copy() if len(wanted) == 4 else None
    return values[:, :3].copy(), rel, labels


def _read_json(p: Path) -> tuple[np.ndarray, np.ndarray | None, list[str]]:
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
    return values, rel, labels


def _json_number(p: Path, where: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise PointsFileError(p, f"{where} is {v!r}, not a number", "give numbers in mm")
    if not math.isfinite(v):
        raise PointsFileError(p, f"{where} is {v}", "give a finite number")
    return float(v)


# --------------------------------------------------------------------------------------------
# checks


def check_points(p, pts: np.ndarray, rel: np.ndarray | None, labels, kind: str) -> None:
    """Refuse points (mm, file order) that cannot be what ``kind`` says: too few, in another unit
    (metres, centimetres, micrometres, a huge offset), duplicated or out of order.

    ``p`` names the file in messages, ``labels`` each point (``"line 7"``); used for CSV and
    JSON point files and for points given inline in an applicator file.
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
    if n >= 3:
        a, b = np.diff(pts, axis=0)[:-1], np.diff(pts, axis=0)[1:]
        cosang = np.einsum("ij,ij->i", a, b) / (steps[:-1] * steps[1:])
        turn = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
        bad = np.flatnonzero(turn > TURN_BACK_DEG)
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
