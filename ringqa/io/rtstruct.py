"""Channel centrelines from a DICOM RT Structure Set (Eclipse/BrachyVision and others).

Planning systems that keep no applicator library store each reconstructed channel as an ROI with
an OPEN contour (``ContourGeometricType`` ``OPEN_NONPLANAR`` or ``OPEN_PLANAR``: "tandem", "left
ovoid", "Applicator1", ...). :func:`applicator_from_structures` turns them into the plan's
channels:

1. The structure set must be the one the plan references (``ReferencedStructureSetSequence``):
   another SOP instance is refused, naming both UIDs. A plan that references none is accepted
   with a note.
2. Each plan channel with dwells is matched to the ROI whose open contour passes within
   :data:`MATCH_TOLERANCE_MM` of ALL its dwells (point-to-polyline distance). No such ROI, two
   such ROIs, or one ROI matched by two channels is refused, naming the channel and the ROIs
   (with their largest dwell distances). The match and its largest dwell-to-contour distance are
   reported (:attr:`ChannelMatch.max_distance_mm`).
3. The contour becomes the centreline, ordered PROXIMAL -> DISTAL: the distal end is the end the
   dwells lie nearer to (a catheter's contour runs from the tip out of the patient; its dwells
   sit in the distal part). Relative position 0 is the most distal dwell (``s_ref`` = its arc
   length on the contour).
4. The lumen is circular: ``lumen_mm`` when given (``--lumen-mm``), else the per-applicator table
   :data:`LUMEN_TABLE` (``data/applicators/lumen_table.csv``, each row with its source) matched by
   the channel's ROI name or the plan's ``SourceApplicatorID``; a channel with neither is refused
   (the report says which diameter came from where: ``metadata["lumen_sources"]``).
5. Unevenly spaced contours are evened out before the centreline is fitted
   (:func:`even_points_mm`): Eclipse/BrachyVision applicator models hold a point 0.15 mm from
   the tip and straight runs of 20-70 mm between 1.5-4 mm spaced bends, which an interpolating
   spline through the points alone cannot follow. A point closer than :data:`MERGE_FRACTION` x
   the median spacing to the previous one is merged into it, and a straight segment longer than
   :data:`SPLIT_FRACTION` x the median spacing is divided evenly; the report notes both.
6. Every channel passes the shared shape checks (bends tighter than the lumen radius,
   self-intersection: :func:`ringqa.geometry.shape_checks.check_channel_shape`) and has at
   least :data:`MIN_CONTOUR_POINTS` points.
7. Families: a channel named like a tandem or an ovoid is one; any other is ``free-form``. With a
   tandem the applicator's frame is :func:`ringqa.geometry.families.tandem_frame` (the ovoids
   left/right by name, else by the DICOM +x side), else fitted to the channels.
"""

from __future__ import annotations

import csv
import itertools
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ringqa.errors import InputFileError
from ringqa.geometry import Applicator, Centreline, Channel, GeometryError, Lumen
from ringqa.geometry.families import family_name_of, tandem_frame
from ringqa.geometry.shape_checks import check_channel_shape
from ringqa.units import mm_to_m

__all__ = [
    "LUMEN_TABLE",
    "MATCH_TOLERANCE_MM",
    "MIN_CONTOUR_POINTS",
    "ChannelMatch",
    "StructureContour",
    "StructureSet",
    "StructuresApplicator",
    "applicator_from_structures",
    "even_points_mm",
    "match_channels",
    "oriented_points_mm",
    "read_rtstruct",
]

RT_STRUCT = "1.2.840.10008.5.1.4.1.1.481.3"
#: A dwell lies on a contour within this distance (mm): a source centre lies within a lumen
#: radius (~1-2 mm) of the channel's centreline, plus the reconstruction's spacing.
MATCH_TOLERANCE_MM = 2.0
#: Fewest points of a channel's contour.
MIN_CONTOUR_POINTS = 4
#: The per-applicator lumen table (``name_pattern,lumen_mm,source``; the pattern a
#: case-insensitive regular expression on the ROI name or the plan's SourceApplicatorID).
LUMEN_TABLE = "applicators/lumen_table.csv"
OPEN_TYPES = ("OPEN_NONPLANAR", "OPEN_PLANAR")
#: A contour point closer than this fraction of the median point spacing to the previous point
#: is merged into it (:func:`even_points_mm`).
MERGE_FRACTION = 0.2
#: A contour segment longer than this multiple of the median spacing is divided evenly.
SPLIT_FRACTION = 1.5
#: The spacing (mm) :func:`even_points_mm` works with is never below this (a contour of mostly
#: near-duplicate points is not divided into thousands of pieces).
MIN_EVEN_SPACING_MM = 0.5


class RTStructError(InputFileError):
    """An RT Structure Set cannot be used (names the file, the element and the fix)."""


@dataclass(frozen=True, eq=False)
class StructureContour:
    """One ROI's open contour.

    Attributes
    ----------
    roi_number : int
    roi_name : str
    points_mm : (n, 3) ndarray
        In file order, patient coordinates (mm).
    """

    roi_number: int
    roi_name: str
    points_mm: np.ndarray


@dataclass(frozen=True, eq=False)
class StructureSet:
    """The open contours of an RT Structure Set.

    Attributes
    ----------
    path : str
    sop_instance_uid : str
    contours : tuple of StructureContour
        One per ROI with an open contour (its longest, when it has several).
    notes : tuple of str
    """

    path: str
    sop_instance_uid: str
    contours: tuple[StructureContour, ...]
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class ChannelMatch:
    """A plan channel matched to an ROI.

    Attributes
    ----------
    channel : int
        The plan's ``ChannelNumber``.
    roi_name : str
    max_distance_mm : float
        Largest distance of the channel's dwells from the contour (mm).
    n_dwells : int
    """

    channel: int
    roi_name: str
    max_distance_mm: float
    n_dwells: int


@dataclass(frozen=True, eq=False)
class StructuresApplicator:
    """What :func:`applicator_from_structures` built.

    Attributes
    ----------
    applicator : Applicator
    matches : tuple of ChannelMatch
    notes : tuple of str
        For the report: the match of each channel, where each lumen comes from, the reference.
    """

    applicator: Applicator
    matches: tuple[ChannelMatch, ...]
    notes: tuple[str, ...]


def read_rtstruct(path) -> StructureSet:
    """Read the open contours of an RT Structure Set.

    Raises
    ------
    RTStructError
        Missing file, not DICOM, not an RT Structure Set, or no open contour.
    """
    p = Path(path)
    if not p.is_file():
        raise RTStructError(p, "file not found", "check the --structures path")
    import pydicom
    from pydicom.errors import InvalidDicomError

    try:
        ds = pydicom.dcmread(p, stop_before_pixels=True)
    except (InvalidDicomError, OSError, ValueError) as exc:
        raise RTStructError(
            p,
            f"not a readable DICOM file ({exc})",
            "export the RT Structure Set (RS*.dcm) from the planning system",
        ) from None
    if str(ds.get("SOPClassUID", "")) != RT_STRUCT and ds.get("Modality") != "RTSTRUCT":
        raise RTStructError(
            p,
            f"is not an RT Structure Set (Modality {ds.get('Modality')!r})",
            "give the RS*.dcm file with --structures",
        )
    names = {
        int(r.ROINumber): str(r.get("ROIName", f"ROI {r.ROINumber}"))
        for r in ds.get("StructureSetROISequence", [])
    }
    contours, notes = [], []
    for roi in ds.get("ROIContourSequence", []):
        number = int(roi.get("ReferencedROINumber", -1))
        name = names.get(number, f"ROI {number}")
        open_ = []
        for c in roi.get("ContourSequence", []):
            if str(c.get("ContourGeometricType", "")) not in OPEN_TYPES:
                continue
            data = np.asarray([float(v) for v in c.get("ContourData", [])], dtype=float)
            if data.size % 3 or not np.isfinite(data).all():
                raise RTStructError(
                    p,
                    f"ROI {name!r}: ContourData is not finite (x, y, z) triples",
                    "export the structure set again",
                )
            open_.append(data.reshape(-1, 3))
        if not open_:
            continue
        longest = max(open_, key=len)
        if len(open_) > 1:
            notes.append(
                f"ROI {name!r} has {len(open_)} open contours: the longest "
                f"({len(longest)} points) is its channel."
            )
        contours.append(StructureContour(number, name, longest))
    if not contours:
        raise RTStructError(
            p,
            "has no OPEN_NONPLANAR/OPEN_PLANAR contour (no reconstructed channel)",
            "export the structure set with the applicator channels reconstructed",
        )
    return StructureSet(str(p), str(ds.get("SOPInstanceUID", "")), tuple(contours), tuple(notes))


def polyline_distance_mm(points_mm, polyline_mm) -> np.ndarray:
    """Distance (mm) of each point from a polyline (its segments), (n,)."""
    p = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    a = np.asarray(polyline_mm, dtype=float)[:-1]
    b = np.asarray(polyline_mm, dtype=float)[1:]
    ab = b - a
    L2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    t = np.clip(np.einsum("kij,ij->ki", p[:, None, :] - a[None], ab) / L2, 0.0, 1.0)
    q = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(p[:, None, :] - q, axis=2).min(axis=1)


def check_referenced(plan, structures: StructureSet) -> str:
    """Refuse a structure set the plan does not reference; return a note.

    Raises
    ------
    RTStructError
        The plan's ReferencedStructureSetSequence names another SOP instance (both UIDs named).
    """
    import pydicom

    ds = pydicom.dcmread(plan.path, stop_before_pixels=True)
    refs = [
        str(r.get("ReferencedSOPInstanceUID", ""))
        for r in ds.get("ReferencedStructureSetSequence", [])
    ]
    if not refs:
        return (
            "The RT Plan references no structure set: the structure set given was used as "
            "is (its dwells lie on the matched contours)."
        )
    if structures.sop_instance_uid not in refs:
        raise RTStructError(
            structures.path,
            f"is SOP instance {structures.sop_instance_uid}, but the RT Plan {Path(plan.path).name}"
            f" references the structure set {', '.join(refs)}",
            "give the RT Structure Set the plan was made on",
        )
    return f"Structure set {structures.sop_instance_uid}: the one the RT Plan references."


def match_channels(plan, structures: StructureSet, tolerance_mm: float = MATCH_TOLERANCE_MM):
    """Match every plan channel with dwells to the one ROI its dwells lie on (module docstring).

    Returns
    -------
    tuple of ChannelMatch

    Raises
    ------
    RTStructError
        A channel matching no ROI or several, or an ROI matched by two channels.
    """
    out = []
    for ch in plan.channels:
        pos = np.asarray(ch.positions_mm, dtype=float).reshape(-1, 3)
        if not len(pos):
            continue
        dist = {
            c.roi_name: float(polyline_distance_mm(pos, c.points_mm).max())
            for c in structures.contours
        }
        near = [n for n, d in dist.items() if d <= tolerance_mm]
        listed = ", ".join(
            f"{n!r} ({d:.1f} mm)" for n, d in sorted(dist.items(), key=lambda kv: kv[1])
        )
        if not near:
            raise RTStructError(
                structures.path,
                f"no open contour passes within {tolerance_mm:g} mm of every dwell of channel "
                f"{ch.number} ({ch.name}); largest dwell distances: {listed}",
                "give the structure set with this channel reconstructed (or the plan it belongs "
                "to)",
            )
        if len(near) > 1:
            raise RTStructError(
                structures.path,
                f"channel {ch.number} ({ch.name}) lies on several contours: {listed}",
                "remove the duplicate channel ROIs from the structure set",
            )
        out.append(ChannelMatch(int(ch.number), near[0], dist[near[0]], len(pos)))
    seen: dict[str, int] = {}
    for m in out:
        if m.roi_name in seen:
            raise RTStructError(
                structures.path,
                f"ROI {m.roi_name!r} matches both channel {seen[m.roi_name]} and channel "
                f"{m.channel}",
                "check the plan's channels against the structure set's ROIs",
            )
        seen[m.roi_name] = m.channel
    return tuple(out)


def oriented_points_mm(points_mm, dwells_mm) -> np.ndarray:
    """A channel contour's points ordered PROXIMAL -> DISTAL: reversed when its dwells lie
    nearer its first point than its last (by their mean arc length along the polyline), (n, 3)."""
    pts = np.asarray(points_mm, dtype=float)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s_pts = np.concatenate([[0.0], np.cumsum(seg)])
    d = np.linalg.norm(np.asarray(dwells_mm, float).reshape(-1, 3)[:, None, :] - pts[None], axis=2)
    s_dwells = s_pts[np.argmin(d, axis=1)]
    return pts[::-1].copy() if float(np.mean(s_dwells)) < 0.5 * s_pts[-1] else pts.copy()


def even_points_mm(points_mm) -> tuple[np.ndarray, str]:
    """A channel contour's points evened out for an interpolating spline (module docstring, 5).

    With ``h`` the median spacing of consecutive points (at least
    :data:`MIN_EVEN_SPACING_MM`): a point closer than
    :data:`MERGE_FRACTION` ``* h`` to the last kept point is dropped (the last point replaces the
    kept one, so both ends stay), and a segment longer than :data:`SPLIT_FRACTION` ``* h`` is
    divided into ``round(length / h)`` equal straight pieces. The polyline's shape is unchanged
    (merged points lie within ``MERGE_FRACTION * h`` of it; added points lie on it); an evenly
    spaced contour is returned as it is.

    Parameters
    ----------
    points_mm : (n, 3) array_like
        Contour points (mm), in order.

    Returns
    -------
    points_mm : (m, 3) ndarray
    note : str
        What was changed ("" when nothing).
    """
    pts = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    if len(pts) < 3:
        return pts.copy(), ""
    h = max(float(np.median(np.linalg.norm(np.diff(pts, axis=0), axis=1))), MIN_EVEN_SPACING_MM)
    keep = [0]
    for i in range(1, len(pts)):
        if np.linalg.norm(pts[i] - pts[keep[-1]]) < MERGE_FRACTION * h:
            if i == len(pts) - 1 and len(keep) > 1:
                keep[-1] = i
            continue
        keep.append(i)
    kept = pts[keep]
    out, n_split = [kept[:1]], 0
    for a, b in itertools.pairwise(kept):
        length = float(np.linalg.norm(b - a))
        n = max(round(length / h), 1) if length > SPLIT_FRACTION * h else 1
        n_split += n > 1
        piece = a + (b - a) * (np.arange(1, n + 1)[:, None] / n)
        piece[-1] = b  # the contour's own point, exactly
        out.append(piece)
    merged = len(pts) - len(kept)
    if not merged and not n_split:
        return pts.copy(), ""
    even = np.concatenate(out)
    note = (
        f"{len(pts)} points, median spacing {h:.2f} mm (at least {MIN_EVEN_SPACING_MM:g}): "
        f"{merged} point(s) closer than "
        f"{MERGE_FRACTION * h:.2f} mm merged, {n_split} straight segment(s) longer than "
        f"{SPLIT_FRACTION * h:.2f} mm divided ({len(even)} points fitted)"
    )
    return even, note


def lumen_table(path=None) -> list[tuple[re.Pattern, float, str]]:
    """The per-applicator lumen table: (pattern, lumen diameter mm, source) rows."""
    if path is None:
        from ringqa.paths import data_dir

        path = data_dir() / LUMEN_TABLE
    rows = []
    with open(path, encoding="utf-8-sig", newline="") as fh:
        for row in csv.DictReader(line for line in fh if not line.startswith("#")):
            rows.append(
                (re.compile(row["name_pattern"], re.I), float(row["lumen_mm"]), row["source"])
            )
    return rows


def _lumen_for(roi: str, applicator_id: str, lumen_mm, table, where) -> tuple[float, str]:
    if lumen_mm is not None:
        return float(lumen_mm), "given (--lumen-mm / simulation.lumen_mm)"
    for pattern, dia, source in table:
        if pattern.search(roi) or (applicator_id and pattern.search(applicator_id)):
            return dia, f"lumen table ({source})"
    raise RTStructError(
        where,
        f"no published lumen diameter for channel ROI {roi!r} (applicator ID "
        f"{applicator_id or 'none'}) in data/{LUMEN_TABLE}",
        "give the lumen diameter: ringqa commission ... --lumen-mm D",
    )


def applicator_from_structures(plan, structures: StructureSet, *, lumen_mm=None, table=None):
    """The plan's channels from the structure set (see the module docstring).

    Parameters
    ----------
    plan : RTPlan
    structures : StructureSet
    lumen_mm : float, optional
        Every channel's lumen diameter (mm); default: the lumen table.
    table : list, optional
        :func:`lumen_table` rows (default: the shipped table).

    Returns
    -------
    StructuresApplicator

    Raises
    ------
    RTStructError
        Not the referenced structure set, a bad match, a contour too short or bent tighter than
        its lumen, no lumen.
    """
    ref_note = check_referenced(plan, structures)
    matches = match_channels(plan, structures)
    by_name = {c.roi_name: c for c in structures.contours}
    table = lumen_table() if table is None and lumen_mm is None else (table or [])
    channels, notes, sources = [], [ref_note, *structures.notes], {}
    for m in matches:
        contour = by_name[m.roi_name]
        where = f"{structures.path} (ROI {m.roi_name!r}, channel {m.channel})"
        pts = contour.points_mm
        if len(pts) < MIN_CONTOUR_POINTS:
            raise RTStructError(
                structures.path,
                f"ROI {m.roi_name!r} (channel {m.channel}) "
                f"has {len(pts)} points; a channel needs at least "
                f"{MIN_CONTOUR_POINTS}",
                "reconstruct the channel with more points",
            )
        pch = plan.channel(m.channel)
        dwells = np.asarray(pch.positions_mm, dtype=float).reshape(-1, 3)
        fit_mm, even_note = even_points_mm(oriented_points_mm(pts, dwells))
        try:
            cl = Centreline.from_points(mm_to_m(fit_mm))
            s, _ = cl.closest(mm_to_m(dwells))
            dia, src = _lumen_for(m.roi_name, pch.applicator_id, lumen_mm, table, where)
            r_b = mm_to_m(dia) / 2
            lumen = Lumen.circular(r_b, r_b - mm_to_m(0.1))
            family = family_name_of(_FREE_FORM_APP, _Named(m.roi_name))
            ch = Channel(
                m.roi_name, cl, lumen, float(np.max(s)), family=family, label=str(m.channel)
            )
            check_channel_shape(ch, where)
        except GeometryError as exc:
            raise RTStructError(
                structures.path,
                f"ROI {m.roi_name!r} (channel {m.channel}): {exc}",
                "check the reconstruction of this channel",
            ) from None
        channels.append(ch)
        sources[m.roi_name] = f"{dia:g} mm: {src}"
        notes.append(
            f"Channel {m.channel} = ROI {m.roi_name!r} ({family}): {m.n_dwells} dwells, the "
            f"farthest {m.max_distance_mm:.2f} mm from the contour; lumen {dia:g} mm ({src})."
            + (f" Contour evened out: {even_note}." if even_note else "")
        )
    frame = _frame(channels)
    name = plan.plan_label or Path(plan.path).stem
    app = Applicator(
        name=name,
        channels=tuple(channels),
        metadata={"lumen_sources": sources, "structure_set": structures.path},
        family="tandem" if any(c.family == "tandem" for c in channels) else "free-form",
        **frame,
    )
    return StructuresApplicator(app, matches, tuple(notes))


@dataclass(frozen=True)
class _Named:
    """A channel name alone (for :func:`~ringqa.geometry.families.family_name_of`)."""

    name: str
    family: str = ""


@dataclass(frozen=True)
class _FreeFormApp:
    """An applicator whose unnamed channels are free-form."""

    family: str = "free-form"


_FREE_FORM_APP = _FreeFormApp()


def _frame(channels) -> dict:
    """The frame fields: a tandem's (:func:`tandem_frame`) when there is one, else none (fitted
    by the Applicator)."""
    tandems = [c for c in channels if c.family == "tandem"]
    if not tandems:
        return {}
    others = [c for c in channels if c.family == "ovoid"]
    left = [c for c in others if re.search(r"\bl(eft)?\b|_l\b|left", c.name, re.I)]
    right = [c for c in others if re.search(r"\br(ight)?\b|_r\b|right", c.name, re.I)]
    if len(others) == 2 and not (len(left) == 1 and len(right) == 1):
        tips = [float(c.centreline.position(c.s_ref_m)[0]) for c in others]
        left, right = (
            ([others[0]], [others[1]]) if tips[0] > tips[1] else ([others[1]], [others[0]])
        )
    f = tandem_frame(
        tandems[0],
        others,
        left[0] if len(left) == 1 else None,
        right[0] if len(right) == 1 else None,
    )
    return {
        "ring_centre_m": f.centre_m,
        "ring_normal": f.normal,
        "ring_lateral": f.lateral,
        "ring_radius_m": f.scale_m,
    }
